//! Fuzzing of the `.brdf` reader, bounded so that it runs with every `cargo test`: the shipped
//! and test files, mutated (bytes cut, fragments and odd numbers inserted, lines repeated and
//! swapped, a BOM or a NUL put in), never make the parser or the compiler panic, and every
//! error names the file and a line that exists. `LOBE_FUZZ_SECONDS` sets the time each fuzz
//! test may take (default [`DEFAULT_SECONDS`]); the case counts bound it too.

use lobe::brdf::{self, BrdfError, LoadOptions, ParamType};
use proptest::prelude::*;
use std::path::Path;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// Wall time each fuzz test may take by default. Here the case counts end both tests first
/// (about a second in all); the bound keeps a slow machine's CI short.
const DEFAULT_SECONDS: u64 = 10;

/// Parser cases: enough to reach each seed with several mutations (a second or two here).
const PARSE_CASES: u32 = 4000;

/// Compiler cases: each compiles up to four kernels (about 0.1 s each on lavapipe's host).
const COMPILE_CASES: u32 = 40;

fn budget() -> Duration {
    let s = std::env::var("LOBE_FUZZ_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(DEFAULT_SECONDS);
    Duration::from_secs(s)
}

/// Every `.brdf` file lobe ships or tests with.
fn seeds() -> &'static [Vec<u8>] {
    static SEEDS: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
    SEEDS.get_or_init(|| {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut out = Vec::new();
        for dir in ["data/brdf", "testdata/brdf", "testdata/brdf/bad"] {
            let mut paths: Vec<_> = std::fs::read_dir(root.join(dir))
                .unwrap()
                .map(|e| e.unwrap().path())
                .filter(|p| p.extension().is_some_and(|e| e == "brdf"))
                .collect();
            paths.sort();
            out.extend(paths.iter().map(|p| std::fs::read(p).unwrap()));
        }
        assert!(out.len() >= 8, "{} seed files", out.len());
        out
    })
}

/// Text the mutations put in: the format's own words, GLSL, numbers beyond f32, odd bytes.
const FRAGMENTS: &[&str] = &[
    "analytic\n",
    "::begin parameters\n",
    "::end parameters\n",
    "::begin shader\n",
    "::end shader\n",
    "::begin\n",
    "float k 0 1e39 1e39\n",
    "float k -1e39 0 0\n",
    "float k 0 3.4028236e38 1\n",
    "float k 1e-50 1 1e-50\n",
    "float k nan 1 0\n",
    "color c 1 1 1\n",
    "bool b 1\n",
    "#",
    "# comment\n",
    "\u{feff}",
    "\0",
    "\r\n",
    "{",
    "}",
    "/*",
    "*/",
    "vec3 reflect(vec3 I, vec3 N) { return I; }\n",
    "layout(std430, binding = 3) buffer B { float m[]; };\n",
    "shared float s[8];\n",
    "float big[100000000];\n",
    "barrier();",
    "#define buffer\n",
    "1e39",
    "é",
];

#[derive(Clone, Debug)]
enum Mutation {
    Cut { at: usize, len: usize },
    Insert { at: usize, fragment: usize },
    Byte { at: usize, byte: u8 },
    RepeatLine { line: usize },
    SwapLines { a: usize, b: usize },
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 0usize..64).prop_map(|(at, len)| Mutation::Cut { at, len }),
        (any::<usize>(), 0..FRAGMENTS.len())
            .prop_map(|(at, fragment)| Mutation::Insert { at, fragment }),
        (any::<usize>(), any::<u8>()).prop_map(|(at, byte)| Mutation::Byte { at, byte }),
        any::<usize>().prop_map(|line| Mutation::RepeatLine { line }),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::SwapLines { a, b }),
    ]
}

fn apply(seed: &[u8], mutations: &[Mutation]) -> Vec<u8> {
    let mut bytes = seed.to_vec();
    for m in mutations {
        let n = bytes.len() + 1;
        match *m {
            Mutation::Cut { at, len } => {
                let at = at % n;
                let end = (at + len).min(bytes.len());
                bytes.drain(at..end);
            }
            Mutation::Insert { at, fragment } => {
                let at = at % n;
                bytes.splice(at..at, FRAGMENTS[fragment].bytes());
            }
            Mutation::Byte { at, byte } => {
                if !bytes.is_empty() {
                    let at = at % bytes.len();
                    bytes[at] = byte;
                }
            }
            Mutation::RepeatLine { line } | Mutation::SwapLines { a: line, .. } => {
                let mut lines: Vec<Vec<u8>> =
                    bytes.split(|&b| b == b'\n').map(<[u8]>::to_vec).collect();
                let k = line % lines.len();
                match *m {
                    Mutation::SwapLines { b, .. } => {
                        let j = b % lines.len();
                        lines.swap(k, j);
                    }
                    _ => lines.insert(k, lines[k].clone()),
                }
                bytes = lines.join(&b'\n');
            }
        }
    }
    bytes
}

fn case() -> impl Strategy<Value = Vec<u8>> {
    (
        0..seeds().len(),
        proptest::collection::vec(mutation(), 1..6),
    )
        .prop_map(|(seed, mutations)| apply(&seeds()[seed], &mutations))
}

/// A seed with only its shader section mutated (the whole file where it has none), so that
/// most cases reach the compiler and the SPIR-V check.
fn shader_case() -> impl Strategy<Value = Vec<u8>> {
    (
        0..seeds().len(),
        proptest::collection::vec(mutation(), 1..4),
    )
        .prop_map(|(seed, mutations)| {
            let seed = &seeds()[seed];
            let find = |what: &[u8]| seed.windows(what.len()).position(|w| w == what);
            match (find(b"::begin shader\n"), find(b"::end shader")) {
                (Some(begin), Some(end)) if begin + 15 <= end => {
                    let body = apply(&seed[begin + 15..end], &mutations);
                    [&seed[..begin + 15], &body[..], &seed[end..]].concat()
                }
                _ => apply(seed, &mutations),
            }
        })
}

/// The parser's answer to `text` is well-formed: a file whose parameters keep their contract,
/// or an error naming the file and one of its lines.
fn check_parse(text: &str) -> Result<(), TestCaseError> {
    let lines = text.split('\n').count().max(1);
    match brdf::parse("fuzz.brdf", text) {
        Ok(f) => {
            prop_assert!(f.shader_line >= 2 && f.shader_line <= lines + 1);
            prop_assert!(!f.shader.contains('\0'));
            for p in &f.params {
                if let ParamType::Float { min, max, default } = p.kind {
                    prop_assert!(min <= default && default <= max);
                    prop_assert!(min.abs() <= f32::MAX as f64 && max.abs() <= f32::MAX as f64);
                }
            }
        }
        Err(e @ BrdfError::Parse { line, .. }) => {
            let shown = e.to_string();
            prop_assert!(
                line >= 1 && line <= lines,
                "line {line} of {lines}: {shown}"
            );
            prop_assert!(
                shown.starts_with(&format!("fuzz.brdf:{line}: ")) && shown.len() > 14,
                "{shown}"
            );
        }
        Err(e) => prop_assert!(false, "{e}"),
    }
    Ok(())
}

fn start() -> Instant {
    static START: OnceLock<Instant> = OnceLock::new();
    *START.get_or_init(Instant::now)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: PARSE_CASES, failure_persistence: None, ..ProptestConfig::default() })]

    /// Mutated files, read as text (bytes that are not UTF-8 replaced): the parser answers.
    #[test]
    fn mutated_files_parse_or_fail_with_file_and_line(bytes in case()) {
        if start().elapsed() > budget() {
            return Ok(());
        }
        check_parse(&String::from_utf8_lossy(&bytes))?;
    }
}

/// Files with a mutated shader through the whole reader and compiler (bytes as they are, so
/// NULs and invalid UTF-8 reach it): a model, or an error naming the file and a line; never a
/// panic.
#[test]
fn mutated_files_load_or_fail_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let begun = Instant::now();
    let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig {
        cases: COMPILE_CASES,
        failure_persistence: None,
        ..ProptestConfig::default()
    });
    let count = std::cell::Cell::new(0);
    // Cases that reached the compiler (a model, a compile error or a refusal).
    let compiled = std::cell::Cell::new(0);
    runner
        .run(&shader_case(), |bytes| {
            if begun.elapsed() > budget() {
                return Ok(());
            }
            count.set(count.get() + 1);
            let path = dir.path().join(format!("m{}.brdf", count.get()));
            std::fs::write(&path, &bytes).unwrap();
            let lines = bytes.split(|&b| b == b'\n').count();
            let shown = path.display().to_string();
            let result = brdf::load(&path, &LoadOptions::default());
            if !matches!(
                result,
                Err(BrdfError::Parse { .. } | BrdfError::Read { .. })
            ) {
                compiled.set(compiled.get() + 1);
            }
            match result {
                Ok(_) => {}
                Err(
                    e @ (BrdfError::Parse { line, .. }
                    | BrdfError::Compile { line, .. }
                    | BrdfError::Refused { line, .. }),
                ) => {
                    let text = e.to_string();
                    prop_assert!(line >= 1 && line <= lines, "line {line} of {lines}: {text}");
                    prop_assert!(text.starts_with(&format!("{shown}:{line}: ")), "{text}");
                }
                Err(e) => prop_assert!(false, "{e}"),
            }
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{e}"));
    // Most files stay readable: the compiler and the SPIR-V check were reached.
    assert!(
        compiled.get() * 2 >= count.get(),
        "{} of {} cases reached the compiler",
        compiled.get(),
        count.get()
    );
    eprintln!(
        "{} of {} cases reached the compiler",
        compiled.get(),
        count.get()
    );
}
