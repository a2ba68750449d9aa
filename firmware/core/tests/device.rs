//! Behaviour of the whole device through the wire protocol.

mod common;

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

fn status(dev: &mut lm_fw_core::Device<'_>, now: u64) -> lm_proto::Status {
    match request(dev, 77, &Message::GetStatus, now) {
        Reply::Status(s) => s,
        r => panic!("expected status, got {r:?}"),
    }
}

#[test]
fn info_reports_configuration() {
    let mut dev = device(config(996), 200 * 996);
    let Reply::Info(i) = request(&mut dev, 3, &Message::GetInfo, 0) else {
        panic!("no info")
    };
    assert_eq!(i.proto_version, PROTOCOL_VERSION);
    assert_eq!(i.max_transducers, 996);
    // The test memory holds a library of two such sequences.
    assert_eq!(i.slot_bytes, 2 * 200 * 996);
    assert_eq!(i.library_free, 2 * 200 * 996);
    assert_eq!(i.slots as usize, lm_fw_core::SLOTS);
    assert!(i.slots >= 32);
    assert_eq!((i.rig_transducers, i.rig_crc32), (0, 0), "no rig yet");
    assert_eq!(i.timer_hz, 1_000_000);
    assert_eq!(i.min_dwell_us, 1000);
    assert_eq!(i.max_chunk, 1024);
    // The board says what its timer runs from; unknown unless it does.
    assert_eq!(i.clock, lm_proto::ClockSource::Unknown);
    let mut cfg = config(996);
    cfg.clock = lm_proto::ClockSource::Crystal;
    let mut on_crystal = device(cfg, 200 * 996);
    let Reply::Info(i) = request(&mut on_crystal, 4, &Message::GetInfo, 0) else {
        panic!("no info")
    };
    assert_eq!(i.clock, lm_proto::ClockSource::Crystal);
    let s = status(&mut dev, 0);
    assert_eq!(s.state, DeviceState::Idle);
    assert_eq!(s.slot, None);
}

#[test]
fn raw_and_delta_uploads_play_their_phases() {
    for enc in [Encoding::Raw, Encoding::Delta] {
        let mut dev = device(config(40), 20 * 40);
        let seq = Seq::pattern(20, 40, 20_000, 1);
        seq.upload(&mut dev, 1, enc, 0);
        acks(&mut dev, 1, &play(1, PlayAt::NextCycle), 500);
        let mut cap = Capture::default();
        let mut now = 500;
        for _ in 0..45 {
            let next = dev.poll(now, &mut cap).unwrap();
            assert!(next > now);
            now = next;
        }
        assert_eq!(cap.frames.len(), 45);
        for (i, (due, slot, step, amp, ph)) in cap.frames.iter().enumerate() {
            assert_eq!(*slot, 1);
            assert_eq!(usize::from(*step), i % 20);
            assert_eq!(*due, 500 + i as u64 * 1000);
            assert_eq!(*amp, 255);
            assert_eq!(ph.as_slice(), seq.step(*step), "{enc:?} step {step}");
        }
        let s = status(&mut dev, now);
        assert_eq!(s.state, DeviceState::Playing);
        assert_eq!(s.cycles, 2);
        assert_eq!(s.missed_deadlines, 0);
    }
}

#[test]
fn min_dwell_is_enforced_at_begin_and_play() {
    let mut dev = device(config(8), 1000 * 8);
    let mut seq = Seq::pattern(100, 8, 99_999, 0); // 999.99 µs per step
    let too_short = seq.begin(0, Encoding::Raw);
    nacks(&mut dev, 1, &too_short, 0, NackCode::DwellTooShort);
    // Exactly 1 ms per step is allowed.
    seq.period_us = 100_000;
    let begin = seq.begin(0, Encoding::Raw);
    for m in seq.rig_requests() {
        acks(&mut dev, 2, &m, 0);
    }
    acks(&mut dev, 2, &begin, 0);
    seq.upload(&mut dev, 0, Encoding::Raw, 0);
    let start = play(0, PlayAt::Immediate);
    dev.set_min_dwell_us(1001);
    nacks(&mut dev, 3, &start, 0, NackCode::DwellTooShort);
    dev.set_min_dwell_us(1000);
    acks(&mut dev, 4, &start, 0);
    // A stricter device refuses the same header.
    let mut cfg = config(8);
    cfg.min_dwell_us = 2000;
    let mut strict = device(cfg, 1000 * 8);
    nacks(&mut strict, 1, &begin, 0, NackCode::DwellTooShort);
}

#[test]
fn uploads_into_the_playing_slot_are_refused() {
    let mut dev = device(config(16), 10 * 16);
    let seq = Seq::pattern(10, 16, 10_000, 2);
    seq.upload(&mut dev, 0, Encoding::Raw, 0);
    acks(&mut dev, 1, &play(0, PlayAt::Immediate), 0);
    let chunk = Message::Chunk(Chunk {
        slot: 0,
        offset: 0,
        data: &[1, 2, 3],
    });
    refuses(
        &mut dev,
        &[
            (2, seq.begin(0, Encoding::Raw), NackCode::SlotPlaying),
            (3, chunk, NackCode::SlotPlaying),
        ],
    );
    // A repeat of the commit that made the slot playable changes nothing:
    // acked again (SPEC section 2); any other commit is refused.
    acks(&mut dev, 4, &seq.commit(0), 0);
    let other = Message::Commit(Commit { slot: 0, crc32: 1 });
    refuses(
        &mut dev,
        &[
            (4, other, NackCode::SlotPlaying),
            (
                5,
                seq.begin(lm_fw_core::SLOTS as u8, Encoding::Raw),
                NackCode::BadSlot,
            ),
            (6, play(1, PlayAt::Immediate), NackCode::NotCommitted),
        ],
    );
    // Queued slot is protected too.
    seq.upload(&mut dev, 1, Encoding::Raw, 0);
    acks(&mut dev, 7, &play(1, PlayAt::NextCycle), 0);
    let queued = seq.begin(1, Encoding::Raw);
    nacks(&mut dev, 8, &queued, 0, NackCode::SlotPlaying);
    // After Stop both slots are writable again.
    acks(&mut dev, 9, &Message::Stop, 0);
    acks(&mut dev, 10, &seq.begin(0, Encoding::Raw), 0);
}

/// Interrupts an upload into slot 1 after every request (and corrupts or
/// abandons it) while slot 0 plays: the output never changes slot or
/// phases, and slot 1 never becomes playable.
#[test]
fn interrupted_upload_never_touches_the_playing_slot() {
    for enc in [Encoding::Raw, Encoding::Delta] {
        let mut dev = device(config(30), 12 * 30);
        let a = Seq::pattern(12, 30, 12_000, 3);
        let b = Seq::pattern(12, 30, 12_000, 4);
        a.upload(&mut dev, 0, enc, 0);
        acks(&mut dev, 1, &play(0, PlayAt::Immediate), 0);
        let stream = b.encode(enc);
        let reqs = b.upload_requests(1, enc, &stream, 37);
        let mut cap = Capture::default();
        let mut now = 0u64;
        for cut in 1..=reqs.len() {
            for (i, m) in reqs[..cut].iter().enumerate() {
                acks(&mut dev, i as u16, m, now);
                now = dev.poll(now, &mut cap).unwrap();
            }
            // Interrupted: a commit now is refused, and so is playing slot 1.
            let commit = request(&mut dev, 500, &b.commit(1), now);
            let rig = b.rig_requests().len();
            if cut <= rig {
                // Only the rig so far (the device holds it already).
                assert_eq!(commit, Reply::Nack(NackCode::NoUpload), "cut {cut}");
            } else if cut < reqs.len() {
                assert_eq!(commit, Reply::Nack(NackCode::Incomplete), "cut {cut}");
            } else {
                // All data there but a corrupt CRC.
                let bad = Message::Commit(Commit {
                    slot: 1,
                    crc32: lm_proto::crc32(&b.phases) ^ 1,
                });
                assert_eq!(commit, Reply::Ack);
                // Recommit a fresh but corrupted copy: one flipped byte.
                let mut corrupt = b.clone();
                corrupt.phases[17] ^= 0x40;
                let cs = corrupt.encode(enc);
                for (i, m) in corrupt.upload_requests(1, enc, &cs, 37).iter().enumerate() {
                    acks(&mut dev, i as u16, m, now);
                }
                nacks(&mut dev, 501, &bad, now, NackCode::CrcMismatch);
            }
            nacks(
                &mut dev,
                502,
                &play(1, PlayAt::Immediate),
                now,
                NackCode::NotCommitted,
            );
            for _ in 0..3 {
                now = dev.poll(now, &mut cap).unwrap();
            }
        }
        assert!(cap.frames.len() > 3 * reqs.len());
        for (_, slot, step, amp, ph) in &cap.frames {
            assert_eq!(*slot, 0);
            assert_eq!(*amp, 255);
            assert_eq!(ph.as_slice(), a.step(*step));
        }
        assert_eq!(status(&mut dev, now).missed_deadlines, 0);
    }
}

#[test]
fn next_cycle_swap_happens_at_the_cycle_boundary() {
    let mut dev = device(config(8), 10 * 8);
    let a = Seq::pattern(10, 8, 10_000, 5);
    let b = Seq::pattern(5, 8, 10_000, 6);
    a.upload(&mut dev, 0, Encoding::Raw, 0);
    b.upload(&mut dev, 1, Encoding::Delta, 0);
    let mut cap = Capture::default();
    acks(&mut dev, 1, &play(0, PlayAt::Immediate), 100);
    let mut now = 100;
    for i in 0..23 {
        if i == 3 {
            acks(&mut dev, 2, &play(1, PlayAt::NextCycle), now);
        }
        now = dev.poll(now, &mut cap).unwrap();
    }
    let slots: Vec<(u8, u16, u64)> = cap.frames.iter().map(|f| (f.1, f.2, f.0)).collect();
    assert_eq!(slots[9], (0, 9, 100 + 9000));
    assert_eq!(slots[10], (1, 0, 100 + 10_000));
    assert_eq!(slots[11], (1, 1, 100 + 12_000));
    assert_eq!(slots[15], (1, 0, 100 + 20_000));
    for f in &cap.frames[10..] {
        assert_eq!(f.4.as_slice(), b.step(f.2));
    }
    // Immediate swap back.
    assert_eq!(
        request(&mut dev, 3, &play(0, PlayAt::Immediate), now + 5),
        Reply::Ack
    );
    dev.poll(now + 5, &mut cap);
    assert_eq!(
        cap.frames.last().map(|f| (f.0, f.1, f.2)),
        Some((now + 5, 0, 0))
    );
}

#[test]
fn gating_mutes_and_resumes() {
    let a = Seq::pattern(100, 8, 100_000, 7); // 1 ms steps
    let mut dev = tracked_device(&a);
    let mut cap = Capture::default();
    acks(&mut dev, 1, &play(0, PlayAt::Immediate), 0);
    let mut now = 0;
    // Before the first centroid: muted (require_tracking).
    for _ in 0..3 {
        now = dev.poll(now, &mut cap).unwrap();
    }
    assert!(cap.frames.iter().all(|f| f.3 == 0));
    assert_eq!(status(&mut dev, now).state, DeviceState::Muted);
    acks(&mut dev, 2, &centroid(1, a.center_um, true), now);
    now = dev.poll(now, &mut cap).unwrap();
    assert_eq!(cap.frames.last().unwrap().3, 255);
    // Presence false mutes at once (the next poll re-sends the step muted).
    assert_eq!(
        request(&mut dev, 3, &centroid(2, a.center_um, false), now + 10),
        Reply::Ack
    );
    let n = cap.frames.len();
    dev.poll(now + 10, &mut cap);
    assert_eq!(cap.frames.len(), n + 1);
    assert_eq!(cap.frames.last().unwrap().3, 0);
    // Stale seq is refused and does not resume.
    assert_eq!(
        request(&mut dev, 4, &centroid(2, a.center_um, true), now + 20),
        Reply::Nack(NackCode::OutOfOrder)
    );
    now = dev.poll(now + 20, &mut cap).unwrap();
    now = dev.poll(now, &mut cap).unwrap();
    assert_eq!(cap.frames.last().unwrap().3, 0);
    // Fresh update resumes at the next step.
    acks(&mut dev, 5, &centroid(3, a.center_um, true), now);
    let t_update = now;
    now = dev.poll(now, &mut cap).unwrap();
    now = dev.poll(now, &mut cap).unwrap();
    assert_eq!(cap.frames.last().unwrap().3, 255);
    // Timeout: no update for > 100 ms mutes within one step (1 ms).
    while now <= t_update + 100_000 {
        now = dev.poll(now, &mut cap).unwrap();
        assert_eq!(cap.frames.last().unwrap().3, 255, "at {now}");
    }
    now = dev.poll(now, &mut cap).unwrap();
    let last = cap.frames.last().unwrap();
    assert_eq!(last.3, 0);
    assert!(last.0 <= t_update + 100_000 + 1000);
    // Settable timeout.
    dev.set_centroid_timeout_us(1_000_000);
    now = dev.poll(now, &mut cap).unwrap();
    assert_eq!(cap.frames.last().unwrap().3, 255);
    // Stop mutes at once.
    assert_eq!(request(&mut dev, 6, &Message::Stop, now + 3), Reply::Ack);
    assert_eq!(dev.poll(now + 3, &mut cap), None);
    assert_eq!(cap.frames.last().unwrap().3, 0);
    assert_eq!(status(&mut dev, now).state, DeviceState::Stopped);
}

#[test]
fn centroid_correction_is_added_from_the_next_step() {
    let mut dev = device(config(252), 10 * 252);
    let a = Seq::pattern(10, 252, 10_000, 8);
    a.upload(&mut dev, 0, Encoding::Raw, 0);
    let mut cap = Capture::default();
    request(&mut dev, 1, &play(0, PlayAt::Immediate), 0);
    let now = dev.poll(0, &mut cap).unwrap();
    let c = [3_000, -2_000, 204_000];
    assert!(
        dev.offsets().is_empty(),
        "no correction before the first centroid"
    );
    assert_eq!(
        request(&mut dev, 2, &centroid(9, c, true), now - 1),
        Reply::Ack
    );
    assert_eq!(status(&mut dev, now).correction_um, [3_000, -2_000, 4_000]);
    dev.poll(now, &mut cap).unwrap();
    let (_, _, step, _, ph) = cap.frames.last().unwrap().clone();
    let lsbs = expected_offsets(&a, c, 340_000);
    for (j, lsb) in lsbs.iter().enumerate() {
        let want = a.step(step)[j].wrapping_add(*lsb);
        let diff = ph[j].wrapping_sub(want) as i8;
        assert!(diff.abs() <= 1, "transducer {j}: {} vs {want}", ph[j]);
    }
    let nonzero = lsbs.iter().filter(|&&lsb| lsb != 0).count();
    assert!(nonzero > 200, "a 5 mm shift moves most phases");
    assert_eq!(dev.offsets().len(), 252);
}

/// Offsets (u8 LSB) a sequence planned for `seq.center_um` at `speed_mm_s`
/// needs for centroid `c`, in f64.
fn expected_offsets(seq: &Seq, c: [i32; 3], speed_mm_s: u32) -> Vec<u8> {
    let k = 2.0 * std::f64::consts::PI * 40_000.0 / (f64::from(speed_mm_s) * 1e3); // rad/µm
    seq.positions
        .iter()
        .map(|x| {
            let d = |p: [i32; 3]| {
                (0..3)
                    .map(|i| (f64::from(x[i]) - f64::from(p[i])).powi(2))
                    .sum::<f64>()
                    .sqrt()
            };
            let dphi = k * (d(seq.center_um) - d(c));
            ((dphi / (2.0 * std::f64::consts::PI) * 256.0).round() as i64).rem_euclid(256) as u8
        })
        .collect()
}

/// Transducers whose offset differs from `want` by more than 1 LSB.
fn off_by_more_than_one(got: &[u8], want: &[u8]) -> usize {
    assert_eq!(got.len(), want.len());
    got.iter()
        .zip(want)
        .filter(|(g, w)| (g.wrapping_sub(**w) as i8).abs() > 1)
        .count()
}

#[test]
fn correction_follows_each_slots_uploaded_sound_speed() {
    let mut dev = device(config(252), 10 * 252);
    let a = Seq::pattern(10, 252, 10_000, 8); // planned at 340 m/s
    let mut b = a.clone();
    b.sound_speed_mm_s = 350_000;
    // Zero or implausible speeds are refused before anything changes.
    for (i, speed) in [0, 99_999, 2_000_001].into_iter().enumerate() {
        let mut z = a.clone();
        z.sound_speed_mm_s = speed;
        assert_eq!(
            request(&mut dev, i as u16, &z.begin(0, Encoding::Raw), 0),
            Reply::Nack(NackCode::OutOfRange),
            "{speed} mm/s"
        );
    }
    a.upload(&mut dev, 0, Encoding::Raw, 0);
    b.upload(&mut dev, 1, Encoding::Raw, 0);
    let c = [9_000, -6_000, 212_000];
    let (want_a, want_b) = (
        expected_offsets(&a, c, 340_000),
        expected_offsets(&b, c, 350_000),
    );
    // The two wavenumbers differ by 3 %: enough to move most offsets.
    assert!(off_by_more_than_one(&want_a, &want_b) > 150);

    let mut cap = Capture::default();
    request(&mut dev, 10, &play(0, PlayAt::Immediate), 0);
    let now = dev.poll(0, &mut cap).unwrap();
    acks(&mut dev, 11, &centroid(1, c, true), now);
    assert_eq!(off_by_more_than_one(dev.offsets(), &want_a), 0);

    // Same geometry, same centres, same centroid: only k differs.
    request(&mut dev, 12, &play(1, PlayAt::Immediate), now);
    dev.poll(now, &mut cap).unwrap();
    assert_eq!(off_by_more_than_one(dev.offsets(), &want_b), 0);

    // And back: the slot's own speed comes back with it.
    request(&mut dev, 13, &play(0, PlayAt::Immediate), now + 1);
    dev.poll(now + 1, &mut cap).unwrap();
    assert_eq!(off_by_more_than_one(dev.offsets(), &want_a), 0);
}

#[test]
fn bad_frames_are_counted_and_nacked() {
    let mut dev = device(config(8), 64);
    // Garbage with a delimiter: one bad frame, no reply.
    assert!(feed(&mut dev, &[1, 2, 3, 0], 0).is_empty());
    // A response sent to the device: Nack(UnknownType).
    nacks(&mut dev, 4, &Message::Ack, 0, NackCode::UnknownType);
    let s = status(&mut dev, 0);
    assert_eq!(s.bad_frames, 1);
    assert_eq!(s.nacks, 1);
}

#[test]
fn chunks_past_end_and_out_of_order_are_nacked() {
    let mut dev = device(config(4), 64);
    let b = Message::BeginUpload(BeginUpload {
        slot: 0,
        header: UploadHeader {
            steps: 2,
            transducers: 4,
            period_us: 10_000,
            center_um: [0; 3],
            foci_per_step: 1,
            sound_speed_mm_s: 340_000,
            max_offset_um: 20_000,
            intensity: 255,
        },
        encoding: Encoding::Raw,
        encoded_len: 8,
        rig_crc32: Seq::pattern(1, 4, 1000, 0).rig_crc32(),
    });
    for m in Seq::pattern(1, 4, 1000, 0).rig_requests() {
        acks(&mut dev, 1, &m, 0);
    }
    acks(&mut dev, 1, &b, 0);
    let ch = |offset, data: &'static [u8]| {
        Message::Chunk(Chunk {
            slot: 0,
            offset,
            data,
        })
    };
    acks(&mut dev, 2, &ch(0, &[1, 2, 3]), 0);
    acks(&mut dev, 3, &ch(0, &[1, 2, 3]), 0);
    nacks(&mut dev, 4, &ch(4, &[1]), 0, NackCode::OutOfOrder);
    assert_eq!(
        request(&mut dev, 5, &ch(3, &[0; 6]), 0),
        Reply::Nack(NackCode::OutOfRange)
    );
    assert_eq!(
        request(&mut dev, 6, &ch(u32::MAX, &[0; 6]), 0),
        Reply::Nack(NackCode::OutOfRange)
    );
    acks(&mut dev, 7, &ch(3, &[4, 5, 6, 7, 8]), 0);
    assert_eq!(
        request(
            &mut dev,
            8,
            &Message::Chunk(Chunk {
                slot: 1,
                offset: 0,
                data: &[1]
            }),
            0
        ),
        Reply::Nack(NackCode::NoUpload)
    );
}

#[test]
fn config_defaults_are_documented_values() {
    let c = Config::new(1_000_000);
    assert_eq!(c.min_dwell_us, 1000);
    assert_eq!(c.centroid_timeout_us, 100_000);
    assert!(c.require_tracking);
    // Half the transducer driver's 100 ms silence timeout.
    assert_eq!(c.frame_repeat_us, 50_000);
}

/// A step of 300 ms outlasts the driver's 100 ms timeout: its frame goes
/// out again every 50 ms, unchanged, until the next step; Stop ends the
/// repeats with its muted frame; 0 turns them off.
#[test]
fn a_long_dwell_is_repeated_before_the_drivers_timeout_until_stop() {
    for repeat_us in [50_000, 0] {
        let mut cfg = config(8);
        cfg.frame_repeat_us = repeat_us;
        let mut dev = device(cfg, 2 * 8);
        let a = Seq::pattern(2, 8, 600_000, 3);
        a.upload(&mut dev, 0, Encoding::Raw, 0);
        // No request comes while it plays: a lease longer than the run.
        acks(&mut dev, 1, &leased(play_untracked(0), 60_000), 1_000);
        let mut out = Capture::default();
        let mut now = 1_000;
        while now < 1_000 + 1_200_000 {
            now = dev.poll(now, &mut out).unwrap();
        }
        let f = &out.frames;
        if repeat_us == 0 {
            // Only the step boundaries: 300 ms apart.
            assert!(
                f.windows(2).all(|w| w[1].0 - w[0].0 == 300_000),
                "{:?}",
                f.iter().map(|x| x.0).collect::<Vec<_>>()
            );
            continue;
        }
        assert!(
            f.windows(2).all(|w| w[1].0 - w[0].0 <= 50_000),
            "a gap over 50 ms"
        );
        // Six frames per 300 ms step, each the step's phases at full amplitude.
        assert_eq!(
            f.len(),
            4 * 6,
            "{:?}",
            f.iter().map(|x| (x.0, x.2)).collect::<Vec<_>>()
        );
        for (k, x) in f.iter().enumerate() {
            let step = ((k / 6) % 2) as u16;
            assert_eq!(
                (x.2, x.3, x.4.as_slice()),
                (step, 255, a.step(step)),
                "frame {k}"
            );
        }
        // Stop: one muted frame, then nothing more to send.
        acks(&mut dev, 2, &Message::Stop, now);
        out.frames.clear();
        assert_eq!(dev.poll(now, &mut out), None);
        assert_eq!(out.frames.len(), 1);
        assert_eq!(out.frames[0].3, 0);
        assert_eq!(dev.next_deadline(), None);
        assert_eq!(dev.poll(now + 500_000, &mut out), None);
        assert_eq!(out.frames.len(), 1, "no repeats after Stop");
    }
}

#[test]
fn play_while_playing_accepts_a_restarted_centroid_sequence() {
    let a = Seq::pattern(10, 8, 10_000, 9);
    let mut dev = tracked_device(&a);
    let mut cap = Capture::default();
    acks(&mut dev, 1, &play(0, PlayAt::Immediate), 0);
    acks(&mut dev, 2, &centroid(500, a.center_um, true), 0);
    let mut now = dev.poll(0, &mut cap).unwrap();
    nacks(
        &mut dev,
        3,
        &centroid(1, a.center_um, true),
        now,
        NackCode::OutOfOrder,
    );
    // The host restarts and re-plays: its sequence starts at 1 again.
    acks(&mut dev, 4, &play(0, PlayAt::NextCycle), now);
    now = dev.poll(now, &mut cap).unwrap();
    assert_eq!(cap.frames.last().unwrap().3, 255, "no glitch on re-play");
    acks(&mut dev, 5, &centroid(1, a.center_um, true), now);
    assert_eq!(status(&mut dev, now).last_centroid_seq, 1);
    // After Stop, a new session needs fresh tracking again.
    acks(&mut dev, 6, &Message::Stop, now);
    acks(&mut dev, 7, &play(0, PlayAt::Immediate), now);
    dev.poll(now, &mut cap);
    assert_eq!(cap.frames.last().unwrap().3, 0);
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

#[test]
fn centroids_outside_the_work_volume_are_refused_and_mute() {
    let seq = Seq::pattern(10, 16, 10_000, 2);
    let mut dev = tracked_device(&seq);
    acks(&mut dev, 1, &play(0, PlayAt::Immediate), 0);
    let s = status(&mut dev, 0);
    assert_eq!(s.state, DeviceState::Muted);
    assert_eq!(s.mute_reason, MuteReason::WaitingForTracking);
    let c0 = seq.center_um;
    let at = |dx: i32, dy: i32| [c0[0] + dx, c0[1] + dy, c0[2]];
    // 5 mm off the centre: inside the 20 mm work volume, steers.
    acks(&mut dev, 2, &centroid(1, at(3000, 4000), true), 10);
    let mut out = Capture::default();
    dev.poll(10, &mut out);
    assert!(dev.is_sounding(10));
    assert!(dev.offsets().iter().any(|o| *o != 0));
    assert_eq!(status(&mut dev, 10).correction_um, [3000, 4000, 0]);
    // 20.0008 mm away: refused, muted at once, correction dropped.
    for (k, pos) in [
        at(12_000, 16_001),
        [i32::MIN, i32::MAX, i32::MIN],
        [c0[0], c0[1], i32::MAX],
    ]
    .into_iter()
    .enumerate()
    {
        let k = k as u32;
        assert_eq!(
            request(&mut dev, 3, &centroid(2 + k, pos, true), 20),
            Reply::Nack(NackCode::OutOfRange),
            "{pos:?}"
        );
        assert!(!dev.is_sounding(20));
        let s = status(&mut dev, 20);
        assert_eq!(s.state, DeviceState::Muted);
        assert_eq!(s.mute_reason, MuteReason::CentroidOutOfRange);
        assert_eq!(s.correction_um, [0; 3]);
        out.frames.clear();
        dev.poll(20, &mut out);
        assert_eq!(out.frames.last().map(|f| f.3), Some(0), "muted frame");
    }
    // Still muted as time passes (a refused centroid never opens the gate).
    let later = 5_000;
    assert!(!dev.is_sounding(later));
    // An absent finger keeps it muted, for that reason.
    assert_eq!(
        request(&mut dev, 4, &centroid(10, [0; 3], false), 30),
        Reply::Ack
    );
    assert_eq!(status(&mut dev, 30).mute_reason, MuteReason::FingerAbsent);
    // Exactly 20 mm away is inside: sounds again.
    acks(&mut dev, 5, &centroid(11, at(12_000, 16_000), true), 40);
    assert!(dev.is_sounding(40));
    let s = status(&mut dev, 40);
    assert_eq!(
        (s.state, s.mute_reason),
        (DeviceState::Playing, MuteReason::None)
    );
    assert_eq!(s.correction_um, [12_000, 16_000, 0]);
}

#[test]
fn a_queued_slot_with_another_centre_mutes_an_out_of_range_centroid() {
    let a = Seq::pattern(10, 16, 10_000, 2);
    let mut dev = tracked_device(&a);
    let mut b = Seq::pattern(10, 16, 10_000, 3);
    b.center_um = [50_000, 0, 200_000];
    b.upload(&mut dev, 1, Encoding::Raw, 0);
    acks(&mut dev, 1, &play(0, PlayAt::Immediate), 0);
    acks(&mut dev, 2, &centroid(1, a.center_um, true), 0);
    acks(&mut dev, 3, &play(1, PlayAt::NextCycle), 100);
    assert_eq!(status(&mut dev, 100).queued_slot, Some(1));
    let mut out = Capture::default();
    let mut now = 100;
    let mut k = 2;
    while dev.status(now).slot != Some(1) {
        // Fresh tracking at slot 0's centre while slot 0 plays.
        acks(&mut dev, 4, &centroid(k, a.center_um, true), now);
        k += 1;
        now = dev.poll(now, &mut out).unwrap();
        assert!(now < 100_000, "swap never happened");
    }
    let s = status(&mut dev, now);
    assert_eq!(s.queued_slot, None);
    assert_eq!(
        s.mute_reason,
        MuteReason::CentroidOutOfRange,
        "50 mm from slot 1's centre"
    );
    assert_eq!(out.frames.last().map(|f| (f.1, f.3)), Some((1, 0)));
}

#[test]
fn untracked_play_sounds_without_a_finger_until_stop() {
    let seq = Seq::pattern(10, 16, 10_000, 2);
    let mut dev = tracked_device(&seq);
    acks(&mut dev, 1, &play_untracked(0), 0);
    let mut out = Capture::default();
    let mut now = 0;
    for _ in 0..30 {
        now = dev.poll(now, &mut out).unwrap();
    }
    assert!(
        out.frames.iter().all(|f| f.3 == 255),
        "full amplitude throughout"
    );
    // Planned phases, uncorrected, even with a centroid far from the centre.
    let off = [seq.center_um[0] + 5000, seq.center_um[1], seq.center_um[2]];
    acks(&mut dev, 2, &centroid(1, off, true), now);
    assert_eq!(
        request(&mut dev, 3, &centroid(2, [0; 3], false), now),
        Reply::Ack
    );
    out.frames.clear();
    now = dev.poll(now + 10_000, &mut out).unwrap();
    let f = out.frames.last().unwrap();
    assert_eq!((f.3, &f.4[..]), (255, seq.step(f.2)));
    assert!(dev.offsets().is_empty());
    let s = status(&mut dev, now);
    assert_eq!(
        (s.state, s.mute_reason),
        (DeviceState::Playing, MuteReason::None)
    );
    // Stop still stops.
    acks(&mut dev, 4, &Message::Stop, now);
    out.frames.clear();
    dev.poll(now, &mut out);
    assert_eq!(out.frames.last().map(|f| f.3), Some(0));
    let s = status(&mut dev, now);
    assert_eq!(
        (s.state, s.mute_reason),
        (DeviceState::Stopped, MuteReason::Stopped)
    );
    // A tracked Play ends the untracked session.
    acks(&mut dev, 5, &play(0, PlayAt::Immediate), now);
    assert_eq!(
        status(&mut dev, now).mute_reason,
        MuteReason::WaitingForTracking
    );
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

#[test]
fn timed_play_outputs_exactly_its_steps_then_mutes_at_the_boundary() {
    // 10 steps of 1 ms.
    let mut dev = device(config(8), 10 * 8);
    let a = Seq::pattern(10, 8, 10_000, 5);
    a.upload(&mut dev, 0, Encoding::Raw, 0);
    acks(&mut dev, 1, &play_steps(0, PlayAt::Immediate, 23), 100);
    let mut out = Capture::default();
    let end = poll_out(&mut dev, 100, &mut out, 1000);
    let sounding: Vec<_> = out.frames.iter().filter(|f| f.3 == 255).collect();
    assert_eq!(sounding.len(), 23);
    for (k, f) in sounding.iter().enumerate() {
        assert_eq!((f.0, f.2), (100 + k as u64 * 1000, (k % 10) as u16));
        assert_eq!(f.4.as_slice(), a.step(f.2));
    }
    // The mute goes out at the 23rd boundary, not later, and is the last frame.
    let last = out.frames.last().unwrap();
    assert_eq!((last.0, last.3), (100 + 23_000, 0));
    assert_eq!(out.frames.len(), 24);
    assert_eq!(dev.next_deadline(), None);
    assert!(!dev.is_sounding(end));
    let s = status(&mut dev, end + 50_000);
    assert_eq!(
        (s.state, s.mute_reason, s.slot, s.queued_slot),
        (DeviceState::Stopped, MuteReason::Stopped, Some(0), None)
    );
    assert_eq!((s.cycles, s.step), (2, 3));
    assert_eq!(s.cycles * 10 + u32::from(s.step), 23);
    assert_eq!(s.missed_deadlines, 0);
    // A later Play starts afresh, without the old limit.
    acks(
        &mut dev,
        2,
        &play_steps(0, PlayAt::Immediate, 0),
        end + 50_000,
    );
    out.frames.clear();
    poll_out(&mut dev, end + 50_000, &mut out, 100);
    assert_eq!(out.frames.len(), 100);
    assert!(out.frames.iter().all(|f| f.3 == 255));
    assert_eq!(status(&mut dev, 0).state, DeviceState::Playing);
}

#[test]
fn queued_timed_play_counts_from_the_takeover() {
    let mut dev = device(config(8), 10 * 8);
    let a = Seq::pattern(10, 8, 10_000, 5);
    let b = Seq::pattern(5, 8, 10_000, 6);
    a.upload(&mut dev, 0, Encoding::Raw, 0);
    b.upload(&mut dev, 1, Encoding::Delta, 0);
    let mut out = Capture::default();
    acks(&mut dev, 1, &play_steps(0, PlayAt::Immediate, 0), 100);
    let mut now = 100;
    for _ in 0..3 {
        now = dev.poll(now, &mut out).unwrap();
    }
    acks(&mut dev, 2, &play_steps(1, PlayAt::NextCycle, 7), now);
    poll_out(&mut dev, now, &mut out, 1000);
    let b_frames: Vec<_> = out.frames.iter().filter(|f| f.1 == 1).collect();
    // 7 sounding steps of slot 1 from the boundary at 10.1 ms, 2 ms each,
    // then the mute at 7 × 2 ms after the takeover.
    assert_eq!(b_frames.iter().filter(|f| f.3 == 255).count(), 7);
    assert_eq!(b_frames[0].0, 100 + 10_000);
    let last = out.frames.last().unwrap();
    assert_eq!((last.0, last.1, last.3), (100 + 10_000 + 14_000, 1, 0));
    let s = status(&mut dev, last.0);
    assert_eq!(
        (s.state, s.slot, s.cycles, s.step, s.missed_deadlines),
        (DeviceState::Stopped, Some(1), 1, 2, 0)
    );
}

#[test]
fn timed_play_missed_deadlines_around_the_limit_still_stop_at_the_limit() {
    let mut dev = device(config(8), 10 * 8);
    Seq::pattern(10, 8, 10_000, 5).upload(&mut dev, 0, Encoding::Raw, 0);
    acks(&mut dev, 1, &play_steps(0, PlayAt::Immediate, 12), 0);
    let mut out = Capture::default();
    for now in [0, 1000, 2000] {
        dev.poll(now, &mut out);
    }
    // The device stalls from 2.5 ms to 40 ms: steps 3..=11 are never entered.
    assert_eq!(dev.poll(40_000, &mut out), None);
    let last = out.frames.last().unwrap();
    assert_eq!((last.0, last.2, last.3), (12_000, 2, 0));
    assert_eq!(out.frames.iter().filter(|f| f.3 == 255).count(), 3);
    let s = status(&mut dev, 40_000);
    assert_eq!(
        (s.state, s.cycles, s.step, s.missed_deadlines),
        (DeviceState::Stopped, 1, 2, 9)
    );
}

#[test]
fn stop_or_a_new_play_replaces_the_limit() {
    let mut dev = device(config(8), 10 * 8);
    Seq::pattern(10, 8, 10_000, 5).upload(&mut dev, 0, Encoding::Raw, 0);
    let mut out = Capture::default();
    // Limit 3, replaced at 1.5 ms by a play without one (same slot).
    acks(&mut dev, 1, &play_steps(0, PlayAt::Immediate, 3), 0);
    dev.poll(0, &mut out);
    dev.poll(1000, &mut out);
    acks(&mut dev, 2, &play_steps(0, PlayAt::Immediate, 0), 1500);
    poll_out(&mut dev, 1500, &mut out, 50);
    assert_eq!(status(&mut dev, 0).state, DeviceState::Playing);
    assert!(out.frames.iter().all(|f| f.3 == 255));
    // Stop, then a timed play again: its own limit, from its start.
    acks(&mut dev, 3, &Message::Stop, 100_000);
    acks(&mut dev, 4, &play_steps(0, PlayAt::Immediate, 4), 100_000);
    out.frames.clear();
    poll_out(&mut dev, 100_000, &mut out, 50);
    assert_eq!(out.frames.iter().filter(|f| f.3 == 255).count(), 4);
    assert_eq!(out.frames.last().map(|f| (f.0, f.3)), Some((104_000, 0)));
}

/// An untracked play of a 10-step, 1 ms-a-step slot, started at `t0` with
/// a `lease_ms` lease (1 MHz timer: counts are µs).
fn leased_device(lease_ms: u16, t0: u64) -> lm_fw_core::Device<'static> {
    let mut dev = device(config(8), 10 * 8);
    let a = Seq::pattern(10, 8, 10_000, 5);
    a.upload(&mut dev, 0, Encoding::Raw, 0);
    acks(&mut dev, 1, &leased(play_untracked(0), lease_ms), t0);
    dev
}

/// The host goes quiet after its `Play`: the play ends exactly one lease
/// later, at a deadline `poll` itself asked for; every frame before it
/// sounds, the frame at it is muted, none follows; `Status` says why and
/// counts it.
#[test]
fn a_play_ends_when_its_host_lease_expires() {
    let t0 = 5_000;
    let mut dev = leased_device(1000, t0);
    let expiry = t0 + 1_000_000;
    let mut out = Capture::default();
    let end = poll_out(&mut dev, t0, &mut out, 100_000);
    assert_eq!(end, expiry, "the last deadline is the lease's end");
    let (last, before) = out.frames.split_last().unwrap();
    assert!(before.iter().all(|f| f.3 == 255 && f.0 < expiry));
    // Every step up to the expiry played (1 ms each).
    assert_eq!(before.len(), 1000);
    assert_eq!((last.0, last.3), (expiry, 0), "muted at the expiry");
    assert_eq!(dev.poll(expiry + 60_000_000, &mut out), None);
    assert_eq!(out.frames.len(), 1001, "no frame after the expiry");
    let st = status(&mut dev, expiry + 1);
    assert_eq!(
        (st.state, st.mute_reason, st.lease_ms, st.lease_expiries),
        (DeviceState::Stopped, MuteReason::LeaseExpired, 1000, 1)
    );
    assert_eq!(dev.counters().lease_expiries, 1);
    // A status request after the end does not revive it.
    assert_eq!(status(&mut dev, expiry + 2).state, DeviceState::Stopped);
    assert_eq!(dev.next_deadline(), None);
}

/// Every accepted request renews the lease: `Renew`, `GetStatus`, a
/// centroid, an upload's chunk; a refused one does not.
#[test]
fn accepted_requests_renew_the_lease_and_refused_ones_do_not() {
    let t0 = 0;
    let mut dev = leased_device(1000, t0);
    let mut out = Capture::default();
    let mut now = t0;
    for k in 0..9u16 {
        // 900 ms apart, for 8 s: eight leases' worth.
        now += 900_000;
        assert!(dev.poll(now, &mut out).is_some());
        let renewal = match k % 3 {
            0 => Message::Renew,
            1 => Message::GetStatus,
            _ => centroid(u32::from(k), [0, 0, 200_000], true),
        };
        let r = request(&mut dev, 10 + k, &renewal, now);
        assert!(!matches!(r, Reply::Nack(_)), "{r:?}");
        assert!(dev.is_sounding(now), "still playing at {now}");
    }
    assert_eq!(status(&mut dev, now).state, DeviceState::Playing);
    // A refused request (no such slot) is not a renewal.
    let last = now;
    nacks(
        &mut dev,
        30,
        &play(40, PlayAt::Immediate),
        last + 500_000,
        NackCode::BadSlot,
    );
    let end = poll_out(&mut dev, last + 500_000, &mut out, 100_000);
    assert_eq!(end, last + 1_000_000);
    assert_eq!(out.frames.last().unwrap().3, 0);
    // The status request at `last` renewed it, the nack did not.
    let st = status(&mut dev, end);
    assert_eq!(
        (st.state, st.mute_reason),
        (DeviceState::Stopped, MuteReason::LeaseExpired)
    );
    assert!(
        out.frames
            .iter()
            .all(|f| f.3 == 0 || f.0 < last + 1_000_000)
    );
}

/// A poll long after the expiry (a busy or sleeping board) still stops at
/// once with a muted frame, and hands out none of the steps it missed; a
/// request arriving late stops the play before it is answered, so it
/// cannot revive it.
#[test]
fn a_late_poll_or_request_still_stops_and_never_revives() {
    let mut dev = leased_device(1000, 0);
    let mut out = Capture::default();
    dev.poll(0, &mut out);
    assert_eq!(out.frames.len(), 1);
    dev.poll(7_000_000, &mut out);
    assert_eq!(out.frames.len(), 2);
    assert_eq!(out.frames[1].3, 0, "the late poll's frame is muted");
    assert_eq!(dev.poll(7_000_001, &mut out), None);
    assert_eq!(
        status(&mut dev, 7_000_002).mute_reason,
        MuteReason::LeaseExpired
    );

    let mut dev = leased_device(1000, 0);
    let mut out = Capture::default();
    dev.poll(0, &mut out);
    // No poll since: the request comes 3 s late.
    acks(&mut dev, 5, &Message::Renew, 3_000_000);
    assert!(!dev.is_sounding(3_000_000));
    dev.poll(3_000_000, &mut out);
    assert_eq!(out.frames.last().unwrap().3, 0);
    let st = status(&mut dev, 3_000_001);
    assert_eq!((st.state, st.lease_expiries), (DeviceState::Stopped, 1));
}

/// Every kind of play has the lease: tracked (even while muted), and timed
/// (a long timed play ends at the lease, not at its steps); a long frame
/// repeat ends with it. A `Stop` before the expiry is a plain stop.
#[test]
fn every_play_has_the_lease_and_stop_is_not_an_expiry() {
    // Tracked, waiting for a finger.
    let mut cfg = config(8);
    cfg.require_tracking = true;
    let mut dev = device(cfg, 10 * 8);
    Seq::pattern(10, 8, 10_000, 5).upload(&mut dev, 0, Encoding::Raw, 0);
    acks(&mut dev, 1, &leased(play(0, PlayAt::Immediate), 250), 0);
    assert_eq!(
        status(&mut dev, 1).mute_reason,
        MuteReason::WaitingForTracking
    );
    let mut out = Capture::default();
    // The status request at 1 µs renewed it.
    assert_eq!(poll_out(&mut dev, 1, &mut out, 10_000), 250_001);
    assert_eq!(
        status(&mut dev, 250_002).mute_reason,
        MuteReason::LeaseExpired
    );

    // Timed: 100 000 steps of 1 ms would take 100 s.
    let mut dev = device(config(8), 10 * 8);
    Seq::pattern(10, 8, 10_000, 5).upload(&mut dev, 0, Encoding::Raw, 0);
    acks(
        &mut dev,
        1,
        &leased(play_steps(0, PlayAt::Immediate, 100_000), 100),
        0,
    );
    let mut out = Capture::default();
    assert_eq!(poll_out(&mut dev, 0, &mut out, 1_000_000), 100_000);
    assert_eq!(out.frames.iter().filter(|f| f.3 == 255).count(), 100);

    // A 300 ms dwell repeated every 50 ms: the repeats end at the expiry.
    let mut dev = device(config(8), 2 * 8);
    Seq::pattern(2, 8, 600_000, 3).upload(&mut dev, 0, Encoding::Raw, 0);
    acks(&mut dev, 1, &leased(play_untracked(0), 1000), 0);
    let mut out = Capture::default();
    assert_eq!(poll_out(&mut dev, 0, &mut out, 10_000), 1_000_000);
    let (last, before) = out.frames.split_last().unwrap();
    assert!(before.iter().all(|f| f.3 == 255 && f.0 < 1_000_000));
    assert_eq!(last.3, 0);

    // Stop within the lease: reason Stopped, nothing counted.
    let mut dev = leased_device(1000, 0);
    acks(&mut dev, 2, &Message::Stop, 500_000);
    let mut out = Capture::default();
    assert_eq!(dev.poll(500_000, &mut out), None);
    let st = status(&mut dev, 5_000_000);
    assert_eq!(
        (st.mute_reason, st.lease_expiries),
        (MuteReason::Stopped, 0)
    );
}

/// `Play.lease_ms` outside 100 ..= 60000 is out of range (0 included:
/// there is no "forever"), checked after the slot number and before the
/// entry; a refused play changes nothing.
#[test]
fn a_lease_outside_its_bounds_is_refused() {
    let mut dev = device(config(8), 10 * 8);
    Seq::pattern(10, 8, 10_000, 5).upload(&mut dev, 0, Encoding::Raw, 0);
    for bad in [0, 1, 99, 60_001, u16::MAX] {
        nacks(
            &mut dev,
            1,
            &leased(play(0, PlayAt::Immediate), bad),
            0,
            NackCode::OutOfRange,
        );
        nacks(
            &mut dev,
            2,
            &leased(play(40, PlayAt::Immediate), bad),
            0,
            NackCode::BadSlot,
        );
        nacks(
            &mut dev,
            3,
            &leased(play(5, PlayAt::Immediate), bad),
            0,
            NackCode::OutOfRange,
        );
    }
    assert_eq!(status(&mut dev, 0).state, DeviceState::Idle);
    for ok in [100, 1000, 60_000] {
        acks(&mut dev, 4, &leased(play(0, PlayAt::Immediate), ok), 0);
        assert_eq!(status(&mut dev, 0).lease_ms, ok);
    }
}

/// An output with a loopback jumper (or without one).
struct Loopback(Option<u8>);

impl lm_fw_core::OutputDriver for Loopback {
    type Error = core::convert::Infallible;
    fn write_frame(&mut self, _: &lm_fw_core::OutputFrame<'_>) -> Result<(), Self::Error> {
        Ok(())
    }
    fn self_test(&mut self) -> lm_proto::SelfTest {
        let stuck = self.0;
        lm_fw_core::output::loopback_test(|sent: &[u8], got: &mut [u8]| {
            for (g, s) in got.iter_mut().zip(sent) {
                *g = stuck.unwrap_or(*s);
            }
            Ok::<(), ()>(())
        })
    }
}

/// `SelfTest` through the wire: the board's result, `Unsupported` where it
/// has none, `Busy` while a slot plays or is queued.
#[test]
fn self_test_reports_the_boards_loopback_and_waits_for_silence() {
    let mut dev = device(config(8), 10 * 8);
    Seq::pattern(10, 8, 10_000, 5).upload(&mut dev, 0, Encoding::Raw, 0);
    let mut wire = [0u8; lm_proto::MAX_ENCODED_FRAME];
    let n = lm_proto::encode_frame(9, &Message::SelfTest, &mut wire).unwrap();
    let run = |dev: &mut lm_fw_core::Device<'_>, out: &mut Loopback| {
        let mut bytes = Vec::new();
        dev.feed(&wire[..n], 0, out, &mut |b: &[u8]| {
            bytes.extend_from_slice(b)
        });
        let mut d = lm_proto::FrameDecoder::new();
        match d.feed(&bytes) {
            lm_proto::FeedResult::Frame { frame, .. } => {
                assert_eq!(frame.seq, 9);
                match frame.message {
                    Message::SelfTestResult(t) => Ok(t),
                    Message::Nack(c) => Err(c),
                    m => panic!("{m:?}"),
                }
            }
            _ => panic!("no reply"),
        }
    };
    assert_eq!(
        run(&mut dev, &mut Loopback(None)),
        Ok(lm_proto::SelfTest::Passed { bytes: 1024 })
    );
    match run(&mut dev, &mut Loopback(Some(0xFF))) {
        Ok(lm_proto::SelfTest::Failed {
            bytes: 1024,
            first_mismatch: 0,
            sent: 0,
            got: 0xFF,
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    // Without an output (`handle`), and with a recorder: unsupported.
    assert_eq!(
        request(&mut dev, 3, &Message::SelfTest, 0),
        Reply::SelfTest(lm_proto::SelfTest::Unsupported)
    );
    assert_eq!(
        dev.handle(&Message::SelfTest, 0),
        Message::SelfTestResult(lm_proto::SelfTest::Unsupported)
    );
    acks(&mut dev, 4, &play_untracked(0), 0);
    assert_eq!(run(&mut dev, &mut Loopback(None)), Err(NackCode::Busy));
    acks(&mut dev, 5, &Message::Stop, 0);
    assert!(run(&mut dev, &mut Loopback(None)).is_ok());
}
