//! The prefiltered map as an engine loads it (`lobe light --prefilter-out DIR`, docs/design.md
//! §15.5): a mip chain, one level per roughness as Karis 2013 and Filament's cmgen lay it out,
//! level k of L at perceptual roughness r_k = k/(L − 1) (α = r_k²) and half the size of the level
//! above, each level written as a lat-long EXR and as six cube faces, with a JSON naming the
//! layout, the roughness per level, the face order and orientation and the DFG table that goes
//! with it. Each texel is the split sum's prefiltered radiance ([`super::split`], n = v = r, summed
//! over every texel of the full map) about the texel centre's direction; level 0 (α = 0, a mirror)
//! is the map itself, its cube faces the map's texel that holds each face texel's centre.

use super::split::Texels;
use crate::backend::light::{texel_direction, EnvMap};
use crate::eval::Evaluator;
use crate::input::BadInput;
use crate::lut::engine::{stage_engine, EngineKind, EngineSpec};
use crate::model::split_sum::{split_sum_lobe, SpecularLobe};
use crate::model::ParamSet;
use crate::output::FileSet;
use anyhow::Result;
use glam::DVec3;
use rayon::prelude::*;
use serde_json::json;
use std::f64::consts::PI;
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// The most levels a chain may have.
pub const MAX_LEVELS: u32 = 16;

/// The cube faces in file order, OpenGL's and KTX's: +x, −x, +y, −y, +z, −z.
pub const FACES: [&str; 6] = ["px", "nx", "py", "ny", "pz", "nz"];

/// How a face texel's (s, t) maps to a direction, as the JSON and the docs state it.
pub const CUBE_CONVENTION: &str = "OpenGL / KTX cube map: faces in the order +x, -x, +y, -y, +z, -z; on each face, column j and row i (row 0 first in the file) give sc = 2 (j + 1/2) / N - 1 and tc = 2 (i + 1/2) / N - 1, and the direction is +x: (1, -tc, -sc), -x: (-1, -tc, sc), +y: (sc, 1, tc), -y: (sc, -1, -tc), +z: (sc, -tc, 1), -z: (-sc, -tc, -1) (OpenGL 4.6 table 8.19), in the map's world frame (+y up, u = atan2(x, -z) / 2pi)";

/// The direction (not normalised) of face `face` ([`FACES`] order) at (sc, tc) ∈ [−1, 1]²,
/// OpenGL's table of cube-map faces.
pub fn cube_direction(face: usize, sc: f64, tc: f64) -> DVec3 {
    match face {
        0 => DVec3::new(1.0, -tc, -sc),
        1 => DVec3::new(-1.0, -tc, sc),
        2 => DVec3::new(sc, 1.0, tc),
        3 => DVec3::new(sc, -1.0, -tc),
        4 => DVec3::new(sc, -tc, 1.0),
        _ => DVec3::new(-sc, -tc, -1.0),
    }
}

/// The normalised direction of texel (row `i`, column `j`) of an `n` × `n` face.
pub fn face_texel_direction(face: usize, n: u32, i: u32, j: u32) -> DVec3 {
    let sc = 2.0 * (j as f64 + 0.5) / n as f64 - 1.0;
    let tc = 2.0 * (i as f64 + 0.5) / n as f64 - 1.0;
    cube_direction(face, sc, tc).normalize()
}

/// The (row, column) of the map's texel that holds direction `d` (Mitsuba's lat-long layout).
pub fn texel_of(map: &EnvMap, d: DVec3) -> (u32, u32) {
    let d = d.normalize();
    let (w, h) = (map.width(), map.height());
    let u = (d.x.atan2(-d.z) / (2.0 * PI)).rem_euclid(1.0);
    let v = d.y.clamp(-1.0, 1.0).acos() / PI;
    let col = ((u * w as f64) as u32).min(w - 1);
    let row = ((v * h as f64) as u32).min(h - 1);
    (row, col)
}

/// The default number of levels for a `w` × `h` map: down to a level whose shorter side is 8
/// texels or more (log2(min(w, h)) − 2), at least 2 and at most [`MAX_LEVELS`].
pub fn default_levels(w: u32, h: u32) -> u32 {
    let short = w.min(h).max(1);
    (31 - short.leading_zeros())
        .saturating_sub(2)
        .clamp(2, MAX_LEVELS)
}

/// Refuses a number of levels outside [2, [`MAX_LEVELS`]].
pub fn check_levels(levels: u32) -> Result<(), BadInput> {
    if !(2..=MAX_LEVELS).contains(&levels) {
        return Err(BadInput::new(
            "prefilter-levels",
            format!("{levels} levels: a prefiltered chain has 2 to {MAX_LEVELS} (level 0 is the map, the last roughness 1)"),
        ));
    }
    Ok(())
}

/// One level of the chain.
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    /// The perceptual roughness r = k/(L − 1).
    pub roughness: f64,
    /// α = r².
    pub alpha: f64,
    /// The lat-long level's width and height.
    pub width: u32,
    /// See `width`.
    pub height: u32,
    /// Row-major RGB, row 0 at +y.
    pub latlong: Vec<[f64; 3]>,
    /// The cube faces' side.
    pub face_size: u32,
    /// The six faces in [`FACES`] order, each row-major RGB.
    pub faces: Vec<Vec<[f64; 3]>>,
}

/// The microfacet lobe the chain prefilters with: the model's own distribution (GGX or
/// Beckmann), or a refusal naming the model.
pub fn chain_lobe(params: &ParamSet) -> Result<SpecularLobe, BadInput> {
    split_sum_lobe(params, true)
        .and_then(|l| l.specular)
        .ok_or_else(|| {
            BadInput::new(
                "prefilter-out",
                format!(
                    "model {}: the prefiltered chain takes the D of a microfacet lobe, and this model has none; the models with one are microfacet and cook_torrance",
                    params.model().name()
                ),
            )
        })
}

/// The prefiltered radiance about the unit vector `r` by `lobe` (n = v = r) over every texel
/// of `map`: the split sum's prefilter at one direction, as [`chain`] takes it per texel.
pub fn prefiltered_at(map: &EnvMap, lobe: &SpecularLobe, r: DVec3) -> [f64; 3] {
    Texels::new(map).prefiltered(r, lobe).to_array()
}

/// The chain of `levels` levels of `map` prefiltered by `lobe`'s distribution, level 0 of the
/// map's size with cube faces of side height/2 (at least 1); `progress` gets (levels done,
/// levels). Cancellation is checked between levels through `cancelled`.
pub fn chain(
    map: &EnvMap,
    lobe: &SpecularLobe,
    levels: u32,
    cancelled: &dyn Fn() -> Result<()>,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<Vec<Level>> {
    check_levels(levels)?;
    let texels = Texels::new(map);
    let (w, h) = (map.width(), map.height());
    let face0 = (h / 2).max(1);
    let mut out = Vec::new();
    progress(0, levels as u64);
    for k in 0..levels {
        cancelled()?;
        let roughness = k as f64 / (levels - 1) as f64;
        let alpha = roughness * roughness;
        let (lw, lh) = ((w >> k).max(1), (h >> k).max(1));
        let face_size = (face0 >> k).max(1);
        let mut level_lobe = lobe.clone();
        level_lobe.alpha = alpha;
        let value = |d: DVec3| -> [f64; 3] {
            if k == 0 {
                let (row, col) = texel_of(map, d);
                map.texel(row, col).map(|c| c as f64)
            } else {
                texels.prefiltered(d, &level_lobe).to_array()
            }
        };
        let latlong: Vec<[f64; 3]> = if k == 0 {
            map.texels().iter().map(|t| t.map(|c| c as f64)).collect()
        } else {
            (0..lh * lw)
                .into_par_iter()
                .map(|n| value(texel_direction(lw, lh, n / lw, n % lw)))
                .collect()
        };
        let faces = (0..6)
            .map(|f| {
                (0..face_size * face_size)
                    .into_par_iter()
                    .map(|n| {
                        value(face_texel_direction(
                            f,
                            face_size,
                            n / face_size,
                            n % face_size,
                        ))
                    })
                    .collect()
            })
            .collect();
        out.push(Level {
            roughness,
            alpha,
            width: lw,
            height: lh,
            latlong,
            face_size,
            faces,
        });
        progress(k as u64 + 1, levels as u64);
    }
    Ok(out)
}

/// The chain's file names in `dir`: per level `latlong_L{k}.exr` then `cube_L{k}_{face}.exr` for
/// each of [`FACES`], and `prefilter.json` last.
pub fn paths(dir: &Path, levels: u32) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for k in 0..levels {
        out.push(dir.join(format!("latlong_L{k}.exr")));
        for f in FACES {
            out.push(dir.join(format!("cube_L{k}_{f}.exr")));
        }
    }
    out.push(dir.join("prefilter.json"));
    out
}

/// The DFG table's EXR in the chain's folder; its `.npy`, `.h` and `.json` lie beside it.
pub const DFG_FILE: &str = "dfg.exr";

/// The split sum's DFG table for `lobe` as `lobe albedo --engine dfg` makes it (the lobe's D and
/// masking, 32 × 32 cells): the table the chain's JSON names.
pub fn dfg_spec(lobe: &SpecularLobe) -> Result<EngineSpec> {
    EngineSpec::new(EngineKind::Dfg, &lobe.lut_sets)
}

/// What [`write_chain`] made.
#[derive(Clone, Debug, PartialEq)]
pub struct ChainSummary {
    /// The files ([`paths`], the JSON last among them), then the DFG table's ([`DFG_FILE`] and
    /// its siblings).
    pub paths: Vec<PathBuf>,
    /// Seconds the prefilter took (writing not included).
    pub seconds: f64,
    /// The levels.
    pub levels: Vec<Level>,
}

/// The chain of `params`'s distribution under `map` ([`chain`]) written into `dir` (made if
/// missing): every level's lat-long EXR and six cube-face EXRs, `prefilter.json`, and the split
/// sum's DFG table on `eval` ([`dfg_spec`], the files of `lobe albedo --lut dfg.exr --engine
/// dfg`), together or none of them. `env` names the map in the JSON.
pub fn write_chain(
    eval: &Evaluator,
    params: &ParamSet,
    map: &EnvMap,
    env: &str,
    levels: u32,
    dir: &Path,
    cancelled: &dyn Fn() -> Result<()>,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<ChainSummary> {
    check_levels(levels)?;
    let lobe = chain_lobe(params)?;
    let mut paths = paths(dir, levels);
    let mut set = FileSet::empty();
    set.create_folder(dir)?;
    for p in &paths {
        set.add(p)?;
    }
    let dfg_spec = dfg_spec(&lobe)?;
    let dfg = stage_engine(
        eval,
        &dfg_spec,
        &dir.join(DFG_FILE),
        &mut set,
        &mut |_, _| {},
    )?;
    let started = std::time::Instant::now();
    let chain = chain(map, &lobe, levels, cancelled, progress)?;
    let seconds = started.elapsed().as_secs_f64();
    let name = |p: &PathBuf| crate::output::file_name(p);
    let mut slot = 0;
    let mut level_json = Vec::new();
    for (k, level) in chain.iter().enumerate() {
        let attrs = |what: String| {
            vec![
                ("lobe.kind", "prefilter".to_string()),
                ("lobe.env", env.to_string()),
                ("lobe.level", k.to_string()),
                ("lobe.roughness", level.roughness.to_string()),
                ("lobe.alpha", level.alpha.to_string()),
                ("lobe.layout", what),
            ]
        };
        encode_rgb(
            level.width,
            level.height,
            &level.latlong,
            &attrs("lat-long, Mitsuba's envmap layout".into()),
            &set[slot],
        )?;
        let latlong_name = name(&paths[slot]);
        slot += 1;
        let mut faces = Vec::new();
        for (f, face) in level.faces.iter().enumerate() {
            encode_rgb(
                level.face_size,
                level.face_size,
                face,
                &attrs(format!("cube face {}", FACES[f])),
                &set[slot],
            )?;
            faces.push(name(&paths[slot]));
            slot += 1;
        }
        level_json.push(json!({
            "level": k,
            "roughness": level.roughness,
            "alpha": level.alpha,
            "latlong": { "file": latlong_name, "width": level.width, "height": level.height },
            "cube": { "size": level.face_size, "faces": faces },
        }));
    }
    let dfg_sets = lobe.lut_sets.join(" --set ");
    let settings = json!({
        "kind": "prefilter",
        "model": params.model().name(),
        "parameters": params.to_json(),
        "distribution": lobe.distribution.name(),
        "env": env,
        "map": { "width": map.width(), "height": map.height() },
        "levels": levels,
        "roughness": "level k of L has perceptual roughness r = k / (L - 1) and alpha = r^2; each level half the width and height of the one above",
        "prefilter": "Karis' PrefilterEnvMap with n = v = r, summed over every texel of the full map about each texel centre's direction: sum L D(h) (r.l)+ dw / sum D(h) (r.l)+ dw; level 0 (alpha = 0) is the map itself, its cube faces the map texel holding each face texel's centre",
        "latlong_convention": "lat-long as Mitsuba 3's envmap: +y up, u = atan2(x, -z) / 2pi mod 1, v = acos(y) / pi, row 0 at +y",
        "cube_convention": CUBE_CONVENTION,
        "face_order": FACES,
        "dfg": {
            "file": DFG_FILE,
            "files": dfg.files.iter().map(name).collect::<Vec<_>>(),
            "command": format!("lobe albedo --lut {DFG_FILE} --engine dfg --set {dfg_sets}"),
            "layout": {
                "width": dfg_spec.lut.n_mu,
                "height": dfg_spec.lut.n_p,
                "columns": "n.v: mu_j = (j + 0.5) / width",
                "rows": "perceptual roughness: r_k = (k + 0.5) / height, alpha = r_k^2",
                "channels": { "R": "scale (the factor of F0)", "G": "bias (the factor of F90)" },
                "exr_layer": "DFG",
                "npy_shape": [dfg_spec.lut.n_p, dfg_spec.lut.n_mu, 2],
                "lookup": "the split sum reads it bilinearly between cell centres: specular = prefiltered(r) * (F0 * scale + F90 * bias)",
            },
        },
        "files": level_json,
        "seconds": seconds,
    });
    let mut w = set[slot].writer();
    serde_json::to_writer_pretty(&mut w, &settings)?;
    w.write_all(b"\n")?;
    w.finish()?;
    set.commit()?;
    paths.extend(dfg.files);
    Ok(ChainSummary {
        paths,
        seconds,
        levels: chain,
    })
}

/// A `w` × `h` float32 RGB EXR with `lobe.*` text attributes.
pub(crate) fn encode_rgb(
    w: u32,
    h: u32,
    rgb: &[[f64; 3]],
    attributes: &[(&'static str, String)],
    out: &crate::output::Pending,
) -> Result<()> {
    use exr::prelude::*;
    let width = w as usize;
    let channels = SpecificChannels::rgb(|Vec2(x, y)| {
        let [r, g, b] = rgb[y * width + x];
        (r as f32, g as f32, b as f32)
    });
    let mut layer = Layer::new(
        (width, h as usize),
        LayerAttributes::named("lobe prefilter"),
        crate::output::EXR_ENCODING,
        channels,
    );
    for (k, v) in attributes {
        layer
            .attributes
            .other
            .insert(Text::new_or_panic(*k), crate::output::exr_text(v));
    }
    crate::output::write_exr(out, |wr| Image::from_layer(layer).write().to_buffered(wr))
}
