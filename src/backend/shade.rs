//! The CPU twin of `glsl/kernels/preview.comp`, in f64: the camera ray's hit on the cell's
//! object, the radiance the lights send from there toward the camera (the preview job's notes
//! give the scene and the shading frame), and whole cells of it. The functions
//! mirror the kernel line by line, so that the GPU's image can be checked pixel by pixel.

use super::scene::{LightKind, Scene, Shape};
use crate::model::Reference;
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::PI;

/// The golden ratio.
const PHI: f64 = 1.618_033_988_749_895;
/// Inradius / circumradius of a regular icosahedron: φ² / (√3 √(1 + φ²)).
const ICOSAHEDRON_INRADIUS: f64 = 0.794_654_472_291_766_1;

/// Outward unit normal of face k (0..19) of the icosahedron with vertices at the cyclic
/// permutations of (0, ±1, ±φ): the face centres are the vertices of the dual dodecahedron,
/// (±1, ±1, ±1) and the cyclic permutations of (±1/φ, 0, ±φ), all of length √3.
pub fn icosahedron_normal(k: usize) -> DVec3 {
    let sign = |bit: usize| if k & bit != 0 { -1.0 } else { 1.0 };
    let v = if k < 8 {
        DVec3::new(sign(1), sign(2), sign(4))
    } else {
        let j = k - 8;
        let a = if j & 1 != 0 { -1.0 / PHI } else { 1.0 / PHI };
        let b = if j & 2 != 0 { -PHI } else { PHI };
        match j >> 2 {
            0 => DVec3::new(a, 0.0, b),
            1 => DVec3::new(b, a, 0.0),
            _ => DVec3::new(0.0, b, a),
        }
    };
    v / 3f64.sqrt()
}

/// Nearest hit of the ray t·d (t > 0, from the camera at the origin) with the scene's object: t
/// and the outward unit normal.
pub fn intersect(scene: &Scene, d: DVec3) -> Option<(f64, DVec3)> {
    let (c, r) = (scene.centre, scene.radius);
    match scene.shape {
        Shape::Sphere => {
            // Haines, Günther & Akenine-Möller, "Precision improvements for ray/sphere
            // intersection" (Ray Tracing Gems, 2019, ch. 7): the discriminant as r² − |c − b d|²
            // has no cancellation at the silhouette, and the near root as c/q avoids b − √disc.
            let b = d.dot(c);
            let f = c - b * d;
            let disc = r * r - f.dot(f);
            if disc < 0.0 || b <= 0.0 {
                return None;
            }
            let q = b + disc.sqrt();
            let t = (c.dot(c) - r * r) / q;
            Some((t, (t * d - c) / r))
        }
        Shape::Icosahedron => {
            // Convex polyhedron as the intersection of its face half-spaces (Haines, "Fast
            // ray-convex polyhedron intersection", Graphics Gems II, 1991).
            let inradius = r * ICOSAHEDRON_INRADIUS;
            let (mut t_near, mut t_far) = (0.0f64, f64::INFINITY);
            let mut n = DVec3::Z;
            for k in 0..20 {
                let nk = icosahedron_normal(k);
                let offset = inradius + nk.dot(c);
                let denom = nk.dot(d);
                if denom == 0.0 {
                    if offset < 0.0 {
                        return None;
                    }
                    continue;
                }
                let t = offset / denom;
                if denom < 0.0 {
                    if t > t_near {
                        t_near = t;
                        n = nk;
                    }
                } else {
                    t_far = t_far.min(t);
                }
            }
            (t_near > 0.0 && t_near <= t_far).then_some((t_near, n))
        }
    }
}

/// The radiance toward the camera from the point p = t·d with outward normal n.
pub fn shade(r: &Reference, scene: &Scene, p: DVec3, n: DVec3, d: DVec3) -> DVec3 {
    let t = DVec3::Y.cross(n);
    let tl = t.length();
    // Same threshold as the kernel: n within ~1e-6 rad of ±y has no latitude direction.
    let t = if tl > 1e-6 { t / tl } else { DVec3::X };
    let bt = n.cross(t);
    let local = |w: DVec3| DVec3::new(w.dot(t), w.dot(bt), w.dot(n));
    let wo = local(-d);
    let mut radiance = DVec3::ZERO;
    for light in &scene.lights {
        let (to_light, e) = match light.kind {
            LightKind::Point => {
                let l = light.position - p;
                (l, light.intensity / l.length_squared())
            }
            LightKind::Directional => (light.position, light.intensity),
        };
        let wi = local(to_light.normalize());
        radiance += r.eval(wi, wo) * wi.z.max(0.0) * e;
    }
    radiance + scene.ambient * PI * r.eval(DVec3::Z, wo)
}

/// The radiance along the camera ray d (0 where it misses).
pub fn radiance_along(r: &Reference, scene: &Scene, d: DVec3) -> DVec3 {
    match intersect(scene, d) {
        Some((t, n)) => shade(r, scene, t * d, n, d),
        None => DVec3::ZERO,
    }
}

/// Every pixel of one cell per reference, in the GPU's order (cell, row from the top, column).
pub fn render_cells_cpu(refs: &[Reference], scene: &Scene) -> Vec<[f32; 3]> {
    let (w, h) = (scene.cell_width as usize, scene.cell_height as usize);
    let mut out = vec![[0.0f32; 3]; refs.len() * w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(row, line)| {
        let (cell, y) = (row / h, row % h);
        for (x, px) in line.iter_mut().enumerate() {
            let l = radiance_along(&refs[cell], scene, scene.camera_ray(x as u32, y as u32));
            *px = [l.x as f32, l.y as f32, l.z as f32];
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Model, ParamSet};

    #[test]
    fn icosahedron_normals_are_the_twenty_face_directions() {
        let normals: Vec<DVec3> = (0..20).map(icosahedron_normal).collect();
        for (k, n) in normals.iter().enumerate() {
            assert!(
                (n.length() - 1.0).abs() < 1e-12,
                "face {k}: |n| = {}",
                n.length()
            );
            for m in &normals[..k] {
                assert!(n.dot(*m) < 1.0 - 1e-6, "face {k} repeats another");
            }
        }
        // Each vertex (0, ±1, ±φ) touches five faces; their planes all pass through it.
        let circumradius = (1.0 + PHI * PHI).sqrt();
        let vertex = DVec3::new(0.0, 1.0, PHI) / circumradius;
        let touching = normals
            .iter()
            .filter(|n| (n.dot(vertex) - ICOSAHEDRON_INRADIUS).abs() < 1e-12)
            .count();
        assert_eq!(touching, 5);
    }

    #[test]
    fn white_lambertian_reads_one_at_the_nearest_point() {
        let mut p = ParamSet::defaults(Model::Lambert);
        p.set_text("albedo=1").unwrap();
        let r = Reference::new(&p, false);
        for kind in [LightKind::Point, LightKind::Directional] {
            let scene = Scene::lab(65, Shape::Sphere, kind, DVec3::ZERO);
            let l = radiance_along(&r, &scene, -DVec3::Z);
            assert!((l - DVec3::ONE).abs().max_element() < 1e-6, "{kind:?}: {l}");
        }
    }

    #[test]
    fn ambient_is_exact_for_lambert() {
        let mut p = ParamSet::defaults(Model::Lambert);
        p.set_text("albedo=0.5").unwrap();
        let r = Reference::new(&p, false);
        let mut scene = Scene::lab(33, Shape::Sphere, LightKind::Point, DVec3::splat(0.25));
        scene.lights.clear();
        let l = radiance_along(&r, &scene, scene.camera_ray(20, 11));
        assert!((l - DVec3::splat(0.125)).abs().max_element() < 1e-12, "{l}");
    }
}
