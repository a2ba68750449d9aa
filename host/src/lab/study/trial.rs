//! What a trial asks and what its row says: the dry run of a responses
//! file through every question and procedure the trials will ask, and a
//! finished trial's row from the session's events, keyed by column name.

use super::answers::{Answers as _, Asked, Lines};
use super::columns::{self, Row};
use super::design::Planned;
use super::procedure::{self, Procedure};
use super::protocol::Protocol;
use super::record::Expect;
use crate::lab::session::{Event, EventKind};
use crate::plan::stimulus::Timing;

/// One answer: its column, the value recorded and the response time (s
/// from the question being asked to its answer).
#[derive(Debug, Clone, PartialEq)]
pub struct Answer {
    /// The `trials.csv` column.
    pub column: String,
    /// The value recorded.
    pub value: String,
    /// Seconds from asked to answered.
    pub rt_s: f64,
}

/// The answers of one trial, in the order asked.
pub type Given = Vec<Answer>;

/// What the row records of the trial's time and the device's health.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Health {
    /// Wall-clock time of the trial's start, RFC 3339 UTC.
    pub time_utc: String,
    /// The device's missed deadlines during the trial (its status after
    /// less before; `None`: not read).
    pub missed_deadlines: Option<u32>,
    /// Its lease expiries during the trial.
    pub lease_expiries: Option<u32>,
}

/// Walks the answers `trials` will ask for, in order, through `answers`
/// (a procedure's first, as they come while the stimulus repeats, then the
/// questions'), and then refuses any left over: the first bad, missing or
/// extra answer is the error, before the device opens. The first trial's
/// procedure has taken the `resumed` answers already (a trial cut short).
pub fn dry_run(
    p: &Protocol,
    trials: &[Planned],
    answers: &mut Lines,
    resumed: &[(String, f64)],
) -> anyhow::Result<()> {
    let mut now = |q: &Asked| -> anyhow::Result<(String, f64)> {
        let a = answers
            .poll(q)?
            .ok_or_else(|| anyhow::anyhow!("a responses file has every answer at once"))?;
        Ok((a, 0.0))
    };
    for (i, t) in trials.iter().enumerate() {
        if let Some(mut pr) = procedure::start(p, t) {
            if i == 0 {
                // Checked by `start::resume` already.
                super::midtrial::replay(pr.as_mut(), resumed).map_err(anyhow::Error::msg)?;
            }
            while !pr.finished() {
                let (a, _) = now(&pr.asked())?;
                pr.respond(&a);
            }
        }
        ask_each(p, t, &mut now)?;
    }
    answers.check_used_up()?;
    Ok(())
}

/// Trial `t`'s questions in the order asked, each answered by `ask` (which
/// keeps the device served while the participant thinks, and returns the
/// answer and its response time, s).
pub fn ask_each(
    p: &Protocol,
    t: &Planned,
    mut ask: impl FnMut(&Asked) -> anyhow::Result<(String, f64)>,
) -> anyhow::Result<Given> {
    let mut given = Given::new();
    for (q, order) in p.questions.iter().zip(&t.orders) {
        for asked in Asked::of(q, order) {
            let (value, rt_s) = ask(&asked)?;
            given.push(Answer {
                column: asked.column,
                value,
                rt_s,
            });
        }
    }
    Ok(given)
}

/// Trial `t`'s row: the values the plan fixes, timing as realised and
/// played (from the trial's session `events` and the entry's `timing`),
/// its time and the device's `health`, the answers `given` and the
/// procedure's columns; and the host-timed on-time, s.
pub fn row(
    expect: &Expect,
    t: &Planned,
    events: &[Event],
    timing: Option<&Timing>,
    health: &Health,
    given: &[Answer],
    procedure: Option<&dyn Procedure>,
) -> (Row, f64) {
    // A staircase presents other levels' entries within the trial.
    let ours = |s: &str| s == t.stimulus || procedure.is_some_and(|p| p.presents(s));
    let mut onset = None;
    let mut offset = None;
    let (mut presented, mut muted, mut device, mut device_known) = (0.0, 0.0, 0.0, true);
    let (mut phases, mut mutes, mut switch) = (0usize, 0usize, None);
    for e in events {
        match &e.kind {
            EventKind::Onset { stimulus, .. } if ours(stimulus) => {
                onset.get_or_insert(e.t_host_us);
            }
            EventKind::Offset {
                stimulus,
                presented_s,
                device_presented_s,
                muted_s,
                ..
            } if ours(stimulus) => {
                offset = Some(e.t_host_us);
                phases += 1;
                presented += presented_s;
                muted += muted_s;
                match device_presented_s {
                    Some(d) => device += d,
                    None => device_known = false,
                }
            }
            EventKind::Mute { .. } => mutes += 1,
            EventKind::Switch { to, latency_ms, .. } if ours(to) => {
                switch = Some(*latency_ms);
            }
            _ => {}
        }
    }
    let mut r = expect.row(t);
    let mut set = |name: &str, v: Option<String>| r.set(name, v.unwrap_or_default());
    set("steps", timing.map(|x| x.steps.to_string()));
    set("dwell_us", timing.map(|x| format!("{:.3}", x.dwell_us)));
    set("freq_hz", timing.map(|x| format!("{:.4}", x.freq_hz)));
    set("step_mm", timing.map(|x| format!("{:.4}", x.step_mm)));
    set("onset_us", onset.map(|v| v.to_string()));
    set("offset_us", offset.map(|v| v.to_string()));
    set(
        "device_presented_s",
        (phases > 0 && device_known).then(|| format!("{device:.4}")),
    );
    set("presented_s", Some(format!("{presented:.4}")));
    set(
        "present_fraction",
        (presented > 0.0).then(|| format!("{:.4}", (1.0 - muted / presented).clamp(0.0, 1.0))),
    );
    set("on_phases", Some(phases.to_string()));
    set("mutes", Some(mutes.to_string()));
    set("switch_ms", switch.map(|v| format!("{v:.3}")));
    set(columns::TIME_UTC, Some(health.time_utc.clone()));
    set(
        columns::MISSED_DEADLINES,
        health.missed_deadlines.map(|v| v.to_string()),
    );
    set(
        columns::LEASE_EXPIRIES,
        health.lease_expiries.map(|v| v.to_string()),
    );
    for a in given {
        r.set(&a.column, a.value.as_str());
        r.set(&columns::rt_column(&a.column), format!("{:.3}", a.rt_s));
    }
    let taken = given.len() + procedure.map_or(0, |p| p.answers());
    r.set(columns::ANSWERS, taken.to_string());
    if let Some(p) = procedure {
        p.record(&mut r);
    }
    (r, presented)
}
