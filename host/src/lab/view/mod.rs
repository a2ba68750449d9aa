//! The live view: a local web page beside a session or a study
//! (`--view ADDR`) that shows the finger's colour video with the stimulus
//! drawn on it, and Experiment 2's participant page (five videos with
//! circles of 2-6 mm; the click is the trial's answer).
//!
//! [`View::start`] serves [`server`] on its own threads; the caller's
//! loop tells it what happens ([`View::events`], [`View::finger`]) and
//! hands it colour frames ([`View::push_frame`], or the synthetic finger's
//! own renderer), and a study asks the participant through a
//! [`Participant`] handle (the study's answer source over it lives in
//! the study, `lab/study/live.rs`). The view never holds the caller up: frames
//! are encoded on a thread of their own (the newest wins), each browser
//! gets the newest frame when it has taken the ones before ([`feed`]: a
//! slow page draws fewer frames and is not dropped; a gone one is, and
//! the pages reconnect). Endpoints and pages: `lab/view/VIEW.md`.
//!
//! Where the circle goes: its centre is the corrected centre the device
//! plays (the finger's centroid while a tracked presentation plays, else
//! the scene's LM centre), its radius the stimulus's A (the participant's
//! radii on their page), in the scene's LM plane, projected through the
//! camera pose, the depth → colour extrinsics and the colour intrinsics
//! ([`crate::sense::track::overlay`]).

pub mod draw;
pub mod feed;
pub mod http;
pub mod server;
mod state;

use std::net::SocketAddr;
use std::sync::Arc;

use crate::geom::Vec3;
use crate::lab::session::{Event, Loaded};
use crate::plan::scene::Scene;
use crate::sense::track::camera::CameraSetup;
use crate::sense::track::colour::{ColourCamera, ColourImage};
use crate::sense::track::overlay::ColourView;
use crate::sense::track::synth::{FingerSim, background_of};
use crate::sense::track::synth_colour::ColourSim;
use state::Shared;
pub use state::{EXPERIMENT2_RADII_MM, Figures, NOT_PERCEIVED, Question, Stimulus};

/// The synthetic colour video's frame rate (Hz): the paper's view is a
/// camera's RGB stream, 30 fps.
pub const SYNTHETIC_FPS: f64 = 30.0;

/// Half the side of the participant's crop (mm in the LM plane): a finger
/// pad and the largest circle with room around it.
pub const CROP_HALF_MM: f64 = 12.0;

/// Most pages at once (their WebSockets); other connections are bounded
/// by [`http::MAX_CONNECTIONS`].
pub const MAX_CLIENTS: usize = 8;

/// Where the colour frames come from.
pub enum Frames {
    /// The synthetic finger rendered in colour at the finger's position,
    /// at [`SYNTHETIC_FPS`].
    Synthetic,
    /// Pushed by the caller ([`View::push_frame`]: a camera's or a
    /// replay's colour stream).
    Pushed,
}

/// What a view needs.
pub struct Options {
    /// Where to listen (127.0.0.1 by default in the CLI).
    pub addr: SocketAddr,
    /// The scene (its camera pose, LM plane and centre).
    pub scene: Scene,
    /// The colour camera (its extrinsics from the depth camera).
    pub colour: ColourCamera,
    /// The frames.
    pub frames: Frames,
    /// The library as planned for the device.
    pub stimuli: Vec<Stimulus>,
}

/// A running view; dropping it stops its threads.
pub struct View {
    shared: Arc<Shared>,
    addr: SocketAddr,
    token: String,
    threads: Vec<std::thread::JoinHandle<()>>,
}

impl View {
    /// Binds `opts.addr` and starts serving.
    pub fn start(opts: Options) -> anyhow::Result<View> {
        let setup = CameraSetup::of_scene_or_default(&opts.scene);
        let scene = draw::Scene {
            view: ColourView {
                pose: setup.camera,
                cam: opts.colour,
            },
            plane: opts.scene.lm_plane,
            center_mm: opts.scene.center_mm,
            crop_half_mm: CROP_HALF_MM,
        };
        let token = state::new_token()?;
        let shared = Arc::new(Shared::new(scene, opts.stimuli, token.clone()));
        let (listener, addr) = http::bind(opts.addr)?;
        let mut threads = vec![
            server::spawn(listener, shared.clone())?,
            state::spawn_encoder(shared.clone())?,
        ];
        if let Frames::Synthetic = opts.frames {
            let finger = FingerSim::new(
                setup,
                crate::sense::track::intrinsics::Intrinsics::D435_848X480,
                background_of(&opts.scene),
            );
            let sim = ColourSim::new(
                opts.colour,
                finger,
                opts.scene.center_mm,
                opts.scene.lm_plane,
            );
            threads.push(state::spawn_synthetic(
                shared.clone(),
                sim,
                finger.rest_depth_mm,
            )?);
        }
        Ok(View {
            shared,
            addr,
            token,
            threads,
        })
    }

    /// The address it listens on (the port chosen when 0 was asked).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The experimenter's page, with the token.
    pub fn experimenter_url(&self) -> String {
        format!("http://{}/?token={}", self.addr, self.token)
    }

    /// The participant's page, with the token.
    pub fn participant_url(&self) -> String {
        format!("http://{}/participant?token={}", self.addr, self.token)
    }

    /// The token every request must carry.
    pub fn token(&self) -> &str {
        &self.token
    }

    /// The session's events: what plays, the mute reason, the log.
    pub fn events(&self, events: &[Event]) {
        self.shared.events(events);
    }

    /// The finger's centroid as sent to the device (scene, mm), `None`
    /// when absent.
    pub fn finger(&self, pos_mm: Option<Vec3>) {
        self.shared.finger(pos_mm);
    }

    /// A colour frame from a camera or a replay.
    pub fn push_frame(&self, img: ColourImage) {
        self.shared.push(img);
    }

    /// The participant's page, to ask questions on and take answers from.
    pub fn participant(&self) -> Participant {
        Participant {
            shared: self.shared.clone(),
        }
    }

    /// What the view measured.
    pub fn figures(&self) -> Figures {
        self.shared.figures()
    }
}

impl Drop for View {
    fn drop(&mut self) {
        self.shared.close();
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

/// The participant's page as seen by whoever asks the questions.
pub struct Participant {
    shared: Arc<Shared>,
}

impl Participant {
    /// Shows `q` on the page (`None`: no question; a new `seq` clears an
    /// earlier answer).
    pub fn ask(&self, q: Option<Question>) {
        self.shared.ask(q);
    }

    /// The page's answer to question `seq`, once.
    pub fn take_answer(&self, seq: u64) -> Option<String> {
        self.shared.take_answer(seq)
    }
}

/// The view's stimuli from a session's library.
pub fn stimuli(loaded: &[Loaded]) -> Vec<Stimulus> {
    loaded
        .iter()
        .map(|l| {
            let t = &l.planned.plan.trajectory;
            Stimulus {
                id: l.id.clone(),
                radius_mm: l.stimulus.cycle.radius_mm,
                planned_mm: t.center_mm,
                foci_mm: (0..t.steps).map(|j| t.foci_step(j).to_vec()).collect(),
                dwell_s: t.dwell_s,
                plan: Arc::new(l.planned.plan.clone()),
            }
        })
        .collect()
}

/// The colour camera a view of `scene` uses when no camera reports one:
/// the D435's colour stream.
pub fn default_colour() -> ColourCamera {
    ColourCamera::D435_848X480
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A question of two circles (also the feed's tests').
    pub(crate) fn question(seq: u64) -> Question {
        Question {
            seq,
            prompt: "Which circle?".into(),
            options: vec!["2".into(), "4".into()],
            radii_mm: Some(vec![2.0, 4.0]),
            not_perceived: None,
        }
    }

    #[test]
    fn the_first_answer_to_a_question_stands() {
        let v = View::start(Options {
            addr: "127.0.0.1:0".parse().unwrap(),
            scene: Scene::default(),
            colour: default_colour(),
            frames: Frames::Pushed,
            stimuli: Vec::new(),
        })
        .unwrap();
        let p = v.participant();
        let sh = &v.shared;
        assert!(sh.answer(1, "2").is_err(), "nothing asked yet");
        p.ask(Some(question(1)));
        assert!(sh.answer(1, "3").is_err(), "not offered");
        assert!(sh.answer(2, "2").is_err(), "not asked");
        sh.answer(1, "2").unwrap();
        // A second click, before or after the study took the first.
        let e = sh.answer(1, "4").unwrap_err();
        assert!(e.contains("answered already"), "{e}");
        assert_eq!(p.take_answer(1).as_deref(), Some("2"));
        assert!(sh.answer(1, "4").is_err());
        assert_eq!(p.take_answer(1), None);
        // The next question takes its own answer.
        p.ask(Some(question(2)));
        assert!(sh.answer(1, "4").is_err());
        sh.answer(2, "4").unwrap();
        assert_eq!(p.take_answer(2).as_deref(), Some("4"));
    }
}
