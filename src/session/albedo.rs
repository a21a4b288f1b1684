//! Albedo: E(ωo) at view directions, Ē and E_avg, and the look-up tables built from them.

use super::{AlbedoSettings, Session};
use crate::error::{IntoLobe, Result};
use crate::integrate::{self, AlbedoReport, HemiAlbedo, PointAlbedo};
use crate::lut::engine::{EngineSpec, EngineTable};
use crate::lut::{LutSpec, LutSummary};
use crate::model::ParamSet;
use std::path::Path;

impl Session {
    /// Directional albedo E(ωo) at each (μo, φo).
    ///
    /// ```
    /// let session = lobe::Session::cpu();
    /// let lambert = lobe::ParamSet::for_model("lambert")?.with("albedo", 0.5)?;
    /// let e = session.directional_albedo(&lambert, &lobe::AlbedoSettings::default(), &[(0.5, 0.0)])?;
    /// assert!((e[0].albedo.x - 0.5).abs() < 1e-6);
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn directional_albedo(
        &self,
        params: &ParamSet,
        settings: &AlbedoSettings,
        points: &[(f64, f64)],
    ) -> Result<Vec<PointAlbedo>> {
        integrate::directional(&self.evaluator(), params, settings, points).lobe()
    }

    /// Hemispherical albedo Ē and Kulla–Conty's E_avg (at azimuth `phi` for anisotropic sets).
    ///
    /// ```
    /// use lobe::integrate::Method;
    /// let settings = lobe::AlbedoSettings { method: Method::Gauss, samples: 256, seed: 0, white_furnace: false };
    /// let lambert = lobe::ParamSet::for_model("lambert")?.with("albedo", 0.5)?;
    /// let h = lobe::Session::cpu().hemispherical_albedo(&lambert, &settings, 0.0)?;
    /// assert!((h.albedo.x - 0.5).abs() < 1e-3);
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn hemispherical_albedo(
        &self,
        params: &ParamSet,
        settings: &AlbedoSettings,
        phi: f64,
    ) -> Result<HemiAlbedo> {
        integrate::hemispherical(&self.evaluator(), params, settings, phi).lobe()
    }

    /// Directional and hemispherical albedo together, with timings, as `lobe albedo` reports.
    ///
    /// ```
    /// use lobe::integrate::Method;
    /// let settings = lobe::AlbedoSettings { method: Method::Gauss, samples: 256, seed: 0, white_furnace: false };
    /// let lambert = lobe::ParamSet::for_model("lambert")?;
    /// let r = lobe::Session::cpu().albedo_report(&lambert, &settings, &[(1.0, 0.0)], 0.0)?;
    /// assert_eq!(r.points.len(), 1);
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn albedo_report(
        &self,
        params: &ParamSet,
        settings: &AlbedoSettings,
        points: &[(f64, f64)],
        phi: f64,
    ) -> Result<AlbedoReport> {
        integrate::albedo_report(&self.evaluator(), params, settings, points, phi).lobe()
    }

    /// [`Session::directional_albedo`] at `points` (and, with `phi`, [`Session::hemispherical_albedo`])
    /// for each parameter set of `rows`, the same values as one set at a time; rows of one model
    /// share each direction's quadrature nodes and the GPU sums them in the same dispatches
    /// ([`integrate::albedo_rows`]).
    ///
    /// ```
    /// use lobe::ParamSet;
    /// let rows = [
    ///     ParamSet::for_model("lambert")?.with("albedo", 0.25)?,
    ///     ParamSet::for_model("lambert")?.with("albedo", 0.75)?,
    /// ];
    /// let settings = lobe::AlbedoSettings::default();
    /// let out = lobe::Session::cpu().albedo_rows(&rows, &settings, &[(1.0, 0.0)], None)?;
    /// assert!((out[1].0[0].albedo.x - 0.75).abs() < 1e-6 && out[1].1.is_none());
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn albedo_rows(
        &self,
        rows: &[ParamSet],
        settings: &AlbedoSettings,
        points: &[(f64, f64)],
        phi: Option<f64>,
    ) -> Result<Vec<(Vec<PointAlbedo>, Option<HemiAlbedo>)>> {
        integrate::albedo_rows(&self.evaluator(), rows, settings, points, phi).lobe()
    }

    /// Computes an albedo look-up table E(μ, p), E_avg(p) in memory; `progress` gets (rows done,
    /// rows).
    ///
    /// ```
    /// let ggx = lobe::ParamSet::for_model("cook_torrance")?;
    /// let mut spec = lobe::lut::LutSpec::new(ggx);
    /// spec.white_furnace = true;
    /// (spec.n_mu, spec.n_p, spec.samples, spec.with_avg) = (4, 3, 256, false);
    /// let lut = lobe::Session::cpu().albedo_lut(&spec, &mut |_, _| {})?;
    /// assert_eq!((lut.mus.len(), lut.ps.len()), (4, 3));
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn albedo_lut(
        &self,
        spec: &LutSpec,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<LutSummary> {
        crate::lut::compute(&self.evaluator(), spec, progress).lobe()
    }

    /// Computes an albedo look-up table and writes its files beside `exr_path` (all or
    /// nothing); `progress` gets (rows done, rows).
    ///
    /// ```
    /// let dir = tempfile::tempdir().unwrap();
    /// let ggx = lobe::ParamSet::for_model("cook_torrance")?;
    /// let mut spec = lobe::lut::LutSpec::new(ggx);
    /// spec.white_furnace = true;
    /// (spec.n_mu, spec.n_p, spec.samples) = (4, 3, 256);
    /// let path = dir.path().join("e.exr");
    /// lobe::Session::cpu().write_albedo_lut(&spec, &path, &mut |_, _| {})?;
    /// assert!(path.exists());
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn write_albedo_lut(
        &self,
        spec: &LutSpec,
        exr_path: &Path,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<LutSummary> {
        crate::lut::write(&self.evaluator(), spec, exr_path, progress).lobe()
    }

    /// Computes a real-time engine's look-up table (DFG, Kulla–Conty, EON) in memory, as
    /// `lobe albedo --engine` does before writing it; `progress` gets (rows done, rows).
    ///
    /// ```
    /// use lobe::lut::engine::{EngineKind, EngineSpec};
    /// let mut spec = EngineSpec::new(EngineKind::KullaConty, &[])?;
    /// (spec.lut.n_mu, spec.lut.n_p, spec.lut.samples) = (4, 3, 256);
    /// let table = lobe::Session::cpu().engine_lut(&spec, &mut |_, _| {})?;
    /// assert_eq!(table.channels, 1);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn engine_lut(
        &self,
        spec: &EngineSpec,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<EngineTable> {
        crate::lut::engine::compute_engine(&self.evaluator(), spec, progress).lobe()
    }

    /// [`Session::engine_lut`], written beside `exr_path` with its C/C++ header (all or
    /// nothing), as `lobe albedo --lut PATH --engine KIND` does.
    ///
    /// ```
    /// use lobe::lut::engine::{EngineKind, EngineSpec};
    /// let dir = tempfile::tempdir().unwrap();
    /// let mut spec = EngineSpec::new(EngineKind::Dfg, &[])?;
    /// (spec.lut.n_mu, spec.lut.n_p, spec.lut.samples) = (4, 3, 256);
    /// let table = lobe::Session::cpu().write_engine_lut(&spec, &dir.path().join("dfg.exr"), &mut |_, _| {})?;
    /// assert!(table.files.iter().all(|f| f.exists()));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn write_engine_lut(
        &self,
        spec: &EngineSpec,
        exr_path: &Path,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<EngineTable> {
        crate::lut::engine::write_engine(&self.evaluator(), spec, exr_path, progress).lobe()
    }
}
