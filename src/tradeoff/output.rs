//! The report as text: aligned tables per section with their notes and Pareto fronts, CSV (one
//! line per variant) and JSON (everything, set-up included).

use super::{Report, Row, Section, REL_FLOOR};
use crate::integrate::REFERENCE_RTOL;

/// A CSV field, quoted where it holds a comma or a quote (variant names do).
fn csv_field(s: &str) -> String {
    if s.contains(',') || s.contains('"') {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

impl Report {
    /// A line per section: what its cost and error mean.
    pub fn section_note(&self, section: Section) -> String {
        let o = &self.options;
        match section {
            Section::Evaluation => format!(
                "cost: ns per evaluation of a {}-cell lobe table, median of {} runs (GPU: kernel \
                 time from timestamp queries; CPU: wall clock, all cores); error: relative error of f \
                 over {} cells ({} grid), floor {} x max|f|, against f64 {} {}",
                o.timing_grid.cells().unwrap_or(0),
                o.eval_repeats,
                o.error_grid.cells().unwrap_or(0),
                o.error_grid.name(),
                REL_FLOOR,
                self.truth.model().name(),
                self.truth.to_text()
            ),
            Section::Integration => format!(
                "cost: wall-clock ms per directional albedo from scratch (nodes, evaluation, sum; \
                 GPU: upload, dispatch, read-back too; kernel ms: timestamp queries), median of {} \
                 runs; error: max |E - E_ref| over mu = {} and channels",
                o.albedo.repeats,
                self.mu_list()
            ),
            Section::TableResolution => format!(
                "cost: wall-clock ms to generate an N x N x 2N isotropic table (theta_i, theta_o, \
                 dphi) and integrate it at every mu (linear in theta_o, cell sums in theta_i and \
                 dphi), median of {} runs; error: max |E - E_ref| over mu = {} and channels",
                o.albedo.repeats,
                self.mu_list()
            ),
        }
    }

    fn mu_list(&self) -> String {
        self.options
            .albedo
            .mus
            .iter()
            .map(|m| format!("{m}"))
            .collect::<Vec<_>>()
            .join(",")
    }

    /// The reference line of the albedo sections.
    pub fn reference_note(&self) -> Option<String> {
        if self.reference.is_empty() {
            return None;
        }
        let values: Vec<String> = self
            .options
            .albedo
            .mus
            .iter()
            .zip(&self.reference)
            .map(|(mu, e)| {
                let v = e.value;
                format!("E({mu}) = {:.9},{:.9},{:.9}", v.x, v.y, v.z)
            })
            .collect();
        let est = self
            .reference
            .iter()
            .map(|e| e.error.max_element())
            .fold(0.0, f64::max);
        Some(format!(
            "reference (adaptive Gauss-Kronrod, f64, rtol {REFERENCE_RTOL:e}, delta lobes excluded): {}; its error estimate <= {est:.1e}",
            values.join("; ")
        ))
    }

    /// The whole report as JSON: subject, parameters, truth, grids, albedo set-up and reference,
    /// sections with their notes, Pareto fronts and rows.
    pub fn to_json(&self) -> serde_json::Value {
        let o = &self.options;
        let reference: Vec<_> = o
            .albedo
            .mus
            .iter()
            .zip(&self.reference)
            .map(|(mu, e)| {
                serde_json::json!({
                    "mu": mu,
                    "albedo": e.value.to_array(),
                    "error_estimate": e.error.to_array(),
                })
            })
            .collect();
        let fronts: serde_json::Map<String, serde_json::Value> = self
            .sections()
            .into_iter()
            .map(|s| {
                let names: Vec<&str> = self
                    .rows_of(s)
                    .filter(|r| r.pareto)
                    .map(|r| r.variant.as_str())
                    .collect();
                (s.name().to_string(), serde_json::json!(names))
            })
            .collect();
        serde_json::json!({
            "model": self.params.model().name(),
            "subject": self.subject,
            "parameters": self.params.to_json(),
            "device": self.device,
            "truth": {"model": self.truth.model().name(), "parameters": self.truth.to_json()},
            "error_grid": o.error_grid.shape(),
            "timing_grid": o.timing_grid.shape(),
            "relative_error_floor": REL_FLOOR,
            "albedo": {
                "mu": o.albedo.mus,
                "samples": o.albedo.samples,
                "table_res": o.albedo.table_res,
                "repeats": o.albedo.repeats,
                "reference_rtol": REFERENCE_RTOL,
                "reference": reference,
            },
            "sections": self.sections().into_iter().map(|s| serde_json::json!({
                "name": s.name(),
                "cost_unit": s.cost_unit(),
                "error_kind": s.error_kind(),
                "note": self.section_note(s),
            })).collect::<Vec<_>>(),
            "pareto_fronts": fronts,
            "notes": self.notes,
            "rows": self.rows,
        })
    }

    /// The rows as CSV with a header line, one row per variant; empty fields where a value does not
    /// apply.
    pub fn write_csv(&self, out: &mut dyn std::io::Write) -> std::io::Result<()> {
        writeln!(
            out,
            "section,variant,backend,samples,cost,cost_unit,kernel_cost,max_error,rms_error,error_kind,pareto,variance_per_sample"
        )?;
        for r in &self.rows {
            writeln!(
                out,
                "{},{},{},{},{},{},{},{},{},{},{},{}",
                r.section.name(),
                csv_field(&r.variant),
                csv_field(&r.backend),
                r.samples.map(|n| n.to_string()).unwrap_or_default(),
                r.cost,
                r.cost_unit,
                r.kernel_cost.map(|k| k.to_string()).unwrap_or_default(),
                r.max_error,
                r.rms_error,
                r.error_kind,
                r.pareto,
                r.variance_per_sample
                    .map(|v| v.to_string())
                    .unwrap_or_default()
            )?;
        }
        Ok(())
    }

    /// The report as aligned text tables, one per section, with its note and the front marked `*`.
    pub fn write_table(&self, out: &mut dyn std::io::Write) -> std::io::Result<()> {
        writeln!(out, "{}: {}", self.subject, self.params.to_text())?;
        if let Some(d) = &self.device {
            writeln!(out, "device: {d}")?;
        }
        for s in self.sections() {
            writeln!(out)?;
            writeln!(out, "== {} ==", s.name())?;
            writeln!(out, "{}", self.section_note(s))?;
            if s != Section::Evaluation {
                if let Some(r) = self.reference_note() {
                    writeln!(out, "{r}")?;
                }
            }
            match s {
                Section::Evaluation => {
                    writeln!(
                        out,
                        "{:<36} {:>12} {:>14} {:>14}  pareto",
                        "variant", "ns/eval", "max rel err", "rms rel err"
                    )?;
                    for r in self.rows_of(s) {
                        writeln!(
                            out,
                            "{:<36} {:>12.3} {:>14.3e} {:>14.3e}  {}",
                            r.variant,
                            r.cost,
                            r.max_error,
                            r.rms_error,
                            if r.pareto { "*" } else { "" }
                        )?;
                    }
                }
                Section::Integration | Section::TableResolution => {
                    let (n, c) = if s == Section::Integration {
                        ("nodes", "ms/albedo")
                    } else {
                        ("cells", "ms/table")
                    };
                    writeln!(
                        out,
                        "{:<36} {:>9} {:>11} {:>11} {:>12} {:>12} {:>12}  pareto",
                        "variant", n, c, "kernel ms", "max |dE|", "rms |dE|", "var/draw"
                    )?;
                    for r in self.rows_of(s) {
                        writeln!(
                            out,
                            "{:<36} {:>9} {:>11.4} {:>11} {:>12.3e} {:>12.3e} {:>12}  {}",
                            r.variant,
                            r.samples.unwrap_or(0),
                            r.cost,
                            r.kernel_cost
                                .map(|k| format!("{k:.4}"))
                                .unwrap_or_else(|| "-".into()),
                            r.max_error,
                            r.rms_error,
                            r.variance_per_sample
                                .map(|v| format!("{v:.3e}"))
                                .unwrap_or_else(|| "-".into()),
                            if r.pareto { "*" } else { "" }
                        )?;
                    }
                }
            }
        }
        writeln!(out)?;
        writeln!(out, "Pareto fronts (cheapest first):")?;
        for s in self.sections() {
            let mut front: Vec<&Row> = self.rows_of(s).filter(|r| r.pareto).collect();
            front.sort_by(|a, b| a.cost.total_cmp(&b.cost));
            let names: Vec<&str> = front.iter().map(|r| r.variant.as_str()).collect();
            writeln!(out, "  {}: {}", s.name(), names.join(" | "))?;
        }
        for n in &self.notes {
            writeln!(out, "note: {n}")?;
        }
        Ok(())
    }
}
