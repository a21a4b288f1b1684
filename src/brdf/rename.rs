//! The file's own functions under names of their own.
//!
//! Desktop GLSL before 4.x let a shader's function hide every built-in of its name, and BRDF
//! Explorer files rely on it (`vec3 reflect(vec3 I, vec3 N)`, `float mix(float a, float b)`);
//! GLSL 4.50 takes such a definition as an overload of the built-in and refuses it. So every
//! function the shader declares or defines at global scope, except `BRDF` (which lobe calls),
//! is renamed with [`USER_FN`] before compiling, and so is every use of that name in the shader
//! (macro bodies included, members after `.` not). Only identifiers change, never line breaks,
//! so compiler messages keep the file's line numbers; the prefix is taken out of messages again.

use super::lex::{lex, tokens, Tok};
use std::collections::BTreeSet;

/// The prefix of a renamed function of the file.
pub(super) const USER_FN: &str = "lobe_fn_";

/// The function lobe calls, which keeps its name.
const ENTRY: &str = "BRDF";

/// The names of the functions `shader` declares or defines at global scope, except `BRDF`.
pub(super) fn user_functions(shader: &str) -> BTreeSet<&str> {
    let (t, _) = tokens(shader);
    let mut out = BTreeSet::new();
    let (mut brace, mut paren, mut initializer) = (0i32, 0i32, false);
    for (k, tok) in t.iter().enumerate() {
        match *tok {
            Tok::Punct(b'{') => brace += 1,
            Tok::Punct(b'}') => brace -= 1,
            Tok::Punct(b'(') => paren += 1,
            Tok::Punct(b')') => paren -= 1,
            Tok::Punct(b'=') if brace == 0 && paren == 0 => initializer = true,
            Tok::Punct(b';') if brace == 0 && paren == 0 => initializer = false,
            Tok::Ident(name) if brace == 0 && paren == 0 && !initializer => {
                // `TYPE name(` or `TYPE[N] name(`: a prototype or a definition.
                let call = t.get(k + 1) == Some(&Tok::Punct(b'('));
                let after_type = k > 0 && matches!(t[k - 1], Tok::Ident(ty) if ty != "layout")
                    || k > 0 && t[k - 1] == Tok::Punct(b']');
                if call && after_type && name != ENTRY && name != "layout" {
                    out.insert(name);
                }
            }
            _ => {}
        }
    }
    out
}

/// `shader` with each of its functions ([`user_functions`]) renamed to `lobe_fn_NAME`.
pub(super) fn rename_functions(shader: &str) -> String {
    let names = user_functions(shader);
    if names.is_empty() {
        return shader.to_string();
    }
    let lexemes = lex(shader);
    let mut out = String::with_capacity(shader.len() + 64);
    let mut copied = 0;
    // Brace depth, and the depth a struct's body opened at: its members are not functions.
    let (mut depth, mut struct_body, mut after_struct) = (0i32, None, false);
    for (k, l) in lexemes.iter().enumerate() {
        let name = match l.tok {
            Tok::Ident(name) => name,
            Tok::Punct(b'{') if !l.directive => {
                if std::mem::take(&mut after_struct) && struct_body.is_none() {
                    struct_body = Some(depth);
                }
                depth += 1;
                continue;
            }
            Tok::Punct(b'}') if !l.directive => {
                depth -= 1;
                if struct_body == Some(depth) {
                    struct_body = None;
                }
                continue;
            }
            _ => continue,
        };
        after_struct |= name == "struct" && !l.directive;
        let previous = k.checked_sub(1).map(|p| lexemes[p].tok);
        // A member (`s.reflect`) and a directive's own word (`#define`) are not the function.
        let member = previous == Some(Tok::Punct(b'.')) || struct_body.is_some();
        let directive_word = l.directive && previous == Some(Tok::Punct(b'#'));
        if names.contains(name) && !member && !directive_word {
            out.push_str(&shader[copied..l.at]);
            out.push_str(USER_FN);
            out.push_str(name);
            copied = l.at + name.len();
        }
    }
    out.push_str(&shader[copied..]);
    out
}

/// A compiler message or SPIR-V name with the file's function names as the file writes them.
pub(super) fn original_names(text: &str) -> String {
    text.replace(USER_FN, "")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn functions_at_global_scope_are_found() {
        let shader = "const vec3 c = vec3(1.0);\nvec3 reflect(vec3 I, vec3 N);\nfloat[2] pair(float a) { return float[2](a, a); }\nhighp float mix(float a, float b) { return a; }\nlayout(std430, binding = 9) buffer B { float m[]; };\nvec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return reflect(L, N) * mix(1.0, 2.0); }\nvec3 reflect(vec3 I, vec3 N) { return -I; }\n";
        let names: Vec<_> = user_functions(shader).into_iter().collect();
        assert_eq!(names, ["mix", "pair", "reflect"]);
    }

    #[test]
    fn every_use_is_renamed_and_nothing_else() {
        let shader = "// reflect in a comment\n#define R(a, b) reflect(a, b)\nstruct S { float reflect; };\nvec3 reflect(vec3 I, vec3 N) { return I; }\n/* reflect */ vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) {\n  S s; return R(L, N) * s.reflect + reflect(V, N);\n}\n";
        let renamed = rename_functions(shader);
        assert_eq!(
            renamed,
            shader
                .replace("b) reflect(", "b) lobe_fn_reflect(")
                .replace("vec3 reflect(", "vec3 lobe_fn_reflect(")
                .replace("+ reflect(", "+ lobe_fn_reflect(")
        );
        assert_eq!(renamed.lines().count(), shader.lines().count());
        assert_eq!(original_names(&renamed), shader);
    }
}
