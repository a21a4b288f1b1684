//! What a plot draws: models with their parameters ([`Subject`]), the header lines and titles
//! that name them, and the JSON of their full parameter sets written beside a picture.

use super::{fmt_value, Plotted};
use crate::model::ParamSet;
use anyhow::{Context, Result};
use std::path::Path;

/// One model with its parameters, as a plot overlays or tiles it.
#[derive(Clone, Debug)]
pub struct Subject {
    /// `gold cook_torrance`, or the model's name without a material.
    pub label: String,
    /// The model and its checked parameter values.
    pub params: ParamSet,
}

impl Subject {
    /// A subject labelled `material model`, or the model's name alone when `material` is `None`.
    pub fn new(params: ParamSet, material: Option<&str>) -> Subject {
        let label = match material {
            Some(m) => format!("{m} {}", params.model().name()),
            None => params.model().name().to_string(),
        };
        Subject { label, params }
    }

    /// `gold cook_torrance: diffuse=… specular=…`, the parameters its components use.
    pub fn describe(&self) -> String {
        describe_subjects(std::slice::from_ref(self)).remove(0)
    }
}

/// A parameter value for a title: numbers shortened, an RGB triple of one grey as one number.
fn value_text(v: crate::model::Value) -> String {
    use crate::model::Value;
    match v {
        Value::One(x) => fmt_value(x),
        Value::Three([r, g, b]) if r == g && g == b => fmt_value(r),
        Value::Three(c) => c.map(fmt_value).join(","),
        Value::Choice(name) => name.to_string(),
    }
}

/// The header lines that say what the series are: the parameters every series shares, once,
/// then each series with only what differs, and only parameters that the series' components
/// use ([`ParamSet::is_active`]). The full sets go to the JSON beside the picture
/// ([`write_params_json`]).
pub fn describe_subjects(subjects: &[Subject]) -> Vec<String> {
    let active: Vec<Vec<(&str, String)>> = subjects
        .iter()
        .map(|s| {
            s.params
                .active_entries()
                .into_iter()
                .map(|(k, v)| (k, value_text(v)))
                .collect()
        })
        .collect();
    if subjects.len() == 1 {
        let text: Vec<String> = active[0].iter().map(|(k, v)| format!("{k}={v}")).collect();
        return vec![format!("{}: {}", subjects[0].label, text.join(" "))];
    }
    // Shared: the same value in every series.
    let shared: Vec<&(&str, String)> = active[0]
        .iter()
        .filter(|e| active.iter().all(|a| a.contains(e)))
        .collect();
    let mut lines = Vec::new();
    if !shared.is_empty() {
        let text: Vec<String> = shared.iter().map(|(k, v)| format!("{k}={v}")).collect();
        lines.push(format!("all: {}", text.join(" ")));
    }
    let own: Vec<String> = subjects
        .iter()
        .zip(&active)
        .map(|(s, a)| {
            let text: Vec<String> = a
                .iter()
                .filter(|e| !shared.contains(e))
                .map(|(k, v)| format!("{k}={v}"))
                .collect();
            if text.is_empty() {
                s.label.clone()
            } else {
                format!("{}: {}", s.label, text.join(" "))
            }
        })
        .collect();
    lines.push(own.join(" · "));
    lines
}

/// The series for a title: `gold: phong, blinn_phong` when every label starts with the same
/// material, `gold cook_torrance vs tin cook_torrance` otherwise; more than four series are
/// counted (the legend names them).
pub fn series_names(subjects: &[Subject]) -> String {
    let labels: Vec<&str> = subjects.iter().map(|s| s.label.as_str()).collect();
    let first = labels.first().copied().unwrap_or_default();
    let prefix = first.split_once(' ').map(|(m, _)| m);
    let common_material = prefix.filter(|m| {
        labels.len() > 1
            && labels
                .iter()
                .all(|l| l.split_once(' ').map(|(p, _)| p) == Some(*m))
    });
    match common_material {
        Some(m) if labels.len() > 4 => format!("{m}, {} models", labels.len()),
        Some(m) => {
            let rest: Vec<&str> = labels.iter().map(|l| &l[m.len() + 1..]).collect();
            format!("{m}: {}", rest.join(" vs "))
        }
        None if labels.len() > 4 => format!("{} series", labels.len()),
        None => labels.join(" vs "),
    }
}

/// Where the parameters of a picture go: `path` with the extension `.json`.
pub fn params_json_path(path: &Path) -> std::path::PathBuf {
    path.with_extension("json")
}

/// Writes every series' full parameter set (and the picture's title) as JSON to
/// [`params_json_path`] of `path`: `{"title": …, "series": [{"label", "model", "params"}]}`.
pub fn write_params_json(path: &Path, subjects: &[Subject], plotted: &Plotted) -> Result<()> {
    let json = params_json(subjects, plotted.title());
    let dest = params_json_path(path);
    let text = serde_json::to_string_pretty(&json)? + "\n";
    crate::output::write_atomic(&dest, |w| {
        std::io::Write::write_all(w, text.as_bytes())
            .with_context(|| format!("writing {}", dest.display()))
    })
}

/// What [`write_params_json`] writes: `{"title": …, "series": [{"label", "model", "params"}]}`.
pub fn params_json(subjects: &[Subject], title: &str) -> serde_json::Value {
    let series: Vec<serde_json::Value> = subjects
        .iter()
        .map(|s| {
            serde_json::json!({
                "label": s.label,
                "model": s.params.model().name(),
                "params": s.params.to_json(),
            })
        })
        .collect();
    serde_json::json!({ "title": title, "series": series })
}
