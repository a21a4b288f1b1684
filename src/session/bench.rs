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

    /// Throughput of the sampling test ([`crate::bench::measure_chi2`]) on this session's
    /// backend; evaluations = draws.
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
        let query = query.into();
        crate::bench::measure_chi2(&self.evaluator(), query, repeats).lobe()
    }

    /// Throughput of the lit sphere's exact sum ([`crate::bench::measure_light`]) on this
    /// session's backend; evaluations = texel terms.
    pub fn bench_light<'q>(
        &self,
        query: impl Into<Query<'q>>,
        repeats: usize,
    ) -> Result<Throughput> {
        let query = query.into();
        crate::bench::measure_light(&self.evaluator(), query, repeats).lobe()
    }
}
