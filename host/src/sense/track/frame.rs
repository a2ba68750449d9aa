//! A depth frame (with the colour image captured with it) and the trait of
//! every source of frames: a module of its own so that the sources
//! ([`super::source`]) and the stream format ([`super::wire`]) both build
//! on it without leaning on each other.

use super::colour::{ColourCamera, ColourImage};
use super::intrinsics::Intrinsics;
use super::synth::Truth;
use crate::sense::stream::run::Next;

/// One depth frame.
#[derive(Debug, Clone)]
pub struct Frame {
    /// Time stamp (s).
    pub t_s: f64,
    /// Row-major depth values.
    pub depth: Vec<u16>,
    /// Ground truth (synthetic frames only).
    pub truth: Option<Truth>,
    /// The colour image captured with this frame, if the source has a
    /// colour stream and one came with it.
    pub colour: Option<ColourImage>,
}

/// A source of frames.
pub trait FrameSource {
    /// The frames' intrinsics.
    fn intrinsics(&self) -> Intrinsics;
    /// The colour camera, if frames carry colour images.
    fn colour_camera(&self) -> Option<ColourCamera> {
        None
    }
    /// The next frame, `None` at the end.
    fn next_frame(&mut self) -> anyhow::Result<Option<Frame>>;
    /// Whether the source is live (already paced by the sensor).
    fn live(&self) -> bool {
        false
    }
    /// The next frame if one comes within `wait` (a source read on its own
    /// thread, [`Live`](super::source::Live), can idle; others block until it comes).
    fn next_frame_within(&mut self, _wait: std::time::Duration) -> anyhow::Result<Next<Frame>> {
        Ok(self.next_frame()?.map_or(Next::End, Next::Ready))
    }
}
