//! The timer against the instruction count, and the cost figures
//! BENCHMARKS.md quotes (each checks only that the work really happened).

use lm_fw_core::{Device, OutputDriver, OutputFrame, memory_bytes};
use lm_fw_qemu::{ARRAY_TRANSDUCERS, FrameCounter, config, hprint, hprintln};
use lm_proto::codec::{self, Encoding};
use lm_proto::{MAX_ENCODED_FRAME, Message, Play, PlayAt, encode_frame};

use crate::support::*;
use crate::{Ctx, Failed, INSTR_PER_COUNT, TestResult};

/// Runs `n` iterations of a 2-instruction loop (`subs`, `bne`).
#[inline(never)]
pub fn spin(n: u32) {
    // SAFETY: a register-only countdown loop.
    unsafe {
        core::arch::asm!("1:", "subs {0}, #1", "bne 1b", inout(reg) n => _, options(nomem, nostack));
    }
}

/// SCB CPUID: implementer, variant, part number, revision.
const CPUID: usize = 0xE000_ED00;
/// Media and VFP feature register 0: which FPU the core has.
const MVFR0: usize = 0xE000_EF40;

/// Says which core the run is on (the figures below are its instruction
/// counts): a Cortex-M4 or M7 by CPUID, with the single-precision FPU
/// this image's hard-float code needs (MVFR0), and whether it also has
/// double precision (the M7's FPv5, as on the STM32H743).
pub fn cpu_is_a_cortex_m_with_an_fpu(_: &mut Ctx, _: &mut [u8]) -> TestResult {
    // SAFETY: CPUID and MVFR0 are read-only system registers every
    // ARMv7-M core with an FPU has; reading them has no side effect.
    let (cpuid, mvfr0) = unsafe {
        (
            core::ptr::read_volatile(CPUID as *const u32),
            core::ptr::read_volatile(MVFR0 as *const u32),
        )
    };
    let core = match (cpuid >> 4) & 0xFFF {
        0xC24 => "Cortex-M4",
        0xC27 => "Cortex-M7",
        _ => "unknown",
    };
    let (single, double) = ((mvfr0 >> 4) & 0xF, (mvfr0 >> 8) & 0xF);
    hprint!(
        "({} r{}p{}, CPUID {:#010x}; FPU single {}, double {}) ",
        core,
        (cpuid >> 20) & 0xF,
        cpuid & 0xF,
        cpuid,
        if single != 0 { "yes" } else { "no" },
        if double != 0 { "yes" } else { "no" }
    );
    check!(
        core != "unknown",
        "CPUID {:#010x} is neither an M4 nor an M7",
        cpuid
    );
    check!(
        single != 0,
        "no single-precision FPU (MVFR0 {:#010x})",
        mvfr0
    );
    Ok(())
}

pub fn timer_counts_instructions(c: &mut Ctx, _: &mut [u8]) -> TestResult {
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

/// Polls `dev` from `t0` into `out` for `frames` more frames, each poll
/// given exactly its step's deadline (one frame per call); the total and
/// the worst timer counts one of those polls took.
pub fn timed_polls(
    c: &Ctx,
    dev: &mut Device<'_>,
    t0: u64,
    frames: u32,
    out: &mut impl OutputDriver,
) -> (u32, u32) {
    let mut deadline = dev.poll(t0, out);
    let (mut total, mut worst) = (0u32, 0u32);
    for _ in 0..frames {
        let Some(d) = deadline else { break };
        let a = c.timer.now();
        deadline = dev.poll(d, out);
        let took = c.timer.now().wrapping_sub(a);
        total += took;
        worst = worst.max(took);
    }
    (total, worst)
}

pub fn measure_step_cost(c: &mut Ctx, mem: &mut [u8]) -> TestResult {
    // 200 steps × 996 transducers, 200 ms cycle (1 ms dwell), correction on.
    let mut dev = device(mem);
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
    let frames = 200u32;
    let (total, worst) = timed_polls(c, &mut dev, t0, frames, &mut out);
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

pub fn vsqrt(x: f32) -> f32 {
    // SAFETY: a leaf function that only touches s0 (thumbv7em-none-eabihf
    // always has the FPU).
    unsafe { lm_vsqrt(x) }
}

pub fn measure_centroid_cost(c: &mut Ctx, mem: &mut [u8]) -> TestResult {
    let mut dev = device(mem);
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
        dev.feed(&wire[..len], now, &mut FrameCounter::default(), &mut |_| {
            acks += 1
        });
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

/// Checks every frame against the raw sequence (outside the timed polls).
struct Verify<'r> {
    raw: &'r [u8],
    t: usize,
    frames: u32,
    wrong: u32,
}

impl OutputDriver for Verify<'_> {
    type Error = core::convert::Infallible;
    fn write_frame(&mut self, f: &OutputFrame<'_>) -> Result<(), Self::Error> {
        self.frames += 1;
        let k = usize::from(f.step) * self.t;
        if self.raw.get(k..k + self.t) != Some(f.phases) {
            self.wrong += 1;
        }
        Ok(())
    }
}

/// A paper-like sequence into `raw` (steps × `t`): against the Delta
/// predictor the residuals are 0 (50 %), ±1 (40 %) and 3 (10 %), about
/// 2.4 bits a phase, 30 % of raw (the paper's stimuli: 19-29 %).
fn paper_like(raw: &mut [u8], t: usize) {
    for idx in 0..raw.len() {
        let (k, i) = (idx / t, idx % t);
        raw[idx] = if k == 0 {
            phase(0, i)
        } else {
            let pred = if k == 1 {
                raw[idx - t]
            } else {
                raw[idx - t].wrapping_mul(2).wrapping_sub(raw[idx - 2 * t])
            };
            let h = ((k as u32).wrapping_mul(2_654_435_761) ^ (i as u32).wrapping_mul(40_503))
                .wrapping_mul(2_246_822_519)
                >> 24;
            let e: i8 = match h % 10 {
                0..=4 => 0,
                5 | 6 => 1,
                7 | 8 => -1,
                _ => 3,
            };
            pred.wrapping_add(e as u8)
        };
    }
}

/// Per-step cost of playing a Raw entry and the same sequence kept as
/// Delta (decoded step by step while playing), untracked (no correction),
/// 100 steps × 996, over two cycles (the wrap included).
pub fn measure_raw_vs_delta_step(c: &mut Ctx, mem: &mut [u8]) -> TestResult {
    const STEPS: usize = 100;
    const T: usize = ARRAY_TRANSDUCERS as usize;
    let (dev_mem, scratch) = mem.split_at_mut(memory_bytes(200 * 1024, T));
    let (raw, enc) = scratch.split_at_mut(STEPS * T);
    paper_like(raw, T);
    let n = match codec::encode(Encoding::Delta, raw, T, enc) {
        Ok(n) => n,
        Err(e) => {
            hprintln!("    encode: {}", e);
            return Err(Failed);
        }
    };
    let crc = lm_proto::crc32(raw);
    let mut dev = match Device::new(config(), dev_mem) {
        Ok(d) => d,
        Err(e) => panic!("device setup: {e}"),
    };
    let h = header(STEPS, T, 100_000);
    let r = upload_stream(&mut dev, 0, h, Encoding::Raw, raw, crc);
    check!(r == Message::Ack, "raw upload answered {:?}", r);
    let before = dev.info().library_free;
    let r = upload_stream(&mut dev, 1, h, Encoding::Delta, &enc[..n], crc);
    check!(r == Message::Ack, "delta upload answered {:?}", r);
    let stored = before - dev.info().library_free;
    check!(
        stored as usize == n,
        "kept {} B, the stream is {} B",
        stored,
        n
    );
    let mut figures = [(0u32, 0u32); 2];
    for slot in 0..2u8 {
        let play = Message::Play(Play {
            slot,
            at: PlayAt::Immediate,
            untracked: true,
            steps: 0,
            lease_ms: lm_proto::DEFAULT_LEASE_MS,
        });
        let t0 = c.now();
        check!(dev.handle(&play, t0) == Message::Ack);
        let mut out = FrameCounter::default();
        let frames = 2 * STEPS as u32;
        let (total, worst) = timed_polls(c, &mut dev, t0, frames, &mut out);
        check!(out.frames == frames + 1, "{} frames", out.frames);
        check!(out.muted == 0 && out.last_intensity == 255);
        figures[usize::from(slot)] = (total * INSTR_PER_COUNT / frames, worst * INSTR_PER_COUNT);
        // The same two cycles again, every frame checked against raw.
        let t1 = c.now();
        check!(dev.handle(&play, t1) == Message::Ack);
        let mut v = Verify {
            raw,
            t: T,
            frames: 0,
            wrong: 0,
        };
        let mut deadline = dev.poll(t1, &mut v);
        for _ in 0..frames {
            let Some(d) = deadline else { break };
            deadline = dev.poll(d, &mut v);
        }
        check!(
            v.frames == frames + 1 && v.wrong == 0,
            "slot {}: {} of {} frames differ from the raw phases",
            slot,
            v.wrong,
            v.frames
        );
    }
    hprintln!("");
    hprintln!(
        "    measure: step playback, 996 transducers, untracked, 100 steps x 2 cycles: Raw entry mean {} instructions, max {}; Delta entry ({} B, {}% of raw) mean {}, max {} (+-{} per sample)",
        figures[0].0,
        figures[0].1,
        n,
        n * 100 / raw.len(),
        figures[1].0,
        figures[1].1,
        INSTR_PER_COUNT
    );
    Ok(())
}
