//! A small GLSL tokenizer: identifiers and punctuation outside comments, with their byte
//! offsets, and the macro names that `#define` lines define. Numbers are skipped; a
//! preprocessor line's tokens are kept apart (they are not GLSL declarations, but a macro's
//! body may call a function).

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Tok<'a> {
    Ident(&'a str),
    Punct(u8),
}

/// One token: where it starts in the text, and whether it is on a preprocessor line.
#[derive(Clone, Copy, Debug)]
pub(super) struct Lexeme<'a> {
    pub tok: Tok<'a>,
    pub at: usize,
    pub directive: bool,
}

/// Every token of `text` outside comments, preprocessor lines included (each such line begins
/// with a `#` token marked `directive`).
pub(super) fn lex(text: &str) -> Vec<Lexeme<'_>> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    let mut line_start = true;
    let mut directive = false;
    while i < b.len() {
        let c = b[i];
        if c == b'\n' {
            line_start = true;
            directive = false;
            i += 1;
        } else if c.is_ascii_whitespace() {
            i += 1;
        } else if b[i..].starts_with(b"//") {
            i = text[i..].find('\n').map_or(b.len(), |e| i + e);
        } else if b[i..].starts_with(b"/*") {
            i = text[i + 2..].find("*/").map_or(b.len(), |e| i + 2 + e + 2);
            line_start = false;
        } else if c.is_ascii_alphabetic() || c == b'_' {
            let start = i;
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                i += 1;
            }
            out.push(Lexeme {
                tok: Tok::Ident(&text[start..i]),
                at: start,
                directive,
            });
            line_start = false;
        } else if c.is_ascii_digit() {
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'.') {
                i += 1;
            }
            line_start = false;
        } else {
            directive |= c == b'#' && line_start;
            out.push(Lexeme {
                tok: Tok::Punct(c),
                at: i,
                directive,
            });
            i += 1;
            line_start = false;
        }
    }
    out
}

/// The tokens of GLSL text outside comments and preprocessor lines, and the macro names that
/// `#define` lines define.
pub(super) fn tokens(text: &str) -> (Vec<Tok<'_>>, Vec<String>) {
    let lexemes = lex(text);
    let mut macros = Vec::new();
    for (k, l) in lexemes.iter().enumerate() {
        if l.tok == Tok::Punct(b'#') && l.directive {
            if let [Lexeme {
                tok: Tok::Ident("define"),
                ..
            }, Lexeme {
                tok: Tok::Ident(name),
                directive: true,
                ..
            }, ..] = &lexemes[k + 1..]
            {
                macros.push(name.to_string());
            }
        }
    }
    let toks = lexemes
        .iter()
        .filter(|l| !l.directive)
        .map(|l| l.tok)
        .collect();
    (toks, macros)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Characters beyond ASCII outside comments are punctuation to GLSL (and an error there);
    /// the tokenizer steps over them byte by byte without cutting one in half.
    #[test]
    fn text_beyond_ascii_is_stepped_over() {
        let names: Vec<_> = lex("a é/ b // ü\n\u{feff}/*ß*/c")
            .into_iter()
            .filter_map(|l| match l.tok {
                Tok::Ident(n) => Some(n),
                _ => None,
            })
            .collect();
        assert_eq!(names, ["a", "b", "c"]);
    }
}
