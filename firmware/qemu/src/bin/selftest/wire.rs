//! The wire code on target: the proto crate's byte vectors, and frames fed
//! byte by byte through the device.

use lm_fw_qemu::{ARRAY_TRANSDUCERS, FrameCounter, PCLK_HZ, hprintln};
use lm_proto::{FeedResult, FrameDecoder, MAX_ENCODED_FRAME, Message, encode_frame, vectors};

use crate::support::*;
use crate::{Ctx, Failed, TestResult};

pub fn proto_vectors_on_target(_: &mut Ctx, _: &mut [u8]) -> TestResult {
    let mut wire = [0u8; 2 * MAX_ENCODED_FRAME];
    let mut again = [0u8; MAX_ENCODED_FRAME];
    let mut count = 0;
    for v in vectors::parse(lm_proto::TEST_VECTORS) {
        if let Err(m) = vectors::replay(&v, &mut wire, &mut again, |_| {}) {
            hprintln!("    vector {}: {}", v.name, m);
            return Err(Failed);
        }
        count += 1;
    }
    check!(count >= 10, "only {} vectors found", count);
    Ok(())
}

pub fn frames_through_feed(c: &mut Ctx, mem: &mut [u8]) -> TestResult {
    // The byte path the firmware uses: encoded requests in, encoded replies out.
    let mut dev = device(mem);
    let mut wire = [0u8; MAX_ENCODED_FRAME];
    let mut reply = [0u8; MAX_ENCODED_FRAME];
    let mut reply_len = 0;
    let mut out = FrameCounter::default();
    let n = encode_frame(42, &Message::GetInfo, &mut wire).map_err(|_| Failed)?;
    // Garbage first, then the request split in two pieces.
    dev.feed(&[0x13, 0x37, 0x00], c.now(), &mut out, &mut |_| {});
    let now = c.now();
    dev.feed(&wire[..3], now, &mut out, &mut |r| {
        reply_len = r.len();
        reply[..r.len()].copy_from_slice(r);
    });
    check!(reply_len == 0, "replied to half a frame");
    dev.feed(&wire[3..n], now, &mut out, &mut |r| {
        reply_len = r.len();
        reply[..r.len()].copy_from_slice(r);
    });
    let mut dec = FrameDecoder::new();
    match dec.feed(&reply[..reply_len]) {
        FeedResult::Frame { frame, .. } => {
            check!(frame.seq == 42, "reply seq {}", frame.seq);
            let Message::Info(info) = frame.message else {
                hprintln!("    reply {:?}", frame.message);
                return Err(Failed);
            };
            check!(info.max_transducers == ARRAY_TRANSDUCERS, "{:?}", info);
            check!(info.timer_hz == PCLK_HZ, "{:?}", info);
            check!(
                info.slots >= 2 && info.slot_bytes >= 200 * 996,
                "{:?}",
                info
            );
        }
        _ => check!(false, "no Info reply frame"),
    }
    check!(
        dev.counters().bad_frames == 1,
        "bad frames {}",
        dev.counters().bad_frames
    );
    Ok(())
}
