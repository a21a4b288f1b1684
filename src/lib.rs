#![deny(missing_docs)]
//! lobe: evaluate BRDFs with Vulkan compute shaders (GLSL, f32) over dense (light, view) grids,
//! checked against a CPU reference in f64, and write lobe tables.
//!
//! Start at [`Session`]: it opens the backend (a Vulkan device or the f64 CPU reference), owns
//! the pipeline cache and runs every job the command line runs — f at direction pairs, lobe tables
//! in memory ([`Table`]) or as files, directional and hemispherical albedo, look-up tables, the
//! energy, stability and trade-off reports, comparisons and fits, plots, previews, scenes, the
//! demo, benchmarks — each a method taking an options value and returning a typed result or
//! [`Error`]. Parameter sets are built with [`ParamSet::for_model`], [`ParamSet::preset`] and
//! [`ParamSet::with`]; models are data ([`model::ModelInfo`]), and a model defined at run time
//! joins them through [`model::runtime::RuntimeModel`]. The job modules below are the same
//! functions one level down, taking a session's [`Evaluator`].
//!
//! ```
//! use lobe::{grid::Grid, ParamSet, Session};
//! let session = Session::cpu(); // or Session::open(SessionOptions::default()) for the GPU
//! let gold = ParamSet::preset("gold", "cook_torrance")?.with("roughness", 0.2)?;
//! let grid = Grid::Isotropic { n_theta_i: 4, n_theta_o: 4, n_dphi: 8 };
//! let table = session.table(&gold, &grid, 1 << 10)?;
//! let [r, g, b] = table.at(&[1, 1, 0]); // f at (θi, θo, Δφ) cell (1, 1, 0), in 1/sr
//! assert!(r > b && g > b); // gold reflects red and green more than blue
//! # Ok::<(), lobe::Error>(())
//! ```
//!
//! Conventions (docs/design.md §2): local frame n = +z, t = +x, b = +y;
//! ω = (sinθ cosφ, sinθ sinφ, cosθ); ωi points to the light, ωo to the viewer; f is in 1/sr,
//! linear RGB, without the cosine, and 0 whenever cosθi ≤ 0 or cosθo ≤ 0.

mod axis;
pub mod backend;
pub mod bench;
pub mod brdf;
pub mod catalogue;
pub mod chi2;
pub mod compare;
pub mod demo;
pub mod energy;
mod error;
mod eval;
#[cfg(feature = "explore")]
pub mod explore;
pub mod finite;
pub mod fit;
pub mod gpu;
pub mod grid;
pub mod input;
pub mod integrate;
pub mod interrupt;
pub mod light;
pub mod loss;
pub mod lut;
pub mod material;
pub mod merl;
pub mod model;
pub mod output;
pub mod pairs;
pub mod plot;
pub mod preview;
mod quadrature;
pub mod random;
pub mod resolve;
pub mod samples;
pub mod scene;
mod session;
mod spec;
pub mod stability;
pub mod table;
pub mod tolerance;
pub mod tradeoff;

pub use backend::{Backend, Query};
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
