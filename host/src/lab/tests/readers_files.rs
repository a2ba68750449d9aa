//! The binary and file readers under the fuzz run: stimulus files
//! (`upload --phases` / `--foci-file`: JSON, plan reports, `.npy`, raw
//! bytes), `.npy` recordings (the header, depth and colour frames, time
//! stamps) and the `LMDEPTH1` / `LMCOLOR1` depth streams. Readers that
//! take a path get each mutant written to a scratch file first.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::harness::{Outcome, Reader, Verdict, finite, refused};
use crate::files::{Scratch, scratch};
use crate::limits::{MAX_REPLAY_GAP_S, MAX_TIME_STAMP_S};
use crate::npy::{self, ColourNpy, DepthNpy};
use crate::plan::scene::Scene;
use crate::plan::stimulus::{Stimulus, TargetPlan};
use crate::plan::stimulus_file::{Content, plan_for};
use crate::plan::target::Target;
use crate::plan::trajectory::{MAX_STEPS, Steps};
use crate::sense::track::colour::ColourImage;
use crate::sense::track::frame::FrameSource as _;
use crate::sense::track::wire;

/// A reader of files named `file` in a scratch folder of its own (kept
/// alive by the reader): each input written there, then `read`.
fn file_reader(
    name: &'static str,
    file: &str,
    seeds: Vec<Vec<u8>>,
    cases: usize,
    read: impl Fn(&Path) -> Outcome + 'static,
) -> Reader {
    let dir: Scratch = scratch(&format!("fuzz-{}", file.replace('.', "-")));
    let path: PathBuf = dir.join(file);
    Reader {
        name,
        seeds,
        cases,
        read: Box::new(move |b| {
            let _keep = &dir;
            std::fs::write(&path, b).map_err(|e| format!("writing the case: {e}"))?;
            read(&path)
        }),
    }
}

/// One device (249 transducers) and 8 steps a cycle: small files.
fn small() -> (Scene, TargetPlan) {
    let scene = Scene::from_toml("[[device]]\ncenter_mm = [0.0, 0.0, 0.0]\n", "small").unwrap();
    let mut s = Stimulus::paper_lm_m();
    s.cycle.steps = Steps::Count(8);
    let planned = s.plan_for(&Target::Lm, scene.clone()).unwrap();
    (scene, planned)
}

/// What an accepted stimulus file planned keeps: whole steps within the
/// device's limits, finite timing and foci.
fn plan_ok(p: &TargetPlan, transducers: usize) -> Result<(), String> {
    let t = &p.timing;
    if !(1..=MAX_STEPS).contains(&t.steps) || p.plan.sequence.phases.len() != t.steps * transducers
    {
        return Err(format!(
            "{} steps, {} phases",
            t.steps,
            p.plan.sequence.phases.len()
        ));
    }
    finite("the timing", &[t.dwell_us, t.freq_hz, t.step_mm])?;
    if !(t.dwell_us > 0.0 && p.plan.sequence.header.period_us > 0) {
        return Err(format!("dwell {} µs", t.dwell_us));
    }
    for f in &p.plan.trajectory.foci_mm {
        finite("a focus", f)?;
    }
    Ok(())
}

fn stimulus_reader(
    name: &'static str,
    file: &str,
    content: Content,
    seeds: Vec<Vec<u8>>,
    freq_hz: Option<f64>,
) -> Reader {
    let (scene, _) = small();
    let n = scene.transducer_count();
    file_reader(name, file, seeds, 5_000, move |p| {
        match plan_for(content, p, &Target::Lm, scene.clone(), freq_hz, None) {
            Ok(plan) => plan_ok(&plan, n).map(|()| Verdict::Accepted),
            Err(e) => refused(e),
        }
    })
}

fn stimulus_readers() -> Vec<Reader> {
    let (scene, planned) = small();
    let seq = &planned.plan.sequence;
    let n = scene.transducer_count();
    let dwell = planned.timing.dwell_us;
    let rows: Vec<String> = seq.phases.chunks(n).map(|r| format!("{r:?}")).collect();
    let phases_json = format!(
        "{{\"phases\": [{}], \"dwell_us\": {dwell}}}",
        rows.join(",")
    );
    let foci: Vec<String> = planned
        .plan
        .trajectory
        .foci_mm
        .chunks(planned.plan.trajectory.foci)
        .map(|s| format!("{s:?}"))
        .collect();
    let foci_json = format!(
        "{{\"foci_mm\": [{}], \"dwell_us\": {dwell}}}",
        foci.join(",")
    );
    let report = planned.out_bytes(Path::new("r.json"), &Target::Lm).unwrap();
    let foci_npy = {
        let t = &planned.plan.trajectory;
        let shape = [t.steps as u64, t.foci as u64, 3];
        let mut b = npy::header("<f8", &shape, 0);
        for f in &t.foci_mm {
            f.iter().for_each(|v| b.extend_from_slice(&v.to_le_bytes()));
        }
        b
    };
    vec![
        stimulus_reader(
            "phases JSON",
            "p.json",
            Content::Phases,
            vec![phases_json.into_bytes()],
            None,
        ),
        stimulus_reader(
            "plan report JSON",
            "r.json",
            Content::Phases,
            vec![report],
            None,
        ),
        stimulus_reader(
            "foci JSON",
            "f.json",
            Content::Foci,
            vec![foci_json.into_bytes()],
            None,
        ),
        stimulus_reader(
            "phases .npy",
            "p.npy",
            Content::Phases,
            vec![seq.to_npy()],
            Some(5.0),
        ),
        stimulus_reader(
            "foci .npy",
            "f.npy",
            Content::Foci,
            vec![foci_npy],
            Some(5.0),
        ),
        stimulus_reader(
            "phases .bin",
            "p.bin",
            Content::Phases,
            vec![seq.phases.clone()],
            Some(5.0),
        ),
    ]
}

/// An `.npy` of `descr` and `shape` holding `data`, as NPY 1.0 and 2.0.
fn npy_seeds(descr: &str, shape: &[u64], data: &[u8]) -> Vec<Vec<u8>> {
    let mut v1 = npy::header(descr, shape, 0);
    let text = v1[10..].to_vec();
    v1.extend_from_slice(data);
    let mut v2 = b"\x93NUMPY\x02\x00".to_vec();
    v2.extend_from_slice(&(text.len() as u32).to_le_bytes());
    v2.extend_from_slice(&text);
    v2.extend_from_slice(data);
    vec![v1, v2]
}

fn npy_readers() -> Vec<Reader> {
    let depth: Vec<u8> = (0..3 * 6 * 8u16)
        .flat_map(|v| (v * 37).to_le_bytes())
        .collect();
    let rgb: Vec<u8> = (0..2 * 4 * 5 * 3u32).map(|v| (v * 7) as u8).collect();
    let times: Vec<u8> = [0.0, 0.011, 0.022, 5.5]
        .iter()
        .flat_map(|v: &f64| v.to_le_bytes())
        .collect();
    let depth_seeds = npy_seeds("<u2", &[3, 6, 8], &depth);
    let colour_seeds = npy_seeds("|u1", &[2, 4, 5, 3], &rgb);
    let time_seeds = npy_seeds("<f8", &[4], &times);
    let mut every = depth_seeds.clone();
    every.extend(colour_seeds.iter().cloned());
    every.extend(time_seeds.iter().cloned());
    vec![
        Reader {
            name: "npy header",
            seeds: every,
            cases: 50_000,
            read: Box::new(|b| {
                match npy::read_header(&mut &b[..], b.len() as u64, Path::new("fuzz.npy")) {
                    Ok(h) if h.data_offset > b.len() as u64 => {
                        Err(format!("data at {} of {} bytes", h.data_offset, b.len()))
                    }
                    Ok(_) => Ok(Verdict::Accepted),
                    Err(e) => refused(e),
                }
            }),
        },
        file_reader("depth .npy", "d.npy", depth_seeds, 10_000, |p| {
            let len = std::fs::metadata(p).map_err(|e| e.to_string())?.len();
            let mut d = match DepthNpy::open(p) {
                Ok(d) => d,
                Err(e) => return refused(e),
            };
            let px = u64::from(d.width) * u64::from(d.height);
            if d.frames.saturating_mul(px).saturating_mul(2) > len {
                return Err(format!("{} frames of {px} pixels in {len} bytes", d.frames));
            }
            let mut buf = Vec::new();
            loop {
                match d.read_into(&mut buf) {
                    Ok(true) if buf.len() as u64 != px => {
                        return Err(format!("a frame of {} pixels, not {px}", buf.len()));
                    }
                    Ok(true) => {}
                    Ok(false) => return Ok(Verdict::Accepted),
                    Err(e) => return refused(e),
                }
            }
        }),
        file_reader("colour .npy", "c.npy", colour_seeds, 10_000, |p| {
            let mut c = match ColourNpy::open(p) {
                Ok(c) => c,
                Err(e) => return refused(e),
            };
            let bytes = 3 * c.width as usize * c.height as usize;
            loop {
                match c.read() {
                    Ok(Some(f)) if f.len() != bytes => {
                        return Err(format!("a frame of {} bytes, not {bytes}", f.len()));
                    }
                    Ok(Some(_)) => {}
                    Ok(None) => return Ok(Verdict::Accepted),
                    Err(e) => return refused(e),
                }
            }
        }),
        file_reader(
            "time stamps .npy",
            "t.npy",
            time_seeds,
            10_000,
            |p| match npy::read_timestamps(p) {
                Ok(t) => {
                    finite("a time stamp", &t)?;
                    let sorted = t
                        .windows(2)
                        .all(|w| w[0] <= w[1] && w[1] - w[0] <= MAX_REPLAY_GAP_S);
                    if !sorted || t.iter().any(|v| !(0.0..=MAX_TIME_STAMP_S).contains(v)) {
                        return Err(format!("time stamps {t:?}"));
                    }
                    Ok(Verdict::Accepted)
                }
                Err(e) => refused(e),
            },
        ),
    ]
}

fn stream(b: &[u8]) -> Outcome {
    let mut s = match wire::Stream::new(b, "fuzz stream") {
        Ok(s) => s,
        Err(e) => return refused(format!("{e:#}")),
    };
    let cams = s.cameras();
    let px = cams.depth.pinhole.width as usize * cams.depth.pinhole.height as usize;
    // Each frame takes at least 9 bytes: the stream ends before this.
    for _ in 0..=b.len() {
        match s.next_frame() {
            Ok(Some(f)) => {
                let stamps = [Some(f.t_s), f.colour.as_ref().map(|c| c.t_s)];
                if let Some(t) = stamps
                    .into_iter()
                    .flatten()
                    .find(|t| !(0.0..=MAX_TIME_STAMP_S).contains(t))
                {
                    return Err(format!("a frame stamped {t} s"));
                }
                if f.depth.len() != px {
                    return Err(format!("{} depth values, not {px}", f.depth.len()));
                }
                if let (Some(img), Some(cam)) = (&f.colour, &cams.colour)
                    && img.rgb.len() != cam.image_bytes()
                {
                    return Err(format!("a colour image of {} bytes", img.rgb.len()));
                }
            }
            Ok(None) => return Ok(Verdict::Accepted),
            Err(e) => return refused(format!("{e:#}")),
        }
    }
    Err("no end to the frames".into())
}

fn stream_seeds() -> Vec<Vec<u8>> {
    let (intr, cam) = crate::sense::track::wire::tests::cameras();
    let depth: Vec<u16> = (0..8).map(|v| 300 + v).collect();
    let mut plain = wire::stream_header(&intr, None);
    let mut colour = wire::stream_header(&intr, Some(&cam));
    for i in 0..3 {
        let t = 0.011 * f64::from(i);
        plain.extend(wire::stream_frame(t, &depth));
        let img = ColourImage {
            t_s: t,
            width: 2,
            height: 2,
            rgb: Arc::new((0..12).collect()),
        };
        let img = (i != 1).then_some(&img);
        colour.extend(wire::stream_frame_colour(t, &depth, img));
    }
    vec![plain, colour]
}

/// The files a study or a calibration reads beside its own: the camera
/// calibration's points file and a study's event log, read back on
/// `--resume` for a trial cut short.
fn lab_readers() -> Vec<Reader> {
    let points = b"ball_diameter_mm = 40.0\nbackground = \"empty.npy\"\n\
        [[point]]\nat_mm = [0, 30, 30]\ndepth = \"p1.npy\"\n\
        [[point]]\nat_mm = [60, 30, 30]\ndepth = \"p2.npy\"\n\
        [[point]]\nat_mm = [0, 90, 70.5]\ndepth = \"sub/p3.npy\"\n"
        .to_vec();
    let mut events = String::from("{\"event\":\"trial\",\"trial\":2}\n");
    events += "{\"event\":\"level\",\"trial\":2,\"answer\":null,\"level_intensity\":0.5}\n";
    for (a, l) in [("no", 0.55), ("yes", 0.5), ("no", 0.55)] {
        events += &format!(
            "{{\"t_host_us\":1,\"event\":\"level\",\"trial\":2,\"answer\":\"{a}\",\"level_intensity\":{l}}}\n"
        );
    }
    events += "{\"event\":\"trial\",\"trial\":2,\"resumed_presentations\":2}\n";
    events += "{\"event\":\"level\",\"trial\":2,\"answer\":\"ye";
    vec![
        file_reader(
            "calibration points TOML",
            "points.toml",
            vec![points],
            10_000,
            |p| {
                let t = match crate::lab::calibrate::camera::Target::load(p) {
                    Ok(t) => t,
                    Err(e) => return refused(e),
                };
                if !(3..=crate::lab::calibrate::camera::MAX_POINTS).contains(&t.points.len())
                    || !(5.0..=500.0).contains(&t.ball_diameter_mm)
                {
                    return Err(format!(
                        "{} points, a {} mm ball",
                        t.points.len(),
                        t.ball_diameter_mm
                    ));
                }
                for (at, _) in &t.points {
                    finite("a point", at)?;
                }
                Ok(Verdict::Accepted)
            },
        ),
        file_reader(
            "study event log",
            "events.jsonl",
            // Beside a hand-made log, a staircase run's own.
            vec![
                events.into_bytes(),
                super::readers_study::studies()[1].participants[0]
                    .2
                    .events
                    .clone(),
            ],
            10_000,
            |p| match crate::lab::study::midtrial::logged(p, 2, "level", "level_intensity") {
                Ok(got) => {
                    let levels: Vec<f64> = got.iter().map(|(_, l)| *l).collect();
                    finite("a level", &levels).map(|()| Verdict::Accepted)
                }
                Err(e) => refused(e),
            },
        ),
    ]
}

/// The binary and file readers with their seeds.
pub fn readers() -> Vec<Reader> {
    let mut v = stimulus_readers();
    v.extend(npy_readers());
    v.extend(lab_readers());
    v.push(Reader {
        name: "LMDEPTH1/LMCOLOR1 stream",
        seeds: stream_seeds(),
        cases: 50_000,
        read: Box::new(stream),
    });
    v
}
