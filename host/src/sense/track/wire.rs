//! The live frame formats, read and written: `LMDEPTH1` (depth) and
//! `LMCOLOR1` (depth with the colour stream beside it). All little-endian.
//!
//! `LMDEPTH1`:
//! - header, 56 bytes: the 8 ASCII bytes `LMDEPTH1`, `u32` width, `u32`
//!   height, then `f64` fx, fy, ppx, ppy, depth_scale (see [`Intrinsics`]);
//! - then per frame: `f64` time stamp (s), width × height `u16` depth values,
//!   row-major (Z16: 0 = no data).
//!
//! `LMCOLOR1` is `LMDEPTH1` with the colour stream beside it:
//! - header, 236 bytes: the 8 ASCII bytes `LMCOLOR1`, the 48 bytes after
//!   `LMDEPTH1`'s magic, then the colour camera ([`ColourCamera`]): `u32`
//!   width, `u32` height, `f64` fx, fy, ppx, ppy, `u32` distortion model
//!   (librealsense's `rs2_distortion` value: 0 none, 1 modified
//!   Brown-Conrady, 2 inverse Brown-Conrady, 4 Brown-Conrady), `f64` ×
//!   5 coefficients (k1, k2, p1, p2, k3), `f64` × 9 depth → colour
//!   rotation (column-major, as librealsense's `rs2_extrinsics`), `f64` ×
//!   3 depth → colour translation (metres);
//! - then per frame: the `LMDEPTH1` frame, then one byte: 0 (no new colour
//!   image with this depth frame) or 1, followed by the colour image's `f64`
//!   time stamp (s, the depth stream's clock) and width × height × 3 bytes
//!   of 8-bit RGB, row-major.
//!
//! A colour image rides with the depth frame it was captured with (the
//! camera's frameset), so the two stay aligned in time whatever their rates
//! (the bridge: depth at 90 fps, colour at 30). Either stream ends at a
//! frame boundary; a partial frame is an error.

use std::io::Read;

use super::colour::{ColourCamera, ColourImage, Distortion};
use super::frame::{Cameras, Frame, FrameSource};
use super::intrinsics::{Intrinsics, Pinhole};
use super::settings_file::SettingsFile as _;
use crate::InputError;

/// `LMDEPTH1`'s magic.
pub const MAGIC: &[u8; 8] = b"LMDEPTH1";
/// `LMCOLOR1`'s magic.
pub const MAGIC_COLOUR: &[u8; 8] = b"LMCOLOR1";
/// Bytes of the colour camera in an `LMCOLOR1` header.
const COLOUR_HEADER: usize = 180;

/// The rule for a depth frame's time stamp `t_s`, on every path that
/// takes one (a recording, a camera, Python's `Tracker.process`): finite,
/// in 0 to [`MAX_TIME_STAMP_S`](crate::limits::MAX_TIME_STAMP_S) as every
/// finger source's, and not before `last`, the frame before's. `what`
/// names the source, `n` the frame (from 0), `whose` a part of it
/// (`"'s colour image"`, or `""`).
pub fn frame_stamp(what: &str, n: u64, whose: &str, t_s: f64, last: f64) -> Result<(), InputError> {
    use crate::limits::{MAX_TIME_STAMP_S, show, show_beside};
    if !(0.0..=MAX_TIME_STAMP_S).contains(&t_s) {
        return Err(InputError::new(format!(
            "{what}: frame {n}{whose} has time stamp {} s, out of range: give 0 to {} s",
            show_beside(t_s, 0.0, MAX_TIME_STAMP_S),
            show(MAX_TIME_STAMP_S)
        )));
    }
    if t_s < last {
        return Err(InputError::new(format!(
            "{what}: frame {n}{whose} has time stamp {} s, before the previous one's {} s",
            show_beside(t_s, last, last),
            show_beside(last, t_s, t_s)
        )));
    }
    Ok(())
}

/// An `LMDEPTH1` or `LMCOLOR1` stream.
pub struct Stream<R: Read> {
    reader: R,
    cameras: Cameras,
    what: String,
    frames: u64,
    last_t: f64,
    last_colour_t: f64,
    pub(super) child: Option<std::process::Child>,
}

fn read_full<R: Read>(r: &mut R, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut got = 0;
    while got < buf.len() {
        match r.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(got)
}

/// Little-endian fields read in order from a header.
struct Fields<'a>(&'a [u8]);

impl Fields<'_> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let (a, rest) = self.0.split_at(N);
        self.0 = rest;
        a.try_into().expect("N bytes")
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take())
    }
    /// A pinhole as [`put_pinhole`] writes it.
    fn pinhole(&mut self) -> Pinhole {
        Pinhole {
            width: self.u32(),
            height: self.u32(),
            fx: self.f64(),
            fy: self.f64(),
            ppx: self.f64(),
            ppy: self.f64(),
        }
    }
}

impl<R: Read> Stream<R> {
    /// Read the header from `reader`; `what` names the stream in errors.
    pub fn new(mut reader: R, what: &str) -> anyhow::Result<Self> {
        let mut h = [0u8; 56];
        let n = read_full(&mut reader, &mut h)?;
        if n < h.len() {
            return Err(InputError::new(format!(
                "{what}: ended after {n} bytes, before its 56-byte LMDEPTH1 header"
            ))
            .into());
        }
        let with_colour = match &h[..8] {
            m if m == MAGIC => false,
            m if m == MAGIC_COLOUR => true,
            _ => {
                return Err(InputError::new(format!(
                    "{what}: not an LMDEPTH1 or LMCOLOR1 stream (bad magic)"
                ))
                .into());
            }
        };
        let mut f = Fields(&h[8..]);
        let intr = Intrinsics {
            pinhole: f.pinhole(),
            depth_scale: f.f64(),
        };
        intr.check(what)?;
        let colour = if with_colour {
            let mut c = [0u8; COLOUR_HEADER];
            if read_full(&mut reader, &mut c)? < c.len() {
                return Err(InputError::new(format!(
                    "{what}: ended inside its LMCOLOR1 header's colour camera"
                ))
                .into());
            }
            Some(colour_camera(&c, what)?)
        } else {
            None
        };
        Ok(Self {
            reader,
            cameras: Cameras {
                depth: intr,
                colour,
            },
            what: what.to_owned(),
            frames: 0,
            last_t: f64::NEG_INFINITY,
            last_colour_t: f64::NEG_INFINITY,
            child: None,
        })
    }

    /// Refuses time stamp `t_s` of frame `self.frames` (`whose` its
    /// colour image's) by [`frame_stamp`].
    fn stamp(&self, t_s: f64, last: f64, whose: &str) -> Result<(), InputError> {
        frame_stamp(&self.what, self.frames, whose, t_s, last)
    }

    fn ended_inside(&self) -> anyhow::Error {
        InputError::new(format!("{}: ended inside frame {}", self.what, self.frames)).into()
    }

    /// The colour image after a depth frame, if the stream has colour and
    /// one rides with it.
    fn read_colour(&mut self) -> anyhow::Result<Option<ColourImage>> {
        let Some(cam) = self.cameras.colour else {
            return Ok(None);
        };
        let mut flag = [0u8; 9];
        if read_full(&mut self.reader, &mut flag[..1])? < 1 {
            return Err(self.ended_inside());
        }
        match flag[0] {
            0 => return Ok(None),
            1 => {}
            v => {
                return Err(InputError::new(format!(
                    "{}: frame {} has colour flag {v}, not 0 or 1",
                    self.what, self.frames
                ))
                .into());
            }
        }
        let mut rgb = vec![0u8; cam.image_bytes()];
        if read_full(&mut self.reader, &mut flag[1..])? < 8
            || read_full(&mut self.reader, &mut rgb)? < rgb.len()
        {
            return Err(self.ended_inside());
        }
        let t_s = f64::from_le_bytes(flag[1..].try_into().expect("8 bytes"));
        self.stamp(t_s, self.last_colour_t, "'s colour image")?;
        self.last_colour_t = t_s;
        Ok(Some(ColourImage {
            t_s,
            width: cam.pinhole.width,
            height: cam.pinhole.height,
            rgb: std::sync::Arc::new(rgb),
        }))
    }
}

/// The colour camera in an `LMCOLOR1` header.
fn colour_camera(c: &[u8; COLOUR_HEADER], what: &str) -> Result<ColourCamera, InputError> {
    let mut f = Fields(c);
    let pinhole = f.pinhole();
    let model = Distortion::from_rs2(f.u32())
        .map_err(|m| InputError::new(format!("{what}: colour camera: {m}")))?;
    let coeffs = [(); 5].map(|_| f.f64());
    let rotation = [(); 9].map(|_| f.f64());
    let translation_m = [(); 3].map(|_| f.f64());
    let cam = ColourCamera {
        pinhole,
        model,
        coeffs,
        rotation,
        translation_m,
    };
    cam.check(what)?;
    Ok(cam)
}

impl<R: Read> FrameSource for Stream<R> {
    fn cameras(&self) -> Cameras {
        self.cameras
    }
    fn live(&self) -> bool {
        true
    }
    fn next_frame(&mut self) -> anyhow::Result<Option<Frame>> {
        let mut t = [0u8; 8];
        let n = read_full(&mut self.reader, &mut t)?;
        if n == 0 {
            if let Some(mut c) = self.child.take() {
                let status = c.wait()?;
                if !status.success() && self.frames == 0 {
                    anyhow::bail!("the RealSense bridge exited ({status}) before sending a frame");
                }
            } else if self.frames == 0 {
                // A recorded or piped stream of no frames: nothing was
                // tracked, not a run that tracked 0 frames.
                return Err(InputError::new(format!(
                    "{}: the stream holds no frames (it ended after its header)",
                    self.what
                ))
                .into());
            }
            return Ok(None);
        }
        let px =
            self.cameras.depth.pinhole.width as usize * self.cameras.depth.pinhole.height as usize;
        let mut bytes = vec![0u8; px * 2];
        if n < 8 || read_full(&mut self.reader, &mut bytes)? < bytes.len() {
            return Err(self.ended_inside());
        }
        let t_s = f64::from_le_bytes(t);
        self.stamp(t_s, self.last_t, "")?;
        let colour = self.read_colour()?;
        self.last_t = t_s;
        self.frames += 1;
        let depth = bytes
            .chunks_exact(2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]))
            .collect();
        Ok(Some(Frame {
            t_s,
            depth,
            truth: None,
            colour,
        }))
    }
}

/// The header of an `LMDEPTH1` stream for `intr`, or of an `LMCOLOR1`
/// stream with `colour`.
pub fn stream_header(intr: &Intrinsics, colour: Option<&ColourCamera>) -> Vec<u8> {
    let mut out = match colour {
        None => MAGIC.to_vec(),
        Some(_) => MAGIC_COLOUR.to_vec(),
    };
    put_pinhole(&mut out, &intr.pinhole);
    out.extend_from_slice(&intr.depth_scale.to_le_bytes());
    if let Some(c) = colour {
        put_pinhole(&mut out, &c.pinhole);
        out.extend_from_slice(&c.model.to_rs2().to_le_bytes());
        for v in c.coeffs.iter().chain(&c.rotation).chain(&c.translation_m) {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    out
}

/// A pinhole as both headers hold it: width, height (u32), then fx, fy,
/// ppx, ppy (f64).
fn put_pinhole(out: &mut Vec<u8>, p: &Pinhole) {
    out.extend_from_slice(&p.width.to_le_bytes());
    out.extend_from_slice(&p.height.to_le_bytes());
    for v in [p.fx, p.fy, p.ppx, p.ppy] {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

/// One frame of an `LMDEPTH1` stream.
pub fn stream_frame(t_s: f64, depth: &[u16]) -> Vec<u8> {
    let mut out = t_s.to_le_bytes().to_vec();
    for v in depth {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// One frame of an `LMCOLOR1` stream: the depth frame and the colour image
/// riding with it, if any.
pub fn stream_frame_colour(t_s: f64, depth: &[u16], colour: Option<&ColourImage>) -> Vec<u8> {
    let mut out = stream_frame(t_s, depth);
    match colour {
        None => out.push(0),
        Some(c) => {
            out.push(1);
            out.extend_from_slice(&c.t_s.to_le_bytes());
            out.extend_from_slice(&c.rgb);
        }
    }
    out
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    fn image(t_s: f64, cam: &ColourCamera, v: u8) -> ColourImage {
        ColourImage {
            t_s,
            width: cam.pinhole.width,
            height: cam.pinhole.height,
            rgb: std::sync::Arc::new(vec![v; cam.image_bytes()]),
        }
    }

    #[test]
    fn colour_streams_round_trip_and_bad_ones_are_input_errors() {
        let intr = Intrinsics {
            pinhole: Pinhole {
                width: 4,
                height: 3,
                ppx: 2.0,
                ppy: 1.0,
                ..Intrinsics::D435_848X480.pinhole
            },
            ..Intrinsics::D435_848X480
        };
        let cam = ColourCamera {
            pinhole: Pinhole {
                width: 5,
                height: 2,
                ppx: 2.0,
                ppy: 1.0,
                ..ColourCamera::D435_848X480.pinhole
            },
            ..ColourCamera::D435_848X480
        };
        let header = stream_header(&intr, Some(&cam));
        assert_eq!(header.len(), 236);
        let mut bytes = header.clone();
        bytes.extend(stream_frame_colour(
            0.0,
            &[1; 12],
            Some(&image(0.001, &cam, 7)),
        ));
        bytes.extend(stream_frame_colour(0.011, &[2; 12], None));
        bytes.extend(stream_frame_colour(
            0.022,
            &[3; 12],
            Some(&image(0.034, &cam, 9)),
        ));
        let mut s = Stream::new(&bytes[..], "t").unwrap();
        assert_eq!(s.colour_camera(), Some(cam));
        let f = s.next_frame().unwrap().unwrap();
        assert_eq!(f.colour.as_ref().unwrap().rgb[0], 7);
        assert_eq!(f.colour.unwrap().t_s, 0.001);
        assert!(s.next_frame().unwrap().unwrap().colour.is_none());
        let f = s.next_frame().unwrap().unwrap();
        assert_eq!((f.depth[0], f.colour.unwrap().rgb[29]), (3, 9));
        assert!(s.next_frame().unwrap().is_none());
        // Cut inside a colour image: an input error naming the frame.
        let e = Stream::new(&bytes[..bytes.len() - 1], "t")
            .and_then(|mut s| {
                while s.next_frame()?.is_some() {}
                Ok(())
            })
            .unwrap_err();
        assert!(e.downcast_ref::<InputError>().is_some(), "{e}");
        assert!(e.to_string().contains("inside frame 2"), "{e}");
        // A flag other than 0 or 1.
        let mut b = header.clone();
        b.extend(stream_frame(0.0, &[1; 12]));
        b.push(2);
        let e = Stream::new(&b[..], "t").unwrap().next_frame().unwrap_err();
        assert!(e.to_string().contains("colour flag 2"), "{e}");
        // A fisheye model in the header.
        let mut b = header.clone();
        b[56 + 40..56 + 44].copy_from_slice(&5u32.to_le_bytes());
        let e = Stream::new(&b[..], "t").err().unwrap().to_string();
        assert!(e.contains("fisheye"), "{e}");
        // A depth-only stream has no colour.
        let mut b = stream_header(&intr, None);
        b.extend(stream_frame(0.0, &[1; 12]));
        let mut s = Stream::new(&b[..], "t").unwrap();
        assert!(s.colour_camera().is_none());
        assert!(s.next_frame().unwrap().unwrap().colour.is_none());
    }

    /// A 4 × 2 depth stream and a 2 × 2 colour camera: the smallest
    /// streams (also the readers fuzz's seeds).
    pub(crate) fn cameras() -> (Intrinsics, ColourCamera) {
        let intr = Intrinsics {
            pinhole: Pinhole::new(4, 2, 3.0, 3.0, 2.0, 1.0),
            depth_scale: 0.001,
        };
        let cam = ColourCamera {
            pinhole: Pinhole::new(2, 2, 2.0, 2.0, 1.0, 1.0),
            ..ColourCamera::D435_848X480
        };
        (intr, cam)
    }

    /// Every frame of `bytes`, or the refusal.
    fn read_all(bytes: &[u8]) -> Result<Vec<Frame>, String> {
        let mut s = Stream::new(bytes, "cam").map_err(|e| format!("{e:#}"))?;
        let mut out = Vec::new();
        while let Some(f) = s.next_frame().map_err(|e| format!("{e:#}"))? {
            out.push(f);
        }
        Ok(out)
    }

    #[test]
    fn a_frame_stamped_outside_0_to_1e10_s_is_refused_as_every_finger_source_refuses_it() {
        let (intr, cam) = cameras();
        let depth = [500u16; 8];
        for t in [-1.0, -5e-324, 1.0e10 + 1.0, 1e300, f64::NAN, f64::INFINITY] {
            let mut b = stream_header(&intr, None);
            b.extend(stream_frame(0.5, &depth));
            b.extend(stream_frame(t, &depth));
            let e = read_all(&b).unwrap_err();
            assert!(
                e.starts_with("cam: frame 1 has time stamp") && e.contains("give 0 to 1e10 s"),
                "{t}: {e}"
            );
            assert!(e.len() < 120 && !e.contains("000000000000"), "{e}");
        }
        // The colour image riding on a frame, the same.
        let img = |t_s| ColourImage {
            t_s,
            width: 2,
            height: 2,
            rgb: std::sync::Arc::new(vec![7; 12]),
        };
        let mut b = stream_header(&intr, Some(&cam));
        b.extend(stream_frame_colour(0.5, &depth, Some(&img(0.5))));
        b.extend(stream_frame_colour(0.6, &depth, Some(&img(-2.0))));
        let e = read_all(&b).unwrap_err();
        assert!(
            e.starts_with("cam: frame 1's colour image has time stamp -2 s"),
            "{e}"
        );
        // Back in time, by less than six digits show.
        let mut b = stream_header(&intr, None);
        b.extend(stream_frame(1000.0000001, &depth));
        b.extend(stream_frame(1000.0, &depth));
        let e = read_all(&b).unwrap_err();
        assert!(
            e.contains("1000 s, before the previous one's 1000.0000001 s"),
            "{e}"
        );
        // At the bounds, read.
        let mut b = stream_header(&intr, Some(&cam));
        b.extend(stream_frame_colour(0.0, &depth, Some(&img(0.0))));
        b.extend(stream_frame_colour(1.0e10, &depth, None));
        let frames = read_all(&b).unwrap();
        assert_eq!(frames.len(), 2);
        assert_eq!(frames[1].t_s, 1.0e10);
    }
}
