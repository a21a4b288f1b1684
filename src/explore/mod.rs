//! `lobe explore`: a local web page that shows what a set of models does (polar plot, hemisphere,
//! directional and hemispherical albedo) with every number computed by a [`Session`].
//!
//! The server is axum on a tokio runtime. It binds to the loopback address unless told
//! otherwise, and answers only requests that carry the session token of the URL it prints
//! (as Jupyter does) and whose `Host` header names the address it is bound to (a page on another
//! site that rebinds its DNS name to 127.0.0.1 still sends its own name). It sends no CORS
//! headers, so no other origin can read an answer. The page and its script are compiled into the
//! binary; the page needs no network.

mod api;
mod cells;
mod download;
mod env;
mod guard;
mod limits;
mod objects;
mod reply;
mod upload;

pub use limits::*;

use crate::model::ParamSet;
use crate::{Session, SessionOptions};
use std::net::{IpAddr, SocketAddr};
use std::sync::{Arc, Mutex};

/// The page, compiled in.
pub(crate) const INDEX_HTML: &str = include_str!("assets/index.html");

/// The page's scripts and style, compiled in: each one's path, content type and text.
pub(crate) const ASSETS: [(&str, &str, &str); 5] = [
    ("/app.js", JAVASCRIPT, include_str!("assets/app.js")),
    ("/views.js", JAVASCRIPT, include_str!("assets/views.js")),
    ("/lobe3d.js", JAVASCRIPT, include_str!("assets/lobe3d.js")),
    ("/files.js", JAVASCRIPT, include_str!("assets/files.js")),
    (
        "/style.css",
        "text/css; charset=utf-8",
        include_str!("assets/style.css"),
    ),
];
const JAVASCRIPT: &str = "text/javascript; charset=utf-8";

/// What `lobe explore` starts with.
#[derive(Clone, Debug)]
pub struct ExploreOptions {
    /// The address to bind (127.0.0.1 unless the user asks otherwise).
    pub host: IpAddr,
    /// The port; 0 lets the system choose a free one.
    pub port: u16,
    /// The models shown first, each with its label and parameters.
    pub models: Vec<(String, ParamSet)>,
    /// The material preset the page's model menus start from, if any.
    pub material: Option<String>,
    /// The session token; [`new_token`] makes one.
    pub token: String,
    /// How a session of its own is opened for models compiled at run time (`.brdf` files), so
    /// that a shader that never returns hangs only that session: the next such request opens a
    /// fresh one, and built-in models never wait on it. None: every model runs on the server's
    /// one session.
    pub shader_session: Option<SessionOptions>,
    /// How `.brdf` files opened from the page are loaded (their time limit per chunk of work).
    pub brdf: crate::brdf::LoadOptions,
}

/// A token of 128 random bits from the operating system, as 32 hexadecimal digits.
pub fn new_token() -> crate::Result<String> {
    let mut bytes = [0u8; 16];
    getrandom::fill(&mut bytes)
        .map_err(|e| crate::Error::Invalid(format!("no random session token: {e}")))?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// A bound server, ready to [`serve`](Server::serve).
pub struct Server {
    listener: tokio::net::TcpListener,
    state: Arc<State>,
    addr: SocketAddr,
}

/// What every handler shares.
pub(crate) struct State {
    pub session: Arc<Session>,
    pub token: String,
    /// `Host` header values accepted: the bound address and port (and `localhost:PORT` on a
    /// loopback address); empty (any) on an unspecified address.
    pub hosts: Vec<String>,
    pub initial: Vec<(String, ParamSet)>,
    pub material: Option<String>,
    /// Models loaded from the page (.brdf uploads), each with its file's name as the page gave
    /// it and the path it was compiled from (which the page never sees), kept for the models
    /// list.
    pub uploaded: Mutex<Vec<(crate::Model, String, String)>>,
    /// The folder uploaded files are compiled from; removed when the server ends.
    pub uploads: tempfile::TempDir,
    /// Environment maps opened from the page (`POST /api/env`), each under its name.
    pub maps: Mutex<Vec<(String, Arc<crate::backend::light::EnvMap>)>>,
    /// See [`ExploreOptions::shader_session`].
    pub shader_options: Option<SessionOptions>,
    /// The session models compiled at run time are evaluated on, once one was needed.
    pub shaders: Mutex<Option<Arc<Session>>>,
    pub brdf: crate::brdf::LoadOptions,
    /// Evaluations stopped because their page stopped waiting for them.
    pub stopped: std::sync::atomic::AtomicU64,
}

impl State {
    /// The session that evaluates `model`: the shader session for a model compiled at run time
    /// (opened on first use, and again after one hung), else the server's own.
    pub fn session_for(&self, model: crate::Model) -> crate::Result<Arc<Session>> {
        let Some(options) = &self.shader_options else {
            return Ok(self.session.clone());
        };
        if model.chunk_timeout().is_none() {
            return Ok(self.session.clone());
        }
        let mut shaders = self.shaders.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(s) = shaders.as_ref() {
            return Ok(s.clone());
        }
        let opened = Arc::new(Session::open(options.clone())?);
        *shaders = Some(opened.clone());
        Ok(opened)
    }

    /// Lets go of `session` when `error` says its device may still run a shader that never
    /// returns (it is leaked, not freed under that work) so that the next request opens a fresh
    /// one; the server's own session is never replaced.
    pub fn retire_if_hung(&self, session: &Arc<Session>, error: &crate::Error) {
        use crate::gpu::GpuError;
        let hung = matches!(
            error,
            crate::Error::Gpu(
                GpuError::ModelTimeout { .. } | GpuError::Timeout { .. } | GpuError::Hung
            )
        );
        if !hung || Arc::ptr_eq(session, &self.session) {
            return;
        }
        let mut shaders = self.shaders.lock().unwrap_or_else(|e| e.into_inner());
        if shaders.as_ref().is_some_and(|s| Arc::ptr_eq(s, session)) {
            *shaders = None;
        }
    }
}

impl Server {
    /// Binds `opts.host:opts.port` on the current tokio runtime.
    pub async fn bind(session: Arc<Session>, opts: ExploreOptions) -> crate::Result<Server> {
        let listener = tokio::net::TcpListener::bind((opts.host, opts.port))
            .await
            .map_err(|e| {
                crate::Error::Invalid(format!("cannot listen on {}:{}: {e}", opts.host, opts.port))
            })?;
        let addr = listener
            .local_addr()
            .map_err(|e| io_error("reading the bound address", e))?;
        // On an unspecified address (0.0.0.0, ::) the page is reached under any of the
        // machine's names, so every Host is taken and the token alone guards it.
        let mut hosts = Vec::new();
        if !addr.ip().is_unspecified() {
            hosts.push(host_port(addr.ip(), addr.port()));
        }
        if addr.ip().is_loopback() {
            hosts.push(format!("localhost:{}", addr.port()));
        }
        let uploads = tempfile::Builder::new()
            .prefix("lobe-explore-")
            .tempdir()
            .map_err(|e| io_error("creating the folder for opened .brdf files", e))?;
        let state = Arc::new(State {
            session,
            token: opts.token,
            hosts,
            initial: opts.models,
            material: opts.material,
            uploaded: Mutex::new(Vec::new()),
            maps: Mutex::new(Vec::new()),
            uploads,
            shader_options: opts.shader_session,
            shaders: Mutex::new(None),
            brdf: opts.brdf,
            stopped: Default::default(),
        });
        Ok(Server {
            listener,
            state,
            addr,
        })
    }

    /// The address the server listens on.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The page's address with the token, as it is printed and opened.
    pub fn url(&self) -> String {
        let ip = match self.addr.ip() {
            ip if ip.is_unspecified() => IpAddr::from([127, 0, 0, 1]),
            ip => ip,
        };
        format!(
            "http://{}/?token={}",
            host_port(ip, self.addr.port()),
            self.state.token
        )
    }

    /// Serves until `shutdown` completes, then finishes the requests under way and returns.
    pub async fn serve(
        self,
        shutdown: impl std::future::Future<Output = ()> + Send + 'static,
    ) -> crate::Result<()> {
        let app = api::router(self.state.clone());
        axum::serve(self.listener, app)
            .with_graceful_shutdown(shutdown)
            .await
            .map_err(|e| io_error("serving the explorer", e))
    }
}

/// `ip:port` as a URL and a `Host` header write it (an IPv6 address in brackets).
fn host_port(ip: IpAddr, port: u16) -> String {
    match ip {
        IpAddr::V4(v4) => format!("{v4}:{port}"),
        IpAddr::V6(v6) => format!("[{v6}]:{port}"),
    }
}

fn io_error(what: &str, source: std::io::Error) -> crate::Error {
    crate::Error::Io {
        what: what.to_string(),
        source,
    }
}
