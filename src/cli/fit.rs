//! `lobe fit`: fits the free parameters of a model to a target ([`lobe::fit`]).

use super::{
    bar, open_session, resolve, session_error, split_spec, stdout, with_flag, BackendArgs,
};
use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use lobe::fit::{FitOptions, FitReport, Space, Target};
use lobe::loss::LossKind;
use lobe::plot::{Format, Subject};
use lobe::ParamSet;
use std::io::Write;

/// Output format of `lobe fit`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FitFormat {
    /// Aligned text for people.
    Table,
    /// One JSON object.
    Json,
}

/// The loss `lobe fit` minimises.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum LossArg {
    /// Cosine-weighted log error (Löw et al. 2012, after Ngan et al. 2005): per channel c,
    /// sqrt(sum w [ln(1 + cos_i f_target) - ln(1 + cos_i f_fit)]^2 / sum w), w the bin's solid
    /// angle; the total is the RMS over channels.
    Log,
    /// Relative L2: sqrt(sum w |f_fit - f_target|^2 / sum w |f_target|^2).
    L2,
}

/// `lobe fit` arguments.
#[derive(Args, Debug)]
pub struct FitArgs {
    /// What to fit against: a model spec, a .brdf file, a MERL .binary file, or a table .npy/.json.
    #[arg(long)]
    pub target: String,
    /// Set a parameter of a model target, KEY=VALUE (repeatable).
    #[arg(long = "target-set", value_name = "KEY=VALUE")]
    pub target_sets: Vec<String>,
    /// The model to fit: NAME or NAME{KEY=VALUE,...} (see `lobe models`).
    #[arg(long)]
    pub model: String,
    /// Fix a parameter of the fitted model, KEY=VALUE (repeatable); a fixed key cannot be free.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// The parameters to fit, comma-separated (numbers or rgb values of --model).
    #[arg(long, value_delimiter = ',', required = true)]
    pub free: Vec<String>,
    /// The distance minimised.
    #[arg(long, value_enum, default_value_t = LossArg::Log)]
    pub loss: LossArg,
    /// Most target bins used, an evenly spaced deterministic subset (0: every valid bin).
    #[arg(long, default_value_t = lobe::fit::DEFAULT_MAX_BINS)]
    pub max_bins: usize,
    /// Nelder-Mead runs, from the first Halton points of the parameter box.
    #[arg(long, default_value_t = lobe::fit::DEFAULT_STARTS)]
    pub starts: usize,
    /// Most Nelder-Mead iterations per start.
    #[arg(long, default_value_t = lobe::fit::DEFAULT_MAX_ITERS)]
    pub max_iters: u64,
    /// Output format.
    #[arg(long, value_enum, default_value_t = FitFormat::Table)]
    pub format: FitFormat,
    /// Write PREFIX_polar.png (target and fit in the plane of incidence) and
    /// PREFIX_difference.png (their relative difference over the hemisphere), each with a .json
    /// of the parameters and a .csv of the plotted numbers beside it. Needs a target that is a
    /// model or a MERL file.
    #[arg(short = 'o', long = "output", value_name = "PREFIX")]
    pub output: Option<std::path::PathBuf>,
    #[command(flatten)]
    pub backend: BackendArgs,
}

/// The keys a model spec and `--set` list give values to.
fn fixed_keys(spec: &str, sets: &[String]) -> Result<Vec<String>> {
    let (_, own) = split_spec(spec)?;
    Ok(own
        .iter()
        .chain(sets)
        .filter_map(|s| s.split_once('=').map(|(k, _)| k.trim().to_string()))
        .collect())
}

/// Runs `lobe fit`.
pub fn run(a: FitArgs) -> Result<()> {
    let target = target(&a)?;
    let base = resolve(&a.model, None, &a.sets).context("--model")?;
    let fixed = fixed_keys(&a.model, &a.sets)?;
    let space = with_flag(Space::new(base, &a.free, &fixed), |o| {
        (o == "free").then(|| "--free".to_string())
    })?;
    let opts = FitOptions {
        loss: match a.loss {
            LossArg::Log => LossKind::CosineLog,
            LossArg::L2 => LossKind::RelativeL2,
        },
        max_bins: a.max_bins,
        starts: a.starts,
        max_iters: a.max_iters,
    };
    let plot_target = match &a.output {
        Some(prefix) => Some(plot_target(&a, prefix, &target)?),
        None => None,
    };
    let session = open_session(&a.backend)?;
    let progress = bar(
        opts.max_iters,
        "fit {bar:30} iteration {pos}/{len}, {msg} [{elapsed}]",
    );
    let report = {
        let update = |p: lobe::fit::FitProgress| {
            progress.set_position(p.iteration);
            progress.set_message(format!("round {}, best loss {:.4e}", p.rounds, p.best_loss));
        };
        with_flag(
            session
                .fit(&target, &space, &opts, &update)
                .map_err(session_error),
            |o| match o {
                "target" => Some(format!("--target {}", a.target)),
                "starts" => Some("--starts".into()),
                "max_iters" => Some("--max-iters".into()),
                _ => None,
            },
        )
    };
    progress.finish_and_clear();
    let report = report?;
    let mut out = stdout();
    match a.format {
        FitFormat::Json => writeln!(
            out,
            "{}",
            serde_json::to_string_pretty(&report.to_json(&target))?
        )?,
        FitFormat::Table => print_table(&mut out, &report, &target)?,
    }
    out.flush()?;
    if let (Some(prefix), Some(tp)) = (&a.output, plot_target) {
        let target_subject = Subject {
            label: format!("target: {}", a.target),
            params: tp,
        };
        let fit_subject = Subject {
            label: format!("fit: {}", report.params.model().name()),
            params: report.params.clone(),
        };
        let plots = session
            .plot_difference(
                &target_subject,
                &fit_subject,
                &lobe::plot::difference::PlotOptions::default(),
                prefix,
                Format::Png,
            )
            .map_err(session_error)?;
        eprintln!(
            "lobe: wrote {} and {}",
            plots.polar_path.display(),
            plots.difference_path.display()
        );
    }
    Ok(())
}

fn print_table(out: &mut impl Write, r: &FitReport, target: &Target) -> Result<()> {
    writeln!(out, "target      {}", target.describe())?;
    writeln!(
        out,
        "samples     {} of {} valid bins ({} bins, {} missing): {}",
        r.samples.used, r.samples.valid, r.samples.grid_bins, r.samples.missing, r.samples.grid
    )?;
    writeln!(
        out,
        "fit         {} {}",
        r.params.model().name(),
        r.params.to_text()
    )?;
    writeln!(out, "free        {}", r.free.join(", "))?;
    writeln!(
        out,
        "loss ({})  {:.6e}   r {:.6e}  g {:.6e}  b {:.6e}",
        r.loss_kind.name(),
        r.loss.total,
        r.loss.channel[0],
        r.loss.channel[1],
        r.loss.channel[2]
    )?;
    writeln!(
        out,
        "work        {} iterations over {} starts, {} rounds, {} evaluations, {:.2} s on {}",
        r.iterations,
        r.starts.len(),
        r.rounds,
        r.evaluations,
        r.seconds,
        r.backend
    )?;
    writeln!(
        out,
        "albedo E(mu)   target (r, g, b)            fit (r, g, b)"
    )?;
    for a in &r.albedo {
        let t = a.target.map_or("(a table: none)".to_string(), |t| {
            format!("{:.4} {:.4} {:.4}", t.x, t.y, t.z)
        });
        writeln!(
            out,
            "  mu {:<5}   {t:<26}  {:.4} {:.4} {:.4}",
            a.mu, a.fit.x, a.fit.y, a.fit.z
        )?;
    }
    writeln!(out, "starts")?;
    for (k, s) in r.starts.iter().enumerate() {
        writeln!(
            out,
            "  {k}: loss {:.6e}, {} iterations ({}): {}",
            s.loss,
            s.iterations,
            s.stopped,
            s.params.to_text()
        )?;
    }
    Ok(())
}

/// The target: a file of measurements or a table, else a model with --target-set.
fn target(a: &FitArgs) -> Result<Target> {
    Ok(match Target::file_kind(&a.target) {
        Some(t) => {
            if !a.target_sets.is_empty() {
                anyhow::bail!(
                    "--target-set: the target {} is a file, which has no parameters to set",
                    a.target
                );
            }
            t
        }
        None => Target::Model(resolve(&a.target, None, &a.target_sets).context("--target")?),
    })
}

/// With -o: the target as a model to draw, once the pictures' folder and names are checked.
fn plot_target(a: &FitArgs, prefix: &std::path::Path, target: &Target) -> Result<ParamSet> {
    let (polar, difference) = lobe::plot::difference::plot_paths(prefix, Format::Png);
    let folder = lobe::output::folder_of(&polar);
    if !folder.as_os_str().is_empty() && !folder.is_dir() {
        anyhow::bail!(
            "-o {}: the folder {} does not exist",
            prefix.display(),
            folder.display()
        );
    }
    for p in [&polar, &difference] {
        lobe::output::check_destination(p).context("-o")?;
    }
    match lobe::fit::target_model(target)? {
        Some(p) => Ok(p),
        None => anyhow::bail!(
            "-o {}: the target {} is a table, which cannot be drawn as a model; fit without -o, or give the model or MERL file it came from",
            prefix.display(),
            a.target
        ),
    }
}
