//! Running a scene: each table, albedo and preview it asks for, written under one folder.

use super::{AlbedoJob, Outputs, PreviewJob, RunSummary, Scene, TableJob, ALBEDO_MU};
use crate::backend::Query;
use crate::eval::Evaluator;
use crate::preview::{self, Sheet};
use crate::{integrate, output, table};
use anyhow::{bail, Context, Result};
use output::FileSet;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

impl Scene {
    /// Produces the outputs `what` asks for under `out_dir` (made, with its parents, when missing),
    /// evaluating on `e`, as one transaction: every output is checked before any work (each
    /// resolves inside `out_dir`, symbolic links followed, and no two write one file), all are
    /// staged, and they replace the old files together at the end, or none does. `log` receives
    /// a line per output once all are in place. Stops with "interrupted" on Ctrl-C (between and
    /// inside outputs), leaving no partial file and the old files as they were.
    pub fn run(
        &self,
        e: &Evaluator,
        out_dir: &Path,
        what: Outputs,
        log: &mut dyn FnMut(&str),
    ) -> Result<RunSummary> {
        if out_dir.exists() && !out_dir.is_dir() {
            bail!(
                "the output folder {} is a file, not a folder; pick another output folder",
                out_dir.display()
            );
        }
        self.check_outputs(out_dir, what)?;
        // A missing folder (and its parents) is made as the outputs are staged, and removed again
        // if the run fails.
        let mut set = FileSet::empty();
        let mut summary = RunSummary::default();
        let mut done = |files: Vec<PathBuf>, line: String| {
            summary.written.extend(files);
            summary.lines.push(line);
        };
        if what.tables {
            for t in &self.tables {
                e.check_cancelled()?;
                self.run_table(e, t, out_dir, &mut set, &mut done)?;
            }
        }
        if what.albedos {
            for a in &self.albedos {
                e.check_cancelled()?;
                self.run_albedo(e, a, out_dir, &mut set, &mut done)?;
            }
        }
        if what.previews {
            for p in &self.previews {
                e.check_cancelled()?;
                self.run_preview(e, p, out_dir, &mut set, &mut done)?;
            }
        }
        e.check_cancelled()?;
        set.commit()?;
        for line in &summary.lines {
            log(line);
        }
        Ok(summary)
    }

    /// Every file the outputs of `what` write, relative to the output folder, each with the
    /// output it belongs to as the scene names it.
    fn planned_files(&self, what: Outputs) -> Vec<(PathBuf, &Path)> {
        let mut files = Vec::new();
        if what.tables {
            for t in &self.tables {
                let (npy, json) = table::sibling_paths(&t.output);
                files.extend([t.output.clone(), npy, json].map(|f| (f, t.output.as_path())));
            }
        }
        if what.albedos {
            files.extend(
                self.albedos
                    .iter()
                    .map(|a| (a.output.clone(), a.output.as_path())),
            );
        }
        if what.previews {
            for p in &self.previews {
                let exr = p.output.with_extension("exr");
                files.extend([p.output.clone(), exr].map(|f| (f, p.output.as_path())));
            }
        }
        files
    }

    /// Before any work: every output resolves inside `out_dir` (following the symbolic links on
    /// the way), no two outputs resolve to one file (sidecars included), and no file there is one
    /// lobe would refuse to replace.
    fn check_outputs(&self, out_dir: &Path, what: Outputs) -> Result<()> {
        let root = resolve_on_disk(out_dir);
        let mut seen: HashMap<PathBuf, &Path> = HashMap::new();
        for (rel, output) in self.planned_files(what) {
            let path = out_dir.join(&rel);
            let resolved = resolve_on_disk(&path);
            if !resolved.starts_with(&root) {
                bail!(
                    "{}: output '{}' resolves to {}, outside the output folder {} (through a symbolic link); outputs stay inside the output folder",
                    self.file,
                    output.display(),
                    resolved.display(),
                    out_dir.display()
                );
            }
            if let Some(first) = seen.get(&resolved) {
                bail!(
                    "{}: outputs '{}' and '{}' both write {}",
                    self.file,
                    first.display(),
                    output.display(),
                    resolved.display()
                );
            }
            output::check_destination(&path)?;
            seen.insert(resolved, output);
        }
        Ok(())
    }

    /// Stages one table (.exr, .npy and .json); `done` receives the files and the log line.
    fn run_table(
        &self,
        e: &Evaluator,
        t: &TableJob,
        out_dir: &Path,
        set: &mut FileSet,
        done: &mut dyn FnMut(Vec<PathBuf>, String),
    ) -> Result<()> {
        let m = &self.materials[t.material];
        let path = out_dir.join(&t.output);
        set.create_folder(output::folder_of(&path))?;
        let meta = table::TableMeta {
            params: &m.params,
            white_furnace: t.white_furnace,
            grid: t.grid,
            backend: e.name(),
        };
        let started = std::time::Instant::now();
        table::stage_table(e, &meta, &path, set, &mut |_, _| {})
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

    /// Stages one albedo report (JSON): E(μ) at [`ALBEDO_MU`] and the hemispherical albedo.
    fn run_albedo(
        &self,
        e: &Evaluator,
        a: &AlbedoJob,
        out_dir: &Path,
        set: &mut FileSet,
        done: &mut dyn FnMut(Vec<PathBuf>, String),
    ) -> Result<()> {
        let m = &self.materials[a.material];
        let path = out_dir.join(&a.output);
        set.create_folder(output::folder_of(&path))?;
        let k = set.add(&path)?;
        let settings = integrate::Settings {
            method: a.method,
            samples: a.samples,
            seed: a.seed,
            white_furnace: a.white_furnace,
        };
        let points: Vec<(f64, f64)> = ALBEDO_MU.iter().map(|&mu| (mu, 0.0)).collect();
        let report = integrate::albedo_report(e, &m.params, &settings, &points, 0.0)
            .with_context(|| format!("albedo of material '{}'", m.name))?;
        e.check_cancelled()?;
        let mut json = report.to_json(
            Query::one(&m.params).with_white_furnace(a.white_furnace),
            &e.name(),
        );
        json["material"] = serde_json::json!(m.name);
        let mut w = set[k].writer();
        serde_json::to_writer_pretty(&mut w, &json)
            .map_err(|err| output::encoder_error(&path, "JSON", err))?;
        w.finish()?;
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

    /// Renders one contact sheet and stages it as .png and .exr (linear radiance).
    fn run_preview(
        &self,
        e: &Evaluator,
        p: &PreviewJob,
        out_dir: &Path,
        set: &mut FileSet,
        done: &mut dyn FnMut(Vec<PathBuf>, String),
    ) -> Result<()> {
        let sheet = self.sheet(p)?;
        let scene = self.preview_scene(p.cell, p.shape)?;
        let path = out_dir.join(&p.output);
        set.create_folder(output::folder_of(&path))?;
        let exr_path = path.with_extension("exr");
        let (exr_k, png_k) = (set.add(&exr_path)?, set.add(&path)?);
        let started = std::time::Instant::now();
        let image = preview::render(e, &sheet, &scene, &mut |_, _| {})?;
        e.check_cancelled()?;
        preview::encode_exr(&image, &sheet, &scene, &e.name(), &set[exr_k])?;
        let caption = preview::caption(&scene, p.exposure, &e.name());
        preview::encode_png(&image, &sheet, p.exposure, &caption, &set[png_k])?;
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
            columns: Sheet::model_names(&p.models),
            params,
        })
    }
}

/// `path` with its longest existing beginning resolved (symbolic links followed, made absolute)
/// and the rest appended as written: where a file there would land, even before its folders exist.
fn resolve_on_disk(path: &Path) -> PathBuf {
    let mut rest = Vec::new();
    let mut at = path.to_path_buf();
    loop {
        if let Ok(real) = std::fs::canonicalize(&at) {
            return rest.iter().rev().fold(real, |p, c| p.join(c));
        }
        match (at.file_name().map(|n| n.to_os_string()), at.parent()) {
            (Some(name), Some(parent)) => {
                rest.push(name);
                at = if parent.as_os_str().is_empty() {
                    PathBuf::from(".")
                } else {
                    parent.to_path_buf()
                };
            }
            _ => return path.to_path_buf(),
        }
    }
}
