//! Running a scene: each table, albedo and preview it asks for, written under one folder.

use super::{AlbedoJob, Outputs, PreviewJob, RunSummary, Scene, TableJob, ALBEDO_MU};
use crate::eval::Evaluator;
use crate::preview::{self, Sheet};
use crate::{integrate, table};
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};

/// Creates the folder an output goes in, with its parents: the output folder itself when it is
/// new, and the sub-folders a scene's output paths may name.
fn create_parent(path: &Path) -> Result<()> {
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("creating the folder {}", parent.display()))?;
    }
    Ok(())
}

impl Scene {
    /// Produces the outputs `what` asks for under `out_dir` (made, with its parents, when missing),
    /// evaluating on `e`. `log` receives a line per output as it is written. Stops with
    /// "interrupted" on Ctrl-C (between and inside outputs), leaving no partial file.
    pub fn run(
        &self,
        e: &Evaluator,
        out_dir: &Path,
        what: Outputs,
        log: &mut dyn FnMut(&str),
    ) -> Result<RunSummary> {
        let mut summary = RunSummary::default();
        // A missing folder (and its parents) is made with the first file written into it, so a
        // run that fails before writing anything leaves nothing behind.
        if out_dir.exists() && !out_dir.is_dir() {
            bail!(
                "the output folder {} is a file, not a folder; pick another output folder",
                out_dir.display()
            );
        }
        let mut done = |files: Vec<PathBuf>, line: String| {
            log(&line);
            summary.written.extend(files);
            summary.lines.push(line);
        };
        if what.tables {
            for t in &self.tables {
                e.check_cancelled()?;
                self.run_table(e, t, out_dir, &mut done)?;
            }
        }
        if what.albedos {
            for a in &self.albedos {
                e.check_cancelled()?;
                self.run_albedo(e, a, out_dir, &mut done)?;
            }
        }
        if what.previews {
            for p in &self.previews {
                e.check_cancelled()?;
                self.run_preview(e, p, out_dir, &mut done)?;
            }
        }
        Ok(summary)
    }

    /// Writes one table (.exr, .npy and .json); `done` receives the files and the log line.
    fn run_table(
        &self,
        e: &Evaluator,
        t: &TableJob,
        out_dir: &Path,
        done: &mut dyn FnMut(Vec<PathBuf>, String),
    ) -> Result<()> {
        let m = &self.materials[t.material];
        let path = out_dir.join(&t.output);
        create_parent(&path)?;
        let meta = table::TableMeta {
            params: &m.params,
            white_furnace: t.white_furnace,
            grid: t.grid,
            backend: e.name(),
        };
        let started = std::time::Instant::now();
        table::write_table(e, &meta, &path, &mut |_, _| {})
            .with_context(|| format!("table of material '{}'", m.name))?;
        let line = format!(
            "table {} ({} {}, {} grid {:?}, {} cells, {:.2} s; {})",
            path.display(),
            m.name,
            m.params.model().name(),
            t.grid.name(),
            t.grid.shape(),
            t.grid.cells().unwrap_or(0),
            started.elapsed().as_secs_f64(),
            t.resolution
        );
        let (npy, json) = table::sibling_paths(&path);
        done(vec![path, npy, json], line);
        Ok(())
    }

    /// Writes one albedo report (JSON): E(μ) at [`ALBEDO_MU`] and the hemispherical albedo.
    fn run_albedo(
        &self,
        e: &Evaluator,
        a: &AlbedoJob,
        out_dir: &Path,
        done: &mut dyn FnMut(Vec<PathBuf>, String),
    ) -> Result<()> {
        let m = &self.materials[a.material];
        let path = out_dir.join(&a.output);
        create_parent(&path)?;
        let settings = integrate::Settings {
            method: a.method,
            samples: a.samples,
            white_furnace: a.white_furnace,
        };
        let points: Vec<(f64, f64)> = ALBEDO_MU.iter().map(|&mu| (mu, 0.0)).collect();
        let report = integrate::albedo_report(e, &m.params, &settings, &points, 0.0)
            .with_context(|| format!("albedo of material '{}'", m.name))?;
        e.check_cancelled()?;
        let mut json = report.to_json(&m.params, a.white_furnace, &e.name());
        json["material"] = serde_json::json!(m.name);
        crate::output::write_atomic(&path, |w| {
            serde_json::to_writer_pretty(w, &json)
                .with_context(|| format!("writing {}", path.display()))
        })?;
        let h = report.hemispherical.albedo;
        let line = format!(
            "albedo {} ({} {}, hemispherical [{:.4}, {:.4}, {:.4}], {:.2} s)",
            path.display(),
            m.name,
            m.params.model().name(),
            h.x,
            h.y,
            h.z,
            report.seconds
        );
        done(vec![path], line);
        Ok(())
    }

    /// Renders one contact sheet and writes it as .png and .exr (linear radiance).
    fn run_preview(
        &self,
        e: &Evaluator,
        p: &PreviewJob,
        out_dir: &Path,
        done: &mut dyn FnMut(Vec<PathBuf>, String),
    ) -> Result<()> {
        let sheet = self.sheet(p)?;
        let scene = self.preview_scene(p.cell, p.shape)?;
        let path = out_dir.join(&p.output);
        create_parent(&path)?;
        let exr_path = path.with_extension("exr");
        let started = std::time::Instant::now();
        let image = preview::render(e, &sheet, &scene, &mut |_, _| {})?;
        e.check_cancelled()?;
        preview::write_exr(&image, &sheet, &scene, &e.name(), &exr_path)?;
        let caption = preview::caption(&scene, p.exposure, &e.name());
        preview::write_png(&image, &sheet, p.exposure, &caption, &path)?;
        let line = format!(
            "preview {} and {} ({} x {} cells of {} px, {:.2} s)",
            path.display(),
            exr_path.display(),
            sheet.materials.len(),
            sheet.models.len(),
            p.cell,
            started.elapsed().as_secs_f64()
        );
        done(vec![path, exr_path], line);
        Ok(())
    }

    /// The contact sheet of preview `p`: its materials (rows) under its models (columns).
    pub fn sheet(&self, p: &PreviewJob) -> Result<Sheet> {
        let names: Vec<String> = p
            .materials
            .iter()
            .map(|&r| self.materials[r].name.clone())
            .collect();
        let params = p
            .models
            .iter()
            .map(|&model| {
                p.materials
                    .iter()
                    .map(|&r| self.cell_params(r, model))
                    .collect::<Result<Vec<_>>>()
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Sheet {
            materials: names,
            models: p.models.clone(),
            params,
        })
    }
}
