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
    assert_eq!(summary.written.len(), 3);
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
fn the_lab_is_the_seed_lab() {
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
        summary.written.len(),
        s.tables.len() + s.albedos.len() + s.previews.len()
    );
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
