//! The exact sum of `lobe light` on the device (`glsl/kernels/light.comp`): the sphere's pixels
//! and the map's texels as the f64 side made them (src/backend/light.rs), rounded to f32 and
//! uploaded once, then one pixel per evaluation in chunks.

use super::buffer::Buffer;
use super::pipeline::{ChunkPush, Dispatcher, Kernel};
use super::{Gpu, GpuError};
use crate::backend::light::{SpherePixel, WeightedTexels};
use crate::interrupt::CancelToken;
use crate::model::Model;

/// Texel evaluations per chunk: about half a second of lavapipe on two cores (~1.5e8 f32
/// evaluations per second), so that Ctrl-C is answered promptly and no chunk nears the
/// per-chunk timeout, yet enough work per submission on a real GPU (thousands of pixels for
/// maps up to 256 × 128).
const EVALS_PER_CHUNK: u64 = 1 << 26;

/// The std430 twin of `Pixel` in `light.comp`: t, b and n with ωo's local coordinates in w.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuLightPixel {
    /// Tangent (world), wo.x.
    pub t: [f32; 4],
    /// Bitangent (world), wo.y.
    pub b: [f32; 4],
    /// Normal (world), wo.z.
    pub n: [f32; 4],
}

/// The std430 twin of `Texel` in `light.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuTexel {
    /// The centre's world direction, 0.
    pub direction: [f32; 4],
    /// L ΔΩ per channel, 0.
    pub weight: [f32; 4],
}

/// The light kernel's first pass (its chunk's `n_wo`, twin of `FRESNEL_PASS` in
/// `glsl/kernels/light.comp`): for a model whose f is a Fresnel factor at c_d = ωi·h times the
/// rest (the microfacet model without a diffuse part or the Kulla–Conty lobe), each texel's
/// weight is multiplied by the factor at c_d = |d + z| / 2 once, rather than f's evaluating it
/// at every pixel (the camera looks along −z, so ωo is +z in the world for every pixel). A pass
/// that changes nothing for the other models.
pub const FRESNEL_PASS: u32 = 1;

fn f32x4(v: glam::DVec3, w: f64) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w as f32]
}

impl Gpu {
    /// The radiance of each of `pixels` under `texels` with `model`'s parameter block `block`,
    /// f32 per channel in the order of `pixels`. Stops between chunks once `cancel` is set.
    pub fn light_pixels(
        &self,
        model: Model,
        block: &[u8],
        texels: &WeightedTexels,
        pixels: &[SpherePixel],
        white_furnace: bool,
        cancel: Option<&CancelToken>,
    ) -> anyhow::Result<Vec<[f32; 3]>> {
        if pixels.is_empty() {
            return Ok(Vec::new());
        }
        let n_texels = texels.terms.len() as u64;
        let rows = n_texels.checked_div(texels.width as u64).unwrap_or(0);
        if rows * texels.width as u64 != n_texels || pixels.len() > u32::MAX as usize {
            return Err(GpuError::Limit(format!(
                "a light request of {} pixels and {n_texels} texels in rows of {}",
                pixels.len(),
                texels.width
            ))
            .into());
        }
        let pipe = self.pipeline(Kernel::Light, model, white_furnace, false)?;
        let texel_bytes = n_texels * std::mem::size_of::<GpuTexel>() as u64;
        let range = self.dev.limits.max_storage_buffer_range as u64;
        let pixel_bytes = 16 + (pixels.len() * std::mem::size_of::<GpuLightPixel>()) as u64;
        if texel_bytes > range || pixel_bytes > range {
            return Err(GpuError::Limit(format!(
                "a map of {n_texels} texels ({texel_bytes} bytes) or {} pixels ({pixel_bytes} bytes) exceeds this device's storage buffer range of {range} bytes",
                pixels.len()
            ))
            .into());
        }
        let gpu_texels: Vec<GpuTexel> = texels
            .terms
            .iter()
            .map(|&(d, w)| GpuTexel {
                direction: f32x4(d, 0.0),
                weight: f32x4(w, 0.0),
            })
            .collect();
        let mut pixel_data: Vec<u8> =
            bytemuck::bytes_of(&[texels.width, rows as u32, 0, 0]).to_vec();
        for p in pixels {
            let wo = p.wo();
            let gp = GpuLightPixel {
                t: f32x4(p.t, wo.x),
                b: f32x4(p.b, wo.y),
                n: f32x4(p.n, wo.z),
            };
            pixel_data.extend_from_slice(bytemuck::bytes_of(&gp));
        }
        let by_work = (EVALS_PER_CHUNK / n_texels.max(1)).max(1);
        let chunk = self
            .max_chunk(&pipe, 0)
            .min(by_work)
            .min(pixels.len() as u64);
        let mut param_buf = Buffer::new(&self.dev, block.len() as u64, "parameter")?;
        param_buf.write(block)?;
        let mut pixel_buf = Buffer::new(&self.dev, pixel_bytes, "light pixels")?;
        pixel_buf.write(&pixel_data)?;
        let mut texel_buf = Buffer::new(&self.dev, texel_bytes.max(32), "environment map")?;
        texel_buf.write(bytemuck::cast_slice(&gpu_texels))?;
        let out_buf = Buffer::output(&self.dev, chunk * 12, "light output")?;
        let dispatcher = Dispatcher::new(&pipe, &[&param_buf, &pixel_buf, &texel_buf, &out_buf])?;
        let by_dispatch = self.dev.limits.max_compute_work_group_count[0] as u64
            * super::pipeline::LOCAL_SIZE as u64;
        let mut first = 0;
        while first < n_texels {
            let count = (n_texels - first).min(by_dispatch);
            dispatcher.run_one(&ChunkPush {
                first: first as u32,
                count: count as u32,
                n_wo: FRESNEL_PASS,
                n_wi: 0,
            })?;
            first += count;
        }
        // Ctrl-C: looked at between chunks; the chunk running finishes first.
        let stop = || cancel.is_some_and(|c| c.check().is_err());
        let out = dispatcher.run_rgb(&out_buf, pixels.len() as u64, chunk, &stop)?;
        if let Some(c) = cancel {
            c.check()?;
        }
        Ok(out)
    }
}

/// Fails the build if the structs drift from the kernel's std430 sizes.
const _: () = assert!(std::mem::size_of::<GpuLightPixel>() == 48);
const _: () = assert!(std::mem::size_of::<GpuTexel>() == 32);
