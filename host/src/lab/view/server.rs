//! The view's endpoints over [`super::http`]: the pages, the frame and
//! state endpoints, the participant's answer, and a WebSocket per page
//! (tungstenite over the upgraded connection) that carries the frames
//! and what happens to the browser. Every request carries the view's
//! token (`?token=`, compared in constant time); the endpoints are
//! documented in `lab/view/VIEW.md`.

use std::sync::Arc;

use super::draw;
use super::http::{Request, Response};
use super::state::Shared;

const EXPERIMENTER_HTML: &str = include_str!("experimenter.html");
const PARTICIPANT_HTML: &str = include_str!("participant.html");
const VIEW_JS: &str = include_str!("view.js");

/// Serves on `l` until the view closes.
pub(super) fn spawn(
    l: std::net::TcpListener,
    sh: Arc<Shared>,
) -> anyhow::Result<std::thread::JoinHandle<()>> {
    let closed = sh.clone();
    super::http::serve(l, move || closed.lock().closed, move |r| handle(r, &sh))
}

/// The value of `key` in a query string, percent-decoded.
fn param(query: &str, key: &str) -> Option<String> {
    query.split('&').find_map(|kv| {
        let (k, v) = kv.split_once('=').unwrap_or((kv, ""));
        (k == key).then(|| percent_decode(v))
    })
}

fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'%' if i + 2 < b.len() => {
                match u8::from_str_radix(std::str::from_utf8(&b[i + 1..i + 3]).unwrap_or("zz"), 16)
                {
                    Ok(v) => {
                        out.push(v);
                        i += 3;
                        continue;
                    }
                    Err(_) => out.push(b'%'),
                }
            }
            b'+' => out.push(b' '),
            c => out.push(c),
        }
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Equal strings, in time that does not depend on where they differ.
fn same(a: &str, b: &str) -> bool {
    a.len() == b.len()
        && a.bytes()
            .zip(b.bytes())
            .fold(0u8, |acc, (x, y)| acc | (x ^ y))
            == 0
}

fn text(code: u16, msg: &str) -> Response {
    Response::text(code, msg)
}

fn bytes(mime: &'static str, b: Vec<u8>) -> Response {
    Response::bytes(mime, b)
}

fn handle(req: Request, sh: &Arc<Shared>) {
    let (path, query) = (req.path.clone(), req.query.clone());
    let query = query.as_str();
    // Unknown paths first: which paths exist is no secret (VIEW.md).
    const KNOWN: [&str; 9] = [
        "/",
        "/participant",
        "/ws",
        "/frame.png",
        "/frame.jpg",
        "/state.json",
        "/pressure.png",
        "/answer",
        "/drawn",
    ];
    if !KNOWN.contains(&path.as_str()) {
        req.respond(text(404, "not found"));
        return;
    }
    let token_ok = param(query, "token").is_some_and(|t| same(&t, &sh.token));
    if !token_ok {
        req.respond(text(
            403,
            "forbidden: open the address lmhost printed (it carries the session's token)",
        ));
        return;
    }
    let get = req.method == "GET";
    let post = req.method == "POST";
    let r = match (path.as_str(), get, post) {
        ("/", true, _) => bytes(
            "text/html; charset=utf-8",
            EXPERIMENTER_HTML
                .replace("/*VIEW_JS*/", VIEW_JS)
                .into_bytes(),
        ),
        ("/participant", true, _) => bytes(
            "text/html; charset=utf-8",
            PARTICIPANT_HTML
                .replace("/*VIEW_JS*/", VIEW_JS)
                .into_bytes(),
        ),
        ("/ws", true, _) => return websocket(req, sh, param(query, "role").as_deref()),
        ("/frame.png", true, _) => frame_png(sh, param(query, "radius_mm").as_deref()),
        ("/frame.jpg", true, _) => match sh.lock().encoded.clone() {
            Some(e) => bytes("image/jpeg", e.jpeg.clone()),
            None => text(503, "no frame yet"),
        },
        ("/state.json", true, _) => bytes("application/json", state_json(sh).into_bytes()),
        // Seconds of work, on this connection's own thread.
        ("/pressure.png", true, _) => pressure(sh),
        ("/answer", _, true) => {
            let seq = param(query, "seq").and_then(|s| s.parse().ok());
            match (seq, param(query, "choice")) {
                (Some(seq), Some(c)) => match sh.answer(seq, &c) {
                    Ok(()) => text(200, "ok"),
                    Err(m) => text(409, &m),
                },
                _ => text(400, "give seq and choice"),
            }
        }
        ("/drawn", _, true) => match (
            param(query, "page").and_then(|s| s.parse().ok()),
            param(query, "seq").and_then(|s| s.parse().ok()),
        ) {
            (Some(p), Some(s)) => {
                sh.drawn(p, s);
                text(200, "ok")
            }
            // Counted in the view's figures: not dropped with an "ok".
            _ => text(400, "give page and seq as whole numbers"),
        },
        (
            "/" | "/participant" | "/ws" | "/frame.png" | "/frame.jpg" | "/state.json"
            | "/pressure.png",
            _,
            _,
        )
        | ("/answer" | "/drawn", _, _) => text(405, "method not allowed"),
        _ => text(404, "not found"),
    };
    req.respond(r);
}

fn frame_png(sh: &Shared, radius: Option<&str>) -> Response {
    let radius = match radius.map(str::parse::<f64>) {
        None => None,
        Some(Ok(r)) if r.is_finite() && r > 0.0 && r <= 50.0 => Some(r),
        Some(_) => return text(400, "radius_mm must be a number of millimetres in (0, 50]"),
    };
    match sh.snapshot(radius) {
        Some((rgb, w, h)) => match draw::png(&rgb, w, h) {
            Ok(b) => bytes("image/png", b),
            Err(e) => text(500, &e.to_string()),
        },
        None => text(503, "no frame yet"),
    }
}

fn state_json(sh: &Shared) -> String {
    let s = sh.lock();
    let v = serde_json::json!({
        "state": s.state,
        "mute": s.mute,
        "question": s.question,
        "overlay": sh.overlay(&s, false),
        "frame": s.encoded.as_ref().map(|e| e.seq),
    });
    drop(s);
    let mut v = v;
    v["figures"] = serde_json::to_value(sh.figures()).unwrap_or_default();
    v.to_string()
}

fn pressure(sh: &Shared) -> Response {
    let Some(plan) = sh.playing_plan() else {
        return text(409, "nothing plays now");
    };
    let view = crate::field::study::View {
        size_mm: (20.0, 20.0),
        step_mm: 0.4,
        center_mm: None,
        axes: None,
        rad: crate::field::Radiation::default(),
        density: crate::field::DEFAULT_DENSITY_KG_M3,
        disk_mm: crate::field::study::DISK_MM,
        calibration: None,
        reference: false,
    };
    match crate::field::study::simulate_plan(&plan, &view)
        .and_then(|s| draw::heat_png(&s.maps.mean_pressure_pa, s.maps.nu, s.maps.nv, 8))
    {
        Ok(b) => bytes("image/png", b),
        Err(e) => text(500, &crate::error::one_line(&e)),
    }
}

/// Upgrades to a WebSocket and feeds the page from a thread of its own;
/// refused past [`super::MAX_CLIENTS`].
fn websocket(req: Request, sh: &Arc<Shared>, role: Option<&str>) {
    let participant = match role {
        Some("participant") => true,
        Some("experimenter") | None => false,
        Some(_) => {
            req.respond(text(400, "role is experimenter or participant"));
            return;
        }
    };
    let Some(key) = req.header("Sec-WebSocket-Key").map(str::to_owned) else {
        req.respond(text(400, "a WebSocket upgrade is expected here"));
        return;
    };
    {
        let mut s = sh.lock();
        if s.clients >= super::MAX_CLIENTS {
            drop(s);
            req.respond(text(503, "too many pages open"));
            return;
        }
        s.clients += 1;
    }
    let accept = tungstenite::handshake::derive_accept_key(key.as_bytes());
    let upgraded = req.upgrade(&[
        ("Upgrade", "websocket"),
        ("Connection", "Upgrade"),
        ("Sec-WebSocket-Accept", &accept),
    ]);
    // On this connection's thread (and one that reads the page); a page
    // is dropped only when it is gone (`feed.rs`).
    if let Ok(stream) = upgraded {
        let page = {
            let mut s = sh.lock();
            s.pages += 1;
            // Not the ids pages give `/drawn` (below 2^53, from JavaScript).
            (1 << 60) + s.pages
        };
        if let Some(why) = super::feed::serve(stream, sh, participant, page) {
            let role = if participant {
                "participant"
            } else {
                "experimenter"
            };
            crate::errln!(
                "lmhost: view: the {role}'s page was dropped: {why}; it reconnects when it can"
            );
        }
    }
    sh.lock().clients -= 1;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn queries_decode_and_tokens_compare_whole() {
        assert_eq!(param("a=1&token=x%20y&b", "token").as_deref(), Some("x y"));
        assert_eq!(param("choice=4", "choice").as_deref(), Some("4"));
        assert_eq!(param("a=1", "b"), None);
        assert_eq!(percent_decode("%4"), "%4");
        assert!(same("abc", "abc"));
        assert!(!same("abc", "abd") && !same("abc", "ab"));
    }
}
