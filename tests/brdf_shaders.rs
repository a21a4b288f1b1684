//! What a `.brdf` file's shader may hold. Helpers named like GLSL built-ins (as old desktop
//! GLSL allowed and BRDF Explorer files use) compile and are the ones the file's code calls.
//! The shader is untrusted code inside lobe's kernels: a resource of its own or one of lobe's
//! bindings, an image, a sampler, `shared` memory, a built-in input, a barrier, an atomic, a
//! huge array, NUL bytes, text that is not UTF-8 and ranges beyond f32 are refused with the
//! file, the line and the construct, through the library and the command line; a byte-order
//! mark is skipped.

mod common;

use glam::DVec3;
use lobe::brdf::{self, BrdfError, LoadOptions};
use lobe::gpu::Gpu;
use lobe::model::ParamSet;
use lobe::Evaluator;
use std::path::{Path, PathBuf};

/// The GPU's f32 result of a few additions and multiplications of values below 16: a few
/// roundings of at most 8 ulp of 16 each.
const F32_ABS: f64 = 4.0 * 16.0 * f32::EPSILON as f64;

/// The start of every test file: a parameter, then the shader from line 6 on.
const HEAD: &str =
    "analytic\n::begin parameters\nfloat a 0 1 0.5\n::end parameters\n::begin shader\n";
const SIG: &str = "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)";

/// A `.brdf` file with `shader` (from line 6), in a fresh directory kept as long as the value.
fn file_with(name: &str, shader: &str) -> (tempfile::TempDir, PathBuf) {
    let text = format!("{HEAD}{}\n::end shader\n", shader.replace("SIG", SIG));
    bytes_file(name, text.as_bytes())
}

fn bytes_file(name: &str, bytes: &[u8]) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    (dir, path)
}

fn load_err(path: &Path) -> BrdfError {
    match brdf::load(path, &LoadOptions::default()) {
        Err(e) => e,
        Ok(l) => panic!("{} loaded as {}", path.display(), l.model.name()),
    }
}

/// The helpers of a file named like built-ins: a prototype of `reflect` before its use and
/// its definition after; `mix` with a signature no built-in mix has; `normalize` with the
/// built-in's own; a call to `reflect` inside another helper. None is what GLSL's would give.
const BUILTIN_NAMES: &str = "vec3 reflect(vec3 I, vec3 N);
float mix(float a, float b) { return a * b; }
vec3 normalize(vec3 v) { return 2.0 * v; }
vec3 mirrored(vec3 v) { return reflect(v, vec3(0.0, 0.0, 1.0)); }
SIG {
    return normalize(mirrored(L)) + vec3(mix(V.z, 3.0)) + 5.0 * a;
}
vec3 reflect(vec3 I, vec3 N) { return N - I; }";

/// The closed form of [`BUILTIN_NAMES`] with the file's own helpers: 2 (n − L) + 3 V.z + 5a.
fn builtin_names_expected(wi: DVec3, wo: DVec3, a: f64) -> DVec3 {
    2.0 * (DVec3::Z - wi) + DVec3::splat(3.0 * wo.z + 5.0 * a)
}

#[test]
fn helpers_named_like_built_ins_are_the_files_own() {
    let (_dir, path) = file_with("builtins.brdf", BUILTIN_NAMES);
    let model = brdf::load(&path, &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .model;
    let Some(dev) = common::gpu_device("built-in names") else {
        return;
    };
    let gpu = Gpu::new(dev);
    let mut p = ParamSet::defaults(model);
    p.set_text("a=0.25").unwrap();
    let dir = |t: f64, ph: f64| {
        let (t, ph) = (t.to_radians(), ph.to_radians());
        let v = DVec3::new(t.sin() * ph.cos(), t.sin() * ph.sin(), t.cos());
        DVec3::new(v.x as f32 as f64, v.y as f32 as f64, v.z as f32 as f64)
    };
    let pairs = [
        (dir(0.0, 0.0), dir(0.0, 0.0)),
        (dir(30.0, 10.0), dir(60.0, 200.0)),
        (dir(75.0, 120.0), dir(20.0, 300.0)),
    ];
    let f = Evaluator::gpu(&gpu).eval_pairs(&p, &pairs).expect("gpu");
    for ((wi, wo), got) in pairs.iter().zip(f) {
        let want = builtin_names_expected(*wi, *wo, 0.25);
        for c in 0..3 {
            assert!(
                (got[c] - want[c]).abs() <= F32_ABS,
                "wi {wi} wo {wo} channel {c}: GPU {} vs the file's helpers {} (difference {:e}, allowed {F32_ABS:e})",
                got[c],
                want[c],
                (got[c] - want[c]).abs()
            );
        }
    }
    common::assert_validation_clean(&gpu, "built-in names");
}

#[test]
fn errors_in_a_file_with_built_in_names_keep_its_lines_and_names() {
    // The wrong call is on line 8; the message says 'reflect', as the file does.
    let (_dir, path) = file_with(
        "typo.brdf",
        "vec3 reflect(vec3 I, vec3 N) { return N - I; }\n\nSIG { return reflect(L); }",
    );
    let e = load_err(&path);
    let text = e.to_string();
    assert!(
        matches!(e, BrdfError::Compile { line: 8, .. })
            && text.contains("typo.brdf:8: 'reflect'")
            && !text.contains("lobe_"),
        "{text}"
    );
}

/// A character beyond ASCII in the code (not in a comment) is the compiler's error at its line.
#[test]
fn a_character_beyond_ascii_in_the_code_is_a_compile_error() {
    let (_dir, path) = file_with(
        "accent.brdf",
        "// é in a comment is fine\nSIG { return vec3(a); } é",
    );
    let e = load_err(&path);
    assert!(matches!(e, BrdfError::Compile { line: 7, .. }), "{e}");
}

/// One attack: its file name, shader (from line 6), and the line and words of the refusal.
struct Attack {
    name: &'static str,
    shader: &'static str,
    line: usize,
    words: &'static [&'static str],
}

const ONLY: &str = "may define functions and constants and read its parameters, nothing else";

fn attacks() -> Vec<Attack> {
    let buffer = |name, binding, words| Attack {
        name,
        shader: binding,
        line: 7,
        words,
    };
    vec![
        buffer(
            "ssbo9.brdf",
            "\nlayout(std430, set = 0, binding = 9) buffer Mine { float m[]; };\nSIG { m[0] = 1.0; return vec3(a); }",
            &["'Mine' declares a buffer block (uniform or storage buffer) at set 0, binding 9", ONLY],
        ),
        buffer(
            "ssbo0.brdf",
            "\nlayout(std430, set = 0, binding = 0) buffer Mine { float m[]; };\nSIG { m[0] = 7.0; return vec3(a); }",
            &["'Mine' declares a buffer block (uniform or storage buffer) at set 0, binding 0"],
        ),
        buffer(
            "ssbo3.brdf",
            "\nlayout(std430, set = 0, binding = 3) buffer Mine { float m[]; };\nSIG { m[0] = 12345.0; return vec3(a); }",
            &["'Mine' declares a buffer block (uniform or storage buffer) at set 0, binding 3"],
        ),
        buffer(
            "ssbo5.brdf",
            "\nlayout(std430, set = 0, binding = 5) buffer Mine { float m[]; };\nSIG { return vec3(m[0]); }",
            &["'Mine' declares a buffer block (uniform or storage buffer) at set 0, binding 5"],
        ),
        // A macro hides the word `buffer` from any look at the text.
        buffer(
            "macro.brdf",
            "#define B(n) layout(std430, binding = n) buff##er\nB(3) Mine { float m[]; };\nSIG { m[0] = 1.0; return vec3(a); }",
            &["'Mine' declares a buffer block (uniform or storage buffer) at set 0, binding 3"],
        ),
        buffer(
            "image.brdf",
            "\nlayout(set = 0, binding = 7, rgba32f) uniform image2D img;\nSIG { imageStore(img, ivec2(0), vec4(1)); return vec3(a); }",
            &["'img' declares an image, sampler or texture at set 0, binding 7", "the function 'BRDF' uses an image or sampler operation"],
        ),
        buffer(
            "sampler.brdf",
            "\nlayout(set = 0, binding = 8) uniform sampler2D tex;\nSIG { return textureLod(tex, vec2(0.5), 0.0).rgb; }",
            &["'tex' declares an image, sampler or texture at set 0, binding 8", "uses an image or sampler operation"],
        ),
        buffer(
            "shared.brdf",
            "\nshared float s[64];\nSIG { s[0] = a; return vec3(s[0]); }",
            &["'s' declares 'shared' memory"],
        ),
        // A built-in input lobe's kernels do not read.
        buffer(
            "input.brdf",
            "\nSIG { return vec3(gl_NumWorkGroups); }",
            &["'gl_NumWorkGroups' declares a shader input (built-in NumWorkgroups)"],
        ),
        // A pointer made from an integer (this one crashed the driver).
        Attack {
            name: "pointer.brdf",
            shader: "#extension GL_EXT_buffer_reference : require\n#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require\nlayout(buffer_reference) buffer P { float x; };\nSIG { P p = P(uint64_t(4096)); p.x = 1.0; return vec3(a); }",
            line: 6,
            words: &["the shader needs the SPIR-V capability", "which lobe's kernels do not use"],
        },
        // A barrier in a helper: the helper is named, at its line.
        buffer(
            "barrier.brdf",
            "\nvoid sync() { barrier(); }\nSIG { sync(); return vec3(a); }",
            &["the function 'sync' uses a barrier"],
        ),
        buffer(
            "atomic.brdf",
            "\nshared uint c;\nSIG { atomicAdd(c, 1u); return vec3(a); }",
            &["'c' declares 'shared' memory", "the function 'BRDF' uses an atomic operation"],
        ),
        Attack {
            name: "local.brdf",
            shader: "\n\nSIG { float big[100000000]; big[int(a * 9.0)] = a; return vec3(big[int(a * 3.0)]); }",
            line: 8,
            words: &["'big' alone 400000000", "at most 65536 (64 KiB)"],
        },
        buffer(
            "global.brdf",
            "\nfloat big[200000000];\nSIG { big[int(a * 9.0)] = a; return vec3(big[int(a * 3.0)]); }",
            &["'big' alone 800000000", "at most 65536 (64 KiB)"],
        ),
    ]
}

#[test]
fn what_a_shader_may_not_add_to_lobes_kernels_is_refused() {
    for attack in attacks() {
        let (_dir, path) = file_with(attack.name, attack.shader);
        let e = load_err(&path);
        let text = e.to_string();
        let at = format!("{}:{}: ", path.display(), attack.line);
        assert!(
            matches!(e, BrdfError::Refused { .. })
                && text.starts_with(&at)
                && attack.words.iter().all(|w| text.contains(w)),
            "{}: expected {at}{:?}, got {text}",
            attack.name,
            attack.words
        );
    }
}

/// A shader of 64 KiB of arrays is the most allowed; one float more is refused.
#[test]
fn per_invocation_memory_is_bounded_at_64_kib() {
    let (_dir, path) = file_with(
        "edge.brdf",
        "float big[16384 - 1];\nSIG { big[int(a)] = a; return vec3(big[0]); }",
    );
    // 16383 floats and the parameter `a`: 65536 bytes.
    brdf::load(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let (_dir, path) = file_with(
        "over.brdf",
        "float big[16384];\nSIG { big[int(a)] = a; return vec3(big[0]); }",
    );
    let text = load_err(&path).to_string();
    assert!(text.contains("take 65540 bytes"), "{text}");
}

/// Bytes that are not text: (file name, bytes, line and words of the error).
fn not_text() -> Vec<(&'static str, Vec<u8>, usize, &'static str)> {
    let good = format!("{HEAD}{SIG} {{ return vec3(a); }}\n::end shader\n").replace("SIG", SIG);
    vec![
        (
            "nul.brdf",
            good.replacen("return", "return\0", 1).into_bytes(),
            6,
            "a NUL byte at offset",
        ),
        (
            "utf8.brdf",
            good.replacen("return", "return \u{e9}", 1)
                .into_bytes()
                .into_iter()
                .map(|b| if b == 0xc3 { 0xff } else { b })
                .collect(),
            6,
            "not UTF-8 text",
        ),
        (
            "range.brdf",
            good.replace("float a 0 1 0.5", "float k 0 1e39 1e39")
                .replace("vec3(a)", "vec3(k)")
                .into_bytes(),
            3,
            "float 'k': MAX 1e39 is beyond the 32-bit floats",
        ),
    ]
}

#[test]
fn binary_files_and_ranges_beyond_f32_are_refused_and_a_bom_is_skipped() {
    for (name, bytes, line, words) in not_text() {
        let (_dir, path) = bytes_file(name, &bytes);
        let text = load_err(&path).to_string();
        let at = format!("{}:{line}: ", path.display());
        assert!(
            text.starts_with(&at) && text.contains(words),
            "{name}: expected {at}{words}, got {text}"
        );
    }
    let text = format!("\u{feff}{HEAD}{SIG} {{ return vec3(a); }}\n::end shader\n");
    let (_dir, path) = bytes_file("bom.brdf", text.as_bytes());
    let loaded = brdf::load(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(ParamSet::defaults(loaded.model).scalar("a"), 0.5);
}

/// Every `.brdf` lobe ships or tests with, other than those made to fail compiling, loads.
#[test]
fn the_shipped_files_still_load() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    for dir in ["data/brdf", "testdata/brdf", "testdata/brdf/bad"] {
        for entry in std::fs::read_dir(root.join(dir)).unwrap() {
            let path = entry.unwrap().path();
            let stem = path.file_stem().unwrap().to_string_lossy().into_owned();
            if brdf::is_brdf_path(&path.to_string_lossy())
                && !matches!(stem.as_str(), "typo" | "no_brdf")
            {
                files.push(path);
            }
        }
    }
    assert!(files.len() >= 7, "{files:?}");
    for path in files {
        brdf::load(&path, &LoadOptions::default())
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    }
}

#[test]
fn the_command_line_refuses_them_naming_file_and_construct() {
    if std::env::var("LOBE_SKIP_GPU").is_ok_and(|v| v == "1") {
        return;
    }
    let mut cases: Vec<(tempfile::TempDir, PathBuf, Vec<String>)> = attacks()
        .into_iter()
        .map(|a| {
            let (dir, path) = file_with(a.name, a.shader);
            let at = format!("{}:{}: ", path.display(), a.line);
            let words = std::iter::once(at)
                .chain(a.words.iter().map(|w| w.to_string()))
                .collect();
            (dir, path, words)
        })
        .collect();
    for (name, bytes, line, words) in not_text() {
        let (dir, path) = bytes_file(name, &bytes);
        let at = format!("{}:{line}: ", path.display());
        cases.push((dir, path, vec![at, words.to_string()]));
    }
    for (_dir, path, words) in &cases {
        let (rc, out, err) = common::lobe_run(&["albedo", "--model", path.to_str().unwrap()]);
        assert!(
            rc == 1 && out.is_empty() && words.iter().all(|w| err.contains(w.as_str())),
            "{}: exit {rc}, expected {words:?} on stderr, got {err}",
            path.display()
        );
    }
    let text = format!("\u{feff}{HEAD}{SIG} {{ return vec3(a); }}\n::end shader\n");
    let (_dir, path) = bytes_file("bom.brdf", text.as_bytes());
    let (rc, _, err) = common::lobe_run(&["albedo", "--model", path.to_str().unwrap()]);
    assert_eq!(rc, 0, "{err}");
    let (_dir, path) = file_with("builtins.brdf", BUILTIN_NAMES);
    let (rc, _, err) = common::lobe_run(&["albedo", "--model", path.to_str().unwrap()]);
    assert_eq!(rc, 0, "{err}");
}
