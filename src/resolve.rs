//! Model specs, the one way every front end (the command line, scene files, the demo, the
//! Python module, the explorer) turns text into models and parameter sets:
//! - a model: a built-in model's name, a `.brdf` file (compiled and registered under a name from
//!   its stem, [`crate::brdf::load`]) or a MERL file (`PATH.binary`, [`crate::merl::model::load`]);
//! - a spec: a model with its own assignments, `NAME{KEY=VALUE,...}` (rgb values as r,g,b);
//! - parameters: the model's defaults, then a material preset, then assignments `KEY=VALUE`
//!   (or `MODEL.KEY=VALUE`, for one model of several), then the spec's own.
//!
//! Refused assignments carry the tag `"set"` ([`BadInput`]); parameter errors keep their
//! [`ParamError`] (its sentence names the key, the value and the valid range).

use crate::input::BadInput;
use crate::model::{Model, ParamError, ParamSet};
use anyhow::Result;
use std::path::{Path, PathBuf};

/// How model files are loaded.
#[derive(Clone, Debug, Default)]
pub struct SpecOptions {
    /// Options of `.brdf` files (the time limit of each chunk of their GPU work).
    pub brdf: crate::brdf::LoadOptions,
    /// The folder relative file paths are read from (a scene file's own); None: the current one.
    pub base: Option<PathBuf>,
}

impl SpecOptions {
    fn path(&self, name: &str) -> PathBuf {
        let path = Path::new(name.trim());
        match &self.base {
            Some(base) => base.join(path),
            None => path.to_path_buf(),
        }
    }
}

/// The model a name stands for: a model file is loaded (once per process; a second call with
/// the same file returns the same model), any other name looked up. `note` receives a sentence
/// for each section of a `.brdf` file that lobe skips and for the first load of a MERL file.
pub fn load_model(name: &str, options: &SpecOptions, note: &mut dyn FnMut(&str)) -> Result<Model> {
    if crate::merl::model::is_merl_path(name) {
        let loaded = crate::merl::model::load(&options.path(name))?;
        if loaded.first {
            note(&format!(
                "loaded {} as model '{}' ({} of {} values missing, read as 0)",
                name.trim(),
                loaded.model.name(),
                loaded.missing,
                3 * crate::merl::BINS
            ));
        }
        return Ok(loaded.model);
    }
    if crate::brdf::is_brdf_path(name) {
        let loaded = crate::brdf::load(&options.path(name), &options.brdf)?;
        for n in &loaded.notes {
            note(&format!("note: {n}"));
        }
        return Ok(loaded.model);
    }
    Ok(Model::from_name(name.trim())?)
}

/// A model spec split into its name and its own assignments: `phong{shininess=50,diffuse=0.1}`
/// gives ("phong", ["shininess=50", "diffuse=0.1"]); a comma not followed by KEY= belongs to
/// the value before it (an rgb triple).
pub fn split_spec(spec: &str) -> Result<(&str, Vec<String>)> {
    let spec = spec.trim();
    let refuse = |message: String| BadInput::new("model", message);
    let Some(open) = spec.find('{') else {
        if spec.contains('}') {
            return Err(refuse(format!(
                "model '{spec}': a '}}' without its '{{'; write NAME{{KEY=VALUE,...}}"
            ))
            .into());
        }
        return Ok((spec, Vec::new()));
    };
    let Some(inner) = spec[open + 1..].strip_suffix('}') else {
        return Err(refuse(format!(
            "model '{spec}': the parameters must end with '}}', as in phong{{shininess=50}}"
        ))
        .into());
    };
    let mut sets: Vec<String> = Vec::new();
    for piece in inner.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        match sets.last_mut() {
            Some(last) if !piece.contains('=') => {
                last.push(',');
                last.push_str(piece);
            }
            _ => sets.push(piece.to_string()),
        }
    }
    // One spec names a value once: which of two would win is not for lobe to guess.
    let key = |set: &str| set.split('=').next().unwrap_or_default().trim().to_string();
    for (k, set) in sets.iter().enumerate() {
        if let Some(again) = sets[k + 1..].iter().find(|s| key(s) == key(set)) {
            return Err(refuse(format!(
                "model '{spec}': '{}' is given twice ({set} and {again}); give each parameter once",
                key(set)
            ))
            .into());
        }
    }
    Ok((spec[..open].trim(), sets))
}

/// Splits comma-separated model specs at the commas outside braces:
/// `phong{diffuse=0.1,0.2,0.3},lambert` gives two specs.
pub fn split_specs(list: &[String]) -> Vec<String> {
    let mut out = Vec::new();
    for text in list {
        let (mut depth, mut cur) = (0i32, String::new());
        for c in text.chars() {
            match c {
                '{' => depth += 1,
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    out.push(std::mem::take(&mut cur));
                    continue;
                }
                _ => {}
            }
            cur.push(c);
        }
        out.push(cur);
    }
    out.into_iter().filter(|s| !s.trim().is_empty()).collect()
}

/// The parameter set of one spec ([`resolve_specs`] of one).
pub fn resolve_spec(
    spec: &str,
    material: Option<&str>,
    assignments: &[String],
    options: &SpecOptions,
    note: &mut dyn FnMut(&str),
) -> Result<ParamSet> {
    let mut all = resolve_specs(&[spec.to_string()], material, assignments, options, note)?;
    Ok(all.remove(0).1)
}

/// An assignment's refusal: the parameter error, tagged `"set"` with the assignment and model.
fn refused(e: ParamError, set: &str, model: &str) -> anyhow::Error {
    anyhow::Error::new(e).context(BadInput::new("set", format!("{set} for model {model}")))
}

/// The parameter sets of several model specs, each with its label (the spec as given, trimmed):
/// the model's defaults, then the material preset, then each assignment, then the spec's own. An
/// assignment `MODEL.KEY=VALUE` applies to that model only; a plain `KEY=VALUE` applies to every
/// listed model that has KEY, and is refused only when none has it.
pub fn resolve_specs(
    specs: &[String],
    material: Option<&str>,
    assignments: &[String],
    options: &SpecOptions,
    note: &mut dyn FnMut(&str),
) -> Result<Vec<(String, ParamSet)>> {
    let mut parsed: Vec<(Model, Vec<String>)> = Vec::new();
    for s in specs {
        let (name, own) = split_spec(s)?;
        parsed.push((load_model(name, options, note)?, own));
    }
    let mut out = Vec::new();
    for (spec, (model, own)) in specs.iter().zip(&parsed) {
        let name = model.name();
        let mut params = crate::spec::resolve_params(name, material, &[])?;
        for set in assignments {
            let Some((key, _)) = set.split_once('=') else {
                let e = ParamError::NotKeyValue { text: set.clone() };
                return Err(anyhow::Error::new(e).context(BadInput::new("set", set.clone())));
            };
            let assignment = match key.trim().split_once('.') {
                Some((m, rest)) if m == name => format!("{rest}={}", &set[key.len() + 1..]),
                Some(_) => continue,
                // With one model, an unknown key is refused with that model's parameter list.
                None if specs.len() == 1 || has_key(&params, key.trim()) => set.clone(),
                None => continue,
            };
            params
                .set_text(&assignment)
                .map_err(|e| refused(e, set, name))?;
        }
        for set in own {
            params
                .set_text(set)
                .map_err(|e| anyhow::Error::new(e).context(format!("model {}", spec.trim())))?;
        }
        out.push((spec.trim().to_string(), params));
    }
    check_reached(assignments, &out)?;
    Ok(out)
}

/// Every assignment must reach some model.
fn check_reached(assignments: &[String], out: &[(String, ParamSet)]) -> Result<()> {
    let names: Vec<&str> = out.iter().map(|(_, p)| p.model().name()).collect();
    for set in assignments {
        let key = set
            .split_once('=')
            .map(|(k, _)| k.trim())
            .unwrap_or_default();
        let reached = match key.split_once('.') {
            Some((model, rest)) => {
                if !names.contains(&model) {
                    return Err(BadInput::new(
                        "set",
                        format!(
                            "{set}: '{model}' is not one of the models listed ({})",
                            names.join(", ")
                        ),
                    )
                    .into());
                }
                out.iter()
                    .any(|(_, p)| p.model().name() == model && has_key(p, rest))
            }
            None => out.iter().any(|(_, p)| has_key(p, key)),
        };
        if !reached {
            let lists: Vec<String> = out
                .iter()
                .map(|(_, p)| {
                    let keys: Vec<&str> = p.model().params().iter().map(|s| s.key).collect();
                    format!("{}: {}", p.model().name(), keys.join(", "))
                })
                .collect();
            return Err(BadInput::new(
                "set",
                format!(
                    "{set}: no listed model has the parameter '{}'; their parameters are: {}",
                    key.rsplit('.').next().unwrap_or(key),
                    lists.join("; ")
                ),
            )
            .into());
        }
    }
    Ok(())
}

fn has_key(p: &ParamSet, key: &str) -> bool {
    p.model().params().iter().any(|s| s.key == key)
}
