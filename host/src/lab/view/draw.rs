//! What the view draws and how it is encoded: the overlay's geometry in
//! colour-image pixels (the stimulus circles, the orbit, the foci, the
//! finger), drawn into an RGB image for the frame endpoint, and the JPEG
//! (frames to the browser) and PNG (the endpoint, the pressure map)
//! encoders.

use crate::geom::{Vec3, add, sub};
use crate::plan::scene::LmPlane;
use crate::sense::track::overlay::ColourView;

/// Points per drawn circle: a chord of a 6 mm circle then stays well
/// under a pixel from the arc at any distance the camera sees the pad.
pub const CIRCLE_POINTS: usize = 96;

/// The overlay's blue (the paper's circle).
pub const BLUE: [u8; 3] = [0, 0, 255];
/// The foci (red).
pub const RED: [u8; 3] = [255, 40, 40];
/// The finger's centroid (green).
pub const GREEN: [u8; 3] = [0, 220, 0];

/// The geometry of one frame's overlay, in colour-image pixels.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Overlay {
    /// The LM centre the device plays (projected), if known.
    pub centre_px: Option<[f64; 2]>,
    /// The finger's centroid (projected), if present.
    pub finger_px: Option<[f64; 2]>,
    /// The playing stimulus's orbit (its radius A about the centre).
    pub orbit: Vec<[f64; 2]>,
    /// The foci now (host-estimated step).
    pub foci: Vec<[f64; 2]>,
    /// The participant's circles, one per answer radius (mm).
    pub circles: Vec<Circle>,
    /// The participant's crop: `[x0, y0, side]`.
    pub crop: [f64; 3],
}

/// One circle of the participant's page.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Circle {
    /// Its radius in the LM plane (mm).
    pub r_mm: f64,
    /// The projected polyline.
    pub pts: Vec<[f64; 2]>,
}

/// What the overlay is computed from.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The colour camera in the scene.
    pub view: ColourView,
    /// The LM plane.
    pub plane: LmPlane,
    /// The scene's LM centre (the planned centre).
    pub center_mm: Vec3,
    /// Half the side of the participant's crop (mm in the LM plane).
    pub crop_half_mm: f64,
}

impl Scene {
    /// The overlay for a stimulus centred at `centre_mm` (`None`: nothing
    /// plays) with `radius_mm` and `foci_mm` (scene, already moved to the
    /// centre), the finger at `finger_mm`, and the participant's `radii_mm`
    /// (drawn about the centre, or the scene's centre when nothing plays).
    pub fn overlay(
        &self,
        centre_mm: Option<Vec3>,
        radius_mm: f64,
        foci_mm: &[Vec3],
        finger_mm: Option<Vec3>,
        radii_mm: &[f64],
    ) -> Overlay {
        let v = &self.view;
        let about = centre_mm.unwrap_or(self.center_mm);
        Overlay {
            centre_px: centre_mm.and_then(|c| v.pixel(c)),
            finger_px: finger_mm.and_then(|f| v.pixel(f)),
            orbit: match centre_mm {
                Some(c) if radius_mm > 0.0 => v.circle(c, &self.plane, radius_mm, CIRCLE_POINTS),
                _ => Vec::new(),
            },
            foci: foci_mm.iter().filter_map(|f| v.pixel(*f)).collect(),
            circles: radii_mm
                .iter()
                .map(|&r| Circle {
                    r_mm: r,
                    pts: v.circle(about, &self.plane, r, CIRCLE_POINTS),
                })
                .collect(),
            crop: v.crop(self.center_mm, &self.plane, self.crop_half_mm),
        }
    }

    /// Where the device plays planned point `p_mm` when it plays the
    /// stimulus planned at `planned_mm` centred at `centre_mm`: the
    /// centroid correction moves every focus by the same offset.
    pub fn moved(p_mm: Vec3, planned_mm: Vec3, centre_mm: Vec3) -> Vec3 {
        add(centre_mm, sub(p_mm, planned_mm))
    }
}

/// An RGB image being drawn on.
pub struct Canvas<'a> {
    /// width × height × 3 bytes.
    pub rgb: &'a mut [u8],
    /// Width (pixels).
    pub width: u32,
    /// Height (pixels).
    pub height: u32,
}

impl Canvas<'_> {
    /// Paints a disc of `r` px about (x, y).
    pub fn dot(&mut self, x: f64, y: f64, r: f64, c: [u8; 3]) {
        let (w, h) = (i64::from(self.width), i64::from(self.height));
        let (x0, x1) = ((x - r).floor() as i64, (x + r).ceil() as i64);
        let (y0, y1) = ((y - r).floor() as i64, (y + r).ceil() as i64);
        for py in y0.max(0)..=y1.min(h - 1) {
            for px in x0.max(0)..=x1.min(w - 1) {
                let (dx, dy) = (px as f64 - x, py as f64 - y);
                if dx * dx + dy * dy <= r * r {
                    let i = (py * w + px) as usize * 3;
                    self.rgb[i..i + 3].copy_from_slice(&c);
                }
            }
        }
    }

    /// Strokes a polyline `half` px either side of it (closed: back to the
    /// first point).
    pub fn polyline(&mut self, pts: &[[f64; 2]], closed: bool, half: f64, c: [u8; 3]) {
        let n = pts.len();
        let segs = if closed { n } else { n.saturating_sub(1) };
        for i in 0..segs {
            let (a, b) = (pts[i], pts[(i + 1) % n]);
            let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
            // Stamps 0.25 px apart: the stroke has no gaps.
            let k = (len / 0.25).ceil().max(1.0) as usize;
            for j in 0..=k {
                let t = j as f64 / k as f64;
                self.dot(a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), half, c);
            }
        }
    }

    /// Draws `o` as the frame endpoint shows it: the circles (blue), the
    /// orbit (blue), the foci (red), the finger (green).
    pub fn overlay(&mut self, o: &Overlay) {
        for c in &o.circles {
            self.polyline(&c.pts, true, 0.8, BLUE);
        }
        self.polyline(&o.orbit, true, 0.8, BLUE);
        for f in &o.foci {
            self.dot(f[0], f[1], 2.5, RED);
        }
        if let Some([x, y]) = o.finger_px {
            self.polyline(&[[x - 5.0, y], [x + 5.0, y]], false, 0.6, GREEN);
            self.polyline(&[[x, y - 5.0], [x, y + 5.0]], false, 0.6, GREEN);
        }
    }
}

/// JPEG quality of the frames sent to the browser: the circles are drawn
/// by the page, so the video needs no more.
pub const JPEG_QUALITY: u8 = 80;

/// An RGB image as JPEG.
pub fn jpeg(rgb: &[u8], width: u32, height: u32) -> anyhow::Result<Vec<u8>> {
    let mut out = Vec::with_capacity(rgb.len() / 8);
    let (w, h) = (
        u16::try_from(width)
            .map_err(|_| anyhow::anyhow!("a {width}-pixel-wide frame is too wide for JPEG"))?,
        u16::try_from(height)
            .map_err(|_| anyhow::anyhow!("a {height}-pixel-high frame is too high for JPEG"))?,
    );
    jpeg_encoder::Encoder::new(&mut out, JPEG_QUALITY)
        .encode(rgb, w, h, jpeg_encoder::ColorType::Rgb)
        .map_err(|e| anyhow::anyhow!("encoding a frame as JPEG: {e}"))?;
    Ok(out)
}

/// An RGB image as PNG (fast compression: it is a snapshot, not an archive).
pub fn png(rgb: &[u8], width: u32, height: u32) -> anyhow::Result<Vec<u8>> {
    let mut out = Vec::new();
    let mut enc = png::Encoder::new(&mut out, width, height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_compression(png::Compression::Fast);
    let mut w = enc
        .write_header()
        .map_err(|e| anyhow::anyhow!("encoding a PNG: {e}"))?;
    w.write_image_data(rgb)
        .map_err(|e| anyhow::anyhow!("encoding a PNG: {e}"))?;
    w.finish()
        .map_err(|e| anyhow::anyhow!("encoding a PNG: {e}"))?;
    Ok(out)
}

/// A map of `nu` × `nv` values (row-major, v rows) as a heat-map PNG
/// (black → red → yellow → white over 0..max), `scale` pixels per cell.
pub fn heat_png(map: &[f64], nu: usize, nv: usize, cell: usize) -> anyhow::Result<Vec<u8>> {
    let max = map
        .iter()
        .copied()
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    let (w, h) = (nu * cell, nv * cell);
    let mut rgb = vec![0u8; w * h * 3];
    for y in 0..h {
        for x in 0..w {
            // Rows from the top: +v up, as the field figures draw it.
            let t = (map[(nv - 1 - y / cell) * nu + x / cell] / max).clamp(0.0, 1.0);
            let c = [
                (t * 3.0).min(1.0),
                (t * 3.0 - 1.0).clamp(0.0, 1.0),
                (t * 3.0 - 2.0).clamp(0.0, 1.0),
            ];
            let i = (y * w + x) * 3;
            for k in 0..3 {
                rgb[i + k] = (c[k] * 255.0).round() as u8;
            }
        }
    }
    png(&rgb, w as u32, h as u32)
}
