//! The live page (`play --human … --live PORT`): one page served on 127.0.0.1 only, with the
//! replay's 3D scene of the game so far (replayed from the arm's latest move as it comes), a
//! board to click the person's moves on, the move list and the built-in engine's evaluation.
//!
//! Routes: `GET /` the page; `GET /state` the game as JSON (FEN, moves, side to move, legal
//! moves in UCI, evaluation, status, a version that changes with every update); `GET /replay`
//! the replay page of the game so far; `POST /move` a move in UCI or SAN, and `POST /command`
//! `undo`, `resign`, `draw` or `quit` — each handed to the game as the person's line.
//!
//! Only the page itself may drive the game. Any web site the person visits can make their
//! browser send requests to 127.0.0.1 (a form's POST needs no permission), and a site whose
//! name is made to resolve to 127.0.0.1 (DNS rebinding) can even read the answers. So every
//! request must name this server in its `Host` (127.0.0.1 or localhost, with the port); a
//! request a browser marks with another site's `Origin` (or, for a POST without one, `Referer`)
//! is refused; and every route but the page carries the run's token, a random number the page
//! holds and no other site can read (the page itself is served only at the address chessarm
//! prints, which carries the token, so another user of the machine cannot read it off the
//! page). Refused requests get 403 and change nothing.
//!
//! Each connection is served by a thread of its own (at most [`MAX_CONNECTIONS`] at once, the
//! oldest silent one closed to make room) and must deliver its whole request within
//! [`REQUEST_DEADLINE`]: a slow or idle client holds only its own connection, for a bounded time. A move or command is taken only while the game
//! waits for the person: one sent while the arm moves (or a second click before the first is
//! played) is refused with 409 and the reason, never queued for later.

use anyhow::{Context, Result};
use std::io::{BufRead, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, Sender};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};

const PAGE: &str = include_str!("../../assets/live.html");
/// Where the page carries the run's token.
const TOKEN_PLACEHOLDER: &str = "{{chessarm-token}}";
/// Largest request head (request line and headers), bytes.
pub const MAX_HEAD: usize = 8 * 1024;
/// Largest request body, bytes (a move or a command is a few bytes).
pub const MAX_BODY: usize = 1024;
/// Connections served at once; more are answered 503 at once.
pub const MAX_CONNECTIONS: usize = 16;
/// Time a client has to send its whole request (a browser on the same machine takes
/// milliseconds); after it the connection is closed.
pub const REQUEST_DEADLINE: Duration = Duration::from_secs(2);
/// Time a client has to take the whole answer (the replay page is a few MB; loopback moves
/// hundreds of MB a second).
const RESPONSE_DEADLINE: Duration = Duration::from_secs(20);

/// What the page shows, replaced as the game goes on, and whether the game waits for the
/// person's move now.
#[derive(Debug, Default)]
struct Shown {
    version: u64,
    state: serde_json::Value,
    replay: Vec<u8>,
    awaiting: bool,
}

/// What the server threads share with the game.
#[derive(Debug)]
struct Shared {
    shown: Mutex<Shown>,
    /// The run's token, which the page carries and every request but the page must give.
    token: String,
    port: u16,
    person: Mutex<Sender<String>>,
    connections: AtomicUsize,
    /// The connections that have not yet sent their request's head, oldest first: when every
    /// place is taken, the oldest of them gives its place to a new one (idle connections
    /// cannot keep the page from its own requests).
    waiting: Mutex<Vec<(u64, TcpStream)>>,
    next_id: std::sync::atomic::AtomicU64,
}

impl Shared {
    fn shown(&self) -> MutexGuard<'_, Shown> {
        self.shown.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// The page's server: its address (with the run's token) and what it shows.
#[derive(Debug)]
pub struct LivePage {
    pub url: String,
    shared: Arc<Shared>,
}

impl LivePage {
    /// Serves the page on 127.0.0.1:`port` (0: a free port); the person's lines (clicked moves
    /// and commands) come from the returned [`PageLines`].
    ///
    /// # Errors
    ///
    /// The port is taken or cannot be bound (the message names it).
    pub fn serve(port: u16) -> Result<(Self, PageLines)> {
        let listener = TcpListener::bind(("127.0.0.1", port)).with_context(|| {
            format!("--live {port}: cannot serve on 127.0.0.1:{port} (taken by another program?); give another port, or 0 for any free one")
        })?;
        let address = listener.local_addr()?;
        let (sender, receiver) = std::sync::mpsc::channel();
        let shared = Arc::new(Shared {
            shown: Mutex::new(Shown::default()),
            token: new_token(),
            port: address.port(),
            person: Mutex::new(sender),
            connections: AtomicUsize::new(0),
            waiting: Mutex::new(Vec::new()),
            next_id: std::sync::atomic::AtomicU64::new(0),
        });
        let serving = Arc::clone(&shared);
        std::thread::spawn(move || {
            for stream in listener.incoming().flatten() {
                accept(stream, &serving);
            }
        });
        let lines = PageLines { receiver, shared: Arc::clone(&shared), pending: Vec::new(), at: 0 };
        let url = format!("http://{address}/?token={}", shared.token);
        Ok((Self { url, shared }, lines))
    }

    /// Shows `state` and the replay page `replay`.
    pub fn show(&self, mut state: serde_json::Value, replay: Vec<u8>) {
        let mut shown = self.shared.shown();
        shown.version += 1;
        state["version"] = serde_json::json!(shown.version);
        shown.state = state;
        shown.replay = replay;
    }
}

/// A token no other site can guess: 128 bits from the operating system's random source (not
/// the simulation's seeded generator, whose numbers anyone can reproduce).
fn new_token() -> String {
    let mut bytes = [0u8; 16];
    let read = std::fs::File::open("/dev/urandom").and_then(|mut f| f.read_exact(&mut bytes));
    if read.is_err() {
        // No /dev/urandom (a sandbox): the standard library's per-process random hash keys.
        use std::hash::{BuildHasher, Hasher};
        for (k, chunk) in bytes.chunks_mut(8).enumerate() {
            let mut hasher = std::collections::hash_map::RandomState::new().build_hasher();
            hasher.write_usize(k);
            chunk.copy_from_slice(&hasher.finish().to_le_bytes());
        }
    }
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Serves a new connection on a thread of its own, or answers 503 when [`MAX_CONNECTIONS`]
/// are being served.
fn accept(mut stream: TcpStream, shared: &Arc<Shared>) {
    if shared.connections.fetch_add(1, Ordering::SeqCst) >= MAX_CONNECTIONS {
        // Every place is taken: the oldest connection still silent is closed for this one
        // (its thread ends at once, a read on a closed socket returning nothing); when all are
        // busy with requests, this one is turned away.
        let oldest = {
            let mut waiting = shared.waiting.lock().unwrap_or_else(PoisonError::into_inner);
            (!waiting.is_empty()).then(|| waiting.remove(0))
        };
        match oldest {
            Some((_, idle)) => {
                let _ = idle.shutdown(std::net::Shutdown::Both);
            }
            None => {
                shared.connections.fetch_sub(1, Ordering::SeqCst);
                let _ = stream.set_write_timeout(Some(Duration::from_millis(100)));
                let _ = respond(&mut stream, &Answer::text("503 Service Unavailable", "busy: too many connections"));
                return;
            }
        }
    }
    let shared_count = Arc::clone(shared);
    let shared = Arc::clone(shared);
    let spawned = std::thread::Builder::new().name("live page".into()).spawn(move || {
        let _ = handle(stream, &shared);
        shared.connections.fetch_sub(1, Ordering::SeqCst);
    });
    if spawned.is_err() {
        // No thread to be had: the connection is closed (dropped with the closure) and its
        // place given back.
        shared_count.connections.fetch_sub(1, Ordering::SeqCst);
    }
}

/// A request as read: its method, path, query, headers (names in lower case) and body.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Request {
    pub method: String,
    pub path: String,
    pub query: String,
    pub headers: Vec<(String, String)>,
    pub body: Vec<u8>,
}

impl Request {
    /// The first value of header `name` (lower case).
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_str())
    }

    /// The value of `key` in the query string.
    fn query_value(&self, key: &str) -> Option<&str> {
        self.query.split('&').find_map(|pair| pair.strip_prefix(key).and_then(|rest| rest.strip_prefix('=')))
    }
}

/// Why a request was not read, as its answer says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Malformed {
    /// The head is longer than [`MAX_HEAD`].
    HeadTooLong,
    /// The body is longer than [`MAX_BODY`].
    BodyTooLong,
    /// Not an HTTP/1 request line and headers.
    BadRequest,
}

impl Malformed {
    fn answer(self) -> Answer {
        match self {
            Self::HeadTooLong => Answer::text("431 Request Header Fields Too Large", "the request's head is too long"),
            Self::BodyTooLong => Answer::text("413 Payload Too Large", "the request's body is too long"),
            Self::BadRequest => Answer::text("400 Bad Request", "not an HTTP request"),
        }
    }
}

/// Where the head ends in `bytes` (the index after its blank line), if it has ended.
pub fn head_end(bytes: &[u8]) -> Option<usize> {
    bytes.windows(4).position(|w| w == b"\r\n\r\n").map(|at| at + 4).or_else(|| {
        // Bare line feeds, as some clients send.
        bytes.windows(2).position(|w| w == b"\n\n").map(|at| at + 2)
    })
}

/// Parses a request head (`head`, up to and including its blank line): the request line and
/// the headers, and the body's length from `Content-Length`.
///
/// # Errors
///
/// Not a request line and headers, more than [`MAX_HEAD`] bytes, or a body longer than
/// [`MAX_BODY`] (or a length that is not a number, or given twice differently).
pub fn parse_head(head: &[u8]) -> Result<(Request, usize), Malformed> {
    if head.len() > MAX_HEAD {
        return Err(Malformed::HeadTooLong);
    }
    let text = std::str::from_utf8(head).map_err(|_| Malformed::BadRequest)?;
    let mut lines = text.split('\n').map(|line| line.strip_suffix('\r').unwrap_or(line));
    let request_line = lines.next().ok_or(Malformed::BadRequest)?;
    let mut words = request_line.split(' ');
    let (Some(method), Some(target), Some(version), None) = (words.next(), words.next(), words.next(), words.next())
    else {
        return Err(Malformed::BadRequest);
    };
    if !version.starts_with("HTTP/1.")
        || method.is_empty()
        || !method.bytes().all(|b| b.is_ascii_uppercase())
        || !target.starts_with('/')
    {
        return Err(Malformed::BadRequest);
    }
    let (path, query) = target.split_once('?').unwrap_or((target, ""));
    let mut headers = Vec::new();
    let mut length: Option<usize> = None;
    for line in lines {
        if line.is_empty() {
            break;
        }
        let (name, value) = line.split_once(':').ok_or(Malformed::BadRequest)?;
        if name.is_empty() || name.bytes().any(|b| b.is_ascii_whitespace() || b.is_ascii_control()) {
            return Err(Malformed::BadRequest);
        }
        let name = name.to_ascii_lowercase();
        let value = value.trim().to_string();
        if name == "content-length" {
            let n: usize = value.parse().map_err(|_| Malformed::BadRequest)?;
            if length.is_some_and(|l| l != n) {
                return Err(Malformed::BadRequest);
            }
            length = Some(n);
        }
        if name == "transfer-encoding" {
            // Chunked bodies are not read: a move fits in a Content-Length body.
            return Err(Malformed::BadRequest);
        }
        headers.push((name, value));
    }
    let length = length.unwrap_or(0);
    if length > MAX_BODY {
        return Err(Malformed::BodyTooLong);
    }
    let request = Request {
        method: method.to_string(),
        path: path.to_string(),
        query: query.to_string(),
        headers,
        body: Vec::new(),
    };
    Ok((request, length))
}

/// Whether `request` may be served by the page at 127.0.0.1:`port` whose token is `token`:
/// `Err` with why not (answered 403).
///
/// # Errors
///
/// A foreign `Host`, another site's `Origin` or `Referer`, a POST that names no origin, or a
/// route other than the page without the run's token.
pub fn authorize(request: &Request, port: u16, token: &str) -> Result<(), &'static str> {
    let own_host = |host: &str| {
        let host = host.to_ascii_lowercase();
        host == format!("127.0.0.1:{port}") || host == format!("localhost:{port}")
    };
    let own_origin = |origin: &str| origin.strip_prefix("http://").is_some_and(own_host);
    if !request.header("host").is_some_and(own_host) {
        return Err("this page answers only requests for its own address (Host)");
    }
    if request.header("origin").is_some_and(|origin| !own_origin(origin)) {
        return Err("requests from other sites are refused (Origin)");
    }
    let referer_origin = request.header("referer").map(|referer| {
        let rest = referer.strip_prefix("http://").unwrap_or("");
        format!("http://{}", rest.split('/').next().unwrap_or(""))
    });
    if referer_origin.as_deref().is_some_and(|origin| !own_origin(origin)) {
        return Err("requests from other sites are refused (Referer)");
    }
    if request.method == "POST" && request.header("origin").is_none() && referer_origin.is_none() {
        return Err("a move or command must come from the page (no Origin)");
    }
    // Only the icon is open: the page itself is served with the token in its address (as
    // chessarm prints it), so that another user of this machine cannot read the token off it.
    let open = request.method == "GET" && request.path == "/favicon.ico";
    let given = request.header("x-chessarm-token").or_else(|| request.query_value("token"));
    if !open && given != Some(token) {
        return Err("the request does not carry this game's token (reload the page chessarm printed)");
    }
    Ok(())
}

/// An answer: status line, content type and body.
#[derive(Debug)]
struct Answer {
    status: &'static str,
    kind: &'static str,
    body: Vec<u8>,
}

impl Answer {
    fn text(status: &'static str, text: &str) -> Self {
        Self { status, kind: "text/plain; charset=utf-8", body: text.as_bytes().to_vec() }
    }
}

fn respond(stream: &mut TcpStream, answer: &Answer) -> std::io::Result<()> {
    let head = format!(
        "HTTP/1.1 {}\r\nContent-Type: {}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\nX-Frame-Options: SAMEORIGIN\r\nConnection: close\r\n\r\n",
        answer.status,
        answer.kind,
        answer.body.len()
    );
    let deadline = Instant::now() + RESPONSE_DEADLINE;
    for chunk in std::iter::once(head.as_bytes()).chain(answer.body.chunks(64 * 1024)) {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(std::io::ErrorKind::TimedOut.into());
        }
        stream.set_write_timeout(Some(left))?;
        stream.write_all(chunk)?;
    }
    stream.flush()
}

/// Reads one request from `stream` within [`REQUEST_DEADLINE`] (`Ok(None)`: the client closed
/// the connection or ran out of time, and gets no answer).
fn read_request(stream: &mut TcpStream) -> std::io::Result<Option<Result<Request, Malformed>>> {
    let deadline = Instant::now() + REQUEST_DEADLINE;
    let mut bytes = Vec::with_capacity(1024);
    let mut chunk = [0u8; 1024];
    let mut read = |stream: &mut TcpStream, bytes: &mut Vec<u8>| -> std::io::Result<bool> {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Ok(false);
        }
        stream.set_read_timeout(Some(left))?;
        match stream.read(&mut chunk) {
            Ok(0) => Ok(false),
            Ok(n) => {
                bytes.extend_from_slice(&chunk[..n]);
                Ok(true)
            }
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => Ok(false),
            Err(e) => Err(e),
        }
    };
    let end = loop {
        if let Some(end) = head_end(&bytes) {
            break end;
        }
        if bytes.len() > MAX_HEAD {
            return Ok(Some(Err(Malformed::HeadTooLong)));
        }
        if !read(stream, &mut bytes)? {
            return Ok(None);
        }
    };
    let (mut request, length) = match parse_head(&bytes[..end]) {
        Ok(parsed) => parsed,
        Err(malformed) => return Ok(Some(Err(malformed))),
    };
    while bytes.len() < end + length {
        if !read(stream, &mut bytes)? {
            return Ok(None);
        }
    }
    request.body = bytes[end..end + length].to_vec();
    Ok(Some(Ok(request)))
}

/// One connection: its request, read within the deadline, and the answer.
fn handle(mut stream: TcpStream, shared: &Shared) -> std::io::Result<()> {
    let id = shared.next_id.fetch_add(1, Ordering::SeqCst);
    if let Ok(clone) = stream.try_clone() {
        shared.waiting.lock().unwrap_or_else(PoisonError::into_inner).push((id, clone));
    }
    let read = read_request(&mut stream);
    shared.waiting.lock().unwrap_or_else(PoisonError::into_inner).retain(|(waiting, _)| *waiting != id);
    let answer = match read? {
        None => return Ok(()),
        Some(Err(malformed)) => malformed.answer(),
        Some(Ok(request)) => match authorize(&request, shared.port, &shared.token) {
            Err(why) => Answer::text("403 Forbidden", why),
            Ok(()) => route(&request, shared),
        },
    };
    respond(&mut stream, &answer)
}

fn route(request: &Request, shared: &Shared) -> Answer {
    let html = "text/html; charset=utf-8";
    match (request.method.as_str(), request.path.as_str()) {
        ("GET", "/") => {
            Answer { status: "200 OK", kind: html, body: PAGE.replace(TOKEN_PLACEHOLDER, &shared.token).into_bytes() }
        }
        ("GET", "/state") => {
            let state = shared.shown().state.to_string();
            Answer { status: "200 OK", kind: "application/json", body: state.into_bytes() }
        }
        ("GET", "/replay") => Answer { status: "200 OK", kind: html, body: shared.shown().replay.clone() },
        ("POST", "/move" | "/command") => {
            // One line, no line breaks of its own: the person's input, as typed.
            let body = String::from_utf8_lossy(&request.body);
            let line: String = body.trim().chars().filter(|c| !c.is_control()).take(64).collect();
            if line.is_empty() {
                return Answer::text("400 Bad Request", "no move or command was sent");
            }
            let mut shown = shared.shown();
            if shown.state["over"] == serde_json::json!(true) {
                return Answer::text("409 Conflict", "the game is over");
            }
            if !shown.awaiting {
                return Answer::text(
                    "409 Conflict",
                    "not now: the arm is moving (or your last move is being played); wait until the page says it is your move",
                );
            }
            // What the game would refuse is answered now, with why (the page shows it).
            if let Err(why) = check_line(request.path.as_str(), &line, &shown.state) {
                return Answer {
                    status: "422 Unprocessable Content",
                    kind: "text/plain; charset=utf-8",
                    body: why.into_bytes(),
                };
            }
            // Taken: the next line waits until the game asks for the person's move again.
            shown.awaiting = false;
            let sent = shared.person.lock().unwrap_or_else(PoisonError::into_inner).send(line);
            if sent.is_err() {
                return Answer::text("409 Conflict", "the game does not take moves now");
            }
            Answer::text("202 Accepted", "ok")
        }
        // No icon: nothing for the browser to complain of.
        ("GET", "/favicon.ico") => Answer { status: "204 No Content", kind: "image/x-icon", body: Vec::new() },
        ("GET" | "POST", _) => Answer::text("404 Not Found", "not found"),
        _ => Answer::text("405 Method Not Allowed", "only GET and POST"),
    }
}

/// Whether `line` sent to `path` is one the game takes in the shown `state`: a legal move (UCI
/// or SAN) in the position shown, or one of the commands; `Err` with why not.
fn check_line(path: &str, line: &str, state: &serde_json::Value) -> Result<(), String> {
    let shown = crate::app::text::escape_controls(line);
    if path == "/command" {
        return match line.to_ascii_lowercase().as_str() {
            // An undo takes back the person's last move and the arm's reply.
            "undo" if state["plies"].as_u64().unwrap_or(0) < 2 => {
                Err("nothing to take back: you have not moved yet".to_string())
            }
            "undo" | "resign" | "draw" | "quit" => Ok(()),
            _ => Err(format!("'{shown}' is not a command (undo, resign, draw or quit)")),
        };
    }
    let position = state["fen"].as_str().and_then(|fen| chessarm_chess::notation::parse_fen(fen).ok());
    let Some(position) = position else { return Err("the game has no position to move in yet".to_string()) };
    chessarm_chess::notation::parse_move(line, &position)
        .map(drop)
        .map_err(|problem| format!("'{shown}' {problem} in this position (click a piece, then its square)"))
}

/// The person's lines from the page, as a line reader for [`super::input::Person`]: while it
/// waits for a line the page takes one move or command; at any other time it refuses them.
#[derive(Debug)]
pub struct PageLines {
    receiver: Receiver<String>,
    shared: Arc<Shared>,
    pending: Vec<u8>,
    at: usize,
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
            // The game waits for the person: the page may send one line now.
            self.shared.shown().awaiting = true;
            // Waits for the page's next line, Ctrl-C checked twice a second.
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

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn request(text: &str) -> Request {
        let (mut request, length) = parse_head(text.as_bytes()).unwrap();
        request.body = vec![b'x'; length];
        request
    }

    const TOKEN: &str = "0123456789abcdef0123456789abcdef";

    #[test]
    fn only_the_pages_own_requests_are_served() {
        let own = "Host: 127.0.0.1:8080\r\nOrigin: http://127.0.0.1:8080\r\nX-Chessarm-Token: 0123456789abcdef0123456789abcdef\r\n";
        let post = |headers: &str| request(&format!("POST /move HTTP/1.1\r\n{headers}Content-Length: 4\r\n\r\n"));
        assert_eq!(authorize(&post(own), 8080, TOKEN), Ok(()));
        // A form or fetch from another site: its Origin.
        let evil = "Host: 127.0.0.1:8080\r\nOrigin: http://evil.example\r\nX-Chessarm-Token: 0123456789abcdef0123456789abcdef\r\n";
        assert!(authorize(&post(evil), 8080, TOKEN).is_err());
        // DNS rebinding: the browser names the other site as the host.
        let rebound =
            request("GET /state?token=0123456789abcdef0123456789abcdef HTTP/1.1\r\nHost: evil.example\r\n\r\n");
        assert!(authorize(&rebound, 8080, TOKEN).unwrap_err().contains("Host"));
        // Another port on this machine is another site.
        let other_port = request("GET / HTTP/1.1\r\nHost: 127.0.0.1:8081\r\n\r\n");
        assert!(authorize(&other_port, 8080, TOKEN).is_err());
        // Without the token (the page was not read), or with a wrong one.
        assert!(authorize(&post("Host: localhost:8080\r\nOrigin: http://localhost:8080\r\n"), 8080, TOKEN).is_err());
        let wrong = "Host: 127.0.0.1:8080\r\nOrigin: http://127.0.0.1:8080\r\nX-Chessarm-Token: 00\r\n";
        assert!(authorize(&post(wrong), 8080, TOKEN).is_err());
        // A POST naming no origin at all is not the page's.
        let bare = "Host: 127.0.0.1:8080\r\nX-Chessarm-Token: 0123456789abcdef0123456789abcdef\r\n";
        assert!(authorize(&post(bare), 8080, TOKEN).unwrap_err().contains("Origin"));
        // A Referer from another site.
        let referred = "Host: 127.0.0.1:8080\r\nReferer: http://127.0.0.1.evil.example/x\r\nX-Chessarm-Token: 0123456789abcdef0123456789abcdef\r\n";
        assert!(authorize(&post(referred), 8080, TOKEN).is_err());
        // The page itself and its state need the token, in a header or the query.
        assert!(authorize(&request("GET / HTTP/1.1\r\nHost: localhost:8080\r\n\r\n"), 8080, TOKEN).is_err());
        let page = request("GET /?token=0123456789abcdef0123456789abcdef HTTP/1.1\r\nHost: localhost:8080\r\n\r\n");
        assert_eq!(authorize(&page, 8080, TOKEN), Ok(()));
        assert!(authorize(&request("GET /state HTTP/1.1\r\nHost: 127.0.0.1:8080\r\n\r\n"), 8080, TOKEN).is_err());
        let replay =
            request("GET /replay?v=3&token=0123456789abcdef0123456789abcdef HTTP/1.1\r\nHost: 127.0.0.1:8080\r\n\r\n");
        assert_eq!(authorize(&replay, 8080, TOKEN), Ok(()));
    }

    #[test]
    fn heads_are_parsed_strictly_and_bounded() {
        let (request, length) = parse_head(b"POST /move?x=1 HTTP/1.1\r\nHost: a\r\nContent-Length: 4\r\n\r\n").unwrap();
        assert_eq!(
            (request.method.as_str(), request.path.as_str(), request.query.as_str(), length),
            ("POST", "/move", "x=1", 4)
        );
        assert_eq!(request.header("host"), Some("a"));
        assert_eq!(parse_head(b"GET / HTTP/1.1\r\nContent-Length: 99999\r\n\r\n"), Err(Malformed::BodyTooLong));
        assert_eq!(parse_head(b"GET / HTTP/1.1\r\nContent-Length: -1\r\n\r\n"), Err(Malformed::BadRequest));
        assert_eq!(
            parse_head(b"GET / HTTP/1.1\r\nContent-Length: 1\r\nContent-Length: 2\r\n\r\n"),
            Err(Malformed::BadRequest)
        );
        assert_eq!(parse_head(b"GET / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n"), Err(Malformed::BadRequest));
        assert_eq!(parse_head(b"GET http://x/ HTTP/1.1\r\n\r\n"), Err(Malformed::BadRequest));
        assert_eq!(parse_head(b"\x00\x01\r\n\r\n"), Err(Malformed::BadRequest));
        let long = format!("GET / HTTP/1.1\r\nX: {}\r\n\r\n", "a".repeat(MAX_HEAD));
        assert_eq!(parse_head(long.as_bytes()), Err(Malformed::HeadTooLong));
        assert_eq!(head_end(b"GET / HTTP/1.1\r\nHost: a\r\n\r\nbody"), Some(27));
        assert_eq!(head_end(b"GET / HTTP/1.1\r\nHost: a\r\n"), None);
    }

    /// Sends `text` and reads the whole answer.
    fn exchange(port: u16, text: &str) -> String {
        let mut stream = TcpStream::connect(("127.0.0.1", port)).unwrap();
        stream.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
        stream.write_all(text.as_bytes()).unwrap();
        let mut answer = String::new();
        stream.read_to_string(&mut answer).unwrap();
        answer
    }

    /// A client sending a byte every half second holds only its own connection: requests made
    /// meanwhile are answered while it still drips, and it is cut off at the deadline.
    #[test]
    fn a_slow_client_does_not_hold_the_page() {
        let (page, _lines) = LivePage::serve(0).unwrap();
        let port = page.shared.port;
        let token = page.shared.token.clone();
        page.show(serde_json::json!({"over": false}), Vec::new());
        let dripping = std::thread::spawn(move || {
            let mut stream = TcpStream::connect(("127.0.0.1", port)).unwrap();
            let started = Instant::now();
            // 20 bytes over 10 s if the server let it: it must close the connection first.
            for byte in b"GET /state HTTP/1.1\r\n".iter().take(20) {
                if stream.write_all(&[*byte]).is_err() {
                    break;
                }
                std::thread::sleep(Duration::from_millis(500));
                let mut probe = [0u8; 1];
                stream.set_nonblocking(true).unwrap();
                let closed = matches!(stream.read(&mut probe), Ok(0));
                stream.set_nonblocking(false).unwrap();
                if closed {
                    break;
                }
            }
            started.elapsed()
        });
        // Every place taken by idle connections as well: the oldest give way.
        let idle: Vec<TcpStream> =
            (0..MAX_CONNECTIONS + 4).map(|_| TcpStream::connect(("127.0.0.1", port)).unwrap()).collect();
        std::thread::sleep(Duration::from_millis(200));
        for _ in 0..5 {
            let answer = exchange(
                port,
                &format!("GET /state HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nX-Chessarm-Token: {token}\r\n\r\n"),
            );
            assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
        }
        assert!(!dripping.is_finished(), "the dripping client was cut off before the others were served");
        let held = dripping.join().unwrap();
        // Cut off at the 2 s deadline, noticed within a half-second drip: well under the 10 s
        // it would take to send its 20 bytes.
        assert!(held < Duration::from_secs(6), "the slow client held its connection {held:?}");
        drop(idle);
    }

    /// A move is taken only while the game waits for one; a second click before the first is
    /// played is refused, not queued.
    #[test]
    fn moves_out_of_turn_are_refused_not_queued() {
        let (page, mut lines) = LivePage::serve(0).unwrap();
        let port = page.shared.port;
        let token = page.shared.token.clone();
        let start = "rnbqkbnr/pppppppp/8/8/8/8/PPPPPPPP/RNBQKBNR w KQkq - 0 1";
        page.show(serde_json::json!({"over": false, "fen": start}), Vec::new());
        let post = |body: &str| {
            exchange(
                port,
                &format!(
                    "POST /move HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nOrigin: http://127.0.0.1:{port}\r\nX-Chessarm-Token: {token}\r\nContent-Length: {}\r\n\r\n{body}",
                    body.len()
                ),
            )
        };
        // The arm is moving: nothing waits for the person.
        assert!(post("e2e4").starts_with("HTTP/1.1 409"));
        // The game asks for the person's move (on another thread, as the game does).
        let reader = std::thread::spawn(move || {
            let mut line = String::new();
            lines.read_line(&mut line).unwrap();
            (line, lines)
        });
        let accepted = loop {
            let answer = post("d2d4");
            if answer.starts_with("HTTP/1.1 202") {
                break answer;
            }
            assert!(answer.starts_with("HTTP/1.1 409"), "{answer}");
            std::thread::sleep(Duration::from_millis(20));
        };
        assert!(accepted.ends_with("ok"));
        // (Taken: what follows is refused as out of turn, whatever it is.)
        let refused = post("g1f3");
        assert!(refused.starts_with("HTTP/1.1 409") && refused.contains("not now"), "{refused}");
        let (line, mut lines) = reader.join().unwrap();
        assert_eq!(line, "d2d4\n");
        // The game asks again: a move that is not legal, or not a move, is answered with why
        // (422) and the game goes on waiting.
        let reader = std::thread::spawn(move || {
            let mut line = String::new();
            lines.read_line(&mut line).unwrap();
            line
        });
        let illegal = loop {
            let answer = post("e2e5");
            if !answer.contains("not now") {
                break answer;
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        assert!(illegal.starts_with("HTTP/1.1 422") && illegal.contains("'e2e5'"), "{illegal}");
        assert!(post("xx\u{1b}").starts_with("HTTP/1.1 422"));
        assert!(post("Nf3").starts_with("HTTP/1.1 202"));
        assert_eq!(reader.join().unwrap(), "Nf3\n");
        // Another site's request changes nothing.
        let evil = exchange(
            port,
            &format!(
                "POST /command HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nOrigin: http://evil.example\r\nContent-Type: text/plain\r\nContent-Length: 4\r\n\r\nquit"
            ),
        );
        assert!(evil.starts_with("HTTP/1.1 403"), "{evil}");
    }
}
