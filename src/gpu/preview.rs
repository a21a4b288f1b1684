//! The GPU path of `lobe preview` (`glsl/kernels/preview.comp`): uploads a scene and one object
//! per cell, shades every pixel of every cell with one model, and reads the radiance back. The
//! scene itself (camera, lights, what the numbers mean) is described in `src/preview/mod.rs`; its
//! f64 twin (`src/backend/shade.rs`) renders the same image.

use super::buffer::Buffer;
use super::pipeline::{Dispatcher, Kernel};
use super::{Gpu, GpuError, Result};
use crate::backend::scene::{LightKind, Scene};
use crate::model::Model;

/// The fixed part of the `Scene` buffer of `preview.comp` (std430).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuSceneHeader {
    /// Cell width, cell height (pixels), cells, lights.
    pub dims: [u32; 4],
    /// tan(vertical field of view / 2), aspect = width / height, unused, unused.
    pub camera: [f32; 4],
    /// RGB radiance of a uniform sky, unused.
    pub ambient: [f32; 4],
}

/// One light of the `Scene` buffer: the std430 twin of `Light` in `preview.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuLight {
    /// xyz; w = 1 a point light at xyz, w = 0 a directional light toward xyz.
    pub position: [f32; 4],
    /// RGB: W/sr for a point light, W/m² at normal incidence for a directional one; w unused.
    pub intensity: [f32; 4],
}

/// One cell's object: the std430 twin of `Object` in `preview.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuObject {
    /// The object's centre in eye space (camera at the origin, looking down −z).
    pub centre: [f32; 3],
    /// The sphere's radius, the icosahedron's circumradius.
    pub radius: f32,
    /// 0 sphere, 1 icosahedron.
    pub shape: u32,
    /// Index of the parameter block that shades it.
    pub param_index: u32,
    /// Padding to the std430 size of 32 bytes; always 0.
    pub pad: [u32; 2],
}

/// The kernel's view of `scene` for `cells` cells: header and lights.
pub fn scene_header(scene: &Scene, cells: usize) -> (GpuSceneHeader, Vec<GpuLight>) {
    let a = scene.ambient;
    let header = GpuSceneHeader {
        dims: [
            scene.cell_width,
            scene.cell_height,
            cells as u32,
            scene.lights.len() as u32,
        ],
        camera: [scene.tan_half_fov as f32, scene.aspect() as f32, 0.0, 0.0],
        ambient: [a.x as f32, a.y as f32, a.z as f32, 0.0],
    };
    let lights = scene
        .lights
        .iter()
        .map(|l| {
            let (p, i) = (l.position, l.intensity);
            let w = match l.kind {
                LightKind::Point => 1.0,
                LightKind::Directional => 0.0,
            };
            GpuLight {
                position: [p.x as f32, p.y as f32, p.z as f32, w],
                intensity: [i.x as f32, i.y as f32, i.z as f32, 0.0],
            }
        })
        .collect();
    (header, lights)
}

/// One object per cell, cell k shaded with parameter block k.
pub fn scene_objects(scene: &Scene, cells: usize) -> Vec<GpuObject> {
    let c = scene.centre;
    (0..cells)
        .map(|k| GpuObject {
            centre: [c.x as f32, c.y as f32, c.z as f32],
            radius: scene.radius as f32,
            shape: scene.shape.code(),
            param_index: k as u32,
            pad: [0; 2],
        })
        .collect()
}

impl Gpu {
    /// Linear RGB radiance of every pixel of `objects.len()` cells, each `header.dims[0]` ×
    /// `header.dims[1]` pixels, in the order (cell, row from the top, column): one `model` for
    /// all, object k shaded with `blocks[objects[k].param_index]` (std430 parameter blocks).
    pub fn render_preview(
        &self,
        model: Model,
        blocks: &[Vec<u8>],
        header: &GpuSceneHeader,
        lights: &[GpuLight],
        objects: &[GpuObject],
    ) -> Result<Vec<[f32; 3]>> {
        let [w, h, cells, n_lights] = header.dims;
        if cells as usize != objects.len() || n_lights as usize != lights.len() {
            return Err(GpuError::Limit(format!(
                "preview scene header says {cells} cells and {n_lights} lights, but {} objects and {} lights were given",
                objects.len(),
                lights.len()
            )));
        }
        if let Some(o) = objects
            .iter()
            .find(|o| o.param_index as usize >= blocks.len())
        {
            return Err(GpuError::Limit(format!(
                "a preview object names parameter block {} of {}",
                o.param_index,
                blocks.len()
            )));
        }
        let pixels = w as u64 * h as u64 * cells as u64;
        if pixels > u32::MAX as u64 {
            return Err(GpuError::Limit(format!(
                "a preview column of {pixels} pixels exceeds the kernel's 32-bit pixel index (at most {}); use smaller cells or fewer materials",
                u32::MAX
            )));
        }
        let pipe = self.pipeline(Kernel::Preview, model, false, false)?;
        let chunk = self.max_chunk(&pipe, 0).min(pixels.max(1));
        let params: Vec<u8> = blocks.concat();
        let mut param_buf = Buffer::new(&self.dev, params.len() as u64, "parameter")?;
        param_buf.write(&params)?;
        let mut scene: Vec<u8> = bytemuck::bytes_of(header).to_vec();
        scene.extend_from_slice(bytemuck::cast_slice(lights));
        let mut scene_buf = Buffer::new(&self.dev, scene.len() as u64, "preview scene")?;
        scene_buf.write(&scene)?;
        let object_bytes: &[u8] = bytemuck::cast_slice(objects);
        let mut object_buf = Buffer::new(&self.dev, object_bytes.len() as u64, "preview object")?;
        object_buf.write(object_bytes)?;
        let out_buf = Buffer::output(&self.dev, chunk * 12, "preview output")?;
        let dispatcher = Dispatcher::new(&pipe, &[&param_buf, &scene_buf, &object_buf, &out_buf])?;
        dispatcher.run_rgb(&out_buf, pixels, chunk, &|| false)
    }
}
