//! `lobe demo`: the main job on the built-in materials (tin, gold, glazed_ceramic, granite), with
//! every model, written under one folder and shown on one self-contained page, `index.html`.
//!
//! Steps, each timed (the page and the terminal summary show the times):
//! 1. **tables**: gold under Cook–Torrance on the full and the isotropic grid (EXR + npy + JSON);
//! 2. **albedo**: `albedo/<material>_<model>.json` for every material × model, with `lobe albedo`'s
//!    default integrator (`peak`) at a modest node count: E at μ = 0.1, 0.5, 1 and the
//!    hemispherical albedo with E_avg;
//! 3. **lut**: one albedo LUT with [`crate::lut::write`]: Kulla–Conty's E(μ, α) and E_avg(α) of
//!    the GGX microfacet lobe under the white furnace (EXR + npy + JSON, and a PNG heat map);
//! 4. **plots**: polar overlays (materials under one model, models for one material), a hemisphere
//!    heat map, and the E(μ) curves of every model for each material (these also give the largest
//!    E(μ) on the page: energy gain);
//! 5. **preview**: the contact sheet (rows materials, columns models) under the lab's lights;
//!    then **white_furnace**: a row of spheres under a uniform white sky (colours at 1, F = 1), each
//!    pixel its albedo E(μo): Oren–Nayar against EON, GGX α = 1 without and with Kulla–Conty;
//! 6. **measured**: gold under Cook–Torrance written as a MERL file by the f64 reference (in a
//!    temporary folder: the file is 35 MB) and read back as a model ([`crate::merl`]), with its
//!    albedo JSON for the nearest and the trilinear lookup;
//! 7. **brdf**: the shipped BRDF Explorer file `data/brdf/coated_plastic.brdf` as a model, its
//!    albedo, and a comparison with the nearest built-in configuration with its plots
//!    ([`shipped`]; GPU only: a `.brdf` shader has no f64 twin);
//! 8. **parity**: GPU (f32) against the f64 reference on a modest direction grid, per model, with
//!    the parity test's tolerance model ([`crate::stability::parity_tolerance`]); not measured
//!    with `--backend cpu`, where there is no GPU run to compare;
//! 9. **page**: `index.html`, written last.
//!
//! Nothing is written into the output folder until every step has succeeded: the steps write into
//! a staging folder beside it (`.lobe-demo-*`), which is then renamed onto the output folder when
//! that does not exist yet, or whose files are moved into it as one transaction with `index.html`
//! last (every check before the first move, the old files back if a move fails:
//! [`crate::output::StagingFolder::commit`]).
//! A failed or interrupted run removes the staging folder and leaves the output folder as it was.
//!
//! Sizes are chosen so that the whole demo takes well under a minute on two CPU cores with lavapipe
//! ([`Settings::full`]); the page states them. `--quick` ([`Settings::quick`]) shrinks everything
//! further for tests.

mod html;
mod lut_picture;
mod page;
mod parity;
mod plan;
pub mod shipped;
mod steps;

pub use html::rgb_text;
pub use plan::PlannedPlot;

use crate::backend::Precision;
use crate::eval::Evaluator;
use crate::grid::Grid;
use crate::integrate::Method;
use crate::model::Model;
use crate::output::StagingFolder;
use crate::preview;
use anyhow::{bail, Context, Result};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;
use steps::Demo;

/// The lab report's materials (docs/design.md §3), the demo's rows; other presets are left to
/// `lobe` commands.
pub const MATERIALS: [&str; 4] = ["tin", "gold", "glazed_ceramic", "granite"];

/// View directions μ = cosθo at which the page shows E (and the JSON files hold it).
pub const ALBEDO_MU: [f64; 3] = crate::integrate::DEFAULT_MUS;

/// Pixel size of every line plot (polar, albedo).
pub const PLOT_SIZE: (u32, u32) = (1200, 800);

/// The page's name inside the output folder.
pub const INDEX: &str = "index.html";

/// How big each step is.
#[derive(Clone, Debug)]
pub struct Settings {
    /// Shown on the page: "full" or "quick".
    pub name: &'static str,
    /// The full-grid table of gold under Cook–Torrance (θi, φi, θo, φo).
    pub table_full: Grid,
    /// The isotropic-grid table of gold under Cook–Torrance (θi, θo, Δφ).
    pub table_isotropic: Grid,
    /// Nodes per view direction of the albedo integrator (`peak`).
    pub albedo_samples: usize,
    /// View directions per E(μ) curve.
    pub curve_mu: usize,
    /// Quadrature nodes per view direction of an E(μ) curve.
    pub curve_samples: usize,
    /// View angles per polar curve.
    pub polar_samples: usize,
    /// Cells across a hemisphere heat map.
    pub hemisphere_res: usize,
    /// Preview cell size in pixels.
    pub preview_cell: u32,
    /// Parity grid: θi × θo × φo cells (φi = 0), cell-centred.
    pub parity_grid: [usize; 3],
    /// Albedo LUT: μ cells × α cells.
    pub lut_res: (usize, usize),
    /// Quadrature nodes per (μ, α) entry of the albedo LUT.
    pub lut_samples: usize,
}

impl Settings {
    /// The demo as the README runs it.
    pub fn full() -> Settings {
        Settings {
            name: "full",
            table_full: Grid::Full {
                n_theta_i: 16,
                n_phi_i: 8,
                n_theta_o: 64,
                n_phi_o: 128,
            },
            table_isotropic: Grid::Isotropic {
                n_theta_i: 90,
                n_theta_o: 90,
                n_dphi: 180,
            },
            // 8192 nodes: ~1e-4 relative against the 65536-node default on the presets (the JSON
            // files carry the integrator's own error estimate), at an eighth of the cost.
            albedo_samples: 8192,
            curve_mu: 32,
            curve_samples: 8192,
            polar_samples: crate::plot::polar::DEFAULT_SAMPLES,
            hemisphere_res: 128,
            preview_cell: preview::DEFAULT_CELL,
            parity_grid: [12, 12, 24],
            // Kulla–Conty's table size.
            lut_res: (32, 32),
            // The sharpest rows (α ≈ 0.01) at grazing and normal view are the hard cells; with the
            // peak rule's extra grading there, 32768 nodes give a largest error estimate of 5e-6.
            lut_samples: 32768,
        }
    }

    /// Everything smaller: for tests and a first look.
    pub fn quick() -> Settings {
        Settings {
            name: "quick",
            table_full: Grid::Full {
                n_theta_i: 4,
                n_phi_i: 4,
                n_theta_o: 16,
                n_phi_o: 32,
            },
            table_isotropic: Grid::Isotropic {
                n_theta_i: 16,
                n_theta_o: 16,
                n_dphi: 32,
            },
            albedo_samples: 2048,
            curve_mu: 12,
            curve_samples: 2048,
            polar_samples: 360,
            hemisphere_res: 48,
            preview_cell: 48,
            parity_grid: [6, 6, 12],
            lut_res: (8, 8),
            lut_samples: 2048,
        }
    }

    /// One line per setting, for the page.
    pub fn describe(&self) -> Vec<String> {
        let [a, b, c] = self.parity_grid;
        vec![
            format!(
                "lobe tables: {} grid {} cells, {} grid {} cells",
                self.table_full.name(),
                self.table_full.cells().unwrap_or(0),
                self.table_isotropic.name(),
                self.table_isotropic.cells().unwrap_or(0)
            ),
            format!(
                "albedo: `peak` rule (lobe albedo's default) with {} nodes per view direction (lobe albedo's default is {})",
                self.albedo_samples,
                Method::Peak.default_samples()
            ),
            format!(
                "E(μ) curves: {} view directions, {} nodes each",
                self.curve_mu, self.curve_samples
            ),
            format!(
                "polar curves: {} view angles; hemisphere maps: {} cells across",
                self.polar_samples, self.hemisphere_res
            ),
            format!(
                "albedo LUT: {} μ × {} α cells, {} nodes per direction",
                self.lut_res.0, self.lut_res.1, self.lut_samples
            ),
            format!("preview: {0}x{0} pixels per cell", self.preview_cell),
            format!("parity: θi × θo × φo = {a} × {b} × {c} cell-centred directions (φi = 0) per material"),
        ]
    }
}

/// Receives the demo's progress: a step begins with its amount of work, advances, and ends.
pub trait Progress {
    /// A step called `step` begins; `total` is its amount of work, in the step's own units.
    fn begin(&mut self, step: &str, total: u64);
    /// The running step has done `done` of its `total` units so far.
    fn advance(&mut self, done: u64);
    /// A step has finished, with its time and what it produced.
    fn end(&mut self, step: &Step);
}

/// Progress that goes nowhere.
pub struct Silent;

impl Progress for Silent {
    fn begin(&mut self, _: &str, _: u64) {}
    fn advance(&mut self, _: u64) {}
    fn end(&mut self, _: &Step) {}
}

/// One finished step.
#[derive(Clone, Debug)]
pub struct Step {
    /// The step's name: `tables`, `albedo`, `lut`, `plots`, `preview`, `white_furnace`, `measured`,
    /// `parity` or `page`.
    pub name: &'static str,
    /// Wall-clock time the step took, in seconds.
    pub seconds: f64,
    /// What it produced, in a few words.
    pub detail: String,
}

/// Albedo of one model at one material, as the page shows it.
#[derive(Clone, Debug)]
pub struct AlbedoRow {
    /// The material's preset name.
    pub material: String,
    /// The model's name.
    pub model: String,
    /// The JSON file, relative to the output folder.
    pub json: String,
    /// E (delta lobe included) at [`ALBEDO_MU`].
    pub e: [[f64; 3]; 3],
    /// Hemispherical albedo Ē.
    pub hemispherical: [f64; 3],
    /// Kulla–Conty's E_avg (at φo = 0).
    pub e_avg: [f64; 3],
    /// The integrator's largest error estimate over the points and Ē.
    pub error: f64,
    /// The largest E over the E(μ) curve's directions and [`ALBEDO_MU`], any channel.
    pub max_e: f64,
    /// Where that largest E was seen.
    pub max_e_mu: f64,
}

/// Gold under Cook–Torrance written as a MERL file and read back as a model (step 6).
#[derive(Clone, Debug)]
pub struct Measured {
    /// The model the file became.
    pub model: String,
    /// Negative (missing) values in the file.
    pub missing: usize,
    /// Its albedo with the nearest and with the trilinear lookup.
    pub rows: Vec<AlbedoRow>,
}

/// How far above 1 an albedo must lie to count as energy gain. E is a weighted sum of thousands
/// of terms: a Lambertian of ρ = 1 (gold's red channel) lands at 1 ± 1e-13 in f64 and ± 1e-7
/// through the GPU's f32 reduction, which is rounding, not gain. The smallest real gain among the
/// presets is ~8e-3 (gold under Oren–Nayar at grazing view), far above this floor.
pub const GAIN_FLOOR: f64 = 1e-6;

impl AlbedoRow {
    /// Whether the model reflects more than it receives somewhere (E > 1 + [`GAIN_FLOOR`]).
    pub fn gains_energy(&self) -> bool {
        self.max_e > 1.0 + GAIN_FLOOR
    }
}

/// GPU-vs-CPU parity of one model over the demo's grid and every material.
#[derive(Clone, Debug)]
pub struct ParityRow {
    /// The model's name.
    pub model: String,
    /// Channel values compared.
    pub values: usize,
    /// max |g − c| / max(|c|, REL_FLOOR) over channels, pairs and materials.
    pub max_rel: f64,
    /// max |g − c| / tolerance (the parity test's model): above 1 the test would fail.
    pub max_ratio: f64,
    /// Channel values outside the tolerance (a NaN counts as outside).
    pub over: usize,
    /// Where max_rel occurred.
    pub worst: String,
}

/// The albedo LUT the demo wrote.
#[derive(Clone, Debug)]
pub struct LutInfo {
    /// The model and parameters tabulated, in words.
    pub what: String,
    /// The LUT's files (EXR, npy of E, npy of E_avg, JSON) and its picture, relative.
    pub files: Vec<String>,
    /// The LUT's heat map picture, relative to the output folder.
    pub png: String,
    /// The picture's size in pixels.
    pub png_size: (u32, u32),
    /// α at each row of the LUT.
    pub alpha: Vec<f64>,
    /// E_avg(α) at each row of `alpha` (white furnace: grey, so one channel).
    pub e_avg: Vec<f64>,
    /// The integrator's largest error estimate of any entry (E or E_avg), absolute.
    pub max_error: f64,
    /// The smallest E in the table and where: (E, μ, α).
    pub min_e: (f64, f64, f64),
}

/// What the demo did.
#[derive(Clone, Debug)]
pub struct Report {
    /// The output folder.
    pub dir: PathBuf,
    /// The evaluator's name: `gpu (device)` or `cpu (f64 reference)`.
    pub backend: String,
    /// The sizes the demo ran with.
    pub settings: Settings,
    /// The steps in the order they ran, `page` last.
    pub steps: Vec<Step>,
    /// Every file written, relative to `dir`.
    pub files: Vec<String>,
    /// Material by material, one row per model.
    pub albedo: Vec<AlbedoRow>,
    /// The albedo LUT of step 3.
    pub lut: LutInfo,
    /// Gold under Cook–Torrance as a MERL file, read back.
    pub measured: Measured,
    /// The shipped `.brdf` file against its nearest built-in model; None with the CPU backend
    /// (a `.brdf` shader has no f64 twin).
    pub shipped: Option<shipped::Shipped>,
    /// None with the CPU backend.
    pub parity: Option<Vec<ParityRow>>,
    /// Pixel size of the white-furnace row's PNG (`preview/white_furnace.png`).
    pub white_furnace_png: (usize, usize),
    /// Wall-clock time of the whole demo, in seconds.
    pub seconds: f64,
}

impl Report {
    /// The terminal summary: step times, energy gain, parity.
    pub fn summary(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "lobe demo ({} settings) on {}: {} files in {} ({:.1} s)",
            self.settings.name,
            self.backend,
            self.files.len(),
            self.dir.display(),
            self.seconds
        );
        for st in &self.steps {
            let _ = writeln!(s, "  {:<8} {:>7.2} s  {}", st.name, st.seconds, st.detail);
        }
        let gains: Vec<String> = self
            .albedo
            .iter()
            .filter(|r| r.gains_energy())
            .map(|r| {
                format!(
                    "{} {} (E = {:.3} at μ = {:.3})",
                    r.material, r.model, r.max_e, r.max_e_mu
                )
            })
            .collect();
        if gains.is_empty() {
            let _ = writeln!(
                s,
                "energy: no model gains energy (E ≤ 1 everywhere sampled)"
            );
        } else {
            let _ = writeln!(s, "energy gain (E > 1): {}", gains.join("; "));
        }
        match &self.parity {
            None => {
                let _ = writeln!(s, "parity: not measured (CPU backend: no GPU run)");
            }
            Some(rows) => {
                let worst = rows.iter().map(|r| r.max_rel).fold(0.0, f64::max);
                let ratio = rows.iter().map(|r| r.max_ratio).fold(0.0, f64::max);
                let over: usize = rows.iter().map(|r| r.over).sum();
                let _ = writeln!(
                    s,
                    "parity GPU vs CPU: max relative error {worst:.1e}, max error/tolerance {ratio:.2}, {over} values over tolerance"
                );
            }
        }
        let _ = write!(s, "open {}", self.dir.join(INDEX).display());
        s
    }
}

/// Times one step and reports it.
struct Steps<'p> {
    /// Its cancellation token is checked before every step.
    eval: Evaluator<'p>,
    progress: &'p mut dyn Progress,
    done: Vec<Step>,
}

impl Steps<'_> {
    fn run<T>(
        &mut self,
        name: &'static str,
        total: u64,
        body: impl FnOnce(&mut dyn Progress) -> Result<(T, String)>,
    ) -> Result<T> {
        self.eval.check_cancelled()?;
        self.progress.begin(name, total);
        let started = Instant::now();
        let (value, detail) =
            body(&mut *self.progress).with_context(|| format!("demo step {name}"))?;
        let step = Step {
            name,
            seconds: started.elapsed().as_secs_f64(),
            detail,
        };
        self.progress.end(&step);
        self.done.push(step);
        Ok(value)
    }
}

/// The models the demo shows: every model, each with its preset for every material.
pub fn models() -> Vec<Model> {
    Model::ALL.to_vec()
}

/// Pixel sizes of the preview's PNG and EXR, for the page.
type PreviewSizes = ((usize, usize), (usize, usize));

/// Checks, before any work, that the demo can write the folder `dir`: no file in the way, and
/// neither `dir` (or, while it does not exist, the folder that would hold it) read-only nor
/// unwritable. The message names `-o`.
pub fn check_output(dir: &Path) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        bail!(
            "-o {}: a file of that name is in the way; the demo writes a folder",
            dir.display()
        );
    }
    crate::output::check_folder_destination(dir).with_context(|| format!("-o {}", dir.display()))
}

/// Runs the demo into `dir` (see the module's notes).
pub fn run(
    eval: &Evaluator,
    dir: &Path,
    settings: &Settings,
    progress: &mut dyn Progress,
) -> Result<Report> {
    let started = Instant::now();
    check_output(dir)?;
    let staging = StagingFolder::new(dir, "demo")?;
    let backend = eval.name();
    let materials: Vec<&'static str> = MATERIALS.to_vec();
    let models = models();
    let demo = Demo {
        staging: &staging,
        settings,
        backend: &backend,
        materials: &materials,
        models: &models,
    };
    let mut files: Vec<String> = Vec::new();
    let mut steps = Steps {
        eval: *eval,
        progress,
        done: Vec::new(),
    };
    for sub in ["tables", "albedo", "plots", "preview"] {
        std::fs::create_dir_all(staging.path(sub))
            .with_context(|| format!("creating {}", staging.path(sub).display()))?;
    }

    steps.run("tables", steps::table_cells(settings), |p| {
        steps::tables(eval, &demo, &mut files, p)
    })?;
    let n_albedo = (materials.len() * models.len()) as u64;
    let mut albedo = steps.run("albedo", n_albedo, |p| {
        steps::albedo(eval, &demo, &mut files, p)
    })?;
    let lut = steps.run("lut", settings.lut_res.1 as u64, |p| {
        steps::lut(eval, &demo, &mut files, p)
    })?;
    let plots = plan::plan_plots(settings, &materials, &models)?;
    let curves = steps.run("plots", plots.len() as u64, |p| {
        steps::plots(eval, &demo, &plots, &mut files, p)
    })?;
    steps::extend_max_e(&mut albedo, &plots, &curves);
    let preview_size = steps.run("preview", models.len() as u64, |p| {
        steps::preview(eval, &demo, &mut files, p)
    })?;
    let white_furnace_png = steps.run("white_furnace", 4, |p| {
        steps::white_furnace(eval, &demo, &mut files, p)
    })?;
    let measured = steps.run("measured", 1 + 2, |p| {
        steps::measured(eval, &demo, &mut files, p)
    })?;
    let shipped = steps.run("brdf", 4, |p| shipped::shipped(eval, &demo, &mut files, p))?;
    // The f32 backend's values against the f64 reference; nothing to compare on the reference.
    let parity = match eval.precision() {
        Precision::F64 => None,
        Precision::F32 => Some(steps.run("parity", models.len() as u64, |p| {
            steps::parity(eval, &demo, p)
        })?),
    };

    let mut report = Report {
        dir: dir.to_path_buf(),
        backend: backend.clone(),
        settings: settings.clone(),
        steps: Vec::new(),
        files,
        albedo,
        lut,
        measured,
        shipped,
        parity,
        white_furnace_png,
        seconds: 0.0,
    };
    publish(
        &mut report,
        staging,
        &plots,
        preview_size,
        &mut steps,
        started,
    )?;
    Ok(report)
}

/// Step 8, the page, last, and the move into place. Its own time is not known while the page is
/// written: the page shows the steps before it, and the report (the terminal summary) adds it.
fn publish(
    report: &mut Report,
    staging: StagingFolder,
    plots: &[PlannedPlot],
    preview_size: PreviewSizes,
    steps: &mut Steps,
    started: Instant,
) -> Result<()> {
    let page_started = Instant::now();
    steps.eval.check_cancelled()?;
    steps.progress.begin("page", 1);
    report.files.push(INDEX.to_string());
    let mut timed = steps.done.clone();
    report.steps = timed.clone();
    report.seconds = started.elapsed().as_secs_f64();
    let html = page::page(report, plots, preview_size);
    std::fs::write(staging.path(INDEX), html).context("writing index.html")?;
    // The page last: a folder with an index.html is complete.
    let order: Vec<&String> = (report.files.iter().filter(|f| *f != INDEX))
        .chain(report.files.iter().filter(|f| *f == INDEX))
        .collect();
    staging.commit(&order)?;
    let step = Step {
        name: "page",
        seconds: page_started.elapsed().as_secs_f64(),
        detail: format!("{INDEX} and {} files moved into place", report.files.len()),
    };
    steps.progress.end(&step);
    timed.push(step);
    report.steps = timed;
    report.seconds = started.elapsed().as_secs_f64();
    Ok(())
}
