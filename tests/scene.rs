//! Scenes: parsing, located errors, automatic grids, the pipelines a run builds, the lab, and a
//! property test that the parser never panics on arbitrary input (nor does `--set`'s parser).

mod common;

use lobe::gpu::Gpu;
use lobe::grid::Grid;
use lobe::scene::{self, Outputs};
use lobe::{Evaluator, Model, ParamSet};
use proptest::prelude::*;
use std::path::Path;

const LAB: &str = include_str!("../data/scenes/lab.toml");

/// The Ctrl-C flag is process-wide: tests that run scenes hold this lock so that the interrupt
/// test cannot stop them.
static RUN_LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn run_lock() -> std::sync::MutexGuard<'static, ()> {
    RUN_LOCK.lock().unwrap_or_else(|e| e.into_inner())
}

/// A scene of three materials over two models, tables only.
const TWO_MODELS: &str = r#"
name = "two"
[[materials]]
name = "a"
model = "lambert"
params = { albedo = [0.2, 0.4, 0.6] }
[[materials]]
name = "b"
model = "cook_torrance"
params = { roughness = 0.2 }
[[materials]]
name = "c"
model = "cook_torrance"
preset = "gold"
[[tables]]
material = "a"
n_theta = 4
n_phi = 8
output = "a.exr"
[[tables]]
material = "b"
n_theta = 4
n_phi = 8
output = "b.exr"
[[tables]]
material = "c"
n_theta = 4
n_phi = 8
output = "sub/c.exr"
"#;

#[test]
fn a_scene_with_two_models_builds_exactly_two_pipelines() {
    let Some(dev) = common::gpu_device("scene pipelines") else {
        return;
    };
    let _lock = run_lock();
    let gpu = Gpu::new(dev);
    let s = scene::parse(TWO_MODELS, "two.toml").unwrap_or_else(|e| panic!("{e}"));
    let dir = tempfile::tempdir().unwrap();
    let summary = s
        .run(&Evaluator::gpu(&gpu), dir.path(), Outputs::ALL, &mut |_| {})
        .unwrap();
    assert_eq!(summary.lines.len(), 3);
    assert_eq!(summary.written.len(), 9, "three tables of three files each");
    let built = gpu.built_pipelines();
    let labels: Vec<&str> = built.iter().map(|(l, _)| l.as_str()).collect();
    assert_eq!(built.len(), 2, "built: {labels:?}");
    for f in [
        "a.exr",
        "a.npy",
        "a.json",
        "b.exr",
        "sub/c.exr",
        "sub/c.npy",
    ] {
        assert!(dir.path().join(f).is_file(), "{f} missing");
    }
    common::assert_validation_clean(&gpu, "scene pipelines");
}

/// grid = "halfdiff" gives the three-axis half/difference grid to an isotropic material and the
/// four-axis one to an anisotropic one, with n_theta and n_phi as on the other grids.
#[test]
fn halfdiff_tables_follow_the_materials_isotropy() {
    let text = LAB.to_string()
        + "\n[[tables]]\nmaterial = \"gold\"\ngrid = \"halfdiff\"\nn_theta = 6\nn_phi = 8\noutput = \"hd/gold.exr\"\n"
        + "\n[[tables]]\nmaterial = \"tin\"\ngrid = \"halfdiff\"\nn_theta = 6\nn_phi = 8\noutput = \"hd/tin.exr\"\n";
    let s = scene::parse(&text, "lab.toml").unwrap_or_else(|e| panic!("{e}"));
    let grids: Vec<Grid> = s.tables.iter().rev().take(2).map(|t| t.grid).collect();
    assert_eq!(
        grids,
        [
            Grid::HalfDiffFull {
                n_theta_h: 6,
                n_phi_h: 8,
                n_theta_d: 6,
                n_phi_d: 8
            },
            Grid::HalfDiff {
                n_theta_h: 6,
                n_theta_d: 6,
                n_phi_d: 4
            }
        ]
    );
}

#[test]
fn isotropic_materials_get_the_isotropic_grid() {
    let s = scene::parse(LAB, "lab.toml").unwrap();
    for t in &s.tables {
        let m = &s.materials[t.material];
        match t.grid {
            Grid::Isotropic { .. } => assert!(m.params.is_isotropic(), "{}", m.name),
            Grid::Full { .. } => assert!(!m.params.is_isotropic(), "{}", m.name),
            other => panic!("{}: the scene's auto grid gave {}", m.name, other.name()),
        }
    }
    // tin's Ashikhmin-Shirley preset is brushed (nu != nv): the lab has one of each.
    assert!(s.tables.iter().any(|t| matches!(t.grid, Grid::Full { .. })));
    assert!(s
        .tables
        .iter()
        .any(|t| matches!(t.grid, Grid::Isotropic { .. })));
}

#[test]
fn the_lab_scene_is_the_lab_reports() {
    let s = scene::parse(LAB, "lab.toml").unwrap();
    let names: Vec<&str> = s.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["tin", "gold", "glazed_ceramic", "granite"]);
    let lights: Vec<[f64; 3]> = s.lights.iter().map(|l| l.position.to_array()).collect();
    assert_eq!(
        lights,
        [
            [0.0, 0.0, 1.0],
            [0.0, 1.0, 1.0],
            [1.0, 0.0, 1.0],
            [-1.0, 0.0, 1.0]
        ]
    );
    assert_eq!(s.camera_position.to_array(), [0.0; 3]);
    assert_eq!(s.ambient.to_array(), [0.0; 3]);
    assert_eq!(
        s.materials[3].params.model(),
        Model::OrenNayar,
        "granite is Oren-Nayar"
    );
    // The lab's preview matches `lobe preview`'s own lab set-up exactly.
    let p = &s.previews[0];
    let from_scene = s.preview_scene(p.cell, p.shape).unwrap();
    let lab = lobe::preview::Scene::lab(
        p.cell,
        p.shape,
        lobe::preview::LightKind::Point,
        glam::DVec3::ZERO,
    );
    assert_eq!(from_scene, lab);
}

#[test]
fn the_lab_runs_on_the_cpu_with_every_output() {
    let _lock = run_lock();
    let s = scene::parse(LAB, "lab.toml").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let summary = s
        .run(&Evaluator::cpu(), dir.path(), Outputs::ALL, &mut |_| {})
        .unwrap();
    assert_eq!(
        summary.lines.len(),
        s.tables.len() + s.albedos.len() + s.previews.len()
    );
    // Every file is counted once: a table's .exr, .npy and .json, an albedo's .json, a
    // preview's .png and .exr; and the files on disk are exactly those.
    assert_eq!(
        summary.written.len(),
        3 * s.tables.len() + s.albedos.len() + 2 * s.previews.len()
    );
    let mut on_disk = walk(dir.path());
    on_disk.sort();
    let mut written = summary.written.clone();
    written.sort();
    assert_eq!(written, on_disk);
    // The gold albedo JSON: E at the scene's view directions, and the hemispherical albedo.
    let gold: serde_json::Value =
        serde_json::from_reader(std::fs::File::open(dir.path().join("albedo/gold.json")).unwrap())
            .unwrap();
    assert_eq!(gold["material"], "gold");
    assert_eq!(gold["model"], "cook_torrance");
    let points = gold["points"].as_array().unwrap();
    assert_eq!(points.len(), scene::ALBEDO_MU.len());
    for p in points {
        let e = p["albedo"][0].as_f64().unwrap();
        // A passive material reflects between nothing and everything (Cook-Torrance's
        // V-cavity loses energy, never gains it, under the gold preset's Schlick F <= 1).
        assert!(e > 0.0 && e < 1.0, "{p}");
    }
    let t = lobe::table::read_npy(&dir.path().join("tables/gold.npy")).unwrap();
    assert_eq!(t.shape, vec![32, 32, 32, 3]);
    // No temporary file is left behind.
    for entry in walk(dir.path()) {
        assert!(
            !entry.to_string_lossy().contains(".partial"),
            "left behind: {}",
            entry.display()
        );
    }
}

fn walk(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}

/// An interrupted table run (Ctrl-C sets the same flag) stops with "interrupted" and leaves
/// neither output nor temporary file.
#[test]
fn an_interrupted_run_leaves_nothing() {
    let _lock = run_lock();
    let s = scene::parse(TWO_MODELS, "two.toml").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let token = lobe::CancelToken::new();
    token.cancel();
    let r = s.run(
        &Evaluator::cpu().with_cancel(&token),
        dir.path(),
        Outputs::ALL,
        &mut |_| {},
    );
    let e = r.expect_err("an interrupted run must fail");
    assert!(format!("{e:#}").contains("interrupted"), "{e:#}");
    assert!(walk(dir.path()).is_empty(), "{:?}", walk(dir.path()));
}

#[test]
fn errors_name_the_line_and_column() {
    let text = "name = \"x\"\n[[materials]]\nname = \"m\"\nmodel = \"cook_torrance\"\nparams = { roughness = 7 }\n";
    let e = scene::parse(text, "x.toml").unwrap_err();
    assert_eq!((e.line, e.column), (5, 24), "{e}");
    assert!(e.to_string().starts_with("x.toml:5:24: "), "{e}");
    assert!(e.message.contains("roughness"), "{e}");
}

/// `lobe run --output-dir` makes a folder that does not exist, with its parents, and its count
/// of files written is the count of files on disk.
#[test]
fn lobe_run_makes_the_output_folder_and_counts_every_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("two.toml"), TWO_MODELS).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args([
            "run",
            "two.toml",
            "--output-dir",
            "new/dir",
            "--backend",
            "cpu",
        ])
        .current_dir(dir.path())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let files = walk(&dir.path().join("new/dir"));
    assert_eq!(files.len(), 9, "{files:?}");
    assert!(
        stdout.contains(&format!("lobe: {} files written", files.len())),
        "{stdout}"
    );
}

const ISOTROPIC_TABLE: &str = r#"
[[materials]]
name = "gold"
model = "cook_torrance"
preset = "gold"
[[materials]]
name = "tin"
model = "ashikhmin_shirley"
preset = "tin"
"#;

fn one_table(keys: &str) -> Result<scene::Scene, scene::SceneError> {
    let text = format!("{ISOTROPIC_TABLE}[[tables]]\n{keys}\noutput = \"t.exr\"\n");
    scene::parse(&text, "t.toml")
}

/// n_phi counts cells over [0, 360 deg) on every grid; the isotropic grid's dphi axis covers
/// [0, 180 deg], so it takes n_phi / 2 cells (the same step) unless n_dphi gives its cells, and
/// the job says which.
#[test]
fn the_isotropic_grid_takes_n_dphi_or_half_of_n_phi_and_says_so() {
    let s = one_table("material = \"gold\"\nn_theta = 8\nn_phi = 64").unwrap();
    let t = &s.tables[0];
    assert_eq!(
        t.grid,
        Grid::Isotropic {
            n_theta_i: 8,
            n_theta_o: 8,
            n_dphi: 32
        }
    );
    for part in [
        "grid = \"auto\" and 'gold' is isotropic",
        "dphi: 32 cells over [0, 180 deg], half of n_phi = 64",
        "5.625 deg step",
    ] {
        assert!(t.resolution.contains(part), "{}", t.resolution);
    }

    let s = one_table("material = \"gold\"\nn_theta = 8\nn_dphi = 64").unwrap();
    let t = &s.tables[0];
    assert_eq!(
        t.grid,
        Grid::Isotropic {
            n_theta_i: 8,
            n_theta_o: 8,
            n_dphi: 64
        }
    );
    assert!(
        t.resolution
            .contains("dphi: 64 cells over [0, 180 deg] (n_dphi = 64)"),
        "{}",
        t.resolution
    );

    // On the three-axis halfdiff grid n_dphi gives phi_d's cells.
    let s = one_table("material = \"gold\"\ngrid = \"halfdiff\"\nn_theta = 4\nn_dphi = 6").unwrap();
    assert_eq!(
        s.tables[0].grid,
        Grid::HalfDiff {
            n_theta_h: 4,
            n_theta_d: 4,
            n_phi_d: 6
        }
    );

    // Without either key: 64 over the full circle, so 32 over the half circle.
    let s = one_table("material = \"gold\"\nn_theta = 4").unwrap();
    assert_eq!(s.tables[0].grid.shape(), vec![4, 4, 32]);
    assert!(s.tables[0].resolution.contains("n_phi = 64 by default"));

    // The full grid keeps n_phi as given.
    let s = one_table("material = \"tin\"\nn_theta = 4\nn_phi = 8").unwrap();
    assert_eq!(s.tables[0].grid.shape(), vec![4, 8, 4, 8]);
    assert!(
        s.tables[0]
            .resolution
            .contains("phi_i, phi_o: 8 cells each over [0, 360 deg) (n_phi = 8)"),
        "{}",
        s.tables[0].resolution
    );
}

/// A resolution that no rule can honour as written is refused, at the key, never changed.
#[test]
fn azimuth_keys_that_cannot_be_honoured_are_refused() {
    let cases = [
        (
            "material = \"gold\"\nn_phi = 63",
            (12, 9),
            vec!["n_phi = 63 is odd", "n_dphi"],
        ),
        (
            "material = \"gold\"\nn_phi = 64\nn_dphi = 32",
            (12, 9),
            vec!["both given", "one azimuth axis"],
        ),
        (
            "material = \"tin\"\nn_dphi = 32",
            (12, 10),
            vec!["n_dphi = 32", "'tin' is anisotropic", "give n_phi"],
        ),
        (
            "material = \"gold\"\ngrid = \"full\"\nn_dphi = 32",
            (13, 10),
            vec!["n_dphi = 32", "full grid", "give n_phi"],
        ),
        (
            "material = \"gold\"\nn_dphi = 0",
            (12, 10),
            vec!["n_dphi = 0", "at least 1"],
        ),
    ];
    for (keys, (line, column), needles) in cases {
        let e = one_table(keys).expect_err(keys);
        assert_eq!((e.line, e.column), (line, column), "{keys}: {e}");
        for n in needles {
            assert!(e.message.contains(n), "{keys}: {e}");
        }
    }
}

/// The run's log line of a table states the resolution used and why.
#[test]
fn a_tables_log_line_states_its_resolution() {
    let _lock = run_lock();
    let s = one_table("material = \"gold\"\nn_theta = 2\nn_phi = 8").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mut lines = Vec::new();
    s.run(&Evaluator::cpu(), dir.path(), Outputs::ALL, &mut |l| {
        lines.push(l.to_string())
    })
    .unwrap();
    assert_eq!(lines.len(), 1);
    assert!(
        lines[0].contains("isotropic grid [2, 2, 4]")
            && lines[0].contains("dphi: 4 cells over [0, 180 deg], half of n_phi = 8"),
        "{}",
        lines[0]
    );
}

/// Two materials of one model (microfacet, two distributions) share one column labelled once,
/// each drawn with its own parameters; a model listed twice is refused.
#[test]
fn a_preview_has_one_column_per_model() {
    let _lock = run_lock();
    let text = r#"
[[lights]]
position = [0.0, 0.0, 1.0]
[[materials]]
name = "smooth"
model = "microfacet"
params = { distribution = "ggx", alpha = 0.2 }
[[materials]]
name = "rough"
model = "microfacet"
params = { distribution = "beckmann", alpha = 0.5 }
[[previews]]
cell = 8
output = "p.png"
"#;
    let s = scene::parse(text, "p.toml").unwrap_or_else(|e| panic!("{e}"));
    let p = &s.previews[0];
    let names: Vec<&str> = p.models.iter().map(|m| m.name()).collect();
    assert_eq!(names, ["microfacet"]);
    let sheet = s.sheet(p).unwrap();
    assert_eq!(sheet.params.len(), 1);
    for (row, m) in s.materials.iter().enumerate() {
        assert_eq!(sheet.params[0][row], m.params, "{}", m.name);
    }
    // The EXR header lists the columns as the PNG labels them.
    let dir = tempfile::tempdir().unwrap();
    s.run(&Evaluator::cpu(), dir.path(), Outputs::ALL, &mut |_| {})
        .unwrap();
    let image = exr::prelude::read_first_flat_layer_from_file(dir.path().join("p.exr")).unwrap();
    let columns: Vec<String> = image
        .layer_data
        .attributes
        .other
        .iter()
        .filter(|(k, _)| *k == "lobe.columns")
        .map(|(_, v)| match v {
            exr::meta::attribute::AttributeValue::Text(t) => t.to_string(),
            other => panic!("lobe.columns is {other:?}"),
        })
        .collect();
    assert_eq!(columns, ["microfacet"]);

    let twice = text.replace("cell = 8", "models = [\"microfacet\", \"microfacet\"]");
    let e = scene::parse(&twice, "p.toml").unwrap_err();
    assert_eq!((e.line, e.column), (13, 25), "{e}");
    assert!(e.message.contains("listed twice"), "{e}");
}

fn arbitrary_toml_like() -> impl Strategy<Value = String> {
    // Fragments of real scenes spliced with noise: reaches deeper into the parser than bytes.
    let pieces = prop::collection::vec(
        prop_oneof![
            Just("[[materials]]\n".to_string()),
            Just("[[tables]]\n".to_string()),
            Just("[[previews]]\n".to_string()),
            Just("[[lights]]\n".to_string()),
            Just("[camera]\n".to_string()),
            Just("name = \"m\"\n".to_string()),
            Just("model = \"cook_torrance\"\n".to_string()),
            Just("model = \"ashikhmin_shirley\"\n".to_string()),
            Just("preset = \"gold\"\n".to_string()),
            Just("material = \"m\"\n".to_string()),
            Just("output = \"t.exr\"\n".to_string()),
            Just("output = \"p.png\"\n".to_string()),
            Just("grid = \"isotropic\"\n".to_string()),
            Just("position = [0.0, 1.0, 1.0]\n".to_string()),
            Just("params = { nu = 1e5, nv = 0 }\n".to_string()),
            (any::<i64>()).prop_map(|n| format!("n_theta = {n}\n")),
            (any::<i64>()).prop_map(|n| format!("n_phi = {n}\n")),
            (any::<i64>()).prop_map(|n| format!("cell = {n}\n")),
            (any::<f64>()).prop_map(|x| format!("params = {{ roughness = {x:?} }}\n")),
            (any::<f64>()).prop_map(|x| format!("ambient = {x:?}\n")),
            "[ -~\n]{0,40}",
        ],
        0..24,
    );
    pieces.prop_map(|v| v.concat())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    /// The scene parser returns Ok or a located error on any text; it never panics.
    #[test]
    fn scene_parser_never_panics(text in "\\PC{0,200}") {
        if let Err(e) = scene::parse(&text, "fuzz.toml") {
            prop_assert!(e.line >= 1 && e.column >= 1);
        }
    }

    #[test]
    fn scene_parser_never_panics_on_scene_like_text(text in arbitrary_toml_like()) {
        if let Err(e) = scene::parse(&text, "fuzz.toml") {
            prop_assert!(e.line >= 1 && e.line <= text.lines().count().max(1) + 1, "{}", e);
            prop_assert!(!e.message.is_empty());
        }
    }

    /// `--set`'s parser returns Ok or an error on any text, for every model; it never panics,
    /// and what it accepts is in range.
    #[test]
    fn set_parser_never_panics(text in "\\PC{0,60}", model in 0usize..Model::ALL.len()) {
        let model = Model::ALL[model];
        let mut p = ParamSet::defaults(model);
        if p.set_text(&text).is_ok() {
            for spec in model.params() {
                for v in p.get(spec.key).numbers() {
                    prop_assert!(v.is_finite());
                    prop_assert!(spec.check(v).is_ok(), "{} = {v}", spec.key);
                }
            }
        }
    }

    #[test]
    fn set_parser_never_panics_on_key_value_like_text(
        key in prop_oneof![Just("roughness".to_string()), Just("albedo".to_string()), Just("nu".to_string()), Just("ior".to_string()), Just("distribution".to_string()), Just("alpha_x".to_string()), "[a-z_]{0,12}"],
        value in prop_oneof![
            any::<f64>().prop_map(|x| format!("{x}")),
            (any::<f64>(), any::<f64>(), any::<f64>()).prop_map(|(a, b, c)| format!("{a},{b},{c}")),
            "[-0-9.,eE+ a-z]{0,30}",
        ],
        model in 0usize..Model::ALL.len(),
    ) {
        let mut p = ParamSet::defaults(Model::ALL[model]);
        let _ = p.set_text(&format!("{key}={value}"));
    }
}
