//! Centroid correction: per-transducer phase offsets that move a planned
//! sequence from its planned centre `c0` to a tracked centroid `c`.
//!
//! Convention (same as the host's `units` module): AUTD3 phase φ = −k·r,
//! u8 phase = round(φ / 2π · 256) mod 256. Moving every focus by `c − c0`
//! changes transducer k's phase by approximately
//! Δφ_k = k·(|x_k − c0| − |x_k − c|), exact for a single focus at `c0`.
//! The offsets are added (wrapping) to every outgoing frame.

/// Carrier frequency of the transducers (Hz), [`lm_proto::CARRIER_HZ`].
pub const CARRIER_HZ: f32 = lm_proto::CARRIER_HZ as f32;

/// Bytes per transducer position on the wire, [`lm_proto::POSITION_LEN`].
pub const POSITION_BYTES: usize = lm_proto::POSITION_LEN;

/// Phase levels of a u8 phase, [`lm_proto::PHASE_LEVELS`].
const PHASE_LEVELS: f32 = lm_proto::PHASE_LEVELS as f32;

/// Speed of sound in m/s from the `BeginUpload::sound_speed_mm_s` a slot
/// was planned with.
pub fn sound_speed_m_s(sound_speed_mm_s: u32) -> f32 {
    sound_speed_mm_s as f32 / 1000.0
}

/// Phase LSB per µm of path length: 256 / λ with λ in µm.
pub fn lsb_per_um(sound_speed_m_s: f32) -> f32 {
    CARRIER_HZ * PHASE_LEVELS / (sound_speed_m_s * 1.0e6)
}

fn read_i32(b: &[u8]) -> i32 {
    let mut a = [0u8; 4];
    a.copy_from_slice(&b[..4]);
    i32::from_le_bytes(a)
}

/// Reads position `i` (µm) from packed wire-format positions.
pub fn position_um(positions: &[u8], i: usize) -> [i32; 3] {
    let p = &positions[i * POSITION_BYTES..(i + 1) * POSITION_BYTES];
    [read_i32(&p[0..4]), read_i32(&p[4..8]), read_i32(&p[8..12])]
}

/// Square root: `vsqrt.f32` on hard-float Arm (Cortex-M4F/M7), where
/// neither `core` nor `libm` emit it (libm's portable `sqrtf` is a
/// ~300-instruction bit loop); `libm` elsewhere (the host lowers it to the
/// native instruction). The operand goes through a core register because
/// stable Rust does not accept the `sreg` class on this target; that costs
/// two `vmov`s.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline(always)]
fn sqrt(x: f32) -> f32 {
    let bits: u32;
    // SAFETY: reads and writes only the named registers (s0 declared clobbered).
    unsafe {
        core::arch::asm!(
            "vmov s0, {x}",
            "vsqrt.f32 s0, s0",
            "vmov {r}, s0",
            x = in(reg) x.to_bits(),
            r = lateout(reg) bits,
            out("s0") _,
            options(pure, nomem, nostack, preserves_flags)
        );
    }
    f32::from_bits(bits)
}

#[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
#[inline(always)]
fn sqrt(x: f32) -> f32 {
    libm::sqrtf(x)
}

/// Fills `offsets[i]` (u8 phase LSB) for every transducer in `positions`
/// (packed `[i32; 3]` µm LE, `offsets.len()` entries), for planned centre
/// `c0_um` and centroid `c_um`.
///
/// Coordinates are taken relative to `c0` in exact integers first, so the
/// f32 distances keep µm resolution whatever the array's origin.
pub fn compute_offsets(
    positions: &[u8],
    c0_um: [i32; 3],
    c_um: [i32; 3],
    sound_speed_m_s: f32,
    offsets: &mut [u8],
) {
    let scale = lsb_per_um(sound_speed_m_s);
    // Saturating i32 differences: one instruction each on Cortex-M4
    // (QSUB); only saturate for positions kilometres apart.
    let s = [
        c_um[0].saturating_sub(c0_um[0]) as f32,
        c_um[1].saturating_sub(c0_um[1]) as f32,
        c_um[2].saturating_sub(c0_um[2]) as f32,
    ];
    for (o, x) in offsets
        .iter_mut()
        .zip(positions.chunks_exact(POSITION_BYTES))
    {
        let x = [read_i32(&x[0..4]), read_i32(&x[4..8]), read_i32(&x[8..12])];
        let d = [
            x[0].saturating_sub(c0_um[0]) as f32,
            x[1].saturating_sub(c0_um[1]) as f32,
            x[2].saturating_sub(c0_um[2]) as f32,
        ];
        let r0 = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        let e = [d[0] - s[0], d[1] - s[1], d[2] - s[2]];
        let r1 = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
        let lsb = (r0 - r1) * scale;
        // Round half away from zero, then wrap to u8 (two's complement).
        let q = if lsb >= 0.0 { lsb + 0.5 } else { lsb - 0.5 } as i32;
        *o = q as u8;
    }
}

/// Adds `offsets` to `phases` byte by byte (wrapping) into `out`.
/// This is the per-step hot loop. Four bytes at a time in a `u32` (the
/// low seven bits of each byte added, the top bit by XOR, so no carry
/// crosses a byte): the byte loop's code depended on what the compiler
/// inlined around it (4.5 to 5.9 instructions a byte on the M7 between
/// two builds of the same source); this is the same on every build.
#[inline]
pub fn apply_offsets(phases: &[u8], offsets: &[u8], out: &mut [u8]) {
    const LOW: u32 = 0x7F7F_7F7F;
    let n = out.len().min(phases.len()).min(offsets.len());
    let (out, phases, offsets) = (&mut out[..n], &phases[..n], &offsets[..n]);
    let mut o4 = out.chunks_exact_mut(4);
    let mut p4 = phases.chunks_exact(4);
    let mut d4 = offsets.chunks_exact(4);
    for ((o, p), d) in (&mut o4).zip(&mut p4).zip(&mut d4) {
        let a = u32::from_le_bytes([p[0], p[1], p[2], p[3]]);
        let b = u32::from_le_bytes([d[0], d[1], d[2], d[3]]);
        let sum = ((a & LOW) + (b & LOW)) ^ ((a ^ b) & !LOW);
        o.copy_from_slice(&sum.to_le_bytes());
    }
    let rest = o4
        .into_remainder()
        .iter_mut()
        .zip(p4.remainder())
        .zip(d4.remainder());
    for ((o, p), d) in rest {
        *o = p.wrapping_add(*d);
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    fn pack(ps: &[[i32; 3]]) -> Vec<u8> {
        let mut v = Vec::new();
        for p in ps {
            for c in p {
                v.extend_from_slice(&c.to_le_bytes());
            }
        }
        v
    }

    fn reference(x: [i32; 3], c0: [i32; 3], c: [i32; 3], sound: f64) -> u8 {
        let d = |a: [i32; 3], b: [i32; 3]| {
            let v: Vec<f64> = (0..3).map(|i| f64::from(a[i]) - f64::from(b[i])).collect();
            (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
        };
        let lsb = (d(x, c0) - d(x, c)) * 40_000.0 * 256.0 / (sound * 1e6);
        (lsb.round() as i64).rem_euclid(256) as u8
    }

    #[test]
    fn matches_f64_reference_within_one_lsb() {
        let mut xs = Vec::new();
        for i in 0..18 {
            for j in 0..14 {
                xs.push([i * 10_160 - 86_360, j * 10_160 - 66_040, 0]);
            }
        }
        let pos = pack(&xs);
        let c0 = [1_000, -2_000, 200_000];
        for c in [
            [1_000, -2_000, 200_000],
            [4_000, 0, 198_000],
            [-9_000, 3_000, 210_000],
        ] {
            let mut off = [0u8; 252];
            compute_offsets(&pos, c0, c, 340.0, &mut off);
            for (i, x) in xs.iter().enumerate() {
                let r = reference(*x, c0, c, 340.0);
                let diff = off[i].wrapping_sub(r) as i8;
                assert!(diff.abs() <= 1, "transducer {i}: {} vs {r}", off[i]);
            }
        }
    }

    #[test]
    fn zero_shift_gives_zero_offsets() {
        let pos = pack(&[[0, 0, 0], [100_000, 50_000, 0], [-70_000, 0, 0]]);
        let mut off = [9u8; 3];
        compute_offsets(&pos, [0, 0, 150_000], [0, 0, 150_000], 340.0, &mut off);
        assert_eq!(off, [0, 0, 0]);
    }

    #[test]
    fn apply_wraps() {
        let mut out = [0u8; 3];
        apply_offsets(&[250, 1, 128], &[10, 255, 128], &mut out);
        assert_eq!(out, [4, 0, 0]);
    }

    #[test]
    fn the_word_at_a_time_sum_is_the_byte_sum_for_every_pair() {
        // Every byte pair, in every lane of a word and in the tail.
        let a: Vec<u8> = (0..=255u8).flat_map(|x| [x; 256]).collect();
        let b: Vec<u8> = (0..256 * 256).map(|i| i as u8).collect();
        for shift in 0..4 {
            let n = a.len() - shift;
            let mut out = std::vec![0u8; n + 3];
            apply_offsets(&a[shift..], &b[..n], &mut out);
            for i in 0..n {
                assert_eq!(out[i], a[shift + i].wrapping_add(b[i]), "{shift} {i}");
            }
            assert_eq!(&out[n..], &[0, 0, 0], "nothing past the shortest");
        }
    }
}
