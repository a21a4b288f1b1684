//! The reader of BRDF Explorer's "analytic" files: the word `analytic` on the first line that is
//! not a comment, then sections between `::begin NAME` and `::end NAME`. The `parameters`
//! section declares one parameter a line (`float NAME MIN MAX DEFAULT`, `bool NAME 0|1`,
//! `color NAME R G B`); the `shader` section is GLSL, kept verbatim with its first line's
//! number so that compiler messages can point into the file. A line starting with `#` outside
//! the shader is a comment (inside it, `#` starts a preprocessor directive); any other section
//! is skipped with a note.

use super::{BrdfError, RESERVED};
use crate::model::runtime::MAX_VALUES;

/// What a parameter is and its default.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamType {
    /// `float NAME MIN MAX DEFAULT`: a number in [min, max].
    Float {
        /// The smallest value.
        min: f64,
        /// The largest value.
        max: f64,
        /// The value it starts from.
        default: f64,
    },
    /// `bool NAME 0|1`: a switch.
    Bool {
        /// Whether it starts on.
        default: bool,
    },
    /// `color NAME R G B`: linear RGB, each channel in [0, 1].
    Color {
        /// The colour it starts from.
        default: [f64; 3],
    },
}

impl ParamType {
    /// How many numbers the parameter block holds for it (a colour three, others one).
    pub fn numbers(&self) -> usize {
        match self {
            ParamType::Color { .. } => 3,
            _ => 1,
        }
    }
}

/// One declared parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    /// Its name, by which the shader reads it.
    pub name: String,
    /// Its type and default.
    pub kind: ParamType,
    /// The line that declares it (from 1).
    pub line: usize,
}

/// A parsed `.brdf` file.
#[derive(Clone, Debug, PartialEq)]
pub struct BrdfFile {
    /// How messages name the file (the path as given).
    pub file: String,
    /// The parameters, in the file's order.
    pub params: Vec<Param>,
    /// The GLSL of the shader section, verbatim.
    pub shader: String,
    /// The file's line number of the shader's first line.
    pub shader_line: usize,
    /// Notes on what was skipped (unknown sections), each naming its line.
    pub notes: Vec<String>,
}

/// Largest `.brdf` file read: real ones are a few kilobytes.
pub const MAX_FILE_BYTES: usize = 1 << 20;

/// The sections lobe reads.
const PARAMETERS: &str = "parameters";
const SHADER: &str = "shader";

/// Parses the text of a `.brdf` file; `file` is how errors name it.
pub fn parse(file: &str, text: &str) -> Result<BrdfFile, BrdfError> {
    let err = |line: usize, message: String| BrdfError::Parse {
        file: file.to_string(),
        line,
        message,
    };
    if text.len() > MAX_FILE_BYTES {
        return Err(BrdfError::TooLarge {
            file: file.to_string(),
            bytes: text.len() as u64,
        });
    }
    let text = crate::input::without_bom(text);
    if let Some(at) = text.find('\0') {
        return Err(err(
            1 + text[..at].matches('\n').count(),
            format!("a NUL byte at offset {at}; a .brdf file is text, not a binary file"),
        ));
    }
    let mut header = false;
    // The section being read: its name and the line of its `::begin`.
    let mut section: Option<(String, usize)> = None;
    let mut params: Vec<Param> = Vec::new();
    let mut shader: Option<(String, usize)> = None;
    let mut seen_params: Option<usize> = None;
    let mut notes = Vec::new();
    // The last line with text: where a missing section is reported.
    let mut last = 1;
    for (index, raw) in text.split('\n').enumerate() {
        let line = index + 1;
        let raw = raw.strip_suffix('\r').unwrap_or(raw);
        let trimmed = raw.trim();
        if !trimmed.is_empty() {
            last = line;
        }
        let directive = trimmed.strip_prefix("::").map(|d| {
            let mut words = d.split_whitespace();
            (
                words.next().unwrap_or(""),
                words.next().unwrap_or(""),
                words.next(),
            )
        });
        // Section boundaries first: inside the shader, every other line is GLSL.
        if let Some((word, name, extra)) = directive {
            if let Some(extra) = extra {
                return Err(err(
                    line,
                    format!("'{extra}' after the section name; expected '::{word} {name}'"),
                ));
            }
            match (word, &section) {
                ("begin", None) => {
                    if !header {
                        return Err(err(line, no_header(trimmed)));
                    }
                    if name.is_empty() {
                        return Err(err(
                            line,
                            "'::begin' without a section name (e.g. '::begin shader')".into(),
                        ));
                    }
                    let earlier = match name {
                        PARAMETERS => seen_params,
                        SHADER => shader.as_ref().map(|s| s.1 - 1),
                        _ => None,
                    };
                    if let Some(at) = earlier {
                        return Err(err(
                            line,
                            format!("a second '{name}' section (the first begins at line {at})"),
                        ));
                    }
                    match name {
                        PARAMETERS => seen_params = Some(line),
                        SHADER => shader = Some((String::new(), line + 1)),
                        _ => notes.push(format!(
                            "{file}:{line}: section '{name}' skipped (lobe reads the '{PARAMETERS}' and '{SHADER}' sections)"
                        )),
                    }
                    section = Some((name.to_string(), line));
                }
                ("begin", Some((open, at))) => {
                    return Err(err(
                        line,
                        format!("'::begin {name}' inside the section '{open}' begun at line {at}; end it first with '::end {open}'"),
                    ));
                }
                ("end", Some((open, at))) => {
                    if name != open {
                        return Err(err(
                            line,
                            format!("'::end {name}' while the section '{open}' begun at line {at} is open; expected '::end {open}'"),
                        ));
                    }
                    section = None;
                }
                ("end", None) => {
                    return Err(err(
                        line,
                        format!("'::end {name}' without its '::begin {name}'"),
                    ));
                }
                _ => {
                    return Err(err(
                        line,
                        format!("unknown directive '{trimmed}'; expected '::begin NAME' or '::end NAME'"),
                    ));
                }
            }
            continue;
        }
        match &section {
            Some((name, _)) if name == SHADER => {
                if let Some((text, _)) = &mut shader {
                    text.push_str(raw);
                    text.push('\n');
                }
                continue;
            }
            Some((name, _)) if name != PARAMETERS => continue,
            _ => {}
        }
        // Outside the shader: blank lines and comments; `#` also ends a parameter line.
        let content = trimmed.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        if !header {
            if content != "analytic" {
                return Err(err(line, no_header(content)));
            }
            header = true;
            continue;
        }
        if section.is_none() {
            return Err(err(
                line,
                format!("'{content}' outside a section; expected '::begin {PARAMETERS}', '::begin {SHADER}' or a comment starting with '#'"),
            ));
        }
        let param = parse_param(content, line).map_err(|m| err(line, m))?;
        if let Some(first) = params.iter().find(|p| p.name == param.name) {
            return Err(err(
                line,
                format!(
                    "parameter '{}' is already declared at line {}",
                    param.name, first.line
                ),
            ));
        }
        let numbers: usize = params
            .iter()
            .chain([&param])
            .map(|p| p.kind.numbers())
            .sum();
        if numbers > MAX_VALUES {
            return Err(err(
                line,
                format!("parameter '{}' makes {numbers} parameter numbers (a color counts three); lobe takes at most {MAX_VALUES}", param.name),
            ));
        }
        params.push(param);
    }
    if let Some((name, at)) = section {
        return Err(err(
            at,
            format!("the section '{name}' has no '::end {name}' before the end of the file"),
        ));
    }
    if !header {
        return Err(err(
            last,
            "the file has no 'analytic' line (it is empty or only comments); lobe reads BRDF Explorer's analytic files".into(),
        ));
    }
    let Some((shader, shader_line)) = shader else {
        return Err(err(
            last,
            format!("no '::begin {SHADER}' section; it must define vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)"),
        ));
    };
    Ok(BrdfFile {
        file: file.to_string(),
        params,
        shader,
        shader_line,
        notes,
    })
}

fn no_header(found: &str) -> String {
    format!("expected 'analytic' as the first line that is not a comment, found '{found}'; lobe reads BRDF Explorer's analytic files")
}

/// One `parameters` line; the error is a sentence without the file and line.
fn parse_param(content: &str, line: usize) -> Result<Param, String> {
    let words: Vec<&str> = content.split_whitespace().collect();
    let (form, count) = match words[0] {
        "float" => ("float NAME MIN MAX DEFAULT", 5),
        "bool" => ("bool NAME 0|1", 3),
        "color" => ("color NAME R G B", 5),
        other => {
            return Err(format!(
                "unknown parameter type '{other}'; expected float, bool or color"
            ))
        }
    };
    if words.len() != count {
        return Err(format!(
            "expected '{form}', found {} word{}",
            words.len(),
            if words.len() == 1 { "" } else { "s" }
        ));
    }
    let name = words[1];
    check_name(name)?;
    // The GPU computes in f32: a bound or default beyond its range would be infinite there.
    let number = |what: &str, text: &str| -> Result<f64, String> {
        match text.parse::<f64>() {
            Ok(v) if v.abs() <= f64::from(f32::MAX) => Ok(v),
            Ok(v) if v.is_finite() => Err(format!(
                "{} '{name}': {what} {text} is beyond the 32-bit floats the GPU computes in (at most {:e} in magnitude)",
                words[0],
                f32::MAX
            )),
            _ => Err(format!(
                "{} '{name}': cannot read {what} '{text}' as a finite number",
                words[0]
            )),
        }
    };
    let kind = match words[0] {
        "float" => {
            let (min, max) = (number("MIN", words[2])?, number("MAX", words[3])?);
            let default = number("DEFAULT", words[4])?;
            if min > max {
                return Err(format!("float '{name}': MIN {min} is above MAX {max}"));
            }
            if !(min..=max).contains(&default) {
                return Err(format!(
                    "float '{name}': DEFAULT {default} is outside [{min}, {max}]"
                ));
            }
            ParamType::Float { min, max, default }
        }
        "bool" => ParamType::Bool {
            default: match words[2] {
                "0" | "false" => false,
                "1" | "true" => true,
                v => return Err(format!("bool '{name}': default '{v}' is not 0 or 1")),
            },
        },
        _ => {
            let mut default = [0.0; 3];
            for (c, (slot, text)) in default.iter_mut().zip(&words[2..]).enumerate() {
                let v = number(["R", "G", "B"][c], text)?;
                if !(0.0..=1.0).contains(&v) {
                    return Err(format!(
                        "color '{name}': {} = {v} is outside [0, 1]",
                        ["R", "G", "B"][c]
                    ));
                }
                *slot = v;
            }
            ParamType::Color { default }
        }
    };
    Ok(Param {
        name: name.to_string(),
        kind,
        line,
    })
}

/// A parameter name becomes a GLSL variable: an identifier, and none of the names GLSL or lobe
/// keep for themselves (`gl_…`, anything with `__`, `lobe_…`).
fn check_name(name: &str) -> Result<(), String> {
    let mut chars = name.chars();
    let identifier = chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_');
    if !identifier {
        return Err(format!(
            "parameter name '{name}' is not a GLSL identifier (letters, digits and '_', not starting with a digit)"
        ));
    }
    if name.starts_with("gl_") || name.contains("__") || name.starts_with(RESERVED) {
        return Err(format!(
            "parameter name '{name}' is reserved (names starting with 'gl_' or '{}', or containing '__')",
            RESERVED
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_err(text: &str) -> (usize, String) {
        match parse("t.brdf", text) {
            Err(BrdfError::Parse { line, message, .. }) => (line, message),
            other => panic!("expected a parse error, got {other:?}"),
        }
    }

    #[test]
    fn a_file_with_every_parameter_type() {
        let text = "# a comment\n\nanalytic\n# more\n::begin parameters\nfloat n 1 1000 100 # exponent\nbool on 1\ncolor kd 0.1 0.2 0.3\n::end parameters\n::begin isFunc\nanything\n::end isFunc\n::begin shader\n#define TWO 2.0\nvec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return kd; }\n::end shader\n";
        let f = parse("t.brdf", text).unwrap();
        assert_eq!(
            f.params,
            vec![
                Param {
                    name: "n".into(),
                    kind: ParamType::Float {
                        min: 1.0,
                        max: 1000.0,
                        default: 100.0
                    },
                    line: 6
                },
                Param {
                    name: "on".into(),
                    kind: ParamType::Bool { default: true },
                    line: 7
                },
                Param {
                    name: "kd".into(),
                    kind: ParamType::Color {
                        default: [0.1, 0.2, 0.3]
                    },
                    line: 8
                },
            ]
        );
        assert_eq!(f.shader_line, 14);
        assert!(
            f.shader.starts_with("#define TWO 2.0\nvec3 BRDF"),
            "{}",
            f.shader
        );
        assert_eq!(f.notes.len(), 1);
        assert!(f.notes[0].contains("t.brdf:10") && f.notes[0].contains("isFunc"));
    }

    #[test]
    fn errors_name_the_line() {
        let cases: &[(&str, usize, &str)] = &[
            ("measured\n", 1, "expected 'analytic'"),
            ("", 1, "no 'analytic' line"),
            (
                "analytic\n::begin shader\nvec3 x;\n",
                2,
                "no '::end shader'",
            ),
            (
                "analytic\n::begin parameters\nfloat a 0 1\n::end parameters\n",
                3,
                "found 4 words",
            ),
            (
                "analytic\n::begin parameters\nfloat a 0 1 2\n",
                3,
                "outside [0, 1]",
            ),
            (
                "analytic\n::begin parameters\nfloat a 1 0 0.5\n",
                3,
                "above MAX",
            ),
            (
                "analytic\n::begin parameters\nfloat a 0 x 0\n",
                3,
                "cannot read MAX 'x'",
            ),
            (
                "analytic\n::begin parameters\nfloat a 0 inf 0\n",
                3,
                "finite",
            ),
            (
                "analytic\n::begin parameters\nfloat k 0 1e39 1e39\n",
                3,
                "float 'k': MAX 1e39 is beyond the 32-bit floats",
            ),
            (
                "analytic\n::begin parameters\nfloat k -3.5e38 0 0\n",
                3,
                "MIN -3.5e38 is beyond",
            ),
            ("analytic\n::begin shader\nvec3\0 x;\n", 3, "a NUL byte"),
            ("analytic\n::begin parameters\nbool b 2\n", 3, "not 0 or 1"),
            (
                "analytic\n::begin parameters\ncolor c 0 0.5 2\n",
                3,
                "B = 2",
            ),
            (
                "analytic\n::begin parameters\nint i 0 1 0\n",
                3,
                "unknown parameter type 'int'",
            ),
            (
                "analytic\n::begin parameters\nfloat 2a 0 1 0\n",
                3,
                "not a GLSL identifier",
            ),
            (
                "analytic\n::begin parameters\nfloat lobe_a 0 1 0\n",
                3,
                "reserved",
            ),
            (
                "analytic\n::begin parameters\nfloat a 0 1 0\nbool a 0\n",
                4,
                "already declared at line 3",
            ),
            ("analytic\nfloat a 0 1 0\n", 2, "outside a section"),
            (
                "analytic\n::end shader\n",
                2,
                "without its '::begin shader'",
            ),
            (
                "analytic\n::begin shader\n::begin parameters\n",
                3,
                "inside the section 'shader'",
            ),
            (
                "analytic\n::begin shader\n::end parameters\n",
                3,
                "expected '::end shader'",
            ),
            (
                "analytic\n::begin parameters\n::end parameters\n",
                3,
                "no '::begin shader'",
            ),
            (
                "analytic\n::begin shader\n::end shader\n::begin shader\n::end shader\n",
                4,
                "a second 'shader' section",
            ),
            ("::begin shader\n", 1, "expected 'analytic'"),
            ("analytic\n::start shader\n", 2, "unknown directive"),
        ];
        for &(text, line, words) in cases {
            let (l, m) = parse_err(text);
            assert!(l == line && m.contains(words), "{text:?}: line {l}: {m}");
        }
    }

    #[test]
    fn too_many_numbers_are_refused_at_the_line_that_passes_the_limit() {
        let mut text = String::from("analytic\n::begin parameters\n");
        for k in 0..MAX_VALUES / 3 + 1 {
            text.push_str(&format!("color c{k} 0 0 0\n"));
        }
        let (line, m) = parse_err(&text);
        assert_eq!(line, 2 + MAX_VALUES / 3 + 1, "{m}");
        assert!(m.contains(&format!("at most {MAX_VALUES}")), "{m}");
    }

    #[test]
    fn a_byte_order_mark_is_skipped() {
        let f = parse(
            "t.brdf",
            "\u{feff}analytic\n::begin shader\nvec3 x;\n::end shader\n",
        )
        .unwrap();
        assert_eq!((f.shader_line, f.shader.as_str()), (3, "vec3 x;\n"));
        // Only at the start: elsewhere it is text like any other.
        let (line, m) = parse_err("analytic\n\u{feff}::begin shader\n");
        assert!(line == 2 && m.contains("outside a section"), "{m}");
    }

    #[test]
    fn crlf_and_comment_lines_in_the_shader_are_kept() {
        let text = "analytic\r\n::begin shader\r\n# define A 1\r\nvec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return vec3(A); }\r\n::end shader\r\n";
        let f = parse("t.brdf", text).unwrap();
        assert!(f.shader.starts_with("# define A 1\n"), "{:?}", f.shader);
        assert!(f.params.is_empty());
    }
}
