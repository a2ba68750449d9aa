//! Amplitude modulation on the LM firmware (protocol v6): an entry's
//! per-step intensity table goes into each step's SPI frame, and a table
//! that did not arrive whole, or arrived changed, never plays.

mod common;

use common::*;
use lm_fw_core::Device;
use lm_fw_core::output::SPI_FRAME_MAGIC;
use lm_fw_core::store::scale_intensity;
use lm_proto::NackCode::{self, *};
use lm_proto::codec::Encoding;
use lm_proto::{Commit, Intensity, Message, PlayAt};

const STEPS: u16 = 8;
const T: u16 = 4;
const PERIOD_US: u32 = 8_000;
const LEVEL: u8 = 200;
/// A square AM, two periods per cycle, at depth 0.75: 255 then 64.
const TABLE: [u8; 8] = [255, 255, 64, 64, 255, 255, 64, 64];

fn levels(slot: u8, offset: u16, data: &[u8]) -> Message<'_> {
    Message::Intensity(Intensity { slot, offset, data })
}

/// The commit of `seq` with `table`: CRC-32 of the phases, then the levels.
fn commit(seq: &Seq, slot: u8, table: &[u8]) -> Message<'static> {
    let mut c = lm_proto::Crc32::new();
    c.update(&seq.phases);
    c.update(table);
    Message::Commit(Commit {
        slot,
        crc32: c.finish(),
    })
}

/// Sends the rig, a table `BeginUpload` and the chunks into `slot`, each acked.
fn begin_with_table(dev: &mut Device<'_>, seq: &Seq, slot: u8) {
    let stream = seq.encode(Encoding::Raw);
    for (i, mut m) in seq
        .upload_requests(slot, Encoding::Raw, &stream, 7)
        .into_iter()
        .enumerate()
    {
        if let Message::BeginUpload(b) = &mut m {
            b.header.intensity = LEVEL;
            b.intensity_table = true;
        }
        assert_eq!(request(dev, i as u16, &m, 0), Reply::Ack, "{m:?}");
    }
}

/// Sends each request of `script` in turn (seq numbers from `first`) and
/// checks its reply; a failure names the request.
fn exchange(dev: &mut Device<'_>, first: u16, script: &[(Message<'_>, Reply)]) {
    for (i, (m, want)) in script.iter().enumerate() {
        assert_eq!(&request(dev, first + i as u16, m, 0), want, "{i}: {m:?}");
    }
}

/// Plays `slot` for `cycles` cycles through [`SpiOutput`]; every transaction.
fn play_cycles(dev: &mut Device<'_>, slot: u8, cycles: usize) -> Vec<Vec<u8>> {
    assert_eq!(
        request(dev, 900, &play(slot, PlayAt::Immediate), 0),
        Reply::Ack
    );
    let mut wire = Wire::default();
    wire.play(dev, cycles * usize::from(STEPS));
    wire.transactions
}

#[test]
fn each_steps_frame_carries_the_entrys_intensity_times_its_level() {
    let seq = Seq::pattern(STEPS, T, PERIOD_US, 3);
    let mut dev = device(config(T), seq.phases.len() + usize::from(STEPS));
    begin_with_table(&mut dev, &seq, 0);
    // Levels in two frames, the second re-sent (an identical repeat).
    exchange(
        &mut dev,
        100,
        &[
            (levels(0, 0, &TABLE[..3]), Reply::Ack),
            (levels(0, 3, &TABLE[3..]), Reply::Ack),
            (levels(0, 3, &TABLE[3..]), Reply::Ack),
            (commit(&seq, 0, &TABLE), Reply::Ack),
        ],
    );
    let frames = play_cycles(&mut dev, 0, 2);
    for (g, f) in frames.iter().enumerate() {
        let k = g % usize::from(STEPS);
        assert_eq!((f[0], f[1]), (SPI_FRAME_MAGIC, 255), "frame {g}");
        assert_eq!(u16::from_le_bytes([f[3], f[4]]) as usize, k);
        // 200 × 255 / 255 = 200 and 200 × 64 / 255 = 50.2 → 50.
        let want = if TABLE[k] == 255 { 200 } else { 50 };
        assert_eq!(f[2], want, "step {k}");
        assert_eq!(f[2], scale_intensity(LEVEL, TABLE[k]));
    }
}

#[test]
fn a_partial_or_changed_table_never_plays_and_the_old_entry_keeps_playing() {
    let seq = Seq::pattern(STEPS, T, PERIOD_US, 5);
    let mut dev = device(config(T), 4 * seq.phases.len());
    // Slot 1: the same phases without a table, at full intensity.
    seq.upload(&mut dev, 1, Encoding::Raw, 0);
    begin_with_table(&mut dev, &seq, 0);
    let nack = Reply::Nack;
    let mut changed = TABLE;
    changed[6] = 63;
    exchange(
        &mut dev,
        100,
        &[
            (levels(0, 0, &TABLE[..5]), Reply::Ack),
            // Levels with a gap, past the last step, or different from received.
            (levels(0, 6, &TABLE[6..]), nack(OutOfOrder)),
            (levels(0, 5, &[1, 2, 3, 4]), nack(OutOfRange)),
            (levels(0, 1, &[9]), nack(OutOfOrder)),
            // Three levels missing: no commit, no play.
            (commit(&seq, 0, &TABLE), nack(Incomplete)),
            (play(0, PlayAt::Immediate), nack(NotCommitted)),
            // The rest arrives, but one level differs from what the host
            // planned: the commit's CRC (phases, then the stored levels)
            // catches it.
            (levels(0, 5, &changed[5..]), Reply::Ack),
            (commit(&seq, 0, &TABLE), nack(CrcMismatch)),
            (play(0, PlayAt::Immediate), nack(NotCommitted)),
        ],
    );
    // A commit of phases only (a host that forgot the table) fails too.
    begin_with_table(&mut dev, &seq, 0);
    exchange(
        &mut dev,
        109,
        &[
            (levels(0, 0, &TABLE), Reply::Ack),
            (seq.commit(0), nack(CrcMismatch)),
        ],
    );
    // Slot 1 plays on at its one intensity in every frame.
    let frames = play_cycles(&mut dev, 1, 1);
    assert!(frames.iter().all(|f| f[2] == 255), "{frames:?}");
}

/// A frame on the wire from raw parts: version, type, seq, payload, CRC.
fn raw_frame(version: u8, msg_type: u8, seq: u16, payload: &[u8]) -> Vec<u8> {
    let mut f = vec![version, msg_type];
    f.extend(seq.to_le_bytes());
    f.extend(payload);
    f.extend(lm_proto::crc32(&f).to_le_bytes());
    let mut enc = vec![0u8; lm_proto::cobs::max_encoded_len(f.len())];
    let n = lm_proto::cobs::encode(&f, &mut enc).unwrap();
    let mut wire = vec![0];
    wire.extend(&enc[..n]);
    wire.push(0);
    wire
}

/// Hostile table bytes while an entry plays and another uploads: each
/// frame gets exactly one answer (malformed ones `Malformed`, counted),
/// the playing entry is never touched and the upload still commits.
#[test]
fn hostile_intensity_frames_get_one_answer_and_touch_nothing_else() {
    use lm_proto::PROTOCOL_VERSION as V;
    let seq = Seq::pattern(STEPS, T, PERIOD_US, 7);
    let mut dev = device(config(T), 4 * seq.phases.len());
    seq.upload(&mut dev, 1, Encoding::Raw, 0);
    assert_eq!(
        request(&mut dev, 50, &play(1, PlayAt::Immediate), 0),
        Reply::Ack
    );
    begin_with_table(&mut dev, &seq, 0);
    let level = |slot: u8, offset: u16, data: &[u8]| {
        let mut p = vec![slot];
        p.extend(offset.to_le_bytes());
        p.extend(data);
        p
    };
    let mut begin_v5 = Vec::new();
    if let Message::BeginUpload(b) = seq.begin(2, Encoding::Raw) {
        let mut buf = [0u8; 64];
        let n = Message::BeginUpload(b).emit_payload(&mut buf).unwrap();
        begin_v5.extend(&buf[..n - 1]);
    }
    let mut begin_flags = begin_v5.clone();
    begin_flags.push(0x80);
    let nack = |c| Reply::Nack(c);
    // Type 0x0E: `Intensity`; 0x02: `BeginUpload`.
    let cases: Vec<(&str, u8, Vec<u8>, Reply)> = vec![
        (
            "no levels",
            0x0E,
            level(0, 0, &[]),
            nack(NackCode::Malformed),
        ),
        (
            "1025 levels",
            0x0E,
            level(0, 0, &[1; 1025]),
            nack(NackCode::Malformed),
        ),
        (
            "2 payload bytes",
            0x0E,
            vec![0, 0],
            nack(NackCode::Malformed),
        ),
        (
            "offset 65535",
            0x0E,
            level(0, u16::MAX, &[1, 2]),
            nack(NackCode::OutOfRange),
        ),
        (
            "past the last step",
            0x0E,
            level(0, 7, &[1, 2]),
            nack(NackCode::OutOfRange),
        ),
        ("a gap", 0x0E, level(0, 3, &[1]), nack(NackCode::OutOfOrder)),
        (
            "the playing slot",
            0x0E,
            level(1, 0, &[1]),
            nack(NackCode::SlotPlaying),
        ),
        (
            "slot 255",
            0x0E,
            level(255, 0, &[1]),
            nack(NackCode::BadSlot),
        ),
        (
            "no upload there",
            0x0E,
            level(2, 0, &[1]),
            nack(NackCode::NoUpload),
        ),
        ("v5 BeginUpload", 0x02, begin_v5, nack(NackCode::Malformed)),
        ("unknown flag", 0x02, begin_flags, nack(NackCode::Malformed)),
    ];
    let before = dev.counters().bad_frames;
    for (i, (what, ty, payload, want)) in cases.iter().enumerate() {
        let replies = feed(&mut dev, &raw_frame(V, *ty, 200 + i as u16, payload), 0);
        assert_eq!(replies.len(), 1, "{what}: {replies:?}");
        assert_eq!(&replies[0].1, want, "{what}");
    }
    assert_eq!(dev.counters().bad_frames - before, 5, "the malformed ones");
    // The upload is intact: the whole table, then the commit.
    exchange(
        &mut dev,
        300,
        &[
            (levels(0, 0, &TABLE), Reply::Ack),
            (commit(&seq, 0, &TABLE), Reply::Ack),
        ],
    );
    // Slot 1 played on untouched at its one intensity.
    let mut wire = Wire::default();
    wire.play(&mut dev, usize::from(STEPS));
    assert!(wire.transactions.iter().all(|f| f[2] == 255));
}
