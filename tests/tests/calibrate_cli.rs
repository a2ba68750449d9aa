//! `lmhost calibrate force|camera` end to end: the scene file updated in
//! place with every other line kept, the calibration then carried by
//! `simulate`, a camera pose recovered from synthetic ball recordings, and
//! bad input refused with one line and exit 2.

use std::path::Path;
use std::process::Output;

use lmhost::geom::{Vec3, add, euler_xyz_deg, norm, sub};
use lmhost::lab::calibrate::camera::render_ball;
use lmhost::npy::DepthNpyWriter;
use lmhost::plan::scene::Scene;
use lmhost::plan::scene::camera::CameraPose;
use lmhost::sense::track::intrinsics::Intrinsics;

mod link_support;
use link_support::{json_file, ok, one_line_error, run, scratch_dir};

fn paper_scene() -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/paper.toml"))
        .unwrap()
}

fn refused(o: &Output, needle: &str) {
    let err = one_line_error(o, 2);
    assert!(err.contains(needle), "{err}");
}

fn force_n(out: &Path) -> f64 {
    let s = json_file(out.join("summary.json"));
    s["force"]["step0_n"].as_f64().unwrap()
}

/// A scene saved on Windows (a byte-order mark, CRLF) is written back so:
/// every line it had stays byte for byte, the new table ends its lines
/// as the file does.
#[test]
fn a_scene_is_written_back_as_its_editor_saved_it() {
    let d = scratch_dir("cal-crlf");
    let scene = d.join("rig.toml");
    let windows = format!("\u{feff}{}", paper_scene().replace('\n', "\r\n"));
    std::fs::write(&scene, &windows).unwrap();
    let s = scene.to_str().unwrap();
    let out = d.join("out.toml");
    for dest in [["--out", out.to_str().unwrap()], ["--write", "--json"]] {
        let mut args = vec!["calibrate", "force", "--measured", "0.022", "--scene", s];
        args.extend(dest);
        ok(&args);
    }
    for written in [&out, &scene] {
        let text = std::fs::read_to_string(written).unwrap();
        assert!(text.starts_with(&windows), "{}", written.display());
        assert!(text.contains("[calibration]\r\n"), "{}", written.display());
        assert!(
            !text.replace("\r\n", "").contains('\n'),
            "{}",
            written.display()
        );
        assert_eq!(text.matches('\u{feff}').count(), 1);
        assert!(Scene::load(written).unwrap().calibration.is_some());
    }
}

#[test]
fn force_calibration_goes_into_the_scene_and_simulate_carries_it() {
    let d = scratch_dir("cal-force");
    let scene = d.join("rig.toml");
    std::fs::write(&scene, paper_scene()).unwrap();
    let s = scene.to_str().unwrap();
    let j: serde_json::Value = serde_json::from_str(&ok(&[
        "calibrate",
        "force",
        "--measured",
        "0.022",
        "--scene",
        s,
        "--write",
        "--json",
    ]))
    .unwrap();
    let k = j["pressure_scale"].as_f64().unwrap();
    assert!((k * j["simulated_n"].as_f64().unwrap() - 0.022).abs() < 1e-12);
    // Every line of the scene is still there; the table was added.
    let text = std::fs::read_to_string(&scene).unwrap();
    assert!(text.starts_with(&paper_scene()));
    assert_eq!(
        Scene::load(&scene)
            .unwrap()
            .calibration
            .unwrap()
            .pressure_scale,
        k
    );
    // Calibrating again replaces the table, it does not add one.
    ok(&[
        "calibrate",
        "force",
        "--measured",
        "0.03",
        "--scene",
        s,
        "--write",
    ]);
    let text = std::fs::read_to_string(&scene).unwrap();
    assert_eq!(text.matches("[calibration]").count(), 1);
    let k3 = Scene::load(&scene)
        .unwrap()
        .calibration
        .unwrap()
        .pressure_scale;
    assert!((k3 / k - 0.03 / 0.022).abs() < 1e-12);

    // simulate: the static focus gives the measured force; --calibration
    // replaces the scene's factor.
    let stat = [
        "simulate",
        "--radius",
        "0",
        "--plane-size",
        "17",
        "--plane-step",
        "0.25",
    ];
    let (a, b) = (d.join("cal"), d.join("flag"));
    let mut args = stat.to_vec();
    args.extend(["--scene", s, "--out", a.to_str().unwrap()]);
    let text = ok(&args);
    assert!(text.contains("calibrated: pressures and forces"), "{text}");
    assert!((force_n(&a) - 0.03).abs() < 1e-9, "{}", force_n(&a));
    let mut args = stat.to_vec();
    args.extend([
        "--scene",
        s,
        "--calibration",
        "1",
        "--out",
        b.to_str().unwrap(),
    ]);
    ok(&args);
    assert!((force_n(&b) * k3 - 0.03).abs() < 1e-9);

    // Bad input: one line, exit 2, the scene untouched.
    let before = std::fs::read(&scene).unwrap();
    for (args, says) in [
        (&["0", "--scene", s, "--write"][..], "--measured"),
        (&["0.02", "--disk", "-3", "--scene", s], "--disk"),
        (&["0.02", "--out", "x.toml"], "--scene"),
        (&["0.02", "--scene", s, "--out", s], "refusing"),
    ] {
        let mut all = vec!["calibrate", "force", "--measured"];
        all.extend_from_slice(args);
        refused(&run(&all), says);
    }
    assert_eq!(std::fs::read(&scene).unwrap(), before);
    let x = d.join("x");
    let bad = d.join("bad.toml");
    std::fs::write(
        &bad,
        paper_scene() + "\n[calibration]\npressure_scale = -1\n",
    )
    .unwrap();
    let mut args = stat.to_vec();
    args.extend([
        "--scene",
        bad.to_str().unwrap(),
        "--out",
        x.to_str().unwrap(),
    ]);
    refused(&run(&args), "calibration.pressure_scale");
    let _ = std::fs::remove_dir_all(&d);
}

/// `calibrate camera POINTS --intrinsics INTRINSICS EXTRA…`.
fn calibrate_camera<'a>(points: &'a Path, intrinsics: &'a Path, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "calibrate",
        "camera",
        points.to_str().unwrap(),
        "--intrinsics",
        intrinsics.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    args
}

#[test]
fn camera_pose_from_synthetic_ball_recordings_is_written_into_the_scene() {
    let d = scratch_dir("cal-camera");
    let intr = Intrinsics::D435_848X480;
    let p = &intr.pinhole;
    std::fs::write(
        d.join("cam.toml"),
        format!(
            "width = {}\nheight = {}\nfx = {:?}\nfy = {:?}\nppx = {:?}\nppy = {:?}\ndepth_scale = {:?}\n",
            p.width, p.height, p.fx, p.fy, p.ppx, p.ppy, intr.depth_scale
        ),
    )
    .unwrap();
    // A pose unlike the scene's.
    let r = euler_xyz_deg([-95.0, 8.0, 170.0]);
    let truth = CameraPose {
        position_mm: [15.0, 265.0, 90.0],
        axes: [0, 1, 2].map(|k| [r[0][k], r[1][k], r[2][k]]),
    };
    let mut rng = lmhost::rng::SplitMix64::new(11);
    let write = |name: &str, frames: Vec<Vec<u16>>| {
        let mut w =
            DepthNpyWriter::create(&d.join(name), intr.pinhole.width, intr.pinhole.height).unwrap();
        for f in &frames {
            w.push(f).unwrap();
        }
        w.finish().unwrap();
    };
    write(
        "bg.npy",
        (0..2)
            .map(|_| {
                render_ball(
                    &intr,
                    &truth,
                    [0.0, -3000.0, 0.0],
                    1.0,
                    650.0,
                    0.5,
                    &mut rng,
                )
            })
            .collect(),
    );
    let mut points = String::from("ball_diameter_mm = 40.0\nbackground = \"bg.npy\"\n");
    let marker: Vec3 = [0.0, 30.0, 30.0];
    for (i, o) in [
        [0.0, 0.0, 0.0],
        [45.0, 5.0, 0.0],
        [-40.0, 0.0, 15.0],
        [0.0, 40.0, -20.0],
        [10.0, -35.0, 25.0],
    ]
    .iter()
    .enumerate()
    {
        let at = add(marker, *o);
        write(
            &format!("p{i}.npy"),
            (0..2)
                .map(|_| render_ball(&intr, &truth, at, 40.0, 650.0, 0.5, &mut rng))
                .collect(),
        );
        points.push_str(&format!(
            "[[point]]\nat_mm = [{}, {}, {}]\ndepth = \"p{i}.npy\"\n",
            at[0], at[1], at[2]
        ));
    }
    std::fs::write(d.join("points.toml"), &points).unwrap();
    let scene = d.join("rig.toml");
    std::fs::write(&scene, paper_scene()).unwrap();
    let (pts, s, cam) = (
        d.join("points.toml"),
        scene.to_str().unwrap().to_string(),
        d.join("cam.toml"),
    );
    let j: serde_json::Value = serde_json::from_str(&ok(&calibrate_camera(
        &pts,
        &cam,
        &["--scene", &s, "--write", "--json"],
    )))
    .unwrap();
    assert_eq!(j["residuals_mm"].as_array().unwrap().len(), 5);
    let got = Scene::load(&scene).unwrap().camera.unwrap();
    let dp = norm(sub(got.position_mm, truth.position_mm));
    let tr: f64 = (0..3)
        .map(|k| lmhost::geom::dot(got.axes[k], truth.axes[k]))
        .sum();
    let da = ((tr - 1.0) / 2.0).clamp(-1.0, 1.0).acos().to_degrees();
    assert!(dp <= 0.5 && da <= 0.2, "{dp} mm, {da}°");
    // Only [camera] changed: the scene's other tables are as they were.
    let text = std::fs::read_to_string(&scene).unwrap();
    let orig = paper_scene();
    let tail = |t: &str| t[t.find("[tracking]").unwrap()..].to_string();
    assert_eq!(tail(&text), tail(&orig));
    assert_eq!(
        text[..text.find("[camera]").unwrap()],
        orig[..orig.find("[camera]").unwrap()]
    );

    // Bad input: one line, exit 2.
    std::fs::write(
        d.join("few.toml"),
        "ball_diameter_mm = 40.0\n[[point]]\nat_mm = [0, 0, 0]\ndepth = \"p0.npy\"\n",
    )
    .unwrap();
    refused(
        &run(&calibrate_camera(&d.join("few.toml"), &cam, &[])),
        "needs 3",
    );
    refused(
        &run(&["calibrate", "camera", pts.to_str().unwrap()]),
        "--intrinsics",
    );
    refused(
        &run(&calibrate_camera(&pts, &cam, &["--max-residual", "0"])),
        "--max-residual",
    );
    let _ = std::fs::remove_dir_all(&d);
}
