//! Experiment 3 with its instruments (`study run --stage --gauge`), as the
//! paper ran it: the stage pushes the force gauge into the other finger
//! pad to the depth the method of adjustment holds, the LM stimulus plays
//! one on-phase (2 s), stops, and the stage returns to rest; then it pushes
//! again, at a new depth once the participant has answered, at the same
//! one after the off-phase if not. On "same" (or after the last
//! adjustment) the stage pushes once more and the gauge records the
//! on-phase; the median of that series is the trial's `force_n`, the
//! series itself goes beside `trials.csv`.
//!
//! The instruments run on a thread of their own, told what to do by
//! commands and answering by reports, so a slow serial reply never delays
//! the session's loop (the device's deadlines, the on/off timing, the
//! answers). A move or reading that fails ends the thread's work: it says
//! so at once (the runner silences the array at its next turn and ends
//! the run), then stops the stage and sends it back to rest, and says how
//! that went.

use std::collections::VecDeque;
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::thread::JoinHandle;
use std::time::Duration;

use super::Runner;
use super::answers::Asked;
use super::procedure::Procedure;
use crate::clock::monotonic_us;
use crate::device::instruments::stage::{move_timeout, retreat};
use crate::device::instruments::{
    FingerPad, GaugeOptions, Series, StageOptions, StagePort, open_rig,
};
use crate::error::{InputError, one_line};
use crate::lab::session::{EventKind, Present};
use crate::limits::show;

/// The gauge's sampling rate while it records, Hz.
pub const RATE_HZ: f64 = crate::device::instruments::gauge::DEFAULT_RATE_HZ;
/// Added to a move's own timeout when the runner waits for the thread
/// (the thread times the move; this only guards a thread that hangs).
const SLACK: Duration = Duration::from_secs(5);

/// The instruments of a run.
#[derive(Debug, Clone)]
pub struct PushOptions {
    /// The stage (`sim`, `sim:fail-after=N`, or a serial port).
    pub stage: StageOptions,
    /// The gauge (`sim` or a serial port).
    pub gauge: GaugeOptions,
    /// Stage position where the probe's face touches the finger pad, mm:
    /// a depth `d` is the position `contact_mm + d`.
    pub contact_mm: f64,
    /// Stage position between pushes, mm (at most `contact_mm`: clear of
    /// the pad, or just touching it).
    pub rest_mm: f64,
}

impl PushOptions {
    /// Refuses positions the stage may not reach: rest beyond contact,
    /// rest or the deepest push (`contact + max_depth_mm`) outside the
    /// soft limits. Before anything opens.
    pub fn check(&self, max_depth_mm: f64) -> Result<(), InputError> {
        let l = self.stage.limits;
        let inside = |mm: f64| mm.is_finite() && (l.min_mm..=l.max_mm).contains(&mm);
        if !(self.contact_mm.is_finite() && self.rest_mm.is_finite()) {
            return Err(InputError::new(
                "--contact and --rest must be finite positions (mm)",
            ));
        }
        if self.rest_mm > self.contact_mm {
            return Err(InputError::new(format!(
                "--rest {} mm is past --contact {} mm: at rest the probe would push the finger",
                show(self.rest_mm),
                show(self.contact_mm)
            )));
        }
        for (what, mm) in [
            ("--rest", self.rest_mm),
            (
                "the deepest push (--contact + the protocol's max_mm)",
                self.contact_mm + max_depth_mm,
            ),
        ] {
            if !inside(mm) {
                return Err(InputError::new(format!(
                    "{what} at {} mm is outside the stage's soft limits {}..={} mm",
                    show(mm),
                    show(l.min_mm),
                    show(l.max_mm)
                )));
            }
        }
        Ok(())
    }

    /// What the run record says of them.
    pub fn describe(&self) -> String {
        let stage = match StagePort::parse(&self.stage.port) {
            Ok(StagePort::Sim(Some(n))) => format!("simulated stage (silent after {n} moves)"),
            Ok(StagePort::Sim(None)) => "simulated stage".into(),
            _ => format!("stage on {}", self.stage.port),
        };
        format!(
            "{stage}, gauge on {}, contact {} mm, rest {} mm, {} mm/s",
            self.gauge.port,
            show(self.contact_mm),
            show(self.rest_mm),
            show(self.stage.speed_mm_s)
        )
    }
}

enum Cmd {
    /// Move to this stage position, mm.
    To(f64),
    /// Record the gauge for this long, s.
    Sample(f64),
    /// Back to rest, and end.
    Quit,
}

enum Report {
    /// Opened and at rest, or why not.
    Opened(anyhow::Result<()>),
    /// A move finished.
    At,
    /// A recording.
    Series(Series),
    /// A move or reading failed (said before the recovery starts).
    Failed(String),
    /// The thread's last word: where the stage ended.
    Ended(String),
}

/// An instrument failed mid-trial.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct InstrumentFailed(pub String);

/// The runner's handle on the instruments' thread.
pub struct Pusher {
    tx: Sender<Cmd>,
    rx: Receiver<Report>,
    join: Option<JoinHandle<()>>,
    inbox: VecDeque<Report>,
    /// Stage position of contact, mm.
    pub contact_mm: f64,
    /// Stage position at rest, mm.
    pub rest_mm: f64,
    /// The longest a move may take.
    longest: Duration,
}

impl std::fmt::Debug for Pusher {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Pusher")
    }
}

impl Pusher {
    /// Opens the stage and gauge on their thread and sends the stage to
    /// rest; returns once it is there.
    pub fn start(o: PushOptions) -> anyhow::Result<Self> {
        let (tx, cmds) = mpsc::channel();
        let (reports, rx) = mpsc::channel();
        let longest = move_timeout(o.stage.limits.span_mm(), o.stage.speed_mm_s) + SLACK;
        let (contact_mm, rest_mm) = (o.contact_mm, o.rest_mm);
        let join = std::thread::Builder::new()
            .name("lmhost-instruments".into())
            .spawn(move || serve(o, cmds, reports))?;
        let p = Self {
            tx,
            rx,
            join: Some(join),
            inbox: VecDeque::new(),
            contact_mm,
            rest_mm,
            longest,
        };
        match p.rx.recv_timeout(longest) {
            Ok(Report::Opened(r)) => r.map(|()| p),
            Ok(Report::Failed(why)) => {
                let ended = p.finish();
                anyhow::bail!("the instruments: {why} ({ended})")
            }
            _ => anyhow::bail!(
                "the instruments did not report within {} s of opening",
                show(longest.as_secs_f64())
            ),
        }
    }

    fn send(&self, c: Cmd) -> anyhow::Result<()> {
        self.tx
            .send(c)
            .map_err(|_| InstrumentFailed("the instruments' thread ended".into()).into())
    }

    /// Takes what the thread said; a failure is the error (the caller
    /// ends the run, which silences the array).
    pub(super) fn check(&mut self) -> anyhow::Result<()> {
        loop {
            match self.rx.try_recv() {
                Ok(Report::Failed(why)) => return Err(InstrumentFailed(why).into()),
                Ok(r) => self.inbox.push_back(r),
                Err(mpsc::TryRecvError::Empty) => return Ok(()),
                Err(mpsc::TryRecvError::Disconnected) => {
                    return Err(InstrumentFailed("the instruments' thread ended".into()).into());
                }
            }
        }
    }

    fn take_at(&mut self) -> bool {
        let i = self.inbox.iter().position(|r| matches!(r, Report::At));
        i.and_then(|i| self.inbox.remove(i)).is_some()
    }

    fn take_series(&mut self) -> Option<Series> {
        let i = self
            .inbox
            .iter()
            .position(|r| matches!(r, Report::Series(_)))?;
        match self.inbox.remove(i) {
            Some(Report::Series(s)) => Some(s),
            _ => None,
        }
    }

    /// Ends the thread: the stage back at rest (or, after a failure, the
    /// recovery it made); says where the stage ended.
    pub fn finish(mut self) -> String {
        let _ = self.tx.send(Cmd::Quit);
        let deadline = std::time::Instant::now() + 2 * self.longest;
        let said = loop {
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            match self.rx.recv_timeout(left) {
                Ok(Report::Ended(s)) => break s,
                Ok(_) => {}
                Err(RecvTimeoutError::Timeout) => {
                    break "the stage did not report where it stopped".to_owned();
                }
                Err(RecvTimeoutError::Disconnected) => {
                    break "the stage is where it stopped".to_owned();
                }
            }
        };
        if let Some(j) = self.join.take() {
            let _ = j.join();
        }
        said
    }
}

/// The instruments' thread: opens them, then does what it is told until
/// told to end (or the runner is gone), then returns the stage to rest.
fn serve(o: PushOptions, cmds: Receiver<Cmd>, tx: Sender<Report>) {
    let pad = FingerPad::TYPICAL.at(o.contact_mm);
    let (mut stage, mut gauge) = match open_rig(&o.stage, &o.gauge, pad) {
        Ok(x) => x,
        Err(e) => {
            let _ = tx.send(Report::Opened(Err(e)));
            return;
        }
    };
    let mut work = || -> Result<(), String> {
        let fail = |what: String, e: &dyn std::fmt::Display| format!("{what}: {e}");
        stage
            .move_to(o.rest_mm)
            .map_err(|e| fail(format!("moving to rest at {} mm", show(o.rest_mm)), &e))?;
        let _ = tx.send(Report::Opened(Ok(())));
        while let Ok(c) = cmds.recv() {
            match c {
                Cmd::To(mm) => {
                    stage
                        .move_to(mm)
                        .map_err(|e| fail(format!("moving to {} mm", show(mm)), &e))?;
                    let _ = tx.send(Report::At);
                }
                Cmd::Sample(hold_s) => {
                    let s = gauge
                        // At least one reading in a short (scaled) hold.
                        .sample(
                            hold_s,
                            RATE_HZ.max(
                                (1.0 / hold_s).min(crate::device::instruments::gauge::MAX_RATE_HZ),
                            ),
                        )
                        .map_err(|e| fail("recording the gauge".into(), &e))?;
                    let _ = tx.send(Report::Series(s));
                }
                Cmd::Quit => break,
            }
        }
        Ok(())
    };
    let failed = work().err();
    if let Some(why) = &failed {
        let _ = tx.send(Report::Failed(why.clone()));
    }
    // A stage that does not answer is not waited for twice.
    // Back to rest also after Ctrl-C (`retreat` does not heed it).
    let back = if failed.is_some() {
        stage
            .stop()
            .and_then(|()| retreat(stage.as_mut(), o.rest_mm))
    } else {
        retreat(stage.as_mut(), o.rest_mm)
    };
    let _ = tx.send(Report::Ended(match back {
        Ok(m) => format!("stage back at rest at {} mm", show(m.at_mm)),
        Err(e) => format!(
            "stage NOT back at rest: {}",
            one_line(&anyhow::Error::new(e))
        ),
    }));
}

/// A question asked once an on-phase at a depth ended, and its answer once
/// given (s after asking).
struct Pending {
    q: Asked,
    at_us: u64,
    got: Option<(String, f64)>,
}

/// A trial's recording: the series and the on-phase's onset, µs.
pub(super) struct Measured {
    pub series: Series,
    pub onset_us: u64,
}

impl Measured {
    /// The series as CSV: seconds from the onset of the on-phase it was
    /// recorded in, force in N.
    pub fn csv(&self) -> String {
        let mut s = String::from("t_s,force_n\n");
        for r in &self.series.samples {
            let t = (r.at_us as i64 - self.onset_us as i64) as f64 / 1e6;
            s.push_str(&format!("{t:.4},{:.4}\n", r.force_n));
        }
        s
    }
}

impl Runner {
    fn pusher(&mut self) -> &mut Pusher {
        self.pusher.as_mut().expect("pushes run with instruments")
    }

    /// One turn of the loop while the instruments work: the session, then
    /// a pending question's answer if one is given.
    fn turn_asking(&mut self, pending: &mut Option<Pending>) -> anyhow::Result<()> {
        self.tick()?;
        if let Some(p) = pending.as_mut()
            && p.got.is_none()
            && let Some(a) = self.answers.poll(&p.q)?
        {
            p.got = Some((a, monotonic_us().saturating_sub(p.at_us) as f64 / 1e6));
        }
        self.pause();
        Ok(())
    }

    /// Turns the loop until the stage reports a finished move.
    fn reached(&mut self, pending: &mut Option<Pending>) -> anyhow::Result<()> {
        while !self.pusher().take_at() {
            self.turn_asking(pending)?;
        }
        Ok(())
    }

    /// The method of adjustment with the stage and gauge (module docs):
    /// pushes until the procedure ends, then records. `rts` gets each
    /// answer's response time, s.
    pub(super) fn pushes(
        &mut self,
        pr: &mut dyn Procedure,
        req: &Present,
        off_s: f64,
        trial: usize,
        rts: &mut Vec<f64>,
    ) -> anyhow::Result<Measured> {
        let on_s = req.on_s.unwrap_or(0.0);
        let mut depth = pr.next().map_or(0.0, |p| p.level);
        let mut pending: Option<Pending> = None;
        loop {
            let record = pr.finished();
            let to = self.pusher().contact_mm + depth;
            self.pusher().send(Cmd::To(to))?;
            self.reached(&mut pending)?;
            let seen = self.trial_events.len();
            let asked_on = monotonic_us();
            self.session().present(req)?;
            self.driver().track_now()?;
            if record {
                self.pusher().send(Cmd::Sample(on_s))?;
            }
            while self.session().presenting() {
                self.turn_asking(&mut pending)?;
            }
            let onset_us = self.trial_events[seen..]
                .iter()
                .find(|e| matches!(e.kind, EventKind::Onset { .. }))
                .map_or(asked_on, |e| e.t_host_us);
            let offset_us = monotonic_us();
            if record {
                let series = loop {
                    if let Some(s) = self.pusher().take_series() {
                        break s;
                    }
                    self.turn_asking(&mut None)?;
                };
                let rest = self.pusher().rest_mm;
                self.pusher().send(Cmd::To(rest))?;
                self.reached(&mut None)?;
                return Ok(Measured { series, onset_us });
            }
            let rest = self.pusher().rest_mm;
            self.pusher().send(Cmd::To(rest))?;
            if pending.is_none() {
                pending = Some(Pending {
                    q: pr.asked(),
                    at_us: offset_us,
                    got: None,
                });
            }
            // Back at rest; then on at once when answered, else after the
            // off-phase at the same depth (the paper's automatic repeat).
            self.reached(&mut pending)?;
            let off_until = offset_us + (off_s * 1e6) as u64;
            while pending.as_ref().is_some_and(|p| p.got.is_none()) && monotonic_us() < off_until {
                self.turn_asking(&mut pending)?;
            }
            if let Some((ans, rt)) = pending.as_mut().and_then(|p| p.got.take()) {
                pending = None;
                rts.push(rt);
                if let Some(level) = self.answered(pr, trial, &ans)? {
                    depth = level;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::instruments::{SIM, StageLimits};

    fn options(stage: &str) -> PushOptions {
        PushOptions {
            stage: StageOptions {
                port: stage.into(),
                ..StageOptions::twin(StageLimits::new(0.0, 20.0).unwrap(), 50.0, "--stage-")
            },
            gauge: GaugeOptions::twin("--gauge-"),
            contact_mm: 5.0,
            rest_mm: 4.0,
        }
    }

    fn wait_for(p: &mut Pusher, want: fn(&Report) -> bool) -> Report {
        let t0 = std::time::Instant::now();
        loop {
            p.check().unwrap();
            if let Some(i) = p.inbox.iter().position(want) {
                return p.inbox.remove(i).unwrap();
            }
            assert!(t0.elapsed() < Duration::from_secs(10), "no report");
            std::thread::sleep(Duration::from_millis(2));
        }
    }

    #[test]
    fn positions_are_checked_against_the_limits_and_depths() {
        let o = options(SIM);
        assert!(o.check(10.0).is_ok());
        let e = o.check(16.0).unwrap_err().to_string();
        assert!(e.contains("the deepest push") && e.contains("21 mm"), "{e}");
        let e = PushOptions {
            rest_mm: 6.0,
            ..o.clone()
        }
        .check(1.0)
        .unwrap_err();
        assert!(e.to_string().contains("past --contact"), "{e}");
        let e = PushOptions {
            contact_mm: f64::NAN,
            ..o
        }
        .check(1.0)
        .unwrap_err();
        assert!(e.to_string().contains("finite"), "{e}");
    }

    #[test]
    fn the_thread_pushes_records_and_returns_to_rest() {
        let mut p = Pusher::start(options(SIM)).unwrap();
        p.send(Cmd::To(7.0)).unwrap();
        wait_for(&mut p, |r| matches!(r, Report::At));
        p.send(Cmd::Sample(0.1)).unwrap();
        let Report::Series(s) = wait_for(&mut p, |r| matches!(r, Report::Series(_))) else {
            unreachable!()
        };
        assert_eq!(s.samples.len(), 5);
        let want = FingerPad::TYPICAL.force_at_depth_n(2.0);
        let got = s.median_n().unwrap();
        assert!((got - want).abs() < 0.03, "{got} vs {want}");
        let m = Measured {
            series: s,
            onset_us: 0,
        };
        assert!(m.csv().starts_with("t_s,force_n\n"));
        assert_eq!(m.csv().lines().count(), 6);
        assert_eq!(p.finish(), "stage back at rest at 4 mm");
    }

    #[test]
    fn a_silent_stage_is_a_failure_then_a_recovery_report() {
        // The move to rest is the first; the push starts, then silence.
        let mut p = Pusher::start(options("sim:fail-after=1")).unwrap();
        p.send(Cmd::To(7.0)).unwrap();
        let t0 = std::time::Instant::now();
        let err = loop {
            if let Err(e) = p.check() {
                break e;
            }
            assert!(t0.elapsed() < Duration::from_secs(10), "no failure");
            std::thread::sleep(Duration::from_millis(2));
        };
        assert!(err.is::<InstrumentFailed>());
        let line = one_line(&err);
        assert!(
            line.starts_with("moving to 7 mm: sim-stage: no reply"),
            "{line}"
        );
        let end = p.finish();
        assert!(
            end.starts_with("stage NOT back at rest: sim-stage"),
            "{end}"
        );
    }
}
