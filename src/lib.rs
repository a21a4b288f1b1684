#![deny(missing_docs)]
//! lobe: evaluate BRDFs with Vulkan compute shaders (GLSL, f32) over dense (light, view) grids,
//! checked against a CPU reference in f64, and write lobe tables.
//!
//! Start at [`Session`]: it opens the backend (a Vulkan device or the f64 CPU reference), owns
//! the pipeline cache and runs every job the command line runs — f at direction pairs, lobe tables
//! in memory or as files, directional and hemispherical albedo, look-up tables, previews, the
//! stability sweep, benchmarks — returning [`Error`]. Parameter sets are built with
//! [`ParamSet::for_model`], [`ParamSet::preset`] and [`ParamSet::with`]; models are data
//! ([`model::ModelInfo`]), and a model defined at run time joins them through
//! [`model::runtime::RuntimeModel`]. The job modules below are the same functions one level down,
//! taking a session's [`Evaluator`].
//!
//! Conventions (docs/design.md §2): local frame n = +z, t = +x, b = +y;
//! ω = (sinθ cosφ, sinθ sinφ, cosθ); ωi points to the light, ωo to the viewer; f is in 1/sr,
//! linear RGB, without the cosine, and 0 whenever cosθi ≤ 0 or cosθo ≤ 0.

pub mod axis;
pub mod backend;
pub mod bench;
pub mod brdf;
pub mod compare;
pub mod demo;
pub mod energy;
pub mod error;
pub mod eval;
#[cfg(feature = "explore")]
pub mod explore;
pub mod finite;
pub mod fit;
pub mod gpu;
pub mod grid;
pub mod input;
pub mod integrate;
pub mod interrupt;
pub mod loss;
pub mod lut;
pub mod material;
pub mod merl;
pub mod model;
pub mod output;
pub mod pairs;
pub mod plot;
pub mod preview;
pub mod quadrature;
pub mod resolve;
pub mod scene;
pub mod session;
pub mod spec;
pub mod stability;
pub mod table;
pub mod tolerance;
pub mod tradeoff;

pub use backend::Backend;
pub use error::{Error, Result};
pub use eval::Evaluator;
pub use glam;
pub use interrupt::CancelToken;
pub use model::{Model, ParamSet, Reference};
pub use resolve::{resolve_spec, resolve_specs, SpecOptions};
pub use session::{
    AlbedoSettings, BackendKind, EnergyOptions, Session, SessionOptions, Table, TableAxis,
};
pub use spec::resolve_params;
