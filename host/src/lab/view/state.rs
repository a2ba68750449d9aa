//! The view's shared state: the newest frame (raw and encoded), what the
//! session reports, the participant's question and answer, the figures;
//! and the threads that feed it (the encoder, the synthetic renderer).

use std::collections::VecDeque;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::Duration;

use super::draw::{self, Overlay};
use crate::clock::{Spread, monotonic_us};
use crate::geom::{Vec3, add, scale};
use crate::lab::session::{Event, EventKind, Gate};
use crate::plan::sequence::Plan;
use crate::sense::track::colour::ColourImage;
use crate::sense::track::synth_colour::ColourSim;

/// A stimulus as the view draws it.
#[derive(Debug, Clone)]
pub struct Stimulus {
    /// Library id (never shown to the participant).
    pub id: String,
    /// Its radius A (mm).
    pub radius_mm: f64,
    /// Where it was planned (scene, mm).
    pub planned_mm: Vec3,
    /// Its foci per step (scene, mm, about `planned_mm`).
    pub foci_mm: Vec<Vec<Vec3>>,
    /// Step dwell (s).
    pub dwell_s: f64,
    /// The plan (for its pressure map on request).
    pub plan: Arc<Plan>,
}

/// A frame encoded for the browsers.
pub struct Encoded {
    /// Frame number (1, 2, ...).
    pub seq: u64,
    /// The JPEG.
    pub jpeg: Vec<u8>,
    /// Its size.
    pub width: u32,
    /// Its size.
    pub height: u32,
}

/// Experiment 2's circle radii (mm): the paper's stimulus radii.
pub const EXPERIMENT2_RADII_MM: [f64; 5] = [2.0, 3.0, 4.0, 5.0, 6.0];

/// What the participant is asked.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Question {
    /// Changes with every question asked.
    pub seq: u64,
    /// The prompt.
    pub prompt: String,
    /// The answers to pick from, in order.
    pub options: Vec<String>,
    /// The circles' radii (mm) when every option is one (Experiment 2).
    pub radii_mm: Option<Vec<f64>>,
    /// The "not perceived" button's label, where the protocol allows the
    /// answer; the page sends it as [`NOT_PERCEIVED`].
    pub not_perceived: Option<String>,
}

/// The choice a "not perceived" answer is sent as (the study records it
/// as such: `columns::NOT_PERCEIVED`).
pub const NOT_PERCEIVED: &str = "na";

impl Question {
    /// Whether `choice` is an answer the page offers: one of the options,
    /// or "not perceived" where the question allows it.
    pub fn offers(&self, choice: &str) -> bool {
        self.options.iter().any(|o| o == choice)
            || (self.not_perceived.is_some() && choice == NOT_PERCEIVED)
    }
}

/// What the view measured: frames encoded, and from each frame reaching
/// the view to a browser saying it drew it (the browser's
/// acknowledgement included: an upper bound).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Figures {
    /// Frames encoded.
    pub frames: u64,
    /// JPEG encode time (ms).
    pub encode_ms: Option<Spread<f64>>,
    /// Frames drawn by browsers (acknowledged).
    pub drawn: u64,
    /// Latency, frame in → drawn (ms).
    pub latency_ms: Option<Spread<f64>>,
    /// Frames drawn per second, per browser page, over the last seconds.
    pub fps: Vec<f64>,
    /// Browser WebSocket connections now.
    pub clients: usize,
}

/// Latency samples kept (the last minute at 30 fps and 2 clients).
const SAMPLES: usize = 4096;
/// Event lines kept for a page that opens late.
const LOG_LINES: usize = 200;

#[derive(Default)]
pub(super) struct State {
    raw: Option<(ColourImage, u64)>,
    raw_seq: u64,
    pub(super) encoded: Option<Arc<Encoded>>,
    /// seq → time in, for the acknowledgements.
    arrivals: VecDeque<(u64, u64)>,
    finger_mm: Option<Vec3>,
    playing: Option<(usize, Gate, u64)>,
    pub(super) state: &'static str,
    pub(super) mute: Option<String>,
    pub(super) log: VecDeque<String>,
    pub(super) log_total: u64,
    pub(super) question: Option<Question>,
    answer: Option<(u64, String)>,
    /// The question last answered (0: none yet; questions count from 1).
    pub(super) answered: u64,
    encode_us: VecDeque<u64>,
    latency_us: VecDeque<u64>,
    /// Per page: acknowledgement times (host µs) of the last seconds.
    drawn_at: std::collections::BTreeMap<u64, VecDeque<u64>>,
    drawn: u64,
    pub(super) clients: usize,
    /// WebSocket connections made so far (each page's id for its figures).
    pub(super) pages: u64,
    pub(super) closed: bool,
}

/// Shared between the caller, the server's threads and the feeders.
pub struct Shared {
    pub(super) state: Mutex<State>,
    /// Signalled on a new raw frame, a new encoded frame, a new event, a
    /// question or the end.
    pub(super) changed: Condvar,
    pub(super) scene: draw::Scene,
    pub(super) stimuli: Vec<Stimulus>,
    pub(super) token: String,
}

impl Shared {
    pub(super) fn new(scene: draw::Scene, stimuli: Vec<Stimulus>, token: String) -> Self {
        Self {
            state: Mutex::new(State {
                state: "idle",
                ..State::default()
            }),
            changed: Condvar::new(),
            scene,
            stimuli,
            token,
        }
    }

    pub(super) fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Waits for a change or `max`, whichever first; the guard back.
    pub(super) fn wait<'a>(
        &self,
        g: MutexGuard<'a, State>,
        max: Duration,
    ) -> MutexGuard<'a, State> {
        self.changed
            .wait_timeout(g, max)
            .map(|(g, _)| g)
            .unwrap_or_else(|e| e.into_inner().0)
    }

    pub(super) fn close(&self) {
        self.lock().closed = true;
        self.changed.notify_all();
    }

    pub(super) fn push(&self, img: ColourImage) {
        let mut s = self.lock();
        s.raw_seq += 1;
        s.raw = Some((img, monotonic_us()));
        drop(s);
        self.changed.notify_all();
    }

    pub(super) fn finger(&self, pos_mm: Option<Vec3>) {
        self.lock().finger_mm = pos_mm;
    }

    pub(super) fn events(&self, events: &[Event]) {
        if events.is_empty() {
            return;
        }
        let mut s = self.lock();
        for e in events {
            match &e.kind {
                EventKind::Onset { stimulus, gate, .. } => {
                    s.playing = self
                        .stimuli
                        .iter()
                        .position(|x| &x.id == stimulus)
                        .map(|i| (i, *gate, e.t_host_us));
                    s.state = "playing";
                    s.mute = None;
                }
                EventKind::Offset { .. } | EventKind::Closed { .. } => {
                    s.playing = None;
                    s.state = "idle";
                    s.mute = None;
                }
                EventKind::Mute { reason } => {
                    s.state = "muted";
                    s.mute = Some(reason.clone());
                }
                EventKind::Unmute => {
                    s.state = "playing";
                    s.mute = None;
                }
                _ => {}
            }
            if let Ok(line) = serde_json::to_string(e) {
                s.log.push_back(line);
                s.log_total += 1;
                if s.log.len() > LOG_LINES {
                    s.log.pop_front();
                }
            }
        }
        drop(s);
        self.changed.notify_all();
    }

    /// Asks the participant (a new `seq` clears an earlier answer).
    pub(super) fn ask(&self, q: Option<Question>) {
        let mut s = self.lock();
        if s.question.as_ref().map(|x| x.seq) != q.as_ref().map(|x| x.seq) {
            s.answer = None;
        }
        s.question = q;
        drop(s);
        self.changed.notify_all();
    }

    /// The answer to question `seq`, once.
    pub(super) fn take_answer(&self, seq: u64) -> Option<String> {
        let mut s = self.lock();
        match &s.answer {
            Some((q, _)) if *q == seq => s.answer.take().map(|a| a.1),
            _ => None,
        }
    }

    /// The participant's choice for question `seq`: refused unless it is
    /// the question asked now, not answered yet, and one of its options.
    /// The first answer stands: a second click (or one from a page that
    /// has not yet heard the question is gone) never replaces it.
    pub(super) fn answer(&self, seq: u64, choice: &str) -> Result<(), String> {
        let mut s = self.lock();
        let Some(q) = &s.question else {
            return Err("no question is asked now".into());
        };
        if q.seq != seq {
            return Err(format!(
                "question {seq} is not the one asked now ({})",
                q.seq
            ));
        }
        if !q.offers(choice) {
            return Err("not one of the answers offered".into());
        }
        if s.answered == seq {
            return Err(format!("question {seq} is answered already"));
        }
        s.answered = seq;
        s.answer = Some((seq, choice.to_owned()));
        Ok(())
    }

    /// The centre the device plays now (scene, mm), if something plays.
    fn centre(&self, s: &State) -> Option<(Vec3, &Stimulus)> {
        let (i, gate, _) = s.playing?;
        let st = &self.stimuli[i];
        let c = match (gate, s.finger_mm) {
            (Gate::Tracked, Some(f)) => f,
            _ => st.planned_mm,
        };
        Some((c, st))
    }

    /// The overlay now; `participant` leaves out what would name the
    /// stimulus (its orbit and foci) and draws the question's circles.
    pub(super) fn overlay(&self, s: &State, participant: bool) -> Overlay {
        let playing = self.centre(s);
        let radii = s
            .question
            .as_ref()
            .and_then(|q| q.radii_mm.clone())
            .unwrap_or_else(|| EXPERIMENT2_RADII_MM.to_vec());
        if participant {
            return self
                .scene
                .overlay(playing.map(|p| p.0), 0.0, &[], None, &radii);
        }
        let (centre, radius, foci) = match (playing, s.playing) {
            (Some((c, st)), Some((_, _, onset))) => {
                let steps = st.foci_mm.len().max(1);
                let step = ((monotonic_us().saturating_sub(onset) as f64
                    / 1e6
                    / st.dwell_s.max(1e-6)) as usize)
                    % steps;
                let foci = st
                    .foci_mm
                    .get(step)
                    .map(|f| {
                        f.iter()
                            .map(|p| draw::Scene::moved(*p, st.planned_mm, c))
                            .collect::<Vec<_>>()
                    })
                    .unwrap_or_default();
                (Some(c), st.radius_mm, foci)
            }
            _ => (None, 0.0, Vec::new()),
        };
        self.scene.overlay(centre, radius, &foci, s.finger_mm, &[])
    }

    /// The newest raw frame with the overlay drawn on it (`radius_mm`:
    /// the participant's circle of that radius; else the experimenter's).
    pub(super) fn snapshot(&self, radius_mm: Option<f64>) -> Option<(Vec<u8>, u32, u32)> {
        let s = self.lock();
        let (img, _) = s.raw.as_ref()?;
        let (w, h) = (img.width, img.height);
        let mut rgb = img.rgb.as_ref().clone();
        let o = match radius_mm {
            Some(r) => {
                let c = self.centre(&s).map(|p| p.0);
                self.scene.overlay(c, 0.0, &[], None, &[r])
            }
            None => self.overlay(&s, false),
        };
        drop(s);
        draw::Canvas {
            rgb: &mut rgb,
            width: w,
            height: h,
        }
        .overlay(&o);
        Some((rgb, w, h))
    }

    /// The playing stimulus's plan, for its pressure map.
    pub(super) fn playing_plan(&self) -> Option<Arc<Plan>> {
        let s = self.lock();
        s.playing.map(|(i, _, _)| self.stimuli[i].plan.clone())
    }

    /// A browser page drew frame `seq`.
    pub(super) fn drawn(&self, page: u64, seq: u64) {
        let now = monotonic_us();
        let mut s = self.lock();
        let Some(&(_, at)) = s.arrivals.iter().find(|(q, _)| *q == seq) else {
            return;
        };
        push_bounded(&mut s.latency_us, now.saturating_sub(at));
        s.drawn += 1;
        note_drawn(&mut s.drawn_at, page, now);
    }

    pub(super) fn figures(&self) -> Figures {
        let s = self.lock();
        Figures {
            frames: s.encoded.as_ref().map_or(0, |e| e.seq),
            encode_ms: Spread::of(s.encode_us.iter().copied()).map(Spread::ms),
            drawn: s.drawn,
            latency_ms: Spread::of(s.latency_us.iter().copied()).map(Spread::ms),
            fps: s
                .drawn_at
                .values()
                .filter(|t| t.len() > 1)
                .map(|t| (t.len() - 1) as f64 / ((t[t.len() - 1] - t[0]) as f64 / 1e6).max(1e-6))
                .collect(),
            clients: s.clients,
        }
    }
}

/// Most pages whose frame rate the view keeps: page ids come from the
/// clients (with the token), so a client naming a new one per request
/// would otherwise grow the map for as long as it asks.
const MAX_PAGES: usize = 64;
/// Most acknowledgements kept per page: three seconds of a 240 Hz screen,
/// with room; a client acknowledging faster is counted on the newest ones.
const MAX_DRAWS_PER_PAGE: usize = 1024;
/// How long (µs) a page's acknowledgements count for its frame rate.
const DRAWN_WINDOW_US: u64 = 3_000_000;

/// Notes that `page` drew a frame at `now` (µs): its times of the last
/// [`DRAWN_WINDOW_US`], at most [`MAX_DRAWS_PER_PAGE`], and at most
/// [`MAX_PAGES`] pages (the one silent longest gives way to a new one).
fn note_drawn(pages: &mut std::collections::BTreeMap<u64, VecDeque<u64>>, page: u64, now: u64) {
    // Pages silent for a while are gone.
    pages.retain(|_, t| {
        t.back()
            .is_some_and(|&b| now.saturating_sub(b) < DRAWN_WINDOW_US)
    });
    if !pages.contains_key(&page) && pages.len() >= MAX_PAGES {
        let quietest = pages
            .iter()
            .min_by_key(|(_, t)| t.back().copied())
            .map(|(k, _)| *k);
        if let Some(k) = quietest {
            pages.remove(&k);
        }
    }
    let times = pages.entry(page).or_default();
    times.push_back(now);
    while times.len() > MAX_DRAWS_PER_PAGE
        || times
            .front()
            .is_some_and(|&t| now.saturating_sub(t) > DRAWN_WINDOW_US)
    {
        times.pop_front();
    }
}

fn push_bounded(v: &mut VecDeque<u64>, x: u64) {
    v.push_back(x);
    if v.len() > SAMPLES {
        v.pop_front();
    }
}

/// A fresh random token: 32 hex digits from the kernel's generator.
pub(super) fn new_token() -> anyhow::Result<String> {
    use std::io::Read as _;
    let mut b = [0u8; 16];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut b))
        .map_err(|e| anyhow::anyhow!("reading /dev/urandom: {}", crate::files::reason(&e)))?;
    Ok(b.iter().map(|x| format!("{x:02x}")).collect())
}

/// Encodes the newest raw frame whenever one comes (frames that arrive
/// while one is encoded are skipped: the newest wins).
pub(super) fn spawn_encoder(sh: Arc<Shared>) -> anyhow::Result<std::thread::JoinHandle<()>> {
    Ok(std::thread::Builder::new()
        .name("lmhost-view-enc".into())
        .spawn(move || {
            let mut done = 0;
            loop {
                let mut s = sh.lock();
                while !s.closed && s.raw_seq == done {
                    s = sh.wait(s, Duration::from_millis(200));
                }
                if s.closed {
                    return;
                }
                done = s.raw_seq;
                let Some((img, at)) = s.raw.clone() else {
                    continue;
                };
                drop(s);
                let t0 = monotonic_us();
                let Ok(jpeg) = draw::jpeg(&img.rgb, img.width, img.height) else {
                    continue;
                };
                let mut s = sh.lock();
                push_bounded(&mut s.encode_us, monotonic_us() - t0);
                s.arrivals.push_back((done, at));
                if s.arrivals.len() > 64 {
                    s.arrivals.pop_front();
                }
                s.encoded = Some(Arc::new(Encoded {
                    seq: done,
                    jpeg,
                    width: img.width,
                    height: img.height,
                }));
                drop(s);
                sh.changed.notify_all();
            }
        })?)
}

/// Renders the synthetic finger in colour at [`super::SYNTHETIC_FPS`]:
/// the pad's tip `rest_mm` behind the finger's centroid along the LM
/// plane's c axis (the finger comes from +c), no finger while absent.
pub(super) fn spawn_synthetic(
    sh: Arc<Shared>,
    sim: ColourSim,
    rest_mm: f64,
) -> anyhow::Result<std::thread::JoinHandle<()>> {
    Ok(std::thread::Builder::new()
        .name("lmhost-view-synth".into())
        .spawn(move || {
            let period_us = (1e6 / super::SYNTHETIC_FPS) as u64;
            let t0 = monotonic_us();
            let mut next = t0;
            loop {
                let (finger, closed) = {
                    let s = sh.lock();
                    (s.finger_mm, s.closed)
                };
                if closed {
                    return;
                }
                let tip = finger.map(|f| add(f, scale(sh.scene.plane.c, -rest_mm)));
                let mut rgb = Vec::new();
                sim.render(tip, &mut rgb);
                let now = monotonic_us();
                sh.push(ColourImage {
                    t_s: now.saturating_sub(t0) as f64 / 1e6,
                    width: sim.cam.pinhole.width,
                    height: sim.cam.pinhole.height,
                    rgb: Arc::new(rgb),
                });
                next += period_us;
                let now = monotonic_us();
                if next > now {
                    std::thread::sleep(Duration::from_micros(next - now));
                } else {
                    next = now;
                }
            }
        })?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drawn_pages_and_their_times_are_bounded() {
        let mut pages = std::collections::BTreeMap::new();
        // A client naming a new page per acknowledgement, 1 µs apart:
        // all within the window, so only the caps hold the map.
        for i in 0..100_000u64 {
            note_drawn(&mut pages, i, 1_000 + i);
        }
        assert_eq!(pages.len(), MAX_PAGES);
        // The newest pages are kept.
        assert!(pages.contains_key(&99_999) && !pages.contains_key(&0));
        // One page acknowledging a million times in the window.
        let mut one = std::collections::BTreeMap::new();
        for i in 0..1_000_000u64 {
            note_drawn(&mut one, 7, i);
        }
        assert_eq!(one[&7].len(), MAX_DRAWS_PER_PAGE);
        assert_eq!(one[&7].back(), Some(&999_999));
        // A page silent for the window is gone.
        note_drawn(&mut one, 8, 999_999 + DRAWN_WINDOW_US + 1);
        assert_eq!(one.keys().copied().collect::<Vec<_>>(), [8]);
    }
}
