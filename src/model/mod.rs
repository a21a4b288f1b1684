//! The CPU reference: every model in f64, with the parameter tables the host validates against.
//! Each model lives in its own file beside its GLSL twin `glsl/brdf/<model>.glsl`.

pub mod ashikhmin_shirley;
pub mod blinn_phong;
pub mod cook_torrance;
pub mod coupled;
pub mod eon;
pub mod kulla_conty;
pub mod lambert;
pub mod merl;
pub mod microfacet;
pub mod oren_nayar;
pub mod params;
pub mod phong;
pub mod registry;
pub use registry::{components, info, kernels, runtime, sampling};
pub mod sample;
pub mod smooth_layered;
pub mod split_sum;
pub mod terms;

use eon::EonConfig;
use glam::{DVec2, DVec3};
pub use info::{LutAxis, ModelInfo};
use microfacet::MicrofacetConfig;
pub use params::{ParamError, ParamKind, ParamSpec, Value, SLOPE_FLOOR};
use sample::Sample;
use std::collections::{BTreeMap, BTreeSet};

/// Field names and byte offsets of a std430 parameter block, checked against the SPIR-V.
pub type Layout = &'static [(&'static str, usize)];

pub(crate) fn f32x3(v: DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// The closed set of models; the GPU selects the same set by pipeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Model {
    /// Ideal diffuse, f = albedo/π.
    Lambert,
    /// Normalized Phong (Lafortune & Willems 1994), a cosⁿ lobe about the mirror direction.
    Phong,
    /// Normalized Blinn–Phong, a cosᴺ lobe of the half vector.
    BlinnPhong,
    /// Oren & Nayar 1994, rough diffuse (the qualitative model).
    OrenNayar,
    /// Cook & Torrance 1982: Beckmann D, V-cavity G, Schlick's Fresnel, plus diffuse.
    CookTorrance,
    /// Shirley's smooth layered model: a Fresnel mirror spike over Lambert.
    SmoothLayered,
    /// Shirley et al. 1997: a mirror spike plus an energy-coupled matte term.
    Coupled,
    /// Ashikhmin & Shirley 2000, the anisotropic Phong model.
    AshikhminShirley,
    /// The general microfacet model; its components are part of the model because each choice
    /// is a different pipeline (specialization constants).
    Microfacet(MicrofacetConfig),
    /// Portsmouth, Kutz & Hill 2025, the energy-preserving Oren–Nayar model; its
    /// multiple-scattering choice is part of the model because each is a different pipeline.
    Eon(EonConfig),
    /// A model defined at run time ([`runtime::RuntimeModel`]): SPIR-V kernels from the caller,
    /// and an f64 reference only where the caller gave one.
    Runtime(&'static runtime::RuntimeModel),
}

impl Model {
    /// The built-in models, each once; the microfacet and EON models with their default
    /// components.
    pub const ALL: [Model; 10] = [
        Model::Lambert,
        Model::Phong,
        Model::BlinnPhong,
        Model::OrenNayar,
        Model::CookTorrance,
        Model::SmoothLayered,
        Model::Coupled,
        Model::AshikhminShirley,
        Model::Microfacet(MicrofacetConfig::DEFAULT),
        Model::Eon(EonConfig::DEFAULT),
    ];

    /// Whether f carries the V-cavity masking min(1, 2 c_h min(c_i, c_o)/c_d), whose kinks the
    /// albedo integrator puts on panel edges.
    pub fn has_v_cavity_masking(self) -> bool {
        (self.info().v_cavity)(self)
    }

    /// Whether the model's GLSL takes ωi + ωo from the caller (`MODEL_EVAL_SUM`, e.g.
    /// `microfacet_from_sum`), so that the albedo kernel can hand it the sum formed exactly from
    /// a node's offset from the mirror direction of ωo (`glsl/kernels/albedo.comp`): the models
    /// whose lobe is a function of the half vector or of the mirror direction.
    pub fn sums_from_mirror_offsets(self) -> bool {
        matches!(
            self,
            Model::Phong
                | Model::BlinnPhong
                | Model::CookTorrance
                | Model::AshikhminShirley
                | Model::Microfacet(_)
        )
    }

    /// The name used on the command line, in file names and in the GLSL function.
    pub fn name(self) -> &'static str {
        self.info().name
    }

    /// Looks a model up by name: the built-in models, then those registered at run time.
    pub fn from_name(name: &str) -> Result<Model, ParamError> {
        let known = || Model::ALL.into_iter().chain(runtime::registered());
        known()
            .find(|m| m.name() == name)
            .ok_or_else(|| ParamError::UnknownModel {
                name: name.to_string(),
                list: known().map(Model::name).collect::<Vec<_>>().join(", "),
            })
    }

    /// Whether the model has an f64 CPU reference (every built-in model does).
    pub fn has_reference(self) -> bool {
        match self {
            Model::Runtime(r) => r.reference().is_some(),
            _ => true,
        }
    }

    /// `Err(NoReference)` for a model without an f64 reference; `job` says what needed it.
    pub fn require_reference(self, job: &str) -> Result<(), runtime::NoReference> {
        if self.has_reference() {
            Ok(())
        } else {
            Err(runtime::NoReference {
                model: self.name().to_string(),
                why: match self {
                    Model::Runtime(r) => r.no_reference_note().to_string(),
                    _ => String::new(),
                },
                job: job.to_string(),
            })
        }
    }

    /// Whether f(ωi, ωo) = f(ωo, ωi) for every parameter set, so that a lobe table may copy a
    /// cell's mirror image instead of evaluating it (docs/design.md §4.5). Every built-in model
    /// is reciprocal; a model defined at run time only where it says so
    /// ([`runtime::RuntimeModel::with_reciprocity`]: MERL tables do, `.brdf` files do not).
    pub fn is_reciprocal(self) -> bool {
        match self {
            Model::Runtime(r) => r.is_reciprocal(),
            _ => true,
        }
    }

    /// Whether f is read from a table by its bins (a MERL file), with jumps or kinks on every
    /// bin boundary ([`runtime::RuntimeModel::with_tabulated`]); every built-in model is smooth
    /// within the albedo rules' panels (their kinks lie on the panels' edges).
    pub fn is_tabulated(self) -> bool {
        match self {
            Model::Runtime(r) => r.is_tabulated(),
            _ => false,
        }
    }

    /// Whether f is unchanged, for every parameter set, when both directions are mirrored across
    /// the xz plane (y → −y) or across the yz plane (x → −x), so that a full table may copy
    /// three quarters of its cells (docs/design.md §4.6). Every built-in model is: its
    /// anisotropic roughness runs along t = x and b = y, and it reads the tangential components
    /// only through their squares or through dot products that either mirror keeps
    /// (`tests/properties.rs` checks each). A model defined at run time is not declared so; an
    /// isotropic and reciprocal one is even in Δφ, which gives the same (the evaluator checks
    /// that).
    pub fn is_mirror_symmetric(self) -> bool {
        !matches!(self, Model::Runtime(_))
    }

    /// The bound on each chunk's GPU wait that the model sets for itself (a model defined at
    /// run time may: [`runtime::RuntimeModel::with_chunk_timeout`]).
    pub fn chunk_timeout(self) -> Option<std::time::Duration> {
        match self {
            Model::Runtime(r) => r.chunk_timeout(),
            _ => None,
        }
    }

    /// The SPIR-V of `kernel` for this model: built into the binary, or given at run time.
    pub fn spirv(self, kernel: &str) -> Option<&'static [u8]> {
        match self {
            Model::Runtime(r) => r.kernel(kernel),
            m => kernels::spirv(kernel, m.name()),
        }
    }

    /// What the Vulkan runner builds `kernel` of this model from; None where the model has no
    /// such kernel.
    pub fn kernel_source(self, kernel: &str) -> Option<kernels::KernelSource> {
        Some(kernels::KernelSource {
            label: self.label(),
            model: self.name(),
            spirv: self.spirv(kernel)?,
            spec_constants: self.spec_constants(),
            data: self.data(),
            timeout: self.chunk_timeout(),
            mirror_offsets: self.sums_from_mirror_offsets(),
        })
    }

    /// The data table this model's kernels read at
    /// [`crate::gpu::pipeline::MODEL_DATA_BINDING`], if it has one: a measured BRDF's bins, or
    /// for `microfacet` the Kulla–Conty table of its distribution and masking
    /// ([`kulla_conty::Table::gpu`]; its kernels declare the table, so every microfacet pipeline
    /// binds it, used or not). Other built-in models have none.
    pub fn data(self) -> Option<&'static [u8]> {
        match self {
            Model::Runtime(r) => r.data(),
            Model::Microfacet(c) => Some(&kulla_conty::tables()[kulla_conty::table_index(c)].gpu),
            _ => None,
        }
    }

    /// One line for `lobe models`.
    pub fn description(self) -> &'static str {
        self.info().description
    }

    /// The parameter table.
    pub fn params(self) -> &'static [ParamSpec] {
        self.info().params
    }

    /// Name of the std430 parameter struct on both sides (`CookTorranceParams`).
    pub fn gpu_struct_name(self) -> &'static str {
        self.info().gpu_struct
    }

    /// Field offsets and size of the parameter block, for the layout test.
    pub fn gpu_layout(self) -> (Layout, usize) {
        (self.info().gpu_layout, self.info().gpu_size)
    }

    /// Models with a mirror spike that tables cannot hold (docs/design.md §3).
    pub fn has_delta(self) -> bool {
        self.info().has_delta
    }

    /// Whether a Fresnel factor multiplies a specular lobe, i.e. the white furnace changes it.
    pub fn has_specular_fresnel(self) -> bool {
        self.info().has_specular_fresnel
    }

    /// Specialization constants 3.. of this model's pipelines (its component choices).
    pub fn spec_constants(self) -> Vec<u32> {
        match self {
            Model::Microfacet(c) => c.spec_constants().to_vec(),
            Model::Eon(c) => c.spec_constants().to_vec(),
            _ => Vec::new(),
        }
    }
}

/// A validated, complete parameter set for one model: every key of the model's table, in range.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamSet {
    model: Model,
    values: BTreeMap<&'static str, Value>,
    /// Keys set explicitly (not left at their default), for parameters whose absence means
    /// something (the microfacet model's alpha_x, alpha_y and f0).
    explicit: BTreeSet<&'static str>,
}

impl ParamSet {
    /// The model's defaults.
    pub fn defaults(model: Model) -> ParamSet {
        let values = model
            .params()
            .iter()
            .map(|s| (s.key, s.default_value()))
            .collect();
        let mut set = ParamSet {
            model,
            values,
            explicit: BTreeSet::new(),
        };
        // A model that carries component choices sets them; they stay defaults (not explicit).
        let choices: Vec<(&'static str, &'static str)> = match model {
            Model::Microfacet(c) => c.choices().to_vec(),
            Model::Eon(c) => c.choices().to_vec(),
            _ => Vec::new(),
        };
        for (key, name) in choices {
            set.values.insert(key, Value::Choice(name));
        }
        // A model defined at run time may start a key from other values than its table's.
        if let Model::Runtime(r) = model {
            set.values.extend(r.defaults().iter().copied());
        }
        set
    }

    /// Keeps a model that carries component choices in step with the values.
    fn sync_model(&mut self) {
        match self.model {
            Model::Microfacet(_) => {
                self.model = Model::Microfacet(MicrofacetConfig::from_values(|k| self.values[k]));
            }
            Model::Eon(_) => self.model = Model::Eon(EonConfig::from_values(|k| self.values[k])),
            _ => {}
        }
    }

    /// Whether `key` was set explicitly rather than left at its default.
    pub fn is_set(&self, key: &str) -> bool {
        self.explicit.contains(key)
    }

    /// The model the set belongs to, with its current component choices.
    pub fn model(&self) -> Model {
        self.model
    }

    fn spec(&self, key: &str) -> Result<&'static ParamSpec, ParamError> {
        self.model
            .params()
            .iter()
            .find(|s| s.key == key)
            .ok_or_else(|| ParamError::UnknownKey {
                key: key.to_string(),
                model: self.model.name().to_string(),
                list: self
                    .model
                    .params()
                    .iter()
                    .map(|s| s.key)
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }

    /// Sets one parameter, validating the key, the shape and every channel's range.
    pub fn set(&mut self, key: &str, value: Value) -> Result<(), ParamError> {
        let spec = self.spec(key)?;
        let shape_ok = match (spec.kind, value) {
            (ParamKind::Choice(options), Value::Choice(name)) => options.contains(&name),
            (ParamKind::Choice(_), _) | (_, Value::Choice(_)) => false,
            (ParamKind::Scalar | ParamKind::Flag, Value::Three(_)) => false,
            (ParamKind::Flag, Value::One(v)) => v == 0.0 || v == 1.0,
            _ => true,
        };
        if !shape_ok {
            let expected = match spec.kind {
                ParamKind::Choice(options) => format!("one of: {}", options.join(", ")),
                ParamKind::Scalar => "a number".to_string(),
                ParamKind::Rgb => "one number or r,g,b".to_string(),
                ParamKind::Flag => params::FLAG_VALUES.to_string(),
            };
            return Err(ParamError::Malformed {
                key: key.to_string(),
                text: value.to_string(),
                expected,
            });
        }
        for v in value.numbers() {
            spec.check(v)?;
        }
        let value = match value {
            Value::One(v) if v < spec.floor => Value::One(spec.floor),
            v => v,
        };
        self.values.insert(spec.key, value);
        self.explicit.insert(spec.key);
        self.sync_model();
        Ok(())
    }

    /// Parses and sets `key=value` as given to `--set`.
    pub fn set_text(&mut self, assignment: &str) -> Result<(), ParamError> {
        let (key, text) = assignment
            .split_once('=')
            .ok_or_else(|| ParamError::NotKeyValue {
                text: assignment.to_string(),
            })?;
        let key = key.trim();
        let spec = self.spec(key)?;
        let value = Value::parse(spec, text.trim())?;
        self.set(key, value)
    }

    /// The value of `key` (panics on an unknown key: the key lists are static).
    pub fn get(&self, key: &str) -> Value {
        self.values[key]
    }

    /// An RGB parameter as a vector (panics on an unknown key: the key lists are static).
    pub fn rgb(&self, key: &str) -> DVec3 {
        DVec3::from_array(self.values[key].rgb())
    }

    /// A scalar parameter, or the first channel of an RGB one (panics on an unknown key).
    pub fn scalar(&self, key: &str) -> f64 {
        self.values[key].rgb()[0]
    }

    /// (key, value) in the order of the model's table; optional keys (whose absence means
    /// something, such as the microfacet model's alpha_x) only when set.
    pub fn entries(&self) -> Vec<(&'static str, Value)> {
        self.model
            .params()
            .iter()
            .filter(|s| !self.model.info().optional_keys.contains(&s.key) || self.is_set(s.key))
            .map(|s| (s.key, self.values[s.key]))
            .collect()
    }

    /// Whether `key` changes f under this set's component choices. Every key does, except in
    /// the microfacet model: `ior` only for fresnel=dielectric, or schlick without `f0`; `f0`
    /// only for schlick; `eta` and `k` only for conductor; `beckmann_g1` only for Smith masking
    /// of the Beckmann distribution; `alpha` not when both `alpha_x` and `alpha_y` are set.
    pub fn is_active(&self, key: &str) -> bool {
        if !matches!(self.model, Model::Microfacet(_)) {
            return true;
        }
        let choice = |k: &str| match self.values.get(k) {
            Some(Value::Choice(name)) => *name,
            _ => "",
        };
        let fresnel = choice("fresnel");
        match key {
            "ior" => fresnel == "dielectric" || (fresnel == "schlick" && !self.is_set("f0")),
            "f0" => fresnel == "schlick",
            "eta" | "k" => fresnel == "conductor",
            "beckmann_g1" => {
                choice("distribution") == "beckmann" && choice("masking") != "v_cavity"
            }
            "alpha" => !(self.is_set("alpha_x") && self.is_set("alpha_y")),
            _ => true,
        }
    }

    /// The [`entries`](ParamSet::entries) that are [active](ParamSet::is_active).
    pub fn active_entries(&self) -> Vec<(&'static str, Value)> {
        self.entries()
            .into_iter()
            .filter(|(k, _)| self.is_active(k))
            .collect()
    }

    /// The same set with every value rounded to f32, as the GPU receives it.
    pub fn rounded_to_f32(&self) -> ParamSet {
        let mut out = self.clone();
        for v in out.values.values_mut() {
            *v = match *v {
                Value::One(x) => Value::One(x as f32 as f64),
                Value::Three(c) => Value::Three(c.map(|x| x as f32 as f64)),
                Value::Choice(name) => Value::Choice(name),
            };
        }
        out
    }

    /// Whether f depends on φi and φo only through φo − φi (the model decides: Ashikhmin–Shirley
    /// and microfacet are anisotropic when their two roughnesses differ).
    pub fn is_isotropic(&self) -> bool {
        (self.model.info().is_isotropic)(self)
    }

    /// A compact one-line form, `diffuse=0.2 specular=0.8,0.7,0.1 roughness=0.3`.
    pub fn to_text(&self) -> String {
        self.entries()
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(" ")
    }

    /// The set as a JSON object `{key: value}`, in the keys of [`ParamSet::entries`].
    pub fn to_json(&self) -> serde_json::Value {
        let mut map = serde_json::Map::new();
        for (k, v) in self.entries() {
            let j = match v {
                Value::One(x) => serde_json::json!(x),
                Value::Three(c) => serde_json::json!(c),
                Value::Choice(name) => serde_json::json!(name),
            };
            map.insert(k.to_string(), j);
        }
        serde_json::Value::Object(map)
    }
}

/// A model with its parameters resolved into the typed struct the formulas take.
#[derive(Clone, Copy, Debug)]
pub enum Brdf {
    /// Parameters of [`Model::Lambert`].
    Lambert(lambert::Lambert),
    /// Parameters of [`Model::Phong`].
    Phong(phong::Phong),
    /// Parameters of [`Model::BlinnPhong`].
    BlinnPhong(blinn_phong::BlinnPhong),
    /// Parameters of [`Model::OrenNayar`].
    OrenNayar(oren_nayar::OrenNayar),
    /// Parameters of [`Model::CookTorrance`].
    CookTorrance(cook_torrance::CookTorrance),
    /// Parameters of [`Model::SmoothLayered`].
    SmoothLayered(smooth_layered::SmoothLayered),
    /// Parameters of [`Model::Coupled`].
    Coupled(coupled::Coupled),
    /// Parameters of [`Model::AshikhminShirley`].
    AshikhminShirley(ashikhmin_shirley::AshikhminShirley),
    /// Parameters of [`Model::Microfacet`], with its component choices.
    Microfacet(microfacet::Microfacet),
    /// Parameters of [`Model::Eon`], with its multiple-scattering choice.
    Eon(eon::Eon),
    /// Parameters of a [`Model::Runtime`] model.
    Runtime(runtime::RuntimeBrdf),
}

/// A model ready to evaluate on the CPU: parameters plus the white-furnace switch.
#[derive(Clone, Copy, Debug)]
pub struct Reference {
    /// The model and its parameters.
    pub brdf: Brdf,
    /// Whether every Fresnel factor of a specular lobe is 1 (the white furnace, docs/design.md §3).
    pub white_furnace: bool,
}

impl Brdf {
    /// Resolves a validated parameter set into its model's struct.
    pub fn new(p: &ParamSet) -> Brdf {
        match p.model() {
            Model::Lambert => Brdf::Lambert(lambert::Lambert::new(p)),
            Model::Phong => Brdf::Phong(phong::Phong::new(p)),
            Model::BlinnPhong => Brdf::BlinnPhong(blinn_phong::BlinnPhong::new(p)),
            Model::OrenNayar => Brdf::OrenNayar(oren_nayar::OrenNayar::new(p)),
            Model::CookTorrance => Brdf::CookTorrance(cook_torrance::CookTorrance::new(p)),
            Model::SmoothLayered => Brdf::SmoothLayered(smooth_layered::SmoothLayered::new(p)),
            Model::Coupled => Brdf::Coupled(coupled::Coupled::new(p)),
            Model::AshikhminShirley => {
                Brdf::AshikhminShirley(ashikhmin_shirley::AshikhminShirley::new(p))
            }
            Model::Microfacet(_) => Brdf::Microfacet(microfacet::Microfacet::new(p)),
            Model::Eon(_) => Brdf::Eon(eon::Eon::new(p)),
            Model::Runtime(r) => Brdf::Runtime(runtime::RuntimeBrdf::new(r, p)),
        }
    }

    /// The std430 parameter block the GPU kernels read, as bytes.
    pub fn gpu_block(&self) -> Vec<u8> {
        use bytemuck::bytes_of;
        match self {
            Brdf::Lambert(m) => bytes_of(&m.gpu_params()).to_vec(),
            Brdf::Phong(m) => bytes_of(&m.gpu_params()).to_vec(),
            Brdf::BlinnPhong(m) => bytes_of(&m.gpu_params()).to_vec(),
            Brdf::OrenNayar(m) => bytes_of(&m.gpu_params()).to_vec(),
            Brdf::CookTorrance(m) => bytes_of(&m.gpu_params()).to_vec(),
            Brdf::SmoothLayered(m) => bytes_of(&m.gpu_params()).to_vec(),
            Brdf::Coupled(m) => bytes_of(&m.gpu_params()).to_vec(),
            Brdf::AshikhminShirley(m) => bytes_of(&m.gpu_params()).to_vec(),
            Brdf::Microfacet(m) => bytes_of(&m.gpu_params()).to_vec(),
            Brdf::Eon(m) => bytes_of(&m.gpu_params()).to_vec(),
            Brdf::Runtime(m) => m.gpu_block(),
        }
    }
}

impl Reference {
    /// The reference for `p`, with or without the white furnace.
    pub fn new(p: &ParamSet, white_furnace: bool) -> Reference {
        Reference {
            brdf: Brdf::new(p),
            white_furnace,
        }
    }

    /// f(ωi, ωo) in 1/sr, without the cosine; 0 below the horizon (docs/design.md §2). Delta
    /// lobes excluded.
    pub fn eval(&self, wi: DVec3, wo: DVec3) -> DVec3 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return DVec3::ZERO;
        }
        let wf = self.white_furnace;
        match &self.brdf {
            Brdf::Lambert(p) => lambert::lambert(p, wi, wo),
            Brdf::Phong(p) => phong::phong(p, wi, wo),
            Brdf::BlinnPhong(p) => blinn_phong::blinn_phong(p, wi, wo),
            Brdf::OrenNayar(p) => oren_nayar::oren_nayar(p, wi, wo),
            Brdf::CookTorrance(p) => cook_torrance::cook_torrance(p, wi, wo, wf),
            Brdf::SmoothLayered(p) => smooth_layered::smooth_layered(p, wi, wo),
            Brdf::Coupled(p) => coupled::coupled(p, wi, wo),
            Brdf::AshikhminShirley(p) => ashikhmin_shirley::ashikhmin_shirley(p, wi, wo, wf),
            Brdf::Microfacet(p) => microfacet::microfacet(p, wi, wo, wf),
            Brdf::Eon(p) => eon::eon(p, wi, wo),
            Brdf::Runtime(p) => p.eval(wi, wo),
        }
    }

    /// Draws ωi for ωo (docs/design.md §13) with the model's sampler: `uc` chooses a
    /// component of a mixture, `u` draws within it. The weight is f cos θi / pdf with f as
    /// [`Reference::eval`] gives it (the white furnace included); a draw below the horizon, and
    /// any draw for ωo below it, has weight 0 and pdf 0. A model defined at run time is drawn
    /// by its own sampler where it has one, by the cosine otherwise; without an f64 reference it has no f, and its weight is NaN as
    /// its `eval` is (jobs refuse such models before they sample).
    pub fn sample(&self, wo: DVec3, uc: f64, u: DVec2) -> Sample {
        if wo.z <= 0.0 {
            return Sample::lost(sample::mirror(wo));
        }
        let wf = self.white_furnace;
        match &self.brdf {
            Brdf::Lambert(p) => lambert::sample_lambert(p, wo, uc, u),
            Brdf::Phong(p) => phong::sample_phong(p, wo, uc, u),
            Brdf::BlinnPhong(p) => blinn_phong::sample_blinn_phong(p, wo, uc, u),
            Brdf::OrenNayar(p) => oren_nayar::sample_oren_nayar(p, wo, uc, u),
            Brdf::CookTorrance(p) => cook_torrance::sample_cook_torrance(p, wo, uc, u, wf),
            Brdf::SmoothLayered(p) => smooth_layered::sample_smooth_layered(p, wo, uc, u),
            Brdf::Coupled(p) => coupled::sample_coupled(p, wo, uc, u),
            Brdf::AshikhminShirley(p) => {
                ashikhmin_shirley::sample_ashikhmin_shirley(p, wo, uc, u, wf)
            }
            Brdf::Microfacet(p) => microfacet::sample_microfacet(p, wo, uc, u, wf),
            Brdf::Eon(p) => eon::sample_eon(p, wo, uc, u),
            Brdf::Runtime(p) => p.sample(wo, uc, u),
        }
    }

    /// The density over the solid angle of ωi of [`Reference::sample`]'s non-delta draws; 0
    /// unless both directions are above the horizon.
    pub fn pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let wf = self.white_furnace;
        match &self.brdf {
            Brdf::Lambert(p) => lambert::pdf_lambert(p, wi, wo),
            Brdf::Phong(p) => phong::pdf_phong(p, wi, wo),
            Brdf::BlinnPhong(p) => blinn_phong::pdf_blinn_phong(p, wi, wo),
            Brdf::OrenNayar(p) => oren_nayar::pdf_oren_nayar(p, wi, wo),
            Brdf::CookTorrance(p) => cook_torrance::pdf_cook_torrance(p, wi, wo, wf),
            Brdf::SmoothLayered(p) => smooth_layered::pdf_smooth_layered(p, wi, wo),
            Brdf::Coupled(p) => coupled::pdf_coupled(p, wi, wo),
            Brdf::AshikhminShirley(p) => ashikhmin_shirley::pdf_ashikhmin_shirley(p, wi, wo, wf),
            Brdf::Microfacet(p) => microfacet::pdf_microfacet(p, wi, wo, wf),
            Brdf::Eon(p) => eon::pdf_eon(p, wi, wo),
            Brdf::Runtime(p) => p.pdf(wi, wo),
        }
    }

    /// The albedo of the delta lobe seen from c_o (zero for models without one).
    pub fn delta_albedo(&self, c_o: f64) -> DVec3 {
        match &self.brdf {
            Brdf::SmoothLayered(p) => smooth_layered::smooth_layered_delta(p, c_o),
            Brdf::Coupled(p) => coupled::coupled_delta(p, c_o),
            _ => DVec3::ZERO,
        }
    }
}
