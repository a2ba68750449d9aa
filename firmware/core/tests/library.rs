//! The resident library with the paper's stimulus set on the boards'
//! library size: it fits, every entry plays its phases step by step (Delta
//! entries decoded while playing, across the cycle wrap), a queued entry
//! takes over at the cycle boundary, what does not fit is refused by name,
//! overwriting frees space, an uncommitted entry never plays, and an upload
//! for another rig is refused.

mod common;
// The paper's rig and LM phases, shared with the protocol's codec tests
// (not every piece of it is used here).
#[allow(dead_code)]
#[path = "../../../proto/tests/common/paper.rs"]
mod paper;

use common::*;
use lm_fw_core::{BOARD_LIBRARY_BYTES, Config, Device, SLOTS, memory_bytes};
use lm_proto::codec::Encoding;
use lm_proto::{
    BeginRig, BeginUpload, Chunk, Commit, DeviceState, Geometry, MAX_GEOMETRY_POSITIONS, Message,
    NackCode, PlayAt, Positions, UploadHeader, rig_crc32,
};
use paper::{autd3_2x2_um, lm_phases};

/// One stimulus of the paper's set, planned on `pos`.
#[derive(Clone)]
struct Stim {
    name: String,
    header: UploadHeader,
    phases: Vec<u8>,
}

/// LM with `foci` foci of radius `r_mm` at `freq_hz`, steps of about
/// `step_mm`, focus 200 mm above the array.
fn stim(pos: &[[i32; 3]], foci: usize, r_mm: f64, freq_hz: f64, step_mm: f64) -> Stim {
    let (phases, steps) = lm_phases(pos, foci, r_mm, step_mm, 200.0);
    Stim {
        name: format!(
            "LM-{} {freq_hz} Hz r={r_mm} mm",
            if foci == 1 { "S" } else { "M" }
        ),
        header: UploadHeader {
            steps: steps as u16,
            transducers: pos.len() as u16,
            period_us: (1e6 / freq_hz).round() as u32,
            center_um: [0, 0, 200_000],
            foci_per_step: foci as u8,
            sound_speed_mm_s: 340_000,
            max_offset_um: 20_000,
            intensity: 255,
        },
        phases,
    }
}

/// The paper's 15 stimuli: LM-S and LM-M at 5 Hz with 0.23 mm steps, LM-S
/// at 25 Hz with 4 mm steps, each at radii 2-6 mm.
fn paper_set(pos: &[[i32; 3]]) -> Vec<Stim> {
    let mut v = Vec::new();
    for (foci, freq, step) in [(1, 5.0, 0.23), (4, 5.0, 0.23), (1, 25.0, 4.0)] {
        for r in [2.0, 3.0, 4.0, 5.0, 6.0] {
            v.push(stim(pos, foci, r, freq, step));
        }
    }
    v
}

impl Stim {
    fn step(&self, k: u16) -> &[u8] {
        let t = usize::from(self.header.transducers);
        &self.phases[usize::from(k) * t..][..t]
    }

    fn encode(&self, enc: Encoding) -> Vec<u8> {
        let t = usize::from(self.header.transducers);
        let mut out = vec![0u8; lm_proto::codec::encoded_len(enc, &self.phases, t).unwrap()];
        lm_proto::codec::encode(enc, &self.phases, t, &mut out).unwrap();
        out
    }
}

/// A device with the boards' library and the paper's rig committed.
fn board(pos: &[[i32; 3]]) -> Device<'static> {
    let mut cfg: Config = config(996);
    cfg.require_tracking = false;
    let mem = Box::leak(vec![0u8; memory_bytes(BOARD_LIBRARY_BYTES, 996)].into_boxed_slice());
    let mut dev = Device::new(cfg, mem).unwrap();
    let crc = rig_crc32(&Positions::from_points(pos));
    let begin = Message::BeginRig(BeginRig {
        transducers: pos.len() as u16,
        crc32: crc,
    });
    assert_eq!(request(&mut dev, 1, &begin, 0), Reply::Ack);
    for (i, ps) in pos.chunks(MAX_GEOMETRY_POSITIONS).enumerate() {
        let g = Message::Geometry(Geometry {
            first: (i * MAX_GEOMETRY_POSITIONS) as u16,
            positions: Positions::from_points(ps),
        });
        assert_eq!(request(&mut dev, 2, &g, 0), Reply::Ack);
    }
    assert_eq!(request(&mut dev, 3, &Message::CommitRig, 0), Reply::Ack);
    dev
}

/// `BeginUpload` of `s` into `slot` as `enc`, then `stream`'s chunks: an
/// upload short of its commit.
fn upload_requests<'a>(
    pos: &[[i32; 3]],
    slot: u8,
    s: &Stim,
    enc: Encoding,
    stream: &'a [u8],
) -> Vec<Message<'a>> {
    let mut reqs = vec![Message::BeginUpload(BeginUpload {
        slot,
        header: s.header,
        encoding: enc,
        encoded_len: stream.len() as u32,
        rig_crc32: rig_crc32(&Positions::from_points(pos)),
        intensity_table: false,
    })];
    for (i, c) in stream.chunks(1024).enumerate() {
        reqs.push(Message::Chunk(Chunk {
            slot,
            offset: (i * 1024) as u32,
            data: c,
        }));
    }
    reqs
}

/// The commit of an upload of `phases` into `slot`.
fn commit(slot: u8, phases: &[u8]) -> Message<'static> {
    Message::Commit(Commit {
        slot,
        crc32: lm_proto::crc32(phases),
    })
}

/// Sends `reqs` in order; returns the first nack.
fn send(dev: &mut Device<'_>, reqs: &[Message<'_>], now: u64) -> Result<(), NackCode> {
    for m in reqs {
        match request(dev, 7, m, now) {
            Reply::Ack => {}
            Reply::Nack(c) => return Err(c),
            r => panic!("{r:?}"),
        }
    }
    Ok(())
}

/// Uploads `s` into `slot` as `enc` and commits; returns the first nack.
fn upload(
    dev: &mut Device<'_>,
    pos: &[[i32; 3]],
    slot: u8,
    s: &Stim,
    enc: Encoding,
    now: u64,
) -> Result<(), NackCode> {
    let stream = s.encode(enc);
    let mut reqs = upload_requests(pos, slot, s, enc, &stream);
    reqs.push(commit(slot, &s.phases));
    send(dev, &reqs, now)
}

fn info(dev: &mut Device<'_>) -> lm_proto::Info {
    match request(dev, 9, &Message::GetInfo, 0) {
        Reply::Info(i) => i,
        r => panic!("{r:?}"),
    }
}

/// Polls `n` frames from `now` at each returned deadline.
fn frames(dev: &mut Device<'_>, now: &mut u64, n: usize) -> Capture {
    let mut cap = Capture::default();
    for _ in 0..n {
        *now = dev.poll(*now, &mut cap).expect("playing");
    }
    cap
}

/// A board holding the paper's rig and its 15 stimuli in slots 0-14
/// (Delta); returns the rig and the set too.
fn board_with_paper_set() -> (Vec<[i32; 3]>, Vec<Stim>, Device<'static>) {
    let pos = autd3_2x2_um();
    let set = paper_set(&pos);
    let mut dev = board(&pos);
    for (i, s) in set.iter().enumerate() {
        upload(&mut dev, &pos, i as u8, s, Encoding::Delta, 0).unwrap();
    }
    (pos, set, dev)
}

#[test]
fn the_paper_set_fits_and_every_entry_plays_its_phases_across_the_wrap() {
    let pos = autd3_2x2_um();
    assert_eq!(pos.len(), 996);
    let set = paper_set(&pos);
    let mut dev = board(&pos);
    let arena = info(&mut dev).library_free;
    assert_eq!(arena as usize, BOARD_LIBRARY_BYTES);
    let (mut raw, mut wire) = (0usize, 0usize);
    for (i, s) in set.iter().enumerate() {
        let before = info(&mut dev).library_free;
        upload(&mut dev, &pos, i as u8, s, Encoding::Delta, 0).unwrap();
        let stored = before - info(&mut dev).library_free;
        let delta = s.encode(Encoding::Delta).len();
        eprintln!(
            "{:<22} {:>3} steps: raw {:>6} B, Delta {:>6} B, stored {:>6} B ({})",
            s.name,
            s.header.steps,
            s.phases.len(),
            delta,
            stored,
            if stored as usize == s.phases.len() {
                "Raw"
            } else {
                "Delta"
            }
        );
        assert!(stored as usize == s.phases.len() || stored as usize == delta);
        raw += s.phases.len();
        wire += delta;
    }
    let free = info(&mut dev).library_free;
    eprintln!(
        "paper set: raw {raw} B, Delta on the wire {wire} B, stored {} B of {arena} ({free} free)",
        arena - free
    );
    assert!(raw > arena as usize, "the raw set alone would not fit");
    assert!(free > arena / 5, "room to spare: {free} B free");
    // Each plays its own phases, step by step, over two cycles plus one step.
    let mut now = 1_000;
    for (i, s) in set.iter().enumerate() {
        assert_eq!(
            request(&mut dev, 10, &play(i as u8, PlayAt::Immediate), now),
            Reply::Ack
        );
        let n = 2 * usize::from(s.header.steps) + 1;
        let cap = frames(&mut dev, &mut now, n);
        for (j, (_, slot, step, amp, ph)) in cap.frames.iter().enumerate() {
            assert_eq!((*slot, *amp), (i as u8, 255), "{}", s.name);
            assert_eq!(usize::from(*step), j % usize::from(s.header.steps));
            assert!(ph.as_slice() == s.step(*step), "{} step {step}", s.name);
        }
        let st = status(&mut dev, now);
        assert_eq!((st.cycles, st.missed_deadlines), (2, 0), "{}", s.name);
    }
}

fn status(dev: &mut Device<'_>, now: u64) -> lm_proto::Status {
    match request(dev, 11, &Message::GetStatus, now) {
        Reply::Status(s) => s,
        r => panic!("{r:?}"),
    }
}

#[test]
fn a_queued_entry_takes_over_at_the_cycle_boundary() {
    let pos = autd3_2x2_um();
    let a = stim(&pos, 4, 2.0, 5.0, 0.23);
    let b = stim(&pos, 1, 3.0, 25.0, 4.0);
    let mut dev = board(&pos);
    upload(&mut dev, &pos, 3, &a, Encoding::Delta, 0).unwrap();
    upload(&mut dev, &pos, 17, &b, Encoding::Delta, 0).unwrap();
    let mut now = 0;
    assert_eq!(
        request(&mut dev, 1, &play(3, PlayAt::NextCycle), now),
        Reply::Ack,
        "from silence: at once"
    );
    let first = frames(&mut dev, &mut now, 10);
    assert_eq!(first.frames[0].0, 0, "step 0 due at the play");
    assert_eq!(
        request(&mut dev, 2, &play(17, PlayAt::NextCycle), now),
        Reply::Ack
    );
    assert_eq!(status(&mut dev, now).queued_slot, Some(17));
    let steps_a = usize::from(a.header.steps);
    let cap = frames(
        &mut dev,
        &mut now,
        steps_a - 10 + usize::from(b.header.steps) + 1,
    );
    let swap = cap.frames.iter().position(|f| f.1 == 17).unwrap();
    assert_eq!(swap, steps_a - 10, "A plays to its last step");
    let (due, _, step, _, ph) = &cap.frames[swap];
    assert_eq!((*due, *step), (u64::from(a.header.period_us), 0));
    assert_eq!(ph.as_slice(), b.step(0));
    for (_, slot, step, _, ph) in &cap.frames[..swap] {
        assert_eq!((*slot, ph.as_slice()), (3, a.step(*step)));
    }
    for (_, slot, step, _, ph) in &cap.frames[swap..] {
        assert_eq!((*slot, ph.as_slice()), (17, b.step(*step)));
    }
    let st = status(&mut dev, now);
    assert_eq!((st.slot, st.queued_slot), (Some(17), None));
    assert_eq!(st.missed_deadlines, 0);
}

#[test]
fn what_does_not_fit_is_refused_as_library_full_and_nothing_changes() {
    let (pos, set, mut dev) = board_with_paper_set();
    let mut now = 0;
    assert_eq!(
        request(&mut dev, 1, &play(0, PlayAt::Immediate), now),
        Reply::Ack
    );
    frames(&mut dev, &mut now, 3);
    // A raw LM-M r = 6 mm (163 kB) into a new slot and over slot 1: no room.
    let big = stim(&pos, 4, 6.0, 5.0, 0.23);
    let free = info(&mut dev).library_free;
    assert!(big.phases.len() > free as usize + 30_000, "{free} B free");
    assert_eq!(
        upload(&mut dev, &pos, 20, &big, Encoding::Raw, now),
        Err(NackCode::LibraryFull)
    );
    assert_eq!(
        upload(&mut dev, &pos, 1, &big, Encoding::Raw, now),
        Err(NackCode::LibraryFull)
    );
    assert_eq!(info(&mut dev).library_free, free, "nothing was taken");
    // Slot 1 still holds its entry; slot 20 none; slot 0 played on.
    let cap = frames(&mut dev, &mut now, 5);
    for (_, slot, step, _, ph) in &cap.frames {
        assert_eq!((*slot, ph.as_slice()), (0, set[0].step(*step)));
    }
    assert_eq!(
        request(&mut dev, 2, &play(20, PlayAt::NextCycle), now),
        Reply::Nack(NackCode::NotCommitted)
    );
    assert_eq!(
        request(&mut dev, 3, &play(1, PlayAt::NextCycle), now),
        Reply::Ack
    );
    assert_eq!(status(&mut dev, now).missed_deadlines, 0);
}

#[test]
fn overwriting_frees_space_and_compaction_keeps_the_playing_entry() {
    let (pos, set, mut dev) = board_with_paper_set();
    let full = info(&mut dev).library_free;
    // Overwrite the largest LM-M with a 25 Hz one: its space comes back.
    let small = &set[10];
    upload(&mut dev, &pos, 9, small, Encoding::Delta, 0).unwrap();
    let freed = info(&mut dev).library_free;
    assert!(freed > full + 20_000, "{full} -> {freed}");
    // Play the last entry (behind the gap), then fill the gap and more:
    // a raw entry larger than any gap but within the free bytes compacts.
    let mut now = 0;
    let last = set.len() as u8 - 1;
    assert_eq!(
        request(&mut dev, 1, &play(last, PlayAt::Immediate), now),
        Reply::Ack
    );
    frames(&mut dev, &mut now, 2);
    let mut big = stim(&pos, 1, 2.0, 5.0, 0.23);
    // Long enough to need more than the gap, short enough to fit.
    let t = 996;
    let steps = (freed as usize - 1000) / t;
    big.phases = (0..steps * t).map(|i| (i * 7 + i / t * 13) as u8).collect();
    big.header.steps = steps as u16;
    big.header.period_us = steps as u32 * 1000;
    upload(&mut dev, &pos, 30, &big, Encoding::Raw, now).unwrap();
    assert!(info(&mut dev).library_free < 1000 + t as u32);
    let cap = frames(&mut dev, &mut now, 30);
    for (_, slot, step, _, ph) in &cap.frames {
        assert_eq!((*slot, ph.as_slice()), (last, set[14].step(*step)));
    }
    assert_eq!(status(&mut dev, now).missed_deadlines, 0);
    // Every entry still plays its own phases after the move.
    for (slot, s) in [(0u8, &set[0]), (9, small), (13, &set[13]), (30, &big)] {
        assert_eq!(
            request(&mut dev, 2, &play(slot, PlayAt::Immediate), now),
            Reply::Ack
        );
        let cap = frames(&mut dev, &mut now, 4);
        for (_, sl, step, _, ph) in &cap.frames {
            assert_eq!((*sl, ph.as_slice()), (slot, s.step(*step)));
        }
    }
}

#[test]
fn an_uncommitted_entry_never_plays() {
    let pos = autd3_2x2_um();
    let s = stim(&pos, 1, 2.0, 5.0, 0.23);
    let mut dev = board(&pos);
    let stream = s.encode(Encoding::Delta);
    let requests = |slot| upload_requests(&pos, slot, &s, Encoding::Delta, &stream);
    // All data, no commit.
    assert_eq!(send(&mut dev, &requests(4), 0), Ok(()));
    let nc = Reply::Nack(NackCode::NotCommitted);
    assert_eq!(request(&mut dev, 3, &play(4, PlayAt::Immediate), 0), nc);
    // Another upload (its `BeginUpload`) abandons it: slot 4 stays
    // unplayable, its space is back.
    assert_eq!(send(&mut dev, &requests(5)[..1], 0), Ok(()));
    assert_eq!(
        request(&mut dev, 5, &commit(4, &s.phases), 0),
        Reply::Nack(NackCode::NoUpload)
    );
    assert_eq!(request(&mut dev, 6, &play(4, PlayAt::Immediate), 0), nc);
    // A wrong CRC never commits.
    let mut bad = s.clone();
    bad.phases[500] ^= 1;
    let r = upload(&mut dev, &pos, 6, &bad, Encoding::Delta, 0);
    assert_eq!(r, Ok(()), "its own CRC: commits");
    assert_eq!(send(&mut dev, &requests(7), 0), Ok(()));
    assert_eq!(
        request(&mut dev, 9, &commit(7, &bad.phases), 0),
        Reply::Nack(NackCode::CrcMismatch)
    );
    assert_eq!(request(&mut dev, 10, &play(7, PlayAt::Immediate), 0), nc);
    let st = status(&mut dev, 0);
    assert_eq!(st.state, DeviceState::Idle);
    const { assert!(SLOTS >= 32) };
}

#[test]
fn another_rig_is_refused_and_a_new_rig_empties_the_library() {
    let pos = autd3_2x2_um();
    let s = stim(&pos, 1, 2.0, 25.0, 4.0);
    let mut dev = board(&pos);
    upload(&mut dev, &pos, 0, &s, Encoding::Delta, 0).unwrap();
    // Planned for other positions: RigMismatch, nothing changes.
    let mut other = pos.clone();
    other[5][2] += 1;
    assert_eq!(
        upload(&mut dev, &other, 1, &s, Encoding::Delta, 0),
        Err(NackCode::RigMismatch)
    );
    let i = info(&mut dev);
    assert_eq!(
        (i.rig_transducers, i.rig_crc32),
        (996, rig_crc32(&Positions::from_points(&pos)))
    );
    assert_eq!(
        request(&mut dev, 1, &play(0, PlayAt::Immediate), 0),
        Reply::Ack
    );
    // Another rig while playing: Busy; after Stop it empties the library.
    let other_rig = Message::BeginRig(BeginRig {
        transducers: 996,
        crc32: rig_crc32(&Positions::from_points(&other)),
    });
    assert_eq!(
        request(&mut dev, 2, &other_rig, 0),
        Reply::Nack(NackCode::Busy)
    );
    assert_eq!(request(&mut dev, 3, &Message::Stop, 0), Reply::Ack);
    assert_eq!(request(&mut dev, 4, &other_rig, 0), Reply::Ack);
    assert_eq!(
        upload(&mut dev, &pos, 1, &s, Encoding::Delta, 0),
        Err(NackCode::NoRig)
    );
    assert_eq!(
        request(&mut dev, 5, &play(0, PlayAt::Immediate), 0),
        Reply::Nack(NackCode::NotCommitted)
    );
    assert_eq!(info(&mut dev).library_free as usize, BOARD_LIBRARY_BYTES);
}
