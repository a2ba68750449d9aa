//! The exact-byte vectors in `vectors/frames.txt` (generated from the spec
//! by an independent Python encoder) against the Rust encoder and decoder.

mod common;

use common::paper;
use lm_proto::vectors::{self, Vector, error_kind, hex_decode};
use lm_proto::*;

/// The echo of request `msg` sent with `seq`.
fn echo(seq: u16, msg: &Message<'_>) -> Echo {
    Echo::of_request(seq, msg).unwrap()
}

/// The head and message each good vector encodes, by name.
fn expected(name: &str) -> Option<(Head, Message<'static>)> {
    let (seq, message) = expected_message(name)?;
    let commit = Message::Commit(Commit {
        slot: 0,
        crc32: 0xCBF4_3926,
    });
    let request = match name {
        "info" | "info_no_rig" => Some(echo(0, &Message::GetInfo)),
        n if n.starts_with("status") => Some(echo(seq, &Message::GetStatus)),
        n if n.starts_with("self_test_") => Some(echo(seq, &Message::SelfTest)),
        "ack" => Some(echo(seq, &Message::Renew)),
        "nack_unknown_code" => Some(Echo {
            request_type: 0x42,
            request_crc32: crc32(&[PROTOCOL_VERSION, 0x42, 17, 0]),
        }),
        n if n.starts_with("nack") => Some(echo(seq, &commit)),
        _ => None,
    };
    Some((Head { seq, echo: request }, message))
}

/// The message each good vector encodes, by name.
fn expected_message(name: &str) -> Option<(u16, Message<'static>)> {
    static LONG: [u8; 300] = {
        let mut a = [0u8; 300];
        let mut i = 0;
        while i < 300 {
            a[i] = (i % 255) as u8 + 1;
            i += 1;
        }
        a
    };
    static LEVELS: [u8; 1024] = {
        let mut a = [0u8; 1024];
        let mut i = 0;
        while i < 1024 {
            a[i] = i as u8;
            i += 1;
        }
        a
    };
    static POS: [[i32; 3]; 2] = [[-96520, -66040, 0], [-86360, -66040, 0]];
    let (seq, message) = match name {
        "get_info" => (0, Message::GetInfo),
        "info" => (
            0,
            Message::Info(Info {
                proto_version: 7,
                fw_version: [0, 1, 0],
                max_transducers: 996,
                slot_bytes: 487_424,
                slots: 32,
                timer_hz: 1_000_000,
                min_dwell_us: 100,
                max_chunk: 1024,
                rig_transducers: 996,
                rig_crc32: 0x89AB_CDEF,
                library_free: 300_000,
                clock: ClockSource::Crystal,
            }),
        ),
        "info_no_rig" => (
            0,
            Message::Info(Info {
                proto_version: 7,
                fw_version: [1, 2, 3],
                max_transducers: 249,
                slot_bytes: 1000,
                slots: 32,
                timer_hz: 25_000_000,
                min_dwell_us: 1000,
                max_chunk: 512,
                rig_transducers: 0,
                rig_crc32: 0,
                library_free: 1000,
                clock: ClockSource::InternalRc,
            }),
        ),
        "begin_rig" => (
            26,
            Message::BeginRig(BeginRig {
                transducers: 996,
                crc32: 0x89AB_CDEF,
            }),
        ),
        "commit_rig" => (27, Message::CommitRig),
        "begin_upload" => (
            1,
            Message::BeginUpload(BeginUpload {
                slot: 0,
                header: UploadHeader {
                    steps: 82,
                    transducers: 996,
                    period_us: 200_000,
                    center_um: [0, 30_000, 30_000],
                    foci_per_step: 4,
                    sound_speed_mm_s: 343_200,
                    max_offset_um: 20_000,
                    intensity: 255,
                },
                encoding: Encoding::Delta,
                encoded_len: 22_000,
                rig_crc32: 0x89AB_CDEF,
                intensity_table: false,
            }),
        ),
        "begin_upload_raw" => (
            2,
            Message::BeginUpload(BeginUpload {
                slot: 1,
                header: UploadHeader {
                    steps: 1,
                    transducers: 1,
                    period_us: 1000,
                    center_um: [-1, -2, -3],
                    foci_per_step: 1,
                    sound_speed_mm_s: 100_000,
                    max_offset_um: 100_000,
                    intensity: 128,
                },
                encoding: Encoding::Raw,
                encoded_len: 1,
                rig_crc32: 1,
                intensity_table: false,
            }),
        ),
        "begin_upload_table" => (
            31,
            Message::BeginUpload(BeginUpload {
                slot: 2,
                header: paper::lm_s::lm_s_header(200),
                encoding: Encoding::Raw,
                encoded_len: 82 * 996,
                rig_crc32: 0x89AB_CDEF,
                intensity_table: true,
            }),
        ),
        "intensity" => (
            32,
            Message::Intensity(Intensity {
                slot: 2,
                offset: 80,
                data: &[0xFF, 0x80, 0x00],
            }),
        ),
        "intensity_long" => (
            33,
            Message::Intensity(Intensity {
                slot: 0,
                offset: u16::MAX,
                data: &LEVELS,
            }),
        ),
        "geometry" => (
            3,
            Message::Geometry(Geometry {
                first: 996,
                positions: Positions::from_points(&POS),
            }),
        ),
        "chunk" => (
            5,
            Message::Chunk(Chunk {
                slot: 0,
                offset: 1024,
                data: &[0, 1, 2, 0xFF, 0],
            }),
        ),
        "chunk_long" => (
            6,
            Message::Chunk(Chunk {
                slot: 1,
                offset: 0,
                data: &LONG,
            }),
        ),
        "commit" => (
            8,
            Message::Commit(Commit {
                slot: 0,
                crc32: 0xCBF4_3926,
            }),
        ),
        "play_next_cycle" => (
            9,
            Message::Play(Play {
                slot: 1,
                at: PlayAt::NextCycle,
                untracked: false,
                steps: 0,
                lease_ms: 1000,
            }),
        ),
        "play_immediate" => (
            10,
            Message::Play(Play {
                slot: 0,
                at: PlayAt::Immediate,
                untracked: false,
                steps: 0,
                lease_ms: 100,
            }),
        ),
        "play_steps" => (
            28,
            Message::Play(Play {
                slot: 2,
                at: PlayAt::NextCycle,
                untracked: true,
                steps: 100_000,
                lease_ms: 60_000,
            }),
        ),
        "stop" => (11, Message::Stop),
        "renew" => (29, Message::Renew),
        "self_test" => (30, Message::SelfTest),
        "centroid" => (
            12,
            Message::Centroid(Centroid {
                seq: 42,
                pos_um: [-1500, 30_250, 29_800],
                present: true,
                host_time_us: 1_234_567_890_123,
            }),
        ),
        "centroid_absent" => (
            13,
            Message::Centroid(Centroid {
                seq: u32::MAX,
                pos_um: [0, 0, 0],
                present: false,
                host_time_us: u64::MAX,
            }),
        ),
        "get_status" => (14, Message::GetStatus),
        "status" => (
            14,
            Message::Status(Status {
                state: DeviceState::Playing,
                slot: Some(1),
                step: 17,
                cycles: 300,
                missed_deadlines: 0,
                last_centroid_seq: 42,
                bad_frames: 2,
                crc_errors: 1,
                nacks: 3,
                correction_um: [-1500, 250, -200],
                queued_slot: Some(0),
                mute_reason: MuteReason::None,
                lease_ms: 1000,
                lease_expiries: 2,
                uptime_ms: 123_456,
            }),
        ),
        // A device fresh from reset.
        "status_idle" => (15, Message::Status(Status::default())),
        "status_muted" => (
            15,
            Message::Status(Status {
                state: DeviceState::Muted,
                slot: Some(0),
                step: 3,
                cycles: 1,
                missed_deadlines: 0,
                last_centroid_seq: 7,
                bad_frames: 0,
                crc_errors: 0,
                nacks: 1,
                correction_um: [0, 0, 0],
                queued_slot: None,
                mute_reason: MuteReason::CentroidOutOfRange,
                lease_ms: 60_000,
                lease_expiries: 0,
                uptime_ms: u32::MAX,
            }),
        ),
        "status_lease_expired" => (
            16,
            Message::Status(Status {
                state: DeviceState::Stopped,
                slot: Some(4),
                step: 9,
                cycles: 12,
                mute_reason: MuteReason::LeaseExpired,
                lease_ms: 1000,
                lease_expiries: u32::MAX,
                uptime_ms: 60_000,
                ..Status::default()
            }),
        ),
        "self_test_unsupported" => (30, Message::SelfTestResult(SelfTest::Unsupported)),
        "self_test_passed" => (
            30,
            Message::SelfTestResult(SelfTest::Passed { bytes: 1024 }),
        ),
        "self_test_failed" => (
            30,
            Message::SelfTestResult(SelfTest::Failed {
                bytes: 1024,
                mismatches: 1020,
                first_mismatch: 3,
                sent: 0x03,
                got: 0xFF,
            }),
        ),
        "ack" => (0xBEEF, Message::Ack),
        "nack" => (16, Message::Nack(NackCode::OutOfOrder)),
        "nack_library_full" => (16, Message::Nack(NackCode::LibraryFull)),
        "nack_no_rig" => (16, Message::Nack(NackCode::NoRig)),
        "nack_rig_mismatch" => (16, Message::Nack(NackCode::RigMismatch)),
        "nack_unknown_code" => (17, Message::Nack(NackCode::Other(200))),
        _ => return None,
    };
    Some((seq, message))
}

fn bytes(hex: &str) -> Vec<u8> {
    let mut buf = vec![0u8; hex.len()];
    let n = hex_decode(hex, &mut buf).expect("valid hex");
    buf.truncate(n);
    buf
}

fn all() -> Vec<Vector<'static>> {
    vectors::parse(TEST_VECTORS).collect()
}

#[test]
fn file_has_every_message_type_and_error_kind() {
    let v = all();
    assert!(v.len() >= 25, "only {} vectors", v.len());
    for t in MessageType::ALL {
        assert!(
            v.iter()
                .any(|r| r.error.is_none() && r.msg_type == Some(t as u8)),
            "no vector for {t:?}"
        );
    }
    for kind in [
        "crc",
        "unknown_type",
        "bad_version",
        "malformed",
        "cobs",
        "too_short",
    ] {
        assert!(
            v.iter().any(|r| r.error == Some(kind)),
            "no vector for error {kind}"
        );
    }
    let mut names: Vec<_> = v.iter().map(|r| r.name).collect();
    names.sort();
    names.dedup();
    assert_eq!(names.len(), v.len(), "duplicate names");
}

#[test]
fn encoder_produces_the_vector_bytes() {
    for v in all().iter().filter(|v| v.error.is_none()) {
        if v.expect.is_some() {
            // Device behaviour records: their fields are checked by the
            // firmware's replay; here they must round-trip exactly.
            let d = bytes(v.decoded.unwrap());
            let f = decode_frame(&d).unwrap_or_else(|e| panic!("{}: {e}", v.name));
            let mut wire = [0u8; MAX_ENCODED_FRAME];
            let n = encode_frame(f.head(), &f.message, &mut wire).unwrap();
            assert_eq!(&wire[..n], &bytes(v.wire)[..], "wire bytes of {}", v.name);
            continue;
        }
        let (head, message) =
            expected(v.name).unwrap_or_else(|| panic!("no expected message for {}", v.name));
        assert_eq!(v.seq, Some(head.seq), "{}", v.name);
        assert_eq!(v.msg_type, Some(message.msg_type() as u8), "{}", v.name);
        let mut wire = [0u8; MAX_ENCODED_FRAME];
        let n = encode_frame(head, &message, &mut wire).unwrap();
        assert_eq!(&wire[..n], &bytes(v.wire)[..], "wire bytes of {}", v.name);
        assert_eq!(encoded_frame_len(head, &message), Ok(n), "{}", v.name);
        let mut dec = [0u8; MAX_FRAME];
        let m = encode_frame_unframed(head, &message, &mut dec).unwrap();
        assert_eq!(
            &dec[..m],
            &bytes(v.decoded.unwrap())[..],
            "decoded bytes of {}",
            v.name
        );
        let echo = if head.echo.is_some() { len::ECHO } else { 0 };
        assert_eq!(message.payload_len(), m - HEADER_LEN - echo - CRC_LEN);
    }
}

#[test]
fn decoder_reads_the_vector_bytes() {
    let mut wire = [0u8; 2 * MAX_ENCODED_FRAME];
    let mut again = [0u8; MAX_ENCODED_FRAME];
    for v in all() {
        let replayed = vectors::replay(&v, &mut wire, &mut again, |frame| {
            if v.expect.is_none() {
                assert_eq!(
                    Some((frame.head(), frame.message)),
                    expected(v.name),
                    "{}",
                    v.name
                );
            }
        });
        assert_eq!(replayed, Ok(()), "{}", v.name);
        if let Some(d) = v.decoded {
            let d = bytes(d);
            match decode_frame(&d) {
                Ok(_) if v.expect.is_some() => {}
                Ok(f) => assert_eq!(Some((f.head(), f.message)), expected(v.name)),
                Err(e) => assert_eq!(Some(error_kind(&e)), v.error, "{}", v.name),
            }
        }
    }
}

/// The replay catches what it is there to catch: a record whose seq, error
/// kind or bytes disagree with the decoder.
#[test]
fn replay_reports_a_record_the_bytes_disagree_with() {
    let mut wire = [0u8; 2 * MAX_ENCODED_FRAME];
    let mut again = [0u8; MAX_ENCODED_FRAME];
    let good = all().into_iter().find(|v| v.name == "get_status").unwrap();
    let bad_crc = all().into_iter().find(|v| v.name == "err_crc").unwrap();
    let replay = |v: Vector<'_>, w: &mut [u8], a: &mut [u8]| vectors::replay(&v, w, a, |_| {});
    let wrong_seq = Vector {
        seq: good.seq.map(|s| s.wrapping_add(1)),
        ..good
    };
    assert!(matches!(
        replay(wrong_seq, &mut wire, &mut again),
        Err(vectors::Mismatch::Seq { .. })
    ));
    let wants_error = Vector {
        error: Some("crc"),
        ..good
    };
    assert_eq!(
        replay(wants_error, &mut wire, &mut again),
        Err(vectors::Mismatch::Decoded)
    );
    let other_kind = Vector {
        error: Some("cobs"),
        ..bad_crc
    };
    assert_eq!(
        replay(other_kind, &mut wire, &mut again),
        Err(vectors::Mismatch::Error { got: "crc" })
    );
    let two_frames = format!("{} {}", good.wire, good.wire);
    let twice = Vector {
        wire: &two_frames,
        ..good
    };
    assert_eq!(
        replay(twice, &mut wire, &mut again),
        Err(vectors::Mismatch::Outcomes(2))
    );
    let bad_hex = Vector { wire: "zz", ..good };
    assert_eq!(
        replay(bad_hex, &mut wire, &mut again),
        Err(vectors::Mismatch::Hex)
    );
}

#[test]
fn unknown_type_vector_maps_to_an_unknown_type_nack() {
    let v = all()
        .into_iter()
        .find(|v| v.name == "err_unknown_type")
        .unwrap();
    let d = bytes(v.decoded.unwrap());
    let e = decode_frame(&d).unwrap_err();
    assert_eq!(
        e,
        FrameError::UnknownType {
            seq: 19,
            msg_type: 0x42,
            crc32: u32::from_le_bytes(d[d.len() - 4..].try_into().unwrap()),
        }
    );
    let echo = Echo {
        request_type: 0x42,
        request_crc32: crc32(&d[..d.len() - 4]),
    };
    assert_eq!(
        e.nack(),
        Some((Head::reply(19, echo), NackCode::UnknownType))
    );
}

/// `frames.txt` is exactly what the independent generator writes from the
/// spec (`python3 vectors/gen_frames.py > vectors/frames.txt`), so neither
/// is edited alone. Skipped, with a message, without python3.
#[test]
fn vector_file_is_what_the_generator_writes() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/vectors");
    let out = match std::process::Command::new("python3")
        .arg("gen_frames.py")
        .current_dir(dir)
        .output()
    {
        Ok(o) => o,
        Err(e) => {
            eprintln!("skipped: python3 cannot run ({e})");
            return;
        }
    };
    assert!(
        out.status.success(),
        "gen_frames.py failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        out.stdout == TEST_VECTORS.as_bytes(),
        "vectors/frames.txt differs from what gen_frames.py writes: run \
         `python3 gen_frames.py > frames.txt` in proto/vectors"
    );
}
