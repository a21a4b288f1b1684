//! `lobe chi2`: the sampling test of a model's sampler (docs/design.md §13, §14).

use super::{BackendArgs, ModelArgs};
use anyhow::Result;
use clap::{Args, ValueEnum};
use lobe::chi2::{DirectionResult, Options, Report};
use std::io::{IsTerminal, Write};

/// The most draws per direction: 2⁴⁰, a bound on run time (hours on a CPU), well above the
/// 2³⁰ at which the test is meant to stay valid.
const MAX_SAMPLES: u64 = 1 << 40;

/// Output format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Chi2Format {
    /// A line per direction and a verdict, for people.
    Text,
    /// Everything, histograms included.
    Json,
}

#[derive(Args)]
pub struct Chi2Args {
    #[command(flatten)]
    model: ModelArgs,
    // Where the draws are made and counted: on the GPU by the counting kernel (checked in
    // f32), or on the CPU reference (checked in f64); the expected counts are integrated in
    // f64 on the CPU either way.
    #[command(flatten)]
    backend: BackendArgs,
    /// View directions θo in degrees, comma-separated, each in [0, 90).
    #[arg(
        long = "theta-o-deg",
        value_delimiter = ',',
        default_values_t = [0.0, 30.0, 60.0, 85.0],
        allow_hyphen_values = true
    )]
    theta_o_deg: Vec<f64>,
    /// Azimuth φo of every view direction, degrees.
    #[arg(long = "phi-o-deg", default_value_t = 0.0, allow_hyphen_values = true)]
    phi_o_deg: f64,
    /// Draws per view direction: a count or a power of two, 2^24 (default 2^24; at most 2^40).
    #[arg(long, default_value = "2^24", value_parser = parse_count)]
    samples: u64,
    /// How many of each view direction's first draws also have their weight checked against
    /// f cos/pdf and their pdf against pdf(wi): a count, 2^K, or "all". Every draw is counted
    /// in the histogram either way.
    #[arg(long = "checked-draws", default_value = "2^24", value_parser = parse_checked)]
    checked_draws: Checked,
    /// The random stream's seed: the same seed draws the same directions.
    #[arg(long, default_value_t = 0)]
    seed: u32,
    /// The probability with which the tests together may reject a correct sampler (Šidák's
    /// correction spreads it over every test).
    #[arg(long, default_value_t = 0.01)]
    significance: f64,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Chi2Format::Text)]
    format: Chi2Format,
    /// Also draw, per view direction, the observed histogram, the expected counts and the
    /// residual (o - e)/sqrt(e) side by side, as PNG, SVG or PDF by the extension.
    #[arg(short = 'o', long = "output", value_name = "PATH.png|.svg|.pdf")]
    output: Option<std::path::PathBuf>,
}

/// A count, `N` or `2^K`.
fn parse_count(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let n = match t.split_once('^') {
        Some((base, exp)) if base.trim() == "2" => exp
            .trim()
            .parse::<u32>()
            .ok()
            .and_then(|k| 1u64.checked_shl(k).filter(|_| k < 64)),
        Some(_) => None,
        None => t.parse::<u64>().ok(),
    };
    match n {
        Some(n) if (1..=MAX_SAMPLES).contains(&n) => Ok(n),
        _ => Err(format!(
            "expected draws per direction from 1 to 2^40 ({MAX_SAMPLES}), as N or 2^K"
        )),
    }
}

/// `--checked-draws`: a count, or every draw.
#[derive(Clone, Copy, Debug)]
struct Checked(Option<u64>);

fn parse_checked(text: &str) -> Result<Checked, String> {
    if text.trim() == "all" {
        return Ok(Checked(None));
    }
    parse_count(text).map(|n| Checked(Some(n))).map_err(|_| {
        format!("expected \"all\" or a count from 1 to 2^40 ({MAX_SAMPLES}), as N or 2^K")
    })
}

/// Exit status of a sampler the test rejects (bad usage exits 2, as clap's own errors do).
const REJECTED_STATUS: i32 = 1;

pub fn run(a: Chi2Args) -> Result<()> {
    if let Err(e) = check(&a) {
        eprintln!("lobe: error: {e}");
        std::process::exit(2);
    }
    let params = a.model.params()?;
    // A shader's sampler exists only in its kernels: on the CPU there is nothing to draw.
    if a.backend.backend == super::BackendArg::Cpu {
        if let Err(e) = params
            .model()
            .require_reference("the sampling test on the CPU")
        {
            eprintln!("lobe: error: {e}");
            std::process::exit(2);
        }
    }
    let options = Options {
        directions: a.theta_o_deg.iter().map(|&t| [t, a.phi_o_deg]).collect(),
        samples: a.samples,
        seed: a.seed,
        significance: a.significance,
        cells: None,
        checked_draws: a.checked_draws.0,
    };
    let session = super::open_session(&a.backend)?;
    let bar = indicatif::ProgressBar::new(options.samples * options.directions.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {percent}% draws, {eta} left")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    if !std::io::stderr().is_terminal() {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let report = session.chi2(&params, a.model.white_furnace, &options, &mut |done, _| {
        bar.set_position(done)
    });
    bar.finish_and_clear();
    let report = report.map_err(super::session_error)?;
    if let Some(path) = &a.output {
        session
            .write_chi2_picture(&params, &report, path)
            .map_err(super::session_error)?;
        eprintln!("wrote {}", path.display());
    }
    let mut out = super::stdout();
    match a.format {
        Chi2Format::Json => writeln!(
            out,
            "{}",
            serde_json::to_string_pretty(&report.to_json_for(&params))?
        )?,
        Chi2Format::Text => write_text(&mut out, &params, &report)?,
    }
    out.flush()?;
    if !report.passed {
        drop(out);
        std::process::exit(REJECTED_STATUS);
    }
    Ok(())
}

/// The flags' own ranges, before any work.
fn check(a: &Chi2Args) -> Result<(), String> {
    if a.theta_o_deg.is_empty() {
        return Err("--theta-o-deg: expected at least one view direction".into());
    }
    if let Some(t) = a
        .theta_o_deg
        .iter()
        .find(|t| !(t.is_finite() && (0.0..90.0).contains(*t)))
    {
        return Err(format!(
            "--theta-o-deg {t}: expected view angles in [0, 90) degrees"
        ));
    }
    if !a.phi_o_deg.is_finite() {
        return Err(format!(
            "--phi-o-deg {}: expected a finite angle in degrees",
            a.phi_o_deg
        ));
    }
    if !(a.significance > 0.0 && a.significance < 1.0) {
        return Err(format!(
            "--significance {}: expected a probability in (0, 1)",
            a.significance
        ));
    }
    if let Some(path) = &a.output {
        lobe::plot::Format::of(path).map_err(|e| format!("-o: {e:#}"))?;
        lobe::output::check_destination(path).map_err(|e| format!("-o: {e:#}"))?;
    }
    Ok(())
}

fn write_text(out: &mut dyn Write, params: &lobe::ParamSet, r: &Report) -> std::io::Result<()> {
    writeln!(out, "{} {}", params.model().name(), params.to_text())?;
    writeln!(
        out,
        "{} draws per direction, seed {}, drawn on {}; {} tests at significance {} each (Sidak, {} overall)",
        r.options.samples, r.options.seed, r.backend, r.tests, fmt_p(r.corrected_significance), r.options.significance
    )?;
    let checked = r.directions.first().map_or(0, |d| d.draws.checked_draws);
    writeln!(
        out,
        "{:>7} {:>7}  {:>10} {:>6} {:>10}  {:>9} {:>9} {:>10}  {:>9} {:>9}  verdict",
        "theta_o", "phi_o", "chi2", "dof", "p", "leaked", "expected", "p outside", "weight", "pdf"
    )?;
    for d in &r.directions {
        writeln!(
            out,
            "{:>7.2} {:>7.2}  {:>10.1} {:>6} {:>10}  {:>9.3e} {:>9.3e} {:>10}  {:>9.1e} {:>9.1e}  {}",
            d.theta_o_deg,
            d.phi_o_deg,
            d.statistic.value,
            d.statistic.dof,
            fmt_p(d.p_value),
            d.leak_share + d.delta_share,
            d.missing_mass,
            fmt_p(d.outside_p_value),
            d.draws.max_weight_error,
            d.draws.max_pdf_error,
            if d.passed { "pass" } else { "REJECTED" }
        )?;
    }
    writeln!(
        out,
        "columns: leaked = share of draws outside the hemisphere's cells (below it, pdf 0, or a delta lobe), expected = 1 - integral of pdf; weight, pdf = largest relative differences from f cos/pdf and pdf(wi) over the first {checked} draws{}",
        if checked < r.options.samples { " (--checked-draws)" } else { " (every draw)" }
    )?;
    for d in r.directions.iter().filter(|d| !d.passed) {
        write_failure(out, d)?;
    }
    let accuracy = r
        .directions
        .iter()
        .map(|d| d.expected_accuracy)
        .fold(0.0, f64::max);
    writeln!(
        out,
        "expected counts accurate to {accuracy:.1e} of their noise (largest over cells), the pdf from {} integrated in f64; {:.1} s",
        r.density, r.seconds
    )?;
    writeln!(
        out,
        "{}",
        if r.passed {
            "the sampler passes"
        } else {
            "the sampler is REJECTED"
        }
    )
}

fn write_failure(out: &mut dyn Write, d: &DirectionResult) -> std::io::Result<()> {
    writeln!(out, "at theta_o {} phi_o {}:", d.theta_o_deg, d.phi_o_deg)?;
    for f in &d.failures {
        writeln!(out, "  {f}")?;
    }
    if let Some(c) = &d.worst_cell {
        writeln!(
            out,
            "  largest difference in the cell phi {:.1}..{:.1} deg, cos theta {:.4}..{:.4}: {} observed, {:.1} expected ({:+.1} sigma)",
            c.phi_deg[0], c.phi_deg[1], c.cos_theta[0], c.cos_theta[1], c.observed, c.expected, c.sigma
        )?;
    }
    Ok(())
}

/// A p-value in a few digits, tiny ones in exponent form.
fn fmt_p(p: f64) -> String {
    if p.is_nan() {
        "n/a".into()
    } else if p != 0.0 && p < 1e-3 {
        format!("{p:.1e}")
    } else {
        format!("{p:.4}")
    }
}
