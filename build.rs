//! Compiles every GLSL compute kernel in `glsl/kernels/` once per BRDF model in `glsl/brdf/`
//! into SPIR-V, and writes `$OUT_DIR/shaders.rs`, a table of the embedded modules.
//!
//! A kernel names its model through the virtual include `"model.glsl"`, which this script
//! resolves to `brdf/<model>.glsl`, and through the macros `MODEL_PARAMS` (the parameter
//! struct), `MODEL_EVAL` (the BRDF function), `MODEL_SAMPLE` (its sampler, `sample_<model>`)
//! and `MODEL_PDF` (the sampler's density, `pdf_<model>`). A GLSL error fails the build with glslang's
//! message, which names the file and the line.

use glslang::include::{IncludeHandler, IncludeResult, IncludeType};
use glslang::{Compiler, CompilerOptions, ShaderInput, ShaderSource, ShaderStage};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

struct Includes {
    root: PathBuf,
    model: String,
}

impl IncludeHandler for Includes {
    fn include(
        &mut self,
        _ty: IncludeType,
        header_name: &str,
        _includer_name: &str,
        _depth: usize,
    ) -> Option<IncludeResult> {
        let rel = if header_name == "model.glsl" {
            format!("brdf/{}.glsl", self.model)
        } else {
            header_name.to_string()
        };
        let path = self.root.join(&rel);
        let data = std::fs::read_to_string(&path).ok()?;
        Some(IncludeResult { name: rel, data })
    }
}

/// `cook_torrance` -> `CookTorranceParams`.
fn params_struct(model: &str) -> String {
    let mut s = String::new();
    for part in model.split('_') {
        let mut c = part.chars();
        if let Some(first) = c.next() {
            s.push(first.to_ascii_uppercase());
            s.extend(c);
        }
    }
    s + "Params"
}

fn stems(dir: &Path, ext: &str) -> Vec<String> {
    let mut out: Vec<String> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", dir.display()))
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.extension().and_then(|x| x.to_str()) == Some(ext))
        .filter_map(|p| p.file_stem().and_then(|s| s.to_str()).map(str::to_string))
        .collect();
    out.sort();
    out
}

fn main() {
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap()).join("glsl");
    let out_dir = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    println!("cargo:rerun-if-changed=glsl");

    let models: Vec<String> = stems(&root.join("brdf"), "glsl")
        .into_iter()
        // Files of shared terms and samplers that models include, not models themselves.
        .filter(|m| m != "terms" && m != "kulla_conty" && m != "sample")
        .collect();
    let kernels = stems(&root.join("kernels"), "comp");
    let compiler = Compiler::acquire().expect("glslang compiler is already in use");
    let options = CompilerOptions::default();

    let mut table = String::from(
        "/// Embedded SPIR-V: (kernel, model, words).\npub static SHADERS: &[(&str, &str, &[u8])] = &[\n",
    );
    let mut failures = Vec::new();
    for kernel in &kernels {
        let path = root.join("kernels").join(format!("{kernel}.comp"));
        let text = std::fs::read_to_string(&path).unwrap();
        let source = ShaderSource::from(text);
        for model in &models {
            let defines = [
                ("MODEL_PARAMS".to_string(), Some(params_struct(model))),
                ("MODEL_EVAL".to_string(), Some(model.clone())),
                ("MODEL_SAMPLE".to_string(), Some(format!("sample_{model}"))),
                ("MODEL_PDF".to_string(), Some(format!("pdf_{model}"))),
            ];
            let defines: Vec<(&str, Option<&str>)> = defines
                .iter()
                .map(|(k, v)| (k.as_str(), v.as_deref()))
                .collect();
            let mut includes = Includes {
                root: root.clone(),
                model: model.clone(),
            };
            let result = ShaderInput::new(
                &source,
                ShaderStage::Compute,
                &options,
                Some(&defines[..]),
                Some(&mut includes),
            )
            .and_then(|input| glslang::Shader::new(compiler, input).parse())
            .and_then(|shader| shader.compile());
            match result {
                Ok(words) => {
                    let name = format!("{kernel}_{model}.spv");
                    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
                    std::fs::write(out_dir.join(&name), bytes).unwrap();
                    writeln!(table, "    (\"{kernel}\", \"{model}\", include_bytes!(concat!(env!(\"OUT_DIR\"), \"/{name}\"))),").unwrap();
                }
                Err(e) => failures.push(format!(
                    "glsl/kernels/{kernel}.comp with model glsl/brdf/{model}.glsl:\n{e}"
                )),
            }
        }
    }
    if !failures.is_empty() {
        for f in &failures {
            eprintln!("{f}");
        }
        panic!(
            "{} GLSL compilation(s) failed:\n{}",
            failures.len(),
            failures.join("\n")
        );
    }
    table.push_str("];\n");
    std::fs::write(out_dir.join("shaders.rs"), table).unwrap();
}
