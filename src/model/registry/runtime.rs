//! Models defined at run time, beside the built-in closed set: a parameter table, SPIR-V kernels
//! compiled by the caller (from a GLSL file, say), and, where one exists, an f64 reference. A
//! model without a reference says so ([`Model::has_reference`]), and every job that needs the
//! f64 reference (the CPU backend, the adaptive integrator, the stability sweep) refuses it with
//! [`NoReference`].
//!
//! Registered models live for the rest of the process (their names must be unique), so that a
//! [`Model`] stays a small `Copy` value whatever defined it.

use super::info::{no_exponent, no_v_cavity, LutAxis, ModelInfo};
use super::sampling::no_lobes;
use crate::axis::Mapping;
use crate::model::params::{ParamError, ParamKind, ParamSpec, Value};
use crate::model::sample::{self, Sample};
use crate::model::{Model, ParamSet};
use glam::{DVec2, DVec3};
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// An f64 reference: f(ωi, ωo) from the parameter values in table order (an rgb key gives three
/// numbers, a scalar one).
pub type ReferenceFn = Arc<dyn Fn(&[f64], DVec3, DVec3) -> DVec3 + Send + Sync>;

/// A run-time model's own sampler in f64 (a measured table's, say), the twin of its kernels'
/// `MODEL_SAMPLE` and `MODEL_PDF`; the parameter values come in table order as for
/// [`ReferenceFn`]. A model without one is drawn by the cosine (docs/design.md §13).
pub trait RuntimeSampler: Send + Sync {
    /// A draw for ωo (above the horizon) with f from `f`, as `Reference::sample` returns it.
    fn sample(
        &self,
        values: &[f64],
        wo: DVec3,
        uc: f64,
        u: DVec2,
        f: &dyn Fn(DVec3) -> DVec3,
    ) -> Sample;
    /// The density over the solid angle of ωi of [`RuntimeSampler::sample`]'s draws (both
    /// directions above the horizon).
    fn pdf(&self, values: &[f64], wi: DVec3, wo: DVec3) -> f64;
}

/// Most parameter numbers a run-time model may have (an rgb key counts three): a fixed array
/// keeps a parameter set `Copy` and no larger than the largest built-in model's.
pub const MAX_VALUES: usize = 20;

/// What a job that needs the f64 reference says of a model that has none.
#[derive(Debug, thiserror::Error)]
#[error("model '{model}' has no f64 CPU reference ({why}), which {job} needs; evaluate it on the GPU backend")]
pub struct NoReference {
    /// The model's name.
    pub model: String,
    /// Why it has none, in words ([`RuntimeModel::with_no_reference_note`]).
    pub why: String,
    /// What needed the reference.
    pub job: String,
}

/// A model defined at run time. Build it with [`RuntimeModel::new`], add kernels and a
/// reference, then [`RuntimeModel::register`] it.
pub struct RuntimeModel {
    info: ModelInfo,
    isotropic: bool,
    kernels: BTreeMap<String, &'static [u8]>,
    reference: Option<ReferenceFn>,
    sampler: Option<Arc<dyn RuntimeSampler>>,
    no_reference_note: &'static str,
    chunk_timeout: Option<Duration>,
    defaults: Vec<(&'static str, Value)>,
    data: Option<&'static [u8]>,
    reciprocal: bool,
    tabulated: bool,
}

impl std::fmt::Debug for RuntimeModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RuntimeModel")
            .field("name", &self.info.name)
            .field("kernels", &self.kernels.keys().collect::<Vec<_>>())
            .field("reference", &self.reference.is_some())
            .field("data_bytes", &self.data.map(<[u8]>::len))
            .finish()
    }
}

/// Registered names are unique, so a model is its name.
impl PartialEq for RuntimeModel {
    fn eq(&self, other: &Self) -> bool {
        self.info.name == other.info.name
    }
}

impl Eq for RuntimeModel {}

impl std::hash::Hash for RuntimeModel {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.info.name.hash(state)
    }
}

impl PartialOrd for RuntimeModel {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for RuntimeModel {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.info.name.cmp(other.info.name)
    }
}

fn leak(s: &str) -> &'static str {
    Box::leak(s.to_string().into_boxed_str())
}

/// The std430 layout of a block holding the parameters in table order: a scalar is a `float`
/// (4-byte aligned), a named choice a `uint` (the option's index, 4-byte aligned), an rgb key a
/// `vec3` (16-byte aligned, 12 bytes); the block's size is rounded up to its largest alignment.
/// A GLSL struct that declares the same members in the same order has exactly this layout.
pub fn std430_layout(params: &[ParamSpec]) -> (Vec<(&'static str, usize)>, usize) {
    let mut offset = 0usize;
    let mut align = 4usize;
    let mut out = Vec::new();
    for p in params {
        let (a, size) = match p.kind {
            ParamKind::Rgb => (16, 12),
            _ => (4, 4),
        };
        align = align.max(a);
        offset = offset.div_ceil(a) * a;
        out.push((p.key, offset));
        offset += size;
    }
    (out, offset.div_ceil(align).max(1) * align)
}

fn runtime_of(p: &ParamSet) -> Option<&'static RuntimeModel> {
    match p.model() {
        Model::Runtime(r) => Some(r),
        _ => None,
    }
}

fn runtime_isotropic(p: &ParamSet) -> bool {
    runtime_of(p).is_none_or(|r| r.isotropic)
}

/// A model defined at run time has no white configuration of its own: it is measured as given.
fn as_given(_: &mut ParamSet) -> Result<bool, ParamError> {
    Ok(false)
}

fn no_edges(_: Model) -> Vec<&'static [&'static str]> {
    Vec::new()
}

static REGISTERED: Mutex<Vec<&'static RuntimeModel>> = Mutex::new(Vec::new());

impl RuntimeModel {
    /// A model named `name` with the parameter table `params`: numbers, rgb triples and named
    /// choices (a choice reaches the kernels as its option's index in the parameter block, not as
    /// a pipeline of its own).
    pub fn new(
        name: &str,
        description: &str,
        params: Vec<ParamSpec>,
        isotropic: bool,
    ) -> Result<RuntimeModel, ParamError> {
        let valid_name = !name.is_empty()
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.');
        if !valid_name {
            return Err(ParamError::UnknownModel {
                name: name.to_string(),
                list: "a model name made of letters, digits, '_', '-' and '.'".into(),
            });
        }
        let numbers: usize = params
            .iter()
            .map(|p| if p.kind == ParamKind::Rgb { 3 } else { 1 })
            .sum();
        if numbers > MAX_VALUES {
            return Err(ParamError::Malformed {
                key: name.to_string(),
                text: format!("{numbers} parameter numbers"),
                expected: format!("at most {MAX_VALUES}"),
            });
        }
        let params: &'static [ParamSpec] = Box::leak(params.into_boxed_slice());
        let (layout, size) = std430_layout(params);
        // The default LUT axis: the first scalar over its range, else the first rgb key grey
        // (a choice is no axis).
        let lut_axis = params
            .iter()
            .find(|p| p.kind == ParamKind::Scalar)
            .or(params.iter().find(|p| p.kind == ParamKind::Rgb))
            .map(|p| LutAxis {
                keys: Box::leak(vec![p.key].into_boxed_slice()),
                lo: p.min,
                hi: p.max,
                mapping: Mapping::Linear,
            })
            .unwrap_or(LutAxis {
                keys: &[],
                lo: 0.0,
                hi: 1.0,
                mapping: Mapping::Linear,
            });
        Ok(RuntimeModel {
            info: ModelInfo {
                name: leak(name),
                description: leak(description),
                params,
                optional_keys: &[],
                gpu_struct: "Params",
                gpu_layout: Box::leak(layout.into_boxed_slice()),
                gpu_size: size,
                has_delta: false,
                has_specular_fresnel: false,
                pow_lobe: false,
                lut_axis,
                white: as_given,
                stability_edges: no_edges,
                exponent: no_exponent,
                is_isotropic: runtime_isotropic,
                sampling_lobes: no_lobes,
                v_cavity: no_v_cavity,
                interleave_table: false,
            },
            isotropic,
            kernels: BTreeMap::new(),
            reference: None,
            sampler: None,
            no_reference_note: "it was defined at run time without one",
            chunk_timeout: None,
            defaults: Vec::new(),
            data: None,
            reciprocal: false,
            tabulated: false,
        })
    }

    /// Adds the SPIR-V of one kernel (`table`, `pairs`, `albedo`, `preview`, `sample`), compiled against
    /// the parameter block of [`std430_layout`].
    pub fn with_kernel(mut self, kernel: &str, spirv: &[u8]) -> RuntimeModel {
        self.kernels.insert(
            kernel.to_string(),
            Box::leak(spirv.to_vec().into_boxed_slice()),
        );
        self
    }

    /// Adds the f64 reference.
    pub fn with_reference(mut self, reference: ReferenceFn) -> RuntimeModel {
        self.reference = Some(reference);
        self
    }

    /// Starts `key` from `value` instead of its table default (an rgb key from three different
    /// channels, say); refused where the table would refuse the value.
    pub fn with_default(mut self, key: &str, value: Value) -> Result<RuntimeModel, ParamError> {
        let spec = self
            .info
            .params
            .iter()
            .find(|s| s.key == key)
            .ok_or_else(|| ParamError::UnknownKey {
                key: key.to_string(),
                model: self.info.name.to_string(),
                list: self
                    .info
                    .params
                    .iter()
                    .map(|s| s.key)
                    .collect::<Vec<_>>()
                    .join(", "),
            })?;
        let shape_ok = match (spec.kind, value) {
            (ParamKind::Rgb, Value::One(_) | Value::Three(_))
            | (ParamKind::Scalar, Value::One(_)) => true,
            (ParamKind::Flag, Value::One(v)) => v == 0.0 || v == 1.0,
            _ => false,
        };
        if !shape_ok {
            return Err(ParamError::Malformed {
                key: key.to_string(),
                text: value.to_string(),
                expected: format!("a value of its kind ({})", spec.range_text()),
            });
        }
        for v in value.numbers() {
            spec.check(v)?;
        }
        self.defaults.retain(|(k, _)| *k != spec.key);
        self.defaults.push((spec.key, value));
        Ok(self)
    }

    /// The defaults set by [`RuntimeModel::with_default`], which replace the table's.
    pub fn defaults(&self) -> &[(&'static str, Value)] {
        &self.defaults
    }

    /// Says, in the refusal of a job that needs the f64 reference, why the model has none
    /// (default: "it was defined at run time without one").
    pub fn with_no_reference_note(mut self, note: &str) -> RuntimeModel {
        self.no_reference_note = leak(note);
        self
    }

    /// Bounds the wait for each chunk of GPU work with this model's kernels (default: the
    /// crate's [`crate::gpu::CHUNK_TIMEOUT`]): a kernel from an untrusted source that never
    /// returns is then stopped with [`crate::gpu::GpuError::ModelTimeout`] after `timeout`.
    pub fn with_chunk_timeout(mut self, timeout: Duration) -> RuntimeModel {
        self.chunk_timeout = Some(timeout);
        self
    }

    /// Adds the model's own f64 sampler (its kernels define `MODEL_SAMPLE` and `MODEL_PDF` to
    /// match); without one the model is drawn by the cosine.
    pub fn with_sampler(mut self, sampler: Arc<dyn RuntimeSampler>) -> RuntimeModel {
        self.sampler = Some(sampler);
        self
    }

    /// Adds a data table the kernels read (a measured BRDF's bins, say): bound as one read-only
    /// storage buffer at binding [`crate::gpu::pipeline::MODEL_DATA_BINDING`] of every kernel
    /// of this model, uploaded once per pipeline.
    pub fn with_data(mut self, data: Vec<u8>) -> RuntimeModel {
        self.data = Some(Box::leak(data.into_boxed_slice()));
        self
    }

    /// Declares f(ωi, ωo) = f(ωo, ωi) for every parameter set (a measured table looked up by
    /// half and difference angles is so by construction); lobe tables may then copy mirror
    /// cells instead of evaluating them (docs/design.md §4.5). Default: not declared.
    pub fn with_reciprocity(mut self) -> RuntimeModel {
        self.reciprocal = true;
        self
    }

    /// Declares f to be read from a table by its bins (a measured BRDF): piecewise constant or
    /// piecewise linear, with jumps or kinks on every bin boundary, so that no quadrature rule
    /// converges geometrically on it and the albedo's error estimate must not assume so
    /// (docs/design.md §5.5). Default: f is smooth within the rules' panels.
    pub fn with_tabulated(mut self) -> RuntimeModel {
        self.tabulated = true;
        self
    }

    /// Makes the model known to [`Model::from_name`] for the rest of the process and returns it.
    /// Refuses a name that a built-in or registered model already has.
    pub fn register(self) -> Result<Model, ParamError> {
        let mut registered = REGISTERED.lock().unwrap_or_else(|e| e.into_inner());
        let name = self.info.name;
        let taken = Model::ALL.iter().any(|m| m.name() == name)
            || registered.iter().any(|r| r.info.name == name);
        if taken {
            return Err(ParamError::Malformed {
                key: "name".into(),
                text: name.to_string(),
                expected: "a name no other model has".into(),
            });
        }
        let model: &'static RuntimeModel = Box::leak(Box::new(self));
        registered.push(model);
        Ok(Model::Runtime(model))
    }

    /// The model's description.
    pub fn info(&self) -> &ModelInfo {
        &self.info
    }

    /// The SPIR-V of `kernel`, if the model was given one.
    pub fn kernel(&self, kernel: &str) -> Option<&'static [u8]> {
        self.kernels.get(kernel).copied()
    }

    /// The f64 reference, if any.
    pub fn reference(&self) -> Option<&ReferenceFn> {
        self.reference.as_ref()
    }

    /// Why the model has no f64 reference, in words.
    pub fn no_reference_note(&self) -> &'static str {
        self.no_reference_note
    }

    /// The bound on each chunk's GPU wait, if the model has its own.
    pub fn chunk_timeout(&self) -> Option<Duration> {
        self.chunk_timeout
    }

    /// The data table the kernels read, if the model has one ([`RuntimeModel::with_data`]).
    pub fn data(&self) -> Option<&'static [u8]> {
        self.data
    }

    /// Whether f is read from a table by its bins ([`RuntimeModel::with_tabulated`]).
    pub fn is_tabulated(&self) -> bool {
        self.tabulated
    }

    /// Whether the model declares reciprocity ([`RuntimeModel::with_reciprocity`]).
    pub fn is_reciprocal(&self) -> bool {
        self.reciprocal
    }
}

/// The registered run-time models, in the order they were registered.
pub fn registered() -> Vec<Model> {
    REGISTERED
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .iter()
        .map(|&r| Model::Runtime(r))
        .collect()
}

/// A run-time model with its parameter values, ready to evaluate (a `Copy` value, as the
/// built-in models' structs are).
#[derive(Clone, Copy, Debug)]
pub struct RuntimeBrdf {
    /// The model.
    pub model: &'static RuntimeModel,
    values: [f64; MAX_VALUES],
    len: usize,
}

impl RuntimeBrdf {
    /// The values of `p` in table order (a choice as its option's index).
    pub fn new(model: &'static RuntimeModel, p: &ParamSet) -> RuntimeBrdf {
        let mut values = [0.0; MAX_VALUES];
        let mut len = 0;
        for spec in model.info.params {
            let n = if spec.kind == ParamKind::Rgb { 3 } else { 1 };
            match (spec.kind, p.get(spec.key)) {
                (ParamKind::Choice(options), Value::Choice(name)) => {
                    values[len] = options.iter().position(|o| *o == name).unwrap_or(0) as f64;
                }
                (_, v) => values[len..len + n].copy_from_slice(&v.rgb()[..n]),
            }
            len += n;
        }
        RuntimeBrdf { model, values, len }
    }

    /// f from the reference; NaN where there is none (jobs refuse such models before they get
    /// here, so a NaN is never silent: every check counts it).
    pub fn eval(&self, wi: DVec3, wo: DVec3) -> DVec3 {
        match &self.model.reference {
            Some(f) => f(&self.values[..self.len], wi, wo),
            None => DVec3::NAN,
        }
    }

    /// A draw for ωo (above the horizon) by the model's sampler, the cosine if it has none;
    /// the weight takes f from [`RuntimeBrdf::eval`].
    pub fn sample(&self, wo: DVec3, uc: f64, u: DVec2) -> Sample {
        let f = |wi| self.eval(wi, wo);
        match &self.model.sampler {
            Some(s) => s.sample(&self.values[..self.len], wo, uc, u, &f),
            None => sample::sample_by_cosine(u, f),
        }
    }

    /// The density of [`RuntimeBrdf::sample`]'s draws (both directions above the horizon).
    pub fn pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        match &self.model.sampler {
            Some(s) => s.pdf(&self.values[..self.len], wi, wo),
            None => sample::pdf_cosine(wi),
        }
    }

    /// The std430 parameter block ([`std430_layout`]) as bytes.
    pub fn gpu_block(&self) -> Vec<u8> {
        let info = &self.model.info;
        let mut out = vec![0u8; info.gpu_size];
        let mut k = 0;
        for (spec, &(_, offset)) in info.params.iter().zip(info.gpu_layout) {
            let n = if spec.kind == ParamKind::Rgb { 3 } else { 1 };
            for c in 0..n {
                let bytes = match spec.kind {
                    ParamKind::Choice(_) => (self.values[k + c] as u32).to_le_bytes(),
                    _ => (self.values[k + c] as f32).to_le_bytes(),
                };
                out[offset + 4 * c..offset + 4 * c + 4].copy_from_slice(&bytes);
            }
            k += n;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The built-in models' blocks follow the same std430 rules: lambert (one vec3) is 16 bytes,
    /// phong (vec3 diffuse, float shininess, vec3 specular) 32.
    #[test]
    fn std430_layout_matches_the_built_in_blocks() {
        let (l, size) = std430_layout(crate::model::lambert::PARAMS);
        assert_eq!((l, size), (vec![("albedo", 0)], 16));
        let phong = [
            crate::model::phong::PARAMS[0],
            crate::model::phong::PARAMS[2],
            crate::model::phong::PARAMS[1],
        ];
        let (l, size) = std430_layout(&phong);
        assert_eq!(l, vec![("diffuse", 0), ("shininess", 12), ("specular", 16)]);
        assert_eq!(size, 32);
        assert_eq!(size, crate::model::phong::INFO.gpu_size);
    }
}

/// A model name for a file that defines a model: its stem with every character other than
/// letters, digits, `_` and `-` made `_` (a `.` would read as MODEL.KEY in `--set`), or
/// `fallback` when nothing is left.
pub fn name_from_stem(path: &std::path::Path, fallback: &str) -> String {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name: String = stem
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if name.is_empty() {
        fallback.to_string()
    } else {
        name
    }
}
