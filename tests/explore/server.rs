//! The server under test: `lobe explore --no-browser` as a child process, and HTTP/1.1 spoken
//! over a plain socket (so that a test can send what a browser would not).

use serde_json::Value;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

/// How long one answer may take on a shared 2-core machine (an albedo on a CPU driver).
const ANSWER_TIMEOUT: Duration = Duration::from_secs(90);

pub fn manifest() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A running `lobe explore --no-browser`, killed when dropped.
pub struct Server {
    pub child: Child,
    pub addr: String,
    pub token: String,
    pub url: String,
    pub tmp: tempfile::TempDir,
}

impl Server {
    pub fn start(args: &[&str]) -> Server {
        Server::start_with_env(args, &[])
    }

    /// [`Server::start`] with environment variables set for the server.
    pub fn start_with_env(args: &[&str], env: &[(&str, &str)]) -> Server {
        let tmp = tempfile::tempdir().unwrap();
        let mut child = Command::new(env!("CARGO_BIN_EXE_lobe"))
            .args(["explore", "--no-browser"])
            .args(args)
            .envs(env.iter().copied())
            .current_dir(manifest())
            // The server's own temporary folder goes here, so that a test can see it removed.
            .env("TMPDIR", tmp.path())
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start lobe explore");
        let mut out = BufReader::new(child.stdout.take().unwrap());
        let mut line = String::new();
        let url = loop {
            line.clear();
            if out.read_line(&mut line).unwrap() == 0 {
                let mut err = String::new();
                child
                    .stderr
                    .take()
                    .unwrap()
                    .read_to_string(&mut err)
                    .unwrap();
                panic!("lobe explore ended before printing its URL: {err}");
            }
            if let Some(at) = line.find("http://") {
                break line[at..].trim().to_string();
            }
        };
        std::thread::spawn(move || out.lines().for_each(drop));
        let addr = url["http://".len()..]
            .split('/')
            .next()
            .unwrap()
            .to_string();
        let token = url.split("token=").nth(1).unwrap().to_string();
        Server {
            child,
            addr,
            token,
            url,
            tmp,
        }
    }

    /// A request with the token in its header and the right Host.
    pub fn post(&self, path: &str, body: &Value) -> Reply {
        http(
            &self.addr,
            "POST",
            path,
            &[("x-lobe-token", &self.token)],
            body.to_string().as_bytes(),
        )
    }
}

impl Server {
    /// A GET with the token, answered 200 with JSON.
    pub fn get_json(&self, path: &str) -> Value {
        let r = http(
            &self.addr,
            "GET",
            path,
            &[("x-lobe-token", &self.token)],
            b"",
        );
        assert_eq!(r.status, 200, "GET {path}: {}", r.text());
        serde_json::from_slice(&r.body).unwrap()
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

pub struct Reply {
    pub status: u16,
    pub head: String,
    pub body: Vec<u8>,
}

impl Reply {
    pub fn text(&self) -> String {
        String::from_utf8_lossy(&self.body).into_owned()
    }
}

/// One HTTP/1.1 request on its own connection; `Host` is `addr` unless `headers` gives one.
pub fn http(
    addr: &str,
    method: &str,
    target: &str,
    headers: &[(&str, &str)],
    body: &[u8],
) -> Reply {
    http_claiming(addr, method, target, headers, body.len(), body)
}

/// [`http`] with a `Content-Length` of `length` whatever the body sent: a server that refuses a
/// body by its length answers before reading it.
pub fn http_claiming(
    addr: &str,
    method: &str,
    target: &str,
    headers: &[(&str, &str)],
    length: usize,
    body: &[u8],
) -> Reply {
    let mut s = open(
        addr,
        method,
        target,
        headers,
        &format!("Content-Length: {length}"),
    );
    s.write_all(body).unwrap();
    read_reply(&mut s)
}

/// A connection to `addr` with the request's head sent: `Host` is `addr` unless `headers` gives
/// one, and `framing` says how the body comes (`Content-Length` or `Transfer-Encoding`).
fn open(
    addr: &str,
    method: &str,
    target: &str,
    headers: &[(&str, &str)],
    framing: &str,
) -> TcpStream {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(ANSWER_TIMEOUT)).unwrap();
    let mut req = format!("{method} {target} HTTP/1.1\r\nConnection: close\r\n");
    if !headers.iter().any(|(k, _)| k.eq_ignore_ascii_case("host")) {
        req += &format!("Host: {addr}\r\n");
    }
    for (k, v) in headers {
        req += &format!("{k}: {v}\r\n");
    }
    req += &format!("{framing}\r\n\r\n");
    s.write_all(req.as_bytes()).unwrap();
    s
}

/// [`http`] with the body sent chunked (no `Content-Length`), in chunks of 8 KiB.
pub fn http_chunked(
    addr: &str,
    method: &str,
    target: &str,
    headers: &[(&str, &str)],
    body: &[u8],
) -> Reply {
    let mut s = open(addr, method, target, headers, "Transfer-Encoding: chunked");
    for chunk in body.chunks(8192) {
        // The server may answer and close before the whole body is sent.
        if s.write_all(format!("{:x}\r\n", chunk.len()).as_bytes())
            .is_err()
            || s.write_all(chunk).is_err()
            || s.write_all(b"\r\n").is_err()
        {
            break;
        }
    }
    let _ = s.write_all(b"0\r\n\r\n");
    read_reply(&mut s)
}

/// The status, head and body of the answer on `s`.
fn read_reply(s: &mut TcpStream) -> Reply {
    let mut raw = Vec::new();
    let _ = s.read_to_end(&mut raw);
    let split = raw
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .unwrap_or_else(|| panic!("no HTTP answer: {}", String::from_utf8_lossy(&raw)));
    let head = String::from_utf8_lossy(&raw[..split]).into_owned();
    let status = head.split(' ').nth(1).unwrap().parse().unwrap();
    Reply {
        status,
        head,
        body: raw[split + 4..].to_vec(),
    }
}

pub fn floats(body: &[u8]) -> Vec<f32> {
    body.chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect()
}
