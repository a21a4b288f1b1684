//! The demo's steps before the page, one function each, in the order [`super::run`] times them.
//! Each writes into the staging folder, adds what it wrote to the list of files, and returns its
//! result with a few words on what it produced.

use super::lut_picture::draw_lut;
use super::parity::parity_of;
use super::{
    AlbedoRow, LutInfo, Measured, ParityRow, PlannedPlot, PreviewSizes, Progress, Settings,
    ALBEDO_MU,
};
use crate::eval::Evaluator;
use crate::integrate::{albedo_report, Method, Settings as AlbedoSettings};
use crate::material;
use crate::merl;
use crate::model::{Model, ParamSet};
use crate::output::StagingFolder;
use crate::plot::{self, Plotted};
use crate::preview::{self, LightKind, Scene, Shape, Sheet};
use crate::table::{write_table, TableMeta};
use anyhow::{Context, Result};
use glam::DVec3;
use std::path::Path;
use std::sync::Mutex;

/// What every step reads.
pub(crate) struct Demo<'a> {
    pub staging: &'a StagingFolder,
    pub settings: &'a Settings,
    pub backend: &'a str,
    pub materials: &'a [&'static str],
    pub models: &'a [Model],
}

/// The gold Cook–Torrance tables: (file, grid).
fn table_files(settings: &Settings) -> [(&'static str, crate::grid::Grid); 2] {
    [
        ("tables/gold_cook_torrance_full.exr", settings.table_full),
        (
            "tables/gold_cook_torrance_isotropic.exr",
            settings.table_isotropic,
        ),
    ]
}

/// Cells in all the tables: the tables step's amount of work.
pub(super) fn table_cells(settings: &Settings) -> u64 {
    table_files(settings)
        .iter()
        .map(|(_, g)| g.cells().unwrap_or(0))
        .sum()
}

/// Step 1, lobe tables: gold under Cook–Torrance on the full and the isotropic grid.
pub(super) fn tables(
    eval: &Evaluator,
    d: &Demo,
    files: &mut Vec<String>,
    p: &mut dyn Progress,
) -> Result<((), String)> {
    let cells = table_cells(d.settings);
    let gold = material::preset("gold", Model::CookTorrance)?;
    let mut before = 0;
    for (rel, grid) in table_files(d.settings) {
        let meta = TableMeta {
            params: &gold,
            white_furnace: false,
            grid,
            backend: d.backend.to_string(),
        };
        write_table(eval, &meta, &d.staging.path(rel), &mut |done, _| {
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
}

/// `lobe albedo`'s default integrator with the demo's sample count.
fn albedo_settings(d: &Demo) -> AlbedoSettings {
    AlbedoSettings {
        method: Method::Peak,
        samples: d.settings.albedo_samples,
        seed: crate::integrate::DEFAULT_SEED,
        white_furnace: false,
    }
}

/// The albedo report of `params` written to `rel` (a JSON file), as a page row under `material`.
pub(super) fn albedo_row(
    eval: &Evaluator,
    d: &Demo,
    material: &str,
    params: &ParamSet,
    rel: String,
    files: &mut Vec<String>,
) -> Result<AlbedoRow> {
    let points: Vec<(f64, f64)> = ALBEDO_MU.iter().map(|&m| (m, 0.0)).collect();
    let report = albedo_report(eval, params, &albedo_settings(d), &points, 0.0)
        .with_context(|| format!("albedo of {material} {}", params.model().name()))?;
    let json = report.to_json(params.into(), d.backend);
    std::fs::write(
        d.staging.path(&rel),
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
    Ok(AlbedoRow {
        material: material.to_string(),
        model: params.model().name().to_string(),
        json: rel,
        e,
        hemispherical: h.albedo.to_array(),
        e_avg: h.e_avg.to_array(),
        error,
        max_e,
        max_e_mu,
    })
}

/// Step 2, albedo: a JSON file per material × model, with `lobe albedo`'s default integrator.
pub(super) fn albedo(
    eval: &Evaluator,
    d: &Demo,
    files: &mut Vec<String>,
    p: &mut dyn Progress,
) -> Result<(Vec<AlbedoRow>, String)> {
    let mut rows = Vec::new();
    for mat in d.materials {
        for &model in d.models {
            eval.check_cancelled()?;
            let params = material::preset(mat, model)?;
            let rel = format!("albedo/{mat}_{}.json", model.name());
            rows.push(albedo_row(eval, d, mat, &params, rel, files)?);
            p.advance(rows.len() as u64);
        }
    }
    let detail = format!(
        "{} JSON files (peak rule, {} nodes per direction)",
        rows.len(),
        d.settings.albedo_samples
    );
    Ok((rows, detail))
}

/// Step 3, one albedo LUT: Kulla–Conty's E(μ, α) and E_avg(α) of the GGX microfacet lobe under
/// the white furnace (F = 1, no diffuse): what engines load to compensate the energy that single
/// scattering loses.
pub(super) fn lut(
    eval: &Evaluator,
    d: &Demo,
    files: &mut Vec<String>,
    p: &mut dyn Progress,
) -> Result<(LutInfo, String)> {
    let settings = d.settings;
    let mut params = ParamSet::defaults(Model::Microfacet(
        crate::model::microfacet::MicrofacetConfig::DEFAULT,
    ));
    for assignment in ["diffuse=0", "specular=1"] {
        params.set_text(assignment)?;
    }
    let mut spec = crate::lut::LutSpec::new(params);
    spec.white_furnace = true;
    spec.n_mu = settings.lut_res.0;
    spec.n_p = settings.lut_res.1;
    spec.samples = settings.lut_samples;
    std::fs::create_dir_all(d.staging.path("lut")).context("creating lut/")?;
    let exr = "lut/ggx_white_furnace_e_mu_alpha.exr";
    let summary = crate::lut::write(eval, &spec, &d.staging.path(exr), &mut |done, _| {
        p.advance(done)
    })?;
    let mut lut_files = Vec::new();
    for f in &summary.files {
        let rel = f
            .strip_prefix(d.staging.root())
            .with_context(|| format!("{} is outside the demo's folder", f.display()))?;
        lut_files.push(rel.to_string_lossy().into_owned());
    }
    let png = "lut/ggx_white_furnace_e_mu_alpha.png".to_string();
    let png_size = draw_lut(&spec, &summary, &d.staging.path(&png))?;
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
                .fold(
                    (f64::INFINITY, 0.0, 0.0),
                    |a, b| if b.0 < a.0 { b } else { a },
                ),
        },
        detail,
    ))
}

/// Step 4, the planned plots; returns each file with what was drawn.
pub(super) fn plots(
    eval: &Evaluator,
    d: &Demo,
    plots: &[PlannedPlot],
    files: &mut Vec<String>,
    p: &mut dyn Progress,
) -> Result<(Vec<(String, Plotted)>, String)> {
    let mut out = Vec::new();
    for (k, pl) in plots.iter().enumerate() {
        eval.check_cancelled()?;
        let drawn = plot::plot(
            eval,
            &pl.subjects,
            &pl.common,
            &pl.request,
            &d.staging.path(&pl.file),
        )
        .with_context(|| format!("drawing {}", pl.file))?;
        let params = plot::params_json_path(std::path::Path::new(&pl.file));
        plot::write_params_json(&d.staging.path(&pl.file), &pl.subjects, &drawn)?;
        plot::csv::write_data_csv(&d.staging.path(&pl.file), &pl.subjects, &drawn)?;
        let data = plot::csv::data_csv_path(std::path::Path::new(&pl.file));
        files.push(pl.file.clone());
        files.push(params.to_string_lossy().into_owned());
        files.push(data.to_string_lossy().into_owned());
        out.push((pl.file.clone(), drawn));
        p.advance(k as u64 + 1);
    }
    Ok((
        out,
        format!(
            "{} PNG plots, each with its parameters in JSON and its data in CSV",
            plots.len()
        ),
    ))
}

/// The E(μ) curves extend each albedo row's largest E (and where it was seen).
pub(super) fn extend_max_e(
    albedo: &mut [AlbedoRow],
    plots: &[PlannedPlot],
    curves: &[(String, Plotted)],
) {
    for (file, drawn) in curves {
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
}

/// Step 5, the preview contact sheet (rows materials, columns models) under the lab's lights, as
/// PNG and EXR.
/// "colours of tin, gold: lab report (…); granite: chosen by lobe: …": where each row's colour
/// comes from, so that a reader takes the lab's test colours for what they are.
fn colour_sources(materials: &[&str]) -> String {
    let mut groups: Vec<(String, Vec<&str>)> = Vec::new();
    for &m in materials {
        let source = crate::material::colour_source(m).unwrap_or_else(|| "not given".into());
        match groups.iter_mut().find(|g| g.0 == source) {
            Some(g) => g.1.push(m),
            None => groups.push((source, vec![m])),
        }
    }
    let parts: Vec<String> = groups
        .iter()
        .map(|(source, names)| format!("{}: {source}", names.join(", ")))
        .collect();
    format!("colours of {}", parts.join("; "))
}

pub(super) fn preview(
    eval: &Evaluator,
    d: &Demo,
    files: &mut Vec<String>,
    p: &mut dyn Progress,
) -> Result<(PreviewSizes, String)> {
    let sheet = Sheet::new(
        &d.materials
            .iter()
            .map(|m| m.to_string())
            .collect::<Vec<_>>(),
        d.models,
    )?;
    let scene = Scene::lab(
        d.settings.preview_cell,
        Shape::Sphere,
        LightKind::Point,
        DVec3::ZERO,
    );
    let image = preview::render(eval, &sheet, &scene, &mut |done, _| p.advance(done as u64))?;
    preview::write_exr(
        &image,
        &sheet,
        &scene,
        d.backend,
        &d.staging.path("preview/contact_sheet.exr"),
    )?;
    let caption = format!(
        "{}; {}",
        preview::caption(&scene, 0.0, d.backend),
        colour_sources(d.materials)
    );
    let size = preview::write_png(
        &image,
        &sheet,
        0.0,
        &caption,
        &d.staging.path("preview/contact_sheet.png"),
    )?;
    files.push("preview/contact_sheet.png".into());
    files.push("preview/contact_sheet.exr".into());
    Ok((
        (size, (image.width(), image.height())),
        format!(
            "{} x {} spheres of {} px, PNG {}x{} + EXR",
            sheet.materials.len(),
            sheet.models.len(),
            d.settings.preview_cell,
            size.0,
            size.1
        ),
    ))
}

/// The name of the demo's measured material: gold under Cook–Torrance as a MERL file.
pub(super) const MEASURED_NAME: &str = "gold_cook_torrance_merl";

/// Gold under Cook–Torrance written as a MERL file by the f64 reference (into a temporary folder,
/// removed again: the file is 35 MB) and read back as a model, with its count of missing values.
/// Once per process: run-time models stay registered, and the file is the same every time.
fn measured_model(eval: &Evaluator) -> Result<(Model, usize)> {
    static MODEL: Mutex<Option<(Model, usize)>> = Mutex::new(None);
    let mut made = MODEL.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(m) = *made {
        return Ok(m);
    }
    let cpu = match eval.cancel_token() {
        Some(t) => Evaluator::cpu().with_cancel(t),
        None => Evaluator::cpu(),
    };
    let dir = tempfile::tempdir().context("creating a temporary folder for the MERL file")?;
    let path = dir.path().join(format!("{MEASURED_NAME}.binary"));
    let gold = material::preset("gold", Model::CookTorrance)?;
    merl::write::write(&cpu, (&gold).into(), &path, &mut |_, _| {})?;
    let loaded = merl::model::load(&path)?;
    *made = Some((loaded.model, loaded.missing));
    Ok((loaded.model, loaded.missing))
}

/// Step 6, measured data: gold under Cook–Torrance as a MERL file read back as a model
/// ([`measured_model`]), its albedo with each lookup, beside the analytic model's.
pub(super) fn measured(
    eval: &Evaluator,
    d: &Demo,
    files: &mut Vec<String>,
    p: &mut dyn Progress,
) -> Result<(Measured, String)> {
    let (model, missing) = measured_model(eval)?;
    p.advance(1);
    let mut rows = Vec::new();
    for how in merl::lookup::LOOKUPS {
        eval.check_cancelled()?;
        let mut params = ParamSet::defaults(model);
        params.set_text(&format!("lookup={how}"))?;
        let rel = format!("albedo/{MEASURED_NAME}_{how}.json");
        let mut row = albedo_row(eval, d, "gold", &params, rel, files)?;
        row.model = format!("{} (lookup={how})", model.name());
        rows.push(row);
        p.advance(1 + rows.len() as u64);
    }
    let detail = format!(
        "gold cook_torrance as a MERL file ({} bytes, {missing} values missing), read back; {} JSON files",
        merl::FILE_BYTES,
        rows.len()
    );
    Ok((
        Measured {
            model: model.name().to_string(),
            missing,
            rows,
        },
        detail,
    ))
}

/// Step 7, GPU against the f64 reference, per model (only on the GPU backend).
pub(super) fn parity(
    eval: &Evaluator,
    d: &Demo,
    p: &mut dyn Progress,
) -> Result<(Vec<ParityRow>, String)> {
    let mut rows = Vec::new();
    for (k, &model) in d.models.iter().enumerate() {
        eval.check_cancelled()?;
        rows.push(parity_of(eval, model, d.materials, d.settings.parity_grid)?);
        p.advance(k as u64 + 1);
    }
    let worst = rows.iter().map(|r| r.max_rel).fold(0.0, f64::max);
    let n: usize = rows.iter().map(|r| r.values).sum();
    Ok((rows, format!("{n} values, max relative error {worst:.1e}")))
}

/// The white-furnace row's configurations: (column label, model, settings), colours at 1 and F = 1, so
/// that every pixel short of white is energy the model loses (and one above, energy it gains).
const FURNACE_ROW: [(&str, &str, &[&str]); 4] = [
    ("oren_nayar", "oren_nayar", &["albedo=1", "sigma=0.5"]),
    ("eon", "eon", &["albedo=1", "roughness=1"]),
    (
        "ggx",
        "microfacet",
        &["fresnel=none", "diffuse=0", "specular=1", "alpha=1"],
    ),
    (
        "ggx+kc",
        "microfacet",
        &[
            "fresnel=none",
            "diffuse=0",
            "specular=1",
            "alpha=1",
            "multiscatter=kulla_conty",
        ],
    ),
];

/// View cosines at which the furnace row's albedo is integrated, cell-centred; a pixel reads
/// E(μo) between them linearly.
const FURNACE_MUS: usize = 24;

/// Step 5b, the white-furnace row: spheres under a uniform white sky of radiance 1, so that a
/// pixel's radiance is the model's directional albedo E(μo) at that pixel's view cosine
/// (integrated with the default rule on the demo's backend). Oren–Nayar against EON, GGX at
/// α = 1 without and with Kulla–Conty. Returns the PNG's size.
pub(super) fn white_furnace(
    eval: &Evaluator,
    d: &Demo,
    files: &mut Vec<String>,
    p: &mut dyn Progress,
) -> Result<((usize, usize), String)> {
    let mut models = Vec::new();
    let mut params = Vec::new();
    let columns = FURNACE_ROW.map(|(label, ..)| label.to_string()).to_vec();
    for (_, name, sets) in FURNACE_ROW {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        let set = crate::resolve_params(name, None, &sets)?;
        models.push(set.model());
        params.push(vec![set]);
    }
    let sheet = Sheet {
        materials: vec!["white furnace".to_string()],
        models,
        columns,
        params,
    };
    let scene = Scene::lab(
        d.settings.preview_cell,
        Shape::Sphere,
        LightKind::Point,
        DVec3::ZERO,
    );
    let (w, h) = (scene.cell_width as usize, scene.cell_height as usize);
    let mus: Vec<(f64, f64)> = (0..FURNACE_MUS)
        .map(|j| ((j as f64 + 0.5) / FURNACE_MUS as f64, 0.0))
        .collect();
    let settings = AlbedoSettings {
        white_furnace: true,
        ..AlbedoSettings::default()
    };
    let mut image = preview::SheetImage {
        rows: 1,
        cols: sheet.models.len(),
        cell_width: w,
        cell_height: h,
        rgb: vec![[0.0; 3]; sheet.models.len() * w * h],
    };
    let width = image.width();
    let mut worst = Vec::new();
    for (col, column) in sheet.params.iter().enumerate() {
        eval.check_cancelled()?;
        let e: Vec<f64> = crate::integrate::directional(eval, &column[0], &settings, &mus)?
            .iter()
            .map(|a| a.albedo.x)
            .collect();
        worst.push(e.iter().map(|v| (v - 1.0).abs()).fold(0.0, f64::max));
        let at = |mu: f64| {
            let u = (mu * FURNACE_MUS as f64 - 0.5).clamp(0.0, (FURNACE_MUS - 1) as f64);
            let j = (u.floor() as usize).min(FURNACE_MUS - 2);
            let t = u - j as f64;
            e[j] * (1.0 - t) + e[j + 1] * t
        };
        for y in 0..h {
            for x in 0..w {
                let dir = scene.camera_ray(x as u32, y as u32);
                if let Some((_, n)) = preview::intersect(&scene, dir) {
                    let v = at(n.dot(-dir).clamp(0.0, 1.0)) as f32;
                    image.rgb[y * width + col * w + x] = [v; 3];
                }
            }
        }
        p.advance(col as u64 + 1);
    }
    let caption = "White furnace: each sphere under a uniform white sky of radiance 1 with colours at 1 and F = 1, so a pixel reads its albedo E(mu_o); darker is energy lost; left to right: oren_nayar (sigma = 0.5), eon (r = 1), ggx: microfacet GGX alpha = 1; ggx+kc: the same with multiscatter=kulla_conty";
    let size = preview::write_png(
        &image,
        &sheet,
        0.0,
        caption,
        &d.staging.path("preview/white_furnace.png"),
    )?;
    files.push("preview/white_furnace.png".into());
    Ok((
        size,
        format!(
            "{} spheres, largest |E - 1| over mu_o: {}",
            worst.len(),
            FURNACE_ROW
                .iter()
                .zip(&worst)
                .map(|((label, ..), v)| format!("{label} {v:.1e}"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    ))
}
