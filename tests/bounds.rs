//! Bounded resources: inputs are streamed (a pairs file of 10⁷ rows through a pipe stays under a
//! memory ceiling; endless inputs are refused after a line or a scene's worth of bytes), every
//! size a user can ask for is refused before work starts with the flag and the limit in the
//! message, and the listed messages say what they should (stdout, a closed pipe).

use std::io::Write;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The exit status of a Rust panic: never acceptable here.
const PANIC_STATUS: i32 = 101;
/// A request that must be refused "at once": well under a second in practice; 5 s leaves room
/// for a loaded CI machine while still catching any attempt to allocate or evaluate.
const AT_ONCE: Duration = Duration::from_secs(5);
/// Rows of the streamed pairs file.
const STREAM_ROWS: usize = 10_000_000;
/// Peak resident memory allowed while streaming, bytes. Measured: ~17 MB (CSV) and ~22 MB
/// (JSON) on the CPU backend; all 10⁷ rows in memory would be ≥ 320 MB for the angles alone
/// (the unstreamed JSON writer reached 22 GB), so 96 MB separates the two with room for
/// allocator and thread-stack differences between machines.
const STREAM_CEILING_BYTES: u64 = 96 << 20;

fn lobe() -> Command {
    Command::new(env!("CARGO_BIN_EXE_lobe"))
}

/// The peak resident set (VmHWM) of a running process, bytes; None once it has gone.
fn peak_rss(pid: u32) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Streams `rows` pairs into `lobe eval --pairs -` from a thread, reading its output as it comes
/// and sampling its peak memory; returns (peak bytes, output bytes, the last output bytes,
/// exit status).
#[cfg(target_os = "linux")]
fn stream_eval(format: &str, rows: usize) -> (u64, u64, Vec<u8>, Option<i32>) {
    let mut child = lobe()
        .args([
            "eval",
            "--backend",
            "cpu",
            "--pairs",
            "-",
            "--format",
            format,
        ])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("running lobe");
    let pid = child.id();
    let mut stdin = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || {
        // 1000 distinct rows repeated: every line is parsed, checked and evaluated.
        let mut block = String::new();
        for k in 0..1000 {
            let (ti, to) = (k % 90, (k * 7) % 90);
            block.push_str(&format!("{ti},{},{to},{}\n", k % 360, (k * 3) % 360));
        }
        writeln!(stdin, "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg").unwrap();
        for _ in 0..rows / 1000 {
            stdin.write_all(block.as_bytes()).unwrap();
        }
    });
    let mut stdout = child.stdout.take().unwrap();
    let peak = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
    let sampler = {
        let peak = peak.clone();
        std::thread::spawn(move || {
            while let Some(p) = peak_rss(pid) {
                peak.fetch_max(p, std::sync::atomic::Ordering::Relaxed);
                std::thread::sleep(Duration::from_millis(20));
            }
        })
    };
    let (mut total, mut tail) = (0u64, Vec::new());
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = std::io::Read::read(&mut stdout, &mut buf).unwrap();
        if n == 0 {
            break;
        }
        total += n as u64;
        tail.extend_from_slice(&buf[..n]);
        if tail.len() > 4096 {
            tail.drain(..tail.len() - 4096);
        }
    }
    writer.join().unwrap();
    let status = child.wait().unwrap();
    sampler.join().unwrap();
    let peak = peak.load(std::sync::atomic::Ordering::Relaxed);
    (peak, total, tail, status.code())
}

#[cfg(target_os = "linux")]
#[test]
fn ten_million_pairs_stream_under_a_memory_ceiling() {
    for format in ["csv", "json"] {
        let (peak, total, tail, code) = stream_eval(format, STREAM_ROWS);
        assert_eq!(code, Some(0), "{format}: exit status");
        let tail = String::from_utf8_lossy(&tail);
        match format {
            "csv" => assert!(tail.ends_with("\n"), "csv ends with a whole row"),
            _ => assert!(tail.ends_with("\n  ]\n}\n"), "json document closed: {tail}"),
        }
        // Each output row holds at least its four angles and three values.
        assert!(
            total > STREAM_ROWS as u64 * 20,
            "{format}: {total} bytes out"
        );
        assert!(
            peak > 0 && peak < STREAM_CEILING_BYTES,
            "{format}: peak resident memory {peak} bytes, ceiling {STREAM_CEILING_BYTES}"
        );
        eprintln!("{format}: {STREAM_ROWS} rows, peak resident memory {peak} bytes");
    }
}

/// Runs lobe in `dir` and checks a refusal: non-zero status (not a panic), at once, every
/// needle in stderr, no file left in `dir`. Returns what is wrong, if anything.
fn refused(dir: &Path, args: &[&str], needles: &[&str]) -> Option<String> {
    let started = Instant::now();
    let out: Output = lobe()
        .args(args)
        .current_dir(dir)
        .output()
        .expect("running lobe");
    let took = started.elapsed();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let mut wrong = Vec::new();
    match out.status.code() {
        Some(0) => wrong.push("exit status 0".to_string()),
        Some(PANIC_STATUS) => wrong.push("exit status 101 (a panic)".to_string()),
        None => wrong.push("killed by a signal".to_string()),
        _ => {}
    }
    if took > AT_ONCE {
        wrong.push(format!("took {took:?}, not refused at once"));
    }
    for n in needles {
        if !stderr.contains(n) {
            wrong.push(format!("message lacks '{n}'"));
        }
    }
    let left: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .collect();
    if !left.is_empty() {
        wrong.push(format!("files left: {left:?}"));
    }
    (!wrong.is_empty()).then(|| {
        format!(
            "{args:?}: {}\n    stderr: {}",
            wrong.join("; "),
            stderr.trim()
        )
    })
}

/// A device that never ends (/dev/zero) is no input file: it is refused before a byte is read,
/// named as a device (a pairs file and a scene once read it up to their line or size bound).
#[test]
fn endless_inputs_are_refused_before_a_read() {
    if !Path::new("/dev/zero").exists() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let failures: Vec<String> = [
        (
            vec!["eval", "--backend", "cpu", "--pairs", "/dev/zero"],
            vec!["pairs file /dev/zero: a device"],
        ),
        (
            vec!["run", "/dev/zero", "--backend", "cpu"],
            vec!["scene /dev/zero: a device"],
        ),
    ]
    .iter()
    .filter_map(|(args, needles)| refused(dir.path(), args, needles))
    .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn a_byte_order_mark_before_the_header_is_accepted() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bom.csv");
    std::fs::write(
        &path,
        "\u{feff}theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg\r\n10,0,20,180\r\n",
    )
    .unwrap();
    let out = lobe()
        .args(["eval", "--backend", "cpu", "--pairs"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(text.lines().count(), 2, "{text}");
    assert!(
        text.lines().nth(1).unwrap().starts_with("10,0,20,180,"),
        "{text}"
    );
}

#[cfg(target_os = "linux")]
#[test]
fn a_full_stdout_is_named_and_a_closed_pipe_ends_quietly() {
    for args in [
        &["eval", "--backend", "cpu", "--wi", "30,0", "--wo", "30,180"][..],
        &["models"][..],
    ] {
        let full = std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap();
        let out = lobe().args(args).stdout(full).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(
            stderr.contains("writing to stdout") && stderr.contains("No space left"),
            "{args:?}: {stderr}"
        );
    }
    // A reader that closes the pipe at once, as `head -0` does, long before 10⁶ rows are out.
    let mut child = lobe()
        .args(["eval", "--backend", "cpu", "--pairs", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let mut stdin = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || {
        let _ = writeln!(stdin, "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg");
        for _ in 0..1_000_000 {
            if writeln!(stdin, "30,0,40,180").is_err() {
                break;
            }
        }
    });
    let out = child.wait_with_output().unwrap();
    writer.join().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(141), "closed pipe: {stderr}");
    assert!(stderr.is_empty(), "closed pipe must end quietly: {stderr}");
}

/// Every size a user can ask for is refused at once, naming the flag and the limit, with a
/// non-zero status and no file left.
#[test]
fn every_size_is_bounded_before_work_starts() {
    let dir = tempfile::tempdir().unwrap();
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec!["albedo", "--backend", "cpu", "--samples", "1000000000000"],
            vec!["--samples 1000000000000", "1048576"],
        ),
        (
            vec!["albedo", "--backend", "cpu", "--samples", "0"],
            vec!["--samples 0", "from 1 to 1048576"],
        ),
        (
            vec!["energy", "--backend", "cpu", "--samples", "1000000000000"],
            vec!["--samples", "1048576"],
        ),
        (
            vec!["energy", "--backend", "cpu", "--sweep", "1000000000"],
            vec!["--sweep 1000000000", "at most 1024"],
        ),
        (
            vec![
                "plot",
                "--kind",
                "albedo",
                "--backend",
                "cpu",
                "--samples",
                "1000000000000",
                "-o",
                "p.png",
            ],
            vec!["--samples", "1048576"],
        ),
        (
            vec!["bench", "--backend", "cpu", "--res", "100000,100000,100000"],
            vec!["--res", "at most 16777216"],
        ),
        (
            vec!["bench", "--backend", "cpu", "--repeats", "0"],
            vec!["--repeats 0", "from 1 to 1000"],
        ),
        (
            vec![
                "tradeoff",
                "--backend",
                "cpu",
                "--error-res",
                "2000,2000,4000",
                "--no-plot",
            ],
            vec!["--error-res", "at most 16777216"],
        ),
        (
            vec![
                "tradeoff",
                "--backend",
                "cpu",
                "--timing-res",
                "2000,2000,4000",
                "--no-plot",
            ],
            vec!["--timing-res", "at most 16777216"],
        ),
        (
            vec![
                "tradeoff",
                "--backend",
                "cpu",
                "--table-res",
                "100000",
                "--no-plot",
            ],
            vec!["--table-res", "at most 16777216"],
        ),
        (
            vec![
                "tradeoff",
                "--backend",
                "cpu",
                "--samples",
                "1000000000000",
                "--no-plot",
            ],
            vec!["--samples", "1048576"],
        ),
        (
            vec![
                "table",
                "--backend",
                "cpu",
                "--model",
                "lambert",
                "--grid",
                "isotropic",
                "--res",
                "60000000,1,1",
                "-o",
                "t.exr",
            ],
            vec![
                "--res 60000000,1,1",
                "60000000 x 1 pixels",
                "at most 4194304",
            ],
        ),
        (
            vec![
                "preview",
                "--backend",
                "cpu",
                "--cell",
                "4096",
                "-o",
                "p.png",
            ],
            vec!["--cell 4096", "at most 67108864"],
        ),
        (
            vec![
                "plot",
                "--backend",
                "cpu",
                "--model",
                "phong,lambert,cook_torrance,oren_nayar,blinn_phong,coupled,eon",
                "--theta-i-deg",
                "0,10,20,30,40,50,60,70",
                "-o",
                "p.png",
            ],
            vec!["56 curves", "at most 24", "--model"],
        ),
        (
            vec!["plot", "--backend", "cpu", "--decades", "0", "-o", "p.png"],
            vec!["--decades", "more than 0 and at most 30"],
        ),
    ];
    let failures: Vec<String> = cases
        .iter()
        .filter_map(|(args, needles)| refused(dir.path(), args, needles))
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A full disk while a plot is saved (the kernel's file-size limit with SIGXFSZ ignored: the
/// write fails as on a full disk, without root) reads as the operating system's sentence, not
/// as the debug text of the drawing library's error.
#[cfg(target_os = "linux")]
#[test]
fn a_failed_plot_save_reads_as_a_sentence() {
    let dir = tempfile::tempdir().unwrap();
    let bin = env!("CARGO_BIN_EXE_lobe");
    let out = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -f 16 && trap '' XFSZ && exec '{bin}' plot --backend cpu -o p.png"
        ))
        .current_dir(dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("writing p.png: File too large"), "{stderr}");
    assert!(
        !stderr.contains("IOError") && !stderr.contains("Os {"),
        "{stderr}"
    );
}

/// Without any Vulkan device, `lobe stability` points at `--backend cpu`, and that runs.
#[test]
fn stability_without_a_device_suggests_a_flag_it_takes() {
    let no_device = [
        ("VK_ICD_FILENAMES", "/nonexistent/icd.json"),
        ("VK_DRIVER_FILES", "/nonexistent/icd.json"),
    ];
    let out = lobe()
        .args(["stability", "--models", "lambert"])
        .envs(no_device)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && stderr.contains("--backend cpu"),
        "{stderr}"
    );
    let out = lobe()
        .args(["stability", "--models", "lambert", "--backend", "cpu"])
        .envs(no_device)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
