//! The `lobe` command line: parses the arguments and hands each command to its file in
//! `src/cli/`, which calls the library and prints.

mod cli;

use clap::{Parser, Subcommand};
use std::sync::atomic::{AtomicBool, Ordering};

#[derive(Parser)]
#[command(
    name = "lobe",
    version,
    about = "Evaluate BRDFs with Vulkan compute shaders, checked against an f64 CPU reference",
    long_about = "Evaluate BRDFs with Vulkan compute shaders (GLSL, f32), checked against a CPU reference in f64.\n\
Conventions: normal +z, tangent +x; theta from the normal, phi from +x counter-clockwise; wi points to the light,\n\
wo to the viewer; f is in 1/sr, linear RGB, without the cosine. The command line takes angles in degrees."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Let this run's outputs replace whole any set of files of another kind or name (a table, a
    /// LUT, …), or any file no lobe set owns, that they would overwrite; without it such a run is
    /// refused before any work.
    #[arg(long, global = true)]
    replace: bool,
}

#[derive(Subcommand)]
enum Command {
    /// Evaluate f at direction pairs; prints CSV (or JSON).
    Eval(cli::eval::EvalArgs),
    /// Write a lobe table (EXR mosaic, plus .npy and .json beside it).
    Table(cli::table::TableArgs),
    /// List every model with its parameters, ranges, defaults and a description.
    Models(cli::models::ModelsArgs),
    /// The main job on the built-in materials (tin, gold, glazed ceramic, granite) with every
    /// model: lobe tables, albedo JSON, an albedo LUT, plots, the preview sheet and GPU-vs-CPU
    /// parity, shown on DIR/index.html. With --backend cpu there is no parity to show.
    Demo(cli::demo::DemoArgs),
    /// Evaluations per second of every model on this device, GPU and CPU reference.
    Bench(cli::bench::BenchArgs),
    /// Cost and error of each speed-for-accuracy variant of a model, measured on this device.
    Tradeoff(cli::tradeoff::TradeoffArgs),
    /// A labelled contact sheet (rows materials, columns models) of shaded spheres or the lab's
    /// icosahedron under the lab's four lights: PNG (sRGB) and EXR (linear radiance).
    Preview(cli::preview::PreviewArgs),
    /// The unit sphere seen from +z under an environment map (built-in or a lat-long EXR or
    /// .hdr file), f cos L summed exactly over every texel for every pixel: EXR (linear
    /// radiance), PNG (sRGB) and JSON (the settings).
    Light(cli::light::LightArgs),
    /// Sweep every model over the edges of its domain (extreme parameters, grazing, mirror and
    /// opposite directions) on both backends (--backend cpu: the CPU reference alone); count NaN,
    /// Inf and negative values and report the largest GPU-vs-CPU error. Exits non-zero if any
    /// NaN, Inf or negative value appears.
    Stability(cli::stability::StabilityArgs),
    /// Produce everything a scene file asks for: lobe tables, albedos and previews. Only the
    /// pipelines the scene needs are built; each is listed with its build time.
    Run(cli::run::RunArgs),
    /// Directional albedo E(mu) (delta lobes added exactly and also shown apart) and the
    /// hemispherical albedo, with error estimates.
    Albedo(cli::albedo::AlbedoArgs),
    /// The sampling test of a model's sampler: its draws against the integral of its pdf over
    /// equal-solid-angle cells (chi-square with pooling, Sidak's correction over the view
    /// directions), the share of draws leaving the hemisphere against 1 - integral of pdf, and
    /// every draw's weight f cos/pdf and pdf. The draws are made and counted on the device with
    /// --backend gpu (the default; checked in f32) or in f64 with --backend cpu; the expected
    /// counts are integrated in f64 either way. Exits 0 when it passes, 1 when the sampler is
    /// rejected, 2 for bad usage.
    Chi2(cli::chi2::Chi2Args),
    /// Draws of a model's sampler for one view direction, as PATH.npy (float64, a row per draw:
    /// wi x, y, z, weight r, g, b, pdf, delta) with its sidecar PATH.json. The same --seed draws
    /// the same directions on every run (within f32 rounding between --backend gpu and cpu).
    Sample(cli::sample::SampleArgs),
    /// Energy report: every model at its presets and over a sweep of its main parameter, in its
    /// white configuration (colours at 1, specular lobes alone under the white furnace): the
    /// largest E(mu) and where, gain (E > 1) and loss (1 - E_avg).
    Energy(cli::energy::EnergyArgs),
    /// Pictures of a model: in-plane polar plot, hemisphere heat map, theta_h x theta_d slice,
    /// 3D lobe or albedo curves, as PNG or SVG by the output's extension (fonts built in).
    Plot(cli::plot::PlotArgs),
    /// Fit the free parameters of a model to a target (a model, a .brdf file, a MERL file or a
    /// lobe table) by the cosine-weighted log error, every round's candidates in one GPU dispatch.
    ///
    /// The target is sampled at MERL's 90x90x180 half/difference bin centres (a table: at its own
    /// cells), missing data and bins below the horizon left out; at most --max-bins of them,
    /// evenly spaced in storage order, are used. Each free key is mapped from R into its range by
    /// a logistic function (in ln(1+x) for ranges wider than 1000); rgb keys fit three channels.
    /// Nelder-Mead (argmin) runs from --starts Halton points in lock-step: each round's
    /// candidates of all starts are evaluated in one GPU dispatch (--backend cpu: the f64
    /// reference).
    Fit(cli::fit::FitArgs),
    /// Two models on the same bins: relative difference (RMS, largest and where), the
    /// cosine-weighted log error, relative L2 and the albedo difference E_A - E_B; -o draws A
    /// and B overlaid and their difference over the hemisphere.
    Compare(cli::compare::CompareArgs),
    /// The models on a local web page: polar plot, 3D lobe, hemisphere, slice, lit spheres and
    /// albedo, with a control per parameter, every value computed by lobe. Serves until Ctrl-C.
    Explore(cli::explore::ExploreArgs),
}

/// The exit status after standard output was closed early (`lobe ... | head`): 128 + SIGPIPE,
/// what a shell reports for a program that a closed pipe ended (`yes | head` gives the same).
const BROKEN_PIPE_STATUS: i32 = 141;

/// `println!` panics when standard output fails; this ends the process instead, quietly with
/// [`BROKEN_PIPE_STATUS`] when the reader went away, else with a message that names stdout.
/// Every other panic goes to the default hook.
fn install_stdout_hook() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let text = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if let Some(reason) = text.strip_prefix("failed printing to stdout: ") {
            if reason.starts_with("Broken pipe") {
                std::process::exit(BROKEN_PIPE_STATUS);
            }
            eprintln!("lobe: error: writing to stdout: {reason}");
            std::process::exit(1);
        }
        default(info);
    }));
}

/// Whether descriptor 1 was closed when the process started (`lobe models >&-`), as
/// [`record_closed_stdout`] saw it. Rust's runtime puts /dev/null, opened read-write, on a closed
/// standard descriptor before `main` (so that no file the process opens takes its place), and a
/// report written there is lost without an error: the command would end with status 0 having
/// printed nothing. By `main` that /dev/null cannot be told from one a caller chose (Python's
/// `subprocess.DEVNULL` and many job runners open it read-write too), so the descriptor is looked
/// at before the runtime touches it.
static STDOUT_CLOSED_AT_START: AtomicBool = AtomicBool::new(false);

/// Runs from `.init_array`, before the runtime's setup (which runs in the C `main` the ELF entry
/// calls after every constructor): `fcntl(F_GETFD)` fails with EBADF only on a closed descriptor.
#[cfg(target_os = "linux")]
extern "C" fn record_closed_stdout() {
    // SAFETY: fcntl(F_GETFD) only reads descriptor 1's flags; errno is read on this thread.
    let closed = unsafe {
        libc::fcntl(1, libc::F_GETFD) == -1
            && std::io::Error::last_os_error().raw_os_error() == Some(libc::EBADF)
    };
    STDOUT_CLOSED_AT_START.store(closed, Ordering::Relaxed);
}

#[cfg(target_os = "linux")]
#[used]
#[link_section = ".init_array"]
static RECORD_CLOSED_STDOUT: extern "C" fn() = record_closed_stdout;

fn main() {
    install_stdout_hook();
    if STDOUT_CLOSED_AT_START.load(Ordering::Relaxed) {
        eprintln!(
            "lobe: error: standard output is closed, and lobe reports on it; redirect it to a \
             file or to /dev/null instead"
        );
        std::process::exit(1);
    }
    let cli = Cli::parse();
    lobe::output::replace_sets(cli.replace);
    let command = cli.command;
    // Ctrl-C, SIGTERM and SIGHUP set the cancellation token every session carries and stop all
    // output, for every command that writes files; the others (eval, models: standard output
    // only) end at once.
    let cancellable = !matches!(command, Command::Eval(_) | Command::Models(_));
    if cancellable {
        if let Err(e) = cli::install_ctrl_c() {
            eprintln!("lobe: error: {e:#}");
            std::process::exit(1);
        }
    }
    let result = match command {
        Command::Eval(a) => cli::eval::run(a),
        Command::Table(a) => cli::table::run(a),
        Command::Models(a) => cli::models::run(a),
        Command::Demo(a) => cli::demo::run(a),
        Command::Bench(a) => cli::bench::run(a),
        Command::Tradeoff(a) => cli::tradeoff::run(a),
        Command::Preview(a) => cli::preview::run(a),
        Command::Light(a) => cli::light::run(a),
        Command::Stability(a) => cli::stability::run(a),
        Command::Run(a) => cli::run::run(a),
        Command::Albedo(a) => cli::albedo::run(a),
        Command::Energy(a) => cli::energy::run(a),
        Command::Chi2(a) => cli::chi2::run(a),
        Command::Sample(a) => cli::sample::run(a),
        Command::Plot(a) => cli::plot::run(a),
        Command::Fit(a) => cli::fit::run(a),
        Command::Compare(a) => cli::compare::run(a),
        Command::Explore(a) => cli::explore::run(a),
    };
    if let Err(e) = result {
        let io_kind = |c: &(dyn std::error::Error + 'static)| {
            c.downcast_ref::<std::io::Error>().map(|io| io.kind())
        };
        if e.chain()
            .any(|c| io_kind(c) == Some(std::io::ErrorKind::BrokenPipe))
        {
            std::process::exit(BROKEN_PIPE_STATUS);
        }
        eprintln!("lobe: error: {e:#}");
        if let Some(hint) = cli::gpu_hint(&e).or_else(|| cli::flag_hint(&e)) {
            eprintln!("lobe: hint: {hint}");
        }
        // 128 + SIGINT, as shells report a command stopped by Ctrl-C.
        let interrupted = e.chain().any(|c| {
            c.downcast_ref::<lobe::interrupt::Interrupted>().is_some()
                || matches!(
                    c.downcast_ref::<lobe::Error>(),
                    Some(lobe::Error::Cancelled(_))
                )
        });
        let status = if interrupted { 130 } else { 1 };
        if cli::device_hung(&e) {
            // The driver's threads (a CPU driver's) may still be running the kernel that did not
            // finish: leave without the process's exit handlers, which tear down the driver
            // under them (that crashed the process now and then).
            use std::io::Write as _;
            let _ = std::io::stderr().flush();
            // SAFETY: _exit ends the process at once; nothing after it runs.
            unsafe { libc::_exit(status) };
        }
        std::process::exit(status);
    }
}
