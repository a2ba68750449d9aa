//! Finger tracking from depth frames: the paper's contact-area centroid.
//!
//! A depth frame ([`source`]: a `.npy` recording, the synthetic finger
//! [`synth`], or a live camera stream) is deprojected with the camera's
//! [`intrinsics`], moved into the scene by the camera pose ([`camera`], the
//! scene's `[camera]`), and the points inside the detection box (the
//! scene's `[tracking]`) are the contact area ([`contact`]); their centroid
//! is the LM centre. [`Pipeline`] adds presence hysteresis ([`presence`])
//! and a centroid filter (`stream::filter`), and yields the samples the
//! streaming loop (`stream::run`) sends to the device. [`surface`] gives
//! the finger surface's depth along the planned circle; [`plot`] draws a
//! frame. [`run`] is `lmhost track`'s whole run: a source through the
//! pipeline, recorded, plotted, scored and streamed.

pub mod camera;
pub mod colour;
pub mod contact;
pub mod frame;
pub mod intrinsics;
pub mod overlay;
pub mod plot;
pub mod presence;
pub mod report;
pub mod run;
pub mod settings_file;
pub mod source;
pub mod surface;
pub mod synth;
pub mod synth_colour;
pub mod wire;

use crate::geom::Vec3;
use crate::sense::stream::Sample;
use crate::sense::stream::filter::Filter;
use contact::{Contact, Tracker};
use presence::Hysteresis;

/// What the pipeline made of one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameResult {
    /// Frame time (s).
    pub t_s: f64,
    /// The raw contact area (`present` is `points >= min_points`).
    pub contact: Contact,
    /// `contact.points >= min_points`: this frame alone, no hysteresis.
    pub present: bool,
    /// Presence after hysteresis (the device gate).
    pub gated: bool,
    /// Filtered centre (mm, scene) while gated present.
    pub filtered_mm: Option<Vec3>,
    /// Seconds spent tracking this frame (box test and centroid).
    pub track_s: f64,
}

impl FrameResult {
    /// The sample for the streaming loop: the filtered centre, present while
    /// the gate is open (pass it through `filter::Passthrough`).
    pub fn sample(&self) -> Sample {
        Sample {
            t_s: self.t_s,
            pos_mm: self.filtered_mm.unwrap_or([0.0; 3]),
            present: self.filtered_mm.is_some(),
        }
    }

    /// The raw centroid if present (`None` also below `min_points`).
    pub fn centroid_mm(&self) -> Option<Vec3> {
        if self.present {
            self.contact.centroid_mm
        } else {
            None
        }
    }
}

/// Contact area → presence hysteresis → centroid filter.
pub struct Pipeline {
    /// The contact-area tracker.
    pub tracker: Tracker,
    /// The presence gate.
    pub gate: Hysteresis,
    filter: Box<dyn Filter + Send>,
    last: Option<Vec3>,
}

impl Pipeline {
    /// A pipeline with the given tracker, gate and filter.
    pub fn new(tracker: Tracker, gate: Hysteresis, filter: Box<dyn Filter + Send>) -> Self {
        Self {
            tracker,
            gate,
            filter,
            last: None,
        }
    }

    /// Process one frame taken at `t_s`.
    pub fn step(&mut self, t_s: f64, depth: &[u16]) -> FrameResult {
        let t0 = std::time::Instant::now();
        let contact = self.tracker.track(depth);
        let track_s = t0.elapsed().as_secs_f64();
        let present = contact.points >= self.tracker.setup().track_box.min_points;
        let gated = self.gate.update(present);
        if present {
            self.last = contact.centroid_mm;
        }
        // Through a one-frame dropout the gate stays open on the last centre.
        let filtered_mm = match (gated, self.last) {
            (true, Some(p)) => self.filter.update(&Sample {
                t_s,
                pos_mm: p,
                present: true,
            }),
            _ => {
                self.filter.update(&Sample {
                    t_s,
                    pos_mm: [0.0; 3],
                    present: false,
                });
                None
            }
        };
        if !gated {
            self.last = if present { contact.centroid_mm } else { None };
        }
        FrameResult {
            t_s,
            contact,
            present,
            gated,
            filtered_mm,
            track_s,
        }
    }
}

/// Why no frame can ever find a finger with this setup, if so: a camera
/// that cannot see the tracking box (too far, facing away, the box off the
/// frame), a `min_points` above the box's pixel count, or a `depth_scale`
/// whose deepest value lies short of the box. `lmhost track` warns with it
/// before the first frame: a silent run with no contact in any frame is
/// never the answer to a wrong setup.
pub fn check_rig(tracker: &contact::Tracker) -> Result<(), crate::InputError> {
    let intr = tracker.intrinsics();
    let setup = tracker.setup();
    let pixels = tracker.roi().pixels();
    if pixels == 0 {
        return Err(crate::InputError::new(format!(
            "the camera cannot see the tracking box: it covers no pixel of the {}×{} frame (box off-screen, behind the camera or too far); check the scene's [camera] and [tracking]",
            intr.pinhole.width, intr.pinhole.height
        )));
    }
    let min_points = setup.track_box.min_points as usize;
    if min_points > pixels {
        return Err(crate::InputError::new(format!(
            "[tracking] min_points {min_points} exceeds the {pixels} pixels the box covers in the frame: no frame can have a contact area; lower min_points"
        )));
    }
    let nearest_mm = setup
        .track_box
        .corners()
        .iter()
        .map(|c| setup.camera.to_camera(*c)[2])
        .fold(f64::INFINITY, f64::min);
    let deepest_mm = f64::from(u16::MAX) * intr.depth_scale * 1000.0;
    if deepest_mm < nearest_mm {
        return Err(crate::InputError::new(format!(
            "depth_scale {} m makes the deepest reading {} mm, short of the tracking box ({} mm from the camera): every depth is ~0 to the tracker; depth_scale is metres per depth unit (0.001 for a RealSense)",
            crate::limits::show(intr.depth_scale),
            crate::limits::show(deepest_mm),
            crate::limits::show(nearest_mm)
        )));
    }
    Ok(())
}

#[cfg(test)]
mod colour_tests;
#[cfg(test)]
mod tests;
