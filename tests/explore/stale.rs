//! A request the page stops waiting for (it aborts a stale one, so its connection closes) stops
//! the evaluation behind it at its next chunk instead of running on for no one.

use super::server::Server;
use std::io::Write;
use std::net::TcpStream;
use std::time::{Duration, Instant};

/// How long the server may take to notice the closed connection and the job its next chunk.
const STOP_TIMEOUT: Duration = Duration::from_secs(60);

#[test]
fn a_dropped_request_stops_its_evaluation() {
    // The f64 reference: an albedo of 64 directions there takes seconds, far longer than the
    // moment the request is left open.
    let server = Server::start(&["--backend", "cpu", "cook_torrance"]);
    assert_eq!(server.get_json("/api/status")["stopped"], 0);
    let body = r#"{"model": "cook_torrance", "samples": 64}"#;
    let mut s = TcpStream::connect(&server.addr).unwrap();
    write!(
        s,
        "POST /api/albedo HTTP/1.1\r\nHost: {}\r\nx-lobe-token: {}\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n{body}",
        server.addr,
        server.token,
        body.len()
    )
    .unwrap();
    std::thread::sleep(Duration::from_millis(300));
    drop(s);
    let start = Instant::now();
    while server.get_json("/api/status")["stopped"] != 1 {
        assert!(
            start.elapsed() < STOP_TIMEOUT,
            "the evaluation of a request whose connection closed was not stopped"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}
