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
//! 6. **parity**: GPU (f32) against the f64 reference on a modest direction grid, per model, with
//!    the parity test's tolerance model ([`crate::stability::parity_tolerance`]); not measured
//!    with `--backend cpu`, where there is no GPU run to compare;
//! 7. **page**: `index.html`, written last.
//!
//! Nothing is written into the output folder until every step has succeeded: the steps write into
//! a staging folder beside it (`.lobe-demo-*`), which is then renamed onto the output folder when
//! that does not exist yet, or whose files are renamed into it one by one with `index.html` last.
//! A failed or interrupted run removes the staging folder and leaves the output folder as it was.
//!
//! Sizes are chosen so that the whole demo takes well under a minute on two CPU cores with lavapipe
//! ([`Settings::full`]); the page states them. `--quick` ([`Settings::quick`]) shrinks everything
//! further for tests.

use crate::eval::Evaluator;
use crate::grid::{direction, Grid};
use crate::integrate::{albedo_report, Method, Settings as AlbedoSettings};
use crate::material;
use crate::model::{Model, ParamSet, Reference};
use crate::output::StagingFolder;
use crate::plot::{self, Common, Plotted, Request, Subject};
use crate::preview::{self, LightKind, Scene, Shape, Sheet};
use crate::stability::{parity_tolerance, REL_FLOOR};
use crate::table::{write_table, TableMeta};
use anyhow::{bail, Context, Result};
use glam::DVec3;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The lab's materials (DESIGN §3), the demo's rows; other presets are left to `lobe` commands.
pub const MATERIALS: [&str; 4] = ["tin", "gold", "glazed_ceramic", "granite"];

/// View directions μ = cosθo at which the page shows E (and the JSON files hold it).
pub const ALBEDO_MU: [f64; 3] = [0.1, 0.5, 1.0];

/// Pixel size of every line plot (polar, albedo).
pub const PLOT_SIZE: (u32, u32) = (1200, 800);

/// The page's name inside the output folder.
pub const INDEX: &str = "index.html";

/// How big each step is.
#[derive(Clone, Debug)]
pub struct Settings {
    /// Shown on the page: "full" or "quick".
    pub name: &'static str,
    /// Gold Cook–Torrance tables.
    pub table_full: Grid,
    pub table_isotropic: Grid,
    /// Nodes per view direction of the albedo integrator (`peak`).
    pub albedo_samples: usize,
    /// View directions per E(μ) curve, and nodes per direction.
    pub curve_mu: usize,
    pub curve_samples: usize,
    /// View angles per polar curve.
    pub polar_samples: usize,
    /// Cells across a hemisphere heat map.
    pub hemisphere_res: usize,
    /// Preview cell size in pixels.
    pub preview_cell: u32,
    /// Parity grid: θi × θo × φo cells (φi = 0), cell-centred.
    pub parity_grid: [usize; 3],
    /// Albedo LUT: μ cells × α cells, and nodes per direction.
    pub lut_res: (usize, usize),
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
    fn begin(&mut self, step: &str, total: u64);
    fn advance(&mut self, done: u64);
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
    pub name: &'static str,
    pub seconds: f64,
    /// What it produced, in a few words.
    pub detail: String,
}

/// Albedo of one model at one material, as the page shows it.
#[derive(Clone, Debug)]
pub struct AlbedoRow {
    pub material: String,
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
    pub model: String,
    pub values: usize,
    /// max |g − c| / max(|c|, REL_FLOOR) over channels, pairs and materials.
    pub max_rel: f64,
    /// max |g − c| / tolerance (the parity test's model): above 1 the test would fail.
    pub max_ratio: f64,
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
    pub png: String,
    pub png_size: (u32, u32),
    /// α at each row and E_avg there (white furnace: grey, so one channel).
    pub alpha: Vec<f64>,
    pub e_avg: Vec<f64>,
    pub max_error: f64,
    /// The smallest E in the table and where: (E, μ, α).
    pub min_e: (f64, f64, f64),
}

/// What the demo did.
#[derive(Clone, Debug)]
pub struct Report {
    pub dir: PathBuf,
    pub backend: String,
    pub settings: Settings,
    pub steps: Vec<Step>,
    /// Every file written, relative to `dir`.
    pub files: Vec<String>,
    pub albedo: Vec<AlbedoRow>,
    pub lut: LutInfo,
    /// None with the CPU backend.
    pub parity: Option<Vec<ParityRow>>,
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
                let _ = writeln!(s, "parity: not measured (--backend cpu: no GPU run)");
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
        crate::interrupt::check()?;
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

/// Runs the demo into `dir` (see the module's notes).
pub fn run(
    eval: &Evaluator,
    dir: &Path,
    settings: &Settings,
    progress: &mut dyn Progress,
) -> Result<Report> {
    let started = Instant::now();
    if dir.exists() && !dir.is_dir() {
        bail!(
            "-o {}: a file of that name is in the way; the demo writes a folder",
            dir.display()
        );
    }
    let staging = StagingFolder::new(dir, "demo")?;
    let backend = eval.name();
    let materials: Vec<&'static str> = MATERIALS.to_vec();
    let models = models();
    let mut files: Vec<String> = Vec::new();
    let mut steps = Steps {
        progress,
        done: Vec::new(),
    };
    for sub in ["tables", "albedo", "plots", "preview"] {
        std::fs::create_dir_all(staging.path(sub))
            .with_context(|| format!("creating {}", staging.path(sub).display()))?;
    }

    // 1. Lobe tables.
    let tables = [
        ("tables/gold_cook_torrance_full.exr", settings.table_full),
        (
            "tables/gold_cook_torrance_isotropic.exr",
            settings.table_isotropic,
        ),
    ];
    let cells: u64 = tables.iter().map(|(_, g)| g.cells().unwrap_or(0)).sum();
    steps.run("tables", cells, |p| {
        let gold = material::preset("gold", Model::CookTorrance)?;
        let mut before = 0;
        for (rel, grid) in tables {
            let meta = TableMeta {
                params: &gold,
                white_furnace: false,
                grid,
                backend: backend.clone(),
            };
            write_table(eval, &meta, &staging.path(rel), &mut |done, _| {
                p.advance(before + done)
            })?;
            before += grid.cells().unwrap_or(0);
            for ext in ["exr", "npy", "json"] {
                files.push(
                    Path::new(rel)
                        .with_extension(ext)
                        .to_string_lossy()
                        .into_owned(),
                );
            }
        }
        Ok((
            (),
            format!("2 gold cook_torrance tables, {cells} cells, EXR + npy + JSON"),
        ))
    })?;

    // 2. Albedo JSON per material × model.
    let albedo_settings = AlbedoSettings {
        method: Method::Peak,
        samples: settings.albedo_samples,
        white_furnace: false,
    };
    let points: Vec<(f64, f64)> = ALBEDO_MU.iter().map(|&m| (m, 0.0)).collect();
    let n_albedo = (materials.len() * models.len()) as u64;
    let mut albedo: Vec<AlbedoRow> = steps.run("albedo", n_albedo, |p| {
        let mut rows = Vec::new();
        for mat in &materials {
            for &model in &models {
                crate::interrupt::check()?;
                let params = material::preset(mat, model)?;
                let report = albedo_report(eval, &params, &albedo_settings, &points, 0.0)
                    .with_context(|| format!("albedo of {mat} {}", model.name()))?;
                let rel = format!("albedo/{mat}_{}.json", model.name());
                let json = report.to_json(&params, false, &backend);
                std::fs::write(
                    staging.path(&rel),
                    serde_json::to_string_pretty(&json)? + "\n",
                )
                .with_context(|| format!("writing {rel}"))?;
                files.push(rel.clone());
                let h = &report.hemispherical;
                let error = report
                    .points
                    .iter()
                    .map(|q| q.error.max_element())
                    .fold(h.error.max_element(), f64::max);
                let e = [0, 1, 2].map(|k| report.points[k].albedo.to_array());
                let (max_e, max_e_mu) = (0..3)
                    .map(|k| (e[k].into_iter().fold(f64::MIN, f64::max), ALBEDO_MU[k]))
                    .fold((f64::MIN, 0.0), |a, b| if b.0 > a.0 { b } else { a });
                rows.push(AlbedoRow {
                    material: mat.to_string(),
                    model: model.name().to_string(),
                    json: rel,
                    e,
                    hemispherical: h.albedo.to_array(),
                    e_avg: h.e_avg.to_array(),
                    error,
                    max_e,
                    max_e_mu,
                });
                p.advance(rows.len() as u64);
            }
        }
        let detail = format!(
            "{} JSON files (peak rule, {} nodes per direction)",
            rows.len(),
            settings.albedo_samples
        );
        Ok((rows, detail))
    })?;

    // 3. One albedo LUT: Kulla–Conty's E(μ, α) and E_avg(α) of the GGX microfacet lobe under the
    //    white furnace (F = 1, no diffuse): what engines load to compensate the energy that
    //    single scattering loses.
    let lut = steps.run("lut", settings.lut_res.1 as u64, |p| {
        let mut params = ParamSet::defaults(Model::Microfacet(
            crate::model::microfacet::MicrofacetConfig::DEFAULT,
        ));
        for assignment in ["diffuse=0", "specular=1"] {
            params.set_text(assignment)?;
        }
        let mut spec = crate::lut::LutSpec::new(params, true);
        spec.n_mu = settings.lut_res.0;
        spec.n_p = settings.lut_res.1;
        spec.samples = settings.lut_samples;
        std::fs::create_dir_all(staging.path("lut")).context("creating lut/")?;
        let exr = "lut/ggx_white_furnace_e_mu_alpha.exr";
        let summary = crate::lut::write(eval, &spec, &staging.path(exr), &mut |done, _| {
            p.advance(done)
        })?;
        let mut lut_files = Vec::new();
        for f in &summary.files {
            let rel = f
                .strip_prefix(staging.root())
                .with_context(|| format!("{} is outside the demo's folder", f.display()))?;
            lut_files.push(rel.to_string_lossy().into_owned());
        }
        let png = "lut/ggx_white_furnace_e_mu_alpha.png".to_string();
        let png_size = draw_lut(&spec, &summary, &staging.path(&png))?;
        files.extend(lut_files.iter().cloned());
        files.push(png.clone());
        let what = format!(
            "microfacet (GGX, height-correlated Smith), white furnace, {}; axis {} = {}..{} ({})",
            spec.params.to_text(),
            spec.keys.join(","),
            spec.lo,
            spec.hi,
            spec.mapping.formula()
        );
        let detail = format!(
            "{} μ × {} α GGX white-furnace LUT (EXR + npy + JSON + PNG), largest error estimate {:.1e}",
            spec.n_mu, spec.n_p, summary.max_error
        );
        Ok((
            LutInfo {
                what,
                files: lut_files,
                png,
                png_size,
                alpha: summary.ps.clone(),
                e_avg: summary.e_avg.iter().map(|v| v.x).collect(),
                max_error: summary.max_error,
                min_e: (0..summary.e.len())
                    .map(|i| {
                        let (k, j) = (i / spec.n_mu, i % spec.n_mu);
                        (summary.e[i].x, summary.mus[j], summary.ps[k])
                    })
                    .fold((f64::INFINITY, 0.0, 0.0), |a, b| if b.0 < a.0 { b } else { a }),
            },
            detail,
        ))
    })?;

    // 4. Plots.
    let plots = plan_plots(settings, &materials, &models)?;
    let curves: Vec<(String, Plotted)> = steps.run("plots", plots.len() as u64, |p| {
        let mut out = Vec::new();
        for (k, pl) in plots.iter().enumerate() {
            crate::interrupt::check()?;
            let drawn = plot::plot(
                eval,
                &pl.subjects,
                &pl.common,
                &pl.request,
                &staging.path(&pl.file),
            )
            .with_context(|| format!("drawing {}", pl.file))?;
            files.push(pl.file.clone());
            out.push((pl.file.clone(), drawn));
            p.advance(k as u64 + 1);
        }
        Ok((out, format!("{} PNG plots", plots.len())))
    })?;
    // The E(μ) curves extend each row's largest E.
    for (file, drawn) in &curves {
        let Plotted::Albedo(data) = drawn else {
            continue;
        };
        let Some(pl) = plots.iter().find(|p| &p.file == file) else {
            continue;
        };
        for c in &data.curves {
            let s = &pl.subjects[c.subject];
            let Some(row) = albedo.iter_mut().find(|r| {
                Some(r.material.as_str()) == pl.material && r.model == s.params.model().name()
            }) else {
                continue;
            };
            for (mu, rgb) in c.mu.iter().zip(&c.rgb) {
                let m = rgb.iter().copied().fold(f64::MIN, f64::max);
                if m > row.max_e {
                    row.max_e = m;
                    row.max_e_mu = *mu;
                }
            }
        }
    }

    // 5. Preview contact sheet.
    let sheet = Sheet::new(
        &materials.iter().map(|m| m.to_string()).collect::<Vec<_>>(),
        &models,
    )?;
    let scene = Scene::lab(
        settings.preview_cell,
        Shape::Sphere,
        LightKind::Point,
        DVec3::ZERO,
    );
    let preview_size = steps.run("preview", models.len() as u64, |p| {
        let image = preview::render(eval, &sheet, &scene, &mut |done, _| p.advance(done as u64))?;
        preview::write_exr(
            &image,
            &sheet,
            &scene,
            &backend,
            &staging.path("preview/contact_sheet.exr"),
        )?;
        let caption = preview::caption(&scene, 0.0, &backend);
        let size = preview::write_png(
            &image,
            &sheet,
            0.0,
            &caption,
            &staging.path("preview/contact_sheet.png"),
        )?;
        files.push("preview/contact_sheet.png".into());
        files.push("preview/contact_sheet.exr".into());
        Ok((
            (size, (image.width(), image.height())),
            format!(
                "{} x {} spheres of {} px, PNG {}x{} + EXR",
                sheet.materials.len(),
                sheet.models.len(),
                settings.preview_cell,
                size.0,
                size.1
            ),
        ))
    })?;

    // 6. Parity.
    let parity = match eval {
        Evaluator::Cpu => None,
        Evaluator::Gpu(_) => Some(steps.run("parity", models.len() as u64, |p| {
            let mut rows = Vec::new();
            for (k, &model) in models.iter().enumerate() {
                crate::interrupt::check()?;
                rows.push(parity_of(eval, model, &materials, settings.parity_grid)?);
                p.advance(k as u64 + 1);
            }
            let worst = rows.iter().map(|r| r.max_rel).fold(0.0, f64::max);
            let n: usize = rows.iter().map(|r| r.values).sum();
            Ok((rows, format!("{n} values, max relative error {worst:.1e}")))
        })?),
    };

    // 7. The page, last.
    let mut report = Report {
        dir: dir.to_path_buf(),
        backend: backend.clone(),
        settings: settings.clone(),
        steps: Vec::new(),
        files,
        albedo,
        lut,
        parity,
        seconds: 0.0,
    };
    let page_started = Instant::now();
    crate::interrupt::check()?;
    steps.progress.begin("page", 1);
    report.files.push(INDEX.to_string());
    let mut timed = steps.done.clone();
    // The page's own time is not known while it is written; it shows the steps before it, and
    // the terminal summary adds it.
    report.steps = timed.clone();
    report.seconds = started.elapsed().as_secs_f64();
    let html = page(&report, &plots, preview_size);
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
    Ok(report)
}

/// The LUT as a picture: E(μ, α) as a heat map (μ across, α up, each cell drawn at its true
/// extent on the α axis, which is not uniform) with a colour bar from 0 to 1.
fn draw_lut(
    spec: &crate::lut::LutSpec,
    lut: &crate::lut::LutSummary,
    path: &Path,
) -> Result<(u32, u32)> {
    use crate::plot::{colour_bar, colour_map, header, Drawn, Scale, FONT};
    use plotters::prelude::*;
    let size = (900u32, 760u32);
    let (n_mu, n_p) = (spec.n_mu, spec.n_p);
    // Cell edges on the α axis: the mapping at t = k/Np.
    let edges: Vec<f64> = (0..=n_p)
        .map(|k| spec.mapping.apply(spec.lo, spec.hi, k as f64 / n_p as f64))
        .collect();
    let title = format!(
        "Albedo LUT E(μ, α): GGX microfacet, white furnace ({} × {} cells)",
        n_mu, n_p
    );
    let lines = vec![
        format!(
            "{} with α from {} to {} ({})",
            spec.params.to_text(),
            spec.lo,
            spec.hi,
            spec.mapping.formula()
        ),
        "1 − E is the energy single scattering loses (Kulla–Conty compensate it); dark = low E"
            .to_string(),
    ];
    let draw = |root: &DrawingArea<BitMapBackend, plotters::coord::Shift>| -> Result<()> {
        let body = header(root, &title, &lines)?;
        let (w, _) = body.dim_in_pixel();
        let (chart_area, bar_area) = body.split_horizontally(w - 110);
        let mut chart = ChartBuilder::on(&chart_area)
            .margin(16)
            .x_label_area_size(44)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..1.0f64, spec.lo..spec.hi)
            .drawing("the LUT's axes")?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("μ = cos θo")
            .y_desc(format!("α ({})", spec.keys.join(", ")))
            .axis_desc_style((FONT, 16))
            .label_style((FONT, 13))
            .draw()
            .drawing("the LUT's axes")?;
        chart
            .draw_series((0..n_p).flat_map(|k| {
                let edges = &edges;
                (0..n_mu).map(move |j| {
                    let e = lut.e[k * n_mu + j].x;
                    Rectangle::new(
                        [
                            (j as f64 / n_mu as f64, edges[k]),
                            ((j + 1) as f64 / n_mu as f64, edges[k + 1]),
                        ],
                        colour_map(e).filled(),
                    )
                })
            }))
            .drawing("the LUT")?;
        colour_bar(
            &bar_area,
            &Scale {
                lo: 0.0,
                hi: 1.0,
                log: false,
            },
            "E (white furnace)",
        )
    };
    crate::plot::render(path, size, draw, |_| {
        bail!("the demo draws its LUT as PNG only")
    })?;
    Ok(size)
}

/// One plot the demo draws.
pub struct PlannedPlot {
    pub file: String,
    pub caption: String,
    /// The material all subjects share, if any (albedo curves per material).
    pub material: Option<&'static str>,
    pub subjects: Vec<Subject>,
    pub common: Common,
    pub request: Request,
}

fn plan_plots(
    settings: &Settings,
    materials: &[&'static str],
    models: &[Model],
) -> Result<Vec<PlannedPlot>> {
    let subject = |mat: &str, model: Model| -> Result<Subject> {
        Ok(Subject::new(material::preset(mat, model)?, Some(mat)))
    };
    let line = Common {
        size: PLOT_SIZE,
        ..Common::default()
    };
    let log = Common {
        log: true,
        ..line.clone()
    };
    let polar = |theta: Vec<f64>| {
        Request::Polar(plot::polar::PolarOptions {
            theta_i_deg: theta,
            samples: settings.polar_samples,
        })
    };
    let mut out = vec![
        PlannedPlot {
            file: "plots/polar_cook_torrance_materials.png".into(),
            caption: "Cook–Torrance at the four materials, θi = 45°, log radius: roughness sets the lobe's width, the diffuse share its floor.".into(),
            material: None,
            subjects: materials
                .iter()
                .map(|m| subject(m, Model::CookTorrance))
                .collect::<Result<_>>()?,
            common: log.clone(),
            request: polar(vec![45.0]),
        },
        PlannedPlot {
            file: "plots/polar_gold_models.png".into(),
            caption: "Gold under the glossy models, θi = 45°, log radius; the coupled model's mirror spike is drawn as an arrow labelled with its albedo.".into(),
            material: None,
            subjects: [
                Model::Phong,
                Model::BlinnPhong,
                Model::CookTorrance,
                Model::AshikhminShirley,
                Model::Microfacet(crate::model::microfacet::MicrofacetConfig::DEFAULT),
                Model::Coupled,
            ]
            .into_iter()
            .map(|m| subject("gold", m))
            .collect::<Result<_>>()?,
            common: log.clone(),
            request: polar(vec![45.0]),
        },
        PlannedPlot {
            file: "plots/polar_glazed_ceramic_cook_torrance.png".into(),
            caption: "Glazed ceramic under Cook–Torrance at θi = 0°, 30°, 60°, 80°, linear radius: the lobe grows and tilts off-specular towards grazing.".into(),
            material: None,
            subjects: vec![subject("glazed_ceramic", Model::CookTorrance)?],
            common: line.clone(),
            request: polar(vec![0.0, 30.0, 60.0, 80.0]),
        },
    ];
    // Hemisphere maps: an isotropic and an anisotropic lobe, four incidence angles each; the
    // height fits two rows of four square panels (as `lobe plot` sizes them).
    let hemi_subjects = vec![
        subject("gold", Model::CookTorrance)?,
        subject("tin", Model::AshikhminShirley)?,
    ];
    let side = 1090 / 4;
    out.push(PlannedPlot {
        file: "plots/hemisphere_gold_tin.png".into(),
        caption: "f over every ωo for ωi at θi = 0°, 30°, 60°, 80° (φi = 0), equal-area projection, log colour: gold Cook–Torrance (isotropic) and tin Ashikhmin–Shirley (anisotropic, brushed).".into(),
        material: None,
        common: Common {
            log: true,
            size: (1200, 150 + hemi_subjects.len() as u32 * (side + 30)),
            ..Common::default()
        },
        subjects: hemi_subjects,
        request: Request::Hemisphere(plot::hemisphere::HemisphereOptions {
            res: settings.hemisphere_res,
            ..Default::default()
        }),
    });
    for &mat in materials {
        out.push(PlannedPlot {
            file: format!("plots/albedo_{mat}.png"),
            caption: format!("Directional albedo E(μ) of every model at {mat}; above the dashed line E = 1 a model creates energy."),
            material: Some(mat),
            subjects: models
                .iter()
                .map(|&m| subject(mat, m))
                .collect::<Result<_>>()?,
            common: line.clone(),
            request: Request::Albedo(plot::albedo::AlbedoOptions {
                n_mu: settings.curve_mu,
                method: Method::Peak,
                samples: Some(settings.curve_samples),
                phi_deg: 0.0,
            }),
        });
    }
    Ok(out)
}

/// GPU against the f64 reference for one model at every material, on a cell-centred grid. As in
/// tests/parity.rs, both sides see the same inputs (f32-rounded parameters and directions), and
/// each value is held to |g − c| ≤ ATOL + rtol·|c| + conditioning.
fn parity_of(
    eval: &Evaluator,
    model: Model,
    materials: &[&str],
    [n_ti, n_to, n_po]: [usize; 3],
) -> Result<ParityRow> {
    use std::f64::consts::{FRAC_PI_2, TAU};
    let f32v = |v: DVec3| DVec3::new(v.x as f32 as f64, v.y as f32 as f64, v.z as f32 as f64);
    let mut pairs = Vec::with_capacity(n_ti * n_to * n_po);
    for a in 0..n_ti {
        let ti = (a as f64 + 0.5) * FRAC_PI_2 / n_ti as f64;
        for b in 0..n_to {
            let to = (b as f64 + 0.5) * FRAC_PI_2 / n_to as f64;
            for c in 0..n_po {
                let po = (c as f64 + 0.5) * TAU / n_po as f64;
                pairs.push((f32v(direction(ti, 0.0)), f32v(direction(to, po))));
            }
        }
    }
    let mut row = ParityRow {
        model: model.name().to_string(),
        values: 0,
        max_rel: 0.0,
        max_ratio: 0.0,
        over: 0,
        worst: String::new(),
    };
    for mat in materials {
        let p32: ParamSet = material::preset(mat, model)?.rounded_to_f32();
        let r = Reference::new(&p32, false);
        let g = eval.eval_pairs(&p32, false, &pairs)?;
        for (&(wi, wo), gv) in pairs.iter().zip(&g) {
            let c = r.eval(wi, wo);
            let tol = parity_tolerance(&p32, &r, wi, wo, c);
            for ch in 0..3 {
                let err = (gv[ch] - c[ch]).abs();
                let rel = err / c[ch].abs().max(REL_FLOOR);
                let ratio = err / tol[ch];
                row.values += 1;
                if ratio.is_nan() || ratio > 1.0 {
                    row.over += 1;
                }
                row.max_ratio =
                    row.max_ratio
                        .max(if ratio.is_nan() { f64::INFINITY } else { ratio });
                if rel > row.max_rel || rel.is_nan() {
                    row.max_rel = if rel.is_nan() { f64::INFINITY } else { rel };
                    row.worst = format!(
                        "{mat}, θi {:.1}°, θo {:.1}°, φo {:.1}°, channel {}",
                        wi.z.acos().to_degrees(),
                        wo.z.acos().to_degrees(),
                        wo.y.atan2(wo.x).to_degrees().rem_euclid(360.0),
                        ["r", "g", "b"][ch]
                    );
                }
            }
        }
    }
    Ok(row)
}

// ---------------------------------------------------------------------------------------------
// The page.

/// HTML-escapes text.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// An RGB triple as the page shows it (and tests/demo.rs parses it): four decimals.
pub fn rgb_text(v: [f64; 3]) -> String {
    format!("{:.4} {:.4} {:.4}", v[0], v[1], v[2])
}

const CSS: &str = "
body { font-family: system-ui, -apple-system, 'Segoe UI', sans-serif; margin: 0 auto; max-width: 1280px; padding: 1em 2em 4em; color: #222; line-height: 1.45; }
h1 { margin-bottom: 0.2em; } h2 { border-bottom: 2px solid #ddd; padding-bottom: 0.2em; margin-top: 2em; }
.meta { color: #555; }
table { border-collapse: collapse; margin: 0.6em 0 1.2em; font-size: 0.9em; }
th, td { border: 1px solid #ddd; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
th { background: #f4f4f4; }
td.num, td.rgb { font-family: ui-monospace, 'DejaVu Sans Mono', monospace; text-align: right; white-space: nowrap; }
td.gain { background: #fde2e1; color: #a40000; font-weight: bold; }
td.ok { color: #176b1a; } td.bad { background: #fde2e1; color: #a40000; font-weight: bold; }
figure { margin: 1em 0 2em; } figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { color: #444; font-size: 0.92em; margin-top: 0.3em; }
code { background: #f4f4f4; padding: 0 0.25em; border-radius: 3px; }
.note { background: #f7f7ff; border-left: 4px solid #99c; padding: 0.5em 1em; }
";

fn figure(out: &mut String, src: &str, size: (usize, usize), caption: &str) {
    let _ = writeln!(
        out,
        "<figure><a href=\"{0}\"><img src=\"{0}\" width=\"{1}\" height=\"{2}\" alt=\"{3}\"></a><figcaption>{3}</figcaption></figure>",
        esc(src),
        size.0,
        size.1,
        esc(caption)
    );
}

fn page(
    r: &Report,
    plots: &[PlannedPlot],
    (preview_png, preview_exr): ((usize, usize), (usize, usize)),
) -> String {
    let mut h = String::new();
    let _ = writeln!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>lobe demo</title><style>{CSS}</style></head><body>"
    );
    let _ = writeln!(h, "<h1>lobe demo</h1>");
    let _ = writeln!(
        h,
        "<p class=\"meta\">Four materials (tin, gold, glazed ceramic, granite) under {} reflection models, evaluated on <b id=\"backend\">{}</b>; {} settings; {} files; steps before the page took {:.1} s.</p>",
        r.albedo.iter().map(|a| &a.model).collect::<std::collections::BTreeSet<_>>().len(),
        esc(&r.backend),
        r.settings.name,
        r.files.len(),
        r.seconds
    );
    let _ = writeln!(
        h,
        "<p class=\"note\">Grids and sample counts are kept modest so that the whole demo finishes in under a minute on two CPU cores with lavapipe (Mesa's CPU Vulkan driver). Run <code>lobe table</code>, <code>lobe albedo</code>, <code>lobe plot</code> and <code>lobe preview</code> for finer versions. This run:</p><ul>"
    );
    for line in r.settings.describe() {
        let _ = writeln!(h, "<li>{}</li>", esc(&line));
    }
    let _ = writeln!(h, "</ul>");

    let _ = writeln!(h, "<h2>At a glance</h2><ul id=\"glance\">");
    let gains: Vec<&AlbedoRow> = r.albedo.iter().filter(|a| a.gains_energy()).collect();
    if gains.is_empty() {
        let _ = writeln!(
            h,
            "<li>No model gains energy: E ≤ 1 at every view direction sampled.</li>"
        );
    } else {
        let list: Vec<String> = gains
            .iter()
            .map(|a| {
                format!(
                    "{} {} (E = {:.3} at μ = {:.3})",
                    a.material, a.model, a.max_e, a.max_e_mu
                )
            })
            .collect();
        let _ = writeln!(
            h,
            "<li><b>Energy gain</b> (E &gt; 1, a physically impossible reflector): {}. The seed's smooth-layered model gains at grazing view (Fresnel → 1 plus the diffuse term); the coupled model exists to fix that.</li>",
            esc(&list.join("; "))
        );
    }
    if let (Some(a), Some(e)) = (r.lut.alpha.last(), r.lut.e_avg.last()) {
        let _ = writeln!(
            h,
            "<li><b>Energy loss</b> of single scattering: the GGX lobe under the white furnace keeps E<sub>avg</sub> = {:.3} at α = {:.3} (1 − E<sub>avg</sub> = {:.3} lost; see the LUT).</li>",
            e,
            a,
            1.0 - e
        );
    }
    match &r.parity {
        None => {
            let _ = writeln!(
                h,
                "<li><b>Parity</b>: not measured (<code>--backend cpu</code>).</li>"
            );
        }
        Some(rows) => {
            let worst = rows.iter().map(|x| x.max_rel).fold(0.0, f64::max);
            let ratio = rows.iter().map(|x| x.max_ratio).fold(0.0, f64::max);
            let over: usize = rows.iter().map(|x| x.over).sum();
            let n: usize = rows.iter().map(|x| x.values).sum();
            let _ = writeln!(
                h,
                "<li><b>GPU vs CPU parity</b> on {}: largest relative error {worst:.1e} over {n} values; largest error / tolerance {ratio:.3}; {over} over tolerance.</li>",
                esc(&r.backend)
            );
        }
    }
    let _ = writeln!(h, "</ul>");

    let _ = writeln!(
        h,
        "<h2>Steps</h2><table id=\"steps\"><tr><th>step</th><th>time</th><th>output</th></tr>"
    );
    for st in &r.steps {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td class=\"num\">{:.2} s</td><td>{}</td></tr>",
            st.name,
            st.seconds,
            esc(&st.detail)
        );
    }
    let _ = writeln!(h, "</table>");

    let _ = writeln!(h, "<h2>Preview</h2>");
    figure(
        &mut h,
        "preview/contact_sheet.png",
        preview_png,
        "Rows: materials; columns: models. Spheres under the lab's four point lights at (0,0,1), (0,1,1), (1,0,1), (−1,0,1), camera at the origin, no ambient light; sRGB, exposure 0 (a white Lambertian facing the camera reads 1). Mirror spikes of the layered models are not drawn.",
    );
    let _ = writeln!(
        h,
        "<p>Linear radiance: <a href=\"preview/contact_sheet.exr\">preview/contact_sheet.exr</a> ({}x{}, float RGB).</p>",
        preview_exr.0, preview_exr.1
    );

    let _ = writeln!(h, "<h2>Albedo and energy</h2>");
    let _ = writeln!(
        h,
        "<p>E(μ) is the directional albedo at view direction μ = cosθo (φo = 0), the mirror spike of the layered models included exactly; Ē the hemispherical albedo; <i>max E</i> the largest E seen over the E(μ) curve and the three points, any channel (above 1 + {GAIN_FLOOR:.0e}, marked <i>gain</i>, the model creates energy); <i>1 − E<sub>avg</sub></i> the energy not reflected (E<sub>avg</sub> = 2∫E(μ)μ dμ), absorption by the material's colour included. Each RGB cell reads r g b. Integrator: <code>peak</code>, {} nodes per direction; <i>err</i> is its own error estimate.</p>",
        r.settings.albedo_samples
    );
    let mats: Vec<&str> = {
        let mut v: Vec<&str> = Vec::new();
        for a in &r.albedo {
            if !v.contains(&a.material.as_str()) {
                v.push(&a.material);
            }
        }
        v
    };
    for mat in &mats {
        let _ = writeln!(
            h,
            "<h3>{}</h3><table class=\"albedo\"><tr><th>model</th><th>E(μ=0.1)</th><th>E(μ=0.5)</th><th>E(μ=1)</th><th>Ē</th><th>max E</th><th>1 − E<sub>avg</sub></th><th>err</th><th>data</th></tr>",
            esc(mat)
        );
        for a in r.albedo.iter().filter(|a| a.material == *mat) {
            let loss = a.e_avg.map(|x| 1.0 - x);
            let _ = write!(
                h,
                "<tr data-albedo=\"{}\" data-material=\"{}\" data-model=\"{}\"><td>{}</td>",
                esc(&a.json),
                esc(&a.material),
                esc(&a.model),
                esc(&a.model)
            );
            for (k, e) in a.e.iter().enumerate() {
                let _ = write!(
                    h,
                    "<td class=\"rgb\" data-field=\"mu={}\">{}</td>",
                    ALBEDO_MU[k],
                    rgb_text(*e)
                );
            }
            let _ = write!(
                h,
                "<td class=\"rgb\" data-field=\"hemispherical\">{}</td>",
                rgb_text(a.hemispherical)
            );
            let _ = write!(
                h,
                "<td class=\"num{}\" data-field=\"max_e\" title=\"at μ = {:.3}\">{:.4}{}</td>",
                if a.gains_energy() { " gain" } else { "" },
                a.max_e_mu,
                a.max_e,
                if a.gains_energy() { " gain" } else { "" }
            );
            let _ = write!(
                h,
                "<td class=\"rgb\" data-field=\"loss\">{}</td><td class=\"num\">{:.1e}</td><td><a href=\"{}\">json</a></td></tr>",
                rgb_text(loss),
                a.error,
                esc(&a.json)
            );
            let _ = writeln!(h);
        }
        let _ = writeln!(h, "</table>");
    }
    for pl in plots.iter().filter(|p| p.material.is_some()) {
        figure(
            &mut h,
            &pl.file,
            (PLOT_SIZE.0 as usize, PLOT_SIZE.1 as usize),
            &pl.caption,
        );
    }

    let _ = writeln!(h, "<h2>Albedo LUT</h2>");
    let _ = writeln!(
        h,
        "<p>Kulla–Conty's table: E(μ, α) and E<sub>avg</sub>(α) of {} (<code>lobe albedo --lut</code> writes others). Largest error estimate of any entry: {:.1e}.</p>",
        esc(&r.lut.what),
        r.lut.max_error
    );
    let (e, mu, alpha) = r.lut.min_e;
    figure(
        &mut h,
        &r.lut.png,
        (r.lut.png_size.0 as usize, r.lut.png_size.1 as usize),
        &format!("E(μ, α) of the GGX lobe under the white furnace; 1 − E is the energy single scattering loses. The smallest E in the table is {e:.3}, at μ = {mu:.3}, α = {alpha:.3}."),
    );
    let _ = writeln!(
        h,
        "<table id=\"lut\"><tr><th>α</th><th>E<sub>avg</sub></th><th>1 − E<sub>avg</sub></th></tr>"
    );
    let step = (r.lut.alpha.len() / 8).max(1);
    for k in (0..r.lut.alpha.len()).step_by(step) {
        let _ = writeln!(
            h,
            "<tr><td class=\"num\">{:.4}</td><td class=\"num\">{:.4}</td><td class=\"num\">{:.4}</td></tr>",
            r.lut.alpha[k],
            r.lut.e_avg[k],
            1.0 - r.lut.e_avg[k]
        );
    }
    let _ = writeln!(h, "</table><ul>");
    for f in &r.lut.files {
        let _ = writeln!(h, "<li><a href=\"{0}\">{0}</a></li>", esc(f));
    }
    let _ = writeln!(h, "</ul>");

    let _ = writeln!(h, "<h2>Lobes</h2>");
    for pl in plots.iter().filter(|p| p.material.is_none()) {
        let size = (pl.common.size.0 as usize, pl.common.size.1 as usize);
        figure(&mut h, &pl.file, size, &pl.caption);
    }

    let _ = writeln!(h, "<h2>Lobe tables</h2><p>Gold under Cook–Torrance, f(ωi, ωo) in 1/sr without the cosine, on cell-centred grids (angles in radians). Each table is an EXR mosaic (one slice per light direction; the layout is in the EXR header and the JSON sidecar), a NumPy array and a JSON sidecar.</p><ul>");
    for f in r.files.iter().filter(|f| f.starts_with("tables/")) {
        let _ = writeln!(h, "<li><a href=\"{0}\">{0}</a></li>", esc(f));
    }
    let _ = writeln!(h, "</ul>");

    let _ = writeln!(h, "<h2>GPU vs CPU parity</h2>");
    match &r.parity {
        None => {
            let _ = writeln!(
                h,
                "<p id=\"parity-none\">Not measured: this run used <code>--backend cpu</code> (the f64 reference alone), so there is no GPU result to compare. Run the demo on the GPU backend, or <code>cargo test --release --test parity</code>.</p>"
            );
        }
        Some(rows) => {
            let [a, b, c] = r.settings.parity_grid;
            let _ = writeln!(
                h,
                "<p>The GPU kernels (f32, on <b>{}</b>) against the CPU reference (f64), per model, at every material preset, on θi × θo × φo = {a} × {b} × {c} cell-centred directions (φi = 0). Both sides see the same f32-rounded inputs. <i>rel. error</i> is |g − c| / max(|c|, {REL_FLOOR:.0e} sr⁻¹); <i>error / tolerance</i> uses the parity test's model (tests/parity.rs): |g − c| ≤ 10⁻⁶ sr⁻¹ + (64ε + 8ε|x|)·|c| + the reference's spread over an 8ε change of direction, x the exponent of the lobe's exp and ε the f32 epsilon; a ratio above 1 fails.</p>",
                esc(&r.backend)
            );
            let _ = writeln!(h, "<table id=\"parity\"><tr><th>model</th><th>values</th><th>max rel. error</th><th>max error / tolerance</th><th>over tolerance</th><th>worst at</th></tr>");
            for row in rows {
                let _ = writeln!(
                    h,
                    "<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{:.2e}</td><td class=\"num\">{:.3}</td><td class=\"num {}\">{}</td><td>{}</td></tr>",
                    esc(&row.model),
                    row.values,
                    row.max_rel,
                    row.max_ratio,
                    if row.over == 0 { "ok" } else { "bad" },
                    row.over,
                    esc(&row.worst)
                );
            }
            let _ = writeln!(h, "</table>");
        }
    }

    let _ = writeln!(h, "<h2>Files</h2><ul class=\"files\">");
    for f in &r.files {
        let _ = writeln!(h, "<li><a href=\"{0}\">{0}</a></li>", esc(f));
    }
    let _ = writeln!(h, "</ul></body></html>");
    h
}
