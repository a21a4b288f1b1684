//! The catalogue of models: every model with its parameters (kind, range, default, meaning) and
//! the material presets, as JSON for programs and as the text `lobe models` prints for people.

use crate::material;
use crate::model::{Model, ParamKind};
use serde_json::{json, Value};
use std::fmt::Write;

/// "rgb", "scalar", "choice" or "flag".
fn kind_name(kind: &ParamKind) -> &'static str {
    match kind {
        ParamKind::Rgb => "rgb",
        ParamKind::Scalar => "scalar",
        ParamKind::Choice(_) => "choice",
        ParamKind::Flag => "flag",
    }
}

/// `{"models": [{name, description, delta_lobe, parameters: [{key, kind, range, default,
/// description}]}], "materials": [names]}`.
pub fn json() -> Value {
    let models: Vec<Value> = Model::ALL
        .iter()
        .map(|m| {
            let params: Vec<Value> = m
                .params()
                .iter()
                .map(|p| {
                    json!({
                        "key": p.key,
                        "kind": kind_name(&p.kind),
                        "range": p.range_text(),
                        "default": p.default_value().to_string(),
                        "description": p.doc,
                    })
                })
                .collect();
            json!({
                "name": m.name(),
                "description": m.description(),
                "delta_lobe": m.has_delta(),
                "parameters": params,
            })
        })
        .collect();
    json!({"models": models, "materials": material::all_names()})
}

/// One block per model: its name, description and a line per parameter.
pub fn text() -> String {
    let mut out = String::new();
    for m in Model::ALL {
        let delta = if m.has_delta() { "  [delta lobe]" } else { "" };
        let _ = writeln!(out, "{}{delta}\n  {}", m.name(), m.description());
        for p in m.params() {
            let kind = match p.kind {
                ParamKind::Rgb => "rgb",
                ParamKind::Choice(_) => "one of",
                ParamKind::Scalar => "",
                ParamKind::Flag => "flag",
            };
            let _ = writeln!(
                out,
                "    {:<12} {:<4} {:<14} default {:<8} {}",
                p.key,
                kind,
                p.range_text(),
                p.default_value().to_string(),
                p.doc
            );
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_model_and_parameter_is_listed() {
        let doc = json();
        let models = doc["models"].as_array().unwrap();
        assert_eq!(models.len(), Model::ALL.len());
        for (m, entry) in Model::ALL.iter().zip(models) {
            assert_eq!(entry["name"], m.name());
            assert_eq!(
                entry["parameters"].as_array().unwrap().len(),
                m.params().len()
            );
        }
        let text = text();
        for m in Model::ALL {
            assert!(text.contains(m.name()), "{}", m.name());
        }
        assert!(doc["materials"].as_array().unwrap().len() >= 4);
    }
}
