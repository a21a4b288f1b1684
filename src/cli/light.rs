//! `lobe light`: the unit sphere seen from +z under an environment map, every texel summed for
//! every pixel (docs/design.md §15); P.exr, P.png and P.json.

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
    #[command(flatten)]
    backend: BackendArgs,
}

/// The flag of a library refusal's input.
fn flag(option: &str) -> Option<String> {
    match option {
        "env" => Some("--env".into()),
        "size" => Some("--size".into()),
        "exposure" => Some("--exposure".into()),
        _ => None,
    }
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
    // The outputs' names are checked before the map is read or any work done.
    lobe::light::files::paths(&a.output)?;
    let params = a.model.params()?;
    let map = with_flag(maps::resolve(&a.env), flag)?;
    let session = open_session(&a.backend)?;
    let progress = bar(a.size as u64, "{msg} [{bar:30}] {pos}/{len} rows");
    progress.set_message(format!("light on {}", session.backend_name()));
    let summary = session
        .write_light(
            &params,
            a.model.white_furnace,
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
    let [exr, png, json] = &summary.paths;
    eprintln!(
        "lobe: lit {} pixels of a {}² sphere under {} ({}x{} texels) in {:.2} s on {}; wrote {}, {} and {}",
        summary.lit_pixels,
        a.size,
        a.env,
        map.width(),
        map.height(),
        summary.seconds,
        summary.backend,
        exr.display(),
        png.display(),
        json.display()
    );
    Ok(())
}
