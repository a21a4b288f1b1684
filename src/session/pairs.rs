//! f at direction pairs: one parameter set, or several of one sweep at once.

use super::Session;
use crate::backend::Query;
use crate::error::{IntoLobe, Result};
use crate::finite::InvalidCount;
use glam::DVec3;

impl Session {
    /// [`Session::eval_pairs`] that keeps NaN, ±Inf and negative values and counts them
    /// instead of refusing them.
    ///
    /// ```
    /// use lobe::glam::DVec3;
    /// let session = lobe::Session::cpu();
    /// let lambert = lobe::ParamSet::for_model("lambert")?;
    /// let (f, invalid) = session.eval_pairs_counting(&lambert, &[(DVec3::Z, DVec3::Z)])?;
    /// assert_eq!(f.len(), 1);
    /// assert!(invalid.is_clean());
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn eval_pairs_counting<'q>(
        &self,
        query: impl Into<Query<'q>>,
        pairs: &[(DVec3, DVec3)],
    ) -> Result<(Vec<[f64; 3]>, InvalidCount)> {
        let query = query.into();
        let tally = std::sync::Mutex::new(InvalidCount::default());
        let f = self
            .evaluator()
            .counting_invalid(&tally)
            .eval_pairs(query, pairs)
            .lobe()?;
        let count = tally
            .into_inner()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        Ok((f, count))
    }

    /// f at each (ωi, ωo) pair, in 1/sr, without the cosine (0 below the horizon); refuses
    /// NaN, ±Inf and negative values ([`Error::InvalidValues`](crate::Error::InvalidValues)).
    ///
    /// ```
    /// use lobe::glam::DVec3;
    /// let session = lobe::Session::cpu();
    /// let lambert = lobe::ParamSet::for_model("lambert")?.with("albedo", 0.5)?;
    /// let f = session.eval_pairs(&lambert, &[(DVec3::Z, DVec3::Z)])?;
    /// assert!((f[0][0] - 0.5 / std::f64::consts::PI).abs() < 1e-12);
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn eval_pairs<'q>(
        &self,
        query: impl Into<Query<'q>>,
        pairs: &[(DVec3, DVec3)],
    ) -> Result<Vec<[f64; 3]>> {
        let query = query.into();
        self.evaluator().eval_pairs(query, pairs).lobe()
    }

    /// f of each parameter set of `sets` at each (ωi, ωo) pair (`out[k][j]`: set k at pair j),
    /// the values [`Session::eval_pairs`] gives one set at a time. On the GPU, sets of one model
    /// go to the device together, each pair naming its set's parameter block, so a sweep of many
    /// sets costs one batch of dispatches instead of one per set. Refuses NaN, ±Inf and negative
    /// values ([`Error::InvalidValues`](crate::Error::InvalidValues)).
    ///
    /// ```
    /// use lobe::glam::DVec3;
    /// use lobe::ParamSet;
    /// let session = lobe::Session::cpu();
    /// let sets = [
    ///     ParamSet::for_model("lambert")?.with("albedo", 0.2)?,
    ///     ParamSet::for_model("lambert")?.with("albedo", 0.8)?,
    /// ];
    /// let f = session.eval_pairs_sets(lobe::Query::sets(&sets), &[(DVec3::Z, DVec3::Z)])?;
    /// assert!(f[1][0][0] > f[0][0][0]);
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn eval_pairs_sets(
        &self,
        query: Query,
        pairs: &[(DVec3, DVec3)],
    ) -> Result<Vec<Vec<[f64; 3]>>> {
        let values = self.evaluator().eval_sets_unchecked(query, pairs).lobe()?;
        for (p, f) in query.sets.iter().zip(&values) {
            let mut count = InvalidCount::default();
            count.add_pairs(0, f, pairs);
            count.refuse(p.model().name(), "evaluating f at direction pairs")?;
        }
        Ok(values)
    }
}
