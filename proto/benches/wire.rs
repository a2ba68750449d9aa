//! Throughput of the wire hot paths: frame encode, streaming decode, CRC,
//! and the sequence codec on a paper-sized sequence (996 transducers ×
//! 164 steps, smooth phases).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use lm_proto::codec::{self, Decoder};
use lm_proto::*;
use std::hint::black_box;

fn smooth_sequence(steps: usize, t: usize) -> Vec<u8> {
    // Each transducer's phase advances by a fixed per-transducer rate that
    // drifts slowly: the shape LM sequences have.
    (0..steps * t)
        .map(|i| {
            let (s, k) = ((i / t) as f64, (i % t) as f64);
            let rate = 5.0 * ((k * 0.37).sin());
            (k * 11.0 + s * rate + 2.0 * (s * 0.05 + k).sin())
                .round()
                .rem_euclid(256.0) as u8
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let data: Vec<u8> = (0..MAX_CHUNK).map(|i| (i * 31 % 256) as u8).collect();
    let msg = Message::Chunk(Chunk {
        slot: 0,
        offset: 0,
        data: &data,
    });
    let mut wire = vec![0u8; MAX_ENCODED_FRAME];
    let n = encode_frame(1, &msg, &mut wire).unwrap();

    let mut g = c.benchmark_group("frame");
    g.throughput(Throughput::Bytes(n as u64));
    g.bench_function("encode_frame chunk 1024", |b| {
        b.iter(|| encode_frame(black_box(1), black_box(&msg), &mut wire).unwrap())
    });
    let frame = wire[..n].to_vec();
    let mut dec = FrameDecoder::new();
    g.bench_function("FrameDecoder::feed chunk 1024", |b| {
        b.iter(|| match dec.feed(black_box(&frame)) {
            FeedResult::Frame { frame, .. } => frame.seq,
            _ => unreachable!(),
        })
    });
    g.bench_function("FrameDecoder::push chunk 1024", |b| {
        b.iter(|| {
            let mut seq = 0;
            for &byte in black_box(&frame) {
                if let Some(Ok(f)) = dec.push(byte) {
                    seq = f.seq;
                }
            }
            seq
        })
    });
    g.bench_function("crc32 1024", |b| b.iter(|| crc32(black_box(&data))));
    g.finish();

    let (steps, t) = (164, 996);
    let phases = smooth_sequence(steps, t);
    let len = codec::encoded_len(Encoding::Delta, &phases, t).unwrap();
    let mut enc = vec![0u8; len];
    let mut out = vec![0u8; phases.len()];
    let mut g = c.benchmark_group("codec");
    g.throughput(Throughput::Bytes(phases.len() as u64));
    g.bench_function("delta encode 164x996", |b| {
        b.iter(|| codec::encode(Encoding::Delta, black_box(&phases), t, &mut enc).unwrap())
    });
    codec::encode(Encoding::Delta, &phases, t, &mut enc).unwrap();
    g.bench_function("delta decode 164x996 in 1024-byte chunks", |b| {
        b.iter(|| {
            let mut d = Decoder::new(Encoding::Delta, steps as u16, t as u16);
            for piece in enc.chunks(MAX_CHUNK) {
                d.feed(black_box(piece), &mut out).unwrap();
            }
            d.finish().unwrap()
        })
    });
    g.finish();
    eprintln!("bench sequence: delta {len} / raw {} bytes", phases.len());
}

criterion_group!(benches, bench);
criterion_main!(benches);
