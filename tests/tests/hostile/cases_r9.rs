//! Round 9: the device's replies as hostile input. What answers on the
//! port may be a board of another protocol version, a half-flashed one, a
//! USB-serial adapter echoing bytes, or another program: a fake device
//! ([`Fake`], the simulated firmware core behind a local TCP port, each of
//! its replies passed through one [`Mutation`]) stands in for each, and
//! `{fake:NAME}` in a row is its `--port`.
//!
//! - An `Info` no LM firmware of this lmhost sends (another protocol
//!   version, 0 slots, a `max_chunk` of 0, 0 transducers, more library
//!   free than it holds, a minimum dwell above a second) is refused where the client reads it, naming the
//!   port and the field: it was driven (an upload reported done on a v5
//!   board), looped on (1-byte chunks, a session past any deadline) or
//!   blamed on the user's flags (exit 2, "--slot 0 does not exist").
//! - A `Status` no firmware reports (a slot beyond the device's count,
//!   playing with mute reason "stopped", playing without a slot) is
//!   refused, not printed or taken as the user's `--slot`.
//! - Every link error names the port, and a wrong kind of reply says what
//!   came (`stream` said "unexpected response to status: ack").
//! - A request that went unanswered says what came instead: the port's
//!   own frames echoed, bytes that are no frame, replies with another
//!   request's seq.
//! - A link that loses replies: a centroid resent after its ack was lost
//!   is the one the device took (its `OutOfOrder` for the copy ended
//!   `stream`), and Ctrl-C ends an upload between two of its frames (it
//!   was held up for as long as the rest of the upload took, 90 s on a
//!   device answering every other request).
//! - A reply with the request's seq that echoes another request: a line
//!   replaying the previous reply, a device making up acks (for version 6,
//!   matched by seq alone, a forged ack of a chunk counted as landed).

use std::collections::BTreeMap;
use std::io::Write as _;
use std::net::{TcpListener, TcpStream};
use std::sync::{Mutex, OnceLock};
use std::time::Duration;

use lm_proto::{
    DeviceState, Echo, FeedResult, FrameDecoder, Head, Info, Message, MessageType, MuteReason,
    Status,
};
use lmhost::device::simdev::{Core as _, FwCore, SimConfig};

use super::*;

/// What a fake device does to the simulated firmware's replies.
#[derive(Clone, Copy)]
pub(crate) enum Mutation {
    /// Changes every `Info`.
    Info(fn(&mut Info)),
    /// Changes every `Status`.
    Status(fn(&mut Status)),
    /// Answers every request with this message instead.
    Every(Message<'static>),
    /// Answers with the seq of the request before.
    PreviousSeq,
    /// Sends the host's bytes back (a loopback, an adapter with nothing
    /// behind it).
    Echo,
    /// Another program: text lines, never a frame delimiter.
    Text,
    /// Loses the reply of every other request (of this type, or of any).
    LoseEveryOther(Option<MessageType>),
    /// Answers with the request's seq but an echo it made up: a reply
    /// written before the request was (its CRC guessed wrong).
    ForgedEcho,
    /// Answers each request after the first with the reply to the one
    /// before, given the new seq (a line replaying what it carried).
    Replay,
}

/// The fakes by name, for `{fake:NAME}`.
fn mutation(name: &str) -> Mutation {
    match name {
        "proto5" => Mutation::Info(|i| i.proto_version = 5),
        "slots0" => Mutation::Info(|i| i.slots = 0),
        "chunk0" => Mutation::Info(|i| i.max_chunk = 0),
        "transducers0" => Mutation::Info(|i| i.max_transducers = 0),
        "free" => Mutation::Info(|i| i.library_free = u32::MAX),
        "dwell_max" => Mutation::Info(|i| i.min_dwell_us = u32::MAX),
        "slot200" => Mutation::Status(|s| s.slot = Some(200)),
        "playing_stopped" => Mutation::Status(|s| {
            s.state = DeviceState::Playing;
            s.slot = Some(0);
            s.mute_reason = MuteReason::Stopped;
        }),
        "ack" => Mutation::Every(Message::Ack),
        "status" => Mutation::Every(Message::Status(Status {
            state: DeviceState::Idle,
            slot: None,
            step: 0,
            cycles: 0,
            missed_deadlines: 0,
            last_centroid_seq: 0,
            bad_frames: 0,
            crc_errors: 0,
            nacks: 0,
            correction_um: [0; 3],
            queued_slot: None,
            mute_reason: MuteReason::None,
            lease_ms: 0,
            lease_expiries: 0,
            uptime_ms: 0,
        })),
        "prev_seq" => Mutation::PreviousSeq,
        "echo" => Mutation::Echo,
        "text" => Mutation::Text,
        "lossy" => Mutation::LoseEveryOther(None),
        "lossy_centroids" => Mutation::LoseEveryOther(Some(MessageType::Centroid)),
        "forged_echo" => Mutation::ForgedEcho,
        "replay" => Mutation::Replay,
        other => {
            super::cases_r16w::mutation(other).unwrap_or_else(|| panic!("no fake device `{name}`"))
        }
    }
}

/// A fake device listening on a local TCP port, one connection at a time,
/// each a freshly reset device.
struct Fake;

impl Fake {
    /// Starts a fake applying `m`; returns its `--port`.
    fn start(m: Mutation) -> String {
        let listener = TcpListener::bind("127.0.0.1:0").expect("a local TCP port");
        let port = listener.local_addr().unwrap().port();
        std::thread::spawn(move || {
            for conn in listener.incoming().flatten() {
                let _ = serve(conn, m);
            }
        });
        format!("tcp:127.0.0.1:{port}")
    }
}

/// One connection: the bytes read go to a fresh simulated firmware, its
/// replies out through `m`.
fn serve(mut conn: TcpStream, m: Mutation) -> std::io::Result<()> {
    conn.set_read_timeout(Some(Duration::from_millis(1)))?;
    let mut core = FwCore::new(SimConfig::default()).expect("the simulated firmware");
    let t0 = std::time::Instant::now();
    let (mut buf, mut out) = (vec![0u8; 4096], Vec::new());
    let mut decoder = FrameDecoder::new();
    // The host's requests by seq, and how many replies the loss counts.
    let (mut requests, mut seen) = (FrameDecoder::new(), BTreeMap::<u16, MessageType>::new());
    let mut answered = 0u64;
    // The reply before, for `Replay`.
    let mut previous: Option<(Head, Message<'static>)> = None;
    loop {
        let now = t0.elapsed().as_micros() as u64;
        core.poll(now);
        let n = match crate::link_support::read_within(&mut conn, &mut buf)? {
            Some(0) => return Ok(()),
            Some(n) => n,
            None => continue,
        };
        match m {
            Mutation::Echo => {
                conn.write_all(&buf[..n])?;
                continue;
            }
            Mutation::Text => {
                conn.write_all(b"AT\r\nOK\r\nready> ")?;
                continue;
            }
            _ => {}
        }
        let mut input = &buf[..n];
        loop {
            input = match requests.feed(input) {
                FeedResult::Consumed => break,
                FeedResult::Frame { frame, remaining } => {
                    seen.insert(frame.seq, frame.message.msg_type());
                    remaining
                }
                FeedResult::Error { remaining, .. } => remaining,
            };
        }
        out.clear();
        core.receive(now, &buf[..n], &mut out);
        let mut input = &out[..];
        let mut frames = Vec::new();
        loop {
            input = match decoder.feed(input) {
                FeedResult::Consumed => break,
                FeedResult::Frame { frame, remaining } => {
                    let lost = match m {
                        Mutation::LoseEveryOther(only)
                            if only.is_none() || only == seen.get(&frame.seq).copied() =>
                        {
                            answered += 1;
                            answered.is_multiple_of(2)
                        }
                        _ => false,
                    };
                    let head = frame.head();
                    let reply = (head, copy(&frame.message));
                    if !lost {
                        frames.push(match (m, previous) {
                            (Mutation::Replay, Some((before, msg))) => encode(
                                Head {
                                    seq: head.seq,
                                    ..before
                                },
                                &msg,
                            ),
                            _ => mutate(head, &frame.message, m),
                        });
                    }
                    previous = Some(reply);
                    remaining
                }
                FeedResult::Error { remaining, .. } => remaining,
            };
        }
        for f in frames {
            conn.write_all(&f)?;
        }
    }
}

/// One reply (`head`, `msg`) as the fake sends it.
fn mutate(head: Head, msg: &Message<'_>, m: Mutation) -> Vec<u8> {
    let seq = head.seq;
    let (seq, msg) = match (m, msg) {
        (Mutation::Info(f), Message::Info(i)) => {
            let mut i = *i;
            f(&mut i);
            (seq, Message::Info(i))
        }
        (Mutation::Status(f), Message::Status(s)) => {
            let mut s = *s;
            f(&mut s);
            (seq, Message::Status(s))
        }
        (Mutation::Every(reply), _) => (seq, reply),
        (Mutation::PreviousSeq, _) => (seq.wrapping_sub(1), copy(msg)),
        _ => (seq, copy(msg)),
    };
    let echo = match (m, head.echo) {
        (Mutation::ForgedEcho, Some(e)) => Echo {
            request_crc32: e.request_crc32 ^ 0x5A5A_5A5A,
            ..e
        },
        (_, Some(e)) => e,
        (_, None) => panic!("the device sent a reply without an echo"),
    };
    encode(Head::reply(seq, echo), &msg)
}

/// `msg` framed with `head`.
fn encode(head: Head, msg: &Message<'_>) -> Vec<u8> {
    let mut buf = vec![0u8; lm_proto::MAX_ENCODED_FRAME];
    let n = lm_proto::encode_frame(head, msg, &mut buf).expect("a reply encodes");
    buf.truncate(n);
    buf
}

/// A reply, owned (replies borrow nothing).
fn copy(msg: &Message<'_>) -> Message<'static> {
    match msg {
        Message::Ack => Message::Ack,
        Message::Nack(c) => Message::Nack(*c),
        Message::Info(i) => Message::Info(*i),
        Message::Status(s) => Message::Status(*s),
        Message::SelfTestResult(t) => Message::SelfTestResult(*t),
        _ => panic!("the device sent a request"),
    }
}

/// `s` with every `{fake:NAME}` replaced by that fake's port, started on
/// first use and kept for the suite.
pub(crate) fn expand_fakes(s: &str) -> String {
    static FAKES: OnceLock<Mutex<BTreeMap<String, String>>> = OnceLock::new();
    let Some((before, rest)) = s.split_once("{fake:") else {
        return s.to_owned();
    };
    let (name, after) = rest.split_once('}').expect("`{fake:NAME}`");
    let port = FAKES
        .get_or_init(Default::default)
        .lock()
        .unwrap()
        .entry(name.to_owned())
        .or_insert_with(|| Fake::start(mutation(name)))
        .clone();
    format!("{before}{port}{}", expand_fakes(after))
}

pub(crate) fn round9_cases() -> Vec<Case> {
    table! {
        // 1. An Info no LM firmware of this lmhost sends.
        DEVICE_INFO "info --port {fake:proto5}" .code(1).err("protocol version 5, and this lmhost speaks 7").err("tcp:127.0.0.1:");
        DEVICE_INFO "upload --radius 3 --foci 4 --no-play --port {fake:proto5}" .code(1).err("protocol version 5");
        DEVICE_INFO "doctor --port {fake:proto5}" .code(1).out("protocol version 5");
        DEVICE_INFO "upload --radius 3 --no-play --port {fake:chunk0}" .code(1).err("max_chunk 0");
        DEVICE_INFO "play --untracked --port {fake:slots0}" .code(1).err("slots 0");
        DEVICE_INFO "upload --radius 3 --no-play --port {fake:transducers0}" .code(1).err("max_transducers 0");
        DEVICE_INFO "stream --synthetic --seconds 0.3 --port {fake:free}" .code(1).err("library_free 4294967295");
        // A minimum dwell no device has is its fault, not the sequence's.
        DEVICE_INFO "info --port {fake:dwell_max}" .code(1).err("min_dwell_us 4294967295").err("tcp:127.0.0.1:");
        DEVICE_INFO "upload --radius 3 --foci 4 --no-play --port {fake:dwell_max}" .code(1).err("min_dwell_us 4294967295");
        // 2. A Status no firmware reports.
        DEVICE_STATUS "status --port {fake:slot200}" .code(1).err("slot 200, and the device has 32 slots");
        DEVICE_STATUS "stream --synthetic --seconds 0.3 --port {fake:slot200}" .code(1).err("the status from tcp:127.0.0.1:");
        DEVICE_STATUS "status --port {fake:playing_stopped}" .code(1).err("state playing with mute reason `stopped`");
        // 3. Link errors name the port and the reply.
        DEVICE_NAMED "stream --synthetic --seconds 0.3 --port {fake:ack}" .code(1).err("127.0.0.1:").err("with an ack");
        DEVICE_NAMED "stop --port {fake:status}" .code(1).err("127.0.0.1:").err("answered stop with a status");
        // 4. An unanswered request says what came instead.
        DEVICE_HEARD "info --timeout-ms 100 --tries 3 --port {fake:echo}" .code(1).err("echoed lmhost's own frames back");
        DEVICE_HEARD "status --timeout-ms 100 --tries 3 --port {fake:text}" .code(1).err("none an LM protocol frame");
        DEVICE_HEARD "info --timeout-ms 100 --tries 3 --port {fake:prev_seq}" .code(1).err("replies came with another request's seq");
        // 5. A link that loses replies.
        DEVICE_LOSSY "stream --synthetic --seconds 0.5 --timeout-ms 50 --port {fake:lossy_centroids}" .ok().out("streamed");
        DEVICE_LOSSY "upload --radius 3 --untracked --timeout-ms 100 --port {fake:lossy}" .signal("TERM", 1500).code(1).err("stopped by a signal before it was committed");
        // 6. A reply that echoes another request than the one written.
        DEVICE_UNBOUND "info --port {fake:forged_echo}" .code(1).err("the info from tcp:127.0.0.1:").err("the info request lmhost wrote has type 0x01");
        DEVICE_UNBOUND "stop --port {fake:forged_echo}" .code(1).err("the ack from tcp:127.0.0.1:").err("answers a request of type 0x07");
        DEVICE_UNBOUND "upload --radius 3 --no-play --port {fake:forged_echo}" .code(1).err("127.0.0.1:").err("made up before the request");
        DEVICE_UNBOUND "status --port {fake:replay}" .code(1).err("the info from tcp:127.0.0.1:").err("answers a request of type 0x01").err("the status request lmhost wrote has type 0x09");
    }
}
