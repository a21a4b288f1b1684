//! Material presets (`data/materials/*.toml`), embedded in the binary: for each preset, one
//! parameter table per model. A key a preset leaves out takes the model's default.
//!
//! Three families:
//! - the lab's four materials, with the lab report's colours where it gives them, have a table for
//!   every model;
//! - the metals (`silver`, `copper`, `aluminium`, `gold_measured`) have their measured colour: F0
//!   from the complex refractive index in `data/conductors.toml`, as the specular colour of the
//!   models that have one, and the exact conductor Fresnel term in `microfacet`;
//! - the diffuse references (`colorchecker_*`) have a ColorChecker patch's published sRGB value,
//!   decoded to linear, as the albedo of the diffuse models.
//!
//! A table's `conductor = "NAME"` sets `eta` and `k` from `data/conductors.toml`. Each file cites
//! its source.

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

/// (name, TOML text) of the metals: measured F0 as the specular colour (`phong`, `blinn_phong`,
/// `ashikhmin_shirley`) and the exact conductor Fresnel term (`microfacet`).
pub const METALS: &[(&str, &str)] = &[
    ("silver", include_str!("../data/materials/silver.toml")),
    ("copper", include_str!("../data/materials/copper.toml")),
    (
        "aluminium",
        include_str!("../data/materials/aluminium.toml"),
    ),
    (
        "gold_measured",
        include_str!("../data/materials/gold_measured.toml"),
    ),
];

/// (name, TOML text) of the diffuse references: ColorChecker patches as the albedo of the diffuse
/// models (`lambert`, `oren_nayar`, `eon`).
pub const DIFFUSE: &[(&str, &str)] = &[
    (
        "colorchecker_dark_skin",
        include_str!("../data/materials/colorchecker_dark_skin.toml"),
    ),
    (
        "colorchecker_light_skin",
        include_str!("../data/materials/colorchecker_light_skin.toml"),
    ),
    (
        "colorchecker_foliage",
        include_str!("../data/materials/colorchecker_foliage.toml"),
    ),
    (
        "colorchecker_neutral_5",
        include_str!("../data/materials/colorchecker_neutral_5.toml"),
    ),
    (
        "colorchecker_white",
        include_str!("../data/materials/colorchecker_white.toml"),
    ),
];

/// Every preset: the lab's materials, the metals, the diffuse references.
fn every_preset() -> impl Iterator<Item = &'static (&'static str, &'static str)> {
    MATERIALS.iter().chain(METALS).chain(DIFFUSE)
}

/// Measured complex refractive indices at lobe's RGB wavelengths, with their sources.
pub const CONDUCTORS: &str = include_str!("../data/conductors.toml");

/// The lab's materials, which have a preset for every model (what contact sheets and the demo
/// show).
pub fn names() -> Vec<&'static str> {
    MATERIALS.iter().map(|(n, _)| *n).collect()
}

/// Every preset `--material` accepts: the lab's materials, the metals, the diffuse references.
pub fn all_names() -> Vec<&'static str> {
    every_preset().map(|(n, _)| *n).collect()
}

/// The names of the presets in `list` ([`METALS`], [`DIFFUSE`]).
pub fn names_of(list: &[(&'static str, &str)]) -> Vec<&'static str> {
    list.iter().map(|(n, _)| *n).collect()
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
    let text = every_preset()
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

/// The preset's linear RGB colour (the lab report's where it gives one, else the measured one
/// the file cites, or lobe's choice).
pub fn colour(name: &str) -> Option<[f64; 3]> {
    let (_, text) = every_preset().find(|(n, _)| *n == name)?;
    let table: toml::Table = text.parse().ok()?;
    let arr = table.get("colour")?.as_array()?;
    let c: Vec<f64> = arr.iter().filter_map(toml::Value::as_float).collect();
    (c.len() == 3).then(|| [c[0], c[1], c[2]])
}

/// Where the preset's colour comes from (its `colour_source`): the lab report's value, lobe's
/// choice where the report gives none, or the measurement a metal or diffuse reference cites.
pub fn colour_source(name: &str) -> Option<String> {
    let (_, text) = every_preset().find(|(n, _)| *n == name)?;
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

    /// A metal is its conductor's η, κ in `microfacet` and has no diffuse model.
    #[test]
    fn metals_are_microfacet_conductors_without_a_diffuse_model() {
        for (name, text) in METALS {
            let p = preset(name, Model::from_name("microfacet").unwrap())
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            let table: toml::Table = text.parse().unwrap();
            let metal = table["conductor"]
                .as_str()
                .expect("a metal names its conductor");
            let (eta, k) = conductor(metal).expect("listed in data/conductors.toml");
            assert_eq!(p.rgb("eta").to_array(), eta, "{name}");
            assert_eq!(p.rgb("k").to_array(), k, "{name}");
            let err = preset(name, Model::Lambert).unwrap_err().to_string();
            assert!(err.contains("microfacet"), "{name}: {err}");
        }
    }

    /// The models a preset's file has a table for.
    fn models_of(text: &str) -> Vec<Model> {
        let table: toml::Table = text.parse().unwrap();
        Model::ALL
            .into_iter()
            .filter(|m| table.get(m.name()).is_some_and(toml::Value::is_table))
            .collect()
    }

    /// Every colour a preset sets (its `colour` and each rgb reflectance of each model's table;
    /// not a conductor's η and κ, which are refractive indices) lies in [0, 1].
    #[test]
    fn every_preset_colour_is_a_reflectance() {
        for (name, text) in every_preset() {
            let models = models_of(text);
            assert!(!models.is_empty(), "{name} defines no model");
            if let Some(c) = colour(name) {
                assert!(
                    c.iter().all(|x| (0.0..=1.0).contains(x)),
                    "{name} colour {c:?}"
                );
            }
            for model in models {
                let set = preset(name, model).unwrap_or_else(|e| panic!("{name}/{model:?}: {e}"));
                for (key, value) in set.entries() {
                    if let (false, Value::Three(c)) = (key == "eta" || key == "k", value) {
                        assert!(
                            c.iter().all(|x| (0.0..=1.0).contains(x)),
                            "{name}/{}: {key} = {c:?}",
                            model.name()
                        );
                    }
                }
            }
        }
    }

    /// A metal's colour and specular colours are F0 = ((n - 1)² + k²) / ((n + 1)² + k²) of the
    /// η, κ its file cites (data/conductors.toml), per channel.
    #[test]
    fn metal_colours_are_the_fresnel_f0_of_their_refractive_index() {
        // η and κ are written with 4 decimals; F0 moves by less than 0.5 per unit of either
        // (|∂F0/∂n|, |∂F0/∂k| < 0.5 for these metals), and F0 itself is written with 4 decimals.
        const ROUNDING: f64 = 0.5 * 5e-5 * 2.0 + 5e-5 + 1e-12;
        for (name, text) in METALS {
            let table: toml::Table = text.parse().unwrap();
            let metal = table["conductor"]
                .as_str()
                .expect("a metal names its conductor");
            let (eta, k) = conductor(metal).unwrap_or_else(|| panic!("{name}: no {metal}"));
            let f0: Vec<f64> = (0..3)
                .map(|c| {
                    ((eta[c] - 1.0).powi(2) + k[c] * k[c]) / ((eta[c] + 1.0).powi(2) + k[c] * k[c])
                })
                .collect();
            let mut colours = vec![("colour".to_string(), colour(name).expect("a colour"))];
            for model in models_of(text) {
                let set = preset(name, model).unwrap();
                if model.name() == "microfacet" {
                    assert_eq!(set.rgb("eta").to_array(), eta, "{name}");
                    assert_eq!(set.rgb("k").to_array(), k, "{name}");
                } else {
                    colours.push((
                        format!("{}.specular", model.name()),
                        set.rgb("specular").to_array(),
                    ));
                }
            }
            assert!(colours.len() >= 4, "{name}: {colours:?}");
            for (what, c) in colours {
                for ch in 0..3 {
                    assert!(
                        (c[ch] - f0[ch]).abs() < ROUNDING,
                        "{name} {what}[{ch}] = {} but F0 of n = {}, k = {} is {}",
                        c[ch],
                        eta[ch],
                        k[ch],
                        f0[ch]
                    );
                }
            }
        }
    }

    /// A diffuse reference's albedo is its published 8-bit sRGB value decoded to linear
    /// (IEC 61966-2-1: c/12.92 up to 0.04045, else ((c + 0.055)/1.055)^2.4), in every model.
    #[test]
    fn diffuse_albedos_are_their_published_srgb_decoded() {
        // The albedos are written with 4 decimals.
        const ROUNDING: f64 = 5e-5 + 1e-12;
        let decode = |v: f64| {
            let c = v / 255.0;
            if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            }
        };
        for (name, text) in DIFFUSE {
            let table: toml::Table = text.parse().unwrap();
            let srgb: Vec<f64> = table["srgb8"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_integer().unwrap() as f64)
                .collect();
            let linear: Vec<f64> = srgb.iter().map(|&v| decode(v)).collect();
            let mut colours = vec![colour(name).expect("a colour")];
            for model in models_of(text) {
                colours.push(preset(name, model).unwrap().rgb("albedo").to_array());
            }
            for c in colours {
                for ch in 0..3 {
                    assert!(
                        (c[ch] - linear[ch]).abs() < ROUNDING,
                        "{name}[{ch}]: {} but sRGB {} decodes to {}",
                        c[ch],
                        srgb[ch],
                        linear[ch]
                    );
                }
            }
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
