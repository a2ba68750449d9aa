//! The proto crate's exact-byte vectors, fed in file order to one device,
//! each get the response this firmware must give.

mod common;

use common::*;
use lm_proto::{DeviceState, NackCode, TEST_VECTORS};

struct Vector {
    name: String,
    wire: Vec<u8>,
}

fn vectors() -> Vec<Vector> {
    let mut out = Vec::new();
    for rec in TEST_VECTORS.split("\n\n") {
        let mut name = None;
        let mut wire = None;
        for line in rec.lines().filter(|l| !l.starts_with('#')) {
            if let Some(v) = line.strip_prefix("name ") {
                name = Some(v.trim().to_string());
            } else if let Some(v) = line.strip_prefix("wire ") {
                wire = Some(
                    v.split_whitespace()
                        .map(|h| u8::from_str_radix(h, 16).unwrap())
                        .collect(),
                );
            }
        }
        if let (Some(name), Some(wire)) = (name, wire) {
            out.push(Vector { name, wire });
        }
    }
    out
}

/// What this device answers each vector with, given the vectors before it.
fn expected(name: &str) -> Option<Option<Reply>> {
    use NackCode::*;
    let nack = |c| Some(Some(Reply::Nack(c)));
    Some(match name {
        "get_info" => return Some(Some(Reply::Other)), // checked below
        "begin_upload" | "begin_upload_raw" | "stop" | "centroid" => Some(Reply::Ack),
        "geometry" => return nack(OutOfRange), // first = 996 of 996
        "geometry_empty" => return nack(BadSlot),
        "chunk" => return nack(OutOfOrder), // offset 1024, nothing received yet
        "chunk_long" => return nack(OutOfRange), // 300 bytes into encoded_len 1
        "chunk_empty" => return nack(OutOfRange), // offset u32::MAX
        "commit" => return nack(Incomplete),
        "play_next_cycle" | "play_immediate" => return nack(NotCommitted),
        "centroid_absent" => return nack(OutOfOrder), // seq u32::MAX is older than 42 (wrapping)
        "get_status" => return Some(Some(Reply::Other)), // checked below
        "info" | "status" | "status_idle" | "ack" | "nack" | "nack_unknown_code" => {
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
    let mut dev = device(config(996), 200 * 996);
    let vs = vectors();
    assert!(vs.len() >= 29, "parsed {} vectors", vs.len());
    let mut checked = 0;
    let mut nacks = 0;
    for v in &vs {
        let replies = feed(&mut dev, &v.wire, 0);
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
    let c = dev.counters();
    assert_eq!(c.crc_errors, 1);
    // cobs, too_short, plus the valid-CRC unknown/version/malformed frames.
    assert_eq!(c.bad_frames, 2 + 1 + 1 + 4);
    assert_eq!(c.nacks, nacks);
}
