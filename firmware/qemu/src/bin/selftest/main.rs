//! On-target tests: the core and the wire code on the Cortex-M7 under
//! `qemu-system-arm -M mps2-an500 -icount shift=0 -semihosting-config
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

//!
//! One file per group: `support` (the device, test sequence and frame
//! recorder the groups share), `wire` (byte vectors, frames through the
//! feed), `device` (store, player, correction, gate, host lease,
//! self-test), `measure` (the timer
//! check and the cost figures).

use cortex_m_rt::entry;
use lm_fw_core::TimeExtender;
use lm_fw_qemu::{PCLK_HZ, TIMER0_BASE, Timer, exit, hprint, hprintln};

/// Instructions per TIMER0 count under `-icount shift=0` (1 ns each, 25 MHz).
pub const INSTR_PER_COUNT: u32 = 1_000_000_000 / PCLK_HZ;

/// What a failed check returns; the message is already printed.
pub struct Failed;

pub type TestResult = Result<(), Failed>;

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

mod device;
mod measure;
mod support;
mod table;
mod wire;

use device::{
    correction_applied_to_frames, gate_mutes_within_one_step, lease_silences_a_quiet_host,
    player_follows_timer_schedule, self_test_is_unsupported_here, store_commit_checks_crc,
};
use measure::{
    cpu_is_a_cortex_m_with_an_fpu, measure_centroid_cost, measure_raw_vs_delta_step,
    measure_step_cost, timer_counts_instructions,
};
use table::intensity_table_scales_each_frame;
use wire::{frames_through_feed, proto_vectors_on_target};

/// What every test gets: the timer and the player's time base.
pub struct Ctx {
    pub timer: Timer,
    pub clock: TimeExtender,
}

impl Ctx {
    /// The player's time base: TIMER0 widened to 64 bits.
    pub fn now(&mut self) -> u64 {
        self.clock.extend(self.timer.now())
    }
}

/// The tests, in order. The `measure_*` ones print figures for
/// BENCHMARKS.md and check only that the measured work really happened.
type Test = fn(&mut Ctx, &mut [u8]) -> TestResult;

const TESTS: &[(&str, Test)] = &[
    (
        "cpu_is_a_cortex_m_with_an_fpu",
        cpu_is_a_cortex_m_with_an_fpu,
    ),
    ("timer_counts_instructions", timer_counts_instructions),
    ("proto_vectors_on_target", proto_vectors_on_target),
    ("store_commit_checks_crc", store_commit_checks_crc),
    (
        "player_follows_timer_schedule",
        player_follows_timer_schedule,
    ),
    ("correction_applied_to_frames", correction_applied_to_frames),
    ("gate_mutes_within_one_step", gate_mutes_within_one_step),
    ("lease_silences_a_quiet_host", lease_silences_a_quiet_host),
    (
        "self_test_is_unsupported_here",
        self_test_is_unsupported_here,
    ),
    ("frames_through_feed", frames_through_feed),
    ("measure_step_cost", measure_step_cost),
    (
        "intensity_table_scales_each_frame",
        intensity_table_scales_each_frame,
    ),
    ("measure_centroid_cost", measure_centroid_cost),
    ("measure_raw_vs_delta_step", measure_raw_vs_delta_step),
];

#[entry]
fn main() -> ! {
    let mut ctx = Ctx {
        // SAFETY: the only owner of TIMER0.
        timer: unsafe { Timer::new(TIMER0_BASE) },
        clock: TimeExtender::new(),
    };
    let Some(store) = support::STORE.try_take() else {
        panic!("the test store is taken once")
    };
    let (mut passed, mut failed) = (0u32, 0u32);
    for (name, test) in TESTS {
        hprint!("test {} ... ", name);
        match test(&mut ctx, store) {
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
