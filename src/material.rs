//! Material presets (`data/materials/*.toml`), embedded in the binary: for each preset, one
//! parameter table per model. A key a preset leaves out takes the model's default.

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

pub fn names() -> Vec<&'static str> {
    MATERIALS.iter().map(|(n, _)| *n).collect()
}

/// The preset `name` for `model`, validated like any user input.
pub fn preset(name: &str, model: Model) -> Result<ParamSet, ParamError> {
    let text = MATERIALS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, t)| *t)
        .ok_or_else(|| ParamError::UnknownMaterial {
            name: name.to_string(),
            list: names().join(", "),
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
}
