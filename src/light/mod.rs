//! Environment light: the unit sphere seen from +z, lit only by a lat-long environment map, its
//! radiance toward the camera summed exactly over every texel for every pixel (docs/design.md
//! §15), beside Karis' split sum of the same scene ([`split`]). The geometry both backends share
//! (pixel frames, texel directions and solid angles) is in [`crate::backend::light`]; this job
//! reads the maps ([`maps`]), runs the sum in bands of rows on the evaluator's backend, and
//! writes the output set ([`files`]).

pub mod files;
pub mod maps;
pub mod prefilter;
pub mod report;
pub mod split;

use crate::backend::light::{sphere_pixels, EnvMap};
use crate::backend::Query;
use crate::eval::Evaluator;
use crate::input::BadInput;
use crate::model::ParamSet;
use anyhow::Result;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub use crate::backend::light::{MAX_MAP_SIDE, MAX_MAP_TEXELS};

/// The default image size (pixels per side).
pub const DEFAULT_SIZE: u32 = 256;

/// The largest image side: 4096² pixels of a 256 × 128 map is already 4 × 10^11 evaluations.
pub const MAX_SIZE: u32 = 4096;

/// Texel evaluations per band of rows handed to the backend at once: a band is one step of the
/// progress and the unit Ctrl-C waits for (about a second on lavapipe's two cores).
const EVALS_PER_BAND: u64 = 1 << 27;

/// The lit sphere: `size` × `size` pixels of linear RGB radiance, row 0 at +y, 0 outside the
/// sphere.
#[derive(Clone, Debug, PartialEq)]
pub struct LightImage {
    /// Pixels per side.
    pub size: u32,
    /// Row-major RGB radiance.
    pub pixels: Vec<[f64; 3]>,
}

impl LightImage {
    /// The pixel at (row, column).
    pub fn at(&self, row: u32, col: u32) -> [f64; 3] {
        self.pixels[(row * self.size + col) as usize]
    }
}

/// What `lobe light` computes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// The exact sum over every texel (§15.2).
    Exact,
    /// Karis' split sum (§15.3).
    SplitSum,
    /// Both, with the split sum's error against the exact sum.
    Both,
}

impl Method {
    /// Every method, as `--method` lists them.
    pub const ALL: [Method; 3] = [Method::Exact, Method::SplitSum, Method::Both];

    /// The name `--method` takes.
    pub fn name(self) -> &'static str {
        match self {
            Method::Exact => "exact",
            Method::SplitSum => "split_sum",
            Method::Both => "both",
        }
    }

    /// The method of a name, or a refusal listing them.
    pub fn from_name(name: &str) -> Result<Method, BadInput> {
        Method::ALL
            .into_iter()
            .find(|m| m.name() == name)
            .ok_or_else(|| {
                BadInput::new(
                    "method",
                    format!("method {name:?}: expected one of exact, split_sum, both"),
                )
            })
    }
}

/// Refuses an image size outside [1, [`MAX_SIZE`]].
pub fn check_image_size(size: u32) -> Result<(), BadInput> {
    if !(1..=MAX_SIZE).contains(&size) {
        return Err(BadInput::new(
            "size",
            format!("size {size}: the image is 1 to {MAX_SIZE} pixels per side"),
        ));
    }
    Ok(())
}

/// The exact sum (docs/design.md §15.2) of `params` under `map` on the evaluator's backend, in
/// bands of rows, every specular Fresnel factor replaced by 1 where `white_furnace`; `progress`
/// gets (rows done, rows). A NaN, ±Inf or negative pixel (a model's f that is not a BRDF) is
/// refused, naming the first.
pub fn exact(
    eval: &Evaluator,
    params: &ParamSet,
    white_furnace: bool,
    map: &EnvMap,
    size: u32,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<LightImage> {
    check_image_size(size)?;
    eval.supports(params.model())?;
    let texels = map.weighted_texels();
    let per_row = size as u64 * texels.terms.len() as u64;
    let band = (EVALS_PER_BAND / per_row.max(1)).clamp(1, size as u64) as u32;
    let mut pixels = vec![[0.0f64; 3]; size as usize * size as usize];
    let mut row = 0u32;
    progress(0, size as u64);
    while row < size {
        eval.check_cancelled()?;
        let end = (row + band).min(size);
        let band_pixels = sphere_pixels(size, row..end);
        let values = eval.backend().light(
            Query::one(params).with_white_furnace(white_furnace),
            &texels,
            &band_pixels,
            eval.cancel_token(),
        )?;
        for (p, v) in band_pixels.iter().zip(values) {
            if v.iter().any(|c| !c.is_finite() || *c < 0.0) {
                anyhow::bail!(
                    "model {} lit pixel (row {}, column {}) with {v:?}: f must be finite and >= 0",
                    params.model().name(),
                    p.row,
                    p.col
                );
            }
            pixels[(p.row * size + p.col) as usize] = v;
        }
        row = end;
        progress(row as u64, size as u64);
    }
    Ok(LightImage { size, pixels })
}

/// What [`write()`] made: where, on what, in how long.
#[derive(Clone, Debug, PartialEq)]
pub struct LightSummary {
    /// The files of the set ([`files::paths`]), the JSON last.
    pub paths: Vec<PathBuf>,
    /// The backend, as the evaluator names it.
    pub backend: String,
    /// Seconds the sum took (reading the map and writing the files not included).
    pub seconds: f64,
    /// Pixels that see the sphere.
    pub lit_pixels: usize,
    /// The split sum's error against the exact sum (`both` only).
    pub error: Option<split::ErrorFigures>,
}

/// The tone map of the PNG, as the JSON states it.
pub const TONE_MAP: &str =
    "each channel L * 2^exposure clipped to [0, 1], then the sRGB transfer function (IEC 61966-2-1), 8 bits";

/// The tone map of the error PNG, as the JSON states it.
pub const ERROR_TONE_MAP: &str = "the signed error's mean over R, G and B divided by its largest magnitude over the image, positive (split sum brighter) in red, negative in blue, then the sRGB transfer function, 8 bits";

/// `method`'s images of `params` under `map` (every specular Fresnel factor 1 where
/// `white_furnace`), written as `exr_path` with a PNG of each at `exposure` stops and the JSON
/// ([`files`]): the destinations are checked before any work, and the files replace what was
/// there together or not at all. `both` writes the exact sum as `exr_path`, the split sum and
/// their signed difference beside it, and the error figures in the JSON. `env` names the map in
/// the JSON and the EXR headers.
#[allow(clippy::too_many_arguments)]
pub fn write(
    eval: &Evaluator,
    params: &ParamSet,
    white_furnace: bool,
    method: Method,
    map: &EnvMap,
    env: &str,
    size: u32,
    exposure: f64,
    exr_path: &Path,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<LightSummary> {
    if !exposure.is_finite() {
        return Err(BadInput::new(
            "exposure",
            format!("exposure {exposure}: expected a finite number of stops"),
        )
        .into());
    }
    check_image_size(size)?;
    let has_split = crate::model::split_sum::split_sum_lobe(params, white_furnace).is_some();
    if method == Method::SplitSum {
        split::lobe_of(params, white_furnace)?;
    } else {
        eval.supports(params.model())?;
    }
    let set = files::create(exr_path, method, has_split)?;
    let started = Instant::now();
    let rows = size as u64;
    let passes = match method {
        Method::Both if has_split => 2,
        _ => 1,
    };
    let exact_image = match method {
        Method::SplitSum => None,
        _ => Some(exact(
            eval,
            params,
            white_furnace,
            map,
            size,
            &mut |d, _| progress(d, passes * rows),
        )?),
    };
    let base = if exact_image.is_some() { rows } else { 0 };
    let split_image = match method {
        Method::Exact => None,
        Method::Both if !has_split => None,
        _ => Some(split::split_sum(
            eval,
            params,
            white_furnace,
            map,
            size,
            &mut |d, _| progress(base + d, passes * rows),
        )?),
    };
    let seconds = started.elapsed().as_secs_f64();
    let backend = eval.name();
    let model = params.model().name().to_string();
    let error = match (&exact_image, &split_image) {
        (Some(e), Some(s)) => Some(split::error_figures(e, s)),
        _ => None,
    };
    let mut settings = json!({
        "kind": "light",
        "model": model,
        "parameters": params.to_json(),
        "white_furnace": white_furnace,
        "env": env,
        "map": { "width": map.width(), "height": map.height() },
        "size": size,
        "method": method.name(),
        "exposure": exposure,
        "tone_map": TONE_MAP,
        "view": "unit sphere seen from +z by an orthographic camera over [-1, 1]^2, row 0 at +y, column 0 at -x; 0 outside the sphere",
        "map_convention": "lat-long as Mitsuba 3's envmap: +y up, u = atan2(x, -z) / 2pi mod 1, v = acos(y) / pi; radiance constant over each texel",
        "units": "linear RGB radiance toward the camera",
        "backend": backend,
        "seconds": seconds,
    });
    if split_image.is_some() {
        settings["split_sum"] = json!({
            "prefilter": "Karis' PrefilterEnvMap with n = v = r, summed over every texel: sum L D(h) (r.l)+ dw / sum D(h) (r.l)+ dw, in f64 on the host",
            "dfg": format!("lobe's engine DFG table (lobe albedo --engine dfg) of the model's D and G, {0} x {0} cells over n.v and sqrt(alpha), read bilinearly between cell centres, edges clamped; F0 * scale + F90 * bias", split::DFG_CELLS),
            "diffuse": "rho / pi * sum L (n.l)+ dw",
        });
    }
    if method == Method::Both {
        settings["files"] = match &split_image {
            Some(_) => json!({
                "exact": files::file_name_of(exr_path, ""),
                "split_sum": files::file_name_of(exr_path, "_split_sum"),
                "error": files::file_name_of(exr_path, "_error"),
            }),
            None => json!({ "exact": files::file_name_of(exr_path, "") }),
        };
        settings["error"] = match &error {
            Some(f) => json!({
                "definition": "split sum - exact, over the pixels inside the sphere and the three channels",
                "rms": f.rms,
                "max_relative": f.max_relative,
                "max_relative_pixel": { "row": f.at.0, "column": f.at.1, "n_dot_v": f.mu },
                "error_tone_map": ERROR_TONE_MAP,
            }),
            None => json!({
                "split_sum": null,
                "reason": format!("model {}: this model has no microfacet lobe the split sum can prefilter", params.model().name()),
            }),
        };
    }
    let attributes = |m: &str, units: &str| {
        vec![
            ("lobe.kind", "light".to_string()),
            ("lobe.model", model.clone()),
            ("lobe.parameters", params.to_json().to_string()),
            ("lobe.white_furnace", white_furnace.to_string()),
            ("lobe.env", env.to_string()),
            ("lobe.method", m.to_string()),
            ("lobe.units", units.to_string()),
            ("lobe.backend", backend.clone()),
        ]
    };
    let radiance = "linear RGB radiance toward the camera; 0 outside the sphere";
    let mut images: Vec<files::Image> = Vec::new();
    if let Some(e) = &exact_image {
        images.push(files::Image::radiance(
            e.clone(),
            attributes("exact", radiance),
        ));
    }
    if let Some(s) = &split_image {
        images.push(files::Image::radiance(
            s.clone(),
            attributes("split_sum", radiance),
        ));
    }
    if let (Some(e), Some(s)) = (&exact_image, &split_image) {
        images.push(files::Image::signed(
            split::difference(e, s),
            attributes(
                "split_sum - exact",
                "split sum minus exact sum, linear RGB radiance, signed; 0 outside the sphere",
            ),
        ));
    }
    let lit_pixels = sphere_pixels(size, 0..size).len();
    let paths = files::paths(exr_path, method, has_split)?;
    files::write(set, &images, exposure, &settings)?;
    Ok(LightSummary {
        paths,
        backend,
        seconds,
        lit_pixels,
        error,
    })
}
