//! `lobe light`: the unit sphere seen from +z under an environment map, every texel summed for
//! every pixel, beside Karis' split sum and its error (docs/design.md §15); P.exr, P.png and
//! P.json, and under `--method both` P_split_sum.* and P_error.* too.

use super::{bar, open_session, session_error, with_flag, BackendArgs, ModelArgs};
use anyhow::Result;
use clap::Args;
use lobe::light::maps;
use std::path::PathBuf;

#[derive(Args)]
pub struct LightArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// The environment map: sky (a soft sun over a blue sky and a dark ground), studio (three
    /// round soft-edged lights in a dark room), constant (radiance 1 everywhere), or the path of
    /// a lat-long OpenEXR or Radiance .hdr file (+y up, Mitsuba's envmap layout; write ./sky for
    /// a file of that name).
    #[arg(long, value_name = "sky|studio|constant|PATH")]
    env: String,
    /// exact: every texel summed for every pixel; split_sum: Karis' split sum (the map
    /// prefiltered by the model's D, times the DFG table; lambert, microfacet and cook_torrance);
    /// both: P.exr (exact), P_split_sum.exr and P_error.exr (split sum - exact) with a PNG each,
    /// and the error figures in P.json (a model without a split sum gets the exact sum alone).
    #[arg(long, default_value = "both", value_parser = ["exact", "split_sum", "both"])]
    method: String,
    /// Pixels per side of the square image of the sphere.
    #[arg(long, default_value_t = lobe::light::DEFAULT_SIZE)]
    size: u32,
    /// Exposure of the PNG in stops (EV): radiance is multiplied by 2^EV before sRGB encoding.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    exposure: f64,
    /// Output EXR (linear radiance); the tone-mapped .png and the .json of settings go beside it.
    #[arg(
        short = 'o',
        long = "output",
        value_name = "PATH.exr",
        default_value = "light.exr"
    )]
    output: PathBuf,
    /// Sweep the model's roughness (microfacet: alpha, cook_torrance: roughness) and write the
    /// split sum's error against the exact sum per value as P_report.csv, a plot P_report.png and
    /// P_report.svg, and P.json (no images); --size sets each value's sphere.
    #[arg(long, conflicts_with = "method")]
    report: bool,
    /// Roughness values the report sweeps (2 to 64), cell-centred over the parameter's range.
    #[arg(long, value_name = "N", default_value_t = lobe::light::report::DEFAULT_STEPS, requires = "report")]
    report_steps: usize,
    /// Write the map prefiltered by the model's D as an engine's mip chain into this folder
    /// instead of images: level k of L at perceptual roughness k/(L-1), half the size of the
    /// level above, as latlong_L{k}.exr and six cube faces cube_L{k}_{px,nx,py,ny,pz,nz}.exr
    /// (OpenGL/KTX order), the split sum's DFG table as `lobe albedo --engine dfg` writes it
    /// (dfg.exr, .npy, .h, .json), and prefilter.json naming the layout (microfacet,
    /// cook_torrance).
    #[arg(long, value_name = "DIR", conflicts_with_all = ["method", "report"])]
    prefilter_out: Option<PathBuf>,
    /// Levels of the prefiltered chain (2 to 16; default: down to a level 8 texels high).
    #[arg(long, value_name = "N", requires = "prefilter_out")]
    prefilter_levels: Option<u32>,
    /// Write the map --env names (a built-in one or a file) as a lat-long OpenEXR file and
    /// nothing else: what Mitsuba's envmap or another tool reads to light the same scene.
    #[arg(long, value_name = "PATH.exr", conflicts_with_all = ["method", "report", "prefilter_out"])]
    write_env: Option<PathBuf>,
    #[command(flatten)]
    backend: BackendArgs,
}

/// The flag of a library refusal's input.
fn flag(option: &str) -> Option<String> {
    match option {
        "env" => Some("--env".into()),
        "size" => Some("--size".into()),
        "exposure" => Some("--exposure".into()),
        "method" => Some("--method".into()),
        "report-steps" => Some("--report-steps".into()),
        "report" => Some("--report".into()),
        "prefilter-out" => Some("--prefilter-out".into()),
        "prefilter-levels" => Some("--prefilter-levels".into()),
        _ => None,
    }
}

/// The files a run wrote, as its last line names them.
fn listed(paths: &[PathBuf]) -> String {
    let names: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
    names.join(", ")
}

pub fn run(a: LightArgs) -> Result<()> {
    if !a.exposure.is_finite() {
        anyhow::bail!(
            "--exposure {}: expected a finite number of stops",
            a.exposure
        );
    }
    with_flag(
        lobe::light::check_image_size(a.size).map_err(Into::into),
        flag,
    )?;
    if let Some(path) = &a.write_env {
        let map = with_flag(maps::resolve(&a.env), flag)?;
        maps::write_map(&map, &a.env, path)?;
        eprintln!(
            "lobe: wrote {} ({}x{} texels) to {}",
            a.env,
            map.width(),
            map.height(),
            path.display()
        );
        return Ok(());
    }
    if a.report {
        return run_report(a);
    }
    if a.prefilter_out.is_some() {
        return run_prefilter(a);
    }
    let method = with_flag(
        lobe::light::Method::from_name(&a.method).map_err(Into::into),
        flag,
    )?;
    // The outputs' names are checked before the map is read or any work done.
    lobe::light::files::paths(&a.output, method, true)?;
    let params = a.model.params()?;
    let map = with_flag(maps::resolve(&a.env), flag)?;
    let session = open_session(&a.backend)?;
    let has_split =
        lobe::model::split_sum::split_sum_lobe(&params, a.model.white_furnace).is_some();
    let passes = if method == lobe::light::Method::Both && has_split {
        2
    } else {
        1
    };
    let progress = bar(passes * a.size as u64, "{msg} [{bar:30}] {pos}/{len} rows");
    progress.set_message(format!("light on {}", session.backend_name()));
    let summary = session
        .write_light(
            &params,
            a.model.white_furnace,
            method,
            &map,
            &a.env,
            a.size,
            a.exposure,
            &a.output,
            &mut |done, _| progress.set_position(done),
        )
        .map_err(session_error);
    progress.finish_and_clear();
    let summary = with_flag(summary, flag)?;
    eprintln!(
        "lobe: lit {} pixels of a {}² sphere under {} ({}x{} texels, {}) in {:.2} s on {}; wrote {}",
        summary.lit_pixels,
        a.size,
        a.env,
        map.width(),
        map.height(),
        a.method,
        summary.seconds,
        summary.backend,
        listed(&summary.paths)
    );
    if let Some(e) = &summary.error {
        eprintln!(
            "lobe: split sum - exact: RMS {:.3e}, largest relative error {:.3e} at pixel (row {}, column {}), n.v = {:.3}",
            e.rms, e.max_relative, e.at.0, e.at.1, e.mu
        );
    } else if method == lobe::light::Method::Both {
        eprintln!(
            "lobe: model {} has no microfacet lobe the split sum can prefilter: wrote the exact sum alone",
            params.model().name()
        );
    }
    Ok(())
}

/// `lobe light --report`: the sweep, its CSV, plot and JSON.
fn run_report(a: LightArgs) -> Result<()> {
    with_flag(
        lobe::light::report::check_steps(a.report_steps).map_err(Into::into),
        flag,
    )?;
    // The outputs' names are checked before the map is read or any work done.
    lobe::light::report::paths(&a.output)?;
    let params = a.model.params()?;
    with_flag(
        lobe::light::report::RoughnessAxis::of(&params, a.model.white_furnace).map_err(Into::into),
        flag,
    )?;
    let map = with_flag(maps::resolve(&a.env), flag)?;
    let session = open_session(&a.backend)?;
    let progress = bar(
        2 * a.report_steps as u64 * a.size as u64,
        "{msg} [{bar:30}] {pos}/{len} rows",
    );
    progress.set_message(format!(
        "split-sum report, {} values on {}",
        a.report_steps,
        session.backend_name()
    ));
    let summary = session
        .write_light_report(
            &params,
            a.model.white_furnace,
            &map,
            &a.env,
            a.size,
            a.report_steps,
            &a.output,
            &mut |done, _| progress.set_position(done),
        )
        .map_err(session_error);
    progress.finish_and_clear();
    let summary = with_flag(summary, flag)?;
    eprintln!(
        "lobe: swept {} values of {} under {} on {}² spheres in {:.2} s on {}; wrote {}",
        summary.report.rows.len(),
        summary.report.axis.key,
        a.env,
        a.size,
        summary.seconds,
        summary.backend,
        listed(&summary.paths)
    );
    for r in &summary.report.rows {
        eprintln!(
            "lobe: {} = {:.4}: RMS {:.3e}, largest relative {:.3e} at n.v = {:.3}, mean relative {:.3e}",
            summary.report.axis.key,
            r.value,
            r.figures.rms,
            r.figures.max_relative,
            r.figures.mu,
            r.mean_relative
        );
    }
    Ok(())
}

/// `lobe light --prefilter-out DIR`: the prefiltered mip chain.
fn run_prefilter(a: LightArgs) -> Result<()> {
    let dir = a.prefilter_out.clone().unwrap_or_default();
    if let Some(n) = a.prefilter_levels {
        with_flag(
            lobe::light::prefilter::check_levels(n).map_err(Into::into),
            flag,
        )?;
    }
    let params = a.model.params()?;
    with_flag(
        lobe::light::prefilter::chain_lobe(&params).map_err(Into::into),
        flag,
    )?;
    let map = with_flag(maps::resolve(&a.env), flag)?;
    let levels = a
        .prefilter_levels
        .unwrap_or_else(|| lobe::light::prefilter::default_levels(map.width(), map.height()));
    let session = open_session(&a.backend)?;
    let progress = bar(levels as u64, "{msg} [{bar:30}] {pos}/{len} levels");
    progress.set_message("prefiltering".to_string());
    let summary = session
        .write_prefilter(&params, &map, &a.env, levels, &dir, &mut |done, _| {
            progress.set_position(done)
        })
        .map_err(session_error);
    progress.finish_and_clear();
    let summary = with_flag(summary, flag)?;
    eprintln!(
        "lobe: prefiltered {} ({}x{} texels) into {} levels in {:.2} s; wrote {} files into {}",
        a.env,
        map.width(),
        map.height(),
        levels,
        summary.seconds,
        summary.paths.len(),
        dir.display()
    );
    Ok(())
}
