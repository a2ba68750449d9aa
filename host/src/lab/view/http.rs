//! The view's HTTP/1.1 layer: std's `TcpListener`, a thread per
//! connection (at most [`MAX_CONNECTIONS`]), each request's head read
//! under bounds and parsed by `httparse` (hyper's parser), one request per
//! connection (`Connection: close`), and the WebSocket upgrade handed to
//! tungstenite. Bounded because a page's address may be typed, pasted or
//! scanned by anything on the host: a request line over [`MAX_LINE`]
//! bytes is answered 414, a head over [`MAX_HEAD`] bytes or
//! [`MAX_HEADERS`] headers 431, a body over [`MAX_BODY`] 413, a client
//! that has not sent its whole request within [`IO_TIMEOUT`] (nothing, or
//! a byte now and then) is answered 408 and dropped, and so is a client
//! that takes nothing of an answer for as long (a page's WebSocket has
//! timeouts of its own: `view/feed.rs`).

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// The longest request line (method, path and query, version).
pub const MAX_LINE: usize = 8 * 1024;
/// The longest request head (line and headers).
pub const MAX_HEAD: usize = 16 * 1024;
/// The most headers in a request.
pub const MAX_HEADERS: usize = 48;
/// The largest request body taken (the view's requests carry none).
pub const MAX_BODY: u64 = 4 * 1024;
/// Most connections served at once (pages, WebSockets, snapshots); the
/// rest are answered 503 at once.
pub const MAX_CONNECTIONS: usize = 32;
/// How long a client may keep a read or a write waiting, and take to send
/// its whole request (a WebSocket then has [`super::feed::SILENT_LIMIT`]).
pub const IO_TIMEOUT: Duration = Duration::from_secs(5);

/// One request, its connection still open for the answer.
pub struct Request {
    /// `GET`, `POST`, …
    pub method: String,
    /// The path, without the query.
    pub path: String,
    /// What follows `?` (may be empty).
    pub query: String,
    headers: Vec<(String, String)>,
    stream: TcpStream,
}

/// An answer: status, content type, body.
pub struct Response {
    code: u16,
    mime: &'static str,
    body: Vec<u8>,
}

impl Response {
    /// `body` as `mime`, status 200.
    pub fn bytes(mime: &'static str, body: Vec<u8>) -> Self {
        Self {
            code: 200,
            mime,
            body,
        }
    }

    /// A one-line plain text answer.
    pub fn text(code: u16, msg: &str) -> Self {
        Self {
            code,
            mime: "text/plain; charset=utf-8",
            body: format!("{msg}\n").into_bytes(),
        }
    }
}

fn reason(code: u16) -> &'static str {
    match code {
        101 => "Switching Protocols",
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        409 => "Conflict",
        413 => "Content Too Large",
        414 => "URI Too Long",
        431 => "Request Header Fields Too Large",
        500 => "Internal Server Error",
        503 => "Service Unavailable",
        _ => "",
    }
}

impl Request {
    /// The value of header `name` (case-insensitive).
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
    }

    /// Answers and closes the connection.
    pub fn respond(self, r: Response) {
        respond(self.stream, &r);
    }

    /// Answers 101 with `headers` and hands over the connection.
    pub fn upgrade(mut self, headers: &[(&str, &str)]) -> std::io::Result<TcpStream> {
        let mut head = String::from("HTTP/1.1 101 Switching Protocols\r\n");
        for (k, v) in headers {
            head.push_str(&format!("{k}: {v}\r\n"));
        }
        head.push_str("\r\n");
        self.stream.write_all(head.as_bytes())?;
        Ok(self.stream)
    }
}

fn respond(mut s: TcpStream, r: &Response) {
    let head = format!(
        "HTTP/1.1 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n",
        r.code,
        reason(r.code),
        r.mime,
        r.body.len()
    );
    let _ = s
        .write_all(head.as_bytes())
        .and_then(|()| s.write_all(&r.body));
    let _ = s.flush();
    let _ = s.shutdown(std::net::Shutdown::Write);
    // What the client still sends is read (a little, briefly) before the
    // socket closes: closing on unread bytes resets the connection, and a
    // reset can lose the answer on its way.
    let _ = s.set_read_timeout(Some(Duration::from_millis(200)));
    let _ = std::io::copy(&mut (&mut s).take(256 * 1024), &mut std::io::sink());
}

/// Reads one request's head (and a small body) from `s`; a refusal is
/// the answer to give.
pub fn read_request(mut s: TcpStream) -> Result<Request, (TcpStream, Response)> {
    let mut buf = Vec::with_capacity(1024);
    let mut chunk = [0u8; 2048];
    // One deadline for the whole request: a read timeout alone restarts
    // with every byte, so a client sending one every few seconds would
    // hold its place among MAX_CONNECTIONS for hours.
    let deadline = Instant::now() + IO_TIMEOUT;
    let late = || Response::text(408, "the request took too long to arrive");
    let end = loop {
        if let Some(i) = find(&buf, b"\r\n\r\n") {
            break i + 4;
        }
        let line_done = find(&buf, b"\r\n").is_some();
        if !line_done && buf.len() > MAX_LINE {
            return Err((s, Response::text(414, "the request line is too long")));
        }
        if buf.len() > MAX_HEAD {
            return Err((s, Response::text(431, "the request head is too long")));
        }
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() || s.set_read_timeout(Some(left)).is_err() {
            return Err((s, late()));
        }
        // Never more than the bounds past what is there.
        let n = match s.read(&mut chunk) {
            Err(_) if Instant::now() >= deadline => return Err((s, late())),
            Ok(0) | Err(_) => return Err((s, Response::text(400, "the request ended early"))),
            Ok(n) => n,
        };
        buf.extend_from_slice(&chunk[..n]);
    };
    if find(&buf[..end], b"\r\n").is_some_and(|i| i > MAX_LINE) {
        return Err((s, Response::text(414, "the request line is too long")));
    }
    if end > MAX_HEAD {
        return Err((s, Response::text(431, "the request head is too long")));
    }
    let mut headers = [httparse::EMPTY_HEADER; MAX_HEADERS];
    let mut req = httparse::Request::new(&mut headers);
    let parsed = match req.parse(&buf[..end]) {
        Ok(httparse::Status::Complete(_)) => true,
        Ok(httparse::Status::Partial) => false,
        Err(httparse::Error::TooManyHeaders) => {
            return Err((s, Response::text(431, "too many request headers")));
        }
        Err(_) => false,
    };
    let (Some(method), Some(target), true) = (req.method, req.path, parsed) else {
        return Err((s, Response::text(400, "not an HTTP/1.1 request")));
    };
    let (path, query) = target.split_once('?').unwrap_or((target, ""));
    let (method, path, query) = (method.to_owned(), path.to_owned(), query.to_owned());
    let headers: Vec<(String, String)> = req
        .headers
        .iter()
        .map(|h| {
            (
                h.name.to_owned(),
                String::from_utf8_lossy(h.value).into_owned(),
            )
        })
        .collect();
    // A body is read (so closing does not reset the answer) when small.
    let length = headers
        .iter()
        .find(|(k, _)| k.eq_ignore_ascii_case("Content-Length"))
        .map(|(_, v)| v.trim().parse::<u64>());
    let len = match length {
        None => 0,
        Some(Ok(n)) if n <= MAX_BODY => n,
        Some(Ok(_)) => return Err((s, Response::text(413, "the request body is too large"))),
        Some(Err(_)) => return Err((s, Response::text(400, "a bad Content-Length"))),
    };
    let have = (buf.len() - end) as u64;
    if len > have {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() || s.set_read_timeout(Some(left)).is_err() {
            return Err((s, late()));
        }
        let _ = std::io::copy(&mut (&mut s).take(len - have), &mut std::io::sink());
        if Instant::now() >= deadline {
            return Err((s, late()));
        }
    }
    // What follows (the answer's writes, a WebSocket's reads) has its own
    // timeouts again.
    let _ = s.set_read_timeout(Some(IO_TIMEOUT));
    Ok(Request {
        method,
        path,
        query,
        headers,
        stream: s,
    })
}

fn find(h: &[u8], n: &[u8]) -> Option<usize> {
    h.windows(n.len()).position(|w| w == n)
}

/// Binds `addr` (port 0: any free port); returns the bound address.
pub fn bind(addr: SocketAddr) -> anyhow::Result<(TcpListener, SocketAddr)> {
    let l = TcpListener::bind(addr)
        .map_err(|e| anyhow::anyhow!("--view {addr}: cannot listen there ({e})"))?;
    let bound = l.local_addr()?;
    l.set_nonblocking(true)?;
    Ok((l, bound))
}

/// Accepts connections until `closed` says so, each on a thread of its
/// own that reads the request and calls `handle`.
pub fn serve(
    l: TcpListener,
    closed: impl Fn() -> bool + Send + 'static,
    handle: impl Fn(Request) + Send + Sync + 'static,
) -> anyhow::Result<std::thread::JoinHandle<()>> {
    let handle = Arc::new(handle);
    let open = Arc::new(AtomicUsize::new(0));
    Ok(std::thread::Builder::new()
        .name("lmhost-view-http".into())
        .spawn(move || {
            while !closed() {
                let s = match l.accept() {
                    Ok((s, _)) => s,
                    Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                        std::thread::sleep(Duration::from_millis(20));
                        continue;
                    }
                    Err(_) => {
                        std::thread::sleep(Duration::from_millis(20));
                        continue;
                    }
                };
                let _ = s.set_nonblocking(false);
                let _ = s.set_read_timeout(Some(IO_TIMEOUT));
                let _ = s.set_write_timeout(Some(IO_TIMEOUT));
                let _ = s.set_nodelay(true);
                if open.fetch_add(1, Ordering::SeqCst) >= MAX_CONNECTIONS {
                    open.fetch_sub(1, Ordering::SeqCst);
                    respond(s, &Response::text(503, "too many connections"));
                    continue;
                }
                let (open2, handle) = (open.clone(), handle.clone());
                // Not joined: a connection ends within its timeouts.
                let spawned = std::thread::Builder::new()
                    .name("lmhost-view-conn".into())
                    .spawn(move || {
                        match read_request(s) {
                            Ok(r) => handle(r),
                            Err((s, r)) => respond(s, &r),
                        }
                        open2.fetch_sub(1, Ordering::SeqCst);
                    });
                if spawned.is_err() {
                    open.fetch_sub(1, Ordering::SeqCst);
                }
            }
        })?)
}
