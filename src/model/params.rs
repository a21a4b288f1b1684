//! Parameters as data with a contract: each model lists its keys with kind, range and default;
//! every value reaches a model only through [`ParamSet`], which validates it once, on the host.

use super::{Model, ParamSet};
use std::fmt;

/// Whether a parameter is one number, an RGB triple ("rgb" accepts one number for grey), or one
/// of a list of named options (a model component such as `distribution = ggx`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamKind {
    /// Three channels, linear RGB, each in the parameter's range.
    Rgb,
    /// One real number.
    Scalar,
    /// One of the listed option names (a model component).
    Choice(&'static [&'static str]),
    /// A switch: 0 or 1 (`true` or `false` in text).
    Flag,
}

/// One row of a model's parameter table.
#[derive(Clone, Copy, Debug)]
pub struct ParamSpec {
    /// The name used in `key=value` assignments, material presets and scene files.
    pub key: &'static str,
    /// What kind of value the parameter takes.
    pub kind: ParamKind,
    /// Lower bound of the valid range (for every channel of an RGB parameter).
    pub min: f64,
    /// The lower bound itself is not allowed (for example a roughness must be > 0).
    pub min_exclusive: bool,
    /// Upper bound of the valid range, inclusive.
    pub max: f64,
    /// The value a model starts from before presets and assignments; for a choice, the option's
    /// index.
    pub default: f64,
    /// One line on what the parameter means, shown by `lobe models`.
    pub doc: &'static str,
    /// Values in range but below this are evaluated as it ([`SLOPE_FLOOR`] for a roughness;
    /// −∞, no floor, for every other parameter).
    pub floor: f64,
}

/// The smallest roughness (slope) a model evaluates: a roughness in (0, 1e-5) is evaluated as
/// 1e-5. Two limits set it. The f32 kernels cannot carry the distribution terms of much smaller
/// slopes: α² and α⁴ (which the Beckmann normalisation reaches at grazing half vectors) leave
/// f32's normal range near α = 1e-19 and 1e-10, and at α = 1e-30 even α² underflows to 0, which
/// made every value NaN. And the albedo rules' error estimates stay true bounds only down to
/// about 1e-5: at normal view the peak rule gave E = 0.57 at α = 1e-6 (truth 1) with an estimate
/// of 0.21, while at 1e-5 it gives 0.998 with an estimate of 0.018. At 1e-5 the lobe is ~6e-4
/// degrees wide: a mirror to every grid and image lobe can make.
pub const SLOPE_FLOOR: f64 = 1e-5;

impl ParamSpec {
    /// An RGB parameter in [0, 1], such as an albedo or a reflectance at normal incidence.
    pub const fn rgb(key: &'static str, default: f64, doc: &'static str) -> Self {
        ParamSpec {
            key,
            kind: ParamKind::Rgb,
            min: 0.0,
            min_exclusive: false,
            max: 1.0,
            default,
            doc,
            floor: f64::NEG_INFINITY,
        }
    }

    /// An RGB parameter with its own range (for example a conductor's complex IOR).
    pub const fn rgb_range(
        key: &'static str,
        min: f64,
        max: f64,
        default: f64,
        doc: &'static str,
    ) -> Self {
        ParamSpec {
            key,
            kind: ParamKind::Rgb,
            min,
            min_exclusive: false,
            max,
            default,
            doc,
            floor: f64::NEG_INFINITY,
        }
    }

    /// One of `options`; `default` is an index into them.
    pub const fn choice(
        key: &'static str,
        options: &'static [&'static str],
        default: usize,
        doc: &'static str,
    ) -> Self {
        ParamSpec {
            key,
            kind: ParamKind::Choice(options),
            min: 0.0,
            min_exclusive: false,
            max: 0.0,
            default: default as f64,
            doc,
            floor: f64::NEG_INFINITY,
        }
    }

    /// The default as a value.
    pub fn default_value(&self) -> Value {
        match self.kind {
            ParamKind::Choice(options) => Value::Choice(options[self.default as usize]),
            _ => Value::One(self.default),
        }
    }

    /// A scalar parameter in the closed range [`min`, `max`].
    pub const fn scalar(
        key: &'static str,
        min: f64,
        max: f64,
        default: f64,
        doc: &'static str,
    ) -> Self {
        ParamSpec {
            key,
            kind: ParamKind::Scalar,
            min,
            min_exclusive: false,
            max,
            default,
            doc,
            floor: f64::NEG_INFINITY,
        }
    }

    /// A roughness or slope in (0, `max`]: zero itself is not allowed, and a value below
    /// [`SLOPE_FLOOR`] is evaluated as the floor.
    pub const fn positive(key: &'static str, max: f64, default: f64, doc: &'static str) -> Self {
        ParamSpec {
            key,
            kind: ParamKind::Scalar,
            min: 0.0,
            min_exclusive: true,
            max,
            default,
            doc,
            floor: SLOPE_FLOOR,
        }
    }

    /// A switch, off (0) or on (1) by `default`.
    pub const fn flag(key: &'static str, default: bool, doc: &'static str) -> Self {
        ParamSpec {
            key,
            kind: ParamKind::Flag,
            min: 0.0,
            min_exclusive: false,
            max: 1.0,
            default: default as u8 as f64,
            doc,
            floor: f64::NEG_INFINITY,
        }
    }

    /// The valid range as people write it: `[0, 1]`, `(0, 1]`.
    pub fn range_text(&self) -> String {
        match self.kind {
            ParamKind::Choice(options) => return options.join(" | "),
            ParamKind::Flag => return FLAG_VALUES.to_string(),
            _ => {}
        }
        let open = if self.min_exclusive { "(" } else { "[" };
        format!("{open}{}, {}]", fmt_num(self.min), fmt_num(self.max))
    }

    fn contains(&self, v: f64) -> bool {
        v.is_finite()
            && v <= self.max
            && if self.min_exclusive {
                v > self.min
            } else {
                v >= self.min
            }
    }

    /// Validates one value (or one channel) of this parameter.
    pub fn check(&self, v: f64) -> Result<f64, ParamError> {
        if self.contains(v) {
            Ok(v)
        } else {
            Err(ParamError::OutOfRange {
                key: self.key.to_string(),
                value: v,
                range: self.range_text(),
            })
        }
    }
}

/// What a [`ParamKind::Flag`] accepts, in words.
pub const FLAG_VALUES: &str = "0 or 1 (false or true)";

fn fmt_num(x: f64) -> String {
    if x == std::f64::consts::FRAC_PI_2 {
        "pi/2".to_string()
    } else if x != 0.0 && x.abs() < 1e-3 {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// Why a model name, a parameter assignment or a material preset was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParamError {
    /// The model name is not one of the known models (built-in or registered at run time), or
    /// a model registered at run time has a name that cannot be used.
    #[error("unknown model '{name}'; the models are: {list}")]
    UnknownModel {
        /// The name as given.
        name: String,
        /// The known model names, comma-separated (for a refused run-time name, what a name may
        /// be made of).
        list: String,
    },
    /// The key is not in the model's parameter table.
    #[error("unknown parameter '{key}' for model {model}; its parameters are: {list}")]
    UnknownKey {
        /// The key as given.
        key: String,
        /// The model's name.
        model: String,
        /// The model's parameter keys, comma-separated.
        list: String,
    },
    /// A number (or one channel of an RGB value) lies outside the parameter's range, or is not
    /// finite.
    #[error("parameter '{key}' = {value} is out of range; valid range is {range}")]
    OutOfRange {
        /// The parameter's key.
        key: String,
        /// The refused number.
        value: f64,
        /// The valid range as written by [`ParamSpec::range_text`].
        range: String,
    },
    /// The text is not a number, not an RGB triple, or not one of a choice's options.
    #[error("parameter '{key}': cannot read '{text}' as {expected}")]
    Malformed {
        /// The parameter's key.
        key: String,
        /// The value text as given.
        text: String,
        /// What the parameter accepts, in words.
        expected: String,
    },
    /// An assignment has no `=`.
    #[error("'{text}' is not of the form key=value (for example roughness=0.3)")]
    NotKeyValue {
        /// The assignment as given.
        text: String,
    },
    /// The material exists but has no preset for this model.
    #[error("material '{material}' has no parameters for model {model}; it defines: {list}")]
    NoPreset {
        /// The material's name.
        material: String,
        /// The model's name.
        model: String,
        /// The models the material has presets for, comma-separated.
        list: String,
    },
    /// The material name is not one of the built-in materials.
    #[error("unknown material '{name}'; the materials are: {list}")]
    UnknownMaterial {
        /// The name as given.
        name: String,
        /// The material names, comma-separated.
        list: String,
    },
}

/// A value as given: one number, three for an RGB parameter, or a named option.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    /// One number; for an RGB parameter, grey (the same number in every channel).
    One(f64),
    /// Three numbers, r, g, b.
    Three([f64; 3]),
    /// A named option of a choice parameter.
    Choice(&'static str),
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::One(v) => write!(f, "{v}"),
            Value::Three([r, g, b]) => write!(f, "{r},{g},{b}"),
            Value::Choice(name) => write!(f, "{name}"),
        }
    }
}

impl Value {
    /// Parses `0.3` or `0.9,0.1,0.2` for the parameter `spec`.
    pub fn parse(spec: &ParamSpec, text: &str) -> Result<Value, ParamError> {
        if let ParamKind::Choice(options) = spec.kind {
            return options
                .iter()
                .find(|o| **o == text)
                .map(|o| Value::Choice(o))
                .ok_or_else(|| ParamError::Malformed {
                    key: spec.key.to_string(),
                    text: text.to_string(),
                    expected: format!("one of: {}", options.join(", ")),
                });
        }
        if spec.kind == ParamKind::Flag {
            return match (text, text.parse::<f64>()) {
                ("false", _) | (_, Ok(0.0)) => Ok(Value::One(0.0)),
                ("true", _) | (_, Ok(1.0)) => Ok(Value::One(1.0)),
                _ => Err(ParamError::Malformed {
                    key: spec.key.to_string(),
                    text: text.to_string(),
                    expected: FLAG_VALUES.to_string(),
                }),
            };
        }
        let expected = match spec.kind {
            ParamKind::Rgb => "one number or three comma-separated numbers (r,g,b)",
            _ => "a number",
        };
        let malformed = || ParamError::Malformed {
            key: spec.key.to_string(),
            text: text.to_string(),
            expected: expected.to_string(),
        };
        let parts: Vec<&str> = text.split(',').map(str::trim).collect();
        let nums: Result<Vec<f64>, _> = parts.iter().map(|s| s.parse::<f64>()).collect();
        let nums = nums.map_err(|_| malformed())?;
        match (spec.kind, nums.as_slice()) {
            (_, [v]) => Ok(Value::One(*v)),
            (ParamKind::Rgb, [r, g, b]) => Ok(Value::Three([*r, *g, *b])),
            _ => Err(malformed()),
        }
    }

    /// The numbers of the value: one for a grey or scalar value, three for an RGB triple, none
    /// for a choice.
    pub fn numbers(&self) -> Vec<f64> {
        match *self {
            Value::One(v) => vec![v],
            Value::Three(c) => c.to_vec(),
            Value::Choice(_) => Vec::new(),
        }
    }

    /// The value as three channels: a grey value repeated; NaN for a choice, which has no numbers.
    pub fn rgb(&self) -> [f64; 3] {
        match *self {
            Value::One(v) => [v, v, v],
            Value::Three(c) => c,
            Value::Choice(_) => [f64::NAN; 3],
        }
    }
}

// Typed construction of parameter sets, for programs that drive the library: no `key=value`
// strings needed.

impl From<f64> for Value {
    /// One number (a scalar, or grey for an rgb parameter).
    fn from(v: f64) -> Value {
        Value::One(v)
    }
}

impl From<[f64; 3]> for Value {
    /// Three numbers for an rgb parameter.
    fn from(v: [f64; 3]) -> Value {
        Value::Three(v)
    }
}

impl ParamSet {
    /// The defaults of the model named `name` (built-in or registered at run time).
    ///
    /// ```
    /// use lobe::model::ParamSet;
    /// let p = ParamSet::for_model("microfacet")?
    ///     .with_choice("distribution", "ggx")?
    ///     .with("alpha", 0.2)?
    ///     .with("specular", [1.0, 0.78, 0.34])?;
    /// assert_eq!(p.scalar("alpha"), 0.2);
    /// # Ok::<(), lobe::model::ParamError>(())
    /// ```
    pub fn for_model(name: &str) -> Result<ParamSet, ParamError> {
        Ok(ParamSet::defaults(Model::from_name(name)?))
    }

    /// The same set with `key` set to `value`, validated against the parameter table.
    pub fn with(mut self, key: &str, value: impl Into<Value>) -> Result<ParamSet, ParamError> {
        self.set(key, value.into())?;
        Ok(self)
    }

    /// The same set with the component choice `key` set to the option named `option`.
    pub fn with_choice(mut self, key: &str, option: &str) -> Result<ParamSet, ParamError> {
        let spec = self.model().params().iter().find(|s| s.key == key);
        let chosen = match spec.map(|s| s.kind) {
            Some(ParamKind::Choice(options)) => options.iter().find(|o| **o == option).copied(),
            _ => None,
        };
        match chosen {
            Some(name) => self.set(key, Value::Choice(name))?,
            // Not a choice, or not one of its options: `set` words the error.
            None => self.set_text(&format!("{key}={option}"))?,
        }
        Ok(self)
    }
}

#[cfg(test)]
mod builder_tests {
    use crate::model::ParamSet;

    #[test]
    fn typed_construction_equals_the_text_form() {
        let typed = ParamSet::for_model("microfacet")
            .and_then(|p| p.with_choice("fresnel", "conductor"))
            .and_then(|p| p.with("alpha", 0.3))
            .and_then(|p| p.with("eta", [0.2, 0.4, 1.4]))
            .unwrap();
        let text = crate::resolve_params(
            "microfacet",
            None,
            &[
                "fresnel=conductor".into(),
                "alpha=0.3".into(),
                "eta=0.2,0.4,1.4".into(),
            ],
        )
        .unwrap();
        assert_eq!(typed, text);
    }

    #[test]
    fn a_bad_typed_value_names_the_parameter_and_its_range() {
        let e = ParamSet::for_model("phong")
            .unwrap()
            .with("shininess", -1.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("shininess") && e.contains("range"), "{e}");
        let e = ParamSet::for_model("microfacet")
            .unwrap()
            .with_choice("distribution", "phong")
            .unwrap_err()
            .to_string();
        assert!(e.contains("distribution") && e.contains("ggx"), "{e}");
    }
}
