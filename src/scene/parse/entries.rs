//! The scene's job sections, `[[tables]]`, `[[albedo]]` and `[[previews]]`: each checked against
//! the materials and the bounds, its output name claimed, and turned into a job.

use super::{
    count, degrees, find_material, model_named, AlbedoFile, Locator, OutputNames, PreviewFile,
    TableFile,
};
use crate::grid::Grid;
use crate::integrate::Method;
use crate::model::Model;
use crate::preview::{self, Shape};
use crate::scene::{
    AlbedoJob, Material, PreviewJob, SceneError, SceneLight, TableJob, DEFAULT_N_PHI,
    DEFAULT_N_THETA, MAX_ALBEDO_SAMPLES, MAX_PREVIEW_CELL, MAX_TABLE_CELLS,
};
use toml::Spanned;
/// One `[[tables]]` section: its grid follows the material's isotropy unless `grid` says.
///
/// The azimuth rule: `n_phi` always counts cells over the full circle [0, 360 deg). The
/// isotropic grids (`isotropic`, and `halfdiff` on an isotropic material) have instead one
/// azimuth axis over the half circle [0, 180 deg] (dphi, or phi_d); `n_dphi` gives its cells.
/// Without `n_dphi` that axis takes n_phi / 2 cells, the same angular step as n_phi cells over
/// the full circle, and an odd n_phi is refused because no whole number of cells keeps its step.
/// The job's [`TableJob::resolution`] says which rule gave each axis its cells.
pub(super) fn table(
    loc: &Locator,
    t: &Spanned<TableFile>,
    materials: &[Material],
    names: &mut OutputNames,
) -> Result<TableJob, SceneError> {
    let tf = t.get_ref();
    let material = find_material(loc, materials, &tf.material)?;
    let m = &materials[material];
    let n_theta = count(loc, &tf.n_theta, "n_theta")?.unwrap_or(DEFAULT_N_THETA);
    let n_phi = count(loc, &tf.n_phi, "n_phi")?.unwrap_or(DEFAULT_N_PHI);
    let n_dphi = count(loc, &tf.n_dphi, "n_dphi")?;
    let choice = grid_choice(loc, t, m)?;
    let thetas = if choice.halfdiff {
        "theta_h, theta_d"
    } else {
        "theta_i, theta_o"
    };
    let theta_text = format!(
        "{thetas}: {n_theta} cells each over [0, 90 deg] (n_theta = {n_theta}{})",
        by_default(&tf.n_theta)
    );
    let azimuth = azimuth_cells(loc, t, m, &choice, (n_phi, n_dphi))?;
    let grid = choice.grid(n_theta, azimuth.cells);
    match grid.cells() {
        Some(c) if c <= MAX_TABLE_CELLS => {}
        _ => {
            let span = tf.n_theta.as_ref().map_or(t.span(), |s| s.span());
            return Err(loc.at(
                span,
                format!(
                    "the {} table of '{}' would have more than {MAX_TABLE_CELLS} cells (n_theta = {n_theta}, {}); lower the resolution",
                    grid.name(),
                    m.name,
                    azimuth.given
                ),
            ));
        }
    }
    Ok(TableJob {
        material,
        grid,
        white_furnace: tf.white_furnace,
        output: names.claim(loc, &tf.output, "exr", "table")?,
        resolution: format!(
            "{} grid since {}; {theta_text}; {}",
            choice.name, choice.reason, azimuth.text
        ),
    })
}

/// The kind of grid a table gets and why.
struct GridChoice {
    halfdiff: bool,
    isotropic: bool,
    /// `halfdiff`, `isotropic` or `full`.
    name: &'static str,
    /// Why: the `grid` key, and for `auto` and `halfdiff` the material's isotropy.
    reason: String,
}

impl GridChoice {
    fn grid(&self, n_theta: usize, n_azimuth: usize) -> Grid {
        match (self.halfdiff, self.isotropic) {
            (true, true) => Grid::HalfDiff {
                n_theta_h: n_theta,
                n_theta_d: n_theta,
                n_phi_d: n_azimuth,
            },
            (false, true) => Grid::Isotropic {
                n_theta_i: n_theta,
                n_theta_o: n_theta,
                n_dphi: n_azimuth,
            },
            (true, false) => Grid::HalfDiffFull {
                n_theta_h: n_theta,
                n_phi_h: n_azimuth,
                n_theta_d: n_theta,
                n_phi_d: n_azimuth,
            },
            (false, false) => Grid::Full {
                n_theta_i: n_theta,
                n_phi_i: n_azimuth,
                n_theta_o: n_theta,
                n_phi_o: n_azimuth,
            },
        }
    }
}

/// The table's `grid` key against the material's isotropy.
fn grid_choice(
    loc: &Locator,
    t: &Spanned<TableFile>,
    m: &Material,
) -> Result<GridChoice, SceneError> {
    let params = &m.params;
    let (kind, kind_span) = match &t.get_ref().grid {
        None => ("auto", t.span()),
        Some(g) => (g.get_ref().as_str(), g.span()),
    };
    let halfdiff = kind == "halfdiff";
    let isotropic = match kind {
        "auto" | "halfdiff" => params.is_isotropic(),
        "isotropic" if !params.is_isotropic() => {
            return Err(loc.at(
                kind_span,
                format!(
                    "grid = \"isotropic\" needs an isotropic material, but '{}' ({} {}) is anisotropic; use grid = \"full\" or \"auto\"",
                    m.name,
                    params.model().name(),
                    params.to_text()
                ),
            ))
        }
        "isotropic" => true,
        "full" => false,
        other => {
            return Err(loc.at(
                kind_span,
                format!("unknown grid '{other}'; the grids are: auto, full, isotropic, halfdiff"),
            ))
        }
    };
    let name = match (halfdiff, isotropic) {
        (true, _) => "halfdiff",
        (false, true) => "isotropic",
        (false, false) => "full",
    };
    let reason = match kind {
        "auto" | "halfdiff" => format!(
            "grid = \"{kind}\" and '{}' is {}",
            m.name,
            if isotropic {
                "isotropic"
            } else {
                "anisotropic"
            }
        ),
        _ => format!("grid = \"{kind}\""),
    };
    Ok(GridChoice {
        halfdiff,
        isotropic,
        name,
        reason,
    })
}

/// How a count that may be left out was set, for the job's resolution text.
fn by_default(v: &Option<Spanned<i64>>) -> &'static str {
    if v.is_none() {
        " by default"
    } else {
        ""
    }
}

/// The cells of a table's azimuth axes.
struct Azimuth {
    cells: usize,
    /// How they follow from the keys.
    text: String,
    /// The key to lower if the table is too large.
    given: String,
}

/// The azimuth cells from `n_phi` (with its default) or `n_dphi` (see [`table`] for the rule).
fn azimuth_cells(
    loc: &Locator,
    t: &Spanned<TableFile>,
    m: &Material,
    choice: &GridChoice,
    (n_phi, n_dphi): (usize, Option<usize>),
) -> Result<Azimuth, SceneError> {
    let tf = t.get_ref();
    let GridChoice {
        halfdiff,
        name: grid_name,
        reason,
        ..
    } = choice;
    if !choice.isotropic {
        if let Some(d) = &tf.n_dphi {
            return Err(loc.at(
                d.span(),
                format!(
                    "n_dphi = {}: the {grid_name} grid of '{}' ({reason}) has no [0, 180 deg] azimuth axis; give n_phi, the cells over [0, 360 deg)",
                    d.get_ref(),
                    m.name
                ),
            ));
        }
        let phis = if *halfdiff {
            "phi_h, phi_d"
        } else {
            "phi_i, phi_o"
        };
        return Ok(Azimuth {
            cells: n_phi,
            text: format!(
                "{phis}: {n_phi} cells each over [0, 360 deg) (n_phi = {n_phi}{})",
                by_default(&tf.n_phi)
            ),
            given: format!("n_phi = {n_phi}"),
        });
    }
    let axis = if *halfdiff { "phi_d" } else { "dphi" };
    match (&tf.n_phi, n_dphi) {
        (Some(p), Some(d)) => Err(loc.at(
            p.span(),
            format!(
                "n_phi = {n_phi} and n_dphi = {d} both given, but the {grid_name} grid of '{}' ({reason}) has one azimuth axis, {axis} over [0, 180 deg]; keep n_dphi (its cells) or n_phi (cells over [0, 360 deg), of which it takes half)",
                m.name
            ),
        )),
        (_, Some(d)) => Ok(Azimuth {
            cells: d,
            text: format!("{axis}: {d} cells over [0, 180 deg] (n_dphi = {d})"),
            given: format!("n_dphi = {d}"),
        }),
        (p, None) => {
            if n_phi % 2 == 1 {
                let span = p.as_ref().map_or(t.span(), |s| s.span());
                return Err(loc.at(
                    span,
                    format!(
                        "n_phi = {n_phi} is odd, but the {grid_name} grid of '{}' ({reason}) covers [0, 180 deg] with n_phi / 2 cells of the width n_phi gives over [0, 360 deg); use an even n_phi, or n_dphi = the cells over [0, 180 deg]",
                        m.name
                    ),
                ));
            }
            let d = n_phi / 2;
            Ok(Azimuth {
                cells: d,
                text: format!(
                    "{axis}: {d} cells over [0, 180 deg], half of n_phi = {n_phi}{} over [0, 360 deg) for the same {} deg step",
                    by_default(p),
                    degrees(360.0 / n_phi as f64)
                ),
                given: format!("n_phi = {n_phi}"),
            })
        }
    }
}

/// One `[[albedos]]` section.
pub(super) fn albedo(
    loc: &Locator,
    a: &Spanned<AlbedoFile>,
    materials: &[Material],
    names: &mut OutputNames,
) -> Result<AlbedoJob, SceneError> {
    let af = a.get_ref();
    let method = match &af.method {
        None => Method::Peak,
        Some(m) => Method::from_name(m.get_ref()).map_err(|e| loc.at(m.span(), e.to_string()))?,
    };
    let samples = match &af.samples {
        None => method.default_samples(),
        Some(n) if (16..=MAX_ALBEDO_SAMPLES).contains(n.get_ref()) => *n.get_ref() as usize,
        Some(n) => {
            return Err(loc.at(
                n.span(),
                format!(
                    "samples = {}: expected nodes per view direction in [16, {MAX_ALBEDO_SAMPLES}]",
                    n.get_ref()
                ),
            ))
        }
    };
    let seed = match &af.seed {
        None => crate::integrate::DEFAULT_SEED,
        Some(n) if method.sampler().is_none() => {
            return Err(loc.at(
                n.span(),
                format!(
                    "seed = {}: method {} draws nothing; a seed applies to the Monte Carlo methods (uniform, cosine, sampled)",
                    n.get_ref(),
                    method.name()
                ),
            ))
        }
        Some(n) => u32::try_from(*n.get_ref()).map_err(|_| {
            loc.at(
                n.span(),
                format!(
                    "seed = {}: expected an integer in [0, {}]",
                    n.get_ref(),
                    u32::MAX
                ),
            )
        })?,
    };
    Ok(AlbedoJob {
        material: find_material(loc, materials, &af.material)?,
        white_furnace: af.white_furnace,
        method,
        samples,
        seed,
        output: names.claim(loc, &af.output, "json", "albedo")?,
    })
}

/// One `[[previews]]` section: rows materials, columns models.
pub(super) fn preview(
    loc: &Locator,
    p: &Spanned<PreviewFile>,
    materials: &[Material],
    lights: &[SceneLight],
    names: &mut OutputNames,
) -> Result<PreviewJob, SceneError> {
    let pf = p.get_ref();
    let rows: Vec<usize> = match &pf.materials {
        None => (0..materials.len()).collect(),
        Some(list) => list
            .iter()
            .map(|s| find_material(loc, materials, s))
            .collect::<Result<_, _>>()?,
    };
    if rows.is_empty() {
        return Err(loc.at(p.span(), "a preview needs at least one material"));
    }
    let models = preview_models(loc, p, materials, &rows)?;
    check_presets(loc, p, materials, &rows, &models)?;
    let shape = match &pf.shape {
        None => Shape::Sphere,
        Some(s) => Shape::from_name(s.get_ref()).map_err(|e| loc.at(s.span(), e.to_string()))?,
    };
    let cell = preview_cell(loc, pf)?;
    let pixels = (rows.len() * models.len()) as u64 * u64::from(cell).pow(2);
    if pixels > preview::MAX_SHEET_PIXELS {
        return Err(loc.at(
            p.span(),
            format!(
                "{} materials x {} models of {cell}x{cell} pixels is {pixels} pixels; a sheet is at most {} (use a smaller cell or fewer materials, models)",
                rows.len(),
                models.len(),
                preview::MAX_SHEET_PIXELS
            ),
        ));
    }
    let exposure = match &pf.exposure {
        None => 0.0,
        Some(e) if e.get_ref().is_finite() => *e.get_ref(),
        Some(e) => return Err(loc.at(e.span(), "exposure must be a finite number of stops")),
    };
    if lights.is_empty() {
        return Err(loc.at(
            p.span(),
            "a preview needs lights: add [[lights]] sections to the scene",
        ));
    }
    Ok(PreviewJob {
        materials: rows,
        models,
        shape,
        cell,
        exposure,
        output: names.claim(loc, &pf.output, "png", "preview")?,
    })
}

/// The sheet's columns: the models listed, or those of its materials.
///
/// One column per model name: the header shows the name, and a material whose model has that
/// name is drawn with its own parameters in it (see `Scene::cell_params`), so two microfacet
/// materials of different distributions share the one "microfacet" column.
fn preview_models(
    loc: &Locator,
    p: &Spanned<PreviewFile>,
    materials: &[Material],
    rows: &[usize],
) -> Result<Vec<Model>, SceneError> {
    Ok(match &p.get_ref().models {
        None => {
            let mut v: Vec<Model> = Vec::new();
            for &r in rows {
                let m = materials[r].params.model();
                if !v.iter().any(|x| x.name() == m.name()) {
                    v.push(m);
                }
            }
            v
        }
        Some(list) => {
            if list.is_empty() {
                return Err(loc.at(p.span(), "a preview needs at least one model"));
            }
            let mut v: Vec<Model> = Vec::new();
            for s in list {
                let m = model_named(loc, s)?;
                if v.iter().any(|x| x.name() == m.name()) {
                    return Err(loc.at(
                        s.span(),
                        format!(
                            "model '{}' is listed twice; each model is one column of the sheet",
                            m.name()
                        ),
                    ));
                }
                v.push(m);
            }
            v
        }
    })
}

/// Refuses a cell whose material has no preset for the column's model.
fn check_presets(
    loc: &Locator,
    p: &Spanned<PreviewFile>,
    materials: &[Material],
    rows: &[usize],
    models: &[Model],
) -> Result<(), SceneError> {
    // A cell of another model than the material's own takes the material's preset for it.
    for &r in rows {
        let m = &materials[r];
        for &model in models {
            if model.name() != m.params.model().name() && m.preset.is_none() {
                return Err(loc.at(
                    p.span(),
                    format!(
                        "material '{}' has no preset, so it can be previewed only under its own model {}, not {}; give it a preset or list models = [\"{}\"]",
                        m.name,
                        m.params.model().name(),
                        model.name(),
                        m.params.model().name()
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The `cell` key: the side of one cell of the sheet, in pixels.
fn preview_cell(loc: &Locator, pf: &PreviewFile) -> Result<u32, SceneError> {
    Ok(match &pf.cell {
        None => preview::DEFAULT_CELL,
        Some(c) => match u32::try_from(*c.get_ref()) {
            Ok(v) if (1..=MAX_PREVIEW_CELL).contains(&v) => v,
            _ => {
                return Err(loc.at(
                    c.span(),
                    format!(
                        "cell = {}: expected a cell size in [1, {MAX_PREVIEW_CELL}] pixels",
                        c.get_ref()
                    ),
                ))
            }
        },
    })
}
