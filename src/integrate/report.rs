//! What `lobe albedo` prints: the directional and hemispherical results with timing, as JSON.

use super::albedo::{directional, hemispherical, HemiAlbedo, PointAlbedo};
use super::{Method, Settings};
use crate::eval::Evaluator;
use crate::model::ParamSet;
use anyhow::Result;
use glam::DVec3;

/// Everything `lobe albedo` prints: directional albedo at each point and the hemispherical one.
#[derive(Clone, Debug)]
pub struct AlbedoReport {
    /// The integrator used.
    pub method: Method,
    /// Nodes per direction asked for (0 for the adaptive reference).
    pub samples: usize,
    /// Directional albedo at each point asked for, in their order.
    pub points: Vec<PointAlbedo>,
    /// Hemispherical albedo and E_avg.
    pub hemispherical: HemiAlbedo,
    /// Wall-clock time of both jobs, seconds.
    pub seconds: f64,
}

/// Directional albedo at `points` (μ, φ radians) and the hemispherical albedo (E_avg at `phi`).
pub fn albedo_report(
    backend: &Evaluator,
    params: &ParamSet,
    s: &Settings,
    points: &[(f64, f64)],
    phi: f64,
) -> Result<AlbedoReport> {
    let start = std::time::Instant::now();
    let pts = directional(backend, params, s, points)?;
    let hemi = hemispherical(backend, params, s, phi)?;
    Ok(AlbedoReport {
        method: s.method,
        samples: s.samples,
        points: pts,
        hemispherical: hemi,
        seconds: start.elapsed().as_secs_f64(),
    })
}

impl AlbedoReport {
    /// The report as `lobe albedo` prints it, with the parameters, the white-furnace switch and
    /// the backend's name.
    pub fn to_json(
        &self,
        params: &ParamSet,
        white_furnace: bool,
        backend: &str,
    ) -> serde_json::Value {
        let a = |v: DVec3| serde_json::json!(v.to_array());
        let points: Vec<_> = self
            .points
            .iter()
            .map(|p| {
                serde_json::json!({
                    "mu": p.mu,
                    "theta_deg": p.mu.acos().to_degrees(),
                    "phi_deg": p.phi.to_degrees(),
                    "albedo": a(p.albedo),
                    "delta": a(p.delta),
                    "error_estimate": a(p.error),
                    "samples": p.samples,
                })
            })
            .collect();
        let h = &self.hemispherical;
        serde_json::json!({
            "model": params.model().name(),
            "parameters": params.to_json(),
            "white_furnace": white_furnace,
            "backend": backend,
            "method": self.method.name(),
            "samples": self.samples,
            "units": "albedo (dimensionless), linear RGB; albedo includes the delta lobe, delta is its part",
            "points": points,
            "hemispherical": {
                "albedo": a(h.albedo),
                "delta": a(h.delta),
                "error_estimate": a(h.error),
                "e_avg": a(h.e_avg),
                "e_avg_error_estimate": a(h.e_avg_error),
                "directions": h.directions,
                "samples": h.samples,
            },
            "seconds": self.seconds,
        })
    }
}
