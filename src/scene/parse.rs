//! The scene parser: TOML text to a validated [`Scene`], one function per section of the file.
//! Every error is a [`SceneError`] located at the text it is about.

use super::{line_column, Material, Scene, SceneError, SceneLight};
use crate::material;
use crate::model::{Model, ParamSet, Value};
use crate::preview::{self, LightKind};
use glam::DVec3;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::PathBuf;
use toml::Spanned;

mod entries;
use entries::{albedo, preview, table};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    name: Option<String>,
    #[allow(dead_code)]
    description: Option<String>,
    camera: Option<Spanned<CameraFile>>,
    ambient: Option<Spanned<toml::Value>>,
    #[serde(default)]
    lights: Vec<Spanned<LightFile>>,
    #[serde(default)]
    materials: Vec<Spanned<MaterialFile>>,
    #[serde(default)]
    tables: Vec<Spanned<TableFile>>,
    #[serde(default)]
    albedos: Vec<Spanned<AlbedoFile>>,
    #[serde(default)]
    previews: Vec<Spanned<PreviewFile>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraFile {
    position: Option<Spanned<[f64; 3]>>,
    fov_y_deg: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightFile {
    position: Spanned<[f64; 3]>,
    kind: Option<Spanned<String>>,
    intensity: Option<Spanned<toml::Value>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialFile {
    name: Spanned<String>,
    model: Spanned<String>,
    preset: Option<Spanned<String>>,
    #[serde(default)]
    params: BTreeMap<String, Spanned<toml::Value>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TableFile {
    material: Spanned<String>,
    grid: Option<Spanned<String>>,
    n_theta: Option<Spanned<i64>>,
    n_phi: Option<Spanned<i64>>,
    n_dphi: Option<Spanned<i64>>,
    #[serde(default)]
    white_furnace: bool,
    output: Spanned<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AlbedoFile {
    material: Spanned<String>,
    #[serde(default)]
    white_furnace: bool,
    /// Quadrature method and nodes per view direction (default: `lobe albedo`'s).
    method: Option<Spanned<String>>,
    samples: Option<Spanned<i64>>,
    /// The Monte Carlo methods' stream (default: `lobe albedo`'s).
    seed: Option<Spanned<i64>>,
    output: Spanned<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PreviewFile {
    materials: Option<Vec<Spanned<String>>>,
    models: Option<Vec<Spanned<String>>>,
    shape: Option<Spanned<String>>,
    cell: Option<Spanned<i64>>,
    exposure: Option<Spanned<f64>>,
    output: Spanned<String>,
}

/// Builds located errors for one file.
struct Locator<'a> {
    file: &'a str,
    text: &'a str,
}

impl Locator<'_> {
    fn at(&self, span: Range<usize>, message: impl Into<String>) -> SceneError {
        let (line, column) = line_column(self.text, span.start);
        SceneError {
            file: self.file.to_string(),
            line,
            column,
            message: message.into(),
        }
    }
}

/// One number (grey) or three, as RGB.
fn rgb_of(v: &toml::Value) -> Option<DVec3> {
    let num = |x: &toml::Value| x.as_float().or_else(|| x.as_integer().map(|i| i as f64));
    match v {
        toml::Value::Array(a) if a.len() == 3 => {
            let c: Vec<f64> = a.iter().filter_map(num).collect();
            (c.len() == 3).then(|| DVec3::new(c[0], c[1], c[2]))
        }
        x => num(x).map(DVec3::splat),
    }
}

/// Parses and validates a scene. `file` names it in errors. Never panics, whatever the text.
pub fn parse(text: &str, file: &str) -> Result<Scene, SceneError> {
    let loc = Locator { file, text };
    let raw: SceneFile = toml::from_str(text).map_err(|e| {
        let span = e.span().unwrap_or(0..0);
        loc.at(span, e.message().trim().to_string())
    })?;
    let (camera_position, fov_y_deg) = camera(&loc, raw.camera.as_ref())?;
    let ambient = ambient(&loc, raw.ambient.as_ref())?;
    let lights = lights(&loc, &raw.lights, camera_position)?;
    let materials = materials(&loc, &raw.materials)?;
    let mut names = OutputNames::default();
    let tables = raw
        .tables
        .iter()
        .map(|t| table(&loc, t, &materials, &mut names))
        .collect::<Result<Vec<_>, _>>()?;
    let albedos = raw
        .albedos
        .iter()
        .map(|a| albedo(&loc, a, &materials, &mut names))
        .collect::<Result<Vec<_>, _>>()?;
    let previews = raw
        .previews
        .iter()
        .map(|p| preview(&loc, p, &materials, &lights, &mut names))
        .collect::<Result<Vec<_>, _>>()?;
    if tables.is_empty() && albedos.is_empty() && previews.is_empty() {
        return Err(loc.at(
            0..0,
            "the scene asks for no output: add [[tables]], [[albedos]] or [[previews]]",
        ));
    }
    Ok(Scene {
        file: file.to_string(),
        name: raw.name.unwrap_or_else(|| "scene".to_string()),
        camera_position,
        fov_y_deg,
        ambient,
        lights,
        materials,
        tables,
        albedos,
        previews,
    })
}

/// `[camera]`: (position, vertical field of view in degrees).
fn camera(loc: &Locator, cam: Option<&Spanned<CameraFile>>) -> Result<(DVec3, f64), SceneError> {
    let (mut position, mut fov_y_deg) = (DVec3::ZERO, preview::FOV_Y_DEG);
    let Some(cam) = cam else {
        return Ok((position, fov_y_deg));
    };
    if let Some(p) = &cam.get_ref().position {
        position = DVec3::from_array(*p.get_ref());
        if !position.is_finite() {
            return Err(loc.at(p.span(), "camera position must be finite"));
        }
    }
    if let Some(f) = &cam.get_ref().fov_y_deg {
        fov_y_deg = *f.get_ref();
        if !(fov_y_deg > 0.0 && fov_y_deg < 180.0) {
            return Err(loc.at(
                f.span(),
                format!("fov_y_deg = {fov_y_deg}: expected a field of view in (0, 180) degrees"),
            ));
        }
    }
    Ok((position, fov_y_deg))
}

/// `ambient`: the radiance of a uniform sky, grey or RGB.
fn ambient(loc: &Locator, a: Option<&Spanned<toml::Value>>) -> Result<DVec3, SceneError> {
    let Some(a) = a else {
        return Ok(DVec3::ZERO);
    };
    match rgb_of(a.get_ref()) {
        Some(v) if v.is_finite() && v.min_element() >= 0.0 => Ok(v),
        _ => Err(loc.at(
            a.span(),
            "ambient: expected a radiance >= 0, one number or [r, g, b]",
        )),
    }
}

/// `[[lights]]`, point lights moved into the camera's frame (the preview's camera sits at the
/// origin).
fn lights(
    loc: &Locator,
    raw: &[Spanned<LightFile>],
    camera_position: DVec3,
) -> Result<Vec<SceneLight>, SceneError> {
    let mut lights = Vec::new();
    for l in raw {
        let lf = l.get_ref();
        let position = DVec3::from_array(*lf.position.get_ref());
        if !position.is_finite() {
            return Err(loc.at(lf.position.span(), "light position must be finite"));
        }
        let kind = match lf.kind.as_ref().map(|k| (k.get_ref().as_str(), k.span())) {
            None | Some(("point", _)) => LightKind::Point,
            Some(("directional", _)) => LightKind::Directional,
            Some((other, span)) => {
                return Err(loc.at(
                    span,
                    format!("unknown light kind '{other}'; the kinds are: point, directional"),
                ))
            }
        };
        if kind == LightKind::Directional && position == DVec3::ZERO {
            return Err(loc.at(
                lf.position.span(),
                "a directional light needs a non-zero direction",
            ));
        }
        let intensity = match &lf.intensity {
            None => None,
            Some(i) => match rgb_of(i.get_ref()) {
                Some(v) if v.is_finite() && v.min_element() >= 0.0 => Some(v),
                _ => {
                    return Err(loc.at(
                        i.span(),
                        "light intensity: expected a number >= 0 or [r, g, b]",
                    ))
                }
            },
        };
        lights.push(SceneLight {
            position: position
                - if kind == LightKind::Point {
                    camera_position
                } else {
                    DVec3::ZERO
                },
            kind,
            intensity,
        });
    }
    let explicit = lights.iter().filter(|l| l.intensity.is_some()).count();
    if explicit != 0 && explicit != lights.len() {
        let l = &raw[lights
            .iter()
            .position(|l| l.intensity.is_none())
            .unwrap_or(0)];
        return Err(loc.at(
            l.span(),
            "give every light an intensity, or none (then all are equal and normalised)",
        ));
    }
    Ok(lights)
}

/// `[[materials]]`, in file order; names are unique.
fn materials(loc: &Locator, raw: &[Spanned<MaterialFile>]) -> Result<Vec<Material>, SceneError> {
    let mut materials: Vec<Material> = Vec::new();
    for m in raw {
        let mf = m.get_ref();
        let name = mf.name.get_ref().clone();
        if name.trim().is_empty() {
            return Err(loc.at(mf.name.span(), "a material needs a non-empty name"));
        }
        if materials.iter().any(|x| x.name == name) {
            return Err(loc.at(
                mf.name.span(),
                format!("material '{name}' is defined twice"),
            ));
        }
        let model = model_named(loc, &mf.model)?;
        let mut params = match &mf.preset {
            Some(p) => {
                material::preset(p.get_ref(), model).map_err(|e| loc.at(p.span(), e.to_string()))?
            }
            None => ParamSet::defaults(model),
        };
        for (key, v) in &mf.params {
            set_param(loc, &mut params, key, v)?;
        }
        materials.push(Material {
            name,
            params,
            preset: mf.preset.as_ref().map(|p| p.get_ref().clone()),
        });
    }
    Ok(materials)
}

/// A model by name, or a file loaded as one, its path relative to the scene file's folder: a
/// `.brdf` file ([`crate::brdf::load`], with its default time limit) or a MERL file
/// (`PATH.binary`, [`crate::merl::model::load`]).
fn model_named(loc: &Locator, name: &Spanned<String>) -> Result<Model, SceneError> {
    let options = crate::resolve::SpecOptions {
        base: std::path::Path::new(loc.file).parent().map(Into::into),
        ..Default::default()
    };
    crate::resolve::load_model(name.get_ref(), &options, &mut |_| {})
        .map_err(|e| loc.at(name.span(), format!("{e:#}")))
}

/// One entry of a material's `params`: a number, [r, g, b], or a name (a choice such as a
/// distribution), checked by the model's own parameter table.
fn set_param(
    loc: &Locator,
    params: &mut ParamSet,
    key: &str,
    v: &Spanned<toml::Value>,
) -> Result<(), SceneError> {
    let value = match v.get_ref() {
        toml::Value::String(s) => {
            return params
                .set_text(&format!("{key}={s}"))
                .map_err(|e| loc.at(v.span(), e.to_string()));
        }
        toml::Value::Float(x) => Value::One(*x),
        toml::Value::Integer(i) => Value::One(*i as f64),
        toml::Value::Array(a) if a.len() == 3 => match rgb_of(v.get_ref()) {
            Some(c) => Value::Three(c.to_array()),
            None => {
                return Err(loc.at(
                    v.span(),
                    format!("parameter '{key}': expected three numbers [r, g, b]"),
                ))
            }
        },
        other => {
            return Err(loc.at(
                v.span(),
                format!(
                    "parameter '{key}': expected a number, [r, g, b] or a name, not {}",
                    other.type_str()
                ),
            ))
        }
    };
    params
        .set(key, value)
        .map_err(|e| loc.at(v.span(), e.to_string()))
}

/// The index of the material `s` names.
fn find_material(
    loc: &Locator,
    materials: &[Material],
    s: &Spanned<String>,
) -> Result<usize, SceneError> {
    materials
        .iter()
        .position(|m| m.name == *s.get_ref())
        .ok_or_else(|| {
            let names: Vec<&str> = materials.iter().map(|m| m.name.as_str()).collect();
            loc.at(
                s.span(),
                format!(
                    "unknown material '{}'; the scene's materials are: {}",
                    s.get_ref(),
                    if names.is_empty() {
                        "(none: add a [[materials]] section)".to_string()
                    } else {
                        names.join(", ")
                    }
                ),
            )
        })
}

/// `text` as a path inside the output folder, without `.` parts; why not, when it is absolute or
/// climbs out with `..` (a shared scene must not write anywhere else the user can write).
fn inside_output_folder(text: &str) -> Result<PathBuf, &'static str> {
    use std::path::Component;
    let mut p = PathBuf::new();
    for c in std::path::Path::new(text).components() {
        match c {
            Component::Normal(n) => p.push(n),
            Component::CurDir => {}
            Component::ParentDir => {
                return Err("has a '..' part: outputs stay inside the output folder, so write the path from there down");
            }
            Component::RootDir | Component::Prefix(_) => {
                return Err("is an absolute path: outputs are relative to the output folder");
            }
        }
    }
    if p.as_os_str().is_empty() {
        return Err("names no file");
    }
    Ok(p)
}

/// The output paths claimed so far, by name without extension: a table writes .npy and .json
/// beside its .exr, a preview its .exr beside the .png, so two outputs may not share a stem.
#[derive(Default)]
struct OutputNames {
    taken: Vec<(PathBuf, Range<usize>)>,
}

impl OutputNames {
    /// Checks the output `s` of a `what` (ending in `.ext`) and claims its name.
    fn claim(
        &mut self,
        loc: &Locator,
        s: &Spanned<String>,
        ext: &str,
        what: &str,
    ) -> Result<PathBuf, SceneError> {
        if s.get_ref().trim().is_empty() {
            return Err(loc.at(s.span(), format!("{what} output: empty path")));
        }
        let p = inside_output_folder(s.get_ref())
            .map_err(|why| loc.at(s.span(), format!("{what} output '{}' {why}", s.get_ref())))?;
        if p.extension().and_then(|e| e.to_str()) != Some(ext) {
            return Err(loc.at(
                s.span(),
                format!("{what} output '{}' must end in .{ext}", s.get_ref()),
            ));
        }
        let stem = p.with_extension("");
        if let Some((_, first)) = self.taken.iter().find(|(q, _)| *q == stem) {
            let (line, _) = line_column(loc.text, first.start);
            return Err(loc.at(
                s.span(),
                format!(
                    "output '{}' clashes with the output on line {line} (same name before the extension)",
                    s.get_ref()
                ),
            ));
        }
        self.taken.push((stem, s.span()));
        Ok(p)
    }
}

/// A resolution key, when given: at least 1.
fn count(loc: &Locator, v: &Option<Spanned<i64>>, key: &str) -> Result<Option<usize>, SceneError> {
    let Some(v) = v else {
        return Ok(None);
    };
    let n = *v.get_ref();
    if n < 1 {
        return Err(loc.at(v.span(), format!("{key} = {n}: expected at least 1")));
    }
    usize::try_from(n)
        .map(Some)
        .map_err(|_| loc.at(v.span(), format!("{key} = {n} is too large")))
}

/// An angle in degrees with at most three decimals, for the log.
fn degrees(x: f64) -> String {
    let s = format!("{x:.3}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}
