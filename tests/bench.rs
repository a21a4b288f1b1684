//! `lobe bench` on the test environment's device.

mod common;

/// `lobe bench` says which driver it measured (throughput differs by driver version: Mesa 25's
/// lavapipe runs tables faster than Mesa 22's), in its table and in each JSON row: the driver's
/// own name and version string from the Vulkan driver properties, Mesa's release on lavapipe.
#[test]
fn bench_names_the_gpu_driver() {
    if common::gpu_device("bench_names_the_gpu_driver").is_none() {
        return;
    }
    let args = [
        "bench",
        "--res",
        "4,4,4",
        "--repeats",
        "1",
        "--tasks",
        "table",
        "--model",
        "lambert",
    ];
    let v = common::lobe_json(&[&args[..], &["--format", "json"]].concat());
    let rows = v.as_array().expect("a list of rows");
    for row in rows {
        let backend = row["backend"].as_str().unwrap_or_default();
        match backend.starts_with("gpu") {
            true => {
                let driver = row["driver"].as_str().unwrap_or_default();
                assert!(!driver.is_empty(), "{row}");
                if backend.contains("llvmpipe") {
                    assert!(driver.contains("Mesa"), "lavapipe's driver: {driver}");
                }
            }
            false => assert!(row["driver"].is_null(), "{row}"),
        }
    }
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args(args)
        .output()
        .expect("run lobe bench");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && text.contains(": driver "), "{text}");
}

/// The JSON rows of `lobe bench` timing one tiny table on the CPU reference of the models `models`
/// (`--model SPEC` or `--models LIST`).
fn cpu_table_rows(models: &[&str]) -> Vec<serde_json::Value> {
    let args = [
        "bench",
        "--res",
        "4,4,4",
        "--repeats",
        "1",
        "--tasks",
        "table",
        "--backend",
        "cpu",
        "--format",
        "json",
    ];
    let v = common::lobe_json(&[&args[..], models].concat());
    v.as_array().expect("a list of rows").clone()
}

/// A model spec with its own parameters (commas inside the braces) is one model to `lobe bench`,
/// as to every command that takes `--model`: the row names the model, a list splits only on the
/// commas outside braces, and the spec's own parameters are applied (a bad value among them is
/// refused, naming its key).
#[test]
fn bench_takes_a_model_with_its_own_parameters() {
    let spec = "microfacet{distribution=beckmann,masking=smith_separable,alpha=0.3}";
    let rows = cpu_table_rows(&["--model", spec]);
    assert_eq!(rows.len(), 1, "{rows:?}");
    assert_eq!(rows[0]["model"], "microfacet", "{rows:?}");
    let two = cpu_table_rows(&[
        "--models",
        "phong{shininess=50},lambert{albedo=0.5,0.4,0.3}",
    ]);
    let models: Vec<&str> = two.iter().map(|r| r["model"].as_str().unwrap()).collect();
    assert_eq!(models, ["phong", "lambert"], "{two:?}");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args([
            "bench",
            "--res",
            "4,4,4",
            "--repeats",
            "1",
            "--tasks",
            "table",
        ])
        .args(["--backend", "cpu", "--model", "phong{shininess=-1}"])
        .output()
        .expect("run lobe bench");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("shininess"), "{err}");
}

/// `--grid` times a table on the grid named, and the GPU row counts the table's cells apart from
/// its evaluations: a mirror-symmetric model's full table with NPHI_I a multiple of 4 evaluates a
/// quarter of its cells (docs/design.md §4.6); the CPU reference evaluates them all.
#[test]
fn bench_times_a_full_table_and_counts_its_copied_cells() {
    if common::gpu_device("bench_times_a_full_table_and_counts_its_copied_cells").is_none() {
        return;
    }
    let v = common::lobe_json(&[
        "bench",
        "--grid",
        "full",
        "--res",
        "2,8,3,4",
        "--repeats",
        "1",
        "--tasks",
        "table",
        "--model",
        "cook_torrance",
        "--format",
        "json",
    ]);
    let rows = v.as_array().expect("a list of rows");
    assert_eq!(rows.len(), 2, "{v}");
    for row in rows {
        let gpu = row["backend"]
            .as_str()
            .unwrap_or_default()
            .starts_with("gpu");
        let evaluated = if gpu { 48 } else { 192 };
        assert_eq!(
            (row["cells"].as_u64(), row["evaluations"].as_u64()),
            (Some(192), Some(evaluated)),
            "{row}"
        );
    }
}

/// `lobe bench --tasks chi2,light` times the sampling test and the lit sphere on each backend:
/// one row per task and backend, whose evaluations are the draws (2²² at θo = 45°) and the texel
/// terms (the 64² sphere's pixels inside the disc × the sky's 256 × 128 texels, counted here
/// from the view's own definition, docs/design.md §15.2), at positive rates.
#[test]
fn bench_times_the_sampling_test_and_the_lit_sphere() {
    if common::gpu_device("bench_times_the_sampling_test_and_the_lit_sphere").is_none() {
        return;
    }
    let v = common::lobe_json(&[
        "bench",
        "--model",
        "lambert",
        "--tasks",
        "chi2,light",
        "--repeats",
        "1",
        "--format",
        "json",
    ]);
    let rows = v.as_array().expect("a list of rows");
    let size = 64.0f64;
    let pixels = (0..64)
        .flat_map(|r| (0..64).map(move |c| (r, c)))
        .filter(|&(r, c)| {
            let x = -1.0 + (2.0 * c as f64 + 1.0) / size;
            let y = 1.0 - (2.0 * r as f64 + 1.0) / size;
            x * x + y * y < 1.0
        })
        .count() as u64;
    for backend in ["gpu", "cpu"] {
        for (task, evaluations) in [("chi2", 1u64 << 22), ("light", pixels * 256 * 128)] {
            let row = rows
                .iter()
                .find(|r| r["task"] == task && r["backend"].as_str().unwrap().starts_with(backend))
                .unwrap_or_else(|| panic!("no {task} row on {backend}: {rows:?}"));
            assert_eq!(row["evaluations"].as_u64(), Some(evaluations), "{row}");
            assert!(row["wall_per_s"].as_f64().unwrap() > 0.0, "{row}");
        }
    }
}
