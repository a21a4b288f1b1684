//! Jobs that write a folder of outputs: a scene file's and the demo's.

use super::Session;
use crate::demo::{self, Progress};
use crate::error::{IntoLobe, Result};
use crate::scene::{Outputs, RunSummary, Scene};
use std::path::Path;

impl Session {
    /// Produces the outputs of `scene` that `what` asks for under `out_dir`, as one transaction
    /// ([`Scene::run`]), as `lobe run` does; `log` receives a line per output once all are in
    /// place.
    ///
    /// ```
    /// use lobe::scene::{self, Outputs};
    /// let dir = tempfile::tempdir().unwrap();
    /// let text = r#"
    /// [[materials]]
    /// name = "matte"
    /// model = "lambert"
    /// [[tables]]
    /// material = "matte"
    /// n_theta = 2
    /// n_phi = 4
    /// output = "matte.exr"
    /// "#;
    /// let scene = scene::parse(text, "matte.toml")?;
    /// let summary = lobe::Session::cpu().run_scene(&scene, dir.path(), Outputs::ALL, &mut |_| {})?;
    /// assert!(summary.written.iter().all(|p| p.exists()));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn run_scene(
        &self,
        scene: &Scene,
        out_dir: &Path,
        what: Outputs,
        log: &mut dyn FnMut(&str),
    ) -> Result<RunSummary> {
        scene.run(&self.evaluator(), out_dir, what, log).lobe()
    }

    /// The demo ([`crate::demo`]): tables, albedos, a LUT, plots, previews and GPU-vs-CPU parity
    /// of the built-in materials under every model, written to the folder `dir` with its
    /// `index.html`; `progress` hears each step begin, advance and end.
    ///
    /// ```
    /// use lobe::demo::{Settings, Step};
    /// use lobe::grid::Grid;
    /// struct Quiet;
    /// impl lobe::demo::Progress for Quiet {
    ///     fn begin(&mut self, _: &str, _: u64) {}
    ///     fn advance(&mut self, _: u64) {}
    ///     fn end(&mut self, _: &Step) {}
    /// }
    /// // Every model and material, at sizes far below even `lobe demo --quick`'s.
    /// let tiny = Settings {
    ///     table_full: Grid::Full { n_theta_i: 2, n_phi_i: 2, n_theta_o: 2, n_phi_o: 4 },
    ///     table_isotropic: Grid::Isotropic { n_theta_i: 2, n_theta_o: 2, n_dphi: 4 },
    ///     albedo_samples: 64,
    ///     curve_mu: 4,
    ///     curve_samples: 64,
    ///     polar_samples: 36,
    ///     hemisphere_res: 8,
    ///     preview_cell: 8,
    ///     lut_res: (2, 2),
    ///     lut_samples: 64,
    ///     ..Settings::quick()
    /// };
    /// let dir = tempfile::tempdir().unwrap();
    /// let out = dir.path().join("demo");
    /// let report = lobe::Session::cpu().demo(&out, &tiny, &mut Quiet)?;
    /// assert!(out.join("index.html").exists() && !report.steps.is_empty());
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn demo(
        &self,
        dir: &Path,
        settings: &demo::Settings,
        progress: &mut dyn Progress,
    ) -> Result<demo::Report> {
        demo::run(&self.evaluator(), dir, settings, progress).lobe()
    }
}
