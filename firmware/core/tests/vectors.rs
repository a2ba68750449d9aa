//! The proto crate's exact-byte vectors, fed in file order to one device,
//! each get the response this firmware must give.

mod common;

use common::*;
use lm_proto::{DeviceState, NackCode, TEST_VECTORS};

struct Vector {
    name: String,
    wire: Vec<u8>,
    expect: Option<String>,
    malformed: bool,
}

fn vectors() -> Vec<Vector> {
    lm_proto::vectors::parse(TEST_VECTORS)
        .map(|v| Vector {
            name: v.name.to_string(),
            wire: {
                let mut wire = vec![0u8; v.wire.len()];
                let n = lm_proto::vectors::hex_decode(v.wire, &mut wire).expect("valid hex");
                wire.truncate(n);
                wire
            },
            expect: v.expect.map(str::to_string),
            malformed: v.error == Some("malformed"),
        })
        .collect()
}

/// A reply in the vector file's `expect` words.
fn words(r: &Reply) -> String {
    match r {
        Reply::Ack => "ack".into(),
        Reply::Nack(c) => format!("nack {c:?}"),
        Reply::Status(s) => format!("status {:?} {:?}", s.state, s.mute_reason),
        Reply::SelfTest(t) => {
            let name = format!("{t:?}");
            format!("self_test {}", name.split([' ', '{']).next().unwrap_or(""))
        }
        other => format!("{other:?}"),
    }
}

/// What this device answers each vector with, given the vectors before it.
fn expected(name: &str) -> Option<Option<Reply>> {
    use NackCode::*;
    let nack = |c| Some(Some(Reply::Nack(c)));
    Some(match name {
        "get_info" => return Some(Some(Reply::Other)), // checked below
        // No rig yet: uploads are refused until one is committed.
        "begin_upload" | "begin_upload_raw" | "begin_upload_table" => return nack(NoRig),
        "begin_rig" | "stop" | "centroid" | "renew" => Some(Reply::Ack),
        // Nothing plays, and the test device has no self-test.
        "self_test" => Some(Reply::SelfTest(lm_proto::SelfTest::Unsupported)),
        "commit_rig" => return nack(Incomplete), // no position has arrived
        "geometry" => return nack(OutOfRange),   // first = 996 of 996
        "chunk" | "chunk_long" | "commit" | "intensity" | "intensity_long" => {
            return nack(NoUpload);
        }
        "play_next_cycle" | "play_immediate" | "play_steps" => return nack(NotCommitted),
        "centroid_absent" => return nack(OutOfOrder), // seq u32::MAX is older than 42 (wrapping)
        "get_status" => return Some(Some(Reply::Other)), // checked below
        "info"
        | "info_no_rig"
        | "status"
        | "status_idle"
        | "status_muted"
        | "status_lease_expired"
        | "self_test_unsupported"
        | "self_test_passed"
        | "self_test_failed"
        | "ack"
        | "nack"
        | "nack_library_full"
        | "nack_no_rig"
        | "nack_rig_mismatch"
        | "nack_unknown_code" => {
            return nack(UnknownType);
        }
        "err_unknown_type" => return nack(UnknownType),
        "err_bad_version" => return nack(BadVersion),
        n if n.starts_with("err_malformed") => return nack(Malformed),
        "err_crc" | "err_cobs" | "err_too_short" => None,
        _ => return None,
    })
}

#[test]
fn every_vector_gets_the_right_response() {
    // The file's device: defaults (tracking required), 996 transducers.
    let mut cfg = config(996);
    cfg.require_tracking = true;
    let mut dev = device(cfg, 200 * 996);
    let vs = vectors();
    assert!(vs.len() >= 60, "parsed {} vectors", vs.len());
    let mut checked = 0;
    let mut behaviours = 0;
    let mut nacks = 0;
    for v in &vs {
        let replies = feed_heads(&mut dev, &v.wire, 0);
        // A reply answers this frame: its seq, type byte and CRC.
        if let Some((head, _)) = replies.first() {
            let want = match lm_proto::FrameDecoder::new().feed(&v.wire) {
                lm_proto::FeedResult::Frame { frame, .. } => Some(frame.reply_head()),
                lm_proto::FeedResult::Error { error, .. } => error.nack().map(|(h, _)| h),
                lm_proto::FeedResult::Consumed => None,
            };
            assert_eq!(Some(*head), want, "{}: the reply's echo", v.name);
        }
        let replies: Vec<_> = replies.into_iter().map(|(h, r)| (h.seq, r)).collect();
        if let Some(want) = &v.expect {
            assert_eq!(replies.len(), 1, "{}", v.name);
            assert_eq!(&words(&replies[0].1), want, "{}", v.name);
            nacks += u32::from(matches!(replies[0].1, Reply::Nack(_)));
            behaviours += 1;
            continue;
        }
        let Some(want) = expected(&v.name) else {
            // A vector newer than this test: it must still not get more than one reply.
            assert!(replies.len() <= 1, "{}: {replies:?}", v.name);
            continue;
        };
        checked += 1;
        match want {
            None => assert!(replies.is_empty(), "{}: {replies:?}", v.name),
            Some(w) => {
                assert_eq!(replies.len(), 1, "{}", v.name);
                let got = &replies[0].1;
                match (v.name.as_str(), got) {
                    ("get_info", Reply::Info(i)) => assert_eq!(i.max_transducers, 996),
                    ("get_status", Reply::Status(s)) => {
                        assert_eq!(s.state, DeviceState::Idle);
                        assert_eq!(s.last_centroid_seq, 42);
                        assert_eq!(s.nacks, nacks);
                    }
                    _ => assert_eq!(got, &w, "{}", v.name),
                }
                if matches!(got, Reply::Nack(_)) {
                    nacks += 1;
                }
            }
        }
    }
    assert!(checked >= 29);
    assert!(behaviours >= 25, "{behaviours} behaviour records");
    let c = dev.counters();
    assert_eq!(c.crc_errors, 1);
    // cobs, too_short, plus the valid-CRC unknown/version/malformed frames.
    let malformed = vs.iter().filter(|v| v.malformed).count() as u32;
    assert!(malformed >= 7);
    assert_eq!(c.bad_frames, 2 + 1 + 1 + malformed);
    assert_eq!(c.nacks, nacks);
}
