//! PNG of one depth frame around the detection box: depth in grey (near is
//! light, no data is dark blue), the box's projected edges in yellow, the
//! contact-area pixels in red and the centroid as a green cross.

use std::path::Path;

use plotters::prelude::*;

use super::contact::Tracker;
use crate::geom::Vec3;

/// Pixels of the output's longer side.
const OUT_PX: u32 = 720;

/// Draw `depth` (one frame) to `path`.
pub fn frame_png(tracker: &Tracker, depth: &[u16], path: &Path) -> anyhow::Result<()> {
    let intr = tracker.intrinsics();
    let roi = tracker.roi();
    // A window 1.5 × the box's rectangle (at least 32 px), inside the frame.
    let (cw, rh) = ((roi.c1 - roi.c0).max(16), (roi.r1 - roi.r0).max(16));
    let (cx, cy) = ((roi.c0 + roi.c1) / 2, (roi.r0 + roi.r1) / 2);
    let half_w = (cw * 3 / 4).max(16);
    let half_h = (rh * 3 / 4).max(16);
    let c0 = cx.saturating_sub(half_w);
    let c1 = (cx + half_w).min(intr.pinhole.width);
    let r0 = cy.saturating_sub(half_h);
    let r1 = (cy + half_h).min(intr.pinhole.height);
    let (nw, nh) = ((c1 - c0).max(1), (r1 - r0).max(1));
    let px = (OUT_PX / nw.max(nh)).max(1);
    let size = (nw * px, nh * px);

    let mut inside = vec![false; nw as usize * nh as usize];
    tracker.for_each_inside(depth, |c, r, _| {
        if (c0..c1).contains(&c) && (r0..r1).contains(&r) {
            inside[((r - r0) * nw + (c - c0)) as usize] = true;
        }
    });
    let window = (r0..r1).flat_map(|r| (c0..c1).map(move |c| (c, r)));
    let vals: Vec<u16> = window
        .clone()
        .map(|(c, r)| depth[(r * intr.pinhole.width + c) as usize])
        .filter(|v| *v > 0)
        .collect();
    let (lo, hi) = (
        vals.iter().copied().min().unwrap_or(0) as f64,
        vals.iter().copied().max().unwrap_or(1) as f64,
    );

    let err = |e: String| anyhow::anyhow!("cannot draw {}: {e}", path.display());
    // Drawn in memory, then written whole or not at all.
    crate::field::plot::write_png(path, size, |root| {
        root.fill(&BLACK).map_err(|e| err(e.to_string()))?;
        for (i, (c, r)) in window.enumerate() {
            let v = depth[(r * intr.pinhole.width + c) as usize];
            let colour = if inside[i] {
                RGBColor(230, 40, 40)
            } else if v == 0 {
                RGBColor(10, 10, 60)
            } else {
                let g =
                    (255.0 * (1.0 - (v as f64 - lo) / (hi - lo).max(1.0))).clamp(30.0, 255.0) as u8;
                RGBColor(g, g, g)
            };
            let (x, y) = (((c - c0) * px) as i32, ((r - r0) * px) as i32);
            root.draw(&Rectangle::new(
                [(x, y), (x + px as i32, y + px as i32)],
                colour.filled(),
            ))
            .map_err(|e| err(e.to_string()))?;
        }
        let to_px = |p: Vec3| -> Option<(i32, i32)> {
            let q = tracker.setup().camera.to_camera(p);
            (q[2] > 1e-6).then(|| {
                let [u, v] = intr.project(q);
                (
                    ((u - c0 as f64 + 0.5) * px as f64) as i32,
                    ((v - r0 as f64 + 0.5) * px as f64) as i32,
                )
            })
        };
        let corners = tracker.setup().track_box.corners();
        for i in 0..8usize {
            for k in 0..3 {
                let j = i ^ (1 << k);
                if j > i
                    && let (Some(a), Some(b)) = (to_px(corners[i]), to_px(corners[j]))
                {
                    root.draw(&PathElement::new(vec![a, b], YELLOW.stroke_width(2)))
                        .map_err(|e| err(e.to_string()))?;
                }
            }
        }
        if let Some(c) = tracker.track(depth).centroid_mm
            && let Some((x, y)) = to_px(c)
        {
            let s = (3 * px as i32).max(8);
            for seg in [[(x - s, y), (x + s, y)], [(x, y - s), (x, y + s)]] {
                root.draw(&PathElement::new(seg.to_vec(), GREEN.stroke_width(3)))
                    .map_err(|e| err(e.to_string()))?;
            }
        }
        Ok(())
    })
}
