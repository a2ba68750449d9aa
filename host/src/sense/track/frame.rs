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

/// The cameras a source's frames come from: the depth stream's
/// intrinsics and the colour camera, if frames carry colour images (what
/// an `LMDEPTH1` header says).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cameras {
    /// The depth stream's intrinsics.
    pub depth: Intrinsics,
    /// The colour camera, if any.
    pub colour: Option<ColourCamera>,
}

/// A source of frames.
pub trait FrameSource {
    /// The cameras its frames come from.
    fn cameras(&self) -> Cameras;
    /// The frames' intrinsics.
    fn intrinsics(&self) -> Intrinsics {
        self.cameras().depth
    }
    /// The colour camera, if frames carry colour images.
    fn colour_camera(&self) -> Option<ColourCamera> {
        self.cameras().colour
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
