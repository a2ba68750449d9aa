//! `lmhost track`: the synthetic finger, recording and replay, the LMDEPTH1
//! stream, streaming to `lmhost sim`, the plot, and bad input.

use std::path::Path;
use std::process::Command;

mod link_support;
use link_support::{
    Sim, assert_fields, json, lmhost, ok, one_line_error, run, run_stdin, scratch_dir, spread,
    stream_json,
};

fn paper() -> String {
    concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/paper.toml").to_string()
}

/// Half-size D435 intrinsics (424 × 240): the finger still covers ≈ 40
/// pixels of the box, and the debug build renders it quickly.
fn half_intrinsics(d: &Path) -> String {
    let p = d.join("half.toml");
    std::fs::write(
        &p,
        "width = 424\nheight = 240\nfx = 213.0\nfy = 213.0\nppx = 211.5\nppy = 119.5\ndepth_scale = 0.0001\n",
    )
    .unwrap();
    p.display().to_string()
}

/// `lmhost track` on the synthetic finger for `seconds`, fast, on the paper
/// scene seen through `cam`, with `extra` flags; its stdout.
fn synthetic(cam: &str, seconds: &str, extra: &[&str]) -> String {
    let scene = paper();
    let mut args = vec![
        "track",
        "--synthetic",
        "--seconds",
        seconds,
        "--fast",
        "--scene",
        &scene,
        "--intrinsics",
        cam,
    ];
    args.extend_from_slice(extra);
    ok(&args)
}

fn depth_args<'a>(rec: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec!["track", "--depth", rec];
    args.extend_from_slice(extra);
    args
}

/// A fresh directory `name` with half-size intrinsics, and `seconds` of the
/// synthetic finger recorded into `file` there: (directory, intrinsics,
/// recording, stdout).
fn recorded(
    name: &str,
    file: &str,
    seconds: &str,
    extra: &[&str],
) -> (link_support::Scratch, String, String, String) {
    let d = scratch_dir(name);
    let cam = half_intrinsics(&d);
    let rec = d.join(file).display().to_string();
    let mut args = vec!["--record", rec.as_str()];
    args.extend_from_slice(extra);
    let out = synthetic(&cam, seconds, &args);
    (d, cam, rec, out)
}

/// `lmhost track --depth <rec> <extra…>`: its one-line input error.
fn depth_error(rec: &str, extra: &[&str]) -> String {
    one_line_error(&run(&depth_args(rec, extra)), 2)
}

/// `lmhost track --depth <rec> --scene <paper> --fast --json <extra…>`: its stdout.
fn depth_json(rec: &str, extra: &[&str]) -> String {
    let scene = paper();
    let mut args = depth_args(rec, &["--scene", &scene, "--fast", "--json"]);
    args.extend_from_slice(extra);
    ok(&args)
}

fn lines(out: &str) -> Vec<serde_json::Value> {
    out.lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

#[test]
fn synthetic_frames_give_one_json_object_per_frame() {
    let d = scratch_dir("track-json");
    let cam = half_intrinsics(&d);
    let out = synthetic(&cam, "1.5", &["--json", "--z-profile", "3,8"]);
    let v = lines(&out);
    assert_eq!(v.len(), 135);
    let mut present = 0;
    let mut rising = 0;
    for (i, o) in v.iter().enumerate() {
        let points = o["points"].as_u64().unwrap();
        assert_eq!(o["present"].as_bool().unwrap(), points >= 20, "{o}");
        assert_eq!(o["centroid_mm"].is_null(), points < 20, "{o}");
        assert!((o["t_s"].as_f64().unwrap() - i as f64 / 90.0).abs() < 1e-9);
        // No filter: the gate's centre is the raw one, held through a
        // dropout, and there is one exactly while the gate is open.
        assert_eq!(
            o["filtered_mm"].is_null(),
            o["gated_present"] == false,
            "{o}"
        );
        if o["present"] == true && o["gated_present"] == true {
            assert_eq!(o["filtered_mm"], o["centroid_mm"], "{o}");
        }
        if o["present"] == true {
            present += 1;
            // The pad curves away from its centre: z_j mostly above it.
            let z = o["z_profile_mm"].as_array().unwrap();
            assert_eq!(z.len(), 8, "{o}");
            let mean: f64 = z.iter().map(|v| v.as_f64().unwrap()).sum::<f64>() / 8.0;
            rising += (mean > 0.0) as u32;
            let (c, t) = (&o["centroid_mm"], &o["truth_mm"]);
            for k in 0..3 {
                let e = c[k].as_f64().unwrap() - t[k].as_f64().unwrap();
                assert!(e.abs() < 1.0, "{o}");
            }
        }
    }
    // The finger arrives at ≈ 0.5 s and rests from 0.8 s.
    assert!(present > 60, "{present}");
    assert!(rising * 10 > present * 9, "{rising} of {present}");
    assert_eq!(v[0]["present"], false);
}

#[test]
fn a_synthetic_recording_replays_to_the_same_results() {
    let (d, _, rec_s, live) = recorded("replay", "rec.npy", "1.2", &["--json"]);
    assert!(d.join("rec.intrinsics.toml").exists());
    assert!(d.join("rec.timestamps.npy").exists());
    // Intrinsics and time stamps found beside the recording.
    let replay = depth_json(&rec_s, &[]);
    // And given explicitly.
    let explicit = depth_json(
        &rec_s,
        &[
            "--intrinsics",
            &d.join("rec.intrinsics.toml").display().to_string(),
            "--timestamps",
            &d.join("rec.timestamps.npy").display().to_string(),
        ],
    );
    let (a, b, c) = (lines(&live), lines(&replay), lines(&explicit));
    assert_eq!(a.len(), 108);
    assert_eq!(b.len(), a.len());
    assert_eq!(b, c);
    for (x, y) in a.iter().zip(&b) {
        for k in ["t_s", "points", "present", "centroid_mm"] {
            assert_eq!(x[k], y[k], "{k}: {x} vs {y}");
        }
    }
    assert!(b.iter().any(|o| o["present"] == true));
    // At recorded speed the replay takes the recording's length.
    let t0 = std::time::Instant::now();
    ok(&["track", "--depth", &rec_s, "--scene", &paper()]);
    assert!(t0.elapsed().as_secs_f64() >= 1.0, "{:?}", t0.elapsed());
}

#[test]
fn an_lmdepth1_stream_on_stdin_is_tracked_and_recorded() {
    use lmhost::sense::track::intrinsics::{Intrinsics, Pinhole};
    use lmhost::sense::track::source::{stream_frame, stream_header};
    let d = scratch_dir("track-stream");
    let intr = Intrinsics {
        pinhole: Pinhole {
            width: 424,
            height: 240,
            fx: 213.0,
            fy: 213.0,
            ppx: 211.5,
            ppy: 119.5,
        },
        depth_scale: 0.0001,
    };
    // Frames from a recording made by --synthetic, re-sent as a stream.
    let cam = half_intrinsics(&d);
    let rec = d.join("src.npy").display().to_string();
    let want = lines(&synthetic(&cam, "1", &["--json", "--record", &rec]));
    let mut bytes = stream_header(&intr, None);
    let mut r =
        lmhost::sense::track::source::Replay::open_with_defaults(Path::new(&rec), None, None)
            .unwrap();
    use lmhost::sense::track::source::FrameSource as _;
    while let Some(f) = r.next_frame().unwrap() {
        bytes.extend(stream_frame(f.t_s, &f.depth));
    }
    let out2 = d.join("again.npy").display().to_string();
    let out = run_stdin(
        &[
            "track",
            "--stream",
            "-",
            "--scene",
            &paper(),
            "--json",
            "--record",
            &out2,
        ],
        &bytes,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let got = lines(&String::from_utf8_lossy(&out.stdout));
    assert_eq!(got.len(), want.len());
    for (x, y) in want.iter().zip(&got) {
        assert_eq!(x["centroid_mm"], y["centroid_mm"]);
    }
    // What the stream delivered was recorded and replays the same.
    let again = lines(&ok(&[
        "track",
        "--depth",
        &out2,
        "--scene",
        &paper(),
        "--fast",
        "--json",
    ]));
    assert_eq!(again, got);

    // A stream cut inside a frame is a one-line input error.
    let out = run_stdin(
        &["track", "--stream", "-", "--scene", &paper()],
        &bytes[..bytes.len() - 100],
    );
    let err = one_line_error(&out, 2);
    assert!(err.contains("ended inside frame"), "{err}");
}

/// The half-size camera's intrinsics file (in a fresh folder named for
/// `name`) and a simulated device playing the default upload planned on
/// the same scene; the folder goes when its guard drops.
fn camera_and_device(name: &str) -> (String, Sim, link_support::Scratch) {
    let scratch = scratch_dir(name);
    let cam = half_intrinsics(&scratch);
    let sim = Sim::uploaded(&["--scene", &paper()]);
    (cam, sim, scratch)
}

#[test]
fn tracking_streams_the_gated_centre_to_the_device() {
    // Planned on the same scene, so the tracked finger is inside the
    // device's work volume around the planned centre.
    let (cam, sim, _dir) = camera_and_device("port");
    let out = synthetic(&cam, "1.5", &["--json", "--port", &sim.port]);
    let v = lines(&out);
    assert_eq!(v.len(), 135);
    for o in &v {
        assert!(
            o.get("gated_present").is_some() && o.get("filtered_mm").is_some(),
            "{o}"
        );
        assert_eq!(
            o["gated_present"] == true,
            !o["filtered_mm"].is_null(),
            "{o}"
        );
    }
    let last = v.last().unwrap();
    assert_eq!(last["gated_present"], true, "{last}");
    let status = json(&["status", "--port", &sim.port, "--json"]);
    assert!(
        status["last_centroid_seq"].as_u64().unwrap() >= 135,
        "{status}"
    );
    // Tracking ended and left the array silent itself (no lease ran out).
    assert_fields(
        &status,
        &["state", "mute_reason"],
        serde_json::json!(["Stopped", "stopped"]),
    );
}

#[test]
fn plot_writes_a_png_of_a_frame_with_the_contact_area() {
    let d = scratch_dir("track-plot");
    let cam = half_intrinsics(&d);
    let pd = d.join("plots");
    let out = synthetic(&cam, "1", &["--plot", &pd.display().to_string()]);
    let png: Vec<_> = std::fs::read_dir(&pd).unwrap().flatten().collect();
    assert_eq!(png.len(), 1, "{out}");
    let bytes = std::fs::read(png[0].path()).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    assert!(out.contains("frames of 424×240"), "{out}");
}

#[test]
fn bad_recordings_and_flags_are_one_line_errors() {
    let (d, cam, rec_s, _) = recorded("bad", "r.npy", "0.1", &[]);
    let rec = Path::new(&rec_s);
    // Truncated.
    let b = std::fs::read(rec).unwrap();
    std::fs::write(rec, &b[..b.len() - 7]).unwrap();
    let err = depth_error(&rec_s, &["--scene", &paper()]);
    assert!(err.contains("truncated"), "{err}");
    // Wrong dtype.
    let mut f8 = b"\x93NUMPY\x01\x00".to_vec();
    let h = "{'descr': '<f8', 'fortran_order': False, 'shape': (1, 2, 2), }";
    let h = format!("{h}{}\n", " ".repeat(128 - 10 - h.len() - 1));
    f8.extend_from_slice(&(h.len() as u16).to_le_bytes());
    f8.extend_from_slice(h.as_bytes());
    f8.extend_from_slice(&[0; 32]);
    std::fs::write(rec, &f8).unwrap();
    let err = depth_error(&rec_s, &["--scene", &paper(), "--intrinsics", &cam]);
    assert!(err.contains("uint16"), "{err}");
    // Intrinsics that do not match the frames.
    std::fs::write(rec, &b).unwrap();
    let full = d.join("full.toml");
    std::fs::write(
        &full,
        "width = 848\nheight = 480\nfx = 426.0\nfy = 426.0\nppx = 423.5\nppy = 239.5\ndepth_scale = 0.0001\n",
    )
    .unwrap();
    let err = depth_error(
        &rec_s,
        &[
            "--scene",
            &paper(),
            "--intrinsics",
            &full.display().to_string(),
        ],
    );
    assert!(err.contains("intrinsics say 848×480"), "{err}");
    // No source, two sources, a scene without [tracking].
    one_line_error(&run(&["track", "--scene", &paper()]), 2);
    one_line_error(
        &run(&["track", "--synthetic", "--camera", "--scene", &paper()]),
        2,
    );
    let flat = d.join("flat.toml");
    std::fs::write(&flat, "[[device]]\ncenter_mm = [0, 0, 0]\n").unwrap();
    let err = depth_error(&rec_s, &["--scene", &flat.display().to_string()]);
    assert!(err.contains("[camera]"), "{err}");
}

#[test]
fn camera_without_a_camera_is_a_one_line_failure() {
    // No RealSense here: the bridge reports what is missing, exit 1.
    let out = run(&["track", "--camera", "--scene", &paper()]);
    let err = one_line_error(&out, 1);
    assert!(err.contains("no camera"), "{err}");
    let out = Command::new(lmhost())
        .args(["track", "--camera", "--scene", &paper()])
        .env("LMHOST_PYTHON", "/nonexistent/python3")
        .output()
        .unwrap();
    let err = one_line_error(&out, 1);
    assert!(err.contains("cannot run"), "{err}");
}

#[test]
fn demo_tracks_synthetic_depth_frames() {
    let v = json(&["demo", "--tracking", "depth", "--seconds", "2", "--json"]);
    let t = &v["tracking"];
    assert!(t["centroid_error_rms_mm"].as_f64().unwrap() < 0.5, "{v}");
    assert!(spread(&v, t, "track_us")[0] > 0.0, "{v}");
    assert_eq!(v["muting"]["muted_in_every_status_while_away"], true, "{v}");
    assert!(v["centroids"]["sent"].as_u64().unwrap() >= 170, "{v}");
}

#[test]
fn replan_uploads_the_surface_profile_into_the_idle_slot() {
    let (cam, sim, _dir) = camera_and_device("replan");
    assert_eq!(json(&["status", "--port", &sim.port, "--json"])["slot"], 0);
    let out = ok(&[
        "track",
        "--synthetic",
        "--seconds",
        "1.5",
        "--fast",
        "--scene",
        &paper(),
        "--intrinsics",
        &cam,
        "--port",
        &sim.port,
        "--z-profile",
        "3,8",
        "--replan",
        "--replan-mm",
        "0.2",
        // Replies waited for as long as a loaded machine may take: a
        // centroid sent again after a late ack is refused as stale by the
        // device (and taken as delivered by lmhost), a NACK this test's
        // count of refusals would take for a refused upload.
        "--timeout-ms",
        "5000",
    ]);
    let line = out
        .lines()
        .find(|l| l.starts_with("device re-plans: "))
        .unwrap_or_else(|| panic!("no re-plan line: {out}"));
    let uploaded: u64 = line["device re-plans: ".len()..]
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(uploaded >= 1, "{line}");
    // The re-planned sequences went to free library entries and were
    // played (acked: the line above), slot 0 was never written while it
    // played (nothing was refused), and tracking left the array silent at
    // its end, queued re-plan and all. (With 32 entries a re-plan made
    // while the previous one is still queued takes the next free entry.)
    let st = json(&["status", "--port", &sim.port, "--json"]);
    assert_eq!(st["nacks"], 0, "{st}");
    assert_fields(
        &st,
        &["mute_reason", "queued_slot"],
        serde_json::json!(["stopped", null]),
    );

    // Without a port there is nothing to upload to: bad input.
    let out = run(&[
        "track",
        "--synthetic",
        "--seconds",
        "0.1",
        "--fast",
        "--z-profile",
        "3,8",
        "--replan",
    ]);
    one_line_error(&out, 2);
}

/// The number after `device re-plans: ` and the rest of that line.
fn replans(out: &str) -> (u64, String) {
    let line = out
        .lines()
        .find(|l| l.starts_with("device re-plans: "))
        .unwrap_or_else(|| panic!("no re-plan line: {out}"));
    let n = line["device re-plans: ".len()..]
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    (n, line.to_owned())
}

#[test]
fn replan_on_the_autd3_emulator_plans_lm_m_on_the_25_us_grid() {
    let scratch = scratch_dir("track-replan-autd3");
    let cam = half_intrinsics(&scratch);
    let out = synthetic(
        &cam,
        "1.5",
        &[
            "--port",
            "autd3:emulator",
            "--z-profile",
            "3,8",
            "--replan",
            "--replan-mm",
            "0.2",
            "--foci",
            "2",
            "--freq",
            "4.9",
        ],
    );
    let (uploaded, line) = replans(&out);
    assert!(uploaded >= 1, "{line}");
    // LM-M (2 foci) on --z-profile's 8 steps; 1 / (8 × 4.9 Hz) = 25.51 ms
    // lands on the grid at 25.5 ms (the LM firmware would play 25510.2 µs).
    assert!(
        line.contains("last: 8 steps × 2 foci, dwell 25500.0 µs"),
        "{line}"
    );
}

#[test]
fn track_plan_flags_upload_and_play_on_the_lm_firmware_too() {
    let (cam, sim, _dir) = camera_and_device("track-flags");
    let before = json(&["status", "--port", &sim.port, "--json"]);
    assert_eq!(before["slot"], 0);
    let scene = paper();
    let o = run(&[
        "track",
        "--synthetic",
        "--seconds",
        "0.3",
        "--fast",
        "--scene",
        &scene,
        "--intrinsics",
        &cam,
        "--port",
        &sim.port,
        "--foci",
        "4",
        "--radius",
        "4",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    // The same summary line as on AUTD3, naming what was planned.
    assert!(
        err.contains(&format!("{}: uploaded ", sim.port))
            && err.contains("read-back not available"),
        "{err}"
    );
    let st = json(&["status", "--port", &sim.port, "--json"]);
    assert!(st["slot"] == 1 || st["queued_slot"] == 1, "{st}");
    // Without --port a stimulus flag cannot apply: refused, not ignored.
    let o = run(&["track", "--synthetic", "--seconds", "0.1", "--radius", "4"]);
    assert!(one_line_error(&o, 2).contains("--radius applies with --port only"));
    // --replan measures the depth profile: --z cannot apply.
    let o = run(&[
        "track",
        "--synthetic",
        "--seconds",
        "0.1",
        "--port",
        &sim.port,
        "--z-profile",
        "3,8",
        "--replan",
        "--z",
        "1",
    ]);
    assert!(one_line_error(&o, 2).contains("--z cannot apply with --replan"));
}

#[test]
fn track_json_lines_stream_to_the_device() {
    let scratch = scratch_dir("track-to-stream");
    let cam = half_intrinsics(&scratch);
    let lines_out = synthetic(&cam, "1.5", &["--json", "--filter", "gaussian"]);
    let n = lines_out.lines().count();
    assert!(n > 30, "{lines_out}");
    let file_dir = scratch_dir("track-to-stream-file");
    let file = file_dir.join("track.jsonl");
    std::fs::write(&file, &lines_out).unwrap();
    let sim = Sim::uploaded(&["--scene", &paper()]);
    let v = stream_json(
        &sim.port,
        &[
            "--scene",
            &paper(),
            "--input",
            file.to_str().unwrap(),
            "--fast",
        ],
    );
    assert_eq!(v["samples"], n as u64, "{v}");
    assert_eq!(v["acked"], n as u64, "{v}");
    // The gated, filtered centre decides presence: as many as track said.
    let gated = lines_out
        .lines()
        .filter(|l| l.contains("\"gated_present\":true"))
        .count();
    assert_eq!(v["present"], gated as u64, "{v}");
    assert!(gated > 0, "{lines_out}");
    // Piped straight in, too.
    let o = run_stdin(
        &["stream", "--port", &sim.port, "--scene", &paper(), "--json"],
        lines_out.as_bytes(),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}
