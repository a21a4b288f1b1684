//! Material presets (`data/materials/*.toml`), embedded in the binary: for each preset, one
//! parameter table per model. A key a preset leaves out takes the model's default.
//!
//! The lab's four materials have a table for every model; the metals (`silver`, `copper`,
//! `aluminium`) only for `microfacet`, whose exact conductor Fresnel term they exist for. A
//! table's `conductor = "NAME"` sets `eta` and `k` from `data/conductors.toml`.

use crate::model::{Model, ParamError, ParamSet, Value};

/// (name, TOML text) of every built-in material.
pub const MATERIALS: &[(&str, &str)] = &[
    ("tin", include_str!("../data/materials/tin.toml")),
    ("gold", include_str!("../data/materials/gold.toml")),
    (
        "glazed_ceramic",
        include_str!("../data/materials/glazed_ceramic.toml"),
    ),
    ("granite", include_str!("../data/materials/granite.toml")),
];

/// (name, TOML text) of the conductor presets, defined for `microfacet` only.
pub const METALS: &[(&str, &str)] = &[
    ("silver", include_str!("../data/materials/silver.toml")),
    ("copper", include_str!("../data/materials/copper.toml")),
    (
        "aluminium",
        include_str!("../data/materials/aluminium.toml"),
    ),
];

/// Measured complex refractive indices at lobe's RGB wavelengths, with their sources.
pub const CONDUCTORS: &str = include_str!("../data/conductors.toml");

/// The lab's materials, which have a preset for every model (what contact sheets and the demo
/// show).
pub fn names() -> Vec<&'static str> {
    MATERIALS.iter().map(|(n, _)| *n).collect()
}

/// Every preset `--material` accepts: the lab's materials, then the metals.
pub fn all_names() -> Vec<&'static str> {
    MATERIALS.iter().chain(METALS).map(|(n, _)| *n).collect()
}

/// η and κ (RGB at 650, 550, 450 nm) of a metal in `data/conductors.toml`.
pub fn conductor(name: &str) -> Option<([f64; 3], [f64; 3])> {
    let table: toml::Table = CONDUCTORS.parse().ok()?;
    let metal = table.get(name)?.as_table()?;
    let rgb = |key: &str| -> Option<[f64; 3]> {
        let a = metal.get(key)?.as_array()?;
        let c: Vec<f64> = a.iter().filter_map(toml::Value::as_float).collect();
        (c.len() == 3).then(|| [c[0], c[1], c[2]])
    };
    Some((rgb("eta")?, rgb("k")?))
}

/// The metals `data/conductors.toml` lists.
pub fn conductor_names() -> Vec<String> {
    let table: toml::Table = CONDUCTORS.parse().unwrap_or_default();
    table
        .iter()
        .filter(|(_, v)| v.is_table())
        .map(|(k, _)| k.clone())
        .collect()
}

/// The preset `name` for `model`, validated like any user input.
pub fn preset(name: &str, model: Model) -> Result<ParamSet, ParamError> {
    let text = MATERIALS
        .iter()
        .chain(METALS)
        .find(|(n, _)| *n == name)
        .map(|(_, t)| *t)
        .ok_or_else(|| ParamError::UnknownMaterial {
            name: name.to_string(),
            list: all_names().join(", "),
        })?;
    from_toml(text, model).map_err(|e| match e {
        // A preset that does not validate is a bug in data/, not user error; say where it is.
        ParamError::OutOfRange { key, value, range } => ParamError::OutOfRange {
            key: format!("{key} (material {name})"),
            value,
            range,
        },
        other => other,
    })
}

/// The preset's linear RGB colour (from the lab report where it gives one).
pub fn colour(name: &str) -> Option<[f64; 3]> {
    let (_, text) = MATERIALS.iter().find(|(n, _)| *n == name)?;
    let table: toml::Table = text.parse().ok()?;
    let arr = table.get("colour")?.as_array()?;
    let c: Vec<f64> = arr.iter().filter_map(toml::Value::as_float).collect();
    (c.len() == 3).then(|| [c[0], c[1], c[2]])
}

/// Where the preset's colour comes from (its `colour_source`): the lab report's value, or lobe's
/// choice where the report gives none.
pub fn colour_source(name: &str) -> Option<String> {
    let (_, text) = MATERIALS.iter().find(|(n, _)| *n == name)?;
    let table: toml::Table = text.parse().ok()?;
    Some(table.get("colour_source")?.as_str()?.to_string())
}

fn from_toml(text: &str, model: Model) -> Result<ParamSet, ParamError> {
    let table: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| ParamError::Malformed {
            key: "material".into(),
            text: e.to_string(),
            expected: "a TOML table".into(),
        })?;
    let mut set = ParamSet::defaults(model);
    let Some(section) = table.get(model.name()).and_then(toml::Value::as_table) else {
        let name = table
            .get("name")
            .and_then(toml::Value::as_str)
            .unwrap_or("?")
            .to_string();
        let defined: Vec<&str> = Model::ALL
            .iter()
            .map(|m| m.name())
            .filter(|m| table.get(*m).is_some_and(toml::Value::is_table))
            .collect();
        return Err(ParamError::NoPreset {
            material: name,
            model: model.name().into(),
            list: defined.join(", "),
        });
    };
    for (key, v) in section {
        if key == "conductor" {
            let metal = v.as_str().unwrap_or_default();
            let (eta, k) = conductor(metal).ok_or_else(|| ParamError::Malformed {
                key: key.clone(),
                text: v.to_string(),
                expected: format!(
                    "a metal of data/conductors.toml: {}",
                    conductor_names().join(", ")
                ),
            })?;
            set.set("eta", Value::Three(eta))?;
            set.set("k", Value::Three(k))?;
            continue;
        }
        let value = match v {
            toml::Value::String(text) => {
                set.set_text(&format!("{key}={text}"))?;
                continue;
            }
            toml::Value::Float(x) => Value::One(*x),
            toml::Value::Integer(i) => Value::One(*i as f64),
            toml::Value::Array(a) if a.len() == 3 => {
                let c: Vec<f64> = a
                    .iter()
                    .filter_map(|x| x.as_float().or(x.as_integer().map(|i| i as f64)))
                    .collect();
                if c.len() != 3 {
                    return Err(ParamError::Malformed {
                        key: key.clone(),
                        text: v.to_string(),
                        expected: "rgb".into(),
                    });
                }
                Value::Three([c[0], c[1], c[2]])
            }
            _ => {
                return Err(ParamError::Malformed {
                    key: key.clone(),
                    text: v.to_string(),
                    expected: "a number or rgb".into(),
                })
            }
        };
        set.set(key, value)?;
    }
    Ok(set)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_preset_validates_for_every_model() {
        for (name, _) in MATERIALS {
            for model in Model::ALL {
                preset(name, model).unwrap_or_else(|e| panic!("{name}/{}: {e}", model.name()));
            }
        }
    }

    #[test]
    fn metals_are_microfacet_conductors_and_nothing_else() {
        for (name, _) in METALS {
            let p = preset(name, Model::from_name("microfacet").unwrap())
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            let (eta, k) = conductor(name).expect("listed in data/conductors.toml");
            assert_eq!(p.rgb("eta").to_array(), eta, "{name}");
            assert_eq!(p.rgb("k").to_array(), k, "{name}");
            let err = preset(name, Model::Lambert).unwrap_err().to_string();
            assert!(err.contains("microfacet"), "{name}: {err}");
        }
    }

    /// Each tabulated η, κ is the linear interpolation, at its wavelength, of the two measured
    /// rows kept beside it (see data/conductors.toml for the sources); and F0 matches.
    #[test]
    fn conductor_values_follow_from_their_source_rows() {
        // The values are written with 4 decimals.
        const ROUNDING: f64 = 5e-5 + 1e-12;
        let table: toml::Table = CONDUCTORS.parse().unwrap();
        let wl: Vec<f64> = table["wavelengths_nm"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_float().unwrap())
            .collect();
        let names = conductor_names();
        assert_eq!(names.len(), 4, "{names:?}");
        for name in names {
            let metal = table[&name].as_table().unwrap();
            let (eta, k) = conductor(&name).unwrap();
            let rows: Vec<Vec<f64>> = metal["rows"]
                .as_array()
                .unwrap()
                .iter()
                .map(|r| {
                    r.as_array()
                        .unwrap()
                        .iter()
                        .map(|v| v.as_float().unwrap())
                        .collect()
                })
                .collect();
            let f0: Vec<f64> = metal["f0"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_float().unwrap())
                .collect();
            for c in 0..3 {
                let (a, b) = (&rows[2 * c], &rows[2 * c + 1]);
                assert!(
                    a[0] <= wl[c] && wl[c] <= b[0],
                    "{name}: rows bracket {} nm",
                    wl[c]
                );
                let t = (wl[c] - a[0]) / (b[0] - a[0]);
                let n = a[1] + t * (b[1] - a[1]);
                let kk = a[2] + t * (b[2] - a[2]);
                assert!(
                    (n - eta[c]).abs() < ROUNDING,
                    "{name} eta[{c}]: {n} vs {}",
                    eta[c]
                );
                assert!(
                    (kk - k[c]).abs() < ROUNDING,
                    "{name} k[{c}]: {kk} vs {}",
                    k[c]
                );
                let r0 = ((n - 1.0).powi(2) + kk * kk) / ((n + 1.0).powi(2) + kk * kk);
                assert!(
                    (r0 - f0[c]).abs() < ROUNDING,
                    "{name} f0[{c}]: {r0} vs {}",
                    f0[c]
                );
            }
        }
    }
}
