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
    if text.len() > MAX_FILE_BYTES {
        return Err(BrdfError::TooLarge {
            file: file.to_string(),
            bytes: text.len() as u64,
        });
    }
    let text = crate::input::without_bom(text);
    let mut reader = Reader::new(file);
    if let Some(at) = text.find('\0') {
        return Err(reader.err(
            1 + text[..at].matches('\n').count(),
            format!("a NUL byte at offset {at}; a .brdf file is text, not a binary file"),
        ));
    }
    for (index, raw) in text.split('\n').enumerate() {
        reader.line(index + 1, raw.strip_suffix('\r').unwrap_or(raw))?;
    }
    reader.finish()
}

/// What the reader has seen so far, line by line.
struct Reader<'a> {
    file: &'a str,
    /// Whether the `analytic` line was seen.
    header: bool,
    /// The section being read: its name and the line of its `::begin`.
    section: Option<(String, usize)>,
    params: Vec<Param>,
    /// The shader's text and its first line.
    shader: Option<(String, usize)>,
    /// The line of the `parameters` section's `::begin`.
    seen_params: Option<usize>,
    notes: Vec<String>,
    /// The last line with text: where a missing section is reported.
    last: usize,
}

impl<'a> Reader<'a> {
    fn new(file: &'a str) -> Self {
        Reader {
            file,
            header: false,
            section: None,
            params: Vec::new(),
            shader: None,
            seen_params: None,
            notes: Vec::new(),
            last: 1,
        }
    }

    fn err(&self, line: usize, message: String) -> BrdfError {
        BrdfError::Parse {
            file: self.file.to_string(),
            line,
            message,
        }
    }

    /// One line of the file, without its line ending.
    fn line(&mut self, line: usize, raw: &str) -> Result<(), BrdfError> {
        let trimmed = raw.trim();
        if !trimmed.is_empty() {
            self.last = line;
        }
        // Section boundaries first: inside the shader, every other line is GLSL.
        if let Some(directive) = trimmed.strip_prefix("::") {
            return self.directive(line, trimmed, directive);
        }
        match &self.section {
            Some((name, _)) if name == SHADER => {
                if let Some((text, _)) = &mut self.shader {
                    text.push_str(raw);
                    text.push('\n');
                }
                return Ok(());
            }
            Some((name, _)) if name != PARAMETERS => return Ok(()),
            _ => {}
        }
        // Outside the shader: blank lines and comments; `#` also ends a parameter line.
        let content = trimmed.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            return Ok(());
        }
        if !self.header {
            if content != "analytic" {
                return Err(self.err(line, no_header(content)));
            }
            self.header = true;
            return Ok(());
        }
        if self.section.is_none() {
            return Err(self.err(
                line,
                format!("'{content}' outside a section; expected '::begin {PARAMETERS}', '::begin {SHADER}' or a comment starting with '#'"),
            ));
        }
        self.param(line, content)
    }

    /// A `::begin NAME` or `::end NAME` line; `trimmed` is the whole line, `directive` what
    /// follows the `::`.
    fn directive(&mut self, line: usize, trimmed: &str, directive: &str) -> Result<(), BrdfError> {
        let mut words = directive.split_whitespace();
        let word = words.next().unwrap_or("");
        let name = words.next().unwrap_or("");
        if let Some(extra) = words.next() {
            return Err(self.err(
                line,
                format!("'{extra}' after the section name; expected '::{word} {name}'"),
            ));
        }
        match (word, &self.section) {
            ("begin", None) => self.begin(line, trimmed, name),
            ("begin", Some((open, at))) => Err(self.err(
                line,
                format!("'::begin {name}' inside the section '{open}' begun at line {at}; end it first with '::end {open}'"),
            )),
            ("end", Some((open, at))) => {
                if name != open {
                    return Err(self.err(
                        line,
                        format!("'::end {name}' while the section '{open}' begun at line {at} is open; expected '::end {open}'"),
                    ));
                }
                self.section = None;
                Ok(())
            }
            ("end", None) => Err(self.err(
                line,
                format!("'::end {name}' without its '::begin {name}'"),
            )),
            _ => Err(self.err(
                line,
                format!("unknown directive '{trimmed}'; expected '::begin NAME' or '::end NAME'"),
            )),
        }
    }

    /// `::begin NAME` outside any section.
    fn begin(&mut self, line: usize, trimmed: &str, name: &str) -> Result<(), BrdfError> {
        if !self.header {
            return Err(self.err(line, no_header(trimmed)));
        }
        if name.is_empty() {
            return Err(self.err(
                line,
                "'::begin' without a section name (e.g. '::begin shader')".into(),
            ));
        }
        let earlier = match name {
            PARAMETERS => self.seen_params,
            SHADER => self.shader.as_ref().map(|s| s.1 - 1),
            _ => None,
        };
        if let Some(at) = earlier {
            return Err(self.err(
                line,
                format!("a second '{name}' section (the first begins at line {at})"),
            ));
        }
        match name {
            PARAMETERS => self.seen_params = Some(line),
            SHADER => self.shader = Some((String::new(), line + 1)),
            _ => self.notes.push(format!(
                "{}:{line}: section '{name}' skipped (lobe reads the '{PARAMETERS}' and '{SHADER}' sections)",
                self.file
            )),
        }
        self.section = Some((name.to_string(), line));
        Ok(())
    }

    /// A declaration in the `parameters` section, without its comment.
    fn param(&mut self, line: usize, content: &str) -> Result<(), BrdfError> {
        let param = parse_param(content, line).map_err(|m| self.err(line, m))?;
        if let Some(first) = self.params.iter().find(|p| p.name == param.name) {
            return Err(self.err(
                line,
                format!(
                    "parameter '{}' is already declared at line {}",
                    param.name, first.line
                ),
            ));
        }
        let numbers: usize = self
            .params
            .iter()
            .chain([&param])
            .map(|p| p.kind.numbers())
            .sum();
        if numbers > MAX_VALUES {
            return Err(self.err(
                line,
                format!("parameter '{}' makes {numbers} parameter numbers (a color counts three); lobe takes at most {MAX_VALUES}", param.name),
            ));
        }
        self.params.push(param);
        Ok(())
    }

    /// The checks at the end of the file: every section closed, the header and a shader seen.
    fn finish(mut self) -> Result<BrdfFile, BrdfError> {
        if let Some((name, at)) = &self.section {
            return Err(self.err(
                *at,
                format!("the section '{name}' has no '::end {name}' before the end of the file"),
            ));
        }
        if !self.header {
            return Err(self.err(
                self.last,
                "the file has no 'analytic' line (it is empty or only comments); lobe reads BRDF Explorer's analytic files".into(),
            ));
        }
        let Some((shader, shader_line)) = self.shader.take() else {
            return Err(self.err(
                self.last,
                format!("no '::begin {SHADER}' section; it must define vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)"),
            ));
        };
        Ok(BrdfFile {
            file: self.file.to_string(),
            params: self.params,
            shader,
            shader_line,
            notes: self.notes,
        })
    }
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
mod tests;
