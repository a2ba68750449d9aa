//! `lmhost sim`: the firmware core on a pseudo-terminal with a real clock.
//! Prints the pty path on stdout, then serves until stopped.

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};

use lmhost::clock::Spread;
use lmhost::device::link::proxy::Faults;
use lmhost::device::simdev::{Core as _, FwCore, Loopback, Pty, ServeOptions, SimConfig, serve};

/// The simulated board's SPI loopback jumper.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum LoopbackArg {
    /// In place: every byte comes back (the self-test passes).
    Ok,
    /// Missing: MISO reads 0xFF (the self-test fails).
    Broken,
}

/// Run the simulated device (any serial tool can talk to it).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Mute when no centroid update came for this long (ms, at most
    /// 3600000: it travels as µs in a u32).
    #[arg(long, value_name = "MS", default_value_t = 100, value_parser = super::whole::whole::<u32>(0, lmhost::limits::MAX_CENTROID_TIMEOUT_MS.into()))]
    centroid_timeout_ms: u32,
    /// Play even before the first centroid update (the firmware's default
    /// is to stay muted until a finger is tracked).
    #[arg(long)]
    no_tracking: bool,
    /// Steps per slot at 996 transducers (1..=65535, the wire's u16 step
    /// count).
    #[arg(long, value_name = "N", default_value_t = 400, value_parser = super::whole::whole::<u32>(1, lmhost::limits::MAX_SLOT_STEPS.into()))]
    slot_steps: u32,
    /// Damage the link on the device's side, e.g. `ber=1e-4,drop=1e-5`
    /// (rates: ber, drop, dup, truncate; `cut=BYTES` kills the link).
    #[arg(long, value_name = "SPEC")]
    faults: Option<String>,
    /// Seed of the fault generator (with --faults) [default: 1].
    #[arg(long, value_parser = super::whole::whole::<u64>(0, u64::MAX))]
    seed: Option<u64>,
    /// Simulate an SPI loopback jumper for `lmhost selftest` [default:
    /// none: the self-test is not supported, as on QEMU].
    #[arg(long, value_enum, value_name = "JUMPER")]
    loopback: Option<LoopbackArg>,
    /// Stop after this many seconds (at most 86400) [default: serve until
    /// killed].
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    seconds: Option<f64>,
}

impl Args {
    /// Run it.
    pub fn run(self) -> anyhow::Result<()> {
        if self.seed.is_some() && self.faults.is_none() {
            lmhost::bad_input!("--seed seeds the fault generator: it applies with --faults only");
        }
        let faults = match &self.faults {
            Some(spec) => Some((
                spec.parse::<Faults>()
                    .map_err(|e| lmhost::InputError::new(format!("--faults: {e}")))?,
                self.seed.unwrap_or(1),
            )),
            None => None,
        };
        let stop_after = self
            .seconds
            .map(|s| lmhost::limits::duration_s("--seconds", s, lmhost::limits::MAX_SECONDS))
            .transpose()?;
        let cfg = SimConfig {
            slot_steps: self.slot_steps,
            centroid_timeout_us: self.centroid_timeout_ms.saturating_mul(1000),
            require_tracking: !self.no_tracking,
            loopback: self.loopback.map(|l| match l {
                LoopbackArg::Ok => Loopback::Ok,
                LoopbackArg::Broken => Loopback::Broken,
            }),
            ..SimConfig::default()
        };
        let core = Arc::new(Mutex::new(FwCore::new(cfg)?));
        let pty = Pty::open()?;
        lmhost::outln!("{}", pty.path)?;
        lmhost::out::flush_stdout()?;
        lmhost::errln!(
            "lmhost sim: simulated device on {} (Ctrl-C to stop)",
            pty.path
        );
        let stop = Arc::new(AtomicBool::new(false));
        if let Some(d) = stop_after {
            let stop = stop.clone();
            std::thread::spawn(move || {
                std::thread::sleep(d);
                stop.store(true, std::sync::atomic::Ordering::Relaxed);
            });
        }
        serve(core.clone(), pty, ServeOptions { faults }, stop)?;
        // Only reached with --seconds: what the device measured.
        let st = core.lock().unwrap_or_else(|e| e.into_inner()).stats();
        lmhost::errln!(
            "lmhost sim: {} frames ({} muted), {} centroid updates applied; host receipt → applying step {}",
            st.frames,
            st.muted_frames,
            st.centroids_applied,
            Spread::describe_or(
                Spread::of(st.latencies_us.iter().copied()).as_ref(),
                |us| format!("{us} µs")
            )
        );
        Ok(())
    }
}
