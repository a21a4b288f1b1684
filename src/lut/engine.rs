//! Tables real-time engines load (`lobe albedo --lut PATH.exr --engine KIND`, docs/luts.md):
//! the split-sum DFG table (Karis 2013, "Real Shading in Unreal Engine 4"; Filament's
//! documentation, "Image based lights"), Kulla–Conty's E(μ, α) and E_avg(α) (Kulla & Conty 2017,
//! "Revisiting physically based shading at Imageworks"), and EON's single-scattering albedo
//! Ê(μ, r) and Ē(r) (Portsmouth, Kutz & Hill 2025).
//!
//! Each is an albedo look-up table of [`crate::lut`] on lobe's own integrators, with the model,
//! the Fresnel factor and the axis the engine's shader expects:
//! - `dfg`: microfacet GGX with height-correlated Smith masking (unless `--set` says otherwise),
//!   α = r², Schlick's F = F0 + (F90 − F0)(1 − ωi·h)⁵; per texel R = ∫ f (1 − Fc) c_i dωi (the
//!   factor of F0) and G = ∫ f Fc c_i dωi (the factor of F90), f taken with F = 1 and
//!   Fc = (1 − ωi·h)⁵, so that E = F0·R + F90·G and R + G is E with F = 1. Made from two tables:
//!   G with F0 = 0, F90 = 1, and R + G under the white furnace.
//! - `dfg-multiscatter`: the same integrals as R = ∫ f Fc c_i dωi and G = E with F = 1 (Filament's
//!   layout for its multiple-scattering compensation: E = mix(R, G, F0)).
//! - `kulla-conty`: E(μ, α) with F = 1 and E_avg(α) of microfacet in its white configuration.
//! - `eon`: Ê(μ, r) and Ē(r) of `eon` with ρ = 1 and no multiple scattering.
//!
//! Axes: μ_j = (j + ½)/Nμ as every LUT; `dfg*` and `kulla-conty` default to the perceptual
//! roughness r_k = (k + ½)/Nr over [0, 1] with α = r² ([`Mapping::Perceptual`]), `eon` to
//! r_k = (k + ½)/Nr linear (its roughness is already perceptual).
//!
//! Files beside `PATH.exr`, written as one [`ArtifactSet`] (nothing on error or when
//! `--max-error` refuses the table): `PATH.exr` (float32, layer `DFG` with channels R, G, or
//! layers `E` and `E_avg` with channel R), `PATH.npy` (Nr × Nμ × 2 for DFG, Nr × Nμ else),
//! `PATH_avg.npy` (Nr, not for DFG), `PATH.h` (a C/C++ header: the table as IEEE half floats in
//! R16F/RG16F texel order and as floats, its axes, centring and source in its comment) and
//! `PATH.json` (the sidecar).

use super::{check_max_error, check_path, compute, LutSpec, LutSummary, Mapping, AVG};
use crate::eval::Evaluator;
use crate::model::Value;
use crate::output::{file_name, sibling, ArtifactSet, ExrLayer, FileSet, Provenance};
use anyhow::Result;
use exr::prelude::f16;
use serde_json::json;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Which engine table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EngineKind {
    /// Split-sum DFG: R multiplies F0, G multiplies F90.
    Dfg,
    /// Split-sum DFG for multiple-scattering compensation: R = the F90 part, G = E with F = 1.
    DfgMultiscatter,
    /// Kulla–Conty's E(μ, α) with F = 1 and E_avg(α).
    KullaConty,
    /// EON's Ê(μ, r) and Ē(r).
    Eon,
}

impl EngineKind {
    /// Every kind, in the order the CLI lists them.
    pub const ALL: [EngineKind; 4] = [
        EngineKind::Dfg,
        EngineKind::DfgMultiscatter,
        EngineKind::KullaConty,
        EngineKind::Eon,
    ];

    /// The name `--engine` takes.
    pub fn name(self) -> &'static str {
        match self {
            EngineKind::Dfg => "dfg",
            EngineKind::DfgMultiscatter => "dfg-multiscatter",
            EngineKind::KullaConty => "kulla-conty",
            EngineKind::Eon => "eon",
        }
    }

    /// The name of the model the table integrates.
    pub fn model_name(self) -> &'static str {
        match self {
            EngineKind::Eon => "eon",
            _ => "microfacet",
        }
    }

    /// Channels per texel: 2 for the DFG tables (RG), 1 otherwise (R).
    pub fn channels(self) -> usize {
        match self {
            EngineKind::Dfg | EngineKind::DfgMultiscatter => 2,
            _ => 1,
        }
    }

    /// Whether the table has an average row E_avg (Kulla–Conty, EON).
    pub fn has_avg(self) -> bool {
        self.channels() == 1
    }

    /// What each channel holds, for the header's comment and the sidecar.
    pub fn meaning(self) -> &'static [&'static str] {
        match self {
            EngineKind::Dfg => &[
                "R = integral of f (1 - Fc) cos(theta_i) dw_i: the factor of F0",
                "G = integral of f Fc cos(theta_i) dw_i: the factor of F90",
            ],
            EngineKind::DfgMultiscatter => &[
                "R = integral of f Fc cos(theta_i) dw_i: the factor of F90",
                "G = integral of f cos(theta_i) dw_i: E with F = 1",
            ],
            EngineKind::KullaConty => &["R = E(mu, alpha): directional albedo with F = 1"],
            EngineKind::Eon => &[
                "R = E_hat(mu, r): directional albedo of the single-scattering lobe with rho = 1",
            ],
        }
    }

    /// How a shader uses the table, for the header's comment.
    pub fn usage(self) -> &'static str {
        match self {
            EngineKind::Dfg => "specular albedo E = F0 * R + F90 * G, Fc = (1 - dot(w_i, h))^5, f with F = 1",
            EngineKind::DfgMultiscatter => "specular albedo E = mix(R, G, F0) = F0 * (G - R) + R (F90 = 1); energy compensation 1 + F0 (1/G - 1)",
            EngineKind::KullaConty => "f_ms = (1 - E(mu_o)) (1 - E(mu_i)) / (pi (1 - E_avg)); E_avg = 2 * integral of E mu dmu",
            EngineKind::Eon => "EON's multiple-scattering lobe (1 - E_hat(mu_o)) (1 - E_hat(mu_i)) / (1 - E_avg); E_avg = 2 * integral of E_hat mu dmu",
        }
    }
}

/// What to tabulate: the kind and the LUT of its model (its parameters, axis, sizes, method).
#[derive(Clone, Debug)]
pub struct EngineSpec {
    /// The table.
    pub kind: EngineKind,
    /// The model's LUT: for the DFG tables the pass with F0 = 0 (the white-furnace pass is
    /// derived from it).
    pub lut: LutSpec,
}

impl EngineSpec {
    /// The table `kind` with the parameters of its model after `sets` (KEY=VALUE, applied to
    /// the model's defaults, then the kind's own settings on top), its default axis and 32 × 32
    /// cells; errors name the offending `--set`.
    pub fn new(kind: EngineKind, sets: &[String]) -> Result<EngineSpec> {
        let mut params = crate::resolve_params(kind.model_name(), None, sets)?;
        let white_furnace = match kind {
            EngineKind::Eon => {
                params.set("albedo", Value::One(1.0))?;
                params.set("multiscatter", Value::Choice("none"))?;
                false
            }
            EngineKind::KullaConty => {
                params.set("diffuse", Value::One(0.0))?;
                params.set("specular", Value::One(1.0))?;
                true
            }
            EngineKind::Dfg | EngineKind::DfgMultiscatter => {
                params.set("diffuse", Value::One(0.0))?;
                params.set("specular", Value::One(1.0))?;
                params.set("fresnel", Value::Choice("schlick"))?;
                params.set("f0", Value::One(0.0))?;
                false
            }
        };
        let mut lut = LutSpec::new(params);
        lut.white_furnace = white_furnace;
        lut.with_avg = kind.has_avg();
        if kind != EngineKind::Eon {
            lut.keys = vec!["alpha".to_string()];
            (lut.lo, lut.hi, lut.mapping) = (0.0, 1.0, Mapping::Perceptual);
        }
        Ok(EngineSpec { kind, lut })
    }

    /// The LUTs to compute: the table's own, and for the DFG tables its white-furnace twin.
    fn passes(&self) -> Vec<LutSpec> {
        let mut first = self.lut.clone();
        first.max_error = None;
        match self.kind {
            EngineKind::Dfg | EngineKind::DfgMultiscatter => {
                let mut white = first.clone();
                white.white_furnace = true;
                vec![first, white]
            }
            _ => vec![first],
        }
    }
}

/// A computed engine table.
#[derive(Clone, Debug)]
pub struct EngineTable {
    /// μ at each column's cell centre.
    pub mus: Vec<f64>,
    /// The model's parameter (α for microfacet, r for eon) of each row.
    pub ps: Vec<f64>,
    /// The axis value of each row before the mapping (r for the perceptual mapping).
    pub axis: Vec<f64>,
    /// Channels per texel.
    pub channels: usize,
    /// The texels: channel c of (μ_j, p_k) at index (k·Nμ + j)·channels + c.
    pub values: Vec<f64>,
    /// E_avg(p_k) (empty for the DFG tables).
    pub avg: Vec<f64>,
    /// The largest entry of `error` and `avg_error` ([`EngineTable::largest_error`]).
    pub max_error: f64,
    /// Each texel's error estimate, indexed k·Nμ + j (DFG: the sum of the two passes').
    pub error: Vec<f64>,
    /// The error estimate of each E_avg(p_k) (empty for the DFG tables).
    pub avg_error: Vec<f64>,
    /// Wall-clock time, seconds.
    pub seconds: f64,
    /// The files written (empty for [`compute_engine`]).
    pub files: Vec<PathBuf>,
}

impl EngineTable {
    /// The entry with the largest error estimate (None for an empty table).
    pub fn largest_error(&self) -> Option<super::ErrorEntry> {
        super::largest_entry(&self.mus, &self.ps, &self.error, &self.avg_error)
    }

    /// (smallest, largest) value of channel `c`.
    pub fn range(&self, c: usize) -> (f64, f64) {
        self.values
            .iter()
            .skip(c)
            .step_by(self.channels)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
                (lo.min(v), hi.max(v))
            })
    }
}

/// Computes the table on `eval`; `progress` receives (rows done, rows) over every pass.
pub fn compute_engine(
    eval: &Evaluator,
    spec: &EngineSpec,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<EngineTable> {
    let start = std::time::Instant::now();
    let passes = spec.passes();
    let rows = (passes.len() * spec.lut.n_p) as u64;
    let mut done: Vec<LutSummary> = Vec::new();
    for (i, pass) in passes.iter().enumerate() {
        let base = (i * spec.lut.n_p) as u64;
        done.push(compute(eval, pass, &mut |k, _| progress(base + k, rows))?);
    }
    // Every pass is grey: its first channel is the table.
    let grey = |s: &LutSummary| -> Vec<f64> { s.e.iter().map(|v| v.x).collect() };
    let values: Vec<f64> = match spec.kind {
        EngineKind::Dfg | EngineKind::DfgMultiscatter => {
            let (bias, total) = (grey(&done[0]), grey(&done[1]));
            bias.iter()
                .zip(&total)
                .flat_map(|(&b, &e)| {
                    if spec.kind == EngineKind::Dfg {
                        [e - b, b]
                    } else {
                        [b, e]
                    }
                })
                .collect()
        }
        _ => grey(&done[0]),
    };
    let first = &done[0];
    let mut error = first.e_error.clone();
    for pass in &done[1..] {
        error
            .iter_mut()
            .zip(&pass.e_error)
            .for_each(|(e, x)| *e += x);
    }
    let max_error = super::largest_entry(&first.mus, &first.ps, &error, &first.e_avg_error)
        .map_or(0.0, |w| w.error);
    let axis = (0..spec.lut.n_p)
        .map(|k| {
            let t = (k as f64 + 0.5) / spec.lut.n_p as f64;
            match spec.lut.mapping {
                Mapping::Perceptual => spec.lut.lo + (spec.lut.hi - spec.lut.lo) * t,
                m => m.apply(spec.lut.lo, spec.lut.hi, t),
            }
        })
        .collect();
    Ok(EngineTable {
        mus: first.mus.clone(),
        ps: first.ps.clone(),
        axis,
        channels: spec.kind.channels(),
        values,
        avg: first.e_avg.iter().map(|v| v.x).collect(),
        max_error,
        error,
        avg_error: first.e_avg_error.clone(),
        seconds: start.elapsed().as_secs_f64(),
        files: Vec::new(),
    })
}

/// The extension of the C header.
const HEADER: &str = "h";

/// The header beside `exr_path`: `PATH.h`.
pub fn header_path(exr_path: &Path) -> PathBuf {
    sibling(exr_path, "", HEADER)
}

/// Computes the table and writes its files (see the module's documentation); `--max-error`
/// ([`LutSpec::max_error`]) refuses it before any file appears.
pub fn write_engine(
    eval: &Evaluator,
    spec: &EngineSpec,
    exr_path: &Path,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<EngineTable> {
    let mut set = FileSet::empty();
    let table = stage_engine(eval, spec, exr_path, &mut set, progress)?;
    set.commit()?;
    Ok(table)
}

/// [`write_engine`]'s files staged into `set`, which commits them with whatever else it holds
/// (`lobe light --prefilter-out DIR` writes the DFG table beside the mip chain this way).
pub fn stage_engine(
    eval: &Evaluator,
    spec: &EngineSpec,
    exr_path: &Path,
    set: &mut FileSet,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<EngineTable> {
    check_path(exr_path)?;
    let avg: &[&str] = if spec.kind.has_avg() { &[AVG] } else { &[] };
    let npy = [&[""], avg].concat();
    let files = ArtifactSet::stage(
        set,
        crate::output::ENGINE_LUT_SET,
        exr_path,
        &npy,
        &[HEADER],
    )?;
    let mut table = compute_engine(eval, spec, progress)?;
    check_max_error(table.max_error, spec.lut.max_error)?;
    let (n_mu, n_p, c) = (spec.lut.n_mu, spec.lut.n_p, table.channels);
    let shape: Vec<usize> = if c == 1 {
        vec![n_p, n_mu]
    } else {
        vec![n_p, n_mu, c]
    };
    let (values, avg) = (f32s(&table.values), f32s(&table.avg));
    files.npy(0, &shape, &values)?;
    if spec.kind.has_avg() {
        files.npy(1, &[n_p], &avg)?;
    }
    write_engine_exr(&files, spec, &table, &values, &avg)?;
    files.text(0, &c_header(spec, &table, eval, exr_path))?;
    let paths: Vec<PathBuf> = files.paths().into_iter().map(Path::to_path_buf).collect();
    let s = &spec.lut;
    let provenance = Provenance {
        model: s.params.model().name(),
        parameters: s.params.to_json(),
        white_furnace: s.white_furnace,
        backend: &eval.name(),
    };
    files.finish(&provenance, engine_sidecar(spec, &table, &paths))?;
    table.files = paths;
    Ok(table)
}

fn f32s(v: &[f64]) -> Vec<f32> {
    v.iter().map(|&x| x as f32).collect()
}

const CHANNEL_NAMES: [&str; 2] = ["R", "G"];

/// Layer `DFG` (R, G) or `E` (R) with the `lobe.*` attributes, and `E_avg` (R) where the table
/// has one; `values` and `avg` are the table's as float32.
fn write_engine_exr<S: std::borrow::BorrowMut<FileSet>>(
    files: &ArtifactSet<S>,
    spec: &EngineSpec,
    t: &EngineTable,
    values: &[f32],
    avg: &[f32],
) -> Result<()> {
    let (n_mu, n_p) = (spec.lut.n_mu, spec.lut.n_p);
    let attributes = [
        ("lobe.engine", spec.kind.name().to_string()),
        ("lobe.model", spec.lut.params.model().name().to_string()),
        ("lobe.parameters", spec.lut.params.to_text()),
        ("lobe.lut_keys", spec.lut.keys.join(",")),
        ("lobe.lut_range", format!("{},{}", spec.lut.lo, spec.lut.hi)),
        ("lobe.lut_mapping", spec.lut.mapping.formula().to_string()),
        ("lobe.lut_centring", centring(spec)),
        ("lobe.channels", spec.kind.meaning().join("; ")),
        ("lobe.method", spec.lut.method.name().to_string()),
    ];
    let mut layers = vec![ExrLayer {
        name: if t.channels == 2 { "DFG" } else { "E" },
        width: n_mu,
        height: n_p,
        channels: &CHANNEL_NAMES[..t.channels],
        values,
        attributes: &attributes,
    }];
    if !t.avg.is_empty() {
        layers.push(ExrLayer {
            name: "E_avg",
            width: 1,
            height: n_p,
            channels: &["R"],
            values: avg,
            attributes: &[],
        });
    }
    files.exr(&layers)
}

/// The axes' centring, in words (ASCII: the EXR attribute, the header and the sidecar).
fn centring(spec: &EngineSpec) -> String {
    let s = &spec.lut;
    let axis = match s.mapping {
        Mapping::Perceptual => format!(
            "r_k = {} + {} * (k + 0.5)/height, alpha = r_k^2",
            s.lo,
            s.hi - s.lo
        ),
        m => format!(
            "t_k = (k + 0.5)/height, {} = {}",
            s.keys.join(","),
            m.formula()
        ),
    };
    format!("cell-centred: mu_j = (j + 0.5)/width; {axis}")
}

/// A C identifier from the file's stem: `lobe_` and the stem's letters, digits and underscores.
fn c_name(exr_path: &Path) -> String {
    let stem = exr_path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let clean: String = stem
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect();
    format!("lobe_{clean}")
}

/// A float as C reads it back exactly: Rust's shortest round-trip form and the `f` suffix.
fn c_float(v: f32) -> String {
    format!("{v:e}f")
}

/// Writes `values` as the body of a C array, `per_line` to a line.
fn c_array(out: &mut String, decl: &str, items: impl Iterator<Item = String>, per_line: usize) {
    let _ = writeln!(out, "{decl} = {{");
    let items: Vec<String> = items.collect();
    for line in items.chunks(per_line) {
        let _ = writeln!(out, "    {},", line.join(", "));
    }
    let _ = writeln!(out, "}};");
}

/// The C/C++ header: a comment stating the source, the axes, the centring, the channels and the
/// largest error estimate; the sizes as macros; the table as IEEE binary16 bit patterns
/// (`uint16_t`, texel order R or RG as an R16F/RG16F texture upload expects, row k = roughness,
/// column j = μ) and as floats; E_avg likewise where the table has one.
pub fn c_header(spec: &EngineSpec, t: &EngineTable, eval: &Evaluator, exr_path: &Path) -> String {
    let name = c_name(exr_path);
    let upper = name.to_ascii_uppercase();
    let s = &spec.lut;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "/* {}: written by lobe {} (`lobe albedo --lut {} --engine {}`).",
        file_name(&header_path(exr_path)),
        env!("CARGO_PKG_VERSION"),
        file_name(exr_path),
        spec.kind.name()
    );
    let _ = writeln!(
        out,
        " * Source: {} {} ({} set per row){}, integrated by lobe's `{}` rule ({} nodes per direction) on {}.",
        s.params.model().name(),
        s.params.to_text(),
        s.keys.join(","),
        if s.white_furnace {
            " (white furnace)"
        } else {
            ""
        },
        s.method.name(),
        s.samples,
        eval.name()
    );
    let _ = writeln!(
        out,
        " * Largest error estimate of an entry: {:.3e} (absolute).",
        t.max_error
    );
    let _ = writeln!(out, " * Layout: {upper}_HEIGHT rows (k, roughness) of {upper}_WIDTH texels (j, mu = cos(theta_o)), {upper}_CHANNELS per texel: index (k * WIDTH + j) * CHANNELS + c.");
    let _ = writeln!(out, " * Axes: {}.", centring(spec));
    let _ = writeln!(out, " *   Sample with linear filtering and clamp-to-edge at u = NoV, v = (r - {}) / {} (texel centres at (j + 0.5)/WIDTH, (k + 0.5)/HEIGHT).", s.lo, s.hi - s.lo);
    for m in spec.kind.meaning() {
        let _ = writeln!(out, " * {m}.");
    }
    let _ = writeln!(out, " * Use: {}.", spec.kind.usage());
    if !t.avg.is_empty() {
        let _ = writeln!(out, " * {name}_avg_*: E_avg per row k (HEIGHT values).");
    }
    let _ = writeln!(out, " * {name}_f16: IEEE 754 binary16 bit patterns ({}16F texel order); {name}_f32: the same as float (rounded once from f64). */", if t.channels == 2 { "RG" } else { "R" });
    let _ = writeln!(
        out,
        "#ifndef {upper}_H\n#define {upper}_H\n\n#include <stdint.h>\n"
    );
    let _ = writeln!(
        out,
        "#define {upper}_WIDTH {}\n#define {upper}_HEIGHT {}\n#define {upper}_CHANNELS {}\n",
        s.n_mu, s.n_p, t.channels
    );
    let per_line = 8;
    let halves = |v: &[f64]| -> Vec<String> {
        v.iter()
            .map(|&x| format!("0x{:04x}", f16::from_f64(x).to_bits()))
            .collect()
    };
    let floats = |v: &[f64]| -> Vec<String> { v.iter().map(|&x| c_float(x as f32)).collect() };
    let size = format!("{upper}_WIDTH * {upper}_HEIGHT * {upper}_CHANNELS");
    c_array(
        &mut out,
        &format!("static const uint16_t {name}_f16[{size}]"),
        halves(&t.values).into_iter(),
        per_line,
    );
    c_array(
        &mut out,
        &format!("static const float {name}_f32[{size}]"),
        floats(&t.values).into_iter(),
        per_line,
    );
    if !t.avg.is_empty() {
        c_array(
            &mut out,
            &format!("static const uint16_t {name}_avg_f16[{upper}_HEIGHT]"),
            halves(&t.avg).into_iter(),
            per_line,
        );
        c_array(
            &mut out,
            &format!("static const float {name}_avg_f32[{upper}_HEIGHT]"),
            floats(&t.avg).into_iter(),
            per_line,
        );
    }
    let _ = writeln!(out, "\n#endif /* {upper}_H */");
    out
}

/// The sidecar's own fields (the [`Provenance`] fields come with every set).
fn engine_sidecar(spec: &EngineSpec, t: &EngineTable, files: &[PathBuf]) -> serde_json::Value {
    let s = &spec.lut;
    json!({
        "kind": "engine look-up table",
        "engine": spec.kind.name(),
        "channels": spec.kind.meaning(),
        "use": spec.kind.usage(),
        "mu_axis": {
            "name": "mu = cos(theta_o)",
            "count": s.n_mu,
            "centring": "cell-centred: mu_j = (j + 0.5) / count",
            "values": t.mus,
        },
        "roughness_axis": {
            "keys": s.keys,
            "lo": s.lo,
            "hi": s.hi,
            "count": s.n_p,
            "mapping": s.mapping.name(),
            "formula": s.mapping.formula(),
            "centring": centring(spec),
            "axis_values": t.axis,
            "parameter_values": t.ps,
        },
        "e_avg": t.avg,
        "method": s.method.name(),
        "samples": s.samples,
        "seed": s.method.sampler().map(|_| s.seed),
        "max_error_estimate": t.max_error,
        "seconds": t.seconds,
        "files": files.iter().map(|p| file_name(p)).collect::<Vec<_>>(),
        "layout": "npy: (rows, mu, channels), channels dropped when 1; exr: layer DFG (R, G) or layers E and E_avg (R), width = mu count, height = row count; header: see its comment",
    })
}
