//! The `session` section: onset latency from silence and switch latency
//! between stimuli (request to the device playing, by its own counters),
//! and the timed on-phases' error, from the rig session's figures, on the
//! simulated LM firmware (in process, real clock) and the AUTD3 emulator.
//! The session runs under its [`Driver`], as in `lmhost session`.

use std::time::{Duration, Instant};

use serde::Serialize;

use super::{Options, Section};
use crate::clock::{Clock, Spread};
use crate::device::autd3::Autd3Backend;
use crate::device::backend::Backend;
use crate::lab::session::driver::{Driver, Finger};
use crate::lab::session::{EventKind, Gate, OffsetReason, Present, Session};
use crate::plan::library::Library;
use crate::plan::scene::Scene;
use crate::plan::target::Target;
use crate::sense::stream::filter::Passthrough;

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
    /// Onsets from silence measured (alternating between the two
    /// stimuli, so between slots).
    pub onsets: usize,
    /// Onset latency (ms): from the `present` to the device playing, by
    /// its own counters.
    pub onset_latency_ms: Option<Spread<f64>>,
    /// The target: one dwell + 1 ms (ms).
    pub onset_limit_ms: f64,
    /// Each onset's offset from the ideal (the `present`), ms, in order.
    pub onset_ms: Vec<f64>,
    /// Switches measured.
    pub switches: usize,
    /// Switch latency (ms).
    pub switch_latency_ms: Option<Spread<f64>>,
    /// The target: one LM cycle + 10 ms (ms).
    pub switch_limit_ms: f64,
    /// Timed untracked on-phases measured.
    pub on_phases: usize,
    /// Their `on_s`.
    pub on_s: f64,
    /// Largest |device-played − on_s| (ms).
    pub on_error_max_ms: f64,
    /// One dwell (ms).
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

/// Turns `d` until `done` holds (or `within`), events in hand.
fn run_until(
    d: &mut Driver,
    within: Duration,
    mut done: impl FnMut(&Driver, &[EventKind]) -> bool,
) -> anyhow::Result<()> {
    let end = Instant::now() + within;
    while Instant::now() < end {
        let ev: Vec<EventKind> = d.turn()?.into_iter().map(|e| e.kind).collect();
        if done(d, &ev) {
            return Ok(());
        }
        d.wait(Duration::from_millis(1));
    }
    anyhow::bail!("the session did not get there within {within:?}")
}

/// Keeps `d` turning for `t`.
fn idle(d: &mut Driver, t: Duration) -> anyhow::Result<()> {
    let end = Instant::now() + t;
    while Instant::now() < end {
        d.turn()?;
        d.wait(Duration::from_millis(1));
    }
    Ok(())
}

fn present(id: &str, on: Option<f64>, repeat: Option<u32>) -> Present {
    Present {
        stimulus: id.into(),
        gate: Some(Gate::Untracked),
        on_s: on,
        off_s: on.map(|_| 0.1),
        repeat,
    }
}

fn measure(
    name: &str,
    target: &Target,
    dev: Box<dyn Backend>,
    n: usize,
    on_phases: u32,
    on_s: f64,
) -> anyhow::Result<SessionFigures> {
    let lib = Library::from_toml(LIBRARY, "bench")?;
    let scene = Scene::default();
    let plans = lib.plan_for(target, &scene)?;
    let s = Session::new(dev, &lib, plans, scene, Clock::real())?;
    let mut d = Driver::new(s, Finger::None, Box::new(Passthrough));
    let ids = ["lms", "lmm"];
    // Onsets from silence, each stimulus where it sits, at varied times.
    for i in 0..n {
        let id = ids[i % 2];
        d.session().prepare(id)?;
        idle(&mut d, Duration::from_millis(20 + 13 * (i as u64 % 7)))?;
        let before = d.session_ref().figures().onsets;
        d.session().present(&present(id, None, None))?;
        run_until(&mut d, Duration::from_secs(5), |d, _| {
            d.session_ref().figures().onsets > before
        })?;
        d.session().stop(OffsetReason::Stop)?;
    }
    d.session().present(&present("lms", None, None))?;
    for i in 0..n {
        let id = ids[(i + 1) % 2];
        // Ask at a varied point of the playing cycle.
        idle(&mut d, Duration::from_millis(37 * (i as u64 % 5)))?;
        d.session().prepare(id)?;
        d.session().present(&present(id, None, None))?;
        run_until(&mut d, Duration::from_secs(5), |_, ev| {
            ev.iter().any(|k| matches!(k, EventKind::Switch { .. }))
        })?;
    }
    d.session().stop(OffsetReason::Stop)?;
    // The stop's own `done` is not the timed presentation's.
    d.session().drain_events();
    let switches = d.session_ref().figures();
    d.session()
        .present(&present("lms", Some(on_s), Some(on_phases)))?;
    let all = Duration::from_secs_f64((on_s + 0.1) * f64::from(on_phases) + 5.0);
    run_until(&mut d, all, |_, ev| {
        ev.iter().any(|k| matches!(k, EventKind::Done { .. }))
    })?;
    let s = d.into_session();
    let f = s.figures();
    let onset_ms = s.onset_latencies_ms()[..n.min(f.onsets)].to_vec();
    let timing = &s.loaded()[0].planned.timing;
    let period_ms = 1e3 / timing.freq_hz.min(s.loaded()[1].planned.timing.freq_hz);
    let dwell_ms = timing.dwell_us.max(s.loaded()[1].planned.timing.dwell_us) / 1e3;
    s.close(OffsetReason::Quit);
    Ok(SessionFigures {
        backend: name.into(),
        onsets: onset_ms.len(),
        onset_latency_ms: Spread::of_f64(onset_ms.iter().copied()),
        onset_limit_ms: dwell_ms + 1.0,
        onset_ms,
        switches: switches.switches,
        switch_latency_ms: switches.switch_ms,
        switch_limit_ms: period_ms + 10.0,
        on_phases: f.timed_on_phases,
        on_s,
        on_error_max_ms: f.on_error_max_abs_ms.unwrap_or(f64::NAN),
        dwell_ms,
    })
}

/// The `session` section.
pub fn section(opts: &Options) -> anyhow::Result<Section> {
    let (n, phases, on_s) = if opts.quick {
        (4, 2, 0.5)
    } else {
        (40, 5, 2.0)
    };
    let figures = vec![
        measure(
            "simulated LM firmware",
            &Target::Lm,
            lm_dev()?,
            n,
            phases,
            on_s,
        )?,
        measure(
            "AUTD3 emulator",
            &Target::Autd3,
            autd3_dev()?,
            n,
            phases,
            on_s,
        )?,
    ];
    let mut text = String::from(
        "session (paper LM-S <-> LM-M at 5 Hz, A = 3 mm; the session's figures under its driver)\n",
    );
    for f in &figures {
        let onset = Spread::describe_or(f.onset_latency_ms.as_ref(), |v| format!("{v:.2} ms"));
        let switch = Spread::describe_or(f.switch_latency_ms.as_ref(), |v| format!("{v:.1} ms"));
        text.push_str(&format!(
            "  {:<22} onset  {onset} (limit {:.2}, {} onsets)\n",
            f.backend, f.onset_limit_ms, f.onsets
        ));
        text.push_str(&format!(
            "  {:<22} switch {switch} (limit {:.1}, {} switches)\n",
            "", f.switch_limit_ms, f.switches
        ));
        text.push_str(&format!(
            "  {:<22} {} x {} s on: |device - on_s| max {:.2} ms (dwell {:.2})\n",
            "", f.on_phases, f.on_s, f.on_error_max_ms, f.dwell_ms
        ));
    }
    Section::new("session", &figures, text)
}
