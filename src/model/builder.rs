//! Typed construction of parameter sets for programs that drive the library: no `key=value`
//! strings needed.
//!
//! ```
//! use lobe::model::ParamSet;
//! let p = ParamSet::for_model("microfacet")?
//!     .with_choice("distribution", "ggx")?
//!     .with("alpha", 0.2)?
//!     .with("specular", [1.0, 0.78, 0.34])?;
//! assert_eq!(p.scalar("alpha"), 0.2);
//! # Ok::<(), lobe::model::ParamError>(())
//! ```

use super::params::{ParamError, ParamKind, Value};
use super::{Model, ParamSet};

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
    pub fn for_model(name: &str) -> Result<ParamSet, ParamError> {
        Ok(ParamSet::defaults(Model::from_name(name)?))
    }

    /// The built-in material preset `material` (tin, gold, …) for the model named `model`.
    pub fn preset(material: &str, model: &str) -> Result<ParamSet, ParamError> {
        crate::material::preset(material, Model::from_name(model)?)
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
mod tests {
    use super::*;

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
