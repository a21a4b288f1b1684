//! `lobe explore`: the models on a local web page ([`lobe::explore`]), served until Ctrl-C or
//! SIGTERM.

use super::{
    cancel_token, open_session, resolve_all, session_options, spec_options, split_specs,
    BackendArgs,
};
use anyhow::{Context, Result};
use clap::Args;
use std::net::IpAddr;
use std::sync::Arc;
use std::time::Duration;

#[derive(Args)]
pub struct ExploreArgs {
    /// Models shown first: NAME, NAME{KEY=VALUE,...}, a .brdf file or a MERL .binary file
    /// (default cook_torrance). More can be added, and .brdf files opened, on the page.
    #[arg(value_name = "MODEL")]
    models: Vec<String>,
    /// Start the models from a material preset (tin, gold, glazed_ceramic, granite, ...).
    #[arg(long)]
    material: Option<String>,
    /// Set a parameter, [MODEL.]KEY=VALUE, as `lobe plot --set` does. Repeatable.
    #[arg(long = "set", value_name = "[MODEL.]KEY=VALUE")]
    sets: Vec<String>,
    /// The port to listen on (default: a free one the system chooses).
    #[arg(long, default_value_t = 0)]
    port: u16,
    /// The address to listen on. Anything but a loopback address lets other machines reach the
    /// page (with the token); lobe warns.
    #[arg(long, default_value = "127.0.0.1")]
    host: IpAddr,
    /// Print the URL without opening a browser.
    #[arg(long)]
    no_browser: bool,
    #[command(flatten)]
    backend: BackendArgs,
}

/// How often the server looks at the cancellation token that Ctrl-C and SIGTERM set: a stop
/// within a tenth of a second feels immediate.
const SIGNAL_POLL: Duration = Duration::from_millis(100);

/// How long requests under way may take to finish once the server stops: a running evaluation
/// stops at its next chunk (the session shares the token), so this is only reached by a user
/// shader that never returns, which its own chunk timeout ends.
const DRAIN_TIMEOUT: Duration = Duration::from_secs(2);

pub fn run(a: ExploreArgs) -> Result<()> {
    let specs = match split_specs(&a.models) {
        s if s.is_empty() => vec!["cook_torrance".to_string()],
        s => s,
    };
    let models = resolve_all(&specs, a.material.as_deref(), &a.sets)?;
    if !a.host.is_loopback() {
        eprintln!(
            "lobe: warning: --host {}: the page is reachable from other machines (anyone with \
             the URL's token can evaluate models on this one); use 127.0.0.1 to keep it local",
            a.host
        );
    }
    let session = Arc::new(open_session(&a.backend)?);
    let options = lobe::explore::ExploreOptions {
        host: a.host,
        port: a.port,
        models,
        material: a.material.clone(),
        token: lobe::explore::new_token()?,
        shader_session: Some(session_options(&a.backend)),
        brdf: spec_options()?.brdf,
    };
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("starting the server's runtime")?;
    let result = runtime.block_on(async {
        let server = lobe::explore::Server::bind(session.clone(), options).await?;
        let url = server.url();
        println!("lobe explore: {} on {url}", session.backend_name());
        println!("lobe explore: press Ctrl-C to stop");
        use std::io::Write as _;
        std::io::stdout().flush().context("writing to stdout")?;
        if !a.no_browser {
            open_browser(&url);
        }
        server.serve(stopped()).await?;
        anyhow::Ok(())
    });
    runtime.shutdown_timeout(DRAIN_TIMEOUT);
    result?;
    eprintln!("lobe explore: stopped");
    Ok(())
}

/// Completes when Ctrl-C, SIGTERM or SIGHUP has set the process's cancellation token.
async fn stopped() {
    while !cancel_token().is_cancelled() {
        tokio::time::sleep(SIGNAL_POLL).await;
    }
}

/// Opens `url` in the default browser; failing softly, as the URL is printed.
fn open_browser(url: &str) {
    let (program, args): (&str, Vec<&str>) = if cfg!(target_os = "macos") {
        ("open", vec![url])
    } else if cfg!(windows) {
        ("cmd", vec!["/C", "start", "", url])
    } else {
        ("xdg-open", vec![url])
    };
    let spawned = std::process::Command::new(program)
        .args(&args)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn();
    if let Err(e) = spawned {
        eprintln!("lobe: note: could not open a browser ({program}: {e}); open the URL above");
    }
}
