//! Amplitude modulation on target (protocol v6): an entry's intensity
//! table goes into each step's frame, and what the table costs a step
//! (BENCHMARKS.md, next to `measure_step_cost` without one).

use lm_fw_core::store::scale_intensity;
use lm_fw_core::{OutputDriver, OutputFrame};
use lm_fw_qemu::hprintln;
use lm_proto::{Encoding, Intensity, Message, NackCode};

use crate::measure::timed_polls;
use crate::support::*;
use crate::{Ctx, Failed, INSTR_PER_COUNT, TestResult};

const STEPS: usize = 200;
const T: usize = 996;
const LEVEL: u8 = 200;

/// Step `s`'s level: a triangle over the cycle, every value 0-255 used.
fn level(s: usize) -> u8 {
    let x = (s * 512 / STEPS) % 512;
    (if x < 256 { x } else { 511 - x }) as u8
}

/// Checks every sounding frame's intensity against the table.
struct Check {
    frames: u32,
    wrong: u32,
}

impl OutputDriver for Check {
    type Error = core::convert::Infallible;
    fn write_frame(&mut self, f: &OutputFrame<'_>) -> Result<(), Self::Error> {
        self.frames += 1;
        let want = scale_intensity(LEVEL, level(usize::from(f.step)));
        if f.amplitude > 0 && f.intensity != want {
            self.wrong += 1;
        }
        Ok(())
    }
}

/// Uploads the test sequence with the table into slot 0; `levels_sent`
/// of them, the commit CRC over phases then all levels.
fn upload_with_table(dev: &mut lm_fw_core::Device<'_>, levels_sent: usize) -> Message<'static> {
    let mut header = header(STEPS, T, 200_000);
    header.intensity = LEVEL;
    let levels: [u8; STEPS] = core::array::from_fn(level);
    let sent = begin_upload(dev, 0, header, Encoding::Raw, STEPS * T, true)
        .and_then(|()| send_raw_phases(dev, 0, STEPS, T))
        .and_then(|mut crc| {
            crc.update(&levels);
            if levels_sent > 0 {
                let m = Message::Intensity(Intensity {
                    slot: 0,
                    offset: 0,
                    data: &levels[..levels_sent],
                });
                acked(dev.handle(&m, 0))?;
            }
            Ok(crc)
        });
    sent.map_or_else(|r| r, |crc| commit(dev, 0, crc.finish()))
}

pub fn intensity_table_scales_each_frame(c: &mut Ctx, mem: &mut [u8]) -> TestResult {
    let mut dev = device(mem);
    dev.set_centroid_timeout_us(u32::MAX);
    // A table one level short never commits, so never plays.
    let r = upload_with_table(&mut dev, STEPS - 1);
    check!(
        r == Message::Nack(NackCode::Incomplete),
        "short table answered {:?}",
        r
    );
    check!(dev.handle(&play_now(0), 0) == Message::Nack(NackCode::NotCommitted));
    let free = dev.info().library_free;
    let r = upload_with_table(&mut dev, STEPS);
    check!(r == Message::Ack, "upload answered {:?}", r);
    let taken = free + (STEPS * T + STEPS) as u32 - dev.info().library_free;
    check!(
        taken == (STEPS * T + STEPS) as u32,
        "the entry took {} B",
        taken
    );
    // As measure_step_cost: 1 ms dwell, tracked, correction applied.
    let t0 = c.now();
    check!(dev.handle(&play_now(0), t0) == Message::Ack);
    check!(dev.handle(&centroid(1, [4_000, -2_500, 151_000], true), t0) == Message::Ack);
    let mut out = Check {
        frames: 0,
        wrong: 0,
    };
    let frames = STEPS as u32;
    let (total, worst) = timed_polls(c, &mut dev, t0, frames, &mut out);
    check!(out.frames == frames + 1, "{} frames", out.frames);
    check!(
        out.wrong == 0,
        "{} frames with the wrong intensity",
        out.wrong
    );
    hprintln!("");
    hprintln!(
        "    measure: step with an intensity table, 996 transducers, correction applied: mean {} instructions, max {}",
        total * INSTR_PER_COUNT / frames,
        worst * INSTR_PER_COUNT
    );
    Ok(())
}
