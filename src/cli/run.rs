//! `lobe run`: everything a scene file asks for; also `table`, `albedo` and `preview --scene`.

use super::{open_session, BackendArgs};
use anyhow::{bail, Result};
use clap::Args;
use lobe::scene::Outputs;
use std::path::{Path, PathBuf};

#[derive(Args)]
pub struct RunArgs {
    /// The scene: materials, lights, camera and the tables, albedos and previews to produce
    /// (see data/scenes/lab.toml).
    #[arg(value_name = "SCENE.toml")]
    scene: PathBuf,
    /// The folder the scene's output paths are relative to.
    #[arg(long, value_name = "DIR", default_value = ".")]
    output_dir: PathBuf,
    #[command(flatten)]
    backend: BackendArgs,
}

pub fn run(a: RunArgs) -> Result<()> {
    run_scene(&a.scene, &a.output_dir, &a.backend, Outputs::ALL)
}

/// Loads a scene, checks every output before any work, produces `what`, and lists the pipelines
/// built with their build times.
pub fn run_scene(path: &Path, out_dir: &Path, backend: &BackendArgs, what: Outputs) -> Result<()> {
    let scene = lobe::scene::load(path)?;
    for (kind, asked, none) in [
        ("tables", what.tables, scene.tables.is_empty()),
        ("albedos", what.albedos, scene.albedos.is_empty()),
        ("previews", what.previews, scene.previews.is_empty()),
    ] {
        if what != Outputs::ALL && asked && none {
            bail!("{}: the scene asks for no {kind}", path.display());
        }
    }
    let needed: Vec<&str> = scene.models_needed(what).iter().map(|m| m.name()).collect();
    eprintln!(
        "lobe: scene '{}' ({}): {} materials, {} lights; kernels needed for: {}",
        scene.name,
        path.display(),
        scene.materials.len(),
        scene.lights.len(),
        needed.join(", ")
    );
    let mut log = |line: &str| println!("wrote {line}");
    let session = open_session(backend)?;
    let result = session.run_scene(&scene, out_dir, what, &mut log);
    if let Some(built) = session.built_kernels() {
        println!("pipelines built: {}", built.len());
        for (label, time) in &built {
            println!("  {label}: {:.1} ms", time.as_secs_f64() * 1e3);
        }
    }
    let summary = result.map_err(super::session_error)?;
    println!("lobe: {} files written", summary.written.len());
    Ok(())
}
