//! On-target tests: the core and the wire code on the Cortex-M4F under
//! `qemu-system-arm -M mps2-an386 -icount shift=0 -semihosting-config
//! enable=on,target=native` (`cargo xtask ci` runs it so). Prints one line per
//! test, then `N passed, N failed`; the semihosting exit status is the verdict.
//!
//! Instruction counts: with `-icount shift=0` QEMU advances virtual time by
//! exactly 1 ns per guest instruction, and TIMER0 counts the 25 MHz APB
//! clock in virtual time, so one timer count = 40 instructions. The
//! `timer_counts_instructions` test checks that ratio on a loop of known
//! length before the measurements rely on it.
#![no_std]
#![no_main]

use core::ptr::addr_of_mut;

use cortex_m_rt::entry;
use lm_fw_core::{Device, Frame, OutputDriver, TimeExtender};
use lm_fw_qemu::{
    ARRAY_TRANSDUCERS, FrameCounter, PCLK_HZ, STORE_BYTES, TIMER0_BASE, Timer, config, exit,
    hprint, hprintln,
};
use lm_proto::{
    BeginUpload, Centroid, Chunk, Commit, Crc32, Encoding, FeedResult, FrameDecoder, Geometry,
    MAX_CHUNK, MAX_ENCODED_FRAME, MAX_GEOMETRY_POSITIONS, Message, NackCode, Play, PlayAt,
    Positions, UploadHeader, encode_frame, vectors,
};

/// Instructions per TIMER0 count under `-icount shift=0` (1 ns each, 25 MHz).
const INSTR_PER_COUNT: u32 = 1_000_000_000 / PCLK_HZ;

/// What a failed check returns; the message is already printed.
struct Failed;

type TestResult = Result<(), Failed>;

/// `check!(cond, "why {}", x)`: prints where and why, then fails the test.
macro_rules! check {
    ($cond:expr) => {{
        let ok: bool = $cond;
        if !ok {
            hprintln!("    check failed at {}:{}: {}", file!(), line!(), stringify!($cond));
            return Err(Failed);
        }
    }};
    ($cond:expr, $($arg:tt)+) => {{
        let ok: bool = $cond;
        if !ok {
            hprintln!("    check failed at {}:{}: {}", file!(), line!(), format_args!($($arg)+));
            return Err(Failed);
        }
    }};
}

struct Ctx {
    timer: Timer,
    clock: TimeExtender,
}

impl Ctx {
    /// The player's time base: TIMER0 widened to 64 bits.
    fn now(&mut self) -> u64 {
        self.clock.extend(self.timer.now())
    }
}

/// The tests, in order. The `measure_*` ones print figures for
/// BENCHMARKS.md and check only that the measured work really happened.
type Test = fn(&mut Ctx) -> TestResult;

const TESTS: &[(&str, Test)] = &[
    ("timer_counts_instructions", timer_counts_instructions),
    ("proto_vectors_on_target", proto_vectors_on_target),
    ("store_commit_checks_crc", store_commit_checks_crc),
    (
        "player_follows_timer_schedule",
        player_follows_timer_schedule,
    ),
    ("correction_applied_to_frames", correction_applied_to_frames),
    ("gate_mutes_within_one_step", gate_mutes_within_one_step),
    ("frames_through_feed", frames_through_feed),
    ("measure_step_cost", measure_step_cost),
    ("measure_centroid_cost", measure_centroid_cost),
];

/// Sequence memory for the devices the tests build (one at a time).
static mut STORE: [u8; STORE_BYTES] = [0; STORE_BYTES];

/// A fresh device over [`STORE`].
fn device() -> Device<'static> {
    // SAFETY: tests run one after another and each drops its device before
    // the next calls this, so the store is never borrowed twice at once.
    let mem = unsafe { &mut *addr_of_mut!(STORE) };
    match Device::new(config(), mem) {
        Ok(d) => d,
        Err(e) => panic!("device setup: {e}"),
    }
}

/// Test transducer layout: a 36 × 28 grid at AUTD3's 10.16 mm pitch, µm.
fn position_um(i: usize) -> [i32; 3] {
    let (x, y) = ((i % 36) as i32, (i / 36) as i32);
    [(2 * x - 35) * 5_080, (2 * y - 27) * 5_080, 0]
}

/// Test sequence: phase of transducer `i` at step `s`.
fn phase(s: usize, i: usize) -> u8 {
    (s * 37 + i * 13 + (i * i) / 7) as u8
}

/// Planned centre of the test sequences: 150 mm above the array.
const CENTER_UM: [i32; 3] = [0, 0, 150_000];

/// Speed of sound the test sequences are uploaded with (20 °C air rather
/// than the usual 340 m/s), so the correction check shows the core uses the
/// uploaded value.
const SOUND_SPEED_MM_S: u32 = 343_200;

/// Uploads the test sequence (Raw, `steps` × `t`) into `slot`; returns the
/// commit's reply. `corrupt` flips the commit CRC.
fn upload(
    dev: &mut Device<'_>,
    slot: u8,
    steps: usize,
    t: usize,
    period_us: u32,
    corrupt: bool,
) -> Message<'static> {
    let begin = BeginUpload {
        slot,
        header: UploadHeader {
            steps: steps as u16,
            transducers: t as u16,
            period_us,
            center_um: CENTER_UM,
            foci_per_step: 1,
            sound_speed_mm_s: SOUND_SPEED_MM_S,
            max_offset_um: 20_000,
        },
        encoding: Encoding::Raw,
        encoded_len: (steps * t) as u32,
    };
    let r = dev.handle(&Message::BeginUpload(begin), 0);
    if r != Message::Ack {
        return r;
    }
    let mut pts = [[0i32; 3]; MAX_GEOMETRY_POSITIONS];
    for first in (0..t).step_by(MAX_GEOMETRY_POSITIONS) {
        let n = (t - first).min(MAX_GEOMETRY_POSITIONS);
        for (j, p) in pts[..n].iter_mut().enumerate() {
            *p = position_um(first + j);
        }
        let g = Geometry {
            slot,
            first: first as u16,
            positions: Positions::from_points(&pts[..n]),
        };
        let r = dev.handle(&Message::Geometry(g), 0);
        if r != Message::Ack {
            return r;
        }
    }
    let mut crc = Crc32::new();
    let mut buf = [0u8; MAX_CHUNK];
    let total = steps * t;
    for offset in (0..total).step_by(MAX_CHUNK) {
        let n = (total - offset).min(MAX_CHUNK);
        for (j, b) in buf[..n].iter_mut().enumerate() {
            let k = offset + j;
            *b = phase(k / t, k % t);
        }
        crc.update(&buf[..n]);
        let c = Chunk {
            slot,
            offset: offset as u32,
            data: &buf[..n],
        };
        let r = dev.handle(&Message::Chunk(c), 0);
        if r != Message::Ack {
            return r;
        }
    }
    let crc32 = crc.finish() ^ u32::from(corrupt);
    dev.handle(&Message::Commit(Commit { slot, crc32 }), 0)
}

fn play_now(slot: u8) -> Message<'static> {
    Message::Play(Play {
        slot,
        at: PlayAt::Immediate,
        untracked: false,
    })
}

fn centroid(seq: u32, pos_um: [i32; 3], present: bool) -> Message<'static> {
    Message::Centroid(Centroid {
        seq,
        pos_um,
        present,
        host_time_us: 0,
    })
}

/// Keeps the frames a test looks at: due time, time written (TIMER0),
/// step, amplitude, and the phases of the last frame.
struct Recorder<'t> {
    timer: &'t Timer,
    n: usize,
    due: [u64; 64],
    written: [u32; 64],
    step: [u16; 64],
    amplitude: [u8; 64],
    phases: [u8; ARRAY_TRANSDUCERS as usize],
}

impl<'t> Recorder<'t> {
    fn new(timer: &'t Timer) -> Self {
        Recorder {
            timer,
            n: 0,
            due: [0; 64],
            written: [0; 64],
            step: [0; 64],
            amplitude: [0; 64],
            phases: [0; ARRAY_TRANSDUCERS as usize],
        }
    }
}

impl OutputDriver for Recorder<'_> {
    type Error = core::convert::Infallible;
    fn write_frame(&mut self, f: &Frame<'_>) -> Result<(), Self::Error> {
        let written = self.timer.now();
        if self.n < self.due.len() {
            self.due[self.n] = f.due;
            self.written[self.n] = written;
            self.step[self.n] = f.step;
            self.amplitude[self.n] = f.amplitude;
        }
        self.n += 1;
        self.phases[..f.phases.len()].copy_from_slice(f.phases);
        Ok(())
    }
}

/// Runs `n` iterations of a 2-instruction loop (`subs`, `bne`).
#[inline(never)]
fn spin(n: u32) {
    // SAFETY: a register-only countdown loop.
    unsafe {
        core::arch::asm!("1:", "subs {0}, #1", "bne 1b", inout(reg) n => _, options(nomem, nostack));
    }
}

fn timer_counts_instructions(c: &mut Ctx) -> TestResult {
    let n = 500_000u32;
    let t0 = c.timer.now();
    spin(n);
    let t1 = c.timer.now();
    let counts = t1.wrapping_sub(t0);
    let expected = 2 * n / INSTR_PER_COUNT;
    // Allow the handful of instructions around the loop (a few counts).
    check!(
        counts.abs_diff(expected) <= 4,
        "{} instructions took {} counts, expected {} (is QEMU running with -icount shift=0?)",
        2 * n,
        counts,
        expected
    );
    Ok(())
}

fn proto_vectors_on_target(_: &mut Ctx) -> TestResult {
    let mut wire = [0u8; 2 * MAX_ENCODED_FRAME];
    let mut again = [0u8; MAX_ENCODED_FRAME];
    let mut count = 0;
    for v in vectors::parse(lm_proto::TEST_VECTORS) {
        let Some(n) = vectors::hex_decode(v.wire, &mut wire) else {
            hprintln!("    vector {}: wire hex does not fit", v.name);
            return Err(Failed);
        };
        let mut dec = FrameDecoder::new();
        let mut outcome = None;
        let mut input = &wire[..n];
        while outcome.is_none() {
            input = match dec.feed(input) {
                FeedResult::Consumed => break,
                FeedResult::Frame { frame, remaining } => {
                    let m = encode_frame(frame.seq, &frame.message, &mut again);
                    let same = m.is_ok_and(|m| again[..m] == wire[..n]);
                    outcome = Some(Ok((frame.seq, same)));
                    remaining
                }
                FeedResult::Error { error, remaining } => {
                    outcome = Some(Err(vectors::error_kind(&error)));
                    remaining
                }
            };
        }
        match (v.error, outcome) {
            (None, Some(Ok((seq, same)))) => {
                check!(
                    Some(seq) == v.seq,
                    "vector {}: seq {} != {:?}",
                    v.name,
                    seq,
                    v.seq
                );
                check!(
                    same,
                    "vector {}: re-encoding differs from the wire bytes",
                    v.name
                );
            }
            (Some(want), Some(Err(got))) => {
                check!(want == got, "vector {}: error {} != {}", v.name, got, want)
            }
            (want, _) => check!(
                false,
                "vector {}: expected {:?}, decoder disagreed",
                v.name,
                want
            ),
        }
        count += 1;
    }
    check!(count >= 10, "only {} vectors found", count);
    Ok(())
}

fn store_commit_checks_crc(_: &mut Ctx) -> TestResult {
    let mut dev = device();
    let r = upload(&mut dev, 0, 20, 996, 200_000, true);
    check!(
        r == Message::Nack(NackCode::CrcMismatch),
        "corrupt commit answered {:?}",
        r
    );
    let r = dev.handle(&play_now(0), 0);
    check!(
        r == Message::Nack(NackCode::NotCommitted),
        "play of a refused slot answered {:?}",
        r
    );
    let r = upload(&mut dev, 0, 20, 996, 200_000, false);
    check!(r == Message::Ack, "good commit answered {:?}", r);
    // Too big for a slot: refused at BeginUpload.
    let r = upload(&mut dev, 1, 300, 996, 300_000, false);
    check!(
        r == Message::Nack(NackCode::TooLarge),
        "oversized upload answered {:?}",
        r
    );
    let r = dev.handle(&play_now(0), 0);
    check!(r == Message::Ack, "play answered {:?}", r);
    Ok(())
}

fn player_follows_timer_schedule(c: &mut Ctx) -> TestResult {
    // 7 steps in 10 ms: 250,000 counts per cycle, 35,714.28 per step, so the
    // floor(k·P/N) rounding is exercised. 996 transducers: real frames.
    let (steps, period_us) = (7usize, 10_000u32);
    let p = u64::from(period_us) * u64::from(PCLK_HZ) / 1_000_000;
    let mut dev = device();
    check!(upload(&mut dev, 0, steps, 996, period_us, false) == Message::Ack);
    let timer = Timer::clone_of(&c.timer);
    let mut rec = Recorder::new(&timer);
    let start = c.now();
    let r = dev.handle(&play_now(0), start);
    check!(r == Message::Ack, "play answered {:?}", r);
    let frames = 3 * steps + 1;
    while rec.n < frames {
        let now = c.now();
        dev.poll(now, &mut rec);
    }
    let t0 = rec.due[0];
    check!(
        t0 >= start && t0 - start < p / steps as u64,
        "first step due {} for play at {}",
        t0,
        start
    );
    let mut worst = 0;
    for g in 0..frames {
        let ideal = t0 + g as u64 * p / steps as u64;
        check!(
            rec.due[g] == ideal,
            "step {} due {} != ideal {}",
            g,
            rec.due[g],
            ideal
        );
        check!(
            usize::from(rec.step[g]) == g % steps,
            "frame {} is step {}",
            g,
            rec.step[g]
        );
        let late = rec.written[g].wrapping_sub(rec.due[g] as u32);
        worst = worst.max(late);
    }
    // Written within 1/20 of a step (about 70 µs) of the boundary.
    check!(
        u64::from(worst) < p / steps as u64 / 20,
        "a frame went out {} counts late",
        worst
    );
    let st = dev.status(c.now());
    check!(
        st.missed_deadlines == 0,
        "{} missed deadlines",
        st.missed_deadlines
    );
    check!(st.cycles >= 3, "{} cycles", st.cycles);
    hprint!(
        "(worst output latency {} counts = {} instructions) ",
        worst,
        worst * INSTR_PER_COUNT
    );
    Ok(())
}

/// The correction the core must apply to transducer `i` for a centroid at
/// `c`, in phase LSB, from a plain f64 formula.
fn reference_offset(i: usize, c: [i32; 3]) -> f64 {
    let x = position_um(i);
    let dist = |a: [i32; 3]| {
        let d = [0, 1, 2].map(|k| f64::from(x[k]) - f64::from(a[k]));
        libm::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    };
    (dist(CENTER_UM) - dist(c)) * 40_000.0 * 256.0 / (f64::from(SOUND_SPEED_MM_S) * 1e3)
}

fn correction_applied_to_frames(c: &mut Ctx) -> TestResult {
    let mut dev = device();
    check!(upload(&mut dev, 0, 4, 996, 8_000, false) == Message::Ack);
    let timer = Timer::clone_of(&c.timer);
    let mut rec = Recorder::new(&timer);
    let now = c.now();
    check!(dev.handle(&play_now(0), now) == Message::Ack);
    for (seq, moved) in [
        (1, [5_000, -3_000, 152_000]),
        (2, [-10_000, 1_000, 145_000]),
    ] {
        check!(dev.handle(&centroid(seq, moved, true), c.now()) == Message::Ack);
        let before = rec.n;
        while rec.n == before {
            let now = c.now();
            dev.poll(now, &mut rec);
        }
        let step = usize::from(rec.step[(rec.n - 1).min(63)]);
        check!(
            rec.amplitude[(rec.n - 1).min(63)] == 255,
            "frame after a fresh centroid is muted"
        );
        let mut worst = 0.0f64;
        for i in 0..996 {
            let got = rec.phases[i].wrapping_sub(phase(step, i)) as i8;
            let want = reference_offset(i, moved);
            let err = libm::fabs(f64::from(got) - libm::remainder(want, 256.0));
            let err = err.min(256.0 - err);
            worst = worst.max(err);
        }
        check!(
            worst <= 1.0,
            "offset error {} LSB at centroid {:?}",
            worst,
            moved
        );
    }
    Ok(())
}

fn gate_mutes_within_one_step(c: &mut Ctx) -> TestResult {
    let mut dev = device();
    dev.set_centroid_timeout_us(3_000);
    check!(upload(&mut dev, 0, 8, 996, 8_000, false) == Message::Ack);
    let timer = Timer::clone_of(&c.timer);
    let mut rec = Recorder::new(&timer);
    let now = c.now();
    check!(dev.handle(&play_now(0), now) == Message::Ack);
    // Returns the amplitude of the next frame written.
    let next_amplitude = |dev: &mut Device<'_>, c: &mut Ctx, rec: &mut Recorder<'_>| {
        let before = rec.n;
        while rec.n == before {
            let now = c.now();
            dev.poll(now, rec);
        }
        rec.amplitude[(rec.n - 1).min(63)]
    };
    check!(
        next_amplitude(&mut dev, c, &mut rec) == 0,
        "sounds before any centroid"
    );
    check!(dev.handle(&centroid(1, CENTER_UM, true), c.now()) == Message::Ack);
    check!(
        next_amplitude(&mut dev, c, &mut rec) == 255,
        "muted after a fresh centroid"
    );
    check!(dev.handle(&centroid(2, CENTER_UM, false), c.now()) == Message::Ack);
    check!(
        next_amplitude(&mut dev, c, &mut rec) == 0,
        "sounds after presence = false"
    );
    let r = dev.handle(&centroid(2, CENTER_UM, true), c.now());
    check!(
        r == Message::Nack(NackCode::OutOfOrder),
        "a repeated seq answered {:?}",
        r
    );
    check!(dev.handle(&centroid(3, CENTER_UM, true), c.now()) == Message::Ack);
    check!(
        next_amplitude(&mut dev, c, &mut rec) == 255,
        "muted after presence came back"
    );
    // No update for longer than the 3 ms timeout: muted by the step after it.
    let last_update = c.now();
    let mut amp = 255;
    while c.now() - last_update < 3 * u64::from(PCLK_HZ) / 1000 + 25_000 {
        amp = next_amplitude(&mut dev, c, &mut rec);
    }
    check!(amp == 0, "still sounding 4 ms after the last centroid");
    check!(dev.handle(&Message::Stop, c.now()) == Message::Ack);
    Ok(())
}

fn frames_through_feed(c: &mut Ctx) -> TestResult {
    // The byte path the firmware uses: encoded requests in, encoded replies out.
    let mut dev = device();
    let mut wire = [0u8; MAX_ENCODED_FRAME];
    let mut reply = [0u8; MAX_ENCODED_FRAME];
    let mut reply_len = 0;
    let n = encode_frame(42, &Message::GetInfo, &mut wire).map_err(|_| Failed)?;
    // Garbage first, then the request split in two pieces.
    dev.feed(&[0x13, 0x37, 0x00], c.now(), &mut |_| {});
    let now = c.now();
    dev.feed(&wire[..3], now, &mut |r| {
        reply_len = r.len();
        reply[..r.len()].copy_from_slice(r);
    });
    check!(reply_len == 0, "replied to half a frame");
    dev.feed(&wire[3..n], now, &mut |r| {
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

fn measure_step_cost(c: &mut Ctx) -> TestResult {
    // 200 steps × 996 transducers, 200 ms cycle (1 ms dwell), correction on.
    let mut dev = device();
    dev.set_centroid_timeout_us(u32::MAX);
    let r = upload(&mut dev, 0, 200, 996, 200_000, false);
    check!(r == Message::Ack, "upload answered {:?}", r);
    let t0 = c.now();
    check!(dev.handle(&play_now(0), t0) == Message::Ack);
    check!(dev.handle(&centroid(1, [4_000, -2_500, 151_000], true), t0) == Message::Ack);
    check!(
        dev.offsets().iter().any(|&o| o != 0),
        "correction offsets are all zero"
    );
    let mut out = FrameCounter::default();
    // Each poll is given exactly its step's deadline: one frame per call.
    let mut deadline = dev.poll(t0, &mut out);
    let (mut total, mut worst, frames) = (0u32, 0u32, 200u32);
    for _ in 0..frames {
        let Some(d) = deadline else { break };
        let a = c.timer.now();
        deadline = dev.poll(d, &mut out);
        let b = c.timer.now();
        total += b.wrapping_sub(a);
        worst = worst.max(b.wrapping_sub(a));
    }
    check!(
        out.frames == frames + 1,
        "{} frames for {} polls",
        out.frames,
        frames + 1
    );
    check!(out.muted == 0, "{} muted frames", out.muted);
    let mean = total * INSTR_PER_COUNT / frames;
    hprintln!("");
    hprintln!(
        "    measure: step, 996 transducers, correction applied: mean {} instructions, max {} (target <= 20000; +-{} per sample)",
        mean,
        worst * INSTR_PER_COUNT,
        INSTR_PER_COUNT
    );
    let a = c.timer.now();
    let r = upload(&mut dev, 1, 200, 996, 200_000, false);
    let up = c.timer.now().wrapping_sub(a) * INSTR_PER_COUNT;
    check!(r == Message::Ack, "second upload answered {:?}", r);
    hprintln!(
        "    measure: upload + commit (CRC-32) of 200 x 996 raw, via Device::handle: {} instructions",
        up
    );
    hprintln!(
        "    measure: core state outside the sequence store, size_of::<Device>() = {} bytes (target <= 16384)",
        core::mem::size_of::<Device<'static>>()
    );
    Ok(())
}

// The FPU's square root (what `f32::sqrt` compiles to with std on this
// target), as a function: hard-float ABI, argument and result in s0.
core::arch::global_asm!(
    ".section .text.lm_vsqrt,\"ax\",%progbits",
    ".global lm_vsqrt",
    ".fpu fpv4-sp-d16",
    ".thumb_func",
    "lm_vsqrt:",
    "vsqrt.f32 s0, s0",
    "bx lr",
);

unsafe extern "C" {
    fn lm_vsqrt(x: f32) -> f32;
}

fn vsqrt(x: f32) -> f32 {
    // SAFETY: a leaf function that only touches s0 (thumbv7em-none-eabihf
    // always has the FPU).
    unsafe { lm_vsqrt(x) }
}

fn measure_centroid_cost(c: &mut Ctx) -> TestResult {
    let mut dev = device();
    check!(upload(&mut dev, 0, 200, 996, 200_000, false) == Message::Ack);
    let now = c.now();
    check!(dev.handle(&play_now(0), now) == Message::Ack);
    let (mut total, mut worst, n) = (0u32, 0u32, 50u32);
    for seq in 1..=n {
        let k = seq as i32;
        let msg = centroid(
            seq,
            [k * 211 - 5_000, 3_000 - k * 97, 150_000 + k * 13],
            true,
        );
        let now = c.now();
        let a = c.timer.now();
        let r = dev.handle(&msg, now);
        let b = c.timer.now();
        check!(r == Message::Ack, "centroid {} answered {:?}", seq, r);
        total += b.wrapping_sub(a);
        worst = worst.max(b.wrapping_sub(a));
    }
    check!(
        dev.offsets().iter().any(|&o| o != 0),
        "correction offsets are all zero"
    );
    // The whole byte path: decode + CRC check + handle + encode the Ack.
    let mut wire = [0u8; MAX_ENCODED_FRAME];
    let (mut fed, mut acks) = (0u32, 0u32);
    for seq in n + 1..=2 * n {
        let k = seq as i32;
        let msg = centroid(
            seq,
            [k * 211 - 5_000, 3_000 - k * 97, 150_000 + k * 13],
            true,
        );
        let len = encode_frame(seq as u16, &msg, &mut wire).map_err(|_| Failed)?;
        let now = c.now();
        let a = c.timer.now();
        dev.feed(&wire[..len], now, &mut |_| acks += 1);
        fed += c.timer.now().wrapping_sub(a);
    }
    check!(acks == n, "{} replies to {} centroid frames", acks, n);
    hprintln!("");
    hprintln!(
        "    measure: centroid update, 996 offsets (Device::handle): mean {} instructions, max {} (target <= 100000)",
        total * INSTR_PER_COUNT / n,
        worst * INSTR_PER_COUNT
    );
    hprintln!(
        "    measure: centroid frame through Device::feed (COBS, CRC, handle, reply): mean {} instructions",
        fed * INSTR_PER_COUNT / n
    );
    // Where the centroid cost goes: the two square roots per transducer.
    let mut acc = 0.0f32;
    let a = c.timer.now();
    for i in 0..1992u32 {
        acc += libm::sqrtf(core::hint::black_box(i as f32 * 1234.5 + 1.0e8));
    }
    let soft = c.timer.now().wrapping_sub(a) * INSTR_PER_COUNT;
    let a = c.timer.now();
    for i in 0..1992u32 {
        acc += vsqrt(core::hint::black_box(i as f32 * 1234.5 + 1.0e8));
    }
    let hard = c.timer.now().wrapping_sub(a) * INSTR_PER_COUNT;
    check!(acc > 0.0);
    hprintln!(
        "    measure: 1992 square roots (2 per transducer): libm::sqrtf {} instructions, FPU vsqrt.f32 {}",
        soft,
        hard
    );
    Ok(())
}

#[entry]
fn main() -> ! {
    // SAFETY: the only owner of TIMER0.
    let mut ctx = Ctx {
        timer: unsafe { Timer::new(TIMER0_BASE) },
        clock: TimeExtender::new(),
    };
    let (mut passed, mut failed) = (0u32, 0u32);
    for (name, test) in TESTS {
        hprint!("test {} ... ", name);
        match test(&mut ctx) {
            Ok(()) => {
                passed += 1;
                hprintln!("ok");
            }
            Err(Failed) => {
                failed += 1;
                hprintln!("test {} FAILED", name);
            }
        }
    }
    hprintln!("{} passed, {} failed", passed, failed);
    exit(failed == 0)
}
