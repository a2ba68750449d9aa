//! The grid's tick labels, placed so that none touches another, within a
//! panel or across the gap to the next.

use plotters::prelude::*;

use super::{Layout, YTICK_W_PT, extent, format_mm, pt};
use crate::field::ObservationPlane;
use crate::field::plot::{TICK_PT, UNITS_PER_PT};

/// A tick label: its text, where it is drawn from (centre top for the x
/// axis, right centre for the y axis), its box and its tick mark, in
/// backend units.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct TickLabel {
    pub(super) text: String,
    /// The panel's column (x labels) or row (y labels).
    pub(super) panel: usize,
    pub(super) horizontal: bool,
    pub(super) anchor: (i32, i32),
    /// Left, top, right, bottom.
    pub(super) rect: (i32, i32, i32, i32),
    pub(super) tick: ((i32, i32), (i32, i32)),
}

/// Whether boxes `a` and `b` come closer than `pad` units.
pub(super) fn too_close(a: (i32, i32, i32, i32), b: (i32, i32, i32, i32), pad: i32) -> bool {
    a.0 < b.2 + pad && b.0 < a.2 + pad && a.1 < b.3 + pad && b.1 < a.3 + pad
}

/// Ticks to try, finest first: steps 1, 2, 2.5, 5 × 10^k from about a
/// tenth of `span` up, each on its multiples and then halfway between
/// them (±5 rather than -10, 0, 10 on a narrow panel).
fn nice_steps(span: f64) -> impl Iterator<Item = (f64, f64)> {
    let e = 10f64.powf((span / 10.0).log10().floor());
    (0..5).flat_map(move |k| {
        [1.0, 2.0, 2.5, 5.0].into_iter().flat_map(move |m| {
            let step = m * e * 10f64.powi(k);
            [(step, 0.0), (step, step / 2.0)]
        })
    })
}

impl Layout {
    /// The tick labels of the grid: along the bottom row's lower edges and
    /// the left column's left edges, at the finest nice step whose labels
    /// neither touch each other nor reach a neighbour panel's (a label
    /// that would cross half the gap to the next panel, or the corner
    /// below the left column's, is left out); at least two per axis where
    /// any step gives two.
    pub(super) fn tick_labels(
        &self,
        plane: &ObservationPlane,
        rows: usize,
        cols: usize,
    ) -> Vec<TickLabel> {
        let ((u0, u1), (v0, v1)) = extent(plane);
        let mut out = self.axis_ticks(true, (u0, u1), (rows, cols)).1;
        out.extend(self.axis_ticks(false, (v0, v1), (rows, cols)).1);
        out
    }

    /// One axis' step and labels for [`Layout::tick_labels`].
    pub(super) fn axis_ticks(
        &self,
        horizontal: bool,
        (lo, hi): (f64, f64),
        (rows, cols): (usize, usize),
    ) -> ((f64, f64), Vec<TickLabel>) {
        let panels = if horizontal { cols } else { rows };
        let mut best = (0, (f64::NAN, 0.0), Vec::new());
        for step in nice_steps(hi - lo) {
            let labels = self.axis_labels(horizontal, (lo, hi), step, (rows, cols), true);
            let pad = pt(TICK_PT * 0.4);
            let clear = labels.iter().enumerate().all(|(i, a)| {
                labels[i + 1..]
                    .iter()
                    .all(|b| !too_close(a.rect, b.rect, pad))
            });
            let least = (0..panels)
                .map(|p| labels.iter().filter(|l| l.panel == p).count())
                .min()
                .unwrap_or(0);
            if clear && least >= 2 {
                return (step, labels);
            }
            if clear && least > best.0 {
                best = (least, step, labels);
            }
        }
        (best.1, best.2)
    }

    /// The labels along one axis at `phase + k step` over `lo..hi` (mm);
    /// `keep_clear` leaves out those crossing into a neighbour's space.
    pub(super) fn axis_labels(
        &self,
        horizontal: bool,
        (lo, hi): (f64, f64),
        (step, phase): (f64, f64),
        (rows, cols): (usize, usize),
        keep_clear: bool,
    ) -> Vec<TickLabel> {
        let mark = pt(2.0);
        let font = ("sans-serif", TICK_PT * UNITS_PER_PT).into_font();
        let first = ((lo - phase) / step).ceil() as i64;
        let last = ((hi - phase) / step).floor() as i64;
        let mut out = Vec::new();
        let panels = if horizontal { cols } else { rows };
        for p in 0..panels {
            let (x, y) = if horizontal {
                (
                    self.x0 + p as i32 * (self.pw + self.gap),
                    self.y0 + (rows as i32 - 1) * (self.ph + self.gap),
                )
            } else {
                (self.x0, self.y0 + p as i32 * (self.ph + self.gap))
            };
            for k in first..=last {
                let v = phase + k as f64 * step;
                let text = format_mm(v);
                let (w, h) = font.box_size(&text).unwrap_or((0, 0));
                let (w, h) = (w as i32, h as i32);
                let label = if horizontal {
                    let px = x + ((v - lo) / (hi - lo) * self.pw as f64).round() as i32;
                    let top = y + self.ph + mark + pt(1.0);
                    TickLabel {
                        text,
                        panel: p,
                        horizontal,
                        anchor: (px, top),
                        rect: (px - w / 2, top, px - w / 2 + w, top + h),
                        tick: ((px, y + self.ph), (px, y + self.ph + mark)),
                    }
                } else {
                    let py = y + ((hi - v) / (hi - lo) * self.ph as f64).round() as i32;
                    let right = x - mark - pt(1.5);
                    TickLabel {
                        text,
                        panel: p,
                        horizontal,
                        anchor: (right, py),
                        rect: (right - w, py - h / 2, right, py - h / 2 + h),
                        tick: ((x - mark, py), (x, py)),
                    }
                };
                // A panel's space: half the gap either side; the left
                // column's x labels may reach under the y tick labels'
                // column, whose labels end at the bottom row's lower edge
                // (the x labels' row).
                let half = self.gap / 2 - pt(0.5);
                let fits = if horizontal {
                    let left = if p == 0 { x - pt(YTICK_W_PT) } else { x - half };
                    let right = if p + 1 == cols {
                        i32::MAX
                    } else {
                        x + self.pw + half
                    };
                    label.rect.0 >= left && label.rect.2 <= right
                } else {
                    let top = if p == 0 { 0 } else { y - half };
                    let bottom = if p + 1 == rows {
                        y + self.ph
                    } else {
                        y + self.ph + half
                    };
                    label.rect.1 >= top && label.rect.3 <= bottom
                };
                if fits || !keep_clear {
                    out.push(label);
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::plot::ONE_COLUMN_MM;
    use crate::field::plot::{Figure, Labels};

    fn plane(size_mm: f64, step_mm: f64) -> ObservationPlane {
        ObservationPlane {
            center_mm: [0.0, 0.0, 200.0],
            u: [1.0, 0.0, 0.0],
            v: [0.0, 1.0, 0.0],
            width_mm: size_mm,
            height_mm: size_mm,
            step_mm,
        }
    }

    fn compare_labels() -> Labels {
        Labels {
            x: "a (mm)".into(),
            y: "b (mm)".into(),
            colorbar: "mean rad. pressure (Pa)".into(),
            rows: vec![
                "LM-S\n5 Hz".into(),
                "LM-M\n5 Hz".into(),
                "LM-S\n25 Hz".into(),
            ],
            cols: ["2 mm", "3 mm", "4 mm", "5 mm", "6 mm"]
                .map(String::from)
                .to_vec(),
            cols_title: "orbit radius A".into(),
            disk_mm: Some(15.0),
        }
    }

    /// Every pair of `labels` that intersects.
    fn overlaps(labels: &[TickLabel]) -> Vec<(String, String)> {
        let mut out = Vec::new();
        for (i, a) in labels.iter().enumerate() {
            for b in &labels[i + 1..] {
                if too_close(a.rect, b.rect, 0) {
                    out.push((a.text.clone(), b.text.clone()));
                }
            }
        }
        out
    }

    #[test]
    fn the_compare_grids_tick_labels_never_overlap() {
        crate::field::plot::register_font();
        let labels = compare_labels();
        let mut crowded = false;
        for width_mm in [60.0, 88.0, 120.0, 180.0] {
            for (size, step) in [(20.0, 0.2), (12.0, 2.0), (30.0, 0.5), (8.0, 0.1)] {
                let p = plane(size, step);
                let fig = Figure {
                    width_mm,
                    ..Figure::default()
                };
                let lay = Layout::new(&p, &labels, 3, 5, &fig);
                let ticks = lay.tick_labels(&p, 3, 5);
                let what = format!("{width_mm} mm wide, {size} mm plane");
                assert_eq!(overlaps(&ticks), [] as [(String, String); 0], "{what}");
                // Every bottom panel and every left panel is labelled
                // (twice at the print widths; 60 mm leaves 3 mm a panel).
                let least = if width_mm < ONE_COLUMN_MM { 1 } else { 2 };
                let xs: Vec<&TickLabel> = ticks.iter().filter(|t| t.horizontal).collect();
                for c in 0..5 {
                    let x = lay.x0 + c * (lay.pw + lay.gap);
                    let n = xs
                        .iter()
                        .filter(|t| (x..=x + lay.pw).contains(&t.anchor.0))
                        .count();
                    assert!(n >= least, "{what}: column {c} has {n} x labels");
                }
                for r in 0..3 {
                    let y = lay.y0 + r * (lay.ph + lay.gap);
                    let n = ticks
                        .iter()
                        .filter(|t| !t.horizontal && (y..=y + lay.ph).contains(&t.anchor.1))
                        .count();
                    assert!(n >= least, "{what}: row {r} has {n} y labels");
                }
                // Every label inside the page.
                for t in &ticks {
                    assert!(
                        t.rect.0 >= 0 && t.rect.2 <= lay.size.0 as i32,
                        "{what}: {t:?}"
                    );
                }
                // Keeping every tick at that step would have them collide
                // between panels (the layout's rule is what prevents it).
                let (lo, hi) = extent(&p).0;
                let (step, _) = lay.axis_ticks(true, (lo, hi), (3, 5));
                assert!(step.0.is_finite() && step.0 > 0.0, "{what}: step {step:?}");
                let all = lay.axis_labels(true, (lo, hi), step, (3, 5), false);
                crowded |= !overlaps(&all).is_empty();
            }
        }
        assert!(crowded, "no layout where every tick would collide");
    }
}
