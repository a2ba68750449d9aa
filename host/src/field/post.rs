//! Post-processing of maps: the peak, and the force over a fingertip-sized
//! disk.

use super::ObservationPlane;

/// Index and value of a map's maximum (first one on ties; NaN ignored).
pub fn peak(map: &[f64]) -> Option<(usize, f64)> {
    map.iter()
        .copied()
        .enumerate()
        .filter(|(_, v)| !v.is_nan())
        .fold(None, |best: Option<(usize, f64)>, (i, v)| match best {
            Some((_, b)) if b >= v => best,
            _ => Some((i, v)),
        })
}

/// Force (N) of a radiation-pressure map (Pa) over a disk in the plane.
///
/// The disk has diameter `diameter_mm` and centre `center_uv_mm` in plane
/// coordinates; each grid point inside counts with area `step²`. Returns
/// the force and whether the disk reaches beyond the grid (then the force
/// is underestimated).
pub fn disk_force_n(
    plane: &ObservationPlane,
    map_pa: &[f64],
    center_uv_mm: [f64; 2],
    diameter_mm: f64,
) -> (f64, bool) {
    let r = diameter_mm / 2.0;
    let (nu, nv) = (plane.nu(), plane.nv());
    let mut sum = 0.0;
    for iv in 0..nv {
        let dv = plane.v_mm(iv) - center_uv_mm[1];
        for iu in 0..nu {
            let du = plane.u_mm(iu) - center_uv_mm[0];
            if du * du + dv * dv <= r * r {
                sum += map_pa[iv * nu + iu];
            }
        }
    }
    let area_m2 = plane.step_mm * plane.step_mm * 1e-6;
    let half_w = plane.u_mm(nu - 1) + plane.step_mm / 2.0;
    let half_h = plane.v_mm(nv - 1) + plane.step_mm / 2.0;
    let clipped = center_uv_mm[0].abs() + r > half_w || center_uv_mm[1].abs() + r > half_h;
    (sum * area_m2, clipped)
}

/// The plane coordinates `([u_lo, u_hi], [v_lo, v_hi])` (mm) spanned by
/// the points of `map` at or above half its peak: how far a figure reaches
/// on the plane. `None` for an empty or all-zero map.
pub fn half_peak_extent_mm(plane: &ObservationPlane, map: &[f64]) -> Option<([f64; 2], [f64; 2])> {
    let (_, top) = peak(map)?;
    if top <= 0.0 {
        return None;
    }
    let nu = plane.nu();
    let mut ext = ([f64::MAX, f64::MIN], [f64::MAX, f64::MIN]);
    for (i, _) in map.iter().enumerate().filter(|(_, v)| **v >= top / 2.0) {
        let (u, v) = (plane.u_mm(i % nu), plane.v_mm(i / nu));
        ext.0 = [ext.0[0].min(u), ext.0[1].max(u)];
        ext.1 = [ext.1[0].min(v), ext.1[1].max(v)];
    }
    Some(ext)
}
