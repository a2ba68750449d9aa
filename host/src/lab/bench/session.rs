//! The `session` section: switch latency between stimuli and the timed
//! on-phases' error by the device's own counters, from the rig session's
//! events, on the simulated LM firmware (in process, real clock) and the
//! AUTD3 emulator.

use std::time::{Duration, Instant};

use serde::Serialize;

use super::{Options, Section};
use crate::clock::Clock;
use crate::device::autd3::Autd3Backend;
use crate::device::backend::Backend;
use crate::lab::session::{EventKind, Gate, Present, Session};
use crate::plan::library::Library;
use crate::plan::scene::Scene;
use crate::plan::target::Target;

/// The paper's 5 Hz LM-S and LM-M at A = 3 mm.
const LIBRARY: &str = r#"
[[stimulus]]
id = "lms"
[[stimulus]]
id = "lmm"
foci = 4
"#;

/// Figures of one backend.
#[derive(Debug, Clone, Serialize)]
pub struct SessionFigures {
    /// The device.
    pub backend: String,
    /// Switches measured.
    pub switches: usize,
    /// Switch latency percentiles and maximum (ms).
    pub switch_p50_ms: f64,
    /// 99th percentile (nearest rank).
    pub switch_p99_ms: f64,
    /// Maximum.
    pub switch_max_ms: f64,
    /// The target: one LM cycle + 10 ms (ms).
    pub switch_limit_ms: f64,
    /// Timed untracked on-phases measured.
    pub on_phases: usize,
    /// Their `on_s`.
    pub on_s: f64,
    /// Largest |device-played − on_s| (ms).
    pub on_error_max_ms: f64,
    /// One dwell, the target for it (ms).
    pub dwell_ms: f64,
}

fn lm_dev() -> anyhow::Result<Box<dyn Backend>> {
    Ok(Box::new(
        crate::device::connect::simulated(Clock::real())?.0,
    ))
}

fn autd3_dev() -> anyhow::Result<Box<dyn Backend>> {
    Ok(Box::new(
        Autd3Backend::open_emulator(&Scene::default(), Clock::real(), None)?.0,
    ))
}

/// Polls `s` until an event `want` says so (or `within`).
fn wait_for(
    s: &mut Session,
    within: Duration,
    want: impl Fn(&EventKind) -> bool,
) -> anyhow::Result<()> {
    let end = Instant::now() + within;
    while Instant::now() < end {
        s.poll()?;
        if s.drain_events().iter().any(|e| want(&e.kind)) {
            return Ok(());
        }
        std::thread::sleep(Duration::from_micros(500));
    }
    anyhow::bail!("the session did not get there within {within:?}")
}

fn measure(
    name: &str,
    target: &Target,
    dev: Box<dyn Backend>,
    switches: usize,
    on_phases: u32,
    on_s: f64,
) -> anyhow::Result<SessionFigures> {
    let lib = Library::from_toml(LIBRARY, "bench")?;
    let scene = Scene::default();
    let plans = lib.plan_for(target, &scene)?;
    let mut s = Session::new(dev, &lib, plans, scene)?;
    let present = |id: &str, on: Option<f64>, repeat: Option<u32>| Present {
        stimulus: id.into(),
        gate: Some(Gate::Untracked),
        on_s: on,
        off_s: on.map(|_| 0.1),
        repeat,
    };
    s.present(&present("lms", None, None))?;
    for i in 0..switches {
        let id = if i % 2 == 0 { "lmm" } else { "lms" };
        // Ask at a random point of the playing cycle.
        std::thread::sleep(Duration::from_millis(37 * (i as u64 % 5)));
        s.prepare(id)?;
        s.present(&present(id, None, None))?;
        wait_for(&mut s, Duration::from_secs(5), |k| {
            matches!(k, EventKind::Switch { .. })
        })?;
    }
    s.stop(crate::lab::session::OffsetReason::Stop)?;
    s.drain_events();
    s.present(&present("lms", Some(on_s), Some(on_phases)))?;
    let all = Duration::from_secs_f64((on_s + 0.1) * f64::from(on_phases) + 5.0);
    wait_for(&mut s, all, |k| matches!(k, EventKind::Done { .. }))?;
    let f = s.figures();
    let timing = &s.loaded()[0].planned.timing;
    let period_ms = 1e3 / timing.freq_hz.min(s.loaded()[1].planned.timing.freq_hz);
    let dwell_ms = timing.dwell_us / 1e3;
    s.close(crate::lab::session::OffsetReason::Quit);
    Ok(SessionFigures {
        backend: name.into(),
        switches: f.switches,
        switch_p50_ms: f.switch_p50_ms.unwrap_or(f64::NAN),
        switch_p99_ms: f.switch_p99_ms.unwrap_or(f64::NAN),
        switch_max_ms: f.switch_max_ms.unwrap_or(f64::NAN),
        switch_limit_ms: period_ms + 10.0,
        on_phases: f.timed_on_phases,
        on_s,
        on_error_max_ms: f.on_error_max_abs_ms.unwrap_or(f64::NAN),
        dwell_ms,
    })
}

/// The `session` section.
pub fn section(opts: &Options) -> anyhow::Result<Section> {
    let (switches, phases, on_s) = if opts.quick {
        (4, 2, 0.5)
    } else {
        (40, 5, 2.0)
    };
    let figures = vec![
        measure(
            "simulated LM firmware",
            &Target::Lm,
            lm_dev()?,
            switches,
            phases,
            on_s,
        )?,
        measure(
            "AUTD3 emulator",
            &Target::Autd3,
            autd3_dev()?,
            switches,
            phases,
            on_s,
        )?,
    ];
    let mut text = String::from("session (paper LM-S <-> LM-M at 5 Hz, A = 3 mm; events)\n");
    for f in &figures {
        text.push_str(&format!(
            "  {:<22} switch p50 {:6.1} ms  p99 {:6.1} ms  max {:6.1} ms (limit {:.1})  {} x {} s on: |device - on_s| max {:.2} ms (dwell {:.2})\n",
            f.backend,
            f.switch_p50_ms,
            f.switch_p99_ms,
            f.switch_max_ms,
            f.switch_limit_ms,
            f.on_phases,
            f.on_s,
            f.on_error_max_ms,
            f.dwell_ms
        ));
    }
    Section::new("session", &figures, text)
}
