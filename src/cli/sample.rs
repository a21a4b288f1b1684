//! `lobe sample`: n draws of a model's sampler for one view direction, as `PATH.npy` with its
//! sidecar `PATH.json` (docs/design.md §13).

use super::{bar, open_session, with_flag, BackendArgs, ModelArgs};
use anyhow::{bail, Result};
use clap::Args;
use lobe::glam::DVec3;
use lobe::samples::MAX_DRAWS;
use lobe::Query;
use std::io::IsTerminal;
use std::path::PathBuf;

#[derive(Args)]
pub struct SampleArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// View direction θo in degrees, in [0, 90).
    #[arg(long = "theta-o-deg", allow_hyphen_values = true)]
    theta_o_deg: f64,
    /// Azimuth φo of the view direction, degrees.
    #[arg(long = "phi-o-deg", default_value_t = 0.0, allow_hyphen_values = true)]
    phi_o_deg: f64,
    /// Draws: a count or a power of two, 2^K, from 1 to 2^22.
    #[arg(short = 'n', value_parser = parse_count)]
    n: usize,
    /// The random stream's seed: the same seed draws the same directions (those of
    /// `lobe chi2 --seed` at its first view direction).
    #[arg(long, default_value_t = 0)]
    seed: u32,
    /// Output: PATH.npy (float64, one row per draw: wi x, y, z, weight r, g, b, pdf, delta),
    /// with its sidecar PATH.json beside it.
    #[arg(short = 'o', long = "output", value_name = "PATH.npy")]
    output: PathBuf,
    #[command(flatten)]
    backend: BackendArgs,
}

/// A count, `N` or `2^K`, from 1 to [`MAX_DRAWS`].
fn parse_count(text: &str) -> Result<usize, String> {
    let t = text.trim();
    let n = match t.split_once('^') {
        Some((base, exp)) if base.trim() == "2" => exp
            .trim()
            .parse::<u32>()
            .ok()
            .and_then(|k| 1usize.checked_shl(k).filter(|_| k < usize::BITS)),
        Some(_) => None,
        None => t.parse::<usize>().ok(),
    };
    match n {
        Some(n) if (1..=MAX_DRAWS).contains(&n) => Ok(n),
        _ => Err(format!(
            "expected draws from 1 to 2^22 ({MAX_DRAWS}), as N or 2^K (more: several runs with other --seed values, or lobe chi2, which counts 2^30 and more)"
        )),
    }
}

pub fn run(a: SampleArgs) -> Result<()> {
    if !(a.theta_o_deg.is_finite() && (0.0..90.0).contains(&a.theta_o_deg)) {
        bail!(
            "--theta-o-deg {}: expected a view angle in [0, 90) degrees",
            a.theta_o_deg
        );
    }
    if !a.phi_o_deg.is_finite() {
        bail!(
            "--phi-o-deg {}: expected a finite angle in degrees",
            a.phi_o_deg
        );
    }
    let flag = |option: &str| match option {
        "path" => Some("-o".to_string()),
        "n" => Some("-n".to_string()),
        "wo" => Some("--theta-o-deg".to_string()),
        _ => None,
    };
    with_flag(
        lobe::samples::paths(&a.output).map_err(anyhow::Error::from),
        flag,
    )?;
    let params = a.model.params()?;
    let (t, p) = (a.theta_o_deg.to_radians(), a.phi_o_deg.to_radians());
    let wo = DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
    let session = open_session(&a.backend)?;
    let progress = bar(
        a.n as u64,
        "{msg} [{bar:40}] {percent}% {per_sec} eta {eta}",
    );
    progress.set_message(format!("{} draws", params.model().name()));
    if !std::io::stderr().is_terminal() {
        progress.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let started = std::time::Instant::now();
    let written = session.write_samples(
        Query::one(&params).with_white_furnace(a.model.white_furnace),
        wo,
        a.n,
        a.seed,
        &a.output,
        &mut |done, _| progress.set_position(done as u64),
    );
    progress.finish_and_clear();
    let s = with_flag(written.map_err(super::session_error), flag)?;
    eprintln!(
        "wrote {} and {}: {} draws of {} on {} in {:.2} s ({} lost below the horizon, {} delta)",
        a.output.display(),
        a.output.with_extension("json").display(),
        s.len(),
        params.model().name(),
        s.backend,
        started.elapsed().as_secs_f64(),
        s.lost(),
        s.deltas()
    );
    Ok(())
}
