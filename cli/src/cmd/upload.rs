//! `lmhost upload`: plan, check it fits the device, upload, commit, play.

use lm_proto::{DeviceState, Encoding, Status};

use super::args::PortArgs;
use crate::cmd::plan::PlanArgs;
use lmhost::device::connect::DeviceKind;
use lmhost::device::upload::{Play, UploadOutcome};
use lmhost::plan::sequence::DEFAULT_MAX_OFFSET_MM;

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
#[command(
    after_help = "Stimulus files (instead of planning one): --phases FILE takes \
    the phases themselves, a .npy of uint8 with shape (steps, transducers) (what \
    `lmhost plan --out F.npy` writes), raw bytes as .bin (steps = length / transducers), \
    JSON {\"phases\": [[p, ...], ...], \"dwell_us\": D}, or the JSON report `lmhost plan --out \
    F.json` writes (its phases at its dwell; refused if its crc32 no longer matches its \
    phases, or it was planned for another --target or scene); \
    --foci-file FILE takes foci in mm (finger space, mirrored like a planned stimulus), a \
    .npy of float64 with shape (steps, foci, 3) or JSON {\"foci_mm\": [[[x, y, z], ...], \
    ...], \"dwell_us\": D}, and synthesises the phases with the planner (linear). Give the \
    timing once: --freq HZ (the dwell is 1/(N f); on an AUTD3 the nearest on its 25 µs \
    grid) or dwell_us in a JSON file (on an AUTD3 a multiple of 25 µs from 1000 µs). \
    --scene, --center (the work volume's centre; default: the foci's mean, else the \
    scene's centre) and --max-offset apply; the other stimulus flags cannot and are \
    refused. A file is checked like a planned stimulus: the scene's transducer count, \
    the device's step limits, the dwell limits, finite foci within ±2000 mm in front of \
    the array; an .npy exactly as long as its shape, JSON at most 64 MiB."
)]
pub struct Args {
    /// Upload these phases instead of planning: .npy uint8 (steps,
    /// transducers), raw .bin, or JSON, plan --out's report too (see below).
    #[arg(
        long,
        value_name = "FILE",
        conflicts_with_all = FILE_CONFLICTS
    )]
    phases: Option<std::path::PathBuf>,
    /// Synthesise the phases of these foci instead of planning a circle:
    /// .npy float64 (steps, foci, 3) in mm, or JSON (see below).
    #[arg(
        long,
        value_name = "FILE",
        conflicts_with_all = FILE_CONFLICTS,
        conflicts_with = "phases"
    )]
    foci_file: Option<std::path::PathBuf>,
    #[command(flatten)]
    port: PortArgs,
    /// Slot to write [default: one that is neither playing nor queued].
    #[arg(long, value_parser = super::whole::whole::<u8>(0, u8::MAX.into()))]
    slot: Option<u8>,
    /// Upload and commit, but do not play (so --hold and --lease, which
    /// apply to a play, are refused).
    #[arg(long, conflicts_with_all = ["hold", "lease"])]
    no_play: bool,
    /// Play without tracking: the device sounds without a finger (no
    /// gating, no correction) while lmhost holds it.
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
    /// LM firmware: the sequence's encoding on the serial link [default:
    /// delta].
    #[arg(long, value_enum)]
    encoding: Option<EncodingArg>,
    #[command(flatten)]
    hold: HoldArgs,
    /// Print a JSON report instead of text.
    #[arg(long)]
    json: bool,
    /// The scene and the stimulus (last, under their help heading).
    #[command(flatten)]
    plan: PlanArgs,
}

/// The plan flags a stimulus file leaves no room for.
const FILE_CONFLICTS: [&str; 9] = [
    "radius",
    "foci",
    "spacing",
    "step",
    "steps",
    "z",
    "method",
    "iterations",
    "weights",
];

/// The one-line warning printed when playing untracked.
pub const UNTRACKED_WARNING: &str = "warning: playing untracked: the device sounds without a finger, \
     with no gating or correction, while lmhost holds it";

/// `--hold`, shared by `upload` and `play`.
#[derive(Debug, clap::Args)]
pub struct HoldArgs {
    /// Keep the link and play this many seconds, then stop (what lmhost
    /// plays lasts only while it holds the link: the LM firmware stops by
    /// itself one host lease, --lease, after lmhost exits or dies; an
    /// AUTD3 at once) [default: until Ctrl-C / SIGTERM; `upload` on the
    /// AUTD3 emulator: exit after the read-back].
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    hold: Option<f64>,
}

impl HoldArgs {
    /// How long to hold, checked; `None`: until a signal.
    pub fn duration(&self) -> Result<Option<std::time::Duration>, lmhost::InputError> {
        self.hold
            .map(|h| lmhost::limits::duration_s("--hold", h, lmhost::limits::MAX_SECONDS))
            .transpose()
    }
}

/// Holds the link to `dev` (named `what`) for `d` or until Ctrl-C or
/// SIGTERM, saying so on stderr first.
pub fn hold_saying(
    dev: &mut dyn lmhost::device::backend::Backend,
    what: &str,
    d: Option<std::time::Duration>,
) -> anyhow::Result<()> {
    lmhost::errln!(
        "holding {what} {}; the array is left silent on exit",
        match d {
            Some(d) => format!(
                "for {} s (Ctrl-C ends it early)",
                lmhost::limits::show(d.as_secs_f64())
            ),
            None => "until Ctrl-C or SIGTERM".into(),
        }
    );
    lmhost::device::connect::hold(dev, d)?;
    Ok(())
}

/// What a `Play` did, from the status right after it.
pub fn play_outcome(slot: u8, status: &Status) -> String {
    played(slot, status.queued_slot == Some(slot))
}

/// What playing `slot` did: it plays, or waits `queued` for the cycle's end.
fn played(slot: u8, queued: bool) -> String {
    if queued {
        format!("slot {slot} queued for the next cycle boundary")
    } else {
        format!("playing slot {slot}")
    }
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        let kind = self.port.spec().device()?;
        if let (Some(_), DeviceKind::Autd3(p)) = (self.encoding, &kind) {
            return Err(lmhost::device::connect::serial_link_only("--encoding", p).into());
        }
        let target = kind.target();
        let hold = self.hold.duration()?;
        let file = match (&self.phases, &self.foci_file) {
            (Some(p), _) => Some((lmhost::plan::stimulus_file::Content::Phases, p)),
            (None, Some(p)) => Some((lmhost::plan::stimulus_file::Content::Foci, p)),
            (None, None) => None,
        };
        let mut planned = match file {
            None => self.plan.plan_for(&target)?,
            Some((content, path)) => {
                let center = self
                    .plan
                    .flags
                    .center
                    .as_deref()
                    .map(|c| crate::cmd::plan::parse_vec3("center", c))
                    .transpose()?;
                // A stimulus file takes its timing from exactly one place:
                // the file's dwell or a --freq given.
                let freq = self.plan.flags.freq;
                lmhost::plan::stimulus_file::plan_for(
                    content,
                    path,
                    &target,
                    self.plan.load_scene()?,
                    freq,
                    center,
                )?
            }
        };
        planned.plan.sequence.set_max_offset_mm(self.max_offset)?;
        let mut dev = lmhost::device::connect::open_with(
            &self.port.spec(),
            &planned.plan.scene,
            self.encoding.unwrap_or(EncodingArg::Delta).into(),
            !self.json,
        )?;
        if !self.no_play {
            // Ctrl-C / SIGTERM end the hold below; the array is left silent.
            lmhost::stop::graceful();
        }
        let play = match (self.no_play, self.untracked) {
            (true, _) => Play::No,
            (false, false) => Play::Tracked,
            (false, true) => Play::Untracked,
        };
        let o = lmhost::device::upload::upload(dev.as_mut(), &planned, self.slot, play)?;
        // An AUTD3 always, the LM firmware once it plays (its host lease).
        let needs_host = dev.needs_host();
        if self.untracked {
            lmhost::errln!("{UNTRACKED_WARNING}");
        }
        let port = o.port.clone();
        // The array plays only while lmhost holds the link (the LM firmware
        // by its host lease); the AUTD3 emulator exits at once by default.
        let hold = match (needs_host && !self.no_play, hold) {
            (false, _) => None,
            (true, Some(d)) => Some(Some(d)),
            (true, None) if kind.in_process() => None,
            (true, None) => Some(None),
        };
        if self.json {
            let mut v = serde_json::to_value(&o)?;
            // null when holding until a signal, without a play, and when
            // the emulator exits at once: the same keys on every backend.
            v["hold_s"] = match hold {
                None => serde_json::Value::Null,
                Some(d) => d.map(|d| d.as_secs_f64()).into(),
            };
            lmhost::outln!("{v}")?;
        } else {
            print_text(&o, needs_host)?;
        }
        if !needs_host {
            return Ok(());
        }
        lmhost::out::flush_stdout()?;
        match hold {
            None if !self.no_play => lmhost::errln!(
                "{port} lives in this process: exiting after the read-back leaves it silent \
                 (--hold SECONDS keeps it playing)"
            ),
            None => lmhost::errln!(
                "{port} holds the sequence only while lmhost holds the link: it is gone on exit \
                 (`lmhost stream --port {port}` uploads, plays and streams)"
            ),
            Some(d) => {
                hold_saying(dev.as_mut(), &port, d)?;
                if self.json {
                    // What played, before the stop silences it: one line.
                    let status = dev.status()?;
                    let v = serde_json::json!({
                        "status": status,
                        "counters": dev.counters_source(),
                    });
                    lmhost::outln!("{v}")?;
                }
            }
        }
        Ok(dev.stop()?)
    }
}

/// The text report of an upload (`--json` prints [`UploadOutcome`]).
fn print_text(o: &UploadOutcome, needs_host: bool) -> anyhow::Result<()> {
    let t = &o.timing;
    match o.transfer.wire() {
        Some(r) => {
            lmhost::outln!(
                "uploaded {} steps × {} transducers to slot {}: {} bytes raw, {} encoded, {} with positions, {} on the wire",
                t.steps,
                o.transducers,
                o.slot,
                r.raw_bytes,
                r.sequence_bytes,
                r.payload_bytes,
                r.wire_bytes_sent + r.wire_bytes_received
            )?;
            lmhost::outln!(
                "{:.3} s, {:.1} kB/s payload, wire efficiency {:.1} %, CRC {:08x}, {} retries",
                r.seconds,
                r.payload_bytes as f64 / r.seconds.max(1e-9) / 1e3,
                r.wire_efficiency() * 100.0,
                r.crc32,
                r.retries
            )?;
        }
        None => {
            lmhost::outln!(
                "uploaded {} steps × {} transducers to {} slot {} on its 25 µs grid: {}, \
                 {} frames, {} phase bytes in {:.3} s, CRC {:08x}",
                t.steps,
                o.transducers,
                o.port,
                o.slot,
                crate::cmd::plan::grid_timing(t),
                o.transfer
                    .frames()
                    .map_or("uncounted".into(), |f| f.to_string()),
                o.payload_bytes,
                o.seconds,
                o.crc32
            )?;
            match o.transfer.readback_mismatches() {
                Some(n) => {
                    lmhost::outln!("read back from the FPGA: {n} phases differ from the plan")?
                }
                None => lmhost::outln!("this link cannot read the FPGA back")?,
            }
        }
    }
    if o.intensity_level < u8::MAX {
        lmhost::outln!(
            "at {} of full output",
            lmhost::plan::stimulus::intensity_words(o.intensity_level)
        )?;
    }
    let how_to_stream = if needs_host {
        format!(
            "`lmhost stream --port {}` uploads, plays and streams in one go",
            o.port
        )
    } else {
        "stream centroids with `lmhost stream`".to_owned()
    };
    let played = played(o.slot, o.queued);
    match (o.playing, o.untracked, o.state) {
        (false, ..) => lmhost::outln!(
            "not playing (--no-play): `lmhost play --slot {}` plays it \
             (add --untracked to play without tracking)",
            o.slot
        ),
        (true, true, _) => lmhost::outln!("{played}, untracked"),
        (true, false, Some(DeviceState::Muted)) => {
            lmhost::outln!("{played}")?;
            lmhost::outln!(
                "muted ({}) until the device tracks a finger within {} mm of the \
                 centre: {how_to_stream}, or upload with \
                 --untracked to play without tracking",
                o.mute_reason.map_or("unknown", |r| r.describe()),
                f64::from(o.max_offset_um) / 1000.0
            )
        }
        (true, false, _) => lmhost::outln!("{played}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn play_outcome_says_queued_when_it_is() {
        let st = Status {
            state: DeviceState::Playing,
            slot: Some(1),
            queued_slot: Some(0),
            ..Status::default()
        };
        assert_eq!(
            play_outcome(0, &st),
            "slot 0 queued for the next cycle boundary"
        );
        assert_eq!(play_outcome(1, &st), "playing slot 1");
    }
}
