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
