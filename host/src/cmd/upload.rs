//! `lmhost upload`: plan, check it fits the device, upload, commit, play.

use std::io::IsTerminal as _;

use anyhow::Context as _;
use lm_proto::{DeviceState, Encoding, Info, PlayAt, Status};

use crate::InputError;
use crate::cmd::plan::PlanArgs;
use crate::link::{PortArgs, UploadSpec};
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
    /// Print a JSON report instead of text.
    #[arg(long)]
    json: bool,
}

/// The slot an upload without `--slot` writes: one that neither plays nor
/// is queued, preferring one other than the last played.
pub fn free_slot(info: &Info, status: &Status) -> Option<u8> {
    let playing = match status.state {
        DeviceState::Playing | DeviceState::Muted => status.slot,
        _ => None,
    };
    let busy = |s: u8| playing == Some(s) || status.queued_slot == Some(s);
    let free = || (0..info.slots).filter(|s| !busy(*s));
    free()
        .find(|s| Some(*s) != status.slot)
        .or_else(|| free().next())
}

/// Checks `slot` exists on the device (bad input otherwise, exit 2).
pub fn check_slot(slot: u8, info: &Info) -> Result<(), InputError> {
    if slot >= info.slots {
        return Err(InputError::new(format!(
            "--slot {slot} does not exist: the device has {} slots (0-{})",
            info.slots,
            info.slots.saturating_sub(1)
        )));
    }
    Ok(())
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
        let mut plan = self.plan.plan()?;
        plan.sequence.set_max_offset_mm(self.max_offset)?;
        let spec = UploadSpec::from_plan(&plan, self.encoding.into())?;
        let mut client = self.port.connect()?;
        let where_ = client.transport_mut().describe();
        let info = client
            .info()
            .with_context(|| format!("asking {where_} for its info"))?;
        let tty = std::io::stderr().is_terminal() && !self.json;
        let chunk = (info.max_chunk as usize).clamp(1, lm_proto::MAX_CHUNK);
        let slot = match self.slot {
            Some(s) => {
                check_slot(s, &info)?;
                s
            }
            None => {
                let st = client.status().context("reading the device status")?;
                free_slot(&info, &st).ok_or_else(|| {
                    anyhow::anyhow!(
                        "no free slot on {where_}: every slot is playing or queued; \
                         use --slot N or `lmhost stop` first"
                    )
                })?
            }
        };
        spec.check_fits(&info, slot).map_err(|e| {
            crate::InputError::new(format!("the sequence does not fit {where_}: {e}"))
        })?;
        let report = client
            .upload(&spec, slot, chunk, |done, total| {
                if tty {
                    let pct = done as f64 / total.max(1) as f64;
                    let bar = "#".repeat((pct * 30.0) as usize);
                    eprint!("\ruploading [{bar:<30}] {:>3.0} %", pct * 100.0);
                    if done == total {
                        eprintln!();
                    }
                }
            })
            .with_context(|| format!("uploading to slot {slot} of {where_}"))?;
        let mut outcome = None;
        if !self.no_play {
            client
                .play(slot, PlayAt::NextCycle, self.untracked)
                .with_context(|| format!("playing slot {slot}"))?;
            let st = client.status().context("reading the device status")?;
            outcome = Some((play_outcome(slot, &st), st));
            if self.untracked {
                eprintln!("{UNTRACKED_WARNING}");
            }
        }
        let h = &spec.header;
        if self.json {
            let mut v = serde_json::to_value(report)?;
            v["wire_efficiency"] = report.wire_efficiency().into();
            v["playing"] = (!self.no_play).into();
            v["queued"] = outcome
                .as_ref()
                .is_some_and(|(_, st)| st.queued_slot == Some(slot))
                .into();
            v["untracked"] = self.untracked.into();
            v["steps"] = h.steps.into();
            v["transducers"] = h.transducers.into();
            v["max_offset_um"] = h.max_offset_um.into();
            println!("{v}");
        } else {
            println!(
                "uploaded {} steps × {} transducers to slot {slot}: {} bytes raw, {} encoded, {} with positions, {} on the wire",
                h.steps,
                h.transducers,
                report.raw_bytes,
                report.sequence_bytes,
                report.payload_bytes,
                report.wire_bytes_sent + report.wire_bytes_received
            );
            println!(
                "{:.3} s, {:.1} kB/s payload, wire efficiency {:.1} %, CRC {:08x}, {} retries",
                report.seconds,
                report.payload_bytes as f64 / report.seconds.max(1e-9) / 1e3,
                report.wire_efficiency() * 100.0,
                report.crc32,
                report.retries
            );
            match &outcome {
                Some((text, _)) if self.untracked => println!("{text}, untracked"),
                Some((text, st)) => {
                    println!("{text}");
                    if st.state == DeviceState::Muted {
                        println!(
                            "muted ({}) until the device tracks a finger within {} mm of the \
                             centre: stream centroids with `lmhost stream`, or upload with \
                             --untracked to play without tracking",
                            st.mute_reason.describe(),
                            f64::from(h.max_offset_um) / 1000.0
                        );
                    }
                }
                None => println!(
                    "not playing (--no-play): `lmhost play --slot {slot}` plays it \
                     (add --untracked to play without tracking)"
                ),
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lm_proto::MuteReason;

    fn info(slots: u8) -> Info {
        Info {
            proto_version: lm_proto::PROTOCOL_VERSION,
            fw_version: [0, 1, 0],
            max_transducers: 996,
            slot_bytes: 200 * 996,
            slots,
            timer_hz: 1_000_000,
            min_dwell_us: 1000,
            max_chunk: 1024,
        }
    }

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
    fn free_slot_is_neither_playing_nor_queued() {
        use DeviceState::*;
        let i = info(2);
        assert_eq!(free_slot(&i, &status(Idle, None, None)), Some(0));
        assert_eq!(free_slot(&i, &status(Playing, Some(0), None)), Some(1));
        assert_eq!(free_slot(&i, &status(Muted, Some(1), None)), Some(0));
        assert_eq!(free_slot(&i, &status(Playing, Some(0), Some(1))), None);
        // Stopped: every slot is free; prefer the one not played last.
        assert_eq!(free_slot(&i, &status(Stopped, Some(0), None)), Some(1));
        assert_eq!(
            free_slot(&info(1), &status(Stopped, Some(0), None)),
            Some(0)
        );
        assert_eq!(free_slot(&info(1), &status(Playing, Some(0), None)), None);
        assert_eq!(
            free_slot(&info(3), &status(Playing, Some(0), Some(1))),
            Some(2)
        );
    }

    #[test]
    fn slots_are_checked_against_the_device() {
        assert!(check_slot(1, &info(2)).is_ok());
        let e = check_slot(7, &info(2)).unwrap_err();
        assert!(e.to_string().contains("2 slots (0-1)"), "{e}");
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
