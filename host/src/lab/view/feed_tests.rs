//! The feed's flow control and its idea of a gone page, on in-memory
//! connections (no sockets, no clocks).

use super::*;
use crate::lab::view::tests::question;
use crate::lab::view::{Frames, Options, View, default_colour};
use crate::plan::scene::Scene;
use crate::sense::track::colour::ColourImage;
use std::sync::Arc;

/// A connection's far end in memory: what is written is kept; reads
/// give what `input` holds, then "timed out" (a silent page).
#[derive(Clone, Default)]
struct Wire {
    out: Arc<Mutex<Vec<u8>>>,
    input: Arc<Mutex<std::io::Cursor<Vec<u8>>>>,
}

impl Read for Wire {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        match self.input.lock().unwrap().read(buf)? {
            0 => Err(std::io::ErrorKind::TimedOut.into()),
            n => Ok(n),
        }
    }
}

impl Write for Wire {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.out.lock().unwrap().extend_from_slice(b);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// The server's frames written so far (unmasked): opcode and payload.
fn frames(w: &Wire) -> Vec<(u8, Vec<u8>)> {
    let b = w.out.lock().unwrap().clone();
    let (mut out, mut i) = (Vec::new(), 0);
    while i + 2 <= b.len() {
        let op = b[i] & 0x0f;
        let (mut len, mut j) = (usize::from(b[i + 1] & 0x7f), i + 2);
        if len == 126 {
            len = usize::from(u16::from_be_bytes([b[j], b[j + 1]]));
            j += 2;
        } else if len == 127 {
            len = u64::from_be_bytes(b[j..j + 8].try_into().unwrap()) as usize;
            j += 8;
        }
        out.push((op, b[j..j + len].to_vec()));
        i = j + len;
    }
    out
}

/// The text messages of type `kind`.
fn messages(w: &Wire, kind: &str) -> Vec<serde_json::Value> {
    frames(w)
        .into_iter()
        .filter(|(op, _)| *op == 1)
        .map(|(_, p)| serde_json::from_slice::<serde_json::Value>(&p).unwrap())
        .filter(|m| m["type"] == kind)
        .collect()
}

fn jpegs(w: &Wire) -> usize {
    frames(w).iter().filter(|(op, _)| *op == 2).count()
}

/// Waits for `f` (what the other threads do next), never for long.
fn until(what: &str, f: impl Fn() -> bool) {
    let t0 = Instant::now();
    while !f() {
        assert!(t0.elapsed() < Duration::from_secs(60), "never: {what}");
        std::thread::sleep(Duration::from_millis(2));
    }
}

fn view() -> View {
    View::start(Options {
        addr: "127.0.0.1:0".parse().unwrap(),
        scene: Scene::default(),
        colour: default_colour(),
        frames: Frames::Pushed,
        stimuli: Vec::new(),
    })
    .unwrap()
}

/// Pushes a frame and waits for it to be encoded: its seq.
fn frame(v: &View) -> u64 {
    let n = v.shared.lock().encoded.as_ref().map_or(0, |e| e.seq) + 1;
    v.push_frame(ColourImage {
        t_s: n as f64,
        width: 16,
        height: 16,
        rgb: Arc::new(vec![(n % 256) as u8; 16 * 16 * 3]),
    });
    until("the frame encoded", || {
        v.shared.lock().encoded.as_ref().map(|e| e.seq) == Some(n)
    });
    n
}

/// Closes the view when dropped.
struct Ends<'a>(&'a Shared);

impl Drop for Ends<'_> {
    fn drop(&mut self) {
        self.0.close();
    }
}

#[test]
fn a_page_that_takes_nothing_is_sent_no_more_frames_and_still_hears_the_question() {
    let v = view();
    let sh = &v.shared;
    let (heard, heard_again) = (Heard::default(), Heard::default());
    let wire = Wire::default();
    std::thread::scope(|scope| {
        let ws = WebSocket::from_raw_socket(wire.clone(), Role::Server, None);
        let fed = scope.spawn(|| feed(ws, sh, true, &heard));
        // A failed assertion ends the feeder too (else the scope waits).
        let _end = Ends(sh);
        // Frames until the page has its window of them, then many more
        // that it never takes (a stalled page).
        while jpegs(&wire) < FRAMES_IN_FLIGHT {
            frame(&v);
        }
        let mut newest = 0;
        for _ in 0..30 {
            newest = frame(&v);
        }
        // Asked after the last frame: once the question is on its way the
        // feeder has seen every frame, and it sent none past the window.
        v.participant().ask(Some(question(1)));
        until("the question sent", || {
            messages(&wire, "question").len() == 2
        });
        assert_eq!(jpegs(&wire), FRAMES_IN_FLIGHT);
        let q = &messages(&wire, "question");
        // Told at once that none is asked, then of the question.
        assert_eq!(q[0]["question"], serde_json::Value::Null);
        let q = &q[1];
        assert_eq!(q["question"]["seq"], 1);
        assert_eq!(q["answered"], false);
        // The page takes the first: the newest frame comes next.
        let first = messages(&wire, "frame")[0]["seq"].as_u64().unwrap();
        heard.took(sh, first);
        until("a frame after the one taken", || {
            jpegs(&wire) > FRAMES_IN_FLIGHT
        });
        assert_eq!(jpegs(&wire), FRAMES_IN_FLIGHT + 1);
        assert_eq!(
            messages(&wire, "frame").last().unwrap()["seq"],
            newest,
            "the newest frame, not the next"
        );
        // Answered, then the page reconnects: the question comes again,
        // marked answered (the page does not ask it again).
        sh.answer(1, "2").unwrap();
        let again = Wire::default();
        let ws = WebSocket::from_raw_socket(again.clone(), Role::Server, None);
        let fed_again = scope.spawn(|| feed(ws, sh, true, &heard_again));
        until("the question sent again", || {
            !messages(&again, "question").is_empty()
        });
        assert_eq!(messages(&again, "question")[0]["answered"], true);
        // The session ends: each page is told so (and stops reconnecting).
        sh.close();
        assert_eq!(fed.join().unwrap(), Ok(()));
        assert_eq!(fed_again.join().unwrap(), Ok(()));
        let (op, close) = frames(&wire).pop().unwrap();
        assert_eq!(op, 8);
        assert_eq!(u16::from_be_bytes([close[0], close[1]]), 1000);
        assert_eq!(&close[2..], ENDED.as_bytes());
    });
}

/// What a page sends, as its browser frames it (masked).
fn from_page(msgs: &[Message]) -> Wire {
    let mut page = WebSocket::from_raw_socket(Wire::default(), Role::Client, None);
    for m in msgs {
        page.send(m.clone()).unwrap();
    }
    let bytes = page.get_ref().out.lock().unwrap().clone();
    Wire {
        input: Arc::new(Mutex::new(std::io::Cursor::new(bytes))),
        ..Wire::default()
    }
}

#[test]
fn a_page_is_gone_when_silent_or_unruly_and_its_feed_ends() {
    let v = view();
    let sh = &v.shared;
    // A frame taken, then nothing (the connection's read timeout).
    let heard = Heard::default();
    read_page(
        from_page(&[Message::text(r#"{"type":"took","seq":7,"drawn":true}"#)]),
        sh,
        &heard,
        1,
    );
    assert_eq!(heard.took.load(Ordering::SeqCst), 7);
    let why = heard.why_gone().unwrap();
    assert!(why.contains("said nothing"), "{why}");
    // Its feeder stops with that reason.
    let ws = WebSocket::from_raw_socket(Wire::default(), Role::Server, None);
    assert_eq!(feed(ws, sh, true, &heard), Err(why));
    // A message past the bound is not read into memory.
    let heard = Heard::default();
    let big = format!(
        r#"{{"type":"took","seq":9,"pad":"{}"}}"#,
        "x".repeat(64 * 1024)
    );
    read_page(from_page(&[Message::text(big)]), sh, &heard, 1);
    assert_eq!(heard.took.load(Ordering::SeqCst), 0);
    let why = heard.why_gone().unwrap();
    assert!(why.starts_with("reading it"), "{why}");
    // A page that closes is gone without complaint.
    let heard = Heard::default();
    read_page(from_page(&[Message::Close(None)]), sh, &heard, 1);
    let ws = WebSocket::from_raw_socket(Wire::default(), Role::Server, None);
    assert_eq!(feed(ws, sh, true, &heard), Ok(()));
}
