//! The live page (`play --human … --live PORT`): one page served on 127.0.0.1 only, with the
//! replay's 3D scene of the game so far (replayed from the arm's latest move as it comes), a
//! board to click the person's moves on, the move list and the built-in engine's evaluation.
//!
//! Routes: `GET /` the page; `GET /state` the game as JSON (FEN, moves, side to move, legal
//! moves in UCI, evaluation, status, a version that changes with every update); `GET /replay`
//! the replay page of the game so far; `POST /move` a move in UCI or SAN, and `POST /command`
//! `undo`, `resign`, `draw` or `quit` — each handed to the game as the person's line. Requests
//! are served one at a time by one thread, each bounded (8 KB of head, 1 KB of body); the page
//! loads nothing from the network.

use anyhow::{Context, Result};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::mpsc::{Receiver, Sender};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

const PAGE: &str = include_str!("../../assets/live.html");
const MAX_HEAD: usize = 8 * 1024;
const MAX_BODY: usize = 1024;

/// What the page shows, replaced as the game goes on.
#[derive(Debug, Default)]
struct Shown {
    version: u64,
    state: serde_json::Value,
    replay: Vec<u8>,
}

/// The page's server: its address and what it shows.
#[derive(Debug)]
pub struct LivePage {
    pub url: String,
    shown: Arc<Mutex<Shown>>,
}

impl LivePage {
    /// Serves the page on 127.0.0.1:`port` (0: a free port); the person's lines (clicked moves
    /// and commands) go to the returned receiver.
    ///
    /// # Errors
    ///
    /// The port is taken or cannot be bound (the message names it).
    pub fn serve(port: u16) -> Result<(Self, Receiver<String>)> {
        let listener = TcpListener::bind(("127.0.0.1", port)).with_context(|| {
            format!("--live {port}: cannot serve on 127.0.0.1:{port} (taken by another program?); give another port, or 0 for any free one")
        })?;
        let address = listener.local_addr()?;
        let shown = Arc::new(Mutex::new(Shown::default()));
        let (sender, receiver) = std::sync::mpsc::channel();
        let serving = Arc::clone(&shown);
        std::thread::spawn(move || {
            for stream in listener.incoming().flatten() {
                let _ = handle(stream, &serving, &sender);
            }
        });
        Ok((Self { url: format!("http://{address}/"), shown }, receiver))
    }

    /// Shows `state` and the replay page `replay`.
    pub fn show(&self, mut state: serde_json::Value, replay: Vec<u8>) {
        let mut shown = self.shown.lock().unwrap_or_else(PoisonError::into_inner);
        shown.version += 1;
        state["version"] = serde_json::json!(shown.version);
        shown.state = state;
        shown.replay = replay;
    }

    /// Shows a new status line (the rest as it was).
    pub fn status(&self, text: &str) {
        let mut shown = self.shown.lock().unwrap_or_else(PoisonError::into_inner);
        shown.version += 1;
        let version = shown.version;
        shown.state["status"] = serde_json::json!(text);
        shown.state["version"] = serde_json::json!(version);
    }
}

fn respond(stream: &mut TcpStream, status: &str, kind: &str, body: &[u8]) -> std::io::Result<()> {
    write!(
        stream,
        "HTTP/1.1 {status}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n",
        body.len()
    )?;
    stream.write_all(body)?;
    stream.flush()
}

/// One request: its line and headers (bounded), its body, the answer.
fn handle(stream: TcpStream, shown: &Mutex<Shown>, person: &Sender<String>) -> std::io::Result<()> {
    stream.set_read_timeout(Some(Duration::from_secs(5)))?;
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut head = Vec::new();
    let mut length = 0usize;
    loop {
        let mut line = Vec::new();
        let n = (&mut reader).take(MAX_HEAD as u64).read_until(b'\n', &mut line)?;
        head.extend_from_slice(&line);
        if n == 0 || head.len() >= MAX_HEAD {
            return Ok(());
        }
        let text = String::from_utf8_lossy(&line);
        if let Some(value) = text.to_ascii_lowercase().strip_prefix("content-length:") {
            length = value.trim().parse().unwrap_or(usize::MAX);
        }
        if text.trim().is_empty() {
            break;
        }
    }
    let mut stream = stream;
    if length > MAX_BODY {
        return respond(&mut stream, "413 Payload Too Large", "text/plain", b"too long");
    }
    let mut body = vec![0u8; length];
    reader.read_exact(&mut body)?;
    let request = String::from_utf8_lossy(&head);
    let mut words = request.split_whitespace();
    let (method, target) = (words.next().unwrap_or(""), words.next().unwrap_or(""));
    let path = target.split('?').next().unwrap_or("");
    let body = String::from_utf8_lossy(&body).trim().to_string();
    match (method, path) {
        ("GET", "/") => respond(&mut stream, "200 OK", "text/html; charset=utf-8", PAGE.as_bytes()),
        ("GET", "/state") => {
            let state = shown.lock().unwrap_or_else(PoisonError::into_inner).state.to_string();
            respond(&mut stream, "200 OK", "application/json", state.as_bytes())
        }
        ("GET", "/replay") => {
            let replay = shown.lock().unwrap_or_else(PoisonError::into_inner).replay.clone();
            respond(&mut stream, "200 OK", "text/html; charset=utf-8", &replay)
        }
        ("POST", "/move" | "/command") => {
            // One line, no line breaks of its own: the person's input, as typed.
            let line: String = body.chars().filter(|c| !c.is_control()).take(64).collect();
            if line.is_empty() || person.send(line).is_err() {
                return respond(&mut stream, "409 Conflict", "text/plain", b"the game does not take moves now");
            }
            respond(&mut stream, "202 Accepted", "text/plain", b"ok")
        }
        // No icon: nothing for the browser to complain of.
        ("GET", "/favicon.ico") => respond(&mut stream, "204 No Content", "image/x-icon", b""),
        _ => respond(&mut stream, "404 Not Found", "text/plain", b"not found"),
    }
}

/// The person's lines from the page, as a line reader for [`super::input::Person`].
#[derive(Debug)]
pub struct PageLines {
    receiver: Receiver<String>,
    pending: Vec<u8>,
    at: usize,
}

impl PageLines {
    pub fn new(receiver: Receiver<String>) -> Self {
        Self { receiver, pending: Vec::new(), at: 0 }
    }
}

impl Read for PageLines {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        let available = self.fill_buf()?;
        let n = available.len().min(out.len());
        out[..n].copy_from_slice(&available[..n]);
        self.consume(n);
        Ok(n)
    }
}

impl BufRead for PageLines {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        if self.at >= self.pending.len() {
            // Waits for the page's next line, Ctrl-C checked twice a second; none ever again
            // (the server is gone) is the end of the input.
            loop {
                if crate::cancelled() {
                    return Err(std::io::Error::new(std::io::ErrorKind::Interrupted, "interrupted"));
                }
                match self.receiver.recv_timeout(Duration::from_millis(500)) {
                    Ok(line) => {
                        self.pending = format!("{line}\n").into_bytes();
                        self.at = 0;
                        break;
                    }
                    Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
                    Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => return Ok(&[]),
                }
            }
        }
        Ok(&self.pending[self.at..])
    }

    fn consume(&mut self, n: usize) {
        self.at += n;
    }
}
