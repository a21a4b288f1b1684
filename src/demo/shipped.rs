//! The demo's `.brdf` section: the BRDF Explorer file the project ships,
//! `data/brdf/coated_plastic.brdf` (a GGX clear coat over a Lambertian base, coupled by
//! (1 − F)(1 − F)), as a model next to the built-in ones: its albedo, and a comparison with the
//! nearest built-in configuration, `microfacet` with the same coat over a plain Lambertian
//! `diffuse` term ([`crate::compare`]), with its overlay and difference plot. A `.brdf` shader
//! has no f64 twin, so the section needs the GPU backend; with `--backend cpu` it says so.

use super::html::{albedo_row as albedo_html, esc, figure, rgb_text, ALBEDO_HEADER};
use super::steps::{albedo_row, Demo};
use super::{AlbedoRow, Progress, ALBEDO_MU};
use crate::backend::Precision;
use crate::compare::{self, Bins, Comparison, Options, Side};
use crate::eval::Evaluator;
use crate::grid::Grid;
use crate::integrate::Settings;
use crate::model::{Model, ParamSet};
use crate::plot::difference;
use crate::plot::{Format, Subject};
use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::sync::Mutex;

/// The file, as the project ships it.
const BRDF_TEXT: &str = include_str!("../../data/brdf/coated_plastic.brdf");

/// Where the demo puts a copy of it, relative to the output folder.
pub const BRDF_FILE: &str = "brdf/coated_plastic.brdf";

/// The parameters of the built-in configuration nearest to the file at its defaults: the same GGX coat
/// (α = roughness² = 0.35², height-correlated Smith, Schlick with R0 = ((1.5 − 1)/(1.5 + 1))² =
/// 0.04) over the same base colour, but with a plain Lambertian base where the file dims it by
/// (1 − F(N·L))(1 − F(N·V)).
pub const TWIN_SETS: [&str; 7] = [
    "distribution=ggx",
    "masking=smith_correlated",
    "fresnel=schlick",
    "f0=0.04",
    "specular=1",
    "alpha=0.1225",
    "diffuse=0.75,0.12,0.08",
];

/// [`TWIN_SETS`] as a model spec, `microfacet{...}`.
pub fn twin_spec() -> String {
    format!("microfacet{{{}}}", TWIN_SETS.join(","))
}

/// The comparison's bins: 24 × 24 × 48 isotropic cells (27,648), under a second on lavapipe.
const GRID: Grid = Grid::Isotropic {
    n_theta_i: 24,
    n_theta_o: 24,
    n_dphi: 48,
};

/// What the section shows.
#[derive(Clone, Debug)]
pub struct Shipped {
    /// The model the file became.
    pub model: String,
    /// The file's albedo and its twin's.
    pub rows: Vec<AlbedoRow>,
    /// The file (A) against the twin (B).
    pub comparison: Comparison,
    /// The overlay and the difference plot, relative to the output folder.
    pub plots: (String, String),
    /// Their sizes in pixels.
    pub sizes: ((u32, u32), (u32, u32)),
}

/// The file registered as a model, once per process (a copy in a temporary folder: the
/// registry keeps one model per file).
fn shipped_model() -> Result<Model> {
    static MODEL: Mutex<Option<Model>> = Mutex::new(None);
    let mut made = MODEL.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(m) = *made {
        return Ok(m);
    }
    let dir = tempfile::tempdir().context("creating a temporary folder for the .brdf file")?;
    let path = dir.path().join("coated_plastic.brdf");
    std::fs::write(&path, BRDF_TEXT).with_context(|| format!("writing {}", path.display()))?;
    let loaded = crate::brdf::load(&path, &crate::brdf::LoadOptions::default())?;
    *made = Some(loaded.model);
    Ok(loaded.model)
}

/// The step: the file's albedo, its twin's, their comparison and plots; None on the CPU
/// backend.
pub(super) fn shipped(
    eval: &Evaluator,
    d: &Demo,
    files: &mut Vec<String>,
    p: &mut dyn Progress,
) -> Result<(Option<Shipped>, String)> {
    if eval.precision() == Precision::F64 {
        return Ok((
            None,
            "not run: a .brdf shader has no f64 twin for the CPU backend".into(),
        ));
    }
    std::fs::create_dir_all(d.staging.path("brdf")).context("creating brdf/")?;
    std::fs::write(d.staging.path(BRDF_FILE), BRDF_TEXT)
        .with_context(|| format!("writing {BRDF_FILE}"))?;
    files.push(BRDF_FILE.to_string());
    let model = shipped_model()?;
    let file = ParamSet::defaults(model);
    let sets: Vec<String> = TWIN_SETS.iter().map(|s| s.to_string()).collect();
    let twin = crate::resolve_params("microfacet", None, &sets)?;
    let mut rows = Vec::new();
    for (params, rel) in [
        (&file, "albedo/coated_plastic_brdf.json"),
        (&twin, "albedo/coated_plastic_twin_microfacet.json"),
    ] {
        eval.check_cancelled()?;
        let mut row = albedo_row(eval, d, "-", params, rel.to_string(), files)?;
        row.material = String::new();
        rows.push(row);
        p.advance(rows.len() as u64);
    }
    rows[1].model = "microfacet (nearest built-in)".into();
    let opts = Options {
        bins: Bins::Grid(GRID),
        white_furnace: false,
        mus: ALBEDO_MU.to_vec(),
        albedo: Some(Settings {
            samples: 4096,
            ..Settings::default()
        }),
    };
    let comparison = compare::compare(
        eval,
        &Side::new(file.clone()),
        &Side::new(twin.clone()),
        &opts,
        &mut |_, _| {},
    )?;
    p.advance(3);
    let a = Subject {
        label: format!("A: {BRDF_FILE}"),
        params: file,
    };
    let b = Subject {
        label: "B: microfacet (same coat, plain Lambertian base)".into(),
        params: twin,
    };
    let plot_opts = difference::PlotOptions::default();
    let plots = difference::write_plots(
        eval,
        &a,
        &b,
        &plot_opts,
        &d.staging.path("plots/coated_plastic_vs_microfacet"),
        Format::Png,
    )?;
    let rel = |p: &std::path::Path| {
        format!(
            "plots/{}",
            p.file_name().unwrap_or_default().to_string_lossy()
        )
    };
    let plots = (rel(&plots.polar_path), rel(&plots.difference_path));
    for f in [&plots.0, &plots.1] {
        files.push(f.clone());
        files.push(f.replace(".png", ".json"));
    }
    p.advance(4);
    let detail = format!(
        "{BRDF_FILE} against microfacet: relative L2 {:.3}, log error {:.4}",
        comparison.relative_l2.total, comparison.log_error.total
    );
    Ok((
        Some(Shipped {
            model: model.name().to_string(),
            rows,
            comparison,
            plots,
            sizes: (plot_opts.common.size, plot_opts.difference_size),
        }),
        detail,
    ))
}

/// The section of the page.
pub(super) fn section(h: &mut String, s: Option<&Shipped>) {
    let _ = writeln!(h, "<h2 id=\"shipped-brdf\">A BRDF Explorer file</h2>");
    let Some(s) = s else {
        let _ = writeln!(
            h,
            "<p id=\"shipped-none\">Not run: <code>{BRDF_FILE}</code> is a GLSL shader with no f64 twin, and this run used the CPU backend.</p>"
        );
        return;
    };
    let _ = writeln!(
        h,
        "<p><a href=\"{BRDF_FILE}\"><code>{BRDF_FILE}</code></a> (the project's <code>data/brdf/coated_plastic.brdf</code>, BRDF Explorer's format) compiled at run time as the model <code>{}</code> (<code>--model {BRDF_FILE}</code>), at its defaults, beside the nearest built-in configuration <code>{}</code>: the same coat, with a plain Lambertian base where the file dims the base by (1 − F(N·L))(1 − F(N·V)).</p><table class=\"albedo\" id=\"shipped-albedo\">{ALBEDO_HEADER}",
        esc(&s.model),
        esc(&twin_spec())
    );
    for r in &s.rows {
        albedo_html(h, r);
    }
    let c = &s.comparison;
    let _ = writeln!(h, "</table>");
    let largest = c.largest.map_or(String::new(), |l| {
        format!(
            ", at θi = {:.1}°, θo = {:.1}°, φo − φi = {:.1}°, channel {}",
            l.theta_i_deg,
            l.theta_o_deg,
            l.phi_deg,
            compare::CHANNELS[l.channel]
        )
    });
    let hemi = c
        .hemispherical
        .map_or(String::new(), |p| rgb_text(p.difference));
    let _ = writeln!(
        h,
        "<p id=\"shipped-compare\"><code>lobe compare {BRDF_FILE} '{}' --grid isotropic --res 24,24,48</code> (A = the file): relative L2 ‖B − A‖/‖A‖ = <span data-field=\"relative_l2\">{:.4}</span>, cosine-weighted log error <span data-field=\"log_error\">{:.4}</span>, relative difference RMS {:.4}, max {:.4}{largest}; Ē<sub>A</sub> − Ē<sub>B</sub> = <span data-field=\"hemispherical_difference\">{hemi}</span>.</p>",
        esc(&twin_spec()),
        c.relative_l2.total,
        c.log_error.total,
        c.relative_rms,
        c.relative_max,
    );
    figure(
        h,
        &s.plots.0,
        (s.sizes.0 .0 as usize, s.sizes.0 .1 as usize),
        "The file (A) and the built-in microfacet (B) in the plane of incidence: the specular peaks coincide (the same coat); the curves part in the diffuse floor, lower for the file.",
    );
    figure(
        h,
        &s.plots.1,
        (s.sizes.1 .0 as usize, s.sizes.1 .1 as usize),
        "(B − A)/max(|A|, |B|, 1e-4) over the hemisphere: look at the rim, where the file's (1 − F) factors darken the base most and B is brighter; at the mirror direction the two agree.",
    );
}
