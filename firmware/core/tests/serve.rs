//! The shared board main loop against a scripted host link.

mod common;

use common::*;
use lm_fw_core::serve::RX_CHUNK;
use lm_fw_core::{HostLink, Server};
use lm_proto::{FeedResult, FrameDecoder, MAX_ENCODED_FRAME, Message, encode_frame};

/// Input waiting to be read, replies written, flushes seen.
#[derive(Default)]
struct Script {
    input: Vec<u8>,
    out: Vec<u8>,
    flushes: usize,
}

impl HostLink for Script {
    fn receive(&mut self, buf: &mut [u8]) -> usize {
        let n = buf.len().min(self.input.len());
        buf[..n].copy_from_slice(&self.input[..n]);
        self.input.drain(..n);
        n
    }
    fn send(&mut self, bytes: &[u8]) {
        self.out.extend_from_slice(bytes);
    }
    fn flush(&mut self) {
        self.flushes += 1;
    }
}

/// Sequence numbers of the frames in `bytes`.
fn reply_seqs(bytes: &[u8]) -> Vec<u16> {
    let mut dec = FrameDecoder::new();
    let mut seqs = Vec::new();
    let mut input = bytes;
    while let FeedResult::Frame { frame, remaining } = dec.feed(input) {
        seqs.push(frame.seq);
        input = remaining;
    }
    seqs
}

#[test]
fn a_pass_answers_what_arrived_and_flushes() {
    let mut dev = device(config(40), 20 * 40);
    let mut link = Script::default();
    let mut counts = 0u32;
    let mut count = || {
        counts += 1;
        counts
    };
    let mut server = Server::new();
    let mut cap = Capture::default();
    server.pass(&mut link, &mut count, &mut dev, &mut cap);
    assert!(link.out.is_empty());
    assert_eq!(link.flushes, 1);

    let mut wire = [0u8; MAX_ENCODED_FRAME];
    let n = encode_frame(9, &Message::GetInfo, &mut wire).unwrap();
    link.input.extend_from_slice(&wire[..n]);
    server.pass(&mut link, &mut count, &mut dev, &mut cap);
    assert_eq!(reply_seqs(&link.out), [9]);
    assert_eq!(link.flushes, 2);
    assert_eq!(counts, 2, "one counter read per pass");
}

#[test]
fn a_burst_is_taken_a_chunk_per_pass() {
    let mut dev = device(config(40), 20 * 40);
    let mut link = Script::default();
    let mut wire = [0u8; MAX_ENCODED_FRAME];
    for seq in 0..10 {
        let n = encode_frame(seq, &Message::GetStatus, &mut wire).unwrap();
        link.input.extend_from_slice(&wire[..n]);
    }
    let total = link.input.len();
    assert!(total > RX_CHUNK);
    let mut server = Server::new();
    let mut cap = Capture::default();
    server.pass(&mut link, &mut || 0, &mut dev, &mut cap);
    assert_eq!(link.input.len(), total - RX_CHUNK);
    let first = reply_seqs(&link.out).len();
    assert!(first > 0 && first < 10, "{first} replies after one pass");
    for _ in 0..total.div_ceil(RX_CHUNK) {
        server.pass(&mut link, &mut || 0, &mut dev, &mut cap);
    }
    assert_eq!(reply_seqs(&link.out), (0..10).collect::<Vec<u16>>());
}
