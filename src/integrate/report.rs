//! What `lobe albedo` prints: the directional and hemispherical results with timing, as JSON,
//! CSV or an aligned table.

use super::albedo::{directional, hemispherical, HemiAlbedo, PointAlbedo};
use super::{Method, Settings};
use crate::backend::Query;
use crate::eval::Evaluator;
use crate::model::ParamSet;
use anyhow::Result;
use glam::DVec3;

/// Everything `lobe albedo` prints: directional albedo at each point and the hemispherical one.
#[derive(Clone, Debug)]
pub struct AlbedoReport {
    /// The integrator used.
    pub method: Method,
    /// Nodes per direction asked for; for the adaptive reference, its budget of evaluations per
    /// job ([`Settings::reference_evals`]).
    pub samples: usize,
    /// The stream a Monte Carlo method drew from ([`Settings::seed`]); None for the rules and
    /// the reference, which draw nothing.
    pub seed: Option<u32>,
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
        samples: if s.method == Method::Reference {
            s.reference_evals() as usize
        } else {
            s.samples
        },
        seed: s.method.sampler().map(|_| s.seed),
        points: pts,
        hemispherical: hemi,
        seconds: start.elapsed().as_secs_f64(),
    })
}

impl AlbedoReport {
    /// The report as `lobe albedo` prints it, with the parameters, the white-furnace switch and
    /// the backend's name.
    pub fn to_json(&self, query: Query, backend: &str) -> serde_json::Value {
        let (params, white_furnace) = (query.params(), query.white_furnace);
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
                    "stopped_short": p.stopped_short,
                    "variance_per_sample": p.variance_per_sample.map(|v| v.to_array()),
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
            "seed": self.seed,
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
                "stopped_short": h.stopped_short,
            },
            "seconds": self.seconds,
        })
    }
}

/// Three channels as `r,g,b` with nine decimals.
fn rgb(v: DVec3) -> String {
    format!("{:.9},{:.9},{:.9}", v.x, v.y, v.z)
}

impl AlbedoReport {
    /// The report as CSV: a header, a `directional` row per point (μ, θ and φ in degrees, albedo,
    /// delta part and error estimate per channel, nodes, and for a Monte Carlo method the
    /// variance per draw per channel, empty otherwise) and one `hemispherical` row.
    pub fn write_csv(&self, out: &mut dyn std::io::Write) -> std::io::Result<()> {
        writeln!(out, "kind,mu,theta_deg,phi_deg,albedo_r,albedo_g,albedo_b,delta_r,delta_g,delta_b,error_r,error_g,error_b,samples,variance_r,variance_g,variance_b")?;
        for p in &self.points {
            let variance = p
                .variance_per_sample
                .map_or_else(|| ",,".to_string(), |v| format!("{},{},{}", v.x, v.y, v.z));
            writeln!(
                out,
                "directional,{},{},{},{},{},{},{},{variance}",
                p.mu,
                p.mu.acos().to_degrees(),
                p.phi.to_degrees(),
                rgb(p.albedo),
                rgb(p.delta),
                rgb(p.error),
                p.samples
            )?;
        }
        let h = &self.hemispherical;
        writeln!(
            out,
            "hemispherical,,,,{},{},{},{},,,",
            rgb(h.albedo),
            rgb(h.delta),
            rgb(h.error),
            h.samples
        )
    }

    /// The report as an aligned table for people: the parameter set, the method and backend, a
    /// row per view direction, the hemispherical albedo with E_avg at `phi_deg`, and the time.
    pub fn write_table(
        &self,
        out: &mut dyn std::io::Write,
        query: Query,
        backend: &str,
        phi_deg: f64,
    ) -> std::io::Result<()> {
        let (params, white_furnace) = (query.params(), query.white_furnace);
        writeln!(out, "{} {}", params.model().name(), params.to_text())?;
        let nodes = if self.method == Method::Reference {
            format!("a budget of {} evaluations", self.samples)
        } else if let Some(seed) = self.seed {
            format!("{} draws per direction, seed {seed}", self.samples)
        } else {
            format!("{} nodes per direction", self.samples)
        };
        writeln!(
            out,
            "method {} ({nodes}) on {}{}",
            self.method.name(),
            backend,
            if white_furnace { ", white furnace" } else { "" }
        )?;
        // A Monte Carlo method also says how spread its draws' weights are (the largest channel's
        // variance per draw: what a sampler is judged by).
        let drawn = self.points.iter().any(|p| p.variance_per_sample.is_some());
        writeln!(
            out,
            "{:>8} {:>8} {:>8}  {:<38} {:<38} {:>10}{}",
            "mu",
            "theta",
            "phi",
            "albedo r,g,b (incl. delta)",
            "delta r,g,b",
            "error est",
            if drawn { "   var/draw" } else { "" }
        )?;
        for p in &self.points {
            let variance = match p.variance_per_sample {
                Some(v) if drawn => format!(" {:>10.2e}", v.max_element()),
                _ => String::new(),
            };
            writeln!(
                out,
                "{:>8.4} {:>8.3} {:>8.3}  {:<38} {:<38} {:>10.2e}{variance}",
                p.mu,
                p.mu.acos().to_degrees(),
                p.phi.to_degrees(),
                rgb(p.albedo),
                rgb(p.delta),
                p.error.max_element()
            )?;
        }
        let h = &self.hemispherical;
        writeln!(
            out,
            "hemispherical albedo {} (delta {}) error est {:.2e}; E_avg at phi {} deg {}",
            rgb(h.albedo),
            rgb(h.delta),
            h.error.max_element(),
            phi_deg,
            rgb(h.e_avg)
        )?;
        for note in self.short_notes() {
            writeln!(out, "{note}")?;
        }
        writeln!(out, "{:.3} s", self.seconds)
    }

    /// One sentence per result the adaptive reference left short of its tolerance: where, why,
    /// and that its error estimate still holds. Empty for the fixed rules.
    pub fn short_notes(&self) -> Vec<String> {
        let why = format!(
            "it spent its budget of {} evaluations, or its panels reached their limit (--samples raises the budget)",
            self.samples
        );
        let mut notes: Vec<String> = self
            .points
            .iter()
            .filter(|p| p.stopped_short)
            .map(|p| {
                format!(
                    "stopped short at mu = {}: {why}; the albedo is as far as it got, within its error estimate {:.2e}",
                    p.mu,
                    p.error.max_element()
                )
            })
            .collect();
        let h = &self.hemispherical;
        if h.stopped_short {
            notes.push(format!(
                "stopped short on the hemispherical albedo: {why}; the value is as far as it got, within its error estimate {:.2e}",
                h.error.max_element()
            ));
        }
        notes
    }
}
