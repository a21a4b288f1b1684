//! `lobe demo`: the built-in materials with every model, shown on DIR/index.html.

use super::{bar, open_session, BackendArgs};
use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct DemoArgs {
    /// Output folder; its files are replaced only when the whole demo has succeeded, with
    /// index.html last.
    #[arg(short = 'o', long = "output", default_value = "lobe-demo")]
    output: PathBuf,
    // With cpu there is no GPU-vs-CPU parity to show.
    #[command(flatten)]
    backend: BackendArgs,
    /// Smaller grids, fewer samples and smaller images: a first look in a few seconds.
    #[arg(long)]
    quick: bool,
}

pub fn run(a: DemoArgs) -> Result<()> {
    let settings = if a.quick {
        lobe::demo::Settings::quick()
    } else {
        lobe::demo::Settings::full()
    };
    lobe::demo::check_output(&a.output)?;
    let session = open_session(&a.backend)?;
    eprintln!(
        "lobe demo: {} settings on {}, writing {}",
        settings.name,
        session.backend_name(),
        a.output.display()
    );
    let report = session
        .demo(&a.output, &settings, &mut DemoBars { bar: None })
        .map_err(super::session_error)?;
    println!("{}", report.summary());
    Ok(())
}

/// One indicatif bar per demo step; each finished step leaves a line with its time.
struct DemoBars {
    bar: Option<indicatif::ProgressBar>,
}

impl lobe::demo::Progress for DemoBars {
    fn begin(&mut self, step: &str, total: u64) {
        let b = bar(
            total.max(1),
            "{prefix:>8} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}",
        );
        b.set_prefix(step.to_string());
        self.bar = Some(b);
    }

    fn advance(&mut self, done: u64) {
        if let Some(b) = &self.bar {
            b.set_position(done);
        }
    }

    fn end(&mut self, step: &lobe::demo::Step) {
        if let Some(b) = self.bar.take() {
            b.finish_and_clear();
        }
        // A live line per finished step on a terminal; the summary on stdout repeats them all.
        if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
            eprintln!("{:>8} {:>7.2} s  {}", step.name, step.seconds, step.detail);
        }
    }
}
