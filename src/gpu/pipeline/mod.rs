//! Compute pipelines, one per (kernel, model, white furnace), specialised at creation:
//! constant 0 = WHITE_FURNACE, 1 = workgroup size, 2 = evaluations per invocation.
//! A pipeline carries exactly one model; nothing is built until a command needs it.

mod dispatch;

pub use dispatch::Dispatcher;

use super::buffer::Buffer;
use super::device::Device;
use super::error::{Context, GpuError, Result};
use super::CHUNK_TIMEOUT;
use crate::model::kernels::KernelSource;
use ash::vk;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Which kernel of `glsl/kernels/`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// Outer product of a wi list and a wo list (bindings 0 params, 1 wi, 2 wo, 3 out, 4 and 5
    /// wi and wo as texel buffers, 6 the flag of invalid values, cleared before each chunk).
    Table,
    /// Explicit (wi, wo, parameter index) pairs (bindings 0 params, 1 pairs, 3 out).
    Pairs,
    /// `lobe preview`: one shaded pixel per evaluation (bindings 0 params, 1 scene, 2 objects,
    /// 3 out); see glsl/kernels/preview.comp.
    Preview,
    /// Directional albedo as a workgroup reduction over quadrature nodes (bindings 0 params,
    /// 1 nodes, 2 entries, 3 partial sums, 4 the nodes as a texel buffer); see
    /// glsl/kernels/albedo.comp and src/gpu/albedo_kernel.rs.
    Albedo,
    /// Draws of the model's sampler for one ωo (bindings 0 params, 1 the request, 3 out); see
    /// glsl/kernels/sample.comp and [`crate::gpu::Gpu::sample_draws`].
    Sample,
    /// The sampling test's counting: draws of the model's sampler for one ωo counted in cells,
    /// with the draw checks' tallies (bindings 0 params, 1 the request, 2 the counts, cleared
    /// before each chunk, 3 each draw's cell where the host counts them); see
    /// glsl/kernels/chi2.comp and [`crate::gpu::Gpu::chi2_counts`].
    Chi2,
    /// `lobe light`'s exact sum: one lit sphere pixel per evaluation, summed over every texel of
    /// an environment map (bindings 0 params, 1 pixels, 2 texels, 3 out); see
    /// glsl/kernels/light.comp and src/gpu/light.rs.
    Light,
}

impl Kernel {
    /// The kernel's file name in `glsl/kernels/` without its extension, as SPIR-V is looked up.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Table => "table",
            Kernel::Pairs => "pairs",
            Kernel::Preview => "preview",
            Kernel::Albedo => "albedo",
            Kernel::Sample => "sample",
            Kernel::Chi2 => "chi2",
            Kernel::Light => "light",
        }
    }

    /// The kernel's bindings, in the order its buffers are given to [`Dispatcher::new`].
    pub(crate) fn bindings(self) -> &'static [(u32, vk::DescriptorType)] {
        const S: vk::DescriptorType = vk::DescriptorType::STORAGE_BUFFER;
        const T: vk::DescriptorType = vk::DescriptorType::UNIFORM_TEXEL_BUFFER;
        match self {
            // 4 and 5: the wi and wo lists again, as texel buffers (TEXEL_DIRECTIONS).
            Kernel::Table => &[(0, S), (1, S), (2, S), (3, S), (4, T), (5, T), (6, S)],
            Kernel::Pairs | Kernel::Sample => &[(0, S), (1, S), (3, S)],
            Kernel::Chi2 => &[(0, S), (1, S), (2, S), (3, S)],
            Kernel::Preview | Kernel::Light => &[(0, S), (1, S), (2, S), (3, S)],
            // 4: the nodes again, as a texel buffer (TEXEL_NODES).
            Kernel::Albedo => &[(0, S), (1, S), (2, S), (3, S), (4, T)],
        }
    }

    /// The bindings whose buffers each dispatch fills with zeros before the kernel runs.
    pub(crate) fn cleared(self) -> &'static [u32] {
        match self {
            Kernel::Table => &[6],
            Kernel::Chi2 => &[2],
            Kernel::Pairs | Kernel::Preview | Kernel::Albedo | Kernel::Sample | Kernel::Light => {
                &[]
            }
        }
    }
}

/// The binding of a model's data table (a measured BRDF's bins, read-only storage buffer) in
/// every kernel of a model that has one ([`crate::model::Model::data`]): a measured BRDF's bins, the
/// microfacet model's Kulla–Conty table. The pipelines of models without one do not have this
/// binding.
pub const MODEL_DATA_BINDING: u32 = 7;

/// A model's data table on the device, with the device it lives on.
struct ModelData {
    /// Declared before `_dev`, so dropped first.
    buffer: Buffer<'static>,
    _dev: Arc<Device>,
}

// SAFETY: the buffer's mapping is written once, in `ModelData::new`, before the value is shared;
// afterwards only kernels read the buffer, and the `Device` is `Send + Sync`.
unsafe impl Send for ModelData {}
// SAFETY: as for `Send`: no method writes through a shared `ModelData`.
unsafe impl Sync for ModelData {}

impl ModelData {
    /// Uploads `bytes` to a new buffer on `dev`.
    fn new(dev: &Arc<Device>, model: &str, bytes: &[u8]) -> Result<ModelData> {
        let range = dev.limits.max_storage_buffer_range as u64;
        if bytes.len() as u64 > range {
            return Err(GpuError::Limit(format!(
                "the data table of model {model} takes {} bytes, over this device's storage buffer range of {range}",
                bytes.len()
            )));
        }
        let mut buffer = Buffer::new(dev, bytes.len() as u64, "model data")?;
        buffer.write(bytes)?;
        // SAFETY: a `Buffer` uses its `&Device` only to reach the device (in `Drop`); the `Arc`
        // kept beside it holds that `Device` at the same address until after `buffer` is
        // dropped (fields drop in declaration order).
        let buffer = unsafe { std::mem::transmute::<Buffer<'_>, Buffer<'static>>(buffer) };
        Ok(ModelData {
            buffer,
            _dev: dev.clone(),
        })
    }
}

/// Specialization constant id of FAST_POW (glsl/common.glsl).
pub const FAST_POW_ID: u32 = 10;

/// Specialization constant id of a kernel's first own switch ([`Pipeline::kernel_switches`]):
/// TEXEL_DIRECTIONS (glsl/kernels/table.comp) and TEXEL_NODES (glsl/kernels/albedo.comp), read
/// a list through a texel buffer; HOST_COUNTS (glsl/kernels/chi2.comp), store each draw's cell
/// for the host to count. The counting kernel's second, CHECKED, is the next id.
pub const KERNEL_SWITCH_ID: u32 = 20;

/// Specialization constant id of LANE_PARTIALS (glsl/kernels/albedo.comp): every invocation
/// writes its own partial sum, no workgroup tree.
pub const LANE_PARTIALS_ID: u32 = 21;

/// Specialization constant id of UPPER_TRIANGLE (glsl/kernels/table.comp): the packed cells
/// with θo index ≥ θi index of a reciprocal isotropic table (docs/design.md §4.5).
pub const UPPER_TRIANGLE_ID: u32 = 22;

/// Specialization constant id of ROW_ALIGNED (glsl/kernels/table.comp): every invocation's cells
/// lie in one row of the table.
pub const ROW_ALIGNED_ID: u32 = 23;

/// Specialization constant id of INTERLEAVED (glsl/kernels/table.comp): a row-aligned
/// invocation's evaluations run as one interleaved stretch of code.
pub const INTERLEAVED_ID: u32 = 24;

/// How the table kernel walks its cells: its evaluations per invocation and its
/// UPPER_TRIANGLE, ROW_ALIGNED and INTERLEAVED constants.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct TableWalk {
    /// Evaluations per invocation ([`table_evals_per_invocation`]); 0 (unused) for another
    /// kernel.
    pub evals: u32,
    /// The packed upper triangle of a reciprocal isotropic table (docs/design.md §4.5).
    pub upper_triangle: bool,
    /// A row's view cells are a multiple of the evaluations per invocation.
    pub row_aligned: bool,
    /// With `row_aligned`: the invocation reads its view directions 8 at a time and evaluates
    /// each 8 as one stretch of code ([`crate::gpu::table_interleaves`] says where).
    pub interleaved: bool,
}

/// The table kernel's evaluations per invocation for rows of `row` view cells (NDPHI for the
/// upper triangle, the view list's length otherwise) and whether they are row-aligned: on a CPU
/// driver the largest of 64, 32, 16 and 8 that divides a row, else 8 (rows not aligned). Each
/// invocation pays for finding its cell and row (a division per lane, the upper triangle's
/// square root and loops), reading its light direction and the model's terms of it alone, and
/// on lavapipe that cost is a SIMD loop of scalar code: over 64 cells it measured ×1.18 faster
/// than over 8 on the roughconductor table with Mesa 25.0.7. On a GPU 4 (one store of three
/// vec4s per invocation, every lane busy).
pub fn table_evals_per_invocation(cpu_driver: bool, row: u64) -> (u32, bool) {
    if !cpu_driver {
        return (4, row % 4 == 0);
    }
    match [64, 32, 16, 8].into_iter().find(|&e| row % e == 0) {
        Some(e) => (e as u32, true),
        None => (8, false),
    }
}

/// Whether the albedo kernel writes one partial sum per invocation (LANE_PARTIALS) rather than
/// one per workgroup. On a CPU driver a barrier switches between the workgroup's SIMD slices,
/// and the tree's seven barriers per workgroup cost more than storing 64 partials and adding
/// them on the host; on a GPU the tree is cheap and keeps the read-back small.
pub fn albedo_lane_partials(cpu_driver: bool) -> bool {
    cpu_driver
}

/// The format of a direction list read as a texel buffer: one vec4 per direction.
pub const TEXEL_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// Workgroup size. 64 suits lavapipe and is a multiple of every GPU's wave width.
pub const LOCAL_SIZE: u32 = 64;

/// Evaluations one invocation of a kernel other than the table kernel makes (specialization
/// constant 2; the table runner chooses its own, [`table_evals_per_invocation`]). On a CPU driver
/// 4 amortise the invocation overhead; on a GPU one per invocation keeps every lane busy.
pub fn evals_per_invocation(cpu_driver: bool) -> u32 {
    if cpu_driver {
        4
    } else {
        1
    }
}

/// Draws one invocation of the counting kernel (glsl/kernels/chi2.comp) makes: its tallies and
/// largest errors go to the counts once per invocation, and it reads the request, the cells and
/// the parameters and forms the terms of ωo alone once. On lavapipe's two threads, 10⁸ draws of
/// GGX α = 0.3 took 1.12–1.17 s to draw and count at 16 per invocation, 0.95–1.02 s at 64 and
/// 0.92–0.94 s at 256 (one run): 64 keeps 512 workgroups in a host chunk of 2²¹ draws for a CPU
/// of many cores. On a GPU one per invocation keeps every lane busy.
pub fn chi2_draws_per_invocation(cpu_driver: bool) -> u32 {
    if cpu_driver {
        64
    } else {
        1
    }
}

/// Push constants: see `Chunk` in `glsl/kernels/eval.glsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ChunkPush {
    /// Index of the chunk's first element in the whole job.
    pub first: u32,
    /// Number of elements in this chunk.
    pub count: u32,
    /// Length of the wo list (the table kernel; the counting kernel: the cells' steps in φ in
    /// the low 16 bits, in cosθ in the high 16; 0 elsewhere).
    pub n_wo: u32,
    /// Length of the wi list (the table kernel; 0 elsewhere).
    pub n_wi: u32,
}

/// One compute pipeline: a kernel specialised for one model, white furnace on or off, and
/// fast-pow on or off, with its descriptor layout and its running GPU time.
pub struct Pipeline {
    dev: Arc<Device>,
    /// The kernel it runs.
    pub kernel: Kernel,
    module: vk::ShaderModule,
    set_layout: vk::DescriptorSetLayout,
    layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
    /// Evaluations one invocation makes (specialization constant 2): see
    /// [`evals_per_invocation`] and, for the table kernel, [`table_evals_per_invocation`].
    pub evals_per_invocation: u32,
    /// The kernel's own switches (specialization constants [`KERNEL_SWITCH_ID`] and the next):
    /// whether the table kernel reads its direction lists as texel buffers (TEXEL_DIRECTIONS),
    /// the albedo kernel its nodes (TEXEL_NODES); whether the counting kernel stores each
    /// draw's cell for the host to count (HOST_COUNTS) and checks each draw's weight and pdf
    /// (CHECKED). Unused switches are false.
    pub kernel_switches: [bool; 2],
    /// How long creating the pipeline took (the driver compiles the shader here).
    pub build_time: Duration,
    /// `kernel/model-label`, with " (white furnace)" where it applies; used in logs and errors.
    pub label: String,
    /// GPU time of every dispatch so far, from timestamp queries (nanoseconds).
    pub gpu_ns: AtomicU64,
    /// The model's own bound on each chunk's wait, if it has one (else [`CHUNK_TIMEOUT`]).
    pub model_timeout: Option<Duration>,
    /// The model's data table, bound at [`MODEL_DATA_BINDING`] by every dispatcher.
    data: Option<ModelData>,
}

impl Pipeline {
    /// Builds the pipeline of `kernel` from a model's `source`, specialised for
    /// `white_furnace` and `fast_pow`, and times the build.
    pub fn new(
        dev: &Arc<Device>,
        kernel: Kernel,
        source: &KernelSource,
        white_furnace: bool,
        fast_pow: bool,
        kernel_switches: [bool; 2],
        walk: TableWalk,
    ) -> Result<Pipeline> {
        let start = Instant::now();
        let words = read_spirv(source)?;
        let mut p = Pipeline {
            dev: dev.clone(),
            kernel,
            module: vk::ShaderModule::null(),
            set_layout: vk::DescriptorSetLayout::null(),
            layout: vk::PipelineLayout::null(),
            pipeline: vk::Pipeline::null(),
            evals_per_invocation: if kernel == Kernel::Table {
                assert!(
                    walk.evals > 0,
                    "a table pipeline's walk names its evaluations"
                );
                walk.evals
            } else if kernel == Kernel::Chi2 {
                chi2_draws_per_invocation(dev.cpu_kernels())
            } else if kernel == Kernel::Light {
                // One pixel per invocation: its loop over every texel of the map is work
                // enough to carry the invocation's overhead.
                1
            } else {
                evals_per_invocation(dev.cpu_kernels())
            },
            kernel_switches,
            build_time: Duration::ZERO,
            label: pipeline_label(kernel, source, white_furnace, walk),
            gpu_ns: AtomicU64::new(0),
            model_timeout: source.timeout,
            data: None,
        };
        if let Some(bytes) = source.data {
            p.data = Some(ModelData::new(dev, source.model, bytes)?);
        }
        let spec = SpecConstants::of(&p, source, white_furnace, fast_pow, walk);
        // SAFETY: create infos outlive their calls; on failure `p` is dropped and releases what exists.
        unsafe {
            p.create_shader_module(&words)?;
            p.create_layouts()?;
            p.create_compute_pipeline(&spec)?;
        }
        p.build_time = start.elapsed();
        Ok(p)
    }

    /// Creates the shader module of `words`.
    ///
    /// # Safety
    /// Called once, on a pipeline under construction.
    unsafe fn create_shader_module(&mut self, words: &[u32]) -> Result<()> {
        self.module = self
            .dev
            .device
            .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(words), None)
            .ctx("creating a shader module")?;
        Ok(())
    }

    /// Creates the descriptor set layout of the pipeline's bindings and the pipeline layout
    /// (that set and the [`ChunkPush`] push constants).
    ///
    /// # Safety
    /// Called once, on a pipeline under construction.
    unsafe fn create_layouts(&mut self) -> Result<()> {
        let d = &self.dev.device;
        let bindings: Vec<_> = self
            .bindings()
            .iter()
            .map(|&(b, ty)| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(b)
                    .descriptor_type(ty)
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        self.set_layout = d
            .create_descriptor_set_layout(
                &vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings),
                None,
            )
            .ctx("creating a descriptor set layout")?;
        let push = [vk::PushConstantRange::default()
            .stage_flags(vk::ShaderStageFlags::COMPUTE)
            .offset(0)
            .size(std::mem::size_of::<ChunkPush>() as u32)];
        let set_layouts = [self.set_layout];
        self.layout = d
            .create_pipeline_layout(
                &vk::PipelineLayoutCreateInfo::default()
                    .set_layouts(&set_layouts)
                    .push_constant_ranges(&push),
                None,
            )
            .ctx("creating a pipeline layout")?;
        Ok(())
    }

    /// Creates the compute pipeline from the module and layout, specialised by `spec`.
    ///
    /// # Safety
    /// Called once, after [`Pipeline::create_shader_module`] and [`Pipeline::create_layouts`].
    unsafe fn create_compute_pipeline(&mut self, spec: &SpecConstants) -> Result<()> {
        let entries = spec.map_entries();
        let info = vk::SpecializationInfo::default()
            .map_entries(&entries)
            .data(bytemuck::cast_slice(&spec.data));
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(self.module)
            .name(c"main")
            .specialization_info(&info);
        let infos = [vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(self.layout)];
        self.pipeline = self
            .dev
            .device
            .create_compute_pipelines(vk::PipelineCache::null(), &infos, None)
            .map_err(|(_, r)| r)
            .ctx(&format!("creating the compute pipeline {}", self.label))?[0];
        Ok(())
    }

    /// The kernel's bindings, and [`MODEL_DATA_BINDING`] where the model has a data table.
    fn bindings(&self) -> Vec<(u32, vk::DescriptorType)> {
        let data = self
            .data
            .as_ref()
            .map(|_| (MODEL_DATA_BINDING, vk::DescriptorType::STORAGE_BUFFER));
        self.kernel.bindings().iter().copied().chain(data).collect()
    }

    /// Runs the kernel once per chunk over bound buffers (in binding order), waiting for each.
    pub fn dispatch(&self, buffers: &[&Buffer<'_>], chunks: &[ChunkPush]) -> Result<()> {
        Dispatcher::new(self, buffers)?.run(chunks)
    }
}

impl Drop for Pipeline {
    fn drop(&mut self) {
        if self.dev.is_hung() {
            // A timed-out submission may still run this pipeline: leak it.
            return;
        }
        let d = &self.dev.device;
        // SAFETY: the device is idle after every dispatch; release in reverse order of creation.
        unsafe {
            d.destroy_pipeline(self.pipeline, None);
            d.destroy_pipeline_layout(self.layout, None);
            d.destroy_descriptor_set_layout(self.set_layout, None);
            d.destroy_shader_module(self.module, None);
        }
    }
}

/// The words of a model's SPIR-V.
fn read_spirv(source: &KernelSource) -> Result<Vec<u32>> {
    ash::util::read_spv(&mut std::io::Cursor::new(source.spirv)).map_err(|e| {
        GpuError::Limit(format!(
            "embedded SPIR-V for {} is unreadable: {e}",
            source.model
        ))
    })
}

/// `kernel/model-label`, with " (white furnace)", " (upper triangle)", " (rows aligned)" and
/// " (interleaved)" where they apply.
fn pipeline_label(
    kernel: Kernel,
    source: &KernelSource,
    white_furnace: bool,
    walk: TableWalk,
) -> String {
    format!(
        "{}/{}{}{}{}{}",
        kernel.name(),
        source.label,
        if white_furnace {
            " (white furnace)"
        } else {
            ""
        },
        if walk.upper_triangle {
            " (upper triangle)"
        } else {
            ""
        },
        if walk.row_aligned {
            " (rows aligned)"
        } else {
            ""
        },
        if walk.interleaved {
            " (interleaved)"
        } else {
            ""
        }
    )
}

/// A pipeline's specialization constants: their ids and, in the same order, their values.
struct SpecConstants {
    ids: Vec<u32>,
    data: Vec<u32>,
}

impl SpecConstants {
    /// The constants of pipeline `p` (its kernel, evaluations per invocation and texel switch
    /// already set) for a model's `source` and the switches given.
    fn of(
        p: &Pipeline,
        source: &KernelSource,
        white_furnace: bool,
        fast_pow: bool,
        walk: TableWalk,
    ) -> SpecConstants {
        let kernel = p.kernel;
        // Constants 0-2 and FAST_POW_ID are every kernel's; 3.. are the model's component
        // choices (glsl/common.glsl, glsl/brdf/<model>.glsl).
        let mut ids: Vec<u32> = vec![0, 1, 2, FAST_POW_ID];
        let mut data: Vec<u32> = vec![
            white_furnace as u32,
            LOCAL_SIZE,
            p.evals_per_invocation,
            fast_pow as u32,
        ];
        if matches!(kernel, Kernel::Table | Kernel::Albedo | Kernel::Chi2) {
            ids.push(KERNEL_SWITCH_ID);
            data.push(p.kernel_switches[0] as u32);
        }
        if kernel == Kernel::Table {
            ids.extend([UPPER_TRIANGLE_ID, ROW_ALIGNED_ID, INTERLEAVED_ID]);
            data.extend([
                walk.upper_triangle as u32,
                walk.row_aligned as u32,
                walk.interleaved as u32,
            ]);
        }
        if kernel == Kernel::Chi2 {
            ids.push(KERNEL_SWITCH_ID + 1);
            data.push(p.kernel_switches[1] as u32);
        }
        if kernel == Kernel::Albedo {
            ids.push(LANE_PARTIALS_ID);
            data.push(albedo_lane_partials(p.dev.cpu_kernels()) as u32);
        }
        for (k, &v) in source.spec_constants.iter().enumerate() {
            ids.push(3 + k as u32);
            data.push(v);
        }
        SpecConstants { ids, data }
    }

    /// One map entry per constant: constant k's 4 bytes at offset 4k of the data.
    fn map_entries(&self) -> Vec<vk::SpecializationMapEntry> {
        self.ids
            .iter()
            .enumerate()
            .map(|(k, &id)| vk::SpecializationMapEntry {
                constant_id: id,
                offset: 4 * k as u32,
                size: 4,
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The largest of 64, 32, 16 and 8 that divides a row on a CPU driver (the default grid's
    /// NDPHI = 256 takes 64), else 8 and rows not aligned; 4 on a GPU.
    #[test]
    fn table_invocations_take_the_largest_count_that_divides_a_row() {
        assert_eq!(table_evals_per_invocation(true, 256), (64, true));
        assert_eq!(table_evals_per_invocation(true, 96), (32, true));
        assert_eq!(table_evals_per_invocation(true, 48), (16, true));
        assert_eq!(table_evals_per_invocation(true, 24), (8, true));
        assert_eq!(table_evals_per_invocation(true, 90), (8, false));
        assert_eq!(table_evals_per_invocation(true, 9), (8, false));
        assert_eq!(table_evals_per_invocation(false, 256), (4, true));
        assert_eq!(table_evals_per_invocation(false, 6), (4, false));
    }
}
