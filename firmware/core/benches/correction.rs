//! Host cost of the centroid correction (996 transducers): the update
//! (offsets from a new centroid) and the per-step byte-add loop, plus a
//! whole `Device::poll` step with correction applied.
//!
//! `cargo bench -p lm-fw-core --bench correction`

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use lm_fw_core::correction::{apply_offsets, compute_offsets};
use lm_fw_core::{Config, Device, OutputDriver, OutputFrame, memory_bytes};
use lm_proto::codec::Encoding;
use lm_proto::{
    BeginRig, BeginUpload, Centroid, Chunk, Commit, Geometry, MAX_CHUNK, MAX_GEOMETRY_POSITIONS,
    Message, Play, PlayAt, Positions, UploadHeader,
};

const T: usize = 996;

fn positions() -> Vec<[i32; 3]> {
    (0..T)
        .map(|j| [(j % 36) as i32 * 10_160, (j / 36) as i32 * 10_160, 0])
        .collect()
}

struct Sink;
impl OutputDriver for Sink {
    type Error = ();
    fn write_frame(&mut self, f: &OutputFrame<'_>) -> Result<(), ()> {
        black_box(f.phases);
        Ok(())
    }
}

fn bench(c: &mut Criterion) {
    let pts = positions();
    let pos: Vec<u8> = pts
        .iter()
        .flat_map(|p| p.iter().flat_map(|v| v.to_le_bytes()))
        .collect();
    let c0 = [177_800, 132_080, 200_000];
    let mut offsets = vec![0u8; T];
    c.bench_function("correction update (996 offsets)", |b| {
        let mut i = 0;
        b.iter(|| {
            i += 1;
            let cc = [c0[0] + 3_000 + (i % 7), c0[1] - 2_000, c0[2] + 1_000];
            compute_offsets(black_box(&pos), c0, cc, 340.0, &mut offsets);
        })
    });
    let phases: Vec<u8> = (0..T).map(|i| (i * 7) as u8).collect();
    let mut out = vec![0u8; T];
    c.bench_function("apply offsets (996 bytes)", |b| {
        b.iter(|| apply_offsets(black_box(&phases), black_box(&offsets), &mut out))
    });

    // A whole step through the device: schedule, gate, correction, driver.
    let steps = 200u16;
    let mem = Box::leak(vec![0u8; memory_bytes(usize::from(steps) * T, T)].into_boxed_slice());
    let mut dev = Device::new(Config::new(1_000_000), mem).unwrap();
    let raw: Vec<u8> = (0..usize::from(steps) * T).map(|i| (i * 3) as u8).collect();
    let rig = lm_proto::rig_crc32(&Positions::from_points(&pts));
    let begin_rig = Message::BeginRig(BeginRig {
        transducers: T as u16,
        crc32: rig,
    });
    assert_eq!(dev.handle(&begin_rig, 0), Message::Ack);
    for (i, ps) in pts.chunks(MAX_GEOMETRY_POSITIONS).enumerate() {
        let g = Message::Geometry(Geometry {
            first: (i * MAX_GEOMETRY_POSITIONS) as u16,
            positions: Positions::from_points(ps),
        });
        assert_eq!(dev.handle(&g, 0), Message::Ack);
    }
    assert_eq!(dev.handle(&Message::CommitRig, 0), Message::Ack);
    let begin = Message::BeginUpload(BeginUpload {
        slot: 0,
        header: UploadHeader {
            steps,
            transducers: T as u16,
            period_us: 200_000,
            center_um: c0,
            foci_per_step: 1,
            sound_speed_mm_s: 340_000,
            max_offset_um: 20_000,
            intensity: 255,
        },
        encoding: Encoding::Raw,
        encoded_len: raw.len() as u32,
        rig_crc32: rig,
        intensity_table: false,
    });
    assert_eq!(dev.handle(&begin, 0), Message::Ack);
    for (i, d) in raw.chunks(MAX_CHUNK).enumerate() {
        let m = Message::Chunk(Chunk {
            slot: 0,
            offset: (i * MAX_CHUNK) as u32,
            data: d,
        });
        assert_eq!(dev.handle(&m, 0), Message::Ack);
    }
    let commit = Message::Commit(Commit {
        slot: 0,
        crc32: lm_proto::crc32(&raw),
    });
    assert_eq!(dev.handle(&commit, 0), Message::Ack);
    assert_eq!(
        dev.handle(
            &Message::Play(Play {
                slot: 0,
                at: PlayAt::Immediate,
                untracked: false,
                steps: 0,
                lease_ms: *lm_proto::LEASE_MS.end(),
            }),
            0
        ),
        Message::Ack
    );
    let centroid = Message::Centroid(Centroid {
        seq: 1,
        pos_um: [c0[0] + 3_000, c0[1], c0[2]],
        present: true,
        host_time_us: 0,
    });
    assert_eq!(dev.handle(&centroid, 0), Message::Ack);
    dev.set_centroid_timeout_us(u32::MAX);
    let mut now = dev.poll(0, &mut Sink).unwrap();
    // The host renews its lease now and then, as a host does (timer counts).
    let renew_every = u64::from(dev.config().timer_hz) * 10;
    let mut renewed = 0;
    c.bench_function("Device::poll step (996, corrected)", |b| {
        b.iter(|| {
            if now - renewed >= renew_every {
                dev.handle(&Message::Renew, now);
                renewed = now;
            }
            now = dev.poll(now, &mut Sink).unwrap();
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
