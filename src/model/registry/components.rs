//! The microfacet model's component choices: distribution, masking, Beckmann's G1 variant,
//! Fresnel term and multiple scattering, each an index into its option list. Every combination
//! is its own pipeline (the indices are specialization constants), and the Kulla–Conty tables
//! are computed per combination.

use crate::model::Value;

/// Options of the `distribution` parameter, in the order of their index (specialization
/// constant 3).
pub const DISTRIBUTIONS: &[&str] = &["beckmann", "ggx"];
/// Options of the `masking` parameter, in the order of their index (specialization constant 4).
pub const MASKINGS: &[&str] = &["v_cavity", "smith_separable", "smith_correlated"];
/// Options of the `beckmann_g1` parameter, in the order of their index (specialization
/// constant 5); only Smith masking with Beckmann's D uses it.
pub const BECKMANN_G1S: &[&str] = &["exact", "rational"];
/// Options of the `fresnel` parameter, in the order of their index (specialization constant 6).
pub const FRESNELS: &[&str] = &["none", "schlick", "dielectric", "conductor"];

/// Options of the `multiscatter` parameter, in the order of their index (specialization
/// constant 7): no multiple scattering, or Kulla & Conty's lobe.
pub const MULTISCATTERS: &[&str] = &["none", "kulla_conty"];

/// The component choices, as indices into the option lists; they are the pipeline's
/// specialization constants 3, 4, 5, 6 and 7.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MicrofacetConfig {
    /// Index into [`DISTRIBUTIONS`].
    pub distribution: u8,
    /// Index into [`MASKINGS`].
    pub masking: u8,
    /// Index into [`BECKMANN_G1S`].
    pub beckmann_g1: u8,
    /// Index into [`FRESNELS`].
    pub fresnel: u8,
    /// Index into [`MULTISCATTERS`].
    pub multiscatter: u8,
}

impl MicrofacetConfig {
    /// GGX, height-correlated Smith, exact Beckmann G1 (unused with GGX), Schlick, no multiple
    /// scattering.
    pub const DEFAULT: MicrofacetConfig = MicrofacetConfig {
        distribution: 1,
        masking: 2,
        beckmann_g1: 0,
        fresnel: 1,
        multiscatter: 0,
    };

    /// The configuration a parameter set's choice values name (`get` reads a value by key); an
    /// option it does not know counts as the first.
    pub fn from_values(get: impl Fn(&'static str) -> Value) -> MicrofacetConfig {
        let index = |key: &'static str, options: &[&str]| match get(key) {
            Value::Choice(name) => options.iter().position(|o| *o == name).unwrap_or(0) as u8,
            _ => 0,
        };
        MicrofacetConfig {
            distribution: index("distribution", DISTRIBUTIONS),
            masking: index("masking", MASKINGS),
            beckmann_g1: index("beckmann_g1", BECKMANN_G1S),
            fresnel: index("fresnel", FRESNELS),
            multiscatter: index("multiscatter", MULTISCATTERS),
        }
    }

    /// (key, option) of each component, as parameter values.
    pub fn choices(&self) -> [(&'static str, &'static str); 5] {
        [
            ("distribution", DISTRIBUTIONS[self.distribution as usize]),
            ("masking", MASKINGS[self.masking as usize]),
            ("beckmann_g1", BECKMANN_G1S[self.beckmann_g1 as usize]),
            ("fresnel", FRESNELS[self.fresnel as usize]),
            ("multiscatter", MULTISCATTERS[self.multiscatter as usize]),
        ]
    }

    /// The five indices in the order of specialization constants 3 to 7.
    pub fn spec_constants(&self) -> [u32; 5] {
        [
            self.distribution as u32,
            self.masking as u32,
            self.beckmann_g1 as u32,
            self.fresnel as u32,
            self.multiscatter as u32,
        ]
    }

    /// Whether Kulla & Conty's multiple-scattering lobe is on.
    pub fn kulla_conty(&self) -> bool {
        MULTISCATTERS[self.multiscatter as usize] == "kulla_conty"
    }

    /// `ggx/smith_correlated/schlick` (the G1 variant only where it matters, `+kulla_conty`
    /// where that lobe is on).
    pub fn label(&self) -> String {
        let d = DISTRIBUTIONS[self.distribution as usize];
        let g1 = if self.distribution == 0 && self.masking != 0 {
            format!("+{}", BECKMANN_G1S[self.beckmann_g1 as usize])
        } else {
            String::new()
        };
        format!(
            "{d}/{}{g1}/{}{}",
            MASKINGS[self.masking as usize],
            FRESNELS[self.fresnel as usize],
            if self.kulla_conty() {
                "+kulla_conty"
            } else {
                ""
            }
        )
    }

    /// Every combination of components.
    pub fn all() -> Vec<MicrofacetConfig> {
        let mut out = Vec::new();
        for distribution in 0..DISTRIBUTIONS.len() as u8 {
            for masking in 0..MASKINGS.len() as u8 {
                for beckmann_g1 in 0..BECKMANN_G1S.len() as u8 {
                    for fresnel in 0..FRESNELS.len() as u8 {
                        for multiscatter in 0..MULTISCATTERS.len() as u8 {
                            out.push(MicrofacetConfig {
                                distribution,
                                masking,
                                beckmann_g1,
                                fresnel,
                                multiscatter,
                            });
                        }
                    }
                }
            }
        }
        out
    }
}
