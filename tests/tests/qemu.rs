//! The firmware under QEMU, driven over its UART with the real protocol:
//! info, upload (BeginUpload, Geometry, Chunks), commit, play, centroid,
//! status, stop.
//!
//! QEMU runs `mps2-an386` with UART0 on a TCP socket on 127.0.0.1 and
//! `-icount shift=0`, so the player's timer runs on the guest's own
//! instruction count and the test can demand zero missed deadlines. The
//! firmware ELF comes from `LM_FW_QEMU_ELF` (set by `cargo xtask ci`, which
//! builds it first); without it the test builds it with
//! `cargo build --release -p lm-fw-qemu --target thumbv7em-none-eabihf` into
//! its own target dir. Skipped, with a message, when `qemu-system-arm` is
//! not installed (`cargo xtask ci` installs it).

use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::Child;
use std::time::{Duration, Instant};

use lmhost::backend::Backend;

use lm_proto::{
    BeginUpload, Centroid, Chunk, Commit, DeviceState, Encoding, FeedResult, FrameDecoder,
    Geometry, MAX_CHUNK, MAX_ENCODED_FRAME, MAX_GEOMETRY_POSITIONS, Message, NackCode,
    PROTOCOL_VERSION, Play, PlayAt, Positions, Status, UploadHeader, codec, crc32, encode_frame,
};

mod qemu_support;
use qemu_support::{firmware_elf, free_port, qemu_command, qemu_installed};

/// Speed of sound the test sequences are planned and uploaded with, mm/s.
const SOUND_SPEED_MM_S: u32 = 340_000;

/// A running QEMU; killed on drop. Its console output goes to a log file
/// that is printed if the test fails.
struct Qemu {
    child: Child,
    log: PathBuf,
}

impl Qemu {
    fn start(elf: &Path) -> (Qemu, TcpStream) {
        let port = free_port();
        let log = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("qemu-{port}.log"));
        let out = std::fs::File::create(&log).unwrap();
        let child = qemu_command(elf, port, true)
            .stdout(out.try_clone().unwrap())
            .stderr(out)
            .spawn()
            .expect("start qemu-system-arm");
        let mut q = Qemu { child, log };
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            match TcpStream::connect(("127.0.0.1", port)) {
                Ok(s) => {
                    s.set_nodelay(true).unwrap();
                    return (q, s);
                }
                Err(e) if Instant::now() > deadline => {
                    panic!(
                        "cannot connect to QEMU's UART on port {port}: {e}\n{}",
                        q.output()
                    )
                }
                Err(_) => {
                    if let Ok(Some(st)) = q.child.try_wait() {
                        panic!("QEMU exited early ({st})\n{}", q.output());
                    }
                    std::thread::sleep(Duration::from_millis(50));
                }
            }
        }
    }

    fn output(&self) -> String {
        format!(
            "--- QEMU output ---\n{}",
            std::fs::read_to_string(&self.log).unwrap_or_default()
        )
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        if std::thread::panicking() {
            eprintln!("{}", self.output());
        }
    }
}

/// Request/response over the socket, matched by sequence number.
struct Link {
    sock: TcpStream,
    dec: FrameDecoder,
    pending: Vec<u8>,
    seq: u16,
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
        }
    }

    fn request(&mut self, msg: &Message<'_>) -> Reply {
        self.seq = self.seq.wrapping_add(1);
        let mut buf = [0u8; MAX_ENCODED_FRAME];
        let n = encode_frame(self.seq, msg, &mut buf).unwrap();
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
    if !qemu_installed() {
        println!("SKIPPED: qemu-system-arm is not installed (`cargo xtask ci` installs it)");
        return;
    }
    let elf = firmware_elf();
    let (_qemu, sock) = Qemu::start(&elf);
    let mut link = Link::new(sock);
    let t0 = Instant::now();

    // Info.
    let Reply::Info(info) = link.request(&Message::GetInfo) else {
        panic!("GetInfo not answered with Info")
    };
    assert_eq!(info.proto_version, PROTOCOL_VERSION);
    assert!(info.slots >= 2, "{info:?}");
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
        })),
        Reply::Nack(_)
    ));

    link.ack(&Message::BeginUpload(BeginUpload {
        slot: 0,
        header: UploadHeader {
            steps: steps as u16,
            transducers: t as u16,
            period_us,
            center_um,
            foci_per_step: 1,
            sound_speed_mm_s: SOUND_SPEED_MM_S,
            max_offset_um: 20_000,
        },
        encoding: Encoding::Delta,
        encoded_len: n as u32,
    }));
    for (i, group) in pos.chunks(MAX_GEOMETRY_POSITIONS).enumerate() {
        link.ack(&Message::Geometry(Geometry {
            slot: 0,
            first: (i * MAX_GEOMETRY_POSITIONS) as u16,
            positions: Positions::from_points(group),
        }));
    }
    for (i, data) in enc.chunks(MAX_CHUNK).enumerate() {
        link.ack(&Message::Chunk(Chunk {
            slot: 0,
            offset: (i * MAX_CHUNK) as u32,
            data,
        }));
    }
    link.ack(&Message::Commit(Commit {
        slot: 0,
        crc32: crc32(&raw),
    }));

    // A corrupt upload (wrong CRC) into the other slot is refused and never playable.
    let small = [10u8, 20, 30, 40, 11, 21, 31, 41];
    link.ack(&Message::BeginUpload(BeginUpload {
        slot: 1,
        header: UploadHeader {
            steps: 2,
            transducers: 4,
            period_us,
            center_um,
            foci_per_step: 1,
            sound_speed_mm_s: SOUND_SPEED_MM_S,
            max_offset_um: 20_000,
        },
        encoding: Encoding::Raw,
        encoded_len: small.len() as u32,
    }));
    link.ack(&Message::Geometry(Geometry {
        slot: 1,
        first: 0,
        positions: Positions::from_points(&pos[..4]),
    }));
    link.ack(&Message::Chunk(Chunk {
        slot: 1,
        offset: 0,
        data: &small,
    }));
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

/// Lets `d` pass on the firmware's own clock: QEMU's virtual time may run
/// slower than the wall clock, so wait until the player has stepped that
/// long (it steps while muted too; every wait of the table is while a
/// slot plays).
fn wait_on_device(
    dev: &mut dyn Backend,
    d: Duration,
    steps: u64,
    dwell_us: f64,
) -> anyhow::Result<()> {
    let pos = |st: &Status| u64::from(st.cycles) * steps + u64::from(st.step);
    let start = pos(&dev.status()?);
    let need = (d.as_secs_f64() * 1e6 / dwell_us).ceil() as u64 + 1;
    let give_up = Instant::now() + d * 50 + Duration::from_secs(10);
    loop {
        std::thread::sleep(Duration::from_millis(5));
        // (A slot taking over restarts the count: the wait only gets longer.)
        if pos(&dev.status()?) >= start + need {
            return Ok(());
        }
        anyhow::ensure!(
            Instant::now() < give_up,
            "the firmware's player did not advance"
        );
    }
}

/// The device policy's conformance table (`lmhost::conformance`), the
/// same one the simulated device and the AUTD3 emulator pass, against the
/// firmware under QEMU: a fresh QEMU per scenario.
#[test]
fn firmware_under_qemu_conforms_to_the_device_policy() {
    use lmhost::conformance::{Dut, run};
    use lmhost::connect::Target;
    use lmhost::scene::Scene;
    use lmhost::stimulus::Stimulus;
    if !qemu_installed() {
        println!("SKIPPED: qemu-system-arm is not installed (`cargo xtask ci` installs it)");
        return;
    }
    let elf = firmware_elf();
    let wide = Stimulus::default()
        .plan_for(&Target::Lm, Scene::default())
        .unwrap()
        .plan;
    let mut narrow = wide.clone();
    narrow.sequence.set_max_offset_mm(2.0).unwrap();
    let steps = u64::from(wide.sequence.header.steps);
    let dwell_us = wide.sequence.dwell_us();
    let mut held: Vec<Qemu> = Vec::new();
    let failures = run(
        &mut || {
            held.clear();
            let port = free_port();
            let log = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("qemu-{port}.log"));
            let out = std::fs::File::create(&log)?;
            let child = qemu_command(&elf, port, false)
                .stdout(out.try_clone()?)
                .stderr(out)
                .spawn()?;
            held.push(Qemu { child, log });
            let spec = lmhost::link::PortSpec::new(Some(format!("tcp:127.0.0.1:{port}")));
            let deadline = Instant::now() + Duration::from_secs(20);
            let dev = loop {
                match lmhost::connect::open(&spec, &Scene::default()) {
                    Ok(d) => break d,
                    Err(e) if Instant::now() > deadline => return Err(e),
                    Err(_) => std::thread::sleep(Duration::from_millis(50)),
                }
            };
            Ok(Dut {
                dev,
                wait: Box::new(move |dev, d| wait_on_device(dev, d, steps, dwell_us)),
            })
        },
        &wide,
        &narrow,
    )
    .unwrap();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
