//! The seam between the jobs and where f is evaluated. A job states what it wants as a
//! [`Query`] (parameter sets of one model and the white-furnace switch) and hands it to a
//! [`Backend`]: the f64 CPU reference ([`CpuBackend`]) or the Vulkan kernels
//! ([`crate::gpu::Gpu`]). Each backend owns everything its side needs (direction formats,
//! parameter blocks, node buffers, dispatch batching); the jobs see directions, parameter sets
//! and rules as node lists, and results as f64.

mod cpu;
pub mod light;
mod mirror;
mod quadrants;
pub mod scene;
pub mod shade;

pub use cpu::CpuBackend;
pub use mirror::UpperTriangle;
pub use quadrants::Quadrants;

use crate::interrupt::CancelToken;
use crate::model::{Model, ParamSet};
use crate::quadrature::Node;
use anyhow::Result;
use glam::DVec3;
use std::sync::Arc;
use std::time::Duration;

/// What a job asks a backend to evaluate: one or more parameter sets of one model (the same
/// component choices: a model is one kernel), with every Fresnel factor of a specular lobe
/// replaced by 1 where `white_furnace` is set.
#[derive(Clone, Copy)]
pub struct Query<'a> {
    /// The parameter sets; every one has the model of the first.
    pub sets: &'a [ParamSet],
    /// The white-furnace switch (docs/design.md §4).
    pub white_furnace: bool,
}

impl<'a> Query<'a> {
    /// One parameter set, with the model's Fresnel factors (`.with_white_furnace(true)` replaces
    /// them by 1). `&params` converts into the same query.
    pub fn one(params: &'a ParamSet) -> Query<'a> {
        Query::sets(std::slice::from_ref(params))
    }

    /// Several parameter sets of one model, with the model's Fresnel factors.
    pub fn sets(sets: &'a [ParamSet]) -> Query<'a> {
        Query {
            sets,
            white_furnace: false,
        }
    }

    /// The same sets, with every Fresnel factor of a specular lobe replaced by 1 where `on`.
    pub fn with_white_furnace(self, on: bool) -> Query<'a> {
        Query {
            white_furnace: on,
            ..self
        }
    }

    /// The first parameter set: the one a single-set job evaluates.
    ///
    /// # Panics
    /// On a query without sets (the constructors of one set cannot make one).
    pub fn params(&self) -> &'a ParamSet {
        &self.sets[0]
    }

    /// The same switch for the one parameter set `params`.
    pub fn for_set<'b>(&self, params: &'b ParamSet) -> Query<'b> {
        Query::one(params).with_white_furnace(self.white_furnace)
    }

    /// The model of every set (of the first; None without sets).
    pub fn model(&self) -> Option<Model> {
        self.sets.first().map(ParamSet::model)
    }

    /// Whether every set has the same model (component choices included), as a backend needs.
    pub fn one_model(&self) -> bool {
        self.sets.windows(2).all(|w| w[0].model() == w[1].model())
    }
}

impl<'a> From<&'a ParamSet> for Query<'a> {
    fn from(params: &'a ParamSet) -> Query<'a> {
        Query::one(params)
    }
}

/// One draw of a model's sampler as a backend returns it ([`Backend::draws`]): the sample
/// (docs/design.md §13) and, at its ωi, the model's density and f cos θi, so that a caller can
/// check the three against each other.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DrawRecord {
    /// The direction drawn, towards the light (kept below the horizon, where the draw is lost).
    pub wi: [f64; 3],
    /// The sampler's density at ωi (for a delta sample, the probability of the spike); 0 for a
    /// lost draw.
    pub pdf: f64,
    /// f cos θi / pdf per channel (for a delta sample, the spike's albedo over its probability).
    pub weight: [f64; 3],
    /// Whether the draw is the mirror spike.
    pub delta: bool,
    /// The model's density function at (ωi, ωo), `Reference::pdf` or the kernel's `MODEL_PDF`.
    pub pdf_at: f64,
    /// f(ωi, ωo) max(0, cos θi), f one-sided (0 below the horizon).
    pub eval_cos: [f64; 3],
}

/// Which draws of a sampler's stream a backend makes ([`Backend::draws`]): draws
/// `first .. first + count` of the stream (`seed`, `group`), draw i from
/// [`crate::random::draw_numbers`]`(seed, i, group)`. The sampling test gives each view
/// direction its own group; a range of draws is a pure function of these four numbers, so
/// any split into ranges draws the same directions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DrawRange {
    /// The stream's seed.
    pub seed: u32,
    /// The group of four dimensions (a view direction's index in the sampling test).
    pub group: u32,
    /// The index of the first draw.
    pub first: u64,
    /// How many draws.
    pub count: usize,
}

impl DrawRange {
    /// Draws `0 .. count` of the stream `seed` in group 0: what `lobe sample` draws (and the
    /// sampling test at its first view direction).
    pub fn new(seed: u32, count: usize) -> DrawRange {
        DrawRange {
            seed,
            group: 0,
            first: 0,
            count,
        }
    }
}

/// A sampler's draws counted on a device for the sampling test ([`Backend::draw_counts`]): the
/// cells' counts and the draw checks' tallies, as `crate::chi2` counts them on the CPU.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DrawCounts {
    /// Draws per cell, cell i_cos · n_phi + i_phi.
    pub cells: Vec<u64>,
    /// Draws below the horizon or with pdf 0 (not delta, not invalid).
    pub lost: u64,
    /// Draws from a delta lobe.
    pub delta: u64,
    /// Draws whose ωi or pdf is NaN or infinite, or whose pdf is negative.
    pub invalid: u64,
    /// Draws off unit length by more than the backend's tolerance.
    pub non_unit: u64,
    /// Draws above the horizon with pdf 0.
    pub zero_pdf: u64,
    /// Draws with a NaN or infinite weight.
    pub non_finite_weight: u64,
    /// Draws outside the cells whose weight is not 0.
    pub nonzero_weight_outside: u64,
    /// Draws below the horizon reported with a pdf other than 0.
    pub nonzero_pdf_below: u64,
    /// The largest relative difference of a counted draw's weight from f cos θi / pdf.
    pub max_weight_error: f64,
    /// The largest relative difference of a counted draw's pdf from the pdf at its ωi.
    pub max_pdf_error: f64,
}

/// The draws a backend counts ([`Backend::draw_counts`]): the range of the stream and the
/// cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DrawCounting {
    /// Which draws.
    pub range: DrawRange,
    /// Steps in φ over [0, 2π).
    pub n_phi: usize,
    /// Steps in cosθ over [0, 1].
    pub n_cos: usize,
    /// How many of the range's first draws also have their weight checked against
    /// f cos θi / pdf and their pdf against the pdf at ωi ([`DrawCounts::max_weight_error`],
    /// [`DrawCounts::max_pdf_error`], [`DrawCounts::non_finite_weight`],
    /// [`DrawCounts::nonzero_weight_outside`]); every draw has the other checks.
    pub checked: u64,
}

/// The arithmetic a backend evaluates and sums in: what an error estimate must allow for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    /// f32 kernels (directions, f and sums rounded to f32).
    F32,
    /// The f64 reference.
    F64,
}

/// A hemispherical rule as a backend sees it: the node list at each view direction, either one
/// list shared by every direction or one made per direction.
pub trait NodeRule: Sync {
    /// The one list every view direction shares, or None where the list depends on ωo.
    fn shared(&self) -> Option<Arc<Vec<Node>>>;
    /// How many nodes the list at `wo` holds.
    fn count(&self, wo: DVec3) -> usize;
    /// Each node of the list at `wo`, in order, without making the list.
    fn visit(&self, wo: DVec3, emit: &mut dyn FnMut(Node));
    /// The list at `wo`.
    fn list(&self, wo: DVec3) -> Vec<Node>;
}

/// One rule's sums for several parameter sets: `[set][ωo]` of (Σ w f, the number of nodes).
pub type RowSums = Vec<Vec<(DVec3, u64)>>;

/// Receives runs of a table's cells, in order, one chunk at a time: the first cell's index and the
/// RGB values (from [`Backend::table_upper_triangle`], packed cells).
pub type TableSink<'a> = dyn FnMut(u64, &[f32]) -> Result<()> + 'a;

/// Where f is evaluated: the jobs' one way down to the CPU reference or the Vulkan kernels.
/// Values come back as the backend computed them (NaN, ±Inf and negative values included: the
/// [`crate::Evaluator`] applies the refusal policy); a backend stops between chunks once
/// `cancel` is set.
pub trait Backend: Send + Sync {
    /// A one-line description: "gpu (device name)" or "cpu (f64 reference)".
    fn name(&self) -> String;

    /// The device's name, where the backend runs on one.
    fn device(&self) -> Option<String> {
        None
    }

    /// The driver and its version where there is one ("llvmpipe Mesa 22.3.6 (LLVM 15.0.6)").
    fn driver(&self) -> Option<String> {
        None
    }

    /// The arithmetic of the backend's values and sums.
    fn precision(&self) -> Precision;

    /// Ok where the backend can evaluate `model`; the error says why not (the CPU reference
    /// needs the model's f64 twin).
    fn supports(&self, model: Model) -> Result<()>;

    /// f of every parameter set of `query` at every pair: `[set][pair]`.
    fn pairs(&self, query: Query, pairs: &[(DVec3, DVec3)]) -> Result<Vec<Vec<[f64; 3]>>>;

    /// The outer-product table f(`wi[i]`, `wo[o]`) of the query's first set, cell
    /// i · wo.len() + o, handed to `sink` in order one chunk at a time. `fast_pow` asks for
    /// cos^n lobes by the plain pow (a speed-for-accuracy variant; the reference ignores it).
    fn table(
        &self,
        query: Query,
        wi: &[DVec3],
        wo: &[DVec3],
        fast_pow: bool,
        cancel: Option<&CancelToken>,
        sink: &mut TableSink<'_>,
    ) -> Result<()>;

    /// Whether the table chunk being handed to a sink right now (on this thread) was found free
    /// of invalid values by the backend itself, so that the caller need not read it for them:
    /// the GPU's table kernel flags any invalid value it makes (docs/design.md §2.1). False
    /// where the backend does not know.
    fn table_chunk_valid(&self) -> bool {
        false
    }

    /// Whether [`Backend::table_upper_triangle`] is available: the backend can evaluate only the
    /// upper triangle of a reciprocal model's isotropic table (docs/design.md §4.5). The f64
    /// reference cannot: it makes every cell from its own directions.
    fn makes_upper_triangle(&self) -> bool {
        false
    }

    /// The packed upper triangle ([`UpperTriangle`]) of the isotropic table of the query's first
    /// set with equal θ axes: `wi[i]` at (θ_i, φ = 0), `wo[o · NDPHI + d]` at (θ_o, Δφ_d),
    /// NDPHI = wo.len() / wi.len(); the cells (i, o, d) with o ≥ i, handed to `sink` in order one
    /// chunk at a time as (first packed cell, values). The caller fills the other cells from
    /// these ([`UpperTriangle::scatter`]). Only where [`Backend::makes_upper_triangle`].
    fn table_upper_triangle(
        &self,
        _query: Query,
        _wi: &[DVec3],
        _wo: &[DVec3],
        _fast_pow: bool,
        _cancel: Option<&CancelToken>,
        _sink: &mut TableSink<'_>,
    ) -> Result<()> {
        anyhow::bail!("{} evaluates every cell of a table", self.name())
    }

    /// Σ w f(ωi, ωo) over each rule's nodes, for each parameter set and each ωo:
    /// `[rule][set][ωo]`. A direction's nodes are made once for every set.
    fn rule_sums(
        &self,
        query: Query,
        rules: &[&dyn NodeRule],
        wo: &[DVec3],
        cancel: Option<&CancelToken>,
    ) -> Result<Vec<RowSums>>;

    /// The draws `range` of the sampler of the query's first set for `wo`: draw i takes its
    /// numbers from [`crate::random::draw_numbers`]`(range.seed, i, range.group)`, so both
    /// backends draw the same directions (the GPU's within f32 rounding). Stops between chunks
    /// once `cancel` is set.
    fn draws(
        &self,
        query: Query,
        wo: DVec3,
        range: DrawRange,
        cancel: Option<&CancelToken>,
    ) -> Result<Vec<DrawRecord>>;

    /// The sampler's density over the solid angle of ωi, pdf(ωi, ωo), of the query's first set
    /// at each (ωi, ωo) pair, in the backend's precision: `Reference::pdf` in f64, or the
    /// kernels' `pdf_at` in f32 (a `.brdf` file's `pdfL` where it has one). 0 where either
    /// direction is at or below the horizon.
    fn pdf(&self, query: Query, pairs: &[(DVec3, DVec3)]) -> Result<Vec<f64>>;

    /// The draws `range` of the sampler of the query's first set for `wo`, counted where they
    /// are drawn in `n_phi` × `n_cos` cells of equal solid angle over (φ, cosθ) (the sampling
    /// test's cells, `crate::chi2::Cells`) with the draw checks, for a backend that draws on a
    /// device; None where the backend counts no draws itself (the f64 reference: the test draws
    /// through its sampler directly). Stops between chunks once `cancel` is set.
    fn draw_counts(
        &self,
        _query: Query,
        _wo: DVec3,
        _range: DrawCounting,
        _cancel: Option<&CancelToken>,
    ) -> Option<Result<DrawCounts>> {
        None
    }

    /// The radiance toward the camera of each of `pixels` of the sphere lit by `texels`, for the
    /// query's first set: per pixel Σ f(ωi, ωo) cos θi L ΔΩ over the texels above its horizon
    /// (docs/design.md §15), in the order of `pixels`. Stops between chunks once `cancel` is set.
    fn light(
        &self,
        query: Query,
        texels: &light::WeightedTexels,
        pixels: &[light::SpherePixel],
        cancel: Option<&CancelToken>,
    ) -> Result<Vec<[f64; 3]>>;

    /// The radiance of every pixel of one cell per parameter set of `query` (cell k shaded with
    /// set k), in the order (cell, row from the top, column).
    fn preview(&self, query: Query, scene: &scene::Scene) -> Result<Vec<[f32; 3]>>;

    /// Device time (from timestamps) of every dispatch since the last call, where the backend
    /// has such a clock.
    fn take_device_time(&self) -> Option<Duration> {
        None
    }

    /// Every kernel built so far, with its build time.
    fn built_kernels(&self) -> Vec<(String, Duration)> {
        Vec::new()
    }
}

/// What the scatter tests of [`UpperTriangle`] and [`Quadrants`] share.
#[cfg(test)]
mod scatter_tests {
    use super::TableSink;
    use anyhow::Result;

    /// A scatter: evaluated cells `first ..` in, runs of table cells out, with scratch memory.
    pub type Scatter<'a> =
        dyn FnMut(u64, &[f32], &mut Vec<f32>, &mut TableSink<'_>) -> Result<()> + 'a;

    /// The table of `cells` cells that `scatter` fills from `evaluated` (3 f32 a cell) handed
    /// over `chunk` cells at a time, and how many times each cell arrived. Asserts that the
    /// scratch memory never outgrows the chunk.
    pub fn scattered(
        cells: usize,
        evaluated: &[f32],
        chunk: usize,
        scatter: &mut Scatter<'_>,
    ) -> (Vec<f32>, Vec<u32>) {
        let mut table = vec![f32::NAN; cells * 3];
        let mut seen = vec![0u32; cells];
        let mut scratch = Vec::new();
        for (c, values) in evaluated.chunks(chunk * 3).enumerate() {
            let first = (c * chunk) as u64;
            scatter(first, values, &mut scratch, &mut |at, run| {
                let at = at as usize;
                table[at * 3..at * 3 + run.len()].copy_from_slice(run);
                seen[at..at + run.len() / 3]
                    .iter_mut()
                    .for_each(|s| *s += 1);
                Ok(())
            })
            .unwrap();
            assert!(scratch.len() <= values.len());
        }
        (table, seen)
    }
}
