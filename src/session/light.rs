//! Environment light: the sphere lit by a lat-long map, summed exactly over its texels, and
//! Karis' split sum of the same scene.

use super::Session;
use crate::error::{IntoLobe, Result};
use crate::light::prefilter::ChainSummary;
use crate::light::report::{Report, ReportSummary};
use crate::light::{self, LightImage, LightSummary, Method};
use crate::model::ParamSet;
use std::path::Path;

pub use crate::backend::light::EnvMap;

impl Session {
    /// The `size` × `size` sphere of `params` lit by `map` (docs/design.md §15), the exact sum
    /// over every texel for every pixel; `progress` gets (rows done, rows).
    ///
    /// ```
    /// use lobe::light::maps::Builtin;
    /// let lambert = lobe::ParamSet::for_model("lambert")?.with("albedo", 0.5)?;
    /// let map = lobe::light::maps::procedural_map(16, 8, |_| lobe::glam::DVec3::ONE)?;
    /// let image = lobe::Session::cpu().light(&lambert, &map, 8, &mut |_, _| {})?;
    /// // A constant map of radiance 1 lights a Lambert sphere to its albedo.
    /// assert!((image.at(4, 4)[0] - 0.5).abs() < 1e-2);
    /// assert_eq!(image.at(0, 0), [0.0; 3]); // outside the sphere
    /// # let _ = Builtin::Sky;
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn light(
        &self,
        params: &ParamSet,
        map: &EnvMap,
        size: u32,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<LightImage> {
        light::exact(&self.evaluator(), params, false, map, size, progress).lobe()
    }

    /// Karis' split sum of the same scene as [`Session::light`] (docs/design.md §15.3): the map
    /// prefiltered by the model's D about each pixel's mirror direction, times the DFG scale
    /// and bias of lobe's engine table, plus the Lambertian part. Refuses a model with no
    /// microfacet lobe or Lambertian part (every model but lambert, microfacet and
    /// cook_torrance).
    ///
    /// ```
    /// let lambert = lobe::ParamSet::for_model("lambert")?.with("albedo", 0.5)?;
    /// let map = lobe::light::maps::procedural_map(16, 8, |_| lobe::glam::DVec3::ONE)?;
    /// let image = lobe::Session::cpu().light_split_sum(&lambert, &map, 8, &mut |_, _| {})?;
    /// assert!((image.at(4, 4)[0] - 0.5).abs() < 1e-2);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn light_split_sum(
        &self,
        params: &ParamSet,
        map: &EnvMap,
        size: u32,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<LightImage> {
        light::split::split_sum(&self.evaluator(), params, false, map, size, progress).lobe()
    }

    /// `method`'s images written beside `exr_path` with a PNG of each at `exposure` stops and
    /// the JSON, all or none, as `lobe light` does (docs/commands.md); `env` names the map in the
    /// files; every specular Fresnel factor is 1 where `white_furnace` (`--white-furnace`).
    #[allow(clippy::too_many_arguments)]
    pub fn write_light(
        &self,
        params: &ParamSet,
        white_furnace: bool,
        method: Method,
        map: &EnvMap,
        env: &str,
        size: u32,
        exposure: f64,
        exr_path: &Path,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<LightSummary> {
        light::write(
            &self.evaluator(),
            params,
            white_furnace,
            method,
            map,
            env,
            size,
            exposure,
            exr_path,
            progress,
        )
        .lobe()
    }

    /// The split sum's error against the exact sum over `steps` values of the model's roughness
    /// (`lobe light --report`, docs/design.md §15.4): per value the RMS, the largest relative
    /// error and its pixel, and the mean relative error by band of n·v, on `size`² spheres under
    /// `map`; `progress` gets (rows done, rows) over the whole sweep. Refuses a model with no
    /// microfacet lobe, naming the models that have one.
    ///
    /// ```
    /// let ggx = lobe::ParamSet::for_model("microfacet")?;
    /// let map = lobe::light::maps::procedural_map(16, 8, |_| lobe::glam::DVec3::ONE)?;
    /// let report = lobe::Session::cpu().light_report(&ggx, false, &map, 8, 3, &mut |_, _| {})?;
    /// assert_eq!(report.rows.len(), 3);
    /// assert_eq!(report.axis.key, "alpha");
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[allow(clippy::too_many_arguments)]
    pub fn light_report(
        &self,
        params: &ParamSet,
        white_furnace: bool,
        map: &EnvMap,
        size: u32,
        steps: usize,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<Report> {
        light::report::report(
            &self.evaluator(),
            params,
            white_furnace,
            map,
            size,
            steps,
            progress,
        )
        .lobe()
    }

    /// [`Session::light_report`] written beside `exr_path` as `P_report.csv`, `P_report.png`,
    /// `P_report.svg` and `P.json`, all or none, as `lobe light --report` does.
    #[allow(clippy::too_many_arguments)]
    pub fn write_light_report(
        &self,
        params: &ParamSet,
        white_furnace: bool,
        map: &EnvMap,
        env: &str,
        size: u32,
        steps: usize,
        exr_path: &Path,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<ReportSummary> {
        light::report::write_report(
            &self.evaluator(),
            params,
            white_furnace,
            map,
            env,
            size,
            steps,
            exr_path,
            progress,
        )
        .lobe()
    }

    /// The map prefiltered by the model's D as an engine's mip chain (`lobe light
    /// --prefilter-out DIR`, docs/design.md §15.5): `levels` levels, level k at perceptual
    /// roughness k/(levels − 1), each a lat-long EXR and six cube faces (OpenGL order), and
    /// `prefilter.json` and the split sum's DFG table (`dfg.exr` and its siblings, as `lobe albedo
    /// --engine dfg` writes it), written into `dir` all or none; `progress` gets (levels done,
    /// levels).
    pub fn write_prefilter(
        &self,
        params: &ParamSet,
        map: &EnvMap,
        env: &str,
        levels: u32,
        dir: &Path,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<ChainSummary> {
        let eval = self.evaluator();
        let cancelled = || eval.check_cancelled().map_err(anyhow::Error::from);
        light::prefilter::write_chain(&eval, params, map, env, levels, dir, &cancelled, progress)
            .lobe()
    }
}
