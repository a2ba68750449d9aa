//! `lmhost upload`: plan, check it fits the device, upload, commit, play.

use std::io::IsTerminal as _;

use anyhow::Context as _;
use lm_proto::{Encoding, NackCode, PlayAt};

use crate::autd3::{Autd3Backend, Autd3Port};
use crate::backend::Backend as _;
use crate::cmd::plan::PlanArgs;
use crate::link::client::check_fits;
use crate::link::{LinkError, PortArgs, UploadSpec, mm_to_um};

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
    /// Slot to write [default: one that is not playing].
    #[arg(long)]
    slot: Option<u8>,
    /// Upload and commit, but do not play.
    #[arg(long)]
    no_play: bool,
    /// Wire encoding.
    #[arg(long, value_enum, default_value_t = EncodingArg::Delta)]
    encoding: EncodingArg,
    /// Print a JSON report instead of text.
    #[arg(long)]
    json: bool,
}

/// The planned sequence as the link wants it.
pub fn upload_spec(plan: &crate::sequence::Plan) -> UploadSpec {
    let h = &plan.sequence.header;
    UploadSpec {
        steps: h.steps,
        transducers: h.transducers,
        period_us: h.period_us,
        center_um: h.center_um,
        foci_per_step: h.foci_per_step,
        sound_speed_mm_s: h.sound_speed_mm_s,
        positions_um: plan
            .scene
            .transducers()
            .iter()
            .map(|t| t.pos_mm.map(mm_to_um))
            .collect(),
        phases: plan.sequence.phases.clone(),
    }
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        if let Some(p) = self.port.port.as_deref().filter(|p| Autd3Port::is_autd3(p)) {
            let port = Autd3Port::parse(p)?;
            return self.run_autd3(&port);
        }
        let plan = self.plan.plan()?;
        let spec = upload_spec(&plan);
        let mut client = self.port.connect()?;
        let where_ = client.transport_mut().describe();
        let info = client
            .info()
            .with_context(|| format!("asking {where_} for its info"))?;
        let tty = std::io::stderr().is_terminal() && !self.json;
        let chunk = (info.max_chunk as usize).clamp(1, lm_proto::MAX_CHUNK);
        // Without --slot: the slot that is not playing. Right after a Play
        // at the next cycle, the other slot is queued and refuses uploads
        // until the cycle ends, so ask again (a cycle is at most ~1 s).
        let mut waits = 0;
        let (slot, report) = loop {
            let slot = match self.slot {
                Some(s) => s,
                None => {
                    let st = client.status().context("reading the device status")?;
                    match st.slot {
                        Some(s) if info.slots > 1 => (s + 1) % info.slots,
                        _ => 0,
                    }
                }
            };
            check_fits(&spec, &info, slot).map_err(|e| {
                crate::InputError::new(format!("the sequence does not fit {where_}: {e}"))
            })?;
            let result = client.upload(&spec, slot, self.encoding.into(), chunk, |done, total| {
                if tty {
                    let pct = done as f64 / total.max(1) as f64;
                    let bar = "#".repeat((pct * 30.0) as usize);
                    eprint!("\ruploading [{bar:<30}] {:>3.0} %", pct * 100.0);
                    if done == total {
                        eprintln!();
                    }
                }
            });
            match result {
                Err(LinkError::Nack {
                    code: NackCode::SlotPlaying,
                    ..
                }) if self.slot.is_none() && waits < 20 => {
                    waits += 1;
                    std::thread::sleep(std::time::Duration::from_millis(100));
                }
                other => {
                    break (
                        slot,
                        other.with_context(|| format!("uploading to slot {slot} of {where_}"))?,
                    );
                }
            }
        };
        if !self.no_play {
            client
                .play(slot, PlayAt::NextCycle)
                .with_context(|| format!("playing slot {slot}"))?;
        }
        if self.json {
            let mut v = serde_json::to_value(report)?;
            v["wire_efficiency"] = report.wire_efficiency().into();
            v["playing"] = (!self.no_play).into();
            v["steps"] = spec.steps.into();
            v["transducers"] = spec.transducers.into();
            println!("{v}");
        } else {
            println!(
                "uploaded {} steps × {} transducers to slot {slot}: {} bytes raw, {} encoded, {} with positions, {} on the wire",
                spec.steps,
                spec.transducers,
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
            if !self.no_play {
                println!("playing slot {slot} from the next cycle boundary");
            }
        }
        Ok(())
    }
}

impl Args {
    /// Upload to an AUTD3 rig: plan on its 25 µs grid, write the idle STM
    /// segment, read it back (emulator). AUTD3 output lasts only while
    /// lmhost holds the link, so this does not play; `stream` and `demo` do.
    fn run_autd3(self, port: &Autd3Port) -> anyhow::Result<()> {
        let scene = self.plan.load_scene()?;
        let params = self.plan.params(&scene)?;
        let (plan, g) = crate::autd3::timing::plan(&params, &scene, &self.plan.synthesis()?)?;
        let mut dev = Autd3Backend::open(port, &scene)?;
        let r = dev
            .upload(&plan, self.slot)
            .with_context(|| format!("uploading to {port}"))?;
        if self.json {
            let mut v = serde_json::to_value(&r)?;
            v["port"] = port.to_string().into();
            v["playing"] = false.into();
            v["timing"] = serde_json::to_value(g)?;
            v["step_mm"] = g.step_mm.into();
            println!("{v}");
        } else {
            println!(
                "uploaded {} steps × {} transducers to {port} slot {}: dwell {} µs on the 25 µs grid, {:.3} Hz ({:+.3} Hz from {} Hz asked), step {:.4} mm ({:+.4} mm), {} frames",
                r.steps,
                r.transducers,
                r.slot,
                g.dwell_us,
                g.freq_hz,
                g.freq_error_hz,
                g.requested_freq_hz,
                g.step_mm,
                g.step_error_mm,
                r.frames
            );
            match r.readback_mismatches {
                Some(n) => println!("read back from the FPGA: {n} phases differ from the plan"),
                None => println!("this link cannot read the FPGA back"),
            }
        }
        if let Some(n) = r.readback_mismatches.filter(|&n| n > 0) {
            anyhow::bail!("{port} holds {n} phases that differ from the plan");
        }
        Ok(())
    }
}
