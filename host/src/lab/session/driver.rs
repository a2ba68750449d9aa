//! The one driver of a [`Session`], shared by `lmhost session`
//! ([`super::serve`]) and `lmhost study`: each [`Driver::turn`] feeds the
//! finger samples that are due, polls the session and hands back its
//! events; [`Driver::next_wake`] says when the next turn is due (the
//! session's own deadlines, the synthetic finger's next sample), so the
//! caller waits on its own input (commands, answers) until then and no
//! longer. Time is the session's [`Clock`]: on a manual clock a test runs
//! a whole presentation without sleeping.

use std::time::Duration;

use super::{Event, OffsetReason, Session};
use crate::clock::Clock;
use crate::sense::reader::Next;
use crate::sense::stream::Sample;
use crate::sense::stream::filter::Filter;
use crate::sense::stream::intake::Intake;
use crate::sense::stream::run::Feed;
use crate::sense::stream::synthetic::FingerTrack;

/// Where the finger comes from.
pub enum Finger {
    /// No finger source: only untracked presentations are taken.
    None,
    /// A synthetic finger resting at the scene's centre (with a tracker's
    /// noise and drift), sampled at 90 Hz on the session's clock.
    Synthetic,
    /// Samples from a feed (a reader thread over a file, stdin, UDP, a
    /// depth camera's tracker), through the plausibility gate of `Intake`
    /// (its live arrivals read on the session's clock).
    Samples(Box<dyn Feed>, Intake),
}

enum Source {
    None,
    Synthetic {
        samples: Box<dyn Iterator<Item = Sample>>,
        t0_us: u64,
        next: Option<Sample>,
    },
    Samples {
        feed: Box<dyn Feed>,
        intake: Intake,
        ended: bool,
    },
}

/// How long a turn may wait while a samples feed is open: the feed's
/// samples arrive on a thread of their own, so the loop looks at least
/// this often (a depth camera's frame is 11 ms).
pub const FEED_WAIT: Duration = Duration::from_millis(1);

/// A session with its finger source, turned by the caller's loop.
pub struct Driver {
    session: Session,
    clock: Clock,
    source: Source,
    filter: Box<dyn Filter>,
    /// Whether the synthetic finger touches (a study lifts it between
    /// trials).
    touching: bool,
    /// The newest finger sent to the session since
    /// [`take_finger`](Self::take_finger) (`Some(None)`: lifted), for an
    /// observer such as the live view.
    sent: Option<Option<[f64; 3]>>,
}

impl Driver {
    /// Drives `session` with `finger` through `filter`. The session takes
    /// tracked presentations only with a finger source.
    pub fn new(mut session: Session, finger: Finger, filter: Box<dyn Filter>) -> Self {
        let clock = session.clock().clone();
        session.set_finger_source(!matches!(finger, Finger::None));
        let source = match finger {
            Finger::None => Source::None,
            Finger::Synthetic => {
                let track = FingerTrack {
                    center_mm: session.scene().center_mm,
                    away_s: None,
                    ..FingerTrack::default()
                };
                Source::Synthetic {
                    samples: Box::new(track.samples()),
                    t0_us: clock.now_us(),
                    next: None,
                }
            }
            Finger::Samples(feed, intake) => Source::Samples {
                feed,
                intake: intake.on_clock(clock.clone()),
                ended: false,
            },
        };
        Self {
            session,
            clock,
            source,
            filter,
            touching: true,
            sent: None,
        }
    }

    /// The synthetic finger starts off the array (until
    /// [`touch`](Self::touch)).
    pub fn lifted(mut self) -> Self {
        self.touching = false;
        self
    }

    /// The session.
    pub fn session(&mut self) -> &mut Session {
        &mut self.session
    }

    /// The session, read only.
    pub fn session_ref(&self) -> &Session {
        &self.session
    }

    /// Gives the session back (to close it).
    pub fn into_session(self) -> Session {
        self.session
    }

    /// Closes the session ([`Session::close`]), its `closed` event with
    /// what the finger source's gate read and dropped.
    pub fn close(self, reason: OffsetReason) -> Vec<Event> {
        let finger = match &self.source {
            Source::Samples { intake, .. } => Some(intake.counts().snapshot()),
            _ => None,
        };
        self.session.close_counted(reason, finger)
    }

    /// Whether the samples feed has ended (no more finger samples come).
    pub fn feed_ended(&self) -> bool {
        matches!(self.source, Source::Samples { ended: true, .. })
    }

    /// Puts the synthetic finger on the array (samples from now on) or
    /// lifts it (no finger at once); other sources ignore it.
    pub fn touch(&mut self, on: bool) -> anyhow::Result<()> {
        if !matches!(self.source, Source::Synthetic { .. }) || self.touching == on {
            return Ok(());
        }
        self.touching = on;
        if on {
            self.track_now()
        } else {
            self.sent = Some(None);
            self.session.finger(None)
        }
    }

    /// The newest finger sample sent since the last call (`Some(None)`:
    /// no finger), or `None` when nothing was sent.
    pub fn take_finger(&mut self) -> Option<Option<[f64; 3]>> {
        self.sent.take()
    }

    /// Whether the finger is the synthetic one.
    pub fn synthetic(&self) -> bool {
        matches!(self.source, Source::Synthetic { .. })
    }

    /// Sends the synthetic finger's next sample now rather than at its
    /// time (a new play forgets the centroids before it).
    pub fn track_now(&mut self) -> anyhow::Result<()> {
        if let Source::Synthetic { t0_us, next, .. } = &mut self.source
            && self.touching
        {
            let now = self.clock.now_us();
            let t = next.as_ref().map_or(0.0, |s| s.t_s);
            *t0_us = (*t0_us).min(now.saturating_sub((t * 1e6) as u64));
        }
        self.feed()
    }

    /// One turn: the finger samples due, the session's timelines and
    /// housekeeping; returns the events since the last turn.
    pub fn turn(&mut self) -> anyhow::Result<Vec<Event>> {
        self.feed()?;
        self.session.poll()?;
        Ok(self.session.drain_events())
    }

    /// When the next turn is due (session clock, µs).
    pub fn next_wake(&self) -> u64 {
        let at = self.session.poll_at();
        match &self.source {
            Source::Synthetic {
                next: Some(s),
                t0_us,
                ..
            } => at.min(t0_us + (s.t_s * 1e6) as u64),
            Source::Samples { ended: false, .. } => {
                at.min(self.clock.now_us() + FEED_WAIT.as_micros() as u64)
            }
            _ => at,
        }
    }

    /// How long from now until the next turn, at most `max`.
    pub fn wait_time(&self, max: Duration) -> Duration {
        let now = self.clock.now_us();
        Duration::from_micros(self.next_wake().saturating_sub(now)).min(max)
    }

    /// Waits (or, on a manual clock, moves time on) until the next turn,
    /// at most `max`.
    pub fn wait(&self, max: Duration) {
        self.clock.sleep(self.wait_time(max));
    }

    /// Sends the newest filtered sample due (only the newest matters to
    /// the device).
    fn feed(&mut self) -> anyhow::Result<()> {
        let mut last = None;
        match &mut self.source {
            Source::None => {}
            Source::Synthetic {
                samples,
                t0_us,
                next,
            } => {
                let t = self.clock.now_us().saturating_sub(*t0_us) as f64 / 1e6;
                while let Some(s) = next.take().or_else(|| samples.next()) {
                    if s.t_s > t {
                        *next = Some(s);
                        break;
                    }
                    if self.touching {
                        last = Some(self.filter.update(&s));
                    }
                }
            }
            Source::Samples {
                feed,
                intake,
                ended,
            } => {
                // Only what the gate lets through reaches the filter.
                while !*ended {
                    match intake.next(&mut **feed, Duration::ZERO) {
                        Next::Ready(s) => last = Some(self.filter.update(&s?)),
                        Next::Idle => break,
                        Next::End => *ended = true,
                    }
                }
            }
        }
        match last {
            Some(p) => {
                self.sent = Some(p);
                self.session.finger(p)
            }
            None => Ok(()),
        }
    }
}
