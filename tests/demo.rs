//! `lobe demo`: the real command on the GPU (full settings) and on the CPU (`--quick`), then the
//! page is read back: every file it references exists and is not empty, every PNG decodes at the
//! size the page gives it, the albedo numbers on the page are those in the JSON files, and the
//! Lambert rows equal the material's albedo (closed form: E = ρ). A failed run leaves nothing.

mod common;

use lobe::demo::{self, Progress, Settings, Step, INDEX, MATERIALS, PLOT_SIZE};
use lobe::model::Model;
use lobe::{material, Evaluator};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The page prints RGB values with four decimals: a shown value is within half a unit of the
/// last digit of the JSON's, plus room for the binary-to-decimal rounding of that half unit.
const DISPLAY_ROUNDING: f64 = 0.5e-4 + 1e-12;

/// Lambert's E is its albedo ρ exactly (docs/design.md §5). The peak rule's weights sum to π within
/// ~1e-13 (src/integrate/ tests) and Ē integrates the constant 2μρ exactly (Gauss–Kronrod), so
/// on the CPU (f64) the only error left is rounding: 1e-9 is generous and still catches any real
/// mistake.
const LAMBERT_TOL_CPU: f64 = 1e-9;

/// On the GPU the reduction kernel takes f32 weights and values (each rounded by ε/2) and adds
/// them in f32 within a workgroup (a tree of 8 levels for 256 invocations) before the host sums
/// in f64: about (2 + 8)·ε/2 relative. 16 ε ≈ 1.9e-6 leaves a margin of 3 (seen: 4.6e-9).
const LAMBERT_TOL_GPU: f64 = 16.0 * f32::EPSILON as f64;

fn lobe() -> Command {
    Command::new(env!("CARGO_BIN_EXE_lobe"))
}

/// Runs `lobe demo -o DIR ARGS`; returns stdout, panics with stderr on failure.
fn run_demo(dir: &Path, args: &[&str]) -> String {
    let started = std::time::Instant::now();
    let out = lobe()
        .arg("demo")
        .arg("-o")
        .arg(dir)
        .args(args)
        .output()
        .expect("running lobe");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(
        out.status.success(),
        "lobe demo {args:?} failed ({}):\nstdout:\n{stdout}\nstderr:\n{stderr}",
        out.status
    );
    eprintln!(
        "lobe demo {args:?}: {:.1} s\n{stdout}",
        started.elapsed().as_secs_f64()
    );
    stdout
}

/// Values of `attr="..."` in `html`, in order.
fn attribute_values(html: &str, attr: &str) -> Vec<String> {
    let key = format!(" {attr}=\"");
    let mut out = Vec::new();
    let mut rest = html;
    while let Some(k) = rest.find(&key) {
        rest = &rest[k + key.len()..];
        let end = rest.find('"').expect("unterminated attribute");
        out.push(rest[..end].replace("&amp;", "&"));
        rest = &rest[end..];
    }
    out
}

/// (src, width, height) of every `<img>`.
fn images(html: &str) -> Vec<(String, u32, u32)> {
    html.split("<img ")
        .skip(1)
        .map(|tag| {
            let tag = &tag[..tag.find('>').expect("unterminated img")];
            let tag = format!(" {tag}");
            let get = |a: &str| attribute_values(&tag, a).into_iter().next();
            let src = get("src").expect("img without src");
            let w = get("width").and_then(|v| v.parse().ok());
            let h = get("height").and_then(|v| v.parse().ok());
            (
                src.clone(),
                w.unwrap_or_else(|| panic!("{src}: no width")),
                h.unwrap_or_else(|| panic!("{src}: no height")),
            )
        })
        .collect()
}

fn png_size(path: &Path) -> (u32, u32) {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut reader = png::Decoder::new(std::io::BufReader::new(file))
        .read_info()
        .unwrap_or_else(|e| panic!("{} does not decode as PNG: {e}", path.display()));
    let mut buf = vec![0; reader.output_buffer_size().expect("PNG buffer size")];
    let info = reader
        .next_frame(&mut buf)
        .unwrap_or_else(|e| panic!("{}: PNG data: {e}", path.display()));
    (info.width, info.height)
}

/// The three numbers of an RGB cell `<td ... data-field="FIELD">r g b</td>` in a row.
fn rgb_cell(row: &str, field: &str) -> [f64; 3] {
    let key = format!("data-field=\"{field}\"");
    let at = row
        .find(&key)
        .unwrap_or_else(|| panic!("no {field} cell in {row}"));
    let text = &row[at..];
    let text = &text[text.find('>').unwrap() + 1..text.find("</td>").unwrap()];
    let v: Vec<f64> = text
        .split_whitespace()
        .map(|x| x.parse().unwrap_or_else(|_| panic!("{field}: '{text}'")))
        .collect();
    assert_eq!(v.len(), 3, "{field}: '{text}'");
    [v[0], v[1], v[2]]
}

fn json_rgb(v: &Value) -> [f64; 3] {
    let a = v.as_array().expect("rgb array");
    [0, 1, 2].map(|k| a[k].as_f64().expect("number"))
}

fn assert_close(what: &str, shown: [f64; 3], truth: [f64; 3], tol: f64) {
    for k in 0..3 {
        let d = (shown[k] - truth[k]).abs();
        assert!(
            d <= tol,
            "{what} channel {k}: page {} vs {}: |difference| {d:.2e} > allowed {tol:.1e}",
            shown[k],
            truth[k]
        );
    }
}

/// Everything the page promises, checked on the files. Returns the page.
fn check_page(dir: &Path, cell: u32, gpu: bool) -> String {
    let lambert_tol = if gpu {
        LAMBERT_TOL_GPU
    } else {
        LAMBERT_TOL_CPU
    };
    let html = std::fs::read_to_string(dir.join(INDEX)).expect("index.html");
    // Self-contained: nothing to fetch.
    for bad in ["http://", "https://", "<script", "<link"] {
        assert!(!html.contains(bad), "the page contains {bad}");
    }
    // Every referenced file exists and is not empty.
    let mut refs = attribute_values(&html, "src");
    refs.extend(attribute_values(&html, "href"));
    assert!(refs.len() > 40, "only {} references", refs.len());
    for r in &refs {
        let p = dir.join(r);
        let meta = std::fs::metadata(&p).unwrap_or_else(|e| panic!("{r} (on the page): {e}"));
        assert!(
            meta.is_file() && meta.len() > 0,
            "{r} is empty or not a file"
        );
    }
    // Tables: EXR, npy and JSON of both gold tables.
    for grid in ["full", "isotropic"] {
        for ext in ["exr", "npy", "json"] {
            let f = format!("tables/gold_cook_torrance_{grid}.{ext}");
            assert!(refs.contains(&f), "{f} is not on the page");
        }
    }
    // The albedo LUT: its EXR, both npy files, its sidecar and its picture.
    for suffix in [".exr", ".npy", "_avg.npy", ".json", ".png"] {
        assert!(
            refs.iter()
                .any(|r| r.starts_with("lut/") && r.ends_with(suffix)),
            "no lut/*{suffix} on the page"
        );
    }
    // Images decode at the size the page gives them; line plots at the demo's plot size.
    let imgs = images(&html);
    assert!(imgs.len() >= 8, "only {} images", imgs.len());
    for (src, w, h) in &imgs {
        assert_eq!(png_size(&dir.join(src)), (*w, *h), "{src}");
        if src.starts_with("plots/albedo") {
            assert_eq!((*w, *h), PLOT_SIZE, "{src}");
        }
        // A half disc is twice as wide as tall: polar plots keep the width on a lower canvas.
        if src.starts_with("plots/polar") {
            assert_eq!(*w, PLOT_SIZE.0, "{src}");
            assert!(*h < PLOT_SIZE.1, "{src}");
        }
        // Beside each plot, the full parameters of its series.
        if src.starts_with("plots/") {
            let json = dir.join(src).with_extension("json");
            let v: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
            assert!(!v["series"].as_array().unwrap().is_empty(), "{src}");
        }
    }
    for kind in ["polar", "hemisphere", "albedo"] {
        assert!(
            imgs.iter()
                .any(|(s, _, _)| s.starts_with(&format!("plots/{kind}"))),
            "no {kind} plot on the page"
        );
    }
    // The preview: a labelled PNG and the linear EXR of exactly materials × models cells.
    assert!(imgs
        .iter()
        .any(|(s, _, _)| s == "preview/contact_sheet.png"));
    let (w, h, _) = lobe::preview::read_exr(&dir.join("preview/contact_sheet.exr")).unwrap();
    assert_eq!(
        (w, h),
        (
            Model::ALL.len() * cell as usize,
            MATERIALS.len() * cell as usize
        ),
        "preview EXR size"
    );
    // Albedo: one row per material × model, and its numbers are the JSON file's.
    let rows: Vec<&str> = html
        .split("<tr data-albedo=")
        .skip(1)
        .map(|r| &r[..r.find("</tr>").unwrap()])
        .collect();
    // ... and, in the measured section, gold cook_torrance again and its MERL file's two lookups;
    // on the GPU, the shipped .brdf file and its nearest built-in model.
    let shipped_rows = if gpu { 2 } else { 0 };
    assert_eq!(
        rows.len(),
        MATERIALS.len() * Model::ALL.len() + 3 + shipped_rows
    );
    assert!(html.contains("gold_cook_torrance_merl (lookup=trilinear)"));
    for row in &rows {
        let file = row[1..].split('"').next().unwrap();
        let json: Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join(file)).unwrap()).unwrap();
        let points = json["points"].as_array().unwrap();
        for (k, mu) in demo::ALBEDO_MU.iter().enumerate() {
            assert_eq!(points[k]["mu"].as_f64(), Some(*mu), "{file}");
            assert_close(
                &format!("{file} E(mu={mu})"),
                rgb_cell(row, &format!("mu={mu}")),
                json_rgb(&points[k]["albedo"]),
                DISPLAY_ROUNDING,
            );
        }
        let hemi = &json["hemispherical"];
        assert_close(
            &format!("{file} hemispherical"),
            rgb_cell(row, "hemispherical"),
            json_rgb(&hemi["albedo"]),
            DISPLAY_ROUNDING,
        );
        assert_close(
            &format!("{file} 1 - E_avg"),
            rgb_cell(row, "loss"),
            json_rgb(&hemi["e_avg"]).map(|x| 1.0 - x),
            DISPLAY_ROUNDING,
        );
    }
    // Lambert: the page and the JSON show the material's albedo.
    for mat in MATERIALS {
        let rho = material::preset(mat, Model::Lambert)
            .unwrap()
            .rgb("albedo")
            .to_array();
        let key = format!("\"albedo/{mat}_lambert.json\"");
        let row = rows
            .iter()
            .find(|r| r.starts_with(&key))
            .unwrap_or_else(|| panic!("no lambert row for {mat}"));
        for mu in demo::ALBEDO_MU {
            assert_close(
                &format!("{mat} lambert E(mu={mu}) vs albedo"),
                rgb_cell(row, &format!("mu={mu}")),
                rho,
                DISPLAY_ROUNDING + lambert_tol,
            );
        }
        assert_close(
            &format!("{mat} lambert hemispherical vs albedo"),
            rgb_cell(row, "hemispherical"),
            rho,
            DISPLAY_ROUNDING + lambert_tol,
        );
        let json: Value = serde_json::from_str(
            &std::fs::read_to_string(dir.join(format!("albedo/{mat}_lambert.json"))).unwrap(),
        )
        .unwrap();
        assert_close(
            &format!("{mat} lambert JSON hemispherical"),
            json_rgb(&json["hemispherical"]["albedo"]),
            rho,
            lambert_tol,
        );
    }
    // Energy: `smooth_layered` gains energy at grazing view (docs/design.md §3: the tool must
    // show it), most of all on glazed ceramic (E ≈ 1.6); a Lambertian never does, not even
    // gold's ρ = 1 red channel.
    let gain_of = |key: &str| {
        let row = rows
            .iter()
            .find(|r| r.starts_with(&format!("\"albedo/{key}.json\"")))
            .unwrap_or_else(|| panic!("no row {key}"));
        row.contains("class=\"num gain\" data-field=\"max_e\"")
    };
    assert!(
        gain_of("glazed_ceramic_smooth_layered"),
        "smooth_layered gain not marked"
    );
    for mat in MATERIALS {
        assert!(
            !gain_of(&format!("{mat}_lambert")),
            "{mat} lambert marked as gain"
        );
    }
    // Every step is timed on the page.
    let steps = &html[html.find("id=\"steps\"").expect("steps table")..];
    let steps = &steps[..steps.find("</table>").unwrap()];
    let mut names = vec![
        "tables",
        "albedo",
        "lut",
        "plots",
        "preview",
        "white_furnace",
        "measured",
        "brdf",
    ];
    if gpu {
        names.push("parity");
    }
    for s in names {
        assert!(
            steps.contains(&format!("<td>{s}</td>")),
            "step {s} not timed"
        );
    }
    // Parity: a row per model with finite numbers on the GPU; said to be absent on the CPU.
    if gpu {
        let t = &html[html.find("id=\"parity\"").expect("parity table")..];
        let t = &t[..t.find("</table>").unwrap()];
        assert_eq!(t.matches("<tr><td>").count(), Model::ALL.len());
        for cell in t.split("<td class=\"num\">").skip(1) {
            let text = &cell[..cell.find('<').unwrap()];
            let v: f64 = text.parse().unwrap_or_else(|_| panic!("parity '{text}'"));
            assert!(v.is_finite(), "parity '{text}'");
        }
    } else {
        assert!(html.contains("id=\"parity-none\""));
    }
    // The shipped .brdf file against its nearest built-in model: numbers on the GPU (the two
    // differ in the base's coupling, so relative L2 is well above 0 and below 1), a note on the
    // CPU, where a .brdf shader has no twin.
    if gpu {
        let t = &html[html
            .find("id=\"shipped-compare\"")
            .expect("shipped compare")..];
        let at = t.find("data-field=\"relative_l2\">").unwrap() + 25;
        let text = &t[at..at + t[at..].find('<').unwrap()];
        let l2: f64 = text
            .parse()
            .unwrap_or_else(|_| panic!("relative L2 '{text}'"));
        assert!(l2 > 0.0 && l2 < 1.0, "relative L2 {l2}");
        assert!(dir.join("brdf/coated_plastic.brdf").is_file());
        assert!(html.contains("plots/coated_plastic_vs_microfacet_difference.png"));
    } else {
        assert!(html.contains("id=\"shipped-none\""));
    }
    // No staging folder left beside the output.
    let parent = dir.parent().unwrap();
    for e in std::fs::read_dir(parent).unwrap() {
        let name = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.starts_with(".lobe-demo-"), "left behind: {name}");
    }
    html
}

#[test]
fn demo_on_the_gpu_with_full_settings() {
    if common::gpu_device("demo").is_none() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("out");
    let stdout = run_demo(&dir, &[]);
    assert!(stdout.contains("index.html"), "{stdout}");
    let html = check_page(&dir, Settings::full().preview_cell, true);
    assert!(html.contains("full settings"));
    check_in_browser(&dir);
}

#[test]
fn demo_on_the_cpu_quick_into_an_existing_folder() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("out");
    std::fs::create_dir_all(&dir).unwrap();
    // A file of the user's survives; an old page is replaced.
    std::fs::write(dir.join("notes.txt"), "mine").unwrap();
    std::fs::write(dir.join(INDEX), "old page").unwrap();
    run_demo(&dir, &["--backend", "cpu", "--quick"]);
    let html = check_page(&dir, Settings::quick().preview_cell, false);
    assert!(html.contains("quick settings"));
    check_in_browser(&dir);
    assert_eq!(
        std::fs::read_to_string(dir.join("notes.txt")).unwrap(),
        "mine"
    );
}

/// Stops the demo (as Ctrl-C does, through the cancellation token) when a given step begins.
struct StopAt(&'static str, lobe::CancelToken);

impl Progress for StopAt {
    fn begin(&mut self, step: &str, _: u64) {
        if step == self.0 {
            self.1.cancel();
        }
    }
    fn advance(&mut self, _: u64) {}
    fn end(&mut self, _: &Step) {}
}

#[test]
fn an_interrupted_demo_leaves_no_page_and_no_files() {
    let tmp = tempfile::tempdir().unwrap();
    let dir: PathBuf = tmp.path().join("out");
    let token = lobe::CancelToken::new();
    let result = demo::run(
        &Evaluator::cpu().with_cancel(&token),
        &dir,
        &Settings::quick(),
        &mut StopAt("plots", token.clone()),
    );
    let err = format!("{:#}", result.expect_err("the demo should stop"));
    assert!(err.contains("interrupted"), "{err}");
    let left: Vec<_> = std::fs::read_dir(tmp.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

/// The width of the browser window the page must fit, in CSS pixels.
const BROWSER_WIDTH: u32 = 1280;

/// A headless Chromium: `LOBE_CHROMIUM`, else `chromium` or `chromium-browser` on the PATH.
/// None only when `LOBE_SKIP_BROWSER=1`; otherwise a missing browser fails the test with the
/// install hint (CI installs it).
fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("LOBE_CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH").unwrap_or_default();
    for dir in std::env::split_paths(&path) {
        for name in ["chromium", "chromium-browser"] {
            if dir.join(name).is_file() {
                return Some(dir.join(name));
            }
        }
    }
    if std::env::var("LOBE_SKIP_BROWSER").as_deref() == Ok("1") {
        eprintln!("skipping the browser check: LOBE_SKIP_BROWSER=1 and no chromium found");
        return None;
    }
    panic!(
        "the page check needs headless Chromium: apt-get install chromium (or set LOBE_CHROMIUM \
         to its path; LOBE_SKIP_BROWSER=1 skips the check)"
    );
}

/// Renders the demo's page in headless Chromium, {BROWSER_WIDTH} px wide, and checks that
/// nothing on it is wider than the window (no horizontal scrolling) and that every image
/// loaded. A copy of the page with a script that writes what it measured into the page is
/// loaded beside the original, and Chromium prints the page as it is after loading.
fn check_in_browser(dir: &Path) {
    let Some(browser) = chromium() else {
        return;
    };
    let html = std::fs::read_to_string(dir.join(INDEX)).unwrap();
    let script = r#"<script>
window.addEventListener('load', () => {
  const root = document.documentElement;
  const imgs = Array.from(document.images);
  const broken = imgs.filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.getAttribute('src'));
  const wide = Array.from(document.querySelectorAll('body *'))
    .filter(e => e.getBoundingClientRect().right > root.clientWidth + 0.5)
    .map(e => e.tagName + (e.id ? '#' + e.id : '') + (e.className ? '.' + e.className : ''))
    .slice(0, 10);
  const out = document.createElement('pre');
  out.id = 'browser-check';
  out.textContent = JSON.stringify({ window: window.innerWidth, client: root.clientWidth,
    scroll: root.scrollWidth, images: imgs.length, broken: broken, wide: wide });
  document.body.appendChild(out);
});
</script>"#;
    let probe = dir.join("browser-check.html");
    std::fs::write(&probe, html.replace("</body>", &format!("{script}</body>"))).unwrap();
    let profile = tempfile::tempdir().unwrap();
    let out = Command::new(&browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            &format!("--window-size={BROWSER_WIDTH},900"),
            "--virtual-time-budget=20000",
            &format!("--user-data-dir={}", profile.path().display()),
            "--dump-dom",
        ])
        .arg(format!("file://{}", probe.display()))
        .output()
        .unwrap_or_else(|e| panic!("running {}: {e}", browser.display()));
    std::fs::remove_file(&probe).unwrap();
    let dom = String::from_utf8_lossy(&out.stdout);
    let start = dom.find("<pre id=\"browser-check\">").unwrap_or_else(|| {
        panic!(
            "Chromium printed no measurement (status {}): {}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        )
    });
    let text = &dom[start..];
    let text = &text[text.find('>').unwrap() + 1..text.find("</pre>").unwrap()];
    let text = text.replace("&quot;", "\"").replace("&amp;", "&");
    println!("browser check of {}: {text}", dir.join(INDEX).display());
    let v: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["window"], BROWSER_WIDTH, "{text}");
    let (client, scroll) = (v["client"].as_u64().unwrap(), v["scroll"].as_u64().unwrap());
    assert!(
        scroll <= client,
        "the page is {scroll} px wide in a {client} px window: {text}"
    );
    assert!(v["wide"].as_array().unwrap().is_empty(), "{text}");
    assert!(v["images"].as_u64().unwrap() >= 8, "{text}");
    assert!(
        v["broken"].as_array().unwrap().is_empty(),
        "images that did not load: {text}"
    );
}
