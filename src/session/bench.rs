//! Throughput of the commands' kernels on this session's backend (`lobe bench`).

use super::Session;
use crate::backend::Query;
use crate::bench::Throughput;
use crate::error::{IntoLobe, Result};
use crate::grid::Grid;
use crate::model::ParamSet;

impl Session {
    /// Throughput of a lobe table on `grid` on this session's backend (median of `repeats`).
    ///
    /// ```
    /// use lobe::grid::Grid;
    /// let lambert = lobe::ParamSet::for_model("lambert")?;
    /// let grid = Grid::Isotropic { n_theta_i: 4, n_theta_o: 4, n_dphi: 4 };
    /// let t = lobe::Session::cpu().bench_table(&lambert, &grid, 1)?;
    /// assert_eq!(t.evaluations, 64);
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn bench_table(
        &self,
        params: &ParamSet,
        grid: &Grid,
        repeats: usize,
    ) -> Result<Throughput> {
        crate::bench::measure(&self.evaluator(), params, grid, repeats).lobe()
    }

    /// [`Session::bench_table`], optionally under the white furnace.
    ///
    /// ```
    /// use lobe::grid::Grid;
    /// let gold = lobe::ParamSet::preset("gold", "cook_torrance")?;
    /// let grid = Grid::Isotropic { n_theta_i: 4, n_theta_o: 4, n_dphi: 4 };
    /// let t = lobe::Session::cpu().bench_table_with(lobe::Query::one(&gold).with_white_furnace(true), &grid, 1)?;
    /// assert_eq!(t.evaluations, 64);
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn bench_table_with<'q>(
        &self,
        query: impl Into<Query<'q>>,
        grid: &Grid,
        repeats: usize,
    ) -> Result<Throughput> {
        let query = query.into();
        crate::bench::measure_table(&self.evaluator(), query, grid, repeats).lobe()
    }

    /// Throughput of directional-albedo integration on this session's backend
    /// ([`crate::bench::measure_albedo`]).
    ///
    /// ```
    /// let lambert = lobe::ParamSet::for_model("lambert")?;
    /// let t = lobe::Session::cpu().bench_albedo(&lambert, 1)?;
    /// assert_eq!(t.task, "albedo");
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn bench_albedo<'q>(
        &self,
        query: impl Into<Query<'q>>,
        repeats: usize,
    ) -> Result<Throughput> {
        let query = query.into();
        crate::bench::measure_albedo(&self.evaluator(), query, repeats).lobe()
    }

    /// Throughput of an albedo look-up table ([`crate::bench::lut_spec`]) on this session's
    /// backend.
    ///
    /// ```
    /// let lambert = lobe::ParamSet::for_model("lambert")?;
    /// let t = lobe::Session::cpu().bench_lut(&lambert, 1)?;
    /// assert!(t.evaluations > 0);
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn bench_lut<'q>(&self, query: impl Into<Query<'q>>, repeats: usize) -> Result<Throughput> {
        let query = query.into();
        crate::bench::measure_lut(&self.evaluator(), query, repeats).lobe()
    }

    /// Throughput of the sampling test on this session's backend (`lobe chi2`:
    /// [`CHI2_SAMPLES`](crate::bench::CHI2_SAMPLES) draws of the model's sampler at θo =
    /// [`CHI2_THETA_O_DEG`](crate::bench::CHI2_THETA_O_DEG), counted in cells on the device or
    /// drawn and checked in f64 on the CPU, then the expected counts and the verdict), the median
    /// of `repeats` runs; evaluations = draws.
    ///
    /// ```
    /// let lambert = lobe::ParamSet::for_model("lambert")?;
    /// let t = lobe::Session::cpu().bench_chi2(&lambert, 1)?;
    /// assert_eq!(t.evaluations, lobe::bench::CHI2_SAMPLES);
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn bench_chi2<'q>(
        &self,
        query: impl Into<Query<'q>>,
        repeats: usize,
    ) -> Result<Throughput> {
        use crate::bench::{CHI2_SAMPLES, CHI2_THETA_O_DEG};
        let query = query.into();
        let params = query.params();
        let eval = self.evaluator();
        let options = crate::chi2::Options {
            directions: vec![[CHI2_THETA_O_DEG, 0.0]],
            samples: CHI2_SAMPLES,
            ..Default::default()
        };
        crate::bench::time_task(&eval, params, "chi2", repeats, || {
            let report = crate::chi2::test_model(
                params,
                query.white_furnace,
                &options,
                eval.backend(),
                None,
                |_, _| {},
            )?;
            std::hint::black_box(report);
            Ok(CHI2_SAMPLES)
        })
        .lobe()
    }

    /// Throughput of the lit sphere's exact sum on this session's backend (`lobe light --method
    /// exact`: a [`LIGHT_SIZE`](crate::bench::LIGHT_SIZE)² sphere under the built-in sky, 256 ×
    /// 128 texels), the median of `repeats` runs; evaluations = texel terms, the pixels inside the
    /// sphere times the map's texels (the sums skip those below each pixel's horizon, so a faster
    /// skip shows as more terms a second).
    pub fn bench_light<'q>(
        &self,
        query: impl Into<Query<'q>>,
        repeats: usize,
    ) -> Result<Throughput> {
        use crate::bench::LIGHT_SIZE;
        let query = query.into();
        let params = query.params();
        let eval = self.evaluator();
        let map = crate::light::maps::Builtin::Sky.map();
        let pixels = crate::backend::light::sphere_pixels(LIGHT_SIZE, 0..LIGHT_SIZE).len() as u64;
        let terms = pixels * map.texels().len() as u64;
        crate::bench::time_task(&eval, params, "light", repeats, || {
            let image = crate::light::exact(
                &eval,
                params,
                query.white_furnace,
                &map,
                LIGHT_SIZE,
                &mut |_, _| {},
            )?;
            std::hint::black_box(image);
            Ok(terms)
        })
        .lobe()
    }
}
