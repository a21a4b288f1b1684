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
