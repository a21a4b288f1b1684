//! A MERL file as a model: registered at run time ([`crate::model::runtime`]) with the kernels of
//! `glsl/brdf/merl.glsl`, its table as the kernels' data buffer, and the f64 twin
//! ([`super::lookup::merl`]) as its reference, so that every command and both backends take it.
//!
//! The data buffer holds the bins and, after them, the tables of the model's importance sampler
//! ([`MerlSampler`], docs/design.md §13), which both backends draw with.
//!
//! The GPU table is f32 (stored × scale rounded once): kernels compute in f32 and write f32, so
//! an f64 table would change no nearest-bin result (an f32 of the f64 value either way) and
//! would need `shaderFloat64`, which many GPUs lack. The f64 reference keeps the file's values.

use super::lookup::{merl, Lookup, MerlSampler, LOOKUPS};
use super::{read, MerlTable, BINS};
use crate::model::kernels;
use crate::model::runtime::{RuntimeModel, RuntimeSampler};
use crate::model::sample::Sample;
use crate::model::{Model, ParamSpec};
use glam::{DVec2, DVec3};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// The kernels a model gets, each compiled with `glsl/brdf/merl.glsl` by build.rs.
const KERNELS: [&str; 7] = [
    "pairs", "table", "albedo", "preview", "sample", "light", "chi2",
];

/// The model's one parameter: how a pair's value comes out of the bins.
pub const LOOKUP_PARAM: ParamSpec = ParamSpec::choice(
    "lookup",
    LOOKUPS,
    0,
    "nearest: the bin the pair falls in (MERL's reader); trilinear: between bin centres",
);

/// A MERL file made a model.
#[derive(Clone, Copy, Debug)]
pub struct Loaded {
    /// The registered model, named after the file's stem.
    pub model: Model,
    /// Negative (missing) stored values, over all channels, read as 0.
    pub missing: usize,
    /// Whether this call read the file (false: it was loaded before in this process).
    pub first: bool,
}

/// Files loaded so far, by canonical path: a file named twice is one model.
static LOADED: Mutex<BTreeMap<PathBuf, (Model, usize)>> = Mutex::new(BTreeMap::new());

/// The model name for a file: its stem, with any character other than a letter, a digit, `_`
/// or `-` replaced by `_` ([`crate::model::runtime::name_from_stem`]).
pub fn model_name(path: &Path) -> String {
    crate::model::runtime::name_from_stem(path, "merl")
}

/// The table's sampler as the model's: the same cells whatever the `lookup` parameter (the
/// weight takes f from the lookup chosen).
impl RuntimeSampler for MerlSampler {
    fn sample(
        &self,
        _values: &[f64],
        wo: DVec3,
        uc: f64,
        u: DVec2,
        f: &dyn Fn(DVec3) -> DVec3,
    ) -> Sample {
        MerlSampler::sample(self, wo, uc, u, f)
    }

    fn pdf(&self, _values: &[f64], wi: DVec3, wo: DVec3) -> f64 {
        MerlSampler::pdf(self, wi, wo)
    }
}

/// Registers `table` as the model `name` (see the module's notes).
pub fn register(name: &str, description: &str, table: MerlTable) -> anyhow::Result<Model> {
    let mut m = RuntimeModel::new(name, description, vec![LOOKUP_PARAM], true)?;
    for kernel in KERNELS {
        let spirv = kernels::spirv(kernel, "merl")
            .ok_or_else(|| anyhow::anyhow!("the {kernel} kernel of the MERL lookup is missing"))?;
        m = m.with_kernel(kernel, spirv);
    }
    let sampler = MerlSampler::new(&table);
    let gpu: Vec<u8> = table
        .values
        .iter()
        .map(|&v| v as f32)
        .chain(sampler.gpu_floats())
        .flat_map(f32::to_le_bytes)
        .collect();
    let table = Arc::new(table);
    let reference =
        move |v: &[f64], wi: DVec3, wo: DVec3| merl(&table, Lookup::from_index(v[0]), wi, wo);
    Ok(m.with_data(gpu)
        .with_reciprocity()
        .with_tabulated()
        .with_reference(Arc::new(reference))
        .with_sampler(Arc::new(sampler))
        .register()?)
}

/// Reads the MERL file `path` and registers it as a model named [`model_name`], once per file:
/// a second call with the same file returns the same model. A file whose name another model
/// already has (a built-in model, or another file with the same stem) is refused.
pub fn load(path: &Path) -> anyhow::Result<Loaded> {
    let key = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    let mut loaded = LOADED.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(&(model, missing)) = loaded.get(&key) {
        return Ok(Loaded {
            model,
            missing,
            first: false,
        });
    }
    let table = read(path)?;
    let name = model_name(path);
    if let Ok(other) = Model::from_name(&name) {
        anyhow::bail!(
            "{}: its model name '{name}' (the file's stem) is taken by {}; rename the file",
            path.display(),
            match loaded.iter().find(|(_, (m, _))| *m == other) {
                Some((p, _)) => format!("the file {}", p.display()),
                None => format!("the model {name}"),
            }
        );
    }
    let missing = table.missing;
    let file = path.file_name().unwrap_or_default().to_string_lossy();
    let description = format!(
        "MERL measured BRDF from {file}: {missing} of {} values missing (read as 0)",
        3 * BINS
    );
    let model = register(&name, &description, table)?;
    loaded.insert(key, (model, missing));
    Ok(Loaded {
        model,
        missing,
        first: true,
    })
}

/// Whether a model spec names a MERL file (it ends in `.binary`).
pub fn is_merl_path(spec: &str) -> bool {
    spec.ends_with(".binary")
}
