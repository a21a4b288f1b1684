//! The kernels for a `.brdf` file, compiled at run time with glslang.
//!
//! Each kernel of `glsl/kernels/` (embedded here as text) is compiled as build.rs compiles it for
//! a built-in model, with the virtual include `model.glsl` resolved to a parameter struct and a
//! prototype of the model function, and the file's shader appended after the kernel:
//!
//! ```text
//! preamble   #define PI lobe_PI, #define params lobe_params, …   every global name of lobe's
//!                                                                kernels, prefixed
//! kernel     glsl/kernels/<kernel>.comp (common.glsl, eval.glsl; model.glsl = struct + prototype)
//! tail       #undef of each of those names and of the kernel's own macros
//!            float rough; bool useX; vec3 kd;   one global per parameter (#line: its line)
//!            the shader section                 (#line: its first line in the file; its
//!                                               functions renamed: rename.rs)
//!            lobe_model(): copies the block into those globals, calls BRDF(L, V, N, X, Y)
//! ```
//!
//! So the file's shader sees a clean namespace: its own `const float PI`, helpers named like
//! lobe's, and its parameters as plain globals (BRDF Explorer makes them uniforms), while lobe's
//! names, renamed with the `lobe_` prefix, cannot clash with them. The shader's macros cannot
//! reach the kernel either, since the kernel comes first. `#line` directives name the file with a
//! tag that the error mapping replaces, so every compiler message points at the `.brdf` file's line.
//! The desktop GLSL 4.50 of the kernels keeps old-style implicit int→float conversions
//! (`1/PI`, `max(0, x)`, `clamp(1-u, 0, 1)`).

use super::lex::{tokens, Tok};
use super::names::declared;
pub use super::names::unused_tangents;
use super::parse::{BrdfFile, ParamType};
use super::rename::{original_names, rename_functions};
use super::validate::{self, Inventory};
use super::{BrdfError, RESERVED};
use glslang::include::{IncludeHandler, IncludeResult, IncludeType};
use glslang::{Compiler, CompilerOptions, ShaderInput, ShaderSource, ShaderStage};
use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::sync::{Mutex, OnceLock};

/// The kernels, by the names [`crate::gpu::pipeline::Kernel::name`] looks them up with.
pub const KERNELS: &[(&str, &str)] = &[
    ("pairs", include_str!("../../glsl/kernels/pairs.comp")),
    ("table", include_str!("../../glsl/kernels/table.comp")),
    ("albedo", include_str!("../../glsl/kernels/albedo.comp")),
    ("preview", include_str!("../../glsl/kernels/preview.comp")),
    ("sample", include_str!("../../glsl/kernels/sample.comp")),
    ("chi2", include_str!("../../glsl/kernels/chi2.comp")),
    ("light", include_str!("../../glsl/kernels/light.comp")),
];

/// The files the kernels include (besides the generated `model.glsl`).
const INCLUDES: &[(&str, &str)] = &[
    ("common.glsl", include_str!("../../glsl/common.glsl")),
    (
        "kernels/eval.glsl",
        include_str!("../../glsl/kernels/eval.glsl"),
    ),
    ("random.glsl", include_str!("../../glsl/random.glsl")),
    (
        "kernels/sampler.glsl",
        include_str!("../../glsl/kernels/sampler.glsl"),
    ),
    (
        "kernels/draw.glsl",
        include_str!("../../glsl/kernels/draw.glsl"),
    ),
    (
        "brdf/terms.glsl",
        include_str!("../../glsl/brdf/terms.glsl"),
    ),
    (
        "brdf/sample.glsl",
        include_str!("../../glsl/brdf/sample.glsl"),
    ),
];

/// The names `#line` gives the file's text and lobe's glue, replaced in compiler messages.
const FILE_TAG: &str = "lobe-brdf-file";
const GLUE_TAG: &str = "lobe-brdf-glue";

/// The struct and function the kernels reach the model through (`MODEL_PARAMS`, `MODEL_EVAL`).
const PARAMS_STRUCT: &str = "lobe_Params";
const MODEL_FN: &str = "lobe_model";

/// What the file's shader must define, as messages say it.
pub const SIGNATURE: &str = "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)";

/// The file's own sampler, optional, both or neither (docs/sampling.md): a direction drawn from
/// two uniform numbers, and its density over the solid angle of `L`.
pub const SAMPLER_SIGNATURES: [&str; 2] = [
    "vec3 sampleL(vec2 u, vec3 V, vec3 N, vec3 X, vec3 Y)",
    "float pdfL(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)",
];

/// The names of [`SAMPLER_SIGNATURES`]' functions.
const SAMPLER_FNS: [&str; 2] = ["sampleL", "pdfL"];

/// The kernels' sampler and density functions for a file with its own sampler (`MODEL_SAMPLE`,
/// `MODEL_PDF` of kernels/sampler.glsl).
const SAMPLE_FN: &str = "lobe_model_sample";
const PDF_FN: &str = "lobe_model_pdf";

/// Lobe's global names in the kernels and their includes: (names to rename, macros to undefine).
fn kernel_names() -> &'static (BTreeSet<String>, BTreeSet<String>) {
    static NAMES: OnceLock<(BTreeSet<String>, BTreeSet<String>)> = OnceLock::new();
    NAMES.get_or_init(|| {
        let (mut globals, mut macros) = (BTreeSet::new(), BTreeSet::new());
        for (_, text) in KERNELS.iter().chain(INCLUDES) {
            let (tokens, defined) = tokens(text);
            globals.extend(declared(&tokens));
            macros.extend(defined);
        }
        globals.remove("main");
        macros.insert("MODEL_PARAMS".into());
        macros.insert("MODEL_EVAL".into());
        (globals, macros)
    })
}

/// Whether the file's shader has its own sampler: both `sampleL` and `pdfL`, or neither (then
/// the kernels draw by the cosine). One without the other is refused, naming its line.
pub fn has_sampler(file: &BrdfFile) -> Result<bool, BrdfError> {
    let defined = super::rename::user_functions(&file.shader);
    match SAMPLER_FNS.map(|n| defined.contains(n)) {
        [true, true] => Ok(true),
        [false, false] => Ok(false),
        [has_sample, _] => {
            let (present, missing) = if has_sample { (0, 1) } else { (1, 0) };
            Err(BrdfError::Parse {
                file: file.file.clone(),
                line: line_of(file, SAMPLER_FNS[present]).unwrap_or(file.shader_line),
                message: format!(
                    "the shader defines {} but not {}: a shader's own sampler needs both \
                     (`{}` and `{}`); without either, lobe draws directions by the cosine",
                    SAMPLER_FNS[present],
                    SAMPLER_FNS[missing],
                    SAMPLER_SIGNATURES[0],
                    SAMPLER_SIGNATURES[1]
                ),
            })
        }
    }
}

/// The generated `model.glsl`: the parameter block's struct (members in the file's order, as
/// [`crate::model::runtime::std430_layout`] lays them out) and the model function's prototype;
/// with the file's own sampler, the prototypes of the kernels' sampler and density functions,
/// which kernels/sampler.glsl then calls instead of the cosine.
fn model_glsl(file: &BrdfFile, sampler: bool) -> String {
    let mut s = format!(
        "// The parameters of {}.\nstruct {PARAMS_STRUCT} {{\n",
        file.file
    );
    for (k, p) in file.params.iter().enumerate() {
        let ty = if matches!(p.kind, ParamType::Color { .. }) {
            "vec3"
        } else {
            "float"
        };
        let _ = writeln!(s, "    {ty} {RESERVED}{k};  // {}", p.name);
    }
    if file.params.is_empty() {
        // GLSL has no empty struct; the block is 4 bytes then (std430_layout's minimum).
        let _ = writeln!(s, "    float {RESERVED}unused;");
    }
    let _ = writeln!(
        s,
        "}};\nvec3 {MODEL_FN}({PARAMS_STRUCT} p, vec3 wi, vec3 wo);"
    );
    if sampler {
        let _ = writeln!(
            s,
            "#include \"brdf/sample.glsl\"\n\
             Sample {SAMPLE_FN}({PARAMS_STRUCT} p, vec3 wo, float uc, vec2 u);\n\
             float {PDF_FN}({PARAMS_STRUCT} p, vec3 wi, vec3 wo);\n\
             #define MODEL_SAMPLE {SAMPLE_FN}\n#define MODEL_PDF {PDF_FN}"
        );
    }
    s
}

/// The statements of a glue function that copy the parameter block `lobe_p` into the
/// parameters' globals.
fn copy_params(file: &BrdfFile) -> String {
    let mut s = String::new();
    for (k, p) in file.params.iter().enumerate() {
        let value = format!("{RESERVED}p.{RESERVED}{k}");
        match p.kind {
            ParamType::Bool { .. } => {
                let _ = writeln!(s, "    {} = {value} != 0.0;", p.name);
            }
            _ => {
                let _ = writeln!(s, "    {} = {value};", p.name);
            }
        }
    }
    s
}

/// What follows the kernel: lobe's names released, the parameters as globals, the shader, and
/// the model function that calls the shader's BRDF (with its own sampler, the sampler and
/// density functions that call `sampleL` and `pdfL`).
fn tail(file: &BrdfFile, sampler: bool) -> String {
    let (globals, macros) = kernel_names();
    let mut s = String::from("\n");
    for name in globals.iter().chain(macros) {
        let _ = writeln!(s, "#undef {name}");
    }
    for p in &file.params {
        let ty = match p.kind {
            ParamType::Float { .. } => "float",
            ParamType::Bool { .. } => "bool",
            ParamType::Color { .. } => "vec3",
        };
        let _ = writeln!(s, "#line {} \"{FILE_TAG}\"\n{ty} {};", p.line, p.name);
    }
    let _ = write!(
        s,
        "#line {} \"{FILE_TAG}\"\n{}",
        file.shader_line,
        rename_functions(&file.shader)
    );
    let _ = writeln!(
        s,
        "\n#line 1 \"{GLUE_TAG}\"\nvec3 {MODEL_FN}({PARAMS_STRUCT} {RESERVED}p, vec3 {RESERVED}wi, vec3 {RESERVED}wo) {{"
    );
    s.push_str(&copy_params(file));
    // docs/design.md §2: L = ωi (to the light), V = ωo (to the viewer), the frame n, t, b.
    const FRAME: &str = "vec3(0.0, 0.0, 1.0), vec3(1.0, 0.0, 0.0), vec3(0.0, 1.0, 0.0)";
    let _ = writeln!(
        s,
        "    return BRDF({RESERVED}wi, {RESERVED}wo, {FRAME});\n}}"
    );
    if sampler {
        // The rules of Reference::sample: sample_from_user_draw loses a draw below the horizon
        // or with a density of 0, and keeps one whose ωi or density is not finite (or whose
        // density is negative) as drawn, for the sampling test to count as invalid; weight =
        // f cos θi / pdf with f one-sided (as eval.glsl's brdf).
        // The names are lobe's as the kernel renamed them (its #defines are undone above).
        let (sample, pdf) = (SAMPLER_FNS[0], SAMPLER_FNS[1]);
        let user = super::rename::USER_FN;
        let _ = writeln!(
            s,
            "{RESERVED}Sample {SAMPLE_FN}({PARAMS_STRUCT} {RESERVED}p, vec3 {RESERVED}wo, float {RESERVED}uc, vec2 {RESERVED}u) {{\n{}\
             \x20   vec3 {RESERVED}wi = {user}{sample}({RESERVED}u, {RESERVED}wo, {FRAME});\n\
             \x20   float {RESERVED}pdf = {user}{pdf}({RESERVED}wi, {RESERVED}wo, {FRAME});\n\
             \x20   vec3 {RESERVED}f = {RESERVED}wi.z > 0.0 && {RESERVED}wo.z > 0.0 ? {MODEL_FN}({RESERVED}p, {RESERVED}wi, {RESERVED}wo) : vec3(0.0);\n\
             \x20   return {RESERVED}sample_from_user_draw({RESERVED}wi, {RESERVED}pdf, {RESERVED}f);\n}}\n\
             float {PDF_FN}({PARAMS_STRUCT} {RESERVED}p, vec3 {RESERVED}wi, vec3 {RESERVED}wo) {{\n{}\
             \x20   return {user}{pdf}({RESERVED}wi, {RESERVED}wo, {FRAME});\n}}",
            copy_params(file),
            copy_params(file),
        );
    }
    s
}

struct Includes<'a> {
    model: &'a str,
}

impl IncludeHandler for Includes<'_> {
    fn include(
        &mut self,
        _ty: IncludeType,
        header_name: &str,
        _includer_name: &str,
        _depth: usize,
    ) -> Option<IncludeResult> {
        let data = if header_name == "model.glsl" {
            self.model.to_string()
        } else {
            INCLUDES
                .iter()
                .find(|(n, _)| *n == header_name)?
                .1
                .to_string()
        };
        Some(IncludeResult {
            name: header_name.to_string(),
            data,
        })
    }
}

/// The shader lobe's own inventory is taken with ([`mod@validate`]).
const STAND_IN: &str = "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return vec3(0.0); }\n";

/// Compiles every kernel for `file`: (kernel name, SPIR-V bytes). A compiler message names the
/// `.brdf` file and its line; a shader that adds to a kernel more than functions, constants
/// and its parameters is refused ([`mod@validate`]).
pub fn compile(file: &BrdfFile) -> Result<Vec<(&'static str, Vec<u8>)>, BrdfError> {
    // glslang takes C strings: a NUL would cut the source short (the reader refuses such files).
    if let Some(at) = file.shader.find('\0') {
        return Err(BrdfError::Parse {
            file: file.file.clone(),
            line: file.shader_line + file.shader[..at].matches('\n').count(),
            message: "a NUL byte in the shader; a .brdf file is text".into(),
        });
    }
    has_sampler(file)?;
    // One compilation at a time: glslang's process-wide state is shared.
    static LOCK: Mutex<()> = Mutex::new(());
    let _guard = LOCK.lock().unwrap_or_else(|e| e.into_inner());
    let compiler = Compiler::acquire().ok_or_else(|| BrdfError::Compile {
        file: file.file.clone(),
        line: file.shader_line,
        message: "the GLSL compiler (glslang) could not start".into(),
    })?;
    // Lobe's own inventory of each kernel, taken once (the compiler is held here).
    static LOBE: OnceLock<Result<Vec<Inventory>, String>> = OnceLock::new();
    let lobe = LOBE.get_or_init(|| {
        let stand_in = BrdfFile {
            file: "stand-in.brdf".into(),
            params: Vec::new(),
            shader: STAND_IN.into(),
            shader_line: 1,
            notes: Vec::new(),
        };
        KERNELS
            .iter()
            .map(|&(_, text)| {
                let words = compile_kernel(compiler, &stand_in, text).map_err(|e| e.1)?;
                validate::inventory(&words)
            })
            .collect()
    });
    let lobe = lobe.as_ref().map_err(|e| BrdfError::Compile {
        file: file.file.clone(),
        line: file.shader_line,
        message: format!("lobe's own kernels did not compile: {e}"),
    })?;
    let mut out = Vec::new();
    for (&(kernel, text), own) in KERNELS.iter().zip(lobe) {
        let words =
            compile_kernel(compiler, file, text).map_err(|(line, message)| BrdfError::Compile {
                file: file.file.clone(),
                line,
                message,
            })?;
        let refused = |message: String, line: usize| BrdfError::Refused {
            file: file.file.clone(),
            line,
            message,
        };
        let user = validate::inventory(&words).map_err(|m| refused(m, file.shader_line))?;
        let refusals = validate::check(&user, own);
        if !refusals.is_empty() {
            let at = |r: &validate::Refusal| {
                let line = r.name.as_deref().and_then(|n| line_of(file, n));
                line.unwrap_or(file.shader_line)
            };
            let mut message = refusals[0].message.clone();
            for r in &refusals[1..] {
                let _ = write!(message, "\n{}:{}: {}", file.file, at(r), r.message);
            }
            return Err(refused(message, at(&refusals[0])));
        }
        out.push((kernel, words.iter().flat_map(|w| w.to_le_bytes()).collect()));
    }
    Ok(out)
}

/// One kernel with `file`'s shader, as SPIR-V words; or the first error's line in the file and
/// the compiler's messages ([`map_log`]).
fn compile_kernel(
    compiler: &Compiler,
    file: &BrdfFile,
    text: &str,
) -> Result<Vec<u32>, (usize, String)> {
    let options = CompilerOptions::default();
    // The renames go right after `#version` (macros from glslang's preamble cannot be
    // undefined), and `#line 2` keeps the kernel's own line numbers.
    let (globals, _) = kernel_names();
    let mut renames = String::new();
    for n in globals {
        let _ = writeln!(renames, "#define {n} {RESERVED}{n}");
    }
    let _ = writeln!(
        renames,
        "#define MODEL_PARAMS {PARAMS_STRUCT}\n#define MODEL_EVAL {MODEL_FN}\n#line 2"
    );
    let sampler = has_sampler(file).map_err(|e| match e {
        BrdfError::Parse { line, message, .. } => (line, message),
        other => (file.shader_line, other.to_string()),
    })?;
    let model = model_glsl(file, sampler);
    let (version, body) = text.split_once('\n').unwrap_or((text, ""));
    let source = ShaderSource::from(format!("{version}\n{renames}{body}{}", tail(file, sampler)));
    let mut includes = Includes { model: &model };
    ShaderInput::new(
        &source,
        ShaderStage::Compute,
        &options,
        None,
        Some(&mut includes),
    )
    .and_then(|input| glslang::Shader::new(compiler, input).parse())
    .and_then(|shader| shader.compile())
    .map_err(|e| map_log(file, &e.to_string()))
}

/// The file's line of the first place its shader names `name` (outside comments).
fn line_of(file: &BrdfFile, name: &str) -> Option<usize> {
    let at = super::lex::lex(&file.shader)
        .into_iter()
        .find(|l| l.tok == Tok::Ident(name))?
        .at;
    Some(file.shader_line + file.shader[..at].matches('\n').count())
}

/// glslang's messages with the tags replaced: the first error's line in the file, and every
/// error as `FILE:LINE: message`, one a line. A message in lobe's glue means the shader lacks
/// the function lobe calls.
fn map_log(file: &BrdfFile, log: &str) -> (usize, String) {
    let mut first = None;
    let mut lines = Vec::new();
    for entry in log.lines().filter_map(|l| l.trim().strip_prefix("ERROR: ")) {
        if let Some(rest) = entry.strip_prefix(&format!("{FILE_TAG}:")) {
            let (n, text) = rest.split_once(':').unwrap_or(("", rest));
            // A line the file sets itself with `#line` may be 0; files count from 1.
            let n: usize = n.trim().parse().unwrap_or(file.shader_line).max(1);
            first.get_or_insert(n);
            let text = original_names(text.trim());
            if text != "'' : compilation terminated" {
                lines.push(format!("{}:{n}: {text}", file.file));
            }
        } else if let Some(rest) = entry.strip_prefix(&format!("{GLUE_TAG}:")) {
            if rest.contains("compilation terminated") {
                continue;
            }
            first.get_or_insert(file.shader_line.saturating_sub(1).max(1));
            let text = original_names(rest.split_once(':').map_or(rest, |r| r.1).trim());
            let line = file.shader_line.saturating_sub(1).max(1);
            lines.push(if has_sampler(file).unwrap_or(false) {
                format!(
                    "the shader section (line {line}) must define {SIGNATURE}, {} and {}; \
                     calling them failed: {text}",
                    SAMPLER_SIGNATURES[0], SAMPLER_SIGNATURES[1]
                )
            } else {
                format!(
                    "the shader section (line {line}) must define {SIGNATURE}; calling it failed: {text}"
                )
            });
        } else if !entry.contains("compilation errors") && !entry.contains("compilation terminated")
        {
            lines.push(format!("in lobe's kernel: {entry}"));
        }
    }
    if lines.is_empty() {
        lines.push(log.trim().to_string());
    }
    (first.unwrap_or(file.shader_line), lines.join("\n"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_kernels_global_names_are_found() {
        let (globals, macros) = kernel_names();
        for name in [
            "PI",
            "INV_PI",
            "WHITE_FURNACE",
            "FAST_POW",
            "EVALS_PER_INVOCATION",
            "ParamBlock",
            "params",
            "chunk",
            "Chunk",
            "brdf",
            "store",
            "sums",
            "Span",
            "spans",
            "Light",
            "lights",
            "ambient",
            "camera",
            "PHI",
            "intersect",
            "shade",
            "light_dir",
            "wi_texels",
        ] {
            assert!(globals.contains(name), "{name} not found in {globals:?}");
        }
        for not in [
            "main",
            "in",
            "layout",
            "vec3",
            "first",
            "count",
            "position",
            "set",
            "binding",
            "constant_id",
            "std430",
            "sqrt",
            "p",
            "wi",
            "MODEL_PARAMS",
        ] {
            assert!(!globals.contains(not), "{not} taken for a global");
        }
        assert!(macros.contains("LOBE_COMMON_GLSL"), "{macros:?}");
        assert!(globals.iter().all(|n| !n.starts_with(RESERVED)));
    }

    /// Every kernel of glsl/kernels/ is embedded, and every file they include is at hand.
    #[test]
    fn every_kernel_and_include_is_embedded() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("glsl/kernels");
        let mut on_disk: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| {
                let p = e.ok()?.path();
                (p.extension()? == "comp").then(|| p.file_stem()?.to_str().map(String::from))?
            })
            .collect();
        on_disk.sort();
        let mut embedded: Vec<String> = KERNELS.iter().map(|k| k.0.to_string()).collect();
        embedded.sort();
        assert_eq!(on_disk, embedded);
        for (_, text) in KERNELS.iter().chain(INCLUDES) {
            for line in text
                .lines()
                .filter(|l| l.trim_start().starts_with("#include"))
            {
                let name = line.split('"').nth(1).unwrap_or("");
                assert!(
                    name == "model.glsl" || INCLUDES.iter().any(|(n, _)| *n == name),
                    "{name} is included but not embedded"
                );
            }
        }
    }
}
