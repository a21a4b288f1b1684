//! `lobe table`: one lobe table (EXR mosaic, .npy and .json), or every table of a scene.

use super::run::run_scene;
use super::{bar, open_session, BackendArgs, ModelArgs};
use anyhow::{anyhow, bail, Result};
use clap::{Args, ValueEnum};
use lobe::grid::Grid;
use lobe::input::option_of;
use lobe::Query;
use std::path::{Path, PathBuf};

/// The table grids (`lobe table --grid`, `lobe compare --grid`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum GridArg {
    /// (theta_i, phi_i, theta_o, phi_o): any model.
    Full,
    /// (theta_i, theta_o, delta_phi in [0, 180 deg]): isotropic parameter sets.
    Isotropic,
    /// Rusinkiewicz's half/difference angles: theta_h, theta_d, phi_d in [0, 180 deg] for
    /// isotropic parameter sets, or theta_h, phi_h, theta_d, phi_d for any.
    Halfdiff,
}

impl GridArg {
    /// The grid's name, as `--grid` and [`lobe::grid::Grid::parse`] spell it.
    pub fn name(self) -> &'static str {
        match self {
            GridArg::Full => "full",
            GridArg::Isotropic => "isotropic",
            GridArg::Halfdiff => "halfdiff",
        }
    }
}

/// What -o holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum FormatArg {
    /// An EXR mosaic, with the .npy and .json beside it.
    Exr,
    /// A MERL BRDF database file (PATH.binary): f at the centres of MERL's 90 x 90 x 180
    /// half/difference bins (theta_h warped as MERL's sqrt index), planar float64 over MERL's
    /// channel scales; needs --grid halfdiff (--res, if given, 90,90,180) and an isotropic model.
    Merl,
}

#[derive(Args)]
pub struct TableArgs {
    #[command(flatten)]
    model: ModelArgs,
    #[command(flatten)]
    backend: BackendArgs,
    /// Grid of (wi, wo) cells.
    #[arg(long, value_enum, default_value_t = GridArg::Full)]
    grid: GridArg,
    /// Resolution: NTHETA_I,NPHI_I,NTHETA_O,NPHI_O (full), NTHETA_I,NTHETA_O,NDPHI (isotropic),
    /// NTHETA_H,NTHETA_D,NPHI_D or NTHETA_H,NPHI_H,NTHETA_D,NPHI_D (halfdiff).
    #[arg(long, required_unless_present_any = ["scene", "format"])]
    res: Option<String>,
    /// File format of -o.
    #[arg(long, value_enum, default_value_t = FormatArg::Exr)]
    format: FormatArg,
    /// Output EXR path; the .npy and .json are written beside it (PATH.binary with --format
    /// merl).
    #[arg(
        short = 'o',
        long = "output",
        value_name = "PATH.exr",
        required_unless_present = "scene"
    )]
    output: Option<PathBuf>,
    /// Write every table a scene file asks for instead (see `lobe run --help`); --model, --set,
    /// --material, --white-furnace, --grid, --res and -o do not apply then.
    #[arg(long, value_name = "SCENE.toml", conflicts_with_all = ["res", "output", "sets", "material"])]
    scene: Option<PathBuf>,
    /// With --scene: the folder the scene's output paths are relative to.
    #[arg(long, value_name = "DIR")]
    output_dir: Option<PathBuf>,
    /// Let a table with NaN, Inf or negative values replace an existing table of the same name
    /// (without it such a table is written only where none exists).
    #[arg(long)]
    allow_invalid: bool,
    /// Take the model as reciprocal, f(wi, wo) = f(wo, wi), where it does not say so itself (a
    /// .brdf file; built-in models and MERL files are): on the isotropic grid with NTHETA_I =
    /// NTHETA_O only the cells with theta_i <= theta_o are evaluated and each is copied into
    /// its mirror cell, so for a model that is not reciprocal both cells hold f at
    /// theta_i <= theta_o; on the three-number halfdiff grid likewise phi_d <= 90 deg is copied
    /// to 180 deg - phi_d. Other grids are unaffected.
    #[arg(long, conflicts_with = "scene")]
    reciprocal: bool,
}

pub fn run(a: TableArgs) -> Result<()> {
    if let Some(scene) = &a.scene {
        return run_scene(
            scene,
            a.output_dir.as_deref().unwrap_or(Path::new(".")),
            &a.backend,
            lobe::scene::Outputs::TABLES,
        );
    }
    if a.output_dir.is_some() {
        bail!("--output-dir applies only with --scene; for one table give -o PATH.exr");
    }
    if a.format == FormatArg::Merl {
        return run_merl(&a);
    }
    let (Some(res), Some(output)) = (&a.res, &a.output) else {
        bail!("give --res and -o PATH.exr, or --scene FILE");
    };
    let params = a.model.params()?;
    let grid = Grid::parse(a.grid.name(), res).map_err(|e| anyhow!("--res: {e}"))?;
    let cells =
        lobe::table::check_request(&params, &grid, output).map_err(|e| match option_of(&e) {
            Some("grid") => {
                let instead = match grid {
                    Grid::Isotropic { .. } => "--grid full",
                    _ => "--grid halfdiff --res NTHETA_H,NPHI_H,NTHETA_D,NPHI_D",
                };
                anyhow!(
                    "--grid {} with --res {res}: {e:#} ({instead})",
                    a.grid.name()
                )
            }
            Some("cells") => e.context(format!("--res {res}")),
            Some("path") => e.context("-o"),
            _ => e,
        })?;
    let session = open_session(&a.backend)?;
    let progress = bar(cells, "{msg} [{bar:40}] {percent}% {per_sec} eta {eta}");
    progress.set_message(format!("{} table", params.model().name()));
    let started = std::time::Instant::now();
    let mut show = |done, _| progress.set_position(done);
    fn allow_hint(e: impl std::fmt::Display) -> anyhow::Error {
        anyhow!("{e} (--allow-invalid lets it replace the existing table)")
    }
    let write = if a.reciprocal {
        lobe::Session::write_table_reciprocal
    } else {
        lobe::Session::write_table
    };
    let written = write(
        &session,
        Query::one(&params).with_white_furnace(a.model.white_furnace),
        grid,
        output,
        a.allow_invalid,
        &mut show,
    )
    .map_err(|e| match &e {
        lobe::Error::Input { input, .. } if input.option == "allow_invalid" => allow_hint(e),
        _ => e.into(),
    });
    progress.finish_and_clear();
    let invalid = written?;
    super::warn_invalid(params.model().name(), &invalid);
    let (npy, json) = lobe::table::sibling_paths(output);
    eprintln!(
        "lobe: wrote {} ({} cells, {:.2} s on {}), {} and {}",
        output.display(),
        cells,
        started.elapsed().as_secs_f64(),
        session.backend_name(),
        npy.display(),
        json.display()
    );
    Ok(())
}

/// `--format merl`: the model at MERL's bin centres, as a MERL file.
fn run_merl(a: &TableArgs) -> Result<()> {
    let merl_res = "90,90,180";
    if a.grid != GridArg::Halfdiff {
        bail!(
            "--format merl writes MERL's half/difference bins: give --grid halfdiff (not --grid {})",
            a.grid.name()
        );
    }
    if let Some(res) = &a.res {
        if Grid::parse("halfdiff", res).ok() != Some(lobe::merl::write::GRID) {
            bail!("--res {res}: a MERL file has {merl_res} bins (theta_h, theta_d, phi_d); give --res {merl_res} or leave it out");
        }
    }
    let Some(output) = &a.output else {
        bail!("give -o PATH.binary");
    };
    let params = a.model.params()?;
    lobe::merl::write::check_request(&params, output).map_err(|e| match option_of(&e) {
        Some("grid") => anyhow!("--format merl: {e:#}"),
        Some("path") => e.context("-o"),
        _ => e,
    })?;
    let session = open_session(&a.backend)?;
    let bins = lobe::merl::BINS as u64;
    let progress = bar(bins, "{msg} [{bar:40}] {percent}% {per_sec} eta {eta}");
    progress.set_message(format!("{} MERL file", params.model().name()));
    let started = std::time::Instant::now();
    session.write_merl(
        Query::one(&params).with_white_furnace(a.model.white_furnace),
        output,
        &mut |done, _| progress.set_position(done),
    )?;
    progress.finish_and_clear();
    eprintln!(
        "lobe: wrote {} (MERL, {bins} bins, {:.2} s on {})",
        output.display(),
        started.elapsed().as_secs_f64(),
        session.backend_name()
    );
    Ok(())
}
