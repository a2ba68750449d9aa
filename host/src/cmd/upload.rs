//! `lmhost upload`: plan, check it fits the device, upload, commit, play.

use anyhow::Context as _;
use lm_proto::{DeviceState, Encoding, Status};

use crate::autd3::GridTiming;
use crate::backend::{Backend, UploadReport};
use crate::cmd::plan::PlanArgs;
use crate::connect::Target;
use crate::link::PortArgs;
use crate::sequence::DEFAULT_MAX_OFFSET_MM;

/// Sequence encoding on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum EncodingArg {
    /// Raw phase bytes.
    Raw,
    /// Per-transducer second-order deltas (smaller for smooth sequences).
    Delta,
}

impl From<EncodingArg> for Encoding {
    fn from(e: EncodingArg) -> Self {
        match e {
            EncodingArg::Raw => Encoding::Raw,
            EncodingArg::Delta => Encoding::Delta,
        }
    }
}

/// Plan a stimulus and upload it to the device.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    plan: PlanArgs,
    #[command(flatten)]
    port: PortArgs,
    /// Slot to write [default: one that is neither playing nor queued].
    #[arg(long)]
    slot: Option<u8>,
    /// Upload and commit, but do not play.
    #[arg(long)]
    no_play: bool,
    /// Play without tracking: the device sounds without a finger (no
    /// gating, no correction) until `lmhost stop`.
    #[arg(long, conflicts_with = "no_play")]
    untracked: bool,
    /// Work volume in mm, (0, 100]: the device refuses (and mutes on) a
    /// tracked centroid farther than this from the planned centre.
    #[arg(
        long,
        value_name = "MM",
        default_value_t = DEFAULT_MAX_OFFSET_MM,
        allow_negative_numbers = true
    )]
    max_offset: f64,
    /// Wire encoding.
    #[arg(long, value_enum, default_value_t = EncodingArg::Delta)]
    encoding: EncodingArg,
    /// AUTD3 ports: keep the link and play this many seconds (the array
    /// plays only while lmhost holds the link) [default: until Ctrl-C /
    /// SIGTERM on a real rig; exit after the read-back on the emulator].
    #[arg(
        long,
        value_name = "SECONDS",
        conflicts_with = "no_play",
        allow_negative_numbers = true
    )]
    hold: Option<f64>,
    /// Print a JSON report instead of text.
    #[arg(long)]
    json: bool,
}

/// The one-line warning printed when playing untracked.
pub const UNTRACKED_WARNING: &str = "warning: playing untracked: the device sounds without a finger, \
     with no gating or correction, until `lmhost stop`";

/// What a `Play` did, from the status right after it.
pub fn play_outcome(slot: u8, status: &Status) -> String {
    if status.queued_slot == Some(slot) {
        format!("slot {slot} queued for the next cycle boundary")
    } else {
        format!("playing slot {slot}")
    }
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        let target = self.port.target()?;
        let hold = self
            .hold
            .map(|h| crate::limits::duration_s("--hold", h, crate::limits::MAX_SECONDS))
            .transpose()?;
        if hold.is_some() && target == Target::Lm {
            crate::bad_input!(
                "--hold applies to AUTD3 ports only (the LM firmware plays on its own)"
            );
        }
        let planned = self.plan.plan_for(&target)?;
        let (mut plan, grid) = (planned.plan, planned.grid);
        plan.sequence.set_max_offset_mm(self.max_offset)?;
        let mut dev =
            crate::connect::open_with(&self.port, &plan.scene, self.encoding.into(), !self.json)?;
        if dev.needs_host() && !self.no_play {
            // Ctrl-C / SIGTERM end the hold below; the array is left silent.
            crate::stop::graceful();
        }
        let report = dev.upload(&plan, self.slot)?;
        let slot = report.slot;
        let mut outcome = None;
        if !self.no_play {
            dev.play(slot, self.untracked)?;
            let st = dev.status().context("reading the device status")?;
            outcome = Some((play_outcome(slot, &st), st));
            if self.untracked {
                crate::errln!("{UNTRACKED_WARNING}");
            }
        }
        let h = &plan.sequence.header;
        let Some(wire) = report.wire else {
            return self.finish_autd3(dev.as_mut(), &report, grid, outcome, hold, h);
        };
        if self.json {
            let mut v = serde_json::to_value(wire)?;
            v["wire_efficiency"] = wire.wire_efficiency().into();
            self.play_json(&mut v, &outcome, slot);
            v["steps"] = h.steps.into();
            v["transducers"] = h.transducers.into();
            v["max_offset_um"] = h.max_offset_um.into();
            crate::outln!("{v}")?;
        } else {
            crate::outln!(
                "uploaded {} steps × {} transducers to slot {slot}: {} bytes raw, {} encoded, {} with positions, {} on the wire",
                h.steps,
                h.transducers,
                wire.raw_bytes,
                wire.sequence_bytes,
                wire.payload_bytes,
                wire.wire_bytes_sent + wire.wire_bytes_received
            )?;
            crate::outln!(
                "{:.3} s, {:.1} kB/s payload, wire efficiency {:.1} %, CRC {:08x}, {} retries",
                wire.seconds,
                wire.payload_bytes as f64 / wire.seconds.max(1e-9) / 1e3,
                wire.wire_efficiency() * 100.0,
                wire.crc32,
                wire.retries
            )?;
            self.print_outcome(&outcome, slot, h, "stream centroids with `lmhost stream`")?;
        }
        Ok(())
    }

    /// The play fields of the JSON report: playing, queued (into `slot`)
    /// and untracked.
    fn play_json(&self, v: &mut serde_json::Value, outcome: &Option<(String, Status)>, slot: u8) {
        v["playing"] = (!self.no_play).into();
        v["queued"] = outcome
            .as_ref()
            .is_some_and(|(_, st)| st.queued_slot == Some(slot))
            .into();
        v["untracked"] = self.untracked.into();
    }

    fn print_outcome(
        &self,
        outcome: &Option<(String, Status)>,
        slot: u8,
        h: &lm_proto::UploadHeader,
        how_to_stream: &str,
    ) -> anyhow::Result<()> {
        match outcome {
            Some((text, _)) if self.untracked => crate::outln!("{text}, untracked")?,
            Some((text, st)) => {
                crate::outln!("{text}")?;
                if st.state == DeviceState::Muted {
                    crate::outln!(
                        "muted ({}) until the device tracks a finger within {} mm of the \
                         centre: {how_to_stream}, or upload with \
                         --untracked to play without tracking",
                        st.mute_reason.describe(),
                        f64::from(h.max_offset_um) / 1000.0
                    )?;
                }
            }
            None => crate::outln!(
                "not playing (--no-play): `lmhost play --slot {slot}` plays it \
                 (add --untracked to play without tracking)"
            )?,
        }
        Ok(())
    }

    /// AUTD3: report the realised grid timing and the FPGA read-back, then
    /// hold the link (the array plays only while lmhost holds it) until
    /// Ctrl-C / SIGTERM or `--hold`; the emulator exits at once by default.
    fn finish_autd3(
        &self,
        dev: &mut dyn Backend,
        r: &UploadReport,
        grid: Option<GridTiming>,
        outcome: Option<(String, Status)>,
        hold: Option<std::time::Duration>,
        h: &lm_proto::UploadHeader,
    ) -> anyhow::Result<()> {
        let port = dev.describe();
        let g = grid.context("an AUTD3 upload is planned on its grid")?;
        let emulator = port.starts_with("autd3:emulator");
        let hold = match (self.no_play, hold, emulator) {
            (true, _, _) => None,
            (false, Some(d), _) => Some(Some(d)),
            (false, None, true) => None,
            (false, None, false) => Some(None),
        };
        let requested_dwell_us = 1e6 / (g.requested_freq_hz * g.steps as f64);
        if self.json {
            let mut v = serde_json::to_value(r)?;
            v["port"] = port.clone().into();
            self.play_json(&mut v, &outcome, r.slot);
            v["mute_reason"] =
                serde_json::to_value(outcome.as_ref().map(|(_, st)| st.mute_reason))?;
            v["divide"] = g.divide.into();
            v["requested_dwell_us"] = requested_dwell_us.into();
            v["dwell_error_us"] = (r.dwell_us - requested_dwell_us).into();
            v["requested_freq_hz"] = g.requested_freq_hz.into();
            v["freq_error_hz"] = g.freq_error_hz.into();
            v["step_mm"] = g.step_mm.into();
            v["requested_step_mm"] = g.requested_step_mm.into();
            v["step_error_mm"] = g.step_error_mm.into();
            v["max_offset_um"] = h.max_offset_um.into();
            v["hold_s"] = match hold {
                None => serde_json::Value::Null,
                Some(d) => d.map(|d| d.as_secs_f64()).into(),
            };
            crate::outln!("{v}")?;
        } else {
            crate::outln!(
                "uploaded {} steps × {} transducers to {port} slot {}: dwell {} µs on the 25 µs grid \
                 ({:+.1} µs from the {:.1} µs asked), {:.3} Hz ({:+.3} Hz from {} Hz), step {:.4} mm \
                 ({:+.4} mm), {} frames",
                r.steps,
                r.transducers,
                r.slot,
                r.dwell_us,
                r.dwell_us - requested_dwell_us,
                requested_dwell_us,
                g.freq_hz,
                g.freq_error_hz,
                g.requested_freq_hz,
                g.step_mm,
                g.step_error_mm,
                r.frames
            )?;
            match r.readback_mismatches {
                Some(n) => {
                    crate::outln!("read back from the FPGA: {n} phases differ from the plan")?
                }
                None => crate::outln!("this link cannot read the FPGA back")?,
            }
            self.print_outcome(
                &outcome,
                r.slot,
                h,
                &format!("`lmhost stream --port {port}` uploads, plays and streams in one go"),
            )?;
        }
        if let Some(n) = r.readback_mismatches.filter(|&n| n > 0) {
            anyhow::bail!("{port} holds {n} phases that differ from the plan");
        }
        use std::io::Write as _;
        std::io::stdout().flush()?;
        match hold {
            None if !self.no_play => crate::errln!(
                "{port} lives in this process: exiting after the read-back leaves it silent \
                 (--hold SECONDS keeps it playing)"
            ),
            None => crate::errln!(
                "{port} holds the sequence only while lmhost holds the link: it is gone on exit \
                 (`lmhost stream --port {port}` uploads, plays and streams)"
            ),
            Some(d) => {
                crate::errln!(
                    "holding {port} {}; the array is left silent on exit",
                    match d {
                        Some(d) => format!("for {:.1} s (Ctrl-C ends it early)", d.as_secs_f64()),
                        None => "until Ctrl-C or SIGTERM".into(),
                    }
                );
                crate::connect::hold(dev, d)?;
            }
        }
        dev.stop()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lm_proto::MuteReason;

    fn status(state: DeviceState, slot: Option<u8>, queued: Option<u8>) -> Status {
        Status {
            state,
            slot,
            step: 0,
            cycles: 0,
            missed_deadlines: 0,
            last_centroid_seq: 0,
            bad_frames: 0,
            crc_errors: 0,
            nacks: 0,
            correction_um: [0; 3],
            queued_slot: queued,
            mute_reason: MuteReason::None,
        }
    }

    #[test]
    fn play_outcome_says_queued_when_it_is() {
        let st = status(DeviceState::Playing, Some(1), Some(0));
        assert_eq!(
            play_outcome(0, &st),
            "slot 0 queued for the next cycle boundary"
        );
        assert_eq!(play_outcome(1, &st), "playing slot 1");
    }
}
