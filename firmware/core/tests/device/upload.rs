//! Uploads, framing and the configuration the device reports.

use super::*;

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
    let (mut dev, _, b) = device_with_a_and_b();
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
        intensity_table: false,
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

/// `Status::uptime_ms` counts whole milliseconds of the timer from reset
/// (from the epoch a shared-clock device sets), whatever it plays.
#[test]
fn status_counts_milliseconds_since_reset() {
    let mut dev = device(config(8), 64);
    assert_eq!(status(&mut dev, 0).uptime_ms, 0);
    assert_eq!(status(&mut dev, 1_999).uptime_ms, 1);
    assert_eq!(status(&mut dev, 2_500_000).uptime_ms, 2_500);
    let mut late = device(config(8), 64);
    late.set_epoch(7_000_000);
    assert_eq!(status(&mut late, 7_000_000).uptime_ms, 0);
    assert_eq!(status(&mut late, 7_250_000).uptime_ms, 250);
}

/// SPEC section 3, Lists: a `Chunk`, `Geometry` or `Intensity` of no
/// elements is malformed however it reaches the device: as bytes (the
/// vectors `dev_chunk_empty`, `dev_geometry_empty`) or built in process
/// and handed to `Device::handle`, at the very offset a real one would be
/// appended at. It changes nothing: the upload goes on and commits.
#[test]
fn a_list_of_no_elements_is_malformed_in_process_too() {
    let mut dev = device(config(4), 64);
    let seq = Seq::pattern(2, 4, 10_000, 3);
    let stream = seq.encode(Encoding::Raw);
    let reqs = seq.upload_requests(0, Encoding::Raw, &stream, 4);
    let (last, head) = reqs.split_last().unwrap();
    for (i, m) in head.iter().enumerate() {
        assert_eq!(request(&mut dev, i as u16, m, 0), Reply::Ack, "{m:?}");
    }
    let empties = [
        Message::Chunk(Chunk {
            slot: 0,
            offset: 4,
            data: &[],
        }),
        Message::Geometry(lm_proto::Geometry {
            first: 4,
            positions: lm_proto::Positions::from_points(&[]),
        }),
        Message::Intensity(lm_proto::Intensity {
            slot: 0,
            offset: 0,
            data: &[],
        }),
    ];
    for m in &empties {
        assert_eq!(
            dev.handle(m, 0),
            Message::Nack(NackCode::Malformed),
            "{m:?}"
        );
    }
    assert_eq!(request(&mut dev, 90, last, 0), Reply::Ack);
    assert_eq!(request(&mut dev, 91, &seq.commit(0), 0), Reply::Ack);
}
