//! Pictures: the preview sheet, `lobe plot`'s kinds and the overlay and difference of two models.

use super::Session;
use crate::error::{IntoLobe, Result};
use crate::plot::difference::{PlotOptions, Plots};
use crate::plot::{Format, PlotSettings, Plotted, Request, Subject};
use crate::preview::{Scene, Sheet, SheetImage};
use std::path::Path;

impl Session {
    /// Renders a material preview sheet (rows of parameter sets, shaded under `scene`);
    /// `progress` gets (columns done, columns).
    ///
    /// ```
    /// use lobe::glam::DVec3;
    /// use lobe::preview::{LightKind, Scene, Shape, Sheet};
    /// let sheet = Sheet::new(&["gold".to_string()], &[lobe::Model::from_name("cook_torrance")?])?;
    /// let scene = Scene::lab(8, Shape::Sphere, LightKind::Point, DVec3::ZERO);
    /// let image = lobe::Session::cpu().preview(&sheet, &scene, &mut |_, _| {})?;
    /// assert_eq!((image.rows, image.cols, image.cell_width), (1, 1, 8));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn preview(
        &self,
        sheet: &Sheet,
        scene: &Scene,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<SheetImage> {
        crate::preview::render(&self.evaluator(), sheet, scene, progress).lobe()
    }

    /// Evaluates and draws `request` for `subjects` into `path` (.png, .svg or .pdf by its
    /// extension), as `lobe plot` does, and returns what the picture shows
    /// ([`crate::plot::plot`]).
    ///
    /// ```
    /// use lobe::plot::{polar::PolarOptions, PlotSettings, Plotted, Request, Subject};
    /// let dir = tempfile::tempdir().unwrap();
    /// let path = dir.path().join("polar.svg");
    /// let subject = Subject { label: "lambert".into(), params: lobe::ParamSet::for_model("lambert")? };
    /// let request = Request::Polar(PolarOptions { theta_i_deg: vec![30.0], samples: 90, ..PolarOptions::default() });
    /// let plotted = lobe::Session::cpu().plot(&[subject], &PlotSettings::default(), &request, &path)?;
    /// assert!(matches!(plotted, Plotted::Polar(_)) && path.exists());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn plot(
        &self,
        subjects: &[Subject],
        common: &PlotSettings,
        request: &Request,
        path: &Path,
    ) -> Result<Plotted> {
        crate::plot::plot(&self.evaluator(), subjects, common, request, path).lobe()
    }

    /// Draws `a` and `b` overlaid in the plane of incidence and their relative difference over
    /// the hemisphere, as `lobe compare -o` and `lobe fit -o` do: `PREFIX_polar.EXT` and
    /// `PREFIX_difference.EXT`, each with its parameters and data beside it, all or none
    /// ([`crate::plot::difference::write_plots`]).
    ///
    /// ```
    /// use lobe::plot::{difference::PlotOptions, Format, Subject};
    /// let dir = tempfile::tempdir().unwrap();
    /// let side = |label: &str, albedo: f64| -> lobe::Result<Subject> {
    ///     let params = lobe::ParamSet::for_model("lambert")?.with("albedo", albedo)?;
    ///     Ok(Subject { label: label.into(), params })
    /// };
    /// let opts = PlotOptions { theta_i_deg: vec![30.0], res: 8, ..PlotOptions::default() };
    /// let plots = lobe::Session::cpu().plot_difference(
    ///     &side("A", 0.5)?, &side("B", 0.4)?, &opts, &dir.path().join("ab"), Format::Svg)?;
    /// assert!(plots.polar_path.exists() && plots.difference_path.exists());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn plot_difference(
        &self,
        a: &Subject,
        b: &Subject,
        opts: &PlotOptions,
        prefix: &Path,
        format: Format,
    ) -> Result<Plots> {
        crate::plot::difference::write_plots(&self.evaluator(), a, b, opts, prefix, format).lobe()
    }
}
