//! Uploads through a damaged link: the fault-injecting proxy between the
//! client and the simulated device (in process, virtual clock, so
//! timeouts cost no wall time).
//!
//! What must hold: a commit is never corrupt (every committed slot plays
//! exactly the uploaded phases), uploads at a bit error rate up to 1e-4
//! complete by retrying, worse links fail with a clear error, and the
//! slot that was playing keeps playing, unchanged, throughout.
//!
//! The 10,000-upload run is `#[ignore]`d; run it with
//! `cargo test --release -p lm-e2e --test fault_upload -- --ignored`.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use lm_proto::{Encoding, PlayAt, UploadHeader};
use lmhost::clock::Clock;
use lmhost::device::link::proxy::{Faults, Faulty};
use lmhost::device::link::{Client, LinkError, UploadSpec};
use lmhost::device::simdev::{CapturedFrame, FwCore, InProcess, SimConfig};
use lmhost::plan::sequence::Sequence;
use lmhost::rng::SplitMix64;

type Link = Faulty<InProcess<FwCore>>;

struct Rig {
    core: Arc<Mutex<FwCore>>,
    time: Clock,
    client: Client<Link>,
    playing: (u8, Sequence),
    corrupt_commits: u32,
    verified_commits: u32,
}

/// Transducers of the simulated rig (one AUTD3 board).
const RIG_TRANSDUCERS: u16 = 249;

fn spec(rng: &mut SplitMix64) -> Sequence {
    let steps = 2 + rng.below(40) as u16;
    // One rig per device (protocol v3): every entry drives its transducers.
    let transducers = RIG_TRANSDUCERS;
    // Half smooth (what the planner makes, Delta-friendly), half noise.
    let smooth = rng.below(2) == 0;
    let base: Vec<u8> = (0..transducers).map(|_| rng.next_u64() as u8).collect();
    let mut phases = Vec::with_capacity(steps as usize * transducers as usize);
    for s in 0..steps as usize {
        for (t, b) in base.iter().enumerate() {
            phases.push(if smooth {
                b.wrapping_add((s * (t % 7)) as u8)
            } else {
                rng.next_u64() as u8
            });
        }
    }
    Sequence {
        header: UploadHeader {
            steps,
            transducers,
            period_us: steps as u32 * (1000 + rng.below(2000) as u32),
            center_um: [0, 0, 200_000],
            foci_per_step: 1,
            sound_speed_mm_s: 340_000,
            max_offset_um: 20_000,
            intensity: 255,
        },
        phases,
        intensity_table: None,
    }
}

/// The upload of `seq` (positions along x, 10.16 mm apart).
fn upload_spec(seq: &Sequence, encoding: Encoding) -> UploadSpec {
    let positions = (0..i32::from(seq.header.transducers))
        .map(|i| [i * 10_160 - 80_000, 0, 0])
        .collect();
    UploadSpec::new(seq, positions, encoding).unwrap()
}

impl Rig {
    fn new(seed: u64) -> Rig {
        let cfg = SimConfig {
            require_tracking: false,
            ..SimConfig::default()
        };
        let core = Arc::new(Mutex::new(FwCore::new(cfg).unwrap()));
        core.lock().unwrap().set_capture(true);
        let time = Clock::manual_at_us(1_000_000);
        let link = InProcess::new(core.clone(), time.clone());
        let mut client = Client::new(Faulty::new(link, Faults::default(), seed));
        client.timeout = Duration::from_millis(20);
        client.tries = 10;
        client.upload_attempts = 8;
        // The test's host never renews on its own: the longest lease, so a
        // run of timeouts on a hopeless link (virtual time) does not end
        // the play the uploads must leave alone.
        client.lease_ms = *lm_proto::LEASE_MS.end();
        let mut rng = SplitMix64::new(seed);
        let first = spec(&mut rng);
        client
            .upload(&upload_spec(&first, Encoding::Delta), 0, 1024, |_, _| {})
            .unwrap();
        client.play(0, PlayAt::Immediate, false).unwrap();
        let mut rig = Rig {
            core,
            time,
            client,
            playing: (0, first),
            corrupt_commits: 0,
            verified_commits: 0,
        };
        rig.run_for(10_000);
        rig.check_playing(&rig.take_frames());
        rig
    }

    fn now(&self) -> u64 {
        self.time.now_us()
    }

    /// Let the device play for `us` of virtual time.
    fn run_for(&mut self, us: u64) {
        let until = self.now() + us;
        self.client.transport_mut().inner_mut().advance_to(until);
    }

    fn take_frames(&self) -> Vec<CapturedFrame> {
        self.core.lock().unwrap().take_captured()
    }

    /// Every frame came from the playing slot, sounding, with its phases.
    fn check_playing(&self, frames: &[CapturedFrame]) {
        let (slot, spec) = &self.playing;
        let t = spec.header.transducers as usize;
        assert!(!frames.is_empty(), "nothing played");
        for f in frames {
            assert_eq!(f.slot, *slot, "the playing slot changed");
            assert!(f.amplitude > 0, "the playing slot went silent");
            let s = f.step as usize;
            assert_eq!(
                f.phases,
                spec.phases[s * t..(s + 1) * t],
                "slot {slot} step {s} differs"
            );
        }
    }

    /// Upload `spec` into the idle slot through `faults`. On success switch
    /// to it and check it plays exactly what was uploaded.
    fn faulty_upload(
        &mut self,
        spec: Sequence,
        faults: Faults,
        seed: u64,
    ) -> Result<(), LinkError> {
        let target = 1 - self.playing.0;
        let clean = std::mem::replace(
            self.client.transport_mut(),
            Faulty::new(
                InProcess::new(self.core.clone(), self.time.clone()),
                faults,
                seed,
            ),
        );
        drop(clean);
        let encoding = if seed.is_multiple_of(2) {
            Encoding::Delta
        } else {
            Encoding::Raw
        };
        let chunk = [1024, 512, 100][(seed % 3) as usize];
        let result = self
            .client
            .upload(&upload_spec(&spec, encoding), target, chunk, |_, _| {})
            .map(|_| ());
        // Back to a clean link to inspect the device.
        *self.client.transport_mut() = Faulty::new(
            InProcess::new(self.core.clone(), self.time.clone()),
            Faults::default(),
            seed,
        );
        self.run_for(5_000);
        self.check_playing(&self.take_frames());
        if result.is_ok() {
            self.client
                .play(target, PlayAt::Immediate, false)
                .expect("play the new slot");
            let cycle = spec.header.period_us as u64;
            self.playing = (target, spec);
            self.run_for(cycle + 5_000);
            let frames = self.take_frames();
            let all_match = {
                let t = self.playing.1.header.transducers as usize;
                frames.iter().filter(|f| f.slot == target).all(|f| {
                    let s = f.step as usize;
                    f.phases == self.playing.1.phases[s * t..(s + 1) * t]
                })
            };
            if all_match {
                self.verified_commits += 1;
            } else {
                self.corrupt_commits += 1;
            }
            self.check_playing(&frames[frames.iter().position(|f| f.slot == target).unwrap()..]);
        }
        result
    }
}

fn random_faults(rng: &mut SplitMix64) -> (Faults, bool) {
    let bers = [0.0, 1e-6, 1e-5, 1e-4, 1e-4, 1e-3, 1e-2];
    let ber = bers[rng.below(bers.len() as u64) as usize];
    let small = |rng: &mut SplitMix64| [0.0, 0.0, 1e-6, 1e-5, 1e-4][rng.below(5) as usize];
    let f = Faults {
        ber,
        drop: small(rng),
        dup: small(rng),
        truncate: small(rng),
        cut_after: (rng.below(10) == 0).then(|| rng.below(20_000)),
    };
    let mendable = f.ber <= 1e-4
        && f.drop <= 1e-4
        && f.dup <= 1e-4
        && f.truncate <= 1e-4
        && f.cut_after.is_none();
    (f, mendable)
}

fn campaign(uploads: u64, seed: u64) {
    let mut rig = Rig::new(seed);
    let mut rng = SplitMix64::new(seed ^ 0xFA17);
    let (mut ok, mut failed) = (0, 0);
    for i in 0..uploads {
        let s = spec(&mut rng);
        let (faults, mendable) = random_faults(&mut rng);
        match rig.faulty_upload(s, faults, seed.wrapping_add(i)) {
            Ok(()) => ok += 1,
            Err(e) => {
                assert!(!mendable, "upload {i} failed at {faults:?}: {e}");
                let msg = e.to_string();
                assert!(!msg.contains('\n') && !msg.is_empty(), "{msg}");
                failed += 1;
            }
        }
    }
    assert_eq!(rig.corrupt_commits, 0);
    assert_eq!(rig.verified_commits, ok);
    eprintln!("{uploads} uploads: {ok} committed and verified, {failed} failed cleanly, 0 corrupt");
}

#[test]
fn uploads_at_ber_1e4_complete_bit_exact() {
    let mut rig = Rig::new(7);
    let mut rng = SplitMix64::new(8);
    for i in 0..20 {
        let faults = Faults {
            ber: 1e-4,
            ..Faults::default()
        };
        rig.faulty_upload(spec(&mut rng), faults, 100 + i).unwrap();
    }
    assert_eq!(rig.verified_commits, 20);
    assert_eq!(rig.corrupt_commits, 0);
}

#[test]
fn cut_link_fails_clearly_and_the_playing_slot_plays_on() {
    let mut rig = Rig::new(3);
    let mut rng = SplitMix64::new(4);
    let before = rig.playing.0;
    let err = rig
        .faulty_upload(
            spec(&mut rng),
            Faults {
                cut_after: Some(600),
                ..Faults::default()
            },
            5,
        )
        .unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("upload failed after") || msg.contains("no response"),
        "{msg}"
    );
    assert_eq!(rig.playing.0, before);
}

#[test]
fn hopeless_link_gives_up_with_a_clear_error() {
    let mut rig = Rig::new(11);
    let mut rng = SplitMix64::new(12);
    let err = rig
        .faulty_upload(
            spec(&mut rng),
            Faults {
                ber: 0.05,
                ..Faults::default()
            },
            13,
        )
        .unwrap_err();
    assert!(
        err.to_string().contains("no response") || err.to_string().contains("upload failed"),
        "{err}"
    );
    assert_eq!(rig.corrupt_commits, 0);
}

/// A link that loses every other reply on its way back (each request is
/// answered; every second answer never arrives): whole frames, up to
/// their closing 0x00 delimiter (one answer per read from the device).
struct LosesEveryOtherReply<T> {
    inner: T,
    /// Off: a clean link, for comparison.
    lossy: bool,
    requests: u64,
    swallow: bool,
}

impl<T: lmhost::device::link::Transport> lmhost::device::link::Transport
    for LosesEveryOtherReply<T>
{
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.requests += 1;
        self.swallow = self.lossy && self.requests % 2 == 1;
        self.inner.send(bytes)
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> std::io::Result<usize> {
        loop {
            let n = self.inner.recv(buf, timeout)?;
            if n == 0 || !self.swallow {
                return Ok(n);
            }
            // A frame may open with a delimiter too: it ends at the first
            // 0x00 after a byte of its own.
            let start = buf[..n].iter().position(|&b| b != 0).unwrap_or(n);
            if let Some(end) = buf[start..n]
                .iter()
                .position(|&b| b == 0)
                .map(|i| start + i)
            {
                self.swallow = false;
                buf.copy_within(end + 1..n, 0);
                if n > end + 1 {
                    return Ok(n - end - 1);
                }
            }
        }
    }

    fn describe(&self) -> String {
        "a link losing every other reply".into()
    }
}

/// Frames an upload of `seq` in 1024-byte chunks sends (resends included)
/// to a fresh simulated device, every other reply lost when `lossy`.
fn frames_to_upload(seq: &Sequence, lossy: bool) -> u64 {
    let core = Arc::new(Mutex::new(FwCore::new(SimConfig::default()).unwrap()));
    let link = InProcess::new(core, Clock::manual_at_us(1_000_000));
    let mut client = Client::new(LosesEveryOtherReply {
        inner: link,
        lossy,
        requests: 0,
        swallow: false,
    });
    client.timeout = Duration::from_millis(20);
    let spec = upload_spec(seq, Encoding::Raw);
    client.upload(&spec, 0, 1024, |_, _| {}).unwrap();
    client.stats.requests + client.stats.retries
}

/// A lost reply costs a resend whatever a chunk's length, so shorter
/// chunks only multiply the frames: a link losing every other reply
/// sends each request twice, at full size once the search down to the
/// floor and back has shown shorter chunks lose as often. Halving on every
/// resend sent 1,562 frames of 64 bytes for the first 50 kB here.
#[test]
fn a_link_losing_every_other_reply_keeps_full_chunks() {
    let mut rng = SplitMix64::new(21);
    for steps in [200u16, 400] {
        let mut seq = spec(&mut rng);
        seq.header.steps = steps;
        seq.header.period_us = u32::from(steps) * 2_000;
        let n = usize::from(steps) * usize::from(seq.header.transducers);
        seq.phases = (0..n).map(|_| rng.next_u64() as u8).collect();
        let clean = frames_to_upload(&seq, false);
        let lossy = frames_to_upload(&seq, true);
        eprintln!("{n} bytes: {clean} frames clean, {lossy} losing every other reply");
        assert!(clean > n as u64 / 1024, "{clean} frames for {n} bytes");
        // The search costs some 30 requests, whatever the upload's length.
        assert!(
            lossy <= 2 * clean + 60,
            "{lossy} frames on the lossy link, {clean} on a clean one"
        );
    }
}

/// The issue's ≥ 1,000 randomised faulty uploads (about 10 s unoptimised).
#[test]
fn a_thousand_random_faulty_uploads() {
    campaign(1000, 2);
}

/// Ten times more, with other seeds.
#[test]
#[ignore = "long: run in release with --ignored"]
fn ten_thousand_random_faulty_uploads() {
    campaign((10_000.0 * long_scale()).round() as u64, 3);
}

/// The long run's share of its full size: `LM_LONG_SCALE` in (0, 1] (the
/// CI's everyday run), 1 when unset (`cargo xtask ci --full`).
fn long_scale() -> f64 {
    let s = std::env::var("LM_LONG_SCALE")
        .ok()
        .and_then(|s| s.parse().ok());
    s.filter(|s: &f64| *s > 0.0 && *s <= 1.0).unwrap_or(1.0)
}
