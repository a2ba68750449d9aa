//! The exact SPI bytes the core sends for a planned LM-M sequence: the
//! input of the gateware simulation (`cargo xtask gateware`, see
//! `firmware/DRIVER.md`).
//!
//! The sequence is `gateware/fixtures/lmm-24x16.phases`: the first 16
//! transducers of `lmhost plan --foci 4 --steps 24 --freq 5
//! --intensity 0.8` (the paper's LM-M on the built-in array), step-major.
//! With `LM_GW_FRAMES_OUT` set, the frames are written there as
//! `u32 LE length + bytes` records, one per SPI transaction: two cycles,
//! then the muted frame the core sends on `Stop`.
//!
//! The full-width run (ignored here; `cargo xtask gateware` runs it) plays
//! the phases `lmhost plan --out X.bin` wrote (`LM_GW_PHASES`, step-major,
//! `LM_GW_CHANNELS` transducers, 5 Hz) the same way and writes its frames to
//! `LM_GW_FRAMES_OUT`.

mod common;

use common::*;
use lm_fw_core::output::{SPI_FRAME_MAGIC, SPI_HEADER_LEN};
use lm_fw_core::{OutputDriver, OutputFrame, SpiOutput};
use lm_proto::codec::Encoding;
use lm_proto::{Message, PlayAt};

const PHASES: &[u8] = include_bytes!("../../../gateware/fixtures/lmm-24x16.phases");
const STEPS: u16 = 24;
const CHANNELS: u16 = 16;
const PERIOD_US: u32 = 200_000;
/// `round(0.8 × 255)`.
const INTENSITY: u8 = 204;

/// One frame is one transaction: magic, amplitude, intensity, step
/// (LE), phase count (LE), phases.
#[test]
fn spi_frame_is_one_transaction_with_header_and_phases() {
    let mut out = SpiOutput::new(Wire::default());
    let phases = [10u8, 20, 30];
    let f = OutputFrame {
        due: 5,
        slot: 1,
        step: 0x0102,
        amplitude: 0,
        intensity: 128,
        phases: &phases,
    };
    out.write_frame(&f).unwrap();
    let spi = out.release();
    assert_eq!(spi.transactions.len(), 1);
    assert_eq!(
        spi.transactions[0],
        [0xA5, 0, 128, 0x02, 0x01, 3, 0, 10, 20, 30]
    );
}

/// Uploads the fixture, plays it for `cycles` cycles through [`SpiOutput`]
/// and returns every SPI transaction.
fn play_lm_m(cycles: u64) -> Vec<Vec<u8>> {
    play_phases(PHASES, STEPS, CHANNELS, INTENSITY, cycles)
}

/// Uploads `phases` (`steps` × `channels`, step-major, 5 Hz) with
/// `intensity`, plays `cycles` cycles through [`SpiOutput`], stops, and
/// returns every SPI transaction.
fn play_phases(
    phases: &[u8],
    steps: u16,
    channels: u16,
    intensity: u8,
    cycles: u64,
) -> Vec<Vec<u8>> {
    let mut seq = Seq::pattern(steps, channels, PERIOD_US, 0);
    seq.phases = phases.to_vec();
    let mut dev = device(config(channels), phases.len());
    let stream = seq.encode(Encoding::Raw);
    for (i, mut m) in seq
        .upload_requests(0, Encoding::Raw, &stream, 700)
        .into_iter()
        .enumerate()
    {
        if let Message::BeginUpload(b) = &mut m {
            b.header.intensity = intensity;
        }
        assert_eq!(request(&mut dev, i as u16, &m, 0), Reply::Ack, "{m:?}");
    }
    assert_eq!(request(&mut dev, 900, &seq.commit(0), 0), Reply::Ack);
    assert_eq!(
        request(&mut dev, 901, &play(0, PlayAt::Immediate), 0),
        Reply::Ack
    );
    let mut wire = Wire::default();
    let total = cycles as usize * usize::from(steps);
    let now = wire.play(&mut dev, total);
    // Stop: the core sends one muted frame (amplitude 0) at once.
    assert_eq!(request(&mut dev, 902, &Message::Stop, now), Reply::Ack);
    dev.poll(now, &mut SpiOutput::new(&mut wire));
    assert_eq!(
        wire.transactions.len(),
        total + 1,
        "one muted frame on Stop"
    );
    wire.transactions
}

#[test]
fn lm_m_frames_are_header_then_the_planned_phases() {
    let frames = play_lm_m(2);
    assert_eq!(frames.len(), 2 * usize::from(STEPS) + 1);
    let t = usize::from(CHANNELS);
    let (played, stop) = frames.split_at(frames.len() - 1);
    assert_eq!(stop[0].len(), SPI_HEADER_LEN + t);
    assert_eq!(
        &stop[0][..3],
        &[SPI_FRAME_MAGIC, 0, INTENSITY],
        "muted on Stop"
    );
    for (g, f) in played.iter().enumerate() {
        let k = g % usize::from(STEPS);
        assert_eq!(f.len(), SPI_HEADER_LEN + t, "frame {g}: one transaction");
        assert_eq!(f[0], SPI_FRAME_MAGIC);
        assert_eq!(f[1], 255, "unmuted (tracking not required)");
        assert_eq!(f[2], INTENSITY);
        assert_eq!(u16::from_le_bytes([f[3], f[4]]) as usize, k);
        assert_eq!(u16::from_le_bytes([f[5], f[6]]), CHANNELS);
        // Centroid at the planned centre: the phases go out as planned.
        assert_eq!(
            &f[SPI_HEADER_LEN..],
            &PHASES[k * t..(k + 1) * t],
            "step {k}"
        );
    }
    if let Some(path) = std::env::var_os("LM_GW_FRAMES_OUT") {
        write_frames(std::path::Path::new(&path), &frames);
    }
}

/// Writes `frames` as `u32 LE length + bytes` records to `path`.
fn write_frames(path: &std::path::Path, frames: &[Vec<u8>]) {
    let mut bytes = Vec::new();
    for f in frames {
        bytes.extend_from_slice(&(f.len() as u32).to_le_bytes());
        bytes.extend_from_slice(f);
    }
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).unwrap();
    }
    std::fs::write(path, bytes).unwrap();
}

/// The paper's LM-M at full width: one cycle of the planner's phases and
/// the Stop frame, each frame the header and that step's phases.
#[test]
#[ignore = "run by `cargo xtask gateware` with LM_GW_PHASES from `lmhost plan --out`"]
fn full_width_frames_from_the_planner() {
    let var = |k: &str| std::env::var_os(k).unwrap_or_else(|| panic!("{k} is not set"));
    let phases = std::fs::read(var("LM_GW_PHASES")).unwrap();
    let channels: u16 = var("LM_GW_CHANNELS").to_str().unwrap().parse().unwrap();
    let t = usize::from(channels);
    assert!(
        !phases.is_empty() && phases.len() % t == 0,
        "{} bytes",
        phases.len()
    );
    let steps = u16::try_from(phases.len() / t).unwrap();
    let frames = play_phases(&phases, steps, channels, 255, 1);
    assert_eq!(frames.len(), usize::from(steps) + 1);
    for (k, f) in frames[..usize::from(steps)].iter().enumerate() {
        assert_eq!(f.len(), SPI_HEADER_LEN + t);
        assert_eq!(
            &f[SPI_HEADER_LEN..],
            &phases[k * t..(k + 1) * t],
            "step {k}"
        );
    }
    write_frames(std::path::Path::new(&var("LM_GW_FRAMES_OUT")), &frames);
}
