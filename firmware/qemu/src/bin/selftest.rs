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

use cortex_m_rt::entry;
use lm_fw_qemu::{PCLK_HZ, TIMER0_BASE, Timer, exit, hprint, hprintln};
use lm_proto::{FeedResult, FrameDecoder, MAX_ENCODED_FRAME, encode_frame, vectors};

/// Instructions per TIMER0 count under `-icount shift=0` (1 ns each, 25 MHz).
const INSTR_PER_COUNT: u32 = 1_000_000_000 / PCLK_HZ;

/// What a failed check returns; the message is already printed.
struct Failed;

type TestResult = Result<(), Failed>;

/// `check!(cond, "why {}", x)`: prints where and why, then fails the test.
macro_rules! check {
    ($cond:expr) => {
        if !$cond {
            hprintln!("    check failed at {}:{}: {}", file!(), line!(), stringify!($cond));
            return Err(Failed);
        }
    };
    ($cond:expr, $($arg:tt)+) => {
        if !$cond {
            hprintln!("    check failed at {}:{}: {}", file!(), line!(), format_args!($($arg)+));
            return Err(Failed);
        }
    };
}

struct Ctx {
    timer: Timer,
}

/// The tests, in order.
const TESTS: &[(&str, fn(&mut Ctx) -> TestResult)] = &[
    ("timer_counts_instructions", timer_counts_instructions),
    ("proto_vectors_on_target", proto_vectors_on_target),
];

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

#[entry]
fn main() -> ! {
    // SAFETY: the only owner of TIMER0.
    let mut ctx = Ctx {
        timer: unsafe { Timer::new(TIMER0_BASE) },
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
