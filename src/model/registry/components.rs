//! The microfacet model's component choices: distribution, masking, Beckmann's G1 variant,
//! Fresnel term and multiple scattering, each a typed enum whose discriminant is the option's
//! index. Every combination is its own pipeline (the indices are specialization constants), and
//! the Kulla–Conty tables are computed per combination.

use crate::model::Value;

/// A closed set of named options that selects a pipeline: the enum (`#[repr(u32)]`, each
/// discriminant the option's index, which is the specialization constant's value), `ALL` in
/// index order, `NAMES` (the option names in the same order: the parameter table's choice list),
/// `name()` and `from_name()`. Each variant is written once, with its index and its name, so the
/// enum and the parameter table cannot disagree.
macro_rules! choice_enum {
    (
        $(#[$meta:meta])*
        pub enum $name:ident {
            $( $(#[$variant_meta:meta])* $variant:ident = $index:literal => $option:literal, )+
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        #[repr(u32)]
        pub enum $name {
            $( $(#[$variant_meta])* $variant = $index, )+
        }

        impl $name {
            /// Every option, in the order of its index.
            pub const ALL: &'static [$name] = &[$($name::$variant),+];

            /// The option names, in the order of their index: the parameter's choice list.
            pub const NAMES: &'static [&'static str] = &[$($option),+];

            /// The option's name, as parameter values spell it.
            pub const fn name(self) -> &'static str {
                match self {
                    $($name::$variant => $option,)+
                }
            }

            /// The option a parameter value names, or None for a name it does not know.
            pub fn from_name(name: &str) -> Option<$name> {
                match name {
                    $($option => Some($name::$variant),)+
                    _ => None,
                }
            }
        }
    };
}
pub(crate) use choice_enum;

choice_enum! {
    /// The normal distribution D: the `distribution` parameter, specialization constant 3.
    pub enum Distribution {
        /// Beckmann's Gaussian distribution of slopes (Beckmann & Spizzichino 1963).
        Beckmann = 0 => "beckmann",
        /// GGX, Trowbridge & Reitz's distribution (Walter et al. 2007).
        Ggx = 1 => "ggx",
    }
}

choice_enum! {
    /// The masking-shadowing term G: the `masking` parameter, specialization constant 4.
    pub enum Masking {
        /// Cook & Torrance's V-cavity masking (Torrance & Sparrow 1967).
        VCavity = 0 => "v_cavity",
        /// Smith's G1(ωi) G1(ωo), masking and shadowing independent (Walter et al. 2007).
        SmithSeparable = 1 => "smith_separable",
        /// Smith's height-correlated 1/(1 + Λ(ωi) + Λ(ωo)) (Heitz 2014).
        SmithCorrelated = 2 => "smith_correlated",
    }
}

choice_enum! {
    /// Beckmann's Smith G1: the `beckmann_g1` parameter, specialization constant 5; only Smith
    /// masking with Beckmann's D uses it.
    pub enum BeckmannG1 {
        /// The exact form with erf.
        Exact = 0 => "exact",
        /// Walter et al. 2007's rational fit.
        Rational = 1 => "rational",
    }
}

choice_enum! {
    /// The Fresnel factor F: the `fresnel` parameter, specialization constant 6.
    pub enum Fresnel {
        /// F = 1.
        None = 0 => "none",
        /// Schlick 1994's approximation, from `f0` or from `ior`.
        Schlick = 1 => "schlick",
        /// The exact unpolarized dielectric, from `ior`.
        Dielectric = 2 => "dielectric",
        /// The exact unpolarized conductor, from `eta` and `k`.
        Conductor = 3 => "conductor",
    }
}

choice_enum! {
    /// Multiple scattering: the `multiscatter` parameter, specialization constant 7.
    pub enum Multiscatter {
        /// The single-scattering lobe alone.
        None = 0 => "none",
        /// Kulla & Conty 2017's lobe, from lobe's own E(μ, α) tables.
        KullaConty = 1 => "kulla_conty",
    }
}

/// The component choices; their indices are the pipeline's specialization constants 3, 4, 5, 6
/// and 7. The derived order is that of the indices, field by field.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MicrofacetConfig {
    /// The normal distribution D.
    pub distribution: Distribution,
    /// The masking-shadowing term G.
    pub masking: Masking,
    /// Beckmann's Smith G1 variant.
    pub beckmann_g1: BeckmannG1,
    /// The Fresnel factor F.
    pub fresnel: Fresnel,
    /// Multiple scattering.
    pub multiscatter: Multiscatter,
}

impl MicrofacetConfig {
    /// GGX, height-correlated Smith, exact Beckmann G1 (unused with GGX), Schlick, no multiple
    /// scattering: the parameter table's defaults.
    pub const DEFAULT: MicrofacetConfig = MicrofacetConfig {
        distribution: Distribution::Ggx,
        masking: Masking::SmithCorrelated,
        beckmann_g1: BeckmannG1::Exact,
        fresnel: Fresnel::Schlick,
        multiscatter: Multiscatter::None,
    };

    /// The configuration a parameter set's choice values name (`get` reads a value by key); an
    /// option it does not know counts as the first.
    pub fn from_values(get: impl Fn(&'static str) -> Value) -> MicrofacetConfig {
        let name = |key: &'static str| match get(key) {
            Value::Choice(name) => name,
            _ => "",
        };
        MicrofacetConfig {
            distribution: Distribution::from_name(name("distribution"))
                .unwrap_or(Distribution::ALL[0]),
            masking: Masking::from_name(name("masking")).unwrap_or(Masking::ALL[0]),
            beckmann_g1: BeckmannG1::from_name(name("beckmann_g1")).unwrap_or(BeckmannG1::ALL[0]),
            fresnel: Fresnel::from_name(name("fresnel")).unwrap_or(Fresnel::ALL[0]),
            multiscatter: Multiscatter::from_name(name("multiscatter"))
                .unwrap_or(Multiscatter::ALL[0]),
        }
    }

    /// (key, option) of each component, as parameter values.
    pub fn choices(&self) -> [(&'static str, &'static str); 5] {
        [
            ("distribution", self.distribution.name()),
            ("masking", self.masking.name()),
            ("beckmann_g1", self.beckmann_g1.name()),
            ("fresnel", self.fresnel.name()),
            ("multiscatter", self.multiscatter.name()),
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
        self.multiscatter == Multiscatter::KullaConty
    }

    /// Whether the G1 choice matters: Smith masking (separable or correlated) with Beckmann's D.
    pub fn uses_beckmann_g1(&self) -> bool {
        self.distribution == Distribution::Beckmann && self.masking != Masking::VCavity
    }

    /// `ggx/smith_correlated/schlick` (the G1 variant only where it matters, `+kulla_conty`
    /// where that lobe is on).
    pub fn label(&self) -> String {
        let g1 = if self.uses_beckmann_g1() {
            format!("+{}", self.beckmann_g1.name())
        } else {
            String::new()
        };
        format!(
            "{}/{}{g1}/{}{}",
            self.distribution.name(),
            self.masking.name(),
            self.fresnel.name(),
            if self.kulla_conty() {
                "+kulla_conty"
            } else {
                ""
            }
        )
    }

    /// Every combination of components, in the derived order.
    pub fn all() -> Vec<MicrofacetConfig> {
        let mut out = Vec::new();
        for &distribution in Distribution::ALL {
            for &masking in Masking::ALL {
                for &beckmann_g1 in BeckmannG1::ALL {
                    for &fresnel in Fresnel::ALL {
                        for &multiscatter in Multiscatter::ALL {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::eon::EonMultiscatter;

    /// Each enum's discriminants are 0, 1, … in the order of `ALL`, its names in `NAMES`, and
    /// every name parses back to its option.
    macro_rules! check_enum {
        ($name:ident, $names:expr) => {
            assert_eq!($name::NAMES, $names);
            assert_eq!($name::ALL.len(), $name::NAMES.len());
            for (i, &v) in $name::ALL.iter().enumerate() {
                assert_eq!(v as usize, i, "{v:?}");
                assert_eq!(v.name(), $name::NAMES[i]);
                assert_eq!($name::from_name(v.name()), Some(v));
            }
            assert_eq!($name::from_name("no_such_option"), None);
        };
    }

    #[test]
    fn options_keep_their_indices_and_names() {
        // The indices are the kernels' specialization constants: these lists must not change
        // order (glsl/brdf/microfacet.glsl, constants 3 to 7).
        check_enum!(Distribution, &["beckmann", "ggx"]);
        check_enum!(
            Masking,
            &["v_cavity", "smith_separable", "smith_correlated"]
        );
        check_enum!(BeckmannG1, &["exact", "rational"]);
        check_enum!(Fresnel, &["none", "schlick", "dielectric", "conductor"]);
        check_enum!(Multiscatter, &["none", "kulla_conty"]);
        // EON's, constant 3 of glsl/brdf/eon.glsl.
        check_enum!(EonMultiscatter, &["exact", "approx", "none"]);
    }

    #[test]
    fn every_combination_once_in_index_order() {
        let all = MicrofacetConfig::all();
        assert_eq!(all.len(), 2 * 3 * 2 * 4 * 2);
        // Sorted by the derived order, which is the lexicographic order of the indices.
        for pair in all.windows(2) {
            assert!(pair[0] < pair[1], "{pair:?}");
            assert!(
                pair[0].spec_constants() < pair[1].spec_constants(),
                "{pair:?}"
            );
        }
        assert_eq!(MicrofacetConfig::DEFAULT.spec_constants(), [1, 2, 0, 1, 0]);
    }

    #[test]
    fn values_round_trip() {
        for c in MicrofacetConfig::all() {
            let choices = c.choices();
            let get = |key: &'static str| {
                let (_, name) = choices
                    .iter()
                    .find(|(k, _)| *k == key)
                    .expect("a component");
                Value::Choice(*name)
            };
            assert_eq!(MicrofacetConfig::from_values(get), c);
        }
        // An unknown option counts as the first.
        let c = MicrofacetConfig::from_values(|_| Value::Choice("no_such_option"));
        assert_eq!(c.spec_constants(), [0; 5]);
    }
}
