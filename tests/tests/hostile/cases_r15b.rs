//! Round 15b: where a model, a spec and the code disagree.
//!
//! - r15b-1: every value a simulated instrument's flag allows is one its
//!   model gives a reading for. `gauge read --port sim --sim-depth 20`
//!   was inside the allowed 0..=20 mm, and the finger pad's exponential
//!   model pushed 1.1 MN there, an overload (exit 1); the range now stops
//!   at 7 mm, where the pad still reads below the gauge's 50 N.
//! - r15b-2: camera intrinsics no depth camera has are refused with their
//!   range: `fx = 1e-300` and `depth_scale = 1e-300` were accepted.
//! - r15b-4: a flag of several parts names the part that is wrong and
//!   what it allows: `--z-profile 0,8` (and `--away 2,1`) said the whole
//!   form and both ranges, `--center 0,inf,200` "must be finite".
//! - r15b-5: a centroid JSON object with a bad value is refused as a bad
//!   value of its key: `{"x":1e999,…}` was "not a centroid JSON object
//!   (`x`: 1e999 …)", `{"x":"a",…}` "not a centroid JSON object (invalid
//!   type: string "a", expected f64 …)", the key unnamed; a line that is
//!   no object, or not whole JSON, is still "not a centroid JSON object".
//! - r15b-6: a scene's `lm_plane` with `c = −(a × b)` (left-handed) is
//!   refused: it was taken as given, and ran the circle the other way
//!   about c, with the depth profile on the other side of the plane, than
//!   the same a and b with c left out.
//!
//! Fixtures in `{dir}/r15b`.

use super::*;

pub(crate) fn round15b_fixtures(dir: &Path) {
    let r = dir.join("r15b");
    std::fs::create_dir_all(&r).unwrap();
    let cam = |fx: &str, scale: &str| {
        format!(
            "width = 4\nheight = 4\nfx = {fx}\nfy = 2.0\nppx = 1.5\nppy = 1.5\ndepth_scale = {scale}\n"
        )
    };
    for (name, fx, scale) in [
        ("cam_fx_tiny.toml", "1e-300", "0.001"),
        ("cam_fx_far.toml", "2e5", "0.001"),
        ("cam_scale_tiny.toml", "2.0", "1e-300"),
    ] {
        std::fs::write(r.join(name), cam(fx, scale)).unwrap();
    }
    let plane = |c: &str| {
        format!(
            "[lm_plane]\na = [1.0, 0.0, 0.0]\nb = [0.0, 1.0, 0.0]\nc = {c}\n\n[[device]]\ncenter_mm = [0.0, 0.0, 0.0]\n"
        )
    };
    std::fs::write(r.join("left_handed.toml"), plane("[0.0, 0.0, -1.0]")).unwrap();
    std::fs::write(r.join("right_handed.toml"), plane("[0.0, 0.0, 1.0]")).unwrap();
}

pub(crate) fn round15b_cases() -> Vec<Case> {
    let full = "(the simulated pad reaches the gauge's 50 N capacity at 7.5 mm)";
    let mut v = Vec::new();
    for depth in ["20", "7.01", "-0.5"] {
        v.push(
            case(
                R15B_MODEL_RANGE,
                &format!("gauge read --port sim --sim-depth {depth}"),
            )
            .err(&format!(
                "error: simulated depth {depth} mm is outside 0..=7 mm {full}"
            )),
        );
    }
    v.push(
        case(R15B_MODEL_RANGE, "gauge read --port sim --sim-depth 7")
            .ok()
            .out(" N"),
    );
    let focal = "must be a focal length of 1..=100000 pixels";
    v.extend(table! {
        R15B_CAMERA "track" .depth("ok.npy", "r15b/cam_fx_tiny.toml")
            .err(&format!("error: intrinsics {{dir}}/r15b/cam_fx_tiny.toml: `fx` {focal}, got 1e-300"));
        R15B_CAMERA "track" .depth("ok.npy", "r15b/cam_fx_far.toml")
            .err(&format!("error: intrinsics {{dir}}/r15b/cam_fx_far.toml: `fx` {focal}, got 200000"));
        R15B_CAMERA "track" .depth("ok.npy", "r15b/cam_scale_tiny.toml")
            .err("error: intrinsics {dir}/r15b/cam_scale_tiny.toml: `depth_scale` must be 1e-6..=1 metres per unit, got 1e-300");
    });
    let radius = "allowed above 0 and at most 20 mm";
    v.extend(table! {
        R15B_PARTS "track --synthetic --fast --z-profile 0,8"
            .err(&format!("error: --z-profile `0,8`: the radius 0 mm is out of range: {radius}"));
        R15B_PARTS "track --synthetic --fast --z-profile 3,1001"
            .err("error: --z-profile `3,1001`: the steps 1001 are out of range: allowed 1..=1000");
        R15B_PARTS "track --synthetic --fast --z-profile 3,x"
            .err("error: --z-profile `3,x`: the steps `x` are not a whole number: allowed 1..=1000");
        R15B_PARTS "track --synthetic --fast --z-profile 3"
            .err("error: --z-profile `3`: give RADIUS_MM,STEPS: a radius and a step count, one comma between");
        R15B_PARTS "stream --port autd3:emulator --synthetic --fast --seconds 0.3 --away 2,1"
            .err("error: --away `2,1`: END 1 s is out of range: allowed after START (2 s), finite");
        R15B_PARTS "stream --port autd3:emulator --synthetic --fast --seconds 0.3 --away x,1"
            .err("error: --away `x,1`: START x is not a number: give one such as 2.5, -1 or 1e-3");
        R15B_PARTS "plan --center 0,inf,200"
            .err("error: --center `0,inf,200`: Y inf is not a finite number of mm");
    });
    let too_large = "is too large to represent (it would be read as inf): give a magnitude of at most 1.79769e308";
    let first = "{\"t\":0,\"x\":0,\"y\":0,\"z\":200}\n";
    for (line, want) in [
        (
            r#"{"t":0.01,"x":1e999,"y":0,"z":200}"#,
            format!("error: line 2: `x`: 1e999 {too_large}"),
        ),
        (
            r#"{"t":0.01,"x":0,"y":"1","z":200}"#,
            r#"error: line 2: `y`: "1" is not a number"#.to_owned(),
        ),
        (
            r#"{"t_s":0.01,"present":true,"centroid_mm":[0,0]}"#,
            "error: line 2: `centroid_mm`: [0,0] is not [x, y, z] (three numbers) or null"
                .to_owned(),
        ),
        (
            r#"{"t":0.01,"x":1e999,"y":0"#,
            "error: line 2: not a centroid JSON object (EOF while parsing".to_owned(),
        ),
    ] {
        v.push(
            case(R15B_BAD_VALUE, "stream --port {port}")
                .stdin(format!("{first}{line}\n"))
                .err(&want),
        );
    }
    v.extend(table! {
        R15B_HANDED "plan --scene {dir}/r15b/left_handed.toml"
            .err("error: scene file {dir}/r15b/left_handed.toml: lm_plane.c must be a × b = [0, 0, 1] (a, b, c right-handed): this c is −(a × b), which reverses the circle's direction about c and the side the depth profile is on; give a × b or leave c out");
        R15B_HANDED "plan --scene {dir}/r15b/right_handed.toml" .ok();
    });
    v
}
