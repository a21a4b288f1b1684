//! How a look-up table's parameter axis maps its cells to parameter values: the models state
//! their default axis with one of these (`ModelInfo::lut_axis`), and `lobe albedo --lut` takes
//! one by name (docs/design.md §5).

use anyhow::Result;

/// How cell t ∈ (0, 1) of the parameter axis maps to a parameter value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mapping {
    /// p = lo + (hi − lo)·t.
    Linear,
    /// p = lo·(hi/lo)^t (needs lo > 0): for exponents that span decades.
    Log,
    /// p = lo + (hi − lo)·t²: uniform in √p, denser at lo.
    Square,
    /// p = r², r = lo + (hi − lo)·t (lo ≥ 0): real-time engines' perceptual roughness r with
    /// α = r², lo and hi given in r.
    Perceptual,
}

impl Mapping {
    /// Every mapping, in the order the CLI lists them.
    pub const ALL: [Mapping; 4] = [
        Mapping::Linear,
        Mapping::Log,
        Mapping::Square,
        Mapping::Perceptual,
    ];

    /// The name the CLI and the sidecar use.
    pub fn name(self) -> &'static str {
        match self {
            Mapping::Linear => "linear",
            Mapping::Log => "log",
            Mapping::Square => "square",
            Mapping::Perceptual => "perceptual",
        }
    }

    /// Looks a mapping up by [`Mapping::name`]; the error lists the names.
    pub fn from_name(name: &str) -> Result<Mapping> {
        Mapping::ALL
            .into_iter()
            .find(|m| m.name() == name)
            .ok_or_else(|| {
                anyhow::anyhow!(
                    "unknown parameter mapping '{name}'; the mappings are: {}",
                    Mapping::ALL.map(Mapping::name).join(", ")
                )
            })
    }

    /// The formula, for the sidecar.
    pub fn formula(self) -> &'static str {
        match self {
            Mapping::Linear => "p = lo + (hi - lo) * t",
            Mapping::Log => "p = lo * (hi / lo) ** t",
            Mapping::Square => "p = lo + (hi - lo) * t**2",
            Mapping::Perceptual => "p = r**2, r = lo + (hi - lo) * t",
        }
    }

    /// The parameter value at t ∈ [0, 1] of the axis from `lo` to `hi`.
    pub fn apply(self, lo: f64, hi: f64, t: f64) -> f64 {
        match self {
            Mapping::Linear => lo + (hi - lo) * t,
            Mapping::Log => lo * (hi / lo).powf(t),
            Mapping::Square => lo + (hi - lo) * t * t,
            Mapping::Perceptual => {
                let r = lo + (hi - lo) * t;
                r * r
            }
        }
    }
}
