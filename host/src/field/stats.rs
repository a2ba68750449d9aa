//! What every path through one LM cycle accumulates per observation point
//! ([`Stats`]) and the DFT twiddles of the LM frequency bin: shared by the
//! fast kernel, its driver (`maps`) and the f64 reference.

use std::f64::consts::PI;

/// Per-point statistics of the radiation pressure over the cycle.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Stats {
    pub(super) amp0: f64,
    pub(super) p0: f64,
    pub(super) sum: f64,
    pub(super) max: f64,
    pub(super) x1_re: f64,
    pub(super) x1_im: f64,
}

/// DFT twiddles `e^{−j2πs/N}` for bin 1.
pub(super) fn twiddles(steps: usize) -> Vec<(f64, f64)> {
    (0..steps)
        .map(|s| {
            let a = -2.0 * PI * s as f64 / steps as f64;
            (a.cos(), a.sin())
        })
        .collect()
}
