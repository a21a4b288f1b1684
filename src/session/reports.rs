//! The reports: energy, stability, speed-for-accuracy trade-offs, comparisons, fits and the
//! sampling test.

use super::Session;
use crate::energy::{self, EnergyRow, Series};
use crate::error::{Error, IntoLobe, Result};
use crate::integrate::Method;
use crate::model::{Model, ParamSet};

/// What [`Session::energy`] reports: the series (a model at its presets and swept from its
/// defaults, or a labelled parameter set swept from itself), the sweep and the integrator.
#[derive(Clone, Debug)]
pub struct EnergyOptions {
    /// The series, in report order.
    pub series: Vec<Series>,
    /// Values of each series' main parameter to sweep (its LUT axis), cell-centred; 0 for the
    /// presets or the set alone.
    pub sweep: usize,
    /// The integrator of every E(μ).
    pub method: Method,
    /// Quadrature nodes per view direction.
    pub samples: usize,
}

impl Default for EnergyOptions {
    /// Every built-in model, swept over 8 values, by the peak rule at
    /// [`energy::DEFAULT_PEAK_SAMPLES`] nodes: `lobe energy` without options.
    fn default() -> EnergyOptions {
        EnergyOptions {
            series: Model::ALL.into_iter().map(Series::Model).collect(),
            sweep: 8,
            method: Method::Peak,
            samples: energy::DEFAULT_PEAK_SAMPLES,
        }
    }
}

impl Session {
    /// The energy report ([`crate::energy`]): each case's largest E(μ) and where, its gain and
    /// its loss, in the white configuration. `on_row` receives each row as soon as it is known,
    /// with (cases done, cases); an error it returns stops the report and is returned as it is.
    ///
    /// ```
    /// use lobe::energy::Series;
    /// use lobe::integrate::Method;
    /// let opts = lobe::EnergyOptions {
    ///     series: vec![Series::Model(lobe::Model::from_name("lambert")?)],
    ///     sweep: 0,
    ///     method: Method::Gauss,
    ///     samples: 256,
    /// };
    /// let rows = lobe::Session::cpu().energy(&opts, &mut |_, _, _| Ok(()))?;
    /// assert!(rows.iter().all(|r| r.model == "lambert"));
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn energy(
        &self,
        opts: &EnergyOptions,
        on_row: &mut dyn FnMut(&EnergyRow, u64, u64) -> Result<()>,
    ) -> Result<Vec<EnergyRow>> {
        // The caller's own error comes back as it was, not re-sorted from the job's.
        let mut stopped: Option<Error> = None;
        let rows = energy::report_series_each(
            &self.evaluator(),
            &opts.series,
            opts.sweep,
            opts.method,
            opts.samples,
            &mut |row, done, total| {
                on_row(row, done, total).map_err(|e| {
                    let message = e.to_string();
                    stopped = Some(e);
                    anyhow::anyhow!(message)
                })
            },
        );
        match (rows, stopped) {
            (Err(_), Some(e)) => Err(e),
            (rows, _) => rows.lobe(),
        }
    }

    /// The sampling test of `params`' sampler ([`crate::chi2`], `lobe chi2`): at each ωo of
    /// `options`, its draws against the integral of its pdf over equal-solid-angle cells, the
    /// share of draws that leave the hemisphere against 1 − ∫pdf, and every draw's weight and
    /// pdf against f cos/pdf and pdf(ωi). Drawn and counted on this session's backend: on the
    /// GPU by the counting kernel (draws checked in f32), on the CPU reference in f64; the
    /// expected counts are the f64 reference's either way ([`crate::chi2::Report::backend`]
    /// says which drew). Stopped by the session's cancellation token. `progress` hears (draws
    /// done, draws in all).
    ///
    /// ```
    /// let session = lobe::Session::cpu();
    /// let ggx = lobe::ParamSet::for_model("microfacet")?;
    /// let options = lobe::chi2::Options {
    ///     directions: vec![[40.0, 0.0]],
    ///     samples: 1 << 16,
    ///     ..Default::default()
    /// };
    /// let report = session.chi2(&ggx, false, &options, &mut |_, _| {})?;
    /// assert!(report.passed, "{:?}", report.directions[0].failures);
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn chi2(
        &self,
        params: &ParamSet,
        white_furnace: bool,
        options: &crate::chi2::Options,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<crate::chi2::Report> {
        let evaluator = self.evaluator();
        crate::chi2::test_model(
            params,
            white_furnace,
            options,
            evaluator.backend(),
            Some(self.cancel_token()),
            progress,
        )
    }

    /// The stability sweep over `models` (every model's parameter edges × extreme directions),
    /// on the CPU reference and, where the session has one, the GPU; `progress` hears each
    /// model's label as its sweep begins.
    ///
    /// ```
    /// let lambert = lobe::Model::from_name("lambert")?;
    /// let report = lobe::Session::cpu().stability(vec![lambert], &mut |_| {})?;
    /// assert_eq!(report.bad_values(), 0);
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn stability(
        &self,
        models: Vec<Model>,
        progress: &mut dyn FnMut(&str),
    ) -> Result<crate::stability::Report> {
        crate::stability::sweep(crate::stability::Options {
            backend: self.evaluator(),
            models,
            progress,
        })
        .lobe()
    }

    /// Cost and error of each speed-for-accuracy variant of `params` ([`crate::tradeoff`]), as
    /// `lobe tradeoff` measures them; `material` names the preset `params` came from, if any.
    /// GPU variants run on this session's device, CPU variants on the CPU; `progress` hears
    /// (step, steps, what) before each variant.
    ///
    /// ```
    /// use lobe::grid::Grid;
    /// use lobe::tradeoff::{AlbedoSetup, Options, Section};
    /// let lambert = lobe::ParamSet::for_model("lambert")?;
    /// let tiny = Grid::Isotropic { n_theta_i: 2, n_theta_o: 2, n_dphi: 2 };
    /// let mut albedo = AlbedoSetup::quick();
    /// (albedo.mus, albedo.samples, albedo.repeats) = (vec![0.5], vec![64], 1);
    /// let opts = Options {
    ///     sections: vec![Section::Integration],
    ///     error_grid: tiny,
    ///     timing_grid: tiny,
    ///     eval_repeats: 1,
    ///     albedo,
    /// };
    /// let report = lobe::Session::cpu().tradeoff(&lambert, None, &opts, &mut |_, _, _| {})?;
    /// assert!(report.rows_of(Section::Integration).count() > 0);
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn tradeoff(
        &self,
        params: &ParamSet,
        material: Option<&str>,
        opts: &crate::tradeoff::Options,
        progress: &mut dyn FnMut(usize, usize, &str),
    ) -> Result<crate::tradeoff::Report> {
        crate::tradeoff::run(&self.evaluator(), params, material, opts, progress).lobe()
    }

    /// Compares model `b` against the reference `a` on the bins of `opts` ([`crate::compare`]),
    /// as `lobe compare` does; `progress` gets (bins done, bins).
    ///
    /// ```
    /// use lobe::compare::{Bins, Options, Side};
    /// use lobe::grid::Grid;
    /// let a = Side::new(lobe::ParamSet::for_model("lambert")?.with("albedo", 0.5)?);
    /// let b = Side::new(lobe::ParamSet::for_model("lambert")?.with("albedo", 0.4)?);
    /// let opts = Options {
    ///     bins: Bins::Grid(Grid::Isotropic { n_theta_i: 2, n_theta_o: 2, n_dphi: 2 }),
    ///     white_furnace: false,
    ///     mus: Vec::new(),
    ///     albedo: None,
    /// };
    /// let c = lobe::Session::cpu().compare(&a, &b, &opts, &mut |_, _| {})?;
    /// assert!((c.relative_max - 0.2).abs() < 1e-9, "{}", c.relative_max);
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn compare(
        &self,
        a: &crate::compare::Side,
        b: &crate::compare::Side,
        opts: &crate::compare::Options,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<crate::compare::Comparison> {
        crate::compare::compare(&self.evaluator(), a, b, opts, progress).lobe()
    }

    /// Fits the free parameters of `space` to `target` ([`crate::fit::fit`]), as `lobe fit`
    /// does; `progress` gets each iteration's best loss.
    ///
    /// ```
    /// use lobe::fit::{FitOptions, Space, Target};
    /// let lambert = lobe::ParamSet::for_model("lambert")?;
    /// let target = Target::Model(lambert.clone().with("albedo", 0.3)?);
    /// let space = Space::new(lambert, &["albedo".to_string()], &[])?;
    /// let opts = FitOptions { max_bins: 64, starts: 1, max_iters: 60, ..FitOptions::default() };
    /// let fit = lobe::Session::cpu().fit(&target, &space, &opts, &|_| {})?;
    /// assert_eq!(fit.free, ["albedo"]);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn fit(
        &self,
        target: &crate::fit::Target,
        space: &crate::fit::Space,
        opts: &crate::fit::FitOptions,
        progress: &(dyn Fn(crate::fit::FitProgress) + Sync),
    ) -> Result<crate::fit::FitReport> {
        crate::fit::fit(&self.evaluator(), target, space, opts, progress).lobe()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lambert_only() -> EnergyOptions {
        EnergyOptions {
            series: vec![Series::Model(Model::from_name("lambert").unwrap())],
            sweep: 2,
            method: Method::Gauss,
            samples: 64,
        }
    }

    #[test]
    fn energy_hands_each_row_over_as_it_is_known() {
        let mut seen = Vec::new();
        let rows = Session::cpu()
            .energy(&lambert_only(), &mut |row, done, total| {
                seen.push((row.case.clone(), done, total));
                Ok(())
            })
            .unwrap();
        assert_eq!(seen.len(), rows.len());
        let total = rows.len() as u64;
        for (k, (case, done, all)) in seen.iter().enumerate() {
            assert_eq!((*done, *all), (k as u64 + 1, total));
            assert_eq!(case, &rows[k].case);
        }
    }

    #[test]
    fn an_error_from_on_row_stops_the_report_and_comes_back_unchanged() {
        let mut calls = 0;
        let e = Session::cpu()
            .energy(&lambert_only(), &mut |_, _, _| {
                calls += 1;
                Err(Error::Io {
                    what: "writing rows".into(),
                    source: std::io::Error::new(std::io::ErrorKind::StorageFull, "disk full"),
                })
            })
            .unwrap_err();
        assert_eq!(calls, 1, "the report went on after its reader failed");
        match e {
            Error::Io { what, source } => {
                assert_eq!(what, "writing rows");
                assert_eq!(source.kind(), std::io::ErrorKind::StorageFull);
            }
            other => panic!("expected the reader's own error, got {other:?}"),
        }
    }
}
