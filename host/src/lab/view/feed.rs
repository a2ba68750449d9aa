//! A page's WebSocket: the frames (its overlay as JSON, then the JPEG),
//! the event log and the question from the view; from the page, a word
//! for every frame it took (`{"type":"took","seq":N,"drawn":B}`) and the
//! pongs to the view's pings.
//!
//! The frames are flow-controlled: at most [`FRAMES_IN_FLIGHT`] frames
//! the page has not taken yet are on their way, and the frame sent when
//! one is taken is the newest. A page slower than the video (a loaded
//! machine, a throttled tab, a slow link) draws fewer frames, each of them
//! fresh, and hears of a new question at once: nothing queues behind it
//! but those few frames. Without this the frames queued in the socket and
//! the browser at the video's rate, the question waited behind seconds of
//! them, and the view dropped the page when its write finally stalled.
//!
//! A page is dropped only when it is gone: it closed, or it neither said
//! anything (a frame taken, a pong to the pings sent every
//! [`PING_EVERY`]) nor took a byte for [`SILENT_LIMIT`]. The page
//! reconnects by itself (`view.js`) and is sent the question again.

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use tungstenite::protocol::frame::CloseFrame;
use tungstenite::protocol::frame::coding::CloseCode;
use tungstenite::protocol::{Role, WebSocketConfig};
use tungstenite::{Message, WebSocket};

use super::state::{Shared, State};

/// Frames sent that the page has not taken yet, at most.
pub const FRAMES_IN_FLIGHT: usize = 2;
/// How often the view pings a page (its browser answers, busy or not).
pub const PING_EVERY: Duration = Duration::from_secs(5);
/// How long a page may say nothing, or take nothing of what is sent,
/// before it is taken for gone: far beyond a stall of a busy machine or a
/// throttled tab, and a gone page's place is free again after it.
pub const SILENT_LIMIT: Duration = Duration::from_secs(30);
/// The largest message a page may send (its words are a few dozen bytes).
const MAX_PAGE_MESSAGE: usize = 4 * 1024;

/// The reason the view's close frame gives when the session has ended
/// (close code 1000): the page then stops reconnecting.
pub const ENDED: &str = "the session has ended";

/// What the page said, shared by the thread reading it and the one
/// feeding it (changed under the view's lock, so the feeder waiting on
/// the view's condition misses no word).
#[derive(Default)]
pub(super) struct Heard {
    /// The newest frame the page took (drawn or not).
    took: AtomicU64,
    /// Why the page is gone (`None` while it is here).
    gone: Mutex<Option<String>>,
}

impl Heard {
    fn took(&self, sh: &Shared, seq: u64) {
        let g = sh.lock();
        self.took.fetch_max(seq, Ordering::SeqCst);
        drop(g);
        sh.changed.notify_all();
    }

    fn gone(&self, sh: &Shared, why: String) {
        let g = sh.lock();
        let mut gone = self.gone.lock().unwrap_or_else(|e| e.into_inner());
        gone.get_or_insert(why);
        drop(gone);
        drop(g);
        sh.changed.notify_all();
    }

    fn why_gone(&self) -> Option<String> {
        self.gone.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }
}

/// The reading side of a connection whose writes belong to the feeder:
/// what tungstenite would write from here (a pong, the close's echo) is
/// dropped, so no two threads ever write frames into one stream.
pub(super) struct ReadOnly<R>(pub R);

impl<R: Read> Read for ReadOnly<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.0.read(buf)
    }
}

impl<R> Write for ReadOnly<R> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Serves a page on an upgraded connection until the view closes or the
/// page goes: a thread reads the page, this one feeds it. `None` when it
/// ended well (the page or its browser went, or the session ended), else
/// why the page was dropped.
pub(super) fn serve(
    stream: std::net::TcpStream,
    sh: &Shared,
    participant: bool,
    page: u64,
) -> Option<String> {
    // The timeouts of a gone page: what a live one, however busy, meets.
    let _ = stream.set_read_timeout(Some(SILENT_LIMIT));
    let _ = stream.set_write_timeout(Some(SILENT_LIMIT));
    let Ok(rd) = stream.try_clone() else {
        return Some("its connection could not be read".into());
    };
    let heard = Heard::default();
    std::thread::scope(|scope| {
        let reader = std::thread::Builder::new()
            .name("lmhost-view-page".into())
            .spawn_scoped(scope, || read_page(ReadOnly(rd), sh, &heard, page));
        if reader.is_err() {
            return Some("no thread to read it".to_owned());
        }
        let ws = WebSocket::from_raw_socket(&stream, Role::Server, None);
        let fed = feed(ws, sh, participant, &heard);
        // The reader ends with the connection.
        let _ = stream.shutdown(std::net::Shutdown::Both);
        fed.err()
    })
}

/// Why a page that closed its connection, or whose browser went, is gone.
const CLOSED: &str = "it closed";

/// Whether `e` says the page went (closed, reset, the browser gone): no
/// fault of the view's or the page's to report.
fn went(e: &tungstenite::Error) -> bool {
    use std::io::ErrorKind as K;
    match e {
        tungstenite::Error::ConnectionClosed
        | tungstenite::Error::AlreadyClosed
        | tungstenite::Error::Protocol(
            tungstenite::error::ProtocolError::ResetWithoutClosingHandshake,
        ) => true,
        tungstenite::Error::Io(e) => matches!(
            e.kind(),
            K::ConnectionReset | K::ConnectionAborted | K::BrokenPipe | K::UnexpectedEof
        ),
        _ => false,
    }
}

/// Whether `e` is a read or a write that timed out.
fn timed_out(e: &tungstenite::Error) -> bool {
    matches!(e, tungstenite::Error::Io(e) if matches!(
        e.kind(),
        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
    ))
}

/// Reads what the page says until it goes: frames taken (and drawn, for
/// the view's figures), pongs; a page silent for [`SILENT_LIMIT`] (the
/// connection's read timeout) is gone.
pub(super) fn read_page<S: Read + Write>(stream: S, sh: &Shared, heard: &Heard, page: u64) {
    let config = WebSocketConfig::default()
        .read_buffer_size(MAX_PAGE_MESSAGE)
        .max_message_size(Some(MAX_PAGE_MESSAGE))
        .max_frame_size(Some(MAX_PAGE_MESSAGE));
    let mut ws = WebSocket::from_raw_socket(stream, Role::Server, Some(config));
    let why = loop {
        match ws.read() {
            Ok(Message::Text(t)) => {
                let v: serde_json::Value = serde_json::from_str(t.as_str()).unwrap_or_default();
                if v["type"] == "took"
                    && let Some(seq) = v["seq"].as_u64()
                {
                    if v["drawn"] == true {
                        sh.drawn(page, seq);
                    }
                    heard.took(sh, seq);
                }
            }
            Ok(Message::Close(_)) => break CLOSED.to_owned(),
            Ok(_) => {}
            Err(e) if timed_out(&e) => {
                break format!("it said nothing for {} s", SILENT_LIMIT.as_secs());
            }
            Err(e) if went(&e) => break CLOSED.to_owned(),
            Err(e) => break format!("reading it: {e}"),
        }
    };
    heard.gone(sh, why);
}

/// Sends the page every frame it is ready for (at most
/// [`FRAMES_IN_FLIGHT`] not taken; the newest), the event log's new lines
/// (the experimenter's) and the question, and a ping every
/// [`PING_EVERY`], until the view closes (`Ok`) or the page goes.
pub(super) fn feed<S: Read + Write>(
    mut ws: WebSocket<S>,
    sh: &Shared,
    participant: bool,
    heard: &Heard,
) -> Result<(), String> {
    let (mut frame, mut log) = (0u64, 0u64);
    // The question the page was last told of (`None`: not told yet; the
    // first says so even when none is asked, a page that reconnects may
    // show one since gone).
    let mut question: Option<Option<u64>> = None;
    // Frames sent and not taken yet, oldest first.
    let mut sent: VecDeque<u64> = VecDeque::with_capacity(FRAMES_IN_FLIGHT);
    let mut pinged = Instant::now();
    let mut first = true;
    loop {
        let mut s = sh.lock();
        let took = heard.took.load(Ordering::SeqCst);
        sent.retain(|&q| q > took);
        let ready = sent.len() < FRAMES_IN_FLIGHT;
        let fresh = |s: &State| {
            s.closed
                || heard.gone.lock().is_ok_and(|g| g.is_some())
                || (ready && s.encoded.as_ref().is_some_and(|e| e.seq != frame))
                || (!participant && s.log_total != log)
                || Some(s.question.as_ref().map(|q| q.seq)) != question
                || pinged.elapsed() >= PING_EVERY
        };
        if !first && !fresh(&s) {
            s = sh.wait(s, Duration::from_millis(250));
        }
        first = false;
        if s.closed {
            drop(s);
            let _ = ws.send(Message::Close(Some(CloseFrame {
                code: CloseCode::Normal,
                reason: ENDED.into(),
            })));
            // The page's answer to the close, briefly, before the
            // connection goes (a close before it could cost the page the
            // view's word, and the page would try to reconnect).
            let t0 = Instant::now();
            let mut s = sh.lock();
            while heard.why_gone().is_none() && t0.elapsed() < Duration::from_secs(1) {
                s = sh.wait(s, Duration::from_millis(50));
            }
            return Ok(());
        }
        if let Some(why) = heard.why_gone() {
            return if why == CLOSED { Ok(()) } else { Err(why) };
        }
        let took = heard.took.load(Ordering::SeqCst);
        sent.retain(|&q| q > took);
        let mut out: Vec<Message> = Vec::new();
        if !participant && s.log_total != log {
            let new = (s.log_total - log).min(s.log.len() as u64) as usize;
            let lines: Vec<&String> = s.log.iter().skip(s.log.len() - new).collect();
            // The connection's first: all the view keeps (a page that
            // reconnects shows them once).
            let whole = log == 0;
            out.push(Message::text(
                serde_json::json!({"type": "log", "lines": lines, "whole": whole}).to_string(),
            ));
            log = s.log_total;
        }
        let q = s.question.as_ref().map(|q| q.seq);
        if Some(q) != question {
            out.push(Message::text(
                serde_json::json!({
                    "type": "question",
                    "question": s.question,
                    // Already answered (a page that reconnects, or is
                    // opened again, after its answer): not to be asked.
                    "answered": q.is_some_and(|q| s.answered == q),
                })
                .to_string(),
            ));
            question = Some(q);
        }
        if sent.len() < FRAMES_IN_FLIGHT
            && let Some(e) = s.encoded.clone()
            && e.seq != frame
        {
            let mut meta = serde_json::json!({
                "type": "frame",
                "seq": e.seq,
                "w": e.width,
                "h": e.height,
                "overlay": sh.overlay(&s, participant),
            });
            if !participant {
                meta["state"] = s.state.into();
                meta["mute"] = s.mute.clone().into();
            }
            out.push(Message::text(meta.to_string()));
            out.push(Message::binary(e.jpeg.clone()));
            frame = e.seq;
            sent.push_back(e.seq);
        }
        drop(s);
        if pinged.elapsed() >= PING_EVERY {
            out.push(Message::Ping(Vec::new().into()));
            pinged = Instant::now();
        }
        for m in out {
            match ws.send(m) {
                Ok(()) => {}
                Err(e) if went(&e) => return Ok(()),
                Err(e) if timed_out(&e) => {
                    return Err(format!("it took nothing for {} s", SILENT_LIMIT.as_secs()));
                }
                Err(e) => return Err(format!("writing to it: {e}")),
            }
        }
    }
}

#[cfg(test)]
#[path = "feed_tests.rs"]
mod tests;
