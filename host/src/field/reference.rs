//! The plain f64 loop the fast path is checked against: one transfer row
//! per point, one dot product per step, no blocking, no threads.

use super::maps::{check_inputs, finish};
use super::stats::{Stats, twiddles};
use super::{C64, FieldError, FieldMaps, FieldModel, ObservationPlane, Radiation, drive_from_u8};

/// Maps of a phase sequence (step-major, `steps × transducers` bytes) by
/// the plain f64 loop: one transfer row per point, then one dot product
/// per step. The reference the fast path is checked against.
pub fn simulate_reference(
    model: &FieldModel,
    plane: &ObservationPlane,
    phases: &[u8],
    steps: usize,
    rad: Radiation,
) -> Result<FieldMaps, FieldError> {
    let plane = check_inputs(model, plane, phases, steps, rad)?;
    let t = model.transducers();
    let table: Vec<C64> = drive_from_u8(&(0..=255).collect::<Vec<u8>>());
    let tw = twiddles(steps);
    let f = model.radiation_factor(rad.alpha);
    let mut row = vec![C64::default(); t];
    let mut stats = Vec::with_capacity(plane.nu() * plane.nv());
    for iv in 0..plane.nv() {
        for iu in 0..plane.nu() {
            model.transfer_row(plane.point(iu, iv), &mut row);
            let mut st = Stats::default();
            for s in 0..steps {
                let ph = &phases[s * t..(s + 1) * t];
                let (mut re, mut im) = (0.0, 0.0);
                for (g, &u) in row.iter().zip(ph) {
                    let p = g.mul(table[u as usize]);
                    re += p.re;
                    im += p.im;
                }
                let a2 = re * re + im * im;
                let prad = f * a2;
                if s == 0 {
                    st.amp0 = a2.sqrt();
                    st.p0 = prad;
                }
                st.sum += prad;
                st.max = st.max.max(prad);
                st.x1_re += prad * tw[s].0;
                st.x1_im += prad * tw[s].1;
            }
            stats.push(st);
        }
    }
    Ok(finish(&plane, steps, &stats))
}
