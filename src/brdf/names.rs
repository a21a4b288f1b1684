//! The names a GLSL text declares at global scope, read from its tokens (`lex.rs`): what lobe's
//! kernels declare (so that a `.brdf` shader's names cannot clash with them) and whether a
//! shader's `BRDF` uses its tangent arguments.

use super::lex::{tokens, Tok};
use std::collections::BTreeSet;

/// Qualifiers that can stand where a declared name would (`layout(...) in;`).
const KEYWORDS: &[&str] = &[
    "in",
    "out",
    "inout",
    "uniform",
    "buffer",
    "shared",
    "const",
    "readonly",
    "writeonly",
    "coherent",
    "volatile",
    "restrict",
    "struct",
    "precision",
    "highp",
    "mediump",
    "lowp",
    "flat",
    "smooth",
    "layout",
    "return",
];

/// The names declared at global scope: functions, constants, variables, structs, blocks and
/// their instances, and the members of a block without an instance name (which are global).
pub fn declared(tokens: &[Tok<'_>]) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut i = 0;
    while i < tokens.len() {
        let (mut brace, mut paren) = (0i32, 0i32);
        let mut end = tokens.len();
        for (j, t) in tokens.iter().enumerate().skip(i) {
            match t {
                Tok::Punct(b'{') => brace += 1,
                Tok::Punct(b'(') => paren += 1,
                Tok::Punct(b')') => paren -= 1,
                Tok::Punct(b'}') => {
                    brace -= 1;
                    if brace == 0 && is_function(&tokens[i..j]) {
                        end = j + 1;
                        break;
                    }
                }
                Tok::Punct(b';') if brace == 0 && paren == 0 => {
                    end = j + 1;
                    break;
                }
                _ => {}
            }
        }
        statement(&tokens[i..end], &mut out);
        i = end;
    }
    out
}

/// Whether a statement's first top-level `{` follows a `)`: a function definition.
fn is_function(s: &[Tok<'_>]) -> bool {
    let mut paren = 0;
    for (k, t) in s.iter().enumerate() {
        match t {
            Tok::Punct(b'(') => paren += 1,
            Tok::Punct(b')') => paren -= 1,
            Tok::Punct(b'{') if paren == 0 => {
                return k > 0 && s[k - 1] == Tok::Punct(b')');
            }
            _ => {}
        }
    }
    false
}

fn statement(mut s: &[Tok<'_>], out: &mut BTreeSet<String>) {
    // layout(...) qualifiers hold `name = value` pairs that declare nothing.
    while let [Tok::Ident("layout"), Tok::Punct(b'('), rest @ ..] = s {
        let close = rest.iter().position(|t| *t == Tok::Punct(b')'));
        s = close.map_or(&[][..], |c| &rest[c + 1..]);
    }
    let open = s.iter().position(|t| *t == Tok::Punct(b'{'));
    let head = &s[..open.unwrap_or(s.len())];
    let block = head
        .iter()
        .any(|t| matches!(t, Tok::Ident("buffer" | "uniform" | "in" | "out")));
    let close = s.iter().rposition(|t| *t == Tok::Punct(b'}'));
    let instance_less = block && close.is_some_and(|c| s.get(c + 1) == Some(&Tok::Punct(b';')));
    let (mut brace, mut paren, mut initializer) = (0, 0, false);
    for (k, t) in s.iter().enumerate() {
        match *t {
            Tok::Punct(b'{') => brace += 1,
            Tok::Punct(b'}') => brace -= 1,
            Tok::Punct(b'(') => paren += 1,
            Tok::Punct(b')') => paren -= 1,
            Tok::Punct(b'=') if brace == 0 && paren == 0 => initializer = true,
            Tok::Punct(b',' | b';') if brace == 0 && paren == 0 => initializer = false,
            Tok::Ident(name) => {
                let next = s.get(k + 1).copied();
                let at_top = brace == 0 && paren == 0 && !initializer;
                let declares = matches!(
                    next,
                    Some(Tok::Punct(b'(' | b'=' | b';' | b'[' | b',' | b'{'))
                );
                let member = instance_less
                    && brace == 1
                    && paren == 0
                    && matches!(next, Some(Tok::Punct(b';' | b'[')));
                if ((at_top && declares) || member) && !KEYWORDS.contains(&name) {
                    out.insert(name.to_string());
                }
            }
            _ => {}
        }
    }
}

/// Whether the shader defines `BRDF` with five parameters and its body never names the fourth
/// and fifth (X and Y, the tangents): false when it does, or when there is no such definition.
pub fn unused_tangents(shader: &str) -> bool {
    let (t, _) = tokens(shader);
    let starts = (0..t.len().saturating_sub(1))
        .filter(|&k| t[k] == Tok::Ident("BRDF") && t[k + 1] == Tok::Punct(b'('));
    for start in starts {
        // The parameter list: the last identifier before each ',' or the closing ')'.
        let mut names = Vec::new();
        let mut k = start + 2;
        let mut last = None;
        while let Some(&tok) = t.get(k) {
            k += 1;
            match tok {
                Tok::Ident(n) => last = Some(n),
                Tok::Punct(b',') => names.extend(last.take()),
                Tok::Punct(b')') => {
                    names.extend(last.take());
                    break;
                }
                _ => {}
            }
        }
        if names.len() != 5 || t.get(k) != Some(&Tok::Punct(b'{')) {
            continue; // a prototype or a call
        }
        let mut depth = 0;
        for &tok in &t[k..] {
            match tok {
                Tok::Punct(b'{') => depth += 1,
                Tok::Punct(b'}') => {
                    depth -= 1;
                    if depth == 0 {
                        return true;
                    }
                }
                Tok::Ident(n) if n == names[3] || n == names[4] => return false,
                _ => {}
            }
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tangent_use_is_seen() {
        let iso = "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return vec3(dot(N, L)); }";
        assert!(unused_tangents(iso));
        let aniso = "float f(vec3 a) { return a.x; }\nvec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 T, vec3 B)\n{ return vec3(f(T)); }";
        assert!(!unused_tangents(aniso));
        assert!(!unused_tangents("vec3 BRDF(vec3 L, vec3 V, vec3 N);"));
        assert!(!unused_tangents(
            "vec3 brdf(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return L; }"
        ));
    }
}
