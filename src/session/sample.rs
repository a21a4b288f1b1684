//! A model's sampler: draws for one ωo and the density at direction pairs (`lobe sample`,
//! Python's `Session.sample` and `Session.pdf`; docs/design.md §13), and the sampling test's
//! pictures (`lobe chi2 -o`).

use super::Session;
use crate::backend::Query;
use crate::error::{IntoLobe, Result};
use crate::samples::{self, SampleFiles, Samples};
use glam::DVec3;
use std::path::Path;

impl Session {
    /// n draws of the query's sampler for `wo` (a unit vector above the horizon) from the
    /// stream `seed`, on this session's backend: draw i from `random::draw_numbers(seed, i, 0)`
    /// ([`crate::samples`]), so the same seed gives the same draws bit for bit on one backend
    /// and within f32 rounding between the GPU and the CPU. At most [`samples::MAX_DRAWS`]
    /// draws a request.
    ///
    /// ```
    /// use lobe::glam::DVec3;
    /// let session = lobe::Session::cpu();
    /// let lambert = lobe::ParamSet::for_model("lambert")?;
    /// let s = session.sample(&lambert, DVec3::Z, 1000, 7)?;
    /// assert_eq!(s.len(), 1000);
    /// // Cosine sampling: pdf = cos θi / π at every draw.
    /// assert!((s.pdf[0] - s.wi[0][2] / std::f64::consts::PI).abs() < 1e-12);
    /// assert_eq!(s, session.sample(&lambert, DVec3::Z, 1000, 7)?);
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn sample<'q>(
        &self,
        query: impl Into<Query<'q>>,
        wo: DVec3,
        n: usize,
        seed: u32,
    ) -> Result<Samples> {
        samples::draw(&self.evaluator(), query.into(), wo, n, seed, &mut |_, _| {}).lobe()
    }

    /// [`Session::sample`] written as `PATH.npy` (float64, n × 8: [`samples::COLUMNS`]) with
    /// its sidecar `PATH.json`, both or neither; the destinations are checked before the first
    /// draw. `progress` hears (draws done, n). Returns the draws written.
    ///
    /// ```
    /// use lobe::glam::DVec3;
    /// let dir = tempfile::tempdir().unwrap();
    /// let path = dir.path().join("s.npy");
    /// let phong = lobe::ParamSet::for_model("phong")?;
    /// let session = lobe::Session::cpu();
    /// let s = session.write_samples(&phong, DVec3::Z, 64, 0, &path, &mut |_, _| {})?;
    /// assert_eq!(s.len(), 64);
    /// assert!(path.exists() && path.with_extension("json").exists());
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn write_samples<'q>(
        &self,
        query: impl Into<Query<'q>>,
        wo: DVec3,
        n: usize,
        seed: u32,
        path: &Path,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<Samples> {
        let query = query.into();
        let mut run = || -> anyhow::Result<Samples> {
            samples::check_wo(wo, "wo")?;
            samples::check_count(n)?;
            let files = SampleFiles::create(path)?;
            let s = samples::draw(&self.evaluator(), query, wo, n, seed, progress)?;
            files.commit(&s, query.params(), query.white_furnace)?;
            Ok(s)
        };
        run().lobe()
    }

    /// The pictures of a sampling test's `report` of `params` (`lobe chi2 -o`,
    /// [`crate::plot::chi2`]): per view direction the observed histogram, the expected counts and
    /// the residual in σ side by side, written to `path` as PNG, SVG or PDF by its extension.
    /// Returns what was drawn.
    ///
    /// ```
    /// let dir = tempfile::tempdir().unwrap();
    /// let session = lobe::Session::cpu();
    /// let lambert = lobe::ParamSet::for_model("lambert")?;
    /// let options = lobe::chi2::Options {
    ///     directions: vec![[30.0, 0.0]],
    ///     samples: 1 << 12,
    ///     ..Default::default()
    /// };
    /// let report = session.chi2(&lambert, false, &options, &mut |_, _| {})?;
    /// let path = dir.path().join("chi2.svg");
    /// let drawn = session.write_chi2_picture(&lambert, &report, &path)?;
    /// assert_eq!(drawn.rows.len(), 1);
    /// assert!(std::fs::read_to_string(&path).unwrap().contains("<svg"));
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn write_chi2_picture(
        &self,
        params: &crate::ParamSet,
        report: &crate::chi2::Report,
        path: &Path,
    ) -> Result<crate::plot::chi2::Chi2Plot> {
        let subject = crate::plot::Subject::new(params.clone(), None);
        crate::plot::chi2::write_chi2(path, report, &[subject.describe()]).lobe()
    }

    /// The density of the query's sampler at each (ωi, ωo) pair, over the solid angle of ωi:
    /// the f64 reference's `pdf` whatever this session's backend ([`samples::pdf`]; a draw's
    /// own pdf on the GPU is the f32 twin of the same formula). A model without an f64
    /// reference (a `.brdf` file, whose `pdfL` exists only in its kernels) has its density
    /// evaluated by a GPU session's kernels in f32, and is refused by a CPU session. 0 where a
    /// direction is at or below the horizon; delta lobes have no density. Directions must be
    /// unit vectors.
    ///
    /// ```
    /// use lobe::glam::DVec3;
    /// let session = lobe::Session::cpu();
    /// let lambert = lobe::ParamSet::for_model("lambert")?;
    /// let p = session.pdf(&lambert, &[(DVec3::Z, DVec3::Z), (-DVec3::Z, DVec3::Z)])?;
    /// assert!((p[0] - 1.0 / std::f64::consts::PI).abs() < 1e-15);
    /// assert_eq!(p[1], 0.0);
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn pdf<'q>(
        &self,
        query: impl Into<Query<'q>>,
        pairs: &[(DVec3, DVec3)],
    ) -> Result<Vec<f64>> {
        let query = query.into();
        if query.params().model().has_reference() {
            return samples::pdf(query.params(), query.white_furnace, pairs).lobe();
        }
        samples::check_pairs(pairs).lobe()?;
        self.evaluator().backend().pdf(query, pairs).lobe()
    }
}
