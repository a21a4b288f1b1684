//! Shared by the integration tests: the GPU policy and a small deterministic random generator.
#![allow(dead_code)]

use lobe::gpu::{Device, DeviceOptions, Gpu};

/// GPU tests do not hide: without a Vulkan device they fail with the install hint. They skip
/// only when LOBE_SKIP_GPU=1 is set (CI never sets it). Returns None when skipping.
pub fn gpu_device(test: &str) -> Option<Device> {
    open_device(test, device_options().gpu_kernels)
}

/// The device options the test environment asks for: LOBE_VALIDATION=1 turns the validation
/// layer on, LOBE_STAGING=1 runs every GPU test on the staging path of discrete GPUs, and
/// LOBE_GPU_KERNELS=1 with a GPU's kernel choices.
pub fn device_options() -> DeviceOptions {
    let on = |name: &str| std::env::var(name).is_ok_and(|v| v == "1");
    DeviceOptions {
        validation: on("LOBE_VALIDATION"),
        force_staging: on("LOBE_STAGING"),
        gpu_kernels: on("LOBE_GPU_KERNELS"),
        ..DeviceOptions::default()
    }
}

/// [`gpu_device`] with a GPU's kernel choices on any device (`DeviceOptions::gpu_kernels`): on
/// lavapipe, the only way to run the kernels' GPU variants.
pub fn gpu_device_with_gpu_kernels(test: &str) -> Option<Device> {
    open_device(test, true)
}

fn open_device(test: &str, gpu_kernels: bool) -> Option<Device> {
    if std::env::var("LOBE_SKIP_GPU").is_ok_and(|v| v == "1") {
        eprintln!("{test}: skipped because LOBE_SKIP_GPU=1");
        return None;
    }
    let opts = DeviceOptions {
        gpu_kernels,
        ..device_options()
    };
    match Device::open(&opts) {
        Ok(d) => Some(d),
        Err(e @ lobe::gpu::GpuError::NoValidationLayer) => {
            panic!("{test}: LOBE_VALIDATION=1 asks for the validation layer: {e}")
        }
        Err(e) => {
            panic!("{test} needs a Vulkan device: {e}\n(set LOBE_SKIP_GPU=1 to skip GPU tests)")
        }
    }
}

/// Runs `check` on the test environment's device, then asserts that the validation layer
/// stayed quiet; with `gpu_kernels`, with a GPU's kernel choices on any device
/// ([`gpu_device_with_gpu_kernels`]). Does nothing when GPU tests are skipped.
pub fn on_gpu(test: &str, gpu_kernels: bool, check: impl FnOnce(&Gpu)) {
    on_gpu_with(test, gpu_kernels, |gpu| gpu, check);
}

/// [`on_gpu`] with tables in chunks of about `bytes` of output, so that a small table runs in
/// several ([`Gpu::with_table_chunk_bytes`]).
pub fn on_gpu_in_chunks(test: &str, gpu_kernels: bool, bytes: u64, check: impl FnOnce(&Gpu)) {
    on_gpu_with(
        test,
        gpu_kernels,
        |gpu| gpu.with_table_chunk_bytes(bytes),
        check,
    );
}

fn on_gpu_with(
    test: &str,
    gpu_kernels: bool,
    configure: impl FnOnce(Gpu) -> Gpu,
    check: impl FnOnce(&Gpu),
) {
    let dev = if gpu_kernels {
        gpu_device_with_gpu_kernels(test)
    } else {
        gpu_device(test)
    };
    let Some(dev) = dev else {
        return;
    };
    let gpu = configure(Gpu::new(dev));
    check(&gpu);
    assert_validation_clean(&gpu, test);
}

/// A GPU [`lobe::Session`] with the test environment's options (LOBE_VALIDATION, LOBE_STAGING);
/// None when GPU tests are skipped, and a failure naming what is missing otherwise.
pub fn gpu_session(test: &str) -> Option<lobe::Session> {
    gpu_device(test)?;
    let opts = device_options();
    Some(
        lobe::Session::open(lobe::SessionOptions {
            validation: opts.validation,
            staging: opts.force_staging,
            ..lobe::SessionOptions::default()
        })
        .unwrap_or_else(|e| panic!("{test}: {e}")),
    )
}

/// With LOBE_VALIDATION=1 the validation layer must have reported nothing.
pub fn assert_validation_clean(gpu: &Gpu, test: &str) {
    let n = gpu.device().validation_messages();
    assert_eq!(
        n, 0,
        "{test}: the Vulkan validation layer reported {n} warnings or errors (see stderr)"
    );
}

/// SplitMix64 (Steele, Lea & Flood 2014): deterministic, so a failure reproduces.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    /// Log-uniform in [lo, hi], lo > 0.
    pub fn log_range(&mut self, lo: f64, hi: f64) -> f64 {
        (lo.ln() + (hi.ln() - lo.ln()) * self.uniform()).exp()
    }
}

/// Every value of `f` is ρ/π per channel within `rel` (relative): Lambert's closed form.
pub fn assert_rho_over_pi(f: &[[f64; 3]], rho: [f64; 3], rel: f64) {
    for v in f {
        for (c, r) in rho.into_iter().enumerate() {
            let want = r * std::f64::consts::FRAC_1_PI;
            assert!(
                (v[c] - want).abs() <= rel * want,
                "{v:?} vs {want} (rho {rho:?})"
            );
        }
    }
}

/// Runs the `lobe` binary with `args`, asserts that it succeeded (printing the arguments and its
/// stderr if not) and returns its stdout parsed as JSON.
pub fn lobe_json<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> serde_json::Value {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args(args)
        .output()
        .expect("run lobe");
    let shown: Vec<_> = args.iter().map(|a| a.as_ref().to_string_lossy()).collect();
    assert!(
        out.status.success(),
        "lobe {}: {}",
        shown.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
}

/// Runs the `lobe` binary with `args` from the crate's root: (exit code, stdout, stderr), the
/// code -1 when a signal ended it.
pub fn lobe_run<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> (i32, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lobe"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run lobe");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}
