//! Behaviour of the whole device through the wire protocol, a file per
//! concern; the helpers every file uses are here.

#[path = "../common/mod.rs"]
mod common;
mod lease;
mod output;
mod self_test;
mod timed;
mod upload;

use common::*;
use lm_fw_core::Config;
use lm_proto::codec::Encoding;
use lm_proto::{
    BeginUpload, Centroid, Chunk, Commit, DeviceState, Message, MuteReason, NackCode,
    PROTOCOL_VERSION, PlayAt, UploadHeader,
};

fn centroid(seq: u32, pos_um: [i32; 3], present: bool) -> Message<'static> {
    Message::Centroid(Centroid {
        seq,
        pos_um,
        present,
        host_time_us: 0,
    })
}

/// Asserts the device acks `msg` (sent as `seq` at `now` µs).
#[track_caller]
fn acks(dev: &mut lm_fw_core::Device<'_>, seq: u16, msg: &Message<'_>, now: u64) {
    assert_eq!(request(dev, seq, msg, now), Reply::Ack);
}

/// Asserts the device refuses `msg` (sent as `seq` at `now` µs) with `code`.
#[track_caller]
fn nacks(dev: &mut lm_fw_core::Device<'_>, seq: u16, msg: &Message<'_>, now: u64, code: NackCode) {
    assert_eq!(request(dev, seq, msg, now), Reply::Nack(code));
}

/// Asserts the device refuses each `(seq, msg, code)` in turn, all at 0 µs.
#[track_caller]
fn refuses(dev: &mut lm_fw_core::Device<'_>, table: &[(u16, Message<'_>, NackCode)]) {
    for (seq, msg, code) in table {
        nacks(dev, *seq, msg, 0, *code);
    }
}

/// A device that needs tracking, its slots sized for `seq`, with `seq`
/// uploaded (raw) into slot 0.
fn tracked_device(seq: &Seq) -> lm_fw_core::Device<'static> {
    let mut cfg = config(seq.transducers);
    cfg.require_tracking = true;
    let mut dev = device(cfg, usize::from(seq.steps) * usize::from(seq.transducers));
    seq.upload(&mut dev, 0, Encoding::Raw, 0);
    dev
}

/// A device for 8 transducers with sequence A (10 steps of 1 ms) uploaded
/// (raw) into slot 0; returns A too.
fn device_with_a() -> (lm_fw_core::Device<'static>, Seq) {
    let mut dev = device(config(8), 10 * 8);
    let a = Seq::pattern(10, 8, 10_000, 5);
    a.upload(&mut dev, 0, Encoding::Raw, 0);
    (dev, a)
}

/// [`device_with_a`], and sequence B (5 steps of 2 ms) uploaded as Delta
/// into slot 1.
fn device_with_a_and_b() -> (lm_fw_core::Device<'static>, Seq, Seq) {
    let (mut dev, a) = device_with_a();
    let b = Seq::pattern(5, 8, 10_000, 6);
    b.upload(&mut dev, 1, Encoding::Delta, 0);
    (dev, a, b)
}

fn status(dev: &mut lm_fw_core::Device<'_>, now: u64) -> lm_proto::Status {
    match request(dev, 77, &Message::GetStatus, now) {
        Reply::Status(s) => s,
        r => panic!("expected status, got {r:?}"),
    }
}

/// `play` with the host lease `lease_ms`.
fn leased(play: Message<'static>, lease_ms: u16) -> Message<'static> {
    match play {
        Message::Play(p) => Message::Play(lm_proto::Play { lease_ms, ..p }),
        other => other,
    }
}

fn play_untracked(slot: u8) -> Message<'static> {
    Message::Play(lm_proto::Play {
        slot,
        at: PlayAt::Immediate,
        untracked: true,
        steps: 0,
        lease_ms: lm_proto::DEFAULT_LEASE_MS,
    })
}

/// `Play` of `slot` for `steps` steps (untracked, so it sounds at once).
fn play_steps(slot: u8, at: PlayAt, steps: u32) -> Message<'static> {
    Message::Play(lm_proto::Play {
        slot,
        at,
        untracked: true,
        steps,
        lease_ms: lm_proto::DEFAULT_LEASE_MS,
    })
}

/// Polls at every deadline the device asks for until it has none (or
/// `max` polls), returning the last `now`.
fn poll_out(dev: &mut lm_fw_core::Device<'_>, mut now: u64, out: &mut Capture, max: usize) -> u64 {
    for _ in 0..max {
        match dev.poll(now, out) {
            Some(next) => now = next,
            None => break,
        }
    }
    now
}
