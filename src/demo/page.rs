//! The demo's page, `index.html`: one self-contained HTML file (inline style, no scripts) with the
//! run's settings, step times, albedo tables, figures, the LUT, parity and the list of files.
//! Element ids and `data-*` attributes are what tests/demo.rs reads back.

use super::html::{albedo_row, esc, figure, ALBEDO_HEADER};
use super::{AlbedoRow, PlannedPlot, PreviewSizes, Report, GAIN_FLOOR, PLOT_SIZE};
use crate::stability::REL_FLOOR;
use std::fmt::Write as _;

const CSS: &str = "
body { font-family: system-ui, -apple-system, 'Segoe UI', sans-serif; margin: 0 auto; max-width: 1200px; padding: 1em 2em 4em; box-sizing: border-box; color: #222; line-height: 1.45; }
h1 { margin-bottom: 0.2em; } h2 { border-bottom: 2px solid #ddd; padding-bottom: 0.2em; margin-top: 2em; }
.meta { color: #555; }
table { border-collapse: collapse; margin: 0.6em 0 1.2em; font-size: 0.9em; }
th, td { border: 1px solid #ddd; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
th { background: #f4f4f4; }
td.num, td.rgb { font-family: ui-monospace, 'DejaVu Sans Mono', monospace; text-align: right; white-space: nowrap; font-variant-numeric: tabular-nums; }
td.rgb { white-space: pre-line; line-height: 1.25; }
td, th { overflow-wrap: anywhere; }
td.gain { background: #fde2e1; color: #a40000; font-weight: bold; }
td.ok { color: #176b1a; } td.bad { background: #fde2e1; color: #a40000; font-weight: bold; }
figure { margin: 1em 0 2em; } figure img { max-width: 100%; height: auto; border: 1px solid #ddd; box-sizing: border-box; }
figcaption { color: #444; font-size: 0.92em; margin-top: 0.3em; }
code { background: #f4f4f4; padding: 0 0.25em; border-radius: 3px; }
.note { background: #f7f7ff; border-left: 4px solid #99c; padding: 0.5em 1em; }
";

/// The whole page: every section, with links to the files in the output folder.
pub(super) fn page(r: &Report, plots: &[PlannedPlot], preview_sizes: PreviewSizes) -> String {
    let mut h = String::new();
    head(&mut h, r);
    at_a_glance(&mut h, r);
    steps(&mut h, r);
    preview(&mut h, r, preview_sizes);
    albedo(&mut h, r, plots);
    measured(&mut h, r);
    super::shipped::section(&mut h, r.shipped.as_ref());
    lut(&mut h, r);
    lobes(&mut h, r, plots);
    parity(&mut h, r);
    files(&mut h, r);
    h
}

/// The title, the run's settings and what the demo is.
fn head(h: &mut String, r: &Report) {
    let _ = writeln!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>lobe demo</title><style>{CSS}</style></head><body>"
    );
    let _ = writeln!(h, "<h1>lobe demo</h1>");
    let _ = writeln!(
        h,
        "<p class=\"meta\">Four materials (tin, gold, glazed ceramic, granite) under {} reflection models, evaluated on <b id=\"backend\">{}</b>; {} settings; {} files; steps before the page took {:.1} s.</p>",
        r.albedo.iter().map(|a| &a.model).collect::<std::collections::BTreeSet<_>>().len(),
        esc(&r.backend),
        r.settings.name,
        r.files.len(),
        r.seconds
    );
    let _ = writeln!(
        h,
        "<p class=\"note\">Grids and sample counts are kept modest so that the whole demo finishes in under a minute on two CPU cores with lavapipe (Mesa's CPU Vulkan driver). Run <code>lobe table</code>, <code>lobe albedo</code>, <code>lobe plot</code> and <code>lobe preview</code> for finer versions. This run:</p><ul>"
    );
    for line in r.settings.describe() {
        let _ = writeln!(h, "<li>{}</li>", esc(&line));
    }
    let _ = writeln!(h, "</ul>");
}

/// Energy gain, energy loss and parity in one list.
fn at_a_glance(h: &mut String, r: &Report) {
    let _ = writeln!(h, "<h2>At a glance</h2><ul id=\"glance\">");
    let gains: Vec<&AlbedoRow> = r.albedo.iter().filter(|a| a.gains_energy()).collect();
    if gains.is_empty() {
        let _ = writeln!(
            h,
            "<li>No model gains energy: E ≤ 1 at every view direction sampled.</li>"
        );
    } else {
        let list: Vec<String> = gains
            .iter()
            .map(|a| {
                format!(
                    "{} {} (E = {:.3} at μ = {:.3})",
                    a.material, a.model, a.max_e, a.max_e_mu
                )
            })
            .collect();
        let _ = writeln!(
            h,
            "<li><b>Energy gain</b> (E &gt; 1, a physically impossible reflector): {}. Shirley's smooth-layered model gains at grazing view (Fresnel → 1 plus the diffuse term); the coupled model exists to fix that.</li>",
            esc(&list.join("; "))
        );
    }
    if let (Some(a), Some(e)) = (r.lut.alpha.last(), r.lut.e_avg.last()) {
        let _ = writeln!(
            h,
            "<li><b>Energy loss</b> of single scattering: the GGX lobe under the white furnace keeps E<sub>avg</sub> = {:.3} at α = {:.3} (1 − E<sub>avg</sub> = {:.3} lost; see the LUT).</li>",
            e,
            a,
            1.0 - e
        );
    }
    match &r.parity {
        None => {
            let _ = writeln!(h, "<li><b>Parity</b>: not measured (CPU backend).</li>");
        }
        Some(rows) => {
            let worst = rows.iter().map(|x| x.max_rel).fold(0.0, f64::max);
            let ratio = rows.iter().map(|x| x.max_ratio).fold(0.0, f64::max);
            let over: usize = rows.iter().map(|x| x.over).sum();
            let n: usize = rows.iter().map(|x| x.values).sum();
            let _ = writeln!(
                h,
                "<li><b>GPU vs CPU parity</b> on {}: largest relative error {worst:.1e} over {n} values; largest error / tolerance {ratio:.3}; {over} over tolerance.</li>",
                esc(&r.backend)
            );
        }
    }
    let _ = writeln!(h, "</ul>");
}

/// Each step's time and output.
fn steps(h: &mut String, r: &Report) {
    let _ = writeln!(
        h,
        "<h2>Steps</h2><table id=\"steps\"><tr><th>step</th><th>time</th><th>output</th></tr>"
    );
    for st in &r.steps {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td class=\"num\">{:.2} s</td><td>{}</td></tr>",
            st.name,
            st.seconds,
            esc(&st.detail)
        );
    }
    let _ = writeln!(h, "</table>");
}

/// The contact sheet and the white furnace.
fn preview(h: &mut String, r: &Report, (preview_png, preview_exr): PreviewSizes) {
    let _ = writeln!(h, "<h2>Preview</h2>");
    figure(
        h,
        "preview/contact_sheet.png",
        preview_png,
        "Rows: materials; columns: models. Spheres under the lab's four point lights at (0,0,1), (0,1,1), (1,0,1), (−1,0,1), camera at the origin, no ambient light; sRGB, exposure 0 (a white Lambertian facing the camera reads 1). Mirror spikes of the layered models are not drawn.",
    );
    let _ = writeln!(
        h,
        "<p>Linear radiance: <a href=\"preview/contact_sheet.exr\">preview/contact_sheet.exr</a> ({}x{}, float RGB).</p>",
        preview_exr.0, preview_exr.1
    );
    figure(
        h,
        "preview/white_furnace.png",
        r.white_furnace_png,
        "White furnace: colours at 1 and F = 1 under a uniform white sky, so each pixel shows the albedo E(μo) and anything darker than white is energy the model loses. Left to right: qualitative Oren–Nayar (σ = 0.5), EON (r = 1), GGX α = 1 (height-correlated Smith), the same with multiscatter=kulla_conty.",
    );
}

/// Albedo tables per material and the albedo plots.
fn albedo(h: &mut String, r: &Report, plots: &[PlannedPlot]) {
    let _ = writeln!(h, "<h2>Albedo and energy</h2>");
    let _ = writeln!(
        h,
        "<p>E(μ) is the directional albedo at view direction μ = cosθo (φo = 0), the mirror spike of the layered models included exactly; Ē the hemispherical albedo; <i>max E</i> the largest E seen over the E(μ) curve and the three points, any channel (above 1 + {GAIN_FLOOR:.0e}, marked <i>gain</i>, the model creates energy); <i>1 − E<sub>avg</sub></i> the energy not reflected (E<sub>avg</sub> = 2∫E(μ)μ dμ), absorption by the material's colour included. Each RGB cell reads r, g, b from top to bottom; red marks a gain, blue the energy lost (darker: more). Integrator: <code>peak</code>, {} nodes per direction; <i>err</i> is its own error estimate.</p>",
        r.settings.albedo_samples
    );
    let mats: Vec<&str> = {
        let mut v: Vec<&str> = Vec::new();
        for a in &r.albedo {
            if !v.contains(&a.material.as_str()) {
                v.push(&a.material);
            }
        }
        v
    };
    for mat in &mats {
        let _ = writeln!(
            h,
            "<h3>{}</h3><table class=\"albedo\">{ALBEDO_HEADER}",
            esc(mat)
        );
        for a in r.albedo.iter().filter(|a| a.material == *mat) {
            albedo_row(h, a);
        }
        let _ = writeln!(h, "</table>");
    }
    for pl in plots.iter().filter(|p| p.material.is_some()) {
        figure(
            h,
            &pl.file,
            (PLOT_SIZE.0 as usize, PLOT_SIZE.1 as usize),
            &pl.caption,
        );
    }
}

/// The MERL-format file read back and integrated.
fn measured(h: &mut String, r: &Report) {
    let m = &r.measured;
    let _ = writeln!(h, "<h2 id=\"measured\">Measured data in MERL's format</h2>");
    let _ = writeln!(
        h,
        "<p>Gold under Cook–Torrance written as a file of the MERL BRDF database's format (<code>lobe table --material gold --model cook_torrance --grid halfdiff --format merl -o {name}.binary</code>, by the f64 reference: f at the centre of each of MERL's 90 × 90 × 180 half/difference bins; {bytes} bytes, too large to keep, so it is made in a temporary folder and removed), then read back as the model <code>{name}</code> (<code>--model {name}.binary</code>; {missing} values missing) and integrated as above. The nearest-bin lookup is MERL's reader's; <code>lookup=trilinear</code> interpolates between bin centres. The file's rows differ from the analytic one by what MERL's bins (1° in θd and φd, square-root spaced in θh) lose of the lobe.</p><table class=\"albedo\" id=\"measured-albedo\">{ALBEDO_HEADER}",
        name = esc(&m.model),
        bytes = crate::merl::FILE_BYTES,
        missing = m.missing,
    );
    let analytic = r
        .albedo
        .iter()
        .filter(|a| a.material == "gold" && a.model == "cook_torrance");
    for a in analytic.chain(&m.rows) {
        albedo_row(h, a);
    }
    let _ = writeln!(h, "</table>");
}

/// Kulla–Conty's table: the figure, E_avg per α and its files.
fn lut(h: &mut String, r: &Report) {
    let _ = writeln!(h, "<h2>Albedo LUT</h2>");
    let _ = writeln!(
        h,
        "<p>Kulla–Conty's table: E(μ, α) and E<sub>avg</sub>(α) of {} (<code>lobe albedo --lut</code> writes others). Largest error estimate of any entry: {:.1e}.</p>",
        esc(&r.lut.what),
        r.lut.max_error
    );
    let (e, mu, alpha) = r.lut.min_e;
    figure(
        h,
        &r.lut.png,
        (r.lut.png_size.0 as usize, r.lut.png_size.1 as usize),
        &format!("E(μ, α) of the GGX lobe under the white furnace; 1 − E is the energy single scattering loses. The smallest E in the table is {e:.3}, at μ = {mu:.3}, α = {alpha:.3}."),
    );
    let _ = writeln!(
        h,
        "<table id=\"lut\"><tr><th>α</th><th>E<sub>avg</sub></th><th>1 − E<sub>avg</sub></th></tr>"
    );
    let step = (r.lut.alpha.len() / 8).max(1);
    for k in (0..r.lut.alpha.len()).step_by(step) {
        let _ = writeln!(
            h,
            "<tr><td class=\"num\">{:.4}</td><td class=\"num\">{:.4}</td><td class=\"num\">{:.4}</td></tr>",
            r.lut.alpha[k],
            r.lut.e_avg[k],
            1.0 - r.lut.e_avg[k]
        );
    }
    let _ = writeln!(h, "</table><ul>");
    for f in &r.lut.files {
        let _ = writeln!(h, "<li><a href=\"{0}\">{0}</a></li>", esc(f));
    }
    let _ = writeln!(h, "</ul>");
}

/// The lobe figures and the lobe tables' files.
fn lobes(h: &mut String, r: &Report, plots: &[PlannedPlot]) {
    let _ = writeln!(h, "<h2>Lobes</h2>");
    for pl in plots.iter().filter(|p| p.material.is_none()) {
        let size = (pl.common.size.0 as usize, pl.common.size.1 as usize);
        figure(h, &pl.file, size, &pl.caption);
    }

    let _ = writeln!(h, "<h2>Lobe tables</h2><p>Gold under Cook–Torrance, f(ωi, ωo) in 1/sr without the cosine, on cell-centred grids (angles in radians). Each table is an EXR mosaic (one slice per light direction; the layout is in the EXR header and the JSON sidecar), a NumPy array and a JSON sidecar.</p><ul>");
    for f in r.files.iter().filter(|f| f.starts_with("tables/")) {
        let _ = writeln!(h, "<li><a href=\"{0}\">{0}</a></li>", esc(f));
    }
    let _ = writeln!(h, "</ul>");
}

/// GPU against CPU per model, or why it was not measured.
fn parity(h: &mut String, r: &Report) {
    let _ = writeln!(h, "<h2>GPU vs CPU parity</h2>");
    match &r.parity {
        None => {
            let _ = writeln!(
                h,
                "<p id=\"parity-none\">Not measured: this run used the CPU backend (the f64 reference alone), so there is no GPU result to compare. Run the demo on the GPU backend, or <code>cargo test --release --test parity</code>.</p>"
            );
        }
        Some(rows) => {
            let [a, b, c] = r.settings.parity_grid;
            let _ = writeln!(
                h,
                "<p>The GPU kernels (f32, on <b>{}</b>) against the CPU reference (f64), per model, at every material preset, on θi × θo × φo = {a} × {b} × {c} cell-centred directions (φi = 0). Both sides see the same f32-rounded inputs. <i>rel. error</i> is |g − c| / max(|c|, {REL_FLOOR:.0e} sr⁻¹); <i>error / tolerance</i> uses the tolerance model of docs/design.md §10: |g − c| ≤ 10⁻⁶ sr⁻¹ + (64ε + 4ε|x|)·|c| + the reference's spread over an 8ε change of direction, x the exponent of the lobe's exp and ε the f32 epsilon; a ratio above 1 fails.</p>",
                esc(&r.backend)
            );
            let _ = writeln!(h, "<table id=\"parity\"><tr><th>model</th><th>values</th><th>max rel. error</th><th>max error / tolerance</th><th>over tolerance</th><th>worst at</th></tr>");
            for row in rows {
                let _ = writeln!(
                    h,
                    "<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{:.2e}</td><td class=\"num\">{:.3}</td><td class=\"num {}\">{}</td><td>{}</td></tr>",
                    esc(&row.model),
                    row.values,
                    row.max_rel,
                    row.max_ratio,
                    if row.over == 0 { "ok" } else { "bad" },
                    row.over,
                    esc(&row.worst)
                );
            }
            let _ = writeln!(h, "</table>");
        }
    }
}

/// Every file in the output folder.
fn files(h: &mut String, r: &Report) {
    let _ = writeln!(h, "<h2>Files</h2><ul class=\"files\">");
    for f in &r.files {
        let _ = writeln!(h, "<li><a href=\"{0}\">{0}</a></li>", esc(f));
    }
    let _ = writeln!(h, "</ul></body></html>");
}
