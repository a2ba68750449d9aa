//! The firmware under QEMU, driven over its UART with the real protocol:
//! info, upload (BeginUpload, Geometry, Chunks), commit, play, centroid,
//! status, stop; and the paper's stimulus library resident. lmhost's
//! device layer against it (conformance, timed play, session) is
//! `qemu_device.rs`.
//!
//! QEMU runs `mps2-an500` with UART0 on a TCP socket on 127.0.0.1 and
//! `-icount shift=0`, so the player's timer runs on the guest's own
//! instruction count and the test can demand zero missed deadlines. The
//! firmware ELF comes from `LM_FW_QEMU_ELF` (set by `cargo xtask ci`, which
//! builds it first); without it the test builds it with
//! `cargo build --release -p lm-fw-qemu --target thumbv7em-none-eabihf` into
//! its own target dir. Skipped, with a message, when `qemu-system-arm` is
//! not installed (`cargo xtask ci` installs it).

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use lmhost::device::backend::Backend;

use lm_proto::{
    BeginRig, BeginUpload, Centroid, Chunk, Commit, DeviceState, Encoding, FeedResult,
    FrameDecoder, Geometry, MAX_CHUNK, MAX_ENCODED_FRAME, MAX_GEOMETRY_POSITIONS, Message,
    NackCode, PROTOCOL_VERSION, Play, PlayAt, Positions, Status, UploadHeader, codec, crc32,
    encode_frame, rig_crc32,
};

mod link_support;
mod qemu_support;
use qemu_support::{Qemu, firmware_or_skip, serving_or_skip, wait_on_device, within_20_s};

/// Speed of sound the test sequences are planned and uploaded with, mm/s.
const SOUND_SPEED_MM_S: u32 = 340_000;

/// Request/response over the socket, matched by sequence number and the
/// reply's echo of the request.
struct Link {
    sock: TcpStream,
    dec: FrameDecoder,
    pending: Vec<u8>,
    seq: u16,
    /// What the reply to the request in flight must echo.
    echo: Option<lm_proto::Echo>,
}

/// A response, owned (chunk-free messages only come back).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Reply {
    Ack,
    Nack(NackCode),
    Info(lm_proto::Info),
    Status(Status),
}

impl Link {
    fn new(sock: TcpStream) -> Link {
        sock.set_read_timeout(Some(Duration::from_millis(100)))
            .unwrap();
        Link {
            sock,
            dec: FrameDecoder::new(),
            pending: Vec::new(),
            seq: 0,
            echo: None,
        }
    }

    fn request(&mut self, msg: &Message<'_>) -> Reply {
        self.seq = self.seq.wrapping_add(1);
        let mut buf = [0u8; MAX_ENCODED_FRAME];
        let n = encode_frame(self.seq, msg, &mut buf).unwrap();
        self.echo = Some(lm_proto::Echo::of_request(self.seq, msg).unwrap());
        self.sock.write_all(&buf[..n]).unwrap();
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            if let Some(r) = self.next_reply() {
                return r;
            }
            assert!(
                Instant::now() < deadline,
                "no reply to {:?} (seq {}) within 10 s",
                msg.msg_type(),
                self.seq
            );
            let mut chunk = [0u8; 4096];
            match self.sock.read(&mut chunk) {
                Ok(0) => panic!("QEMU closed the UART socket"),
                Ok(n) => self.pending.extend_from_slice(&chunk[..n]),
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) => {}
                Err(e) => panic!("reading the UART socket: {e}"),
            }
        }
    }

    /// The reply to the current request from the bytes read so far, if any;
    /// anything else (replies to other seqs, bad frames) is a test failure.
    fn next_reply(&mut self) -> Option<Reply> {
        let mut input: &[u8] = &self.pending;
        let mut found = None;
        while found.is_none() {
            input = match self.dec.feed(input) {
                FeedResult::Consumed => {
                    input = &[];
                    break;
                }
                FeedResult::Frame { frame, remaining } => {
                    assert_eq!(frame.seq, self.seq, "reply to another request: {frame:?}");
                    assert_eq!(frame.echo, self.echo, "reply echoes another request");
                    found = Some(match frame.message {
                        Message::Ack => Reply::Ack,
                        Message::Nack(c) => Reply::Nack(c),
                        Message::Info(i) => Reply::Info(i),
                        Message::Status(s) => Reply::Status(s),
                        other => panic!("unexpected message from the device: {other:?}"),
                    });
                    remaining
                }
                FeedResult::Error { error, .. } => panic!("bad frame from the device: {error:?}"),
            };
        }
        self.pending = input.to_vec();
        found
    }

    fn ack(&mut self, msg: &Message<'_>) {
        let r = self.request(msg);
        assert_eq!(r, Reply::Ack, "{:?} was not acked", msg.msg_type());
    }

    /// Begins an upload of `stream` (in `encoding`) into `slot` and sends
    /// it in chunks, each acked; the commit is the caller's.
    fn send_stream(
        &mut self,
        slot: u8,
        header: UploadHeader,
        encoding: Encoding,
        stream: &[u8],
        rig_crc32: u32,
    ) {
        self.ack(&Message::BeginUpload(BeginUpload {
            slot,
            header,
            encoding,
            encoded_len: stream.len() as u32,
            rig_crc32,
            intensity_table: false,
        }));
        for (i, data) in stream.chunks(MAX_CHUNK).enumerate() {
            self.ack(&Message::Chunk(Chunk {
                slot,
                offset: (i * MAX_CHUNK) as u32,
                data,
            }));
        }
    }

    fn status(&mut self) -> Status {
        match self.request(&Message::GetStatus) {
            Reply::Status(s) => s,
            r => panic!("GetStatus answered {r:?}"),
        }
    }
}

/// A 36 × 28 grid (10.16 mm pitch, AUTD3's) cut to `t` transducers, in µm.
fn positions_um(t: usize) -> Vec<[i32; 3]> {
    (0..t)
        .map(|i| {
            let (x, y) = ((i % 36) as f64, (i / 36) as f64);
            [
                ((x - 17.5) * 10_160.0) as i32,
                ((y - 13.5) * 10_160.0) as i32,
                0,
            ]
        })
        .collect()
}

/// One focus 150 mm above the array moving on a 4 mm circle: φ = −k r.
fn lm_phases(pos: &[[i32; 3]], steps: usize) -> Vec<u8> {
    let k = 2.0 * std::f64::consts::PI * 40_000.0 / (f64::from(SOUND_SPEED_MM_S) * 1e3); // rad per µm
    let mut out = Vec::with_capacity(steps * pos.len());
    for s in 0..steps {
        let a = 2.0 * std::f64::consts::PI * s as f64 / steps as f64;
        let f = [2000.0 * a.cos(), 2000.0 * a.sin(), 150_000.0];
        for p in pos {
            let r = ((p[0] as f64 - f[0]).powi(2)
                + (p[1] as f64 - f[1]).powi(2)
                + (p[2] as f64 - f[2]).powi(2))
            .sqrt();
            let phi = (-k * r).rem_euclid(2.0 * std::f64::consts::PI);
            out.push(((phi / (2.0 * std::f64::consts::PI) * 256.0).round() as u32 % 256) as u8);
        }
    }
    out
}

fn centroid(seq: u32, pos_um: [i32; 3], present: bool, t0: Instant) -> Message<'static> {
    Message::Centroid(Centroid {
        seq,
        pos_um,
        present,
        host_time_us: t0.elapsed().as_micros() as u64,
    })
}

#[test]
fn firmware_under_qemu_speaks_the_protocol() {
    let Some(elf) = firmware_or_skip() else {
        return;
    };
    let (_qemu, sock) = Qemu::start(&elf);
    let mut link = Link::new(sock);
    let t0 = Instant::now();

    // Info.
    let Reply::Info(info) = link.request(&Message::GetInfo) else {
        panic!("GetInfo not answered with Info")
    };
    assert_eq!(info.proto_version, PROTOCOL_VERSION);
    assert_eq!(info.clock, lm_proto::ClockSource::Emulated);
    assert!(info.slots >= 32, "{info:?}");
    assert_eq!((info.rig_transducers, info.rig_crc32), (0, 0), "{info:?}");
    assert!(info.max_transducers >= 996, "{info:?}");
    assert!(info.slot_bytes >= 200 * 996, "{info:?}");
    assert_eq!(info.max_chunk as usize, MAX_CHUNK);
    assert!(info.timer_hz >= 1_000_000, "{info:?}");

    // Upload: 996 transducers × 40 steps, Delta-encoded, 5 Hz cycle.
    let t = 996usize;
    let steps = 40usize;
    // 1 ms dwell (the minimum): short cycles, so several pass quickly even
    // though QEMU's virtual clock runs slower than the wall clock.
    let period_us = 40_000u32;
    let center_um = [0, 0, 150_000];
    let pos = positions_um(t);
    let raw = lm_phases(&pos, steps);
    let mut enc = vec![0u8; codec::encoded_len(Encoding::Delta, &raw, t).unwrap()];
    let n = codec::encode(Encoding::Delta, &raw, t, &mut enc).unwrap();
    assert_eq!(n, enc.len());
    assert!(n < raw.len(), "Delta should compress a smooth LM sequence");

    // Play before any upload is refused.
    assert!(matches!(
        link.request(&Message::Play(Play {
            slot: 0,
            at: PlayAt::Immediate,
            untracked: false,
            steps: 0,
            lease_ms: lm_proto::DEFAULT_LEASE_MS,
        })),
        Reply::Nack(_)
    ));

    // The rig first, once: the positions every entry is planned for.
    let rig = rig_crc32(&Positions::from_points(&pos));
    link.ack(&Message::BeginRig(BeginRig {
        transducers: t as u16,
        crc32: rig,
    }));
    for (i, group) in pos.chunks(MAX_GEOMETRY_POSITIONS).enumerate() {
        link.ack(&Message::Geometry(Geometry {
            first: (i * MAX_GEOMETRY_POSITIONS) as u16,
            positions: Positions::from_points(group),
        }));
    }
    link.ack(&Message::CommitRig);
    let header = |steps: u16| UploadHeader {
        steps,
        transducers: t as u16,
        period_us,
        center_um,
        foci_per_step: 1,
        sound_speed_mm_s: SOUND_SPEED_MM_S,
        max_offset_um: 20_000,
        intensity: 255,
    };
    link.send_stream(0, header(steps as u16), Encoding::Delta, &enc, rig);
    link.ack(&Message::Commit(Commit {
        slot: 0,
        crc32: crc32(&raw),
    }));

    // A corrupt upload (wrong CRC) into the other slot is refused and never playable.
    let small: Vec<u8> = (0..2 * t).map(|i| (i * 7) as u8).collect();
    link.send_stream(1, header(2), Encoding::Raw, &small, rig);
    assert_eq!(
        link.request(&Message::Commit(Commit {
            slot: 1,
            crc32: crc32(&small) ^ 1
        })),
        Reply::Nack(NackCode::CrcMismatch)
    );
    assert_eq!(
        link.request(&Message::Play(Play {
            slot: 1,
            at: PlayAt::Immediate,
            untracked: false,
            steps: 0,
            lease_ms: lm_proto::DEFAULT_LEASE_MS,
        })),
        Reply::Nack(NackCode::NotCommitted)
    );

    // Play with a fresh centroid; status shows steps advancing and cycles counted.
    // (A new play session forgets old centroids: tracking starts after Play;
    // until the first update the output stays muted.)
    link.ack(&Message::Play(Play {
        slot: 0,
        at: PlayAt::Immediate,
        untracked: false,
        steps: 0,
        lease_ms: lm_proto::DEFAULT_LEASE_MS,
    }));
    assert_eq!(link.status().state, DeviceState::Muted);
    let mut cseq = 1;
    link.ack(&centroid(cseq, center_um, true, t0));
    let first = link.status();
    assert_eq!(first.state, DeviceState::Playing, "{first:?}");
    assert_eq!(first.slot, Some(0));
    let mut steps_seen = std::collections::BTreeSet::new();
    let until = Instant::now() + Duration::from_secs(60);
    let moved = [1500, -1000, 150_000];
    let mut last = first;
    // Sample until 3 cycles passed and the samples caught 5 different steps
    // (how many samples a cycle gets depends on the host's load).
    while last.cycles < first.cycles + 3 || steps_seen.len() < 5 {
        assert!(
            Instant::now() < until,
            "3 cycles and 5 steps not seen in 60 s: {first:?} -> {last:?}, steps {steps_seen:?}"
        );
        cseq += 1;
        link.ack(&centroid(cseq, moved, true, t0));
        let s = link.status();
        // Playing, or Muted if this host was too slow to keep the 100 ms
        // centroid timeout (checked strictly below, back to back).
        assert!(
            matches!(s.state, DeviceState::Playing | DeviceState::Muted),
            "{s:?}"
        );
        assert_eq!(s.slot, Some(0));
        steps_seen.insert(s.step);
        last = s;
        std::thread::sleep(Duration::from_millis(5));
    }
    cseq += 1;
    link.ack(&centroid(cseq, moved, true, t0));
    let last = link.status();
    assert_eq!(
        last.state,
        DeviceState::Playing,
        "a fresh centroid resumes: {last:?}"
    );
    assert_eq!(last.missed_deadlines, 0, "{last:?}");
    assert_eq!(last.last_centroid_seq, cseq);
    assert_eq!(last.correction_um, [1500, -1000, 0], "{last:?}");
    assert_eq!(last.crc_errors, 0);
    assert_eq!(last.bad_frames, 0);
    println!(
        "QEMU: {} cycles, {} distinct steps seen, {} missed deadlines, {} nacks",
        last.cycles,
        steps_seen.len(),
        last.missed_deadlines,
        last.nacks
    );

    // Presence lost mutes; a fresh update resumes; Stop stops.
    cseq += 1;
    link.ack(&centroid(cseq, moved, false, t0));
    assert_eq!(link.status().state, DeviceState::Muted);
    cseq += 1;
    link.ack(&centroid(cseq, moved, true, t0));
    assert_eq!(link.status().state, DeviceState::Playing);
    link.ack(&Message::Stop);
    assert_eq!(link.status().state, DeviceState::Stopped);
}

/// The paper's 15 stimuli (SPEC: LM-S and LM-M at 5 Hz with 0.23 mm steps,
/// LM-S at 25 Hz with 4 mm steps, radii 2-6 mm), planned on the default
/// scene (996 transducers), with a name each.
fn paper_set() -> Vec<(String, lmhost::plan::sequence::Plan)> {
    use lmhost::plan::scene::Scene;
    use lmhost::plan::stimulus::Stimulus;
    use lmhost::plan::target::Target;
    use lmhost::plan::trajectory::{Cycle, Steps};
    let mut v = Vec::new();
    for (foci, freq_hz, step_mm) in [(1, 5.0, 0.23), (4, 5.0, 0.23), (1, 25.0, 4.0)] {
        for radius_mm in [2.0, 3.0, 4.0, 5.0, 6.0] {
            let s = Stimulus::of(Cycle {
                radius_mm,
                foci,
                freq_hz,
                steps: Steps::Width(step_mm),
                ..Cycle::default()
            });
            let plan = s.plan_for(&Target::Lm, Scene::default()).unwrap().plan;
            let name = format!(
                "LM-{} {freq_hz} Hz A={radius_mm} mm",
                if foci == 1 { "S" } else { "M" }
            );
            v.push((name, plan));
        }
    }
    v
}

/// Frame bytes (delimiters included) of preloading `set` into slots 0..
/// over a clean link: the rig once, then per stimulus `BeginUpload`,
/// 1024-byte chunks and `Commit` (Delta, or Raw where Delta is larger, as
/// the client sends them); and the acks coming back.
fn preload_frame_bytes(set: &[(String, lmhost::plan::sequence::Plan)]) -> (u64, u64) {
    use lm_proto::encoded_frame_len;
    use lmhost::device::link::UploadSpec;
    let len = |m: &Message<'_>| encoded_frame_len(1, m).unwrap() as u64;
    // An ack's echo: a request's type and a CRC (without zero bytes, as
    // most are: COBS adds nothing for them).
    let echo = lm_proto::Echo {
        request_type: 0x04,
        request_crc32: 0x9E37_79B9,
    };
    let ack = encoded_frame_len(lm_proto::Head::reply(1, echo), &Message::Ack).unwrap() as u64;
    let (mut sent, mut acks) = (0, 0);
    for (slot, (_, plan)) in set.iter().enumerate() {
        let spec = UploadSpec::from_plan(plan, Encoding::Delta).unwrap();
        if slot == 0 {
            sent += len(&Message::BeginRig(BeginRig {
                transducers: spec.header.transducers,
                crc32: spec.rig_crc32,
            }));
            for (i, g) in spec.positions_um.chunks(MAX_GEOMETRY_POSITIONS).enumerate() {
                sent += len(&Message::Geometry(Geometry {
                    first: (i * MAX_GEOMETRY_POSITIONS) as u16,
                    positions: Positions::from_points(g),
                }));
                acks += 1;
            }
            sent += len(&Message::CommitRig);
            acks += 2;
        }
        sent += len(&Message::BeginUpload(spec.begin(slot as u8)));
        for (i, data) in spec.encoded.chunks(MAX_CHUNK).enumerate() {
            sent += len(&Message::Chunk(Chunk {
                slot: slot as u8,
                offset: (i * MAX_CHUNK) as u32,
                data,
            }));
            acks += 1;
        }
        sent += len(&Message::Commit(Commit {
            slot: slot as u8,
            crc32: spec.crc32,
        }));
        acks += 2;
    }
    (sent, acks * ack)
}

/// The paper's set resident on the firmware under QEMU, through the
/// library's LM backend: the rig goes once, every stimulus fits the
/// board's library, each plays at once from silence, a queued one takes
/// over at the cycle boundary, and what does not fit is refused by name.
/// Prints the bytes the preload takes on the wire.
#[test]
fn firmware_under_qemu_holds_the_papers_stimulus_library() {
    use lmhost::device::backend::Transfer;
    use lmhost::device::connect::LmBackend;
    let Some((_qemu, spec)) = serving_or_skip() else {
        return;
    };
    let client =
        within_20_s(|| spec.connect()).unwrap_or_else(|e| panic!("connecting to QEMU: {e}"));
    let mut dev = LmBackend::new(client, Encoding::Delta);
    dev.progress = false;
    let info = dev.info().unwrap();
    assert!(info.slots >= 32, "{info:?}");
    let free_at_start = dev.client.info().unwrap().library_free;

    let set = paper_set();
    assert_eq!(set.len(), 15);
    let (mut raw, mut seq_bytes, mut rig_bytes, mut wire_sent, mut wire_recv) = (0, 0, 0, 0, 0);
    for (slot, (name, plan)) in set.iter().enumerate() {
        let r = dev.upload(plan, Some(slot as u8)).unwrap();
        let Transfer::Wire(w) = r.transfer else {
            panic!("{r:?}")
        };
        assert_eq!(w.slot, slot as u8);
        // The rig goes with the first upload only.
        assert_eq!(w.rig_bytes > 0, slot == 0, "{name}: {w:?}");
        println!(
            "{name:<22} {:>3} steps: raw {:>6} B, on the wire {:>6} B ({} B of frames sent)",
            r.steps, w.raw_bytes, w.sequence_bytes, w.wire_bytes_sent
        );
        raw += w.raw_bytes;
        seq_bytes += w.sequence_bytes;
        rig_bytes += w.rig_bytes;
        wire_sent += w.wire_bytes_sent;
        wire_recv += w.wire_bytes_received;
    }
    let free = dev.client.info().unwrap().library_free;
    let stored = free_at_start - free;
    let total_wire = wire_sent + wire_recv;
    println!(
        "paper library: raw {raw} B; sequences on the wire {seq_bytes} B + rig {rig_bytes} B; \
         stored {stored} B of {free_at_start} ({free} free)"
    );
    println!(
        "preload: {wire_sent} B sent + {wire_recv} B received = {total_wire} B on the wire; \
         at 115200 Bd (10 bits a byte) {:.1} s, at 1 MB/s (USB full speed) {:.2} s",
        total_wire as f64 * 10.0 / 115_200.0,
        total_wire as f64 / 1e6
    );
    assert!(
        u64::from(free) > u64::from(free_at_start) / 5,
        "room to spare"
    );
    let (sent, received) = preload_frame_bytes(&set);
    assert!(sent <= wire_sent, "{sent} > {wire_sent}");
    println!(
        "preload without resends: {sent} B sent + {received} B of acks = {} B; \
         at 115200 Bd {:.1} s, at 1 MB/s {:.2} s",
        sent + received,
        (sent + received) as f64 * 10.0 / 115_200.0,
        (sent + received) as f64 / 1e6
    );

    // Each resident stimulus plays at once from silence with one short Play.
    for (slot, (name, plan)) in set.iter().enumerate() {
        dev.stop().unwrap();
        dev.play(slot as u8, true).unwrap();
        let st = dev.status().unwrap();
        assert_eq!(
            (st.state, st.slot, st.queued_slot),
            (DeviceState::Playing, Some(slot as u8), None),
            "{name}"
        );
        let steps = u64::from(plan.sequence.header.steps);
        wait_on_device(
            &mut dev,
            Duration::from_millis(5),
            steps,
            plan.sequence.dwell_us(),
        )
        .unwrap();
    }

    // While slot 5 (LM-M 5 Hz, A = 2 mm) plays, slot 12 (LM-S 25 Hz,
    // A = 4 mm) queued with NextCycle takes over at the cycle boundary.
    dev.stop().unwrap();
    dev.play(5, true).unwrap();
    let before = dev.status().unwrap();
    dev.play_at(12, PlayAt::NextCycle, true).unwrap();
    let queued = dev.status().unwrap();
    assert_eq!(
        (queued.slot, queued.queued_slot),
        (Some(5), Some(12)),
        "{queued:?}"
    );
    let give_up = Instant::now() + Duration::from_secs(60);
    let mut last = queued;
    while last.slot == Some(5) {
        assert!(Instant::now() < give_up, "no swap: {last:?}");
        // Until the swap, slot 5 plays on through its cycle.
        assert_eq!(last.queued_slot, Some(12), "{last:?}");
        std::thread::sleep(Duration::from_millis(5));
        last = dev.status().unwrap();
    }
    assert_eq!((last.slot, last.queued_slot), (Some(12), None), "{last:?}");
    assert_eq!(last.state, DeviceState::Playing);
    // The swap took no step early and skipped none.
    assert_eq!(last.missed_deadlines, before.missed_deadlines, "{last:?}");

    // What does not fit is refused by name, and nothing changes: a raw
    // LM-M at A = 6 mm (163 kB) into a new slot, with ~100 kB free.
    let big = &set[9].1;
    let mut raw_dev = dev;
    raw_dev.encoding = Encoding::Raw;
    let e = raw_dev.upload(big, Some(20)).unwrap_err();
    assert_eq!(e.refusal(), Some(NackCode::LibraryFull), "{e}");
    let chain = anyhow::Error::new(e)
        .chain()
        .map(|c| c.to_string())
        .collect::<Vec<_>>();
    assert!(
        chain.join(": ").contains("stimulus library full"),
        "{chain:?}"
    );
    assert_eq!(raw_dev.client.info().unwrap().library_free, free);
    let st = raw_dev.status().unwrap();
    assert_eq!((st.slot, st.state), (Some(12), DeviceState::Playing));
    assert_eq!(st.missed_deadlines, before.missed_deadlines, "{st:?}");
    let e = raw_dev.play(20, true).unwrap_err();
    assert_eq!(e.refusal(), Some(NackCode::NotCommitted), "{e:#}");
}
