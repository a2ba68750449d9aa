//! Sequences: `N` frames × `T` phase bytes (step-major) plus the header the
//! device needs, and their upload encodings ([`lm_proto::codec`]).
//!
//! A [`Plan`] bundles what produced a sequence (scene, trajectory) with the
//! sequence itself; `lmhost plan`, `upload` and `simulate` all start from one.

use lm_proto::UploadHeader;
use lm_proto::codec::{self, CodecError, Encoding};

use crate::error::InputError;
use crate::geom::Vec3;
use crate::plan::scene::Scene;
use crate::plan::synth::fast::{PhasorTable, Scratch, SynthPlan};
use crate::plan::synth::{Weight, quantise_turns, solver};
use crate::plan::trajectory::{Cycle, LmParams, Trajectory};
use crate::units;

/// Default work volume (mm): the largest distance from the planned centre
/// a device steers a tracked centroid to (`--max-offset`).
pub const DEFAULT_MAX_OFFSET_MM: f64 = 20.0;

/// Largest phasor table (points × transducers) the sequence synthesis
/// builds (32 MB); longer trajectories are synthesised step by step.
const TABLE_LIMIT: usize = 4 << 20;

/// How the phases of a multi-focus step are synthesised.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Synthesis {
    /// The paper's linear synthesis: `arg Σ exp(−j k r_i)`, equal weights
    /// (fast path).
    #[default]
    Linear,
    /// `arg Σ w_i exp(−j k r_i)` with one real weight per focus (fast path).
    Weighted(Vec<f64>),
    /// GS-PAT phase-only solver (f64), equal pressure at every focus.
    GsPat {
        /// Iterations of the m × m power step.
        iterations: usize,
    },
}

/// Reusable buffers for synthesising many sequences over one
/// [`SynthPlan`] (plan once, run many: no large allocation per sequence).
#[derive(Debug, Clone)]
pub struct SynthWorkspace {
    table: PhasorTable,
    scratch: Scratch,
    idx: Vec<usize>,
    points: Vec<Vec3>,
}

impl SynthWorkspace {
    /// Buffers sized for `plan`.
    pub fn new(plan: &SynthPlan) -> Self {
        Self {
            table: PhasorTable::default(),
            scratch: plan.scratch(),
            idx: Vec::new(),
            points: Vec::new(),
        }
    }
}

/// A phase sequence: `steps × transducers` bytes, step-major.
#[derive(Debug, Clone, PartialEq)]
pub struct Sequence {
    /// What the device needs besides the phases (the wire's upload header,
    /// checked by [`UploadHeader::validate`] on both ends).
    pub header: UploadHeader,
    /// Phases, `phases[j * T + n]` for step `j`, transducer `n`.
    pub phases: Vec<u8>,
    /// Per-step intensity levels (one per step, 255 = the header's
    /// intensity), the LM firmware's amplitude modulation (protocol v6);
    /// `None`: every step at the header's intensity.
    pub intensity_table: Option<Vec<u8>>,
}

impl Sequence {
    /// Synthesises every step of `traj` over `scene`'s transducers.
    pub fn synthesize(
        scene: &Scene,
        traj: &Trajectory,
        synthesis: &Synthesis,
    ) -> Result<Self, InputError> {
        let transducers = scene.transducers();
        let plan = SynthPlan::new(&transducers, scene.wavenumber_rad_per_mm());
        Self::synthesize_with(scene, &plan, traj, synthesis)
    }

    /// As [`synthesize`](Self::synthesize) with a prepared plan.
    pub fn synthesize_with(
        scene: &Scene,
        plan: &SynthPlan,
        traj: &Trajectory,
        synthesis: &Synthesis,
    ) -> Result<Self, InputError> {
        Self::synthesize_reusing(scene, plan, &mut SynthWorkspace::new(plan), traj, synthesis)
    }

    /// As [`synthesize_with`](Self::synthesize_with), reusing `ws` (keep one
    /// per plan when synthesising many sequences).
    pub fn synthesize_reusing(
        scene: &Scene,
        plan: &SynthPlan,
        ws: &mut SynthWorkspace,
        traj: &Trajectory,
        synthesis: &Synthesis,
    ) -> Result<Self, InputError> {
        let t = plan.len();
        let header = Self::header_for(scene, traj, t)?;
        let mut phases = vec![0u8; traj.steps * t];
        let weights: Option<Vec<Weight>> = match synthesis {
            Synthesis::Weighted(w) => {
                if w.len() != traj.foci {
                    return Err(InputError::new(format!(
                        "{} weights given for {} foci",
                        w.len(),
                        traj.foci
                    )));
                }
                if let Some(x) = w.iter().find(|x| !(x.is_finite() && **x >= 0.0)) {
                    return Err(InputError::new(format!(
                        "weights must be finite and ≥ 0, got {x}"
                    )));
                }
                Some(w.iter().map(|&x| Weight::real(x)).collect())
            }
            _ => None,
        };
        match synthesis {
            Synthesis::GsPat { iterations } => {
                let tr = scene.transducers();
                let k = scene.wavenumber_rad_per_mm();
                for (j, out) in phases.chunks_exact_mut(t).enumerate() {
                    let turns = solver::gspat_turns(
                        &tr,
                        traj.drive_step(j),
                        k,
                        scene.directivity,
                        *iterations,
                    );
                    for (o, x) in out.iter_mut().zip(turns) {
                        *o = quantise_turns(x);
                    }
                }
            }
            _ if traj.foci > 1 && traj.steps * t <= TABLE_LIMIT => {
                // Every focus sits on one of the N trajectory points
                // (focus i of step j is point (j + i l) mod N, and focus 0 of
                // step k is point k): evaluate each point's phasors once.
                ws.points.clear();
                ws.points
                    .extend((0..traj.steps).map(|k| traj.drive_step(k)[0]));
                plan.fill_phasor_table(&ws.points, &mut ws.table);
                ws.idx.clear();
                ws.idx.resize(traj.foci, 0);
                for (j, out) in phases.chunks_exact_mut(t).enumerate() {
                    for (i, k) in ws.idx.iter_mut().enumerate() {
                        *k = (j + i * traj.index_offset) % traj.steps;
                    }
                    plan.foci_from_table(
                        &ws.table,
                        &ws.idx,
                        weights.as_deref(),
                        &mut ws.scratch,
                        out,
                    );
                }
            }
            _ => {
                for (j, out) in phases.chunks_exact_mut(t).enumerate() {
                    plan.foci(traj.drive_step(j), weights.as_deref(), &mut ws.scratch, out);
                }
            }
        }
        Ok(Self {
            header,
            phases,
            intensity_table: None,
        })
    }

    /// The header for `traj` over `transducers` transducers in `scene`,
    /// with the default work volume ([`DEFAULT_MAX_OFFSET_MM`]).
    pub fn header_for(
        scene: &Scene,
        traj: &Trajectory,
        transducers: usize,
    ) -> Result<UploadHeader, InputError> {
        Ok(UploadHeader {
            steps: u16::try_from(traj.steps)
                .map_err(|_| InputError::new(format!("{} steps exceed u16", traj.steps)))?,
            transducers: u16::try_from(transducers)
                .map_err(|_| InputError::new(format!("{transducers} transducers exceed u16")))?,
            period_us: units::period_us(traj.period_s)?,
            // Planned in drive coordinates: the mirrored centre when the
            // scene has a reflector, the frame of the transducer positions.
            center_um: units::vec_mm_to_um(scene.drive_point(traj.center_mm))?,
            foci_per_step: traj.foci as u8,
            sound_speed_mm_s: units::sound_speed_mm_s(scene.sound_speed_m_s)?,
            max_offset_um: units::max_offset_um(DEFAULT_MAX_OFFSET_MM)?,
            intensity: u8::MAX,
        })
    }

    /// Sets the work volume (mm, checked: (0, 100]).
    pub fn set_max_offset_mm(&mut self, max_offset_mm: f64) -> Result<(), InputError> {
        self.header.max_offset_um = units::max_offset_um(max_offset_mm)?;
        Ok(())
    }

    /// Dwell per step, µs (`period / steps`, exact).
    pub fn dwell_us(&self) -> f64 {
        f64::from(self.header.period_us) / f64::from(self.header.steps.max(1))
    }

    /// Phases of step `j`.
    pub fn step(&self, j: usize) -> &[u8] {
        let t = usize::from(self.header.transducers);
        &self.phases[j * t..(j + 1) * t]
    }

    /// The sequence encoded for upload: the bytes the link sends as they
    /// are. `BadShape` when `phases` is not steps × transducers.
    pub fn encode(&self, encoding: Encoding) -> Result<Vec<u8>, CodecError> {
        let t = usize::from(self.header.transducers);
        if self.phases.len() as u64 != self.header.raw_len() {
            return Err(CodecError::BadShape);
        }
        let mut out = vec![0u8; codec::encoded_len(encoding, &self.phases, t)?];
        let n = self.encode_into(encoding, &mut out)?;
        out.truncate(n);
        Ok(out)
    }

    /// Encodes into `out` (sized with [`encoded_len`](Self::encoded_len));
    /// returns the length.
    pub fn encode_into(&self, encoding: Encoding, out: &mut [u8]) -> Result<usize, CodecError> {
        let t = usize::from(self.header.transducers);
        codec::encode(encoding, &self.phases, t, out)
    }

    /// Encoded size in bytes (0 when `phases` is not a whole number of
    /// steps, which a synthesised sequence never is; [`encode`](Self::encode)
    /// reports that as `BadShape`).
    pub fn encoded_len(&self, encoding: Encoding) -> usize {
        codec::encoded_len(encoding, &self.phases, usize::from(self.header.transducers))
            .unwrap_or(0)
    }

    /// CRC-32 of the raw sequence followed by its intensity table, if any
    /// (the `Commit` check value).
    pub fn crc32(&self) -> u32 {
        let mut c = lm_proto::Crc32::new();
        c.update(&self.phases);
        if let Some(t) = &self.intensity_table {
            c.update(t);
        }
        c.finish()
    }

    /// The phases as a NumPy `.npy` file (u8, shape `(steps, transducers)`).
    pub fn to_npy(&self) -> Vec<u8> {
        crate::npy::encode_u8(
            usize::from(self.header.steps),
            usize::from(self.header.transducers),
            &self.phases,
        )
    }
}

/// A planned stimulus: the scene, the trajectory and the phase sequence.
#[derive(Debug, Clone)]
pub struct Plan {
    /// Scene the plan was made for.
    pub scene: Scene,
    /// Where the foci go.
    pub trajectory: Trajectory,
    /// The phases.
    pub sequence: Sequence,
    /// The amplitude modulation over the sequence, if any (an AUTD3 plays
    /// it as its modulation, the LM firmware as the sequence's
    /// `intensity_table`).
    pub am: Option<crate::plan::modulation::Am>,
}

impl Plan {
    /// Plans the trajectory of `params` over `scene` and synthesises its
    /// sequence. Bad parameters are [`InputError`]s.
    pub fn new(scene: Scene, params: &LmParams, synthesis: &Synthesis) -> Result<Self, InputError> {
        let trajectory = Trajectory::plan(params, &scene)?;
        let sequence = Sequence::synthesize(&scene, &trajectory, synthesis)?;
        Ok(Self {
            scene,
            trajectory,
            sequence,
            am: None,
        })
    }

    /// The paper's LM-M stimulus on the built-in array: A = 3 mm, 4 foci
    /// 3 mm apart, 5 Hz, 0.23 mm steps, linear synthesis.
    pub fn paper_lm_m() -> Result<Self, InputError> {
        let scene = Scene::default();
        let params = Cycle::paper_lm_m().at(scene.center_mm, scene.lm_plane);
        Self::new(scene, &params, &Synthesis::Linear)
    }

    /// The JSON summary `lmhost plan --json` prints (`phases` adds the
    /// sequence, steps × transducers).
    pub fn summary_json(&self, phases: bool) -> serde_json::Value {
        let t = &self.trajectory;
        let s = &self.sequence;
        let raw = s.encoded_len(Encoding::Raw);
        let delta = s.encoded_len(Encoding::Delta);
        let steps: Vec<_> = (0..t.steps).map(|j| t.foci_step(j).to_vec()).collect();
        let mut v = serde_json::json!({
            "scene": self.scene.name,
            "transducers": s.header.transducers,
            "steps": t.steps,
            "foci_per_step": t.foci,
            "index_offset": t.index_offset,
            "step_mm": t.step_mm,
            "dwell_s": t.dwell_s,
            "period_s": t.period_s,
            "header": s.header,
            "center_mm": t.center_mm,
            "mirrored": self.scene.reflector.is_some(),
            "foci_mm": steps,
            "encoding": {"raw_bytes": raw, "delta_bytes": delta, "delta_ratio": delta as f64 / raw as f64},
            "crc32": s.crc32(),
        });
        if let Some(levels) = &s.intensity_table {
            v["intensity_table"] = serde_json::json!(levels);
        }
        if self.scene.reflector.is_some() {
            let drive: Vec<_> = (0..t.steps).map(|j| t.drive_step(j).to_vec()).collect();
            v["drive_foci_mm"] = serde_json::json!(drive);
        }
        if phases {
            let rows: Vec<&[u8]> = (0..t.steps).map(|j| s.step(j)).collect();
            v["phases"] = serde_json::json!(rows);
        }
        v
    }

    /// The scene's transducer positions in wire µm, in phase order.
    pub fn positions_um(&self) -> Result<Vec<[i32; 3]>, InputError> {
        self.scene
            .transducers()
            .iter()
            .map(|t| units::vec_mm_to_um(t.pos_mm))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::trajectory::{LmParams, Steps};

    fn paper(foci: usize) -> Sequence {
        let scene = Scene::default();
        let mut p = LmParams::paper(scene.center_mm);
        p.cycle.foci = foci;
        let t = Trajectory::plan(&p, &scene).unwrap();
        Sequence::synthesize(&scene, &t, &Synthesis::Linear).unwrap()
    }

    #[test]
    fn header_carries_the_scenes_sound_speed() {
        let mut scene = Scene::default();
        let t = Trajectory::plan(&LmParams::paper(scene.center_mm), &scene).unwrap();
        assert_eq!(
            Sequence::header_for(&scene, &t, 996)
                .unwrap()
                .sound_speed_mm_s,
            340_000
        );
        scene.sound_speed_m_s = crate::units::sound_speed_from_celsius(20.0);
        let h = Sequence::header_for(&scene, &t, 996).unwrap();
        assert_eq!(
            h.sound_speed_mm_s,
            (scene.sound_speed_m_s * 1000.0).round() as u32
        );
        assert_ne!(h.sound_speed_mm_s, 340_000);
        // A speed no device accepts is refused while planning, not by a nack.
        scene.sound_speed_m_s = 5_000.0;
        let e = Sequence::header_for(&scene, &t, 996).unwrap_err();
        assert!(e.to_string().contains("speed of sound"), "{e}");
    }

    #[test]
    fn paper_sequences_compress_to_under_half() {
        for foci in [1, 4] {
            let s = paper(foci);
            assert_eq!((s.header.steps, s.header.transducers), (82, 996));
            assert_eq!(s.phases.len(), 82 * 996);
            let raw = s.encoded_len(Encoding::Raw);
            let delta = s.encoded_len(Encoding::Delta);
            assert_eq!(raw, s.phases.len());
            assert!(delta * 2 <= raw, "{foci} foci: {delta} of {raw}");
            assert_eq!(s.encode(Encoding::Delta).unwrap().len(), delta);
        }
    }

    #[test]
    fn delta_round_trips_through_the_device_decoder() {
        let s = paper(4);
        let enc = s.encode(Encoding::Delta).unwrap();
        let mut dec = codec::Decoder::new(Encoding::Delta, s.header.steps, s.header.transducers);
        let mut out = vec![0u8; s.phases.len()];
        for piece in enc.chunks(lm_proto::MAX_CHUNK) {
            dec.feed(piece, &mut out).unwrap();
        }
        dec.finish().unwrap();
        assert_eq!(out, s.phases);
    }

    #[test]
    fn header_holds_period_dwell_and_centre() {
        let s = paper(1);
        assert_eq!(s.header.period_us, 200_000);
        assert!((s.dwell_us() - 2439.02).abs() < 0.01);
        assert_eq!(s.header.center_um, [0, 0, 200_000]);
        assert_eq!(s.header.foci_per_step, 1);
        assert_eq!(s.header.max_offset_um, 20_000);
    }

    #[test]
    fn work_volume_is_checked_and_the_header_validates() {
        let mut s = paper(1);
        for bad in [0.0, -1.0, 100.001, f64::NAN, f64::INFINITY, 1e300] {
            let e = s.set_max_offset_mm(bad).unwrap_err();
            assert!(e.to_string().contains("--max-offset"), "{e}");
        }
        assert_eq!(s.header.max_offset_um, 20_000, "unchanged by a refusal");
        s.set_max_offset_mm(100.0).unwrap();
        assert_eq!(s.header.max_offset_um, 100_000);
        let limits = lm_proto::DeviceLimits {
            slots: 2,
            max_transducers: 996,
            slot_bytes: 200 * 996,
            min_dwell_us: 1000,
        };
        assert_eq!(s.header.validate(&limits), Ok(()));
        s.phases.pop();
        assert_eq!(s.encode(Encoding::Raw), Err(CodecError::BadShape));
    }

    #[test]
    fn every_step_matches_the_reference_within_0_51_lsb() {
        let scene = Scene::default();
        let mut p = LmParams::paper(scene.center_mm);
        p.cycle.foci = 4;
        p.cycle.steps = Steps::Width(0.23);
        let t = Trajectory::plan(&p, &scene).unwrap();
        let s = Sequence::synthesize(&scene, &t, &Synthesis::Linear).unwrap();
        let tr = scene.transducers();
        let kappa = scene.wavenumber_rad_per_mm() / (2.0 * std::f64::consts::PI);
        for j in 0..t.steps {
            for (q, tr) in s.step(j).iter().zip(&tr) {
                let exact = crate::plan::synth::reference::phase_turns(
                    tr.pos_mm,
                    t.drive_step(j),
                    None,
                    kappa,
                );
                assert!(crate::plan::synth::error_lsb(*q, exact) <= 0.51);
            }
        }
    }

    #[test]
    fn npy_header_is_aligned_and_describes_the_shape() {
        let s = paper(1);
        let npy = s.to_npy();
        assert_eq!(&npy[..8], b"\x93NUMPY\x01\x00");
        let hl = u16::from_le_bytes([npy[8], npy[9]]) as usize;
        assert_eq!((10 + hl) % 64, 0);
        let h = std::str::from_utf8(&npy[10..10 + hl]).unwrap();
        assert!(h.contains("'shape': (82, 996)") && h.ends_with('\n'));
        assert_eq!(&npy[10 + hl..], &s.phases[..]);
    }

    #[test]
    fn weights_must_match_the_foci() {
        let scene = Scene::default();
        let mut p = LmParams::paper(scene.center_mm);
        p.cycle.foci = 2;
        let t = Trajectory::plan(&p, &scene).unwrap();
        let e = Sequence::synthesize(&scene, &t, &Synthesis::Weighted(vec![1.0])).unwrap_err();
        assert!(e.0.contains("1 weights given for 2 foci"));
        let s = Sequence::synthesize(&scene, &t, &Synthesis::Weighted(vec![1.0, 0.0])).unwrap();
        // Weight 0 on the second focus = single-focus phases.
        let mut one = vec![0u8; 996];
        SynthPlan::new(&scene.transducers(), scene.wavenumber_rad_per_mm())
            .focus(t.drive_step(0)[0], &mut one);
        let diff = one.iter().zip(s.step(0)).filter(|(a, b)| a != b).count();
        assert!(diff < 5, "{diff}");
    }
}
