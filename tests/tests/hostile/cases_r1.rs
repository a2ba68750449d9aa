//! Rounds 1 and 2: issue 9's numbered classes and the paper audit.

use super::*;

/// Cases on devices of their own whose state carries from case to case
/// (play semantics, untracked play, one validation, the work volume).
pub(crate) fn device_state_cases() -> Vec<Case> {
    let at = |x: f64| {
        csv(&[
            &format!("0,{x},0,200,1"),
            &format!("0.01,{x},0,200,1"),
            &format!("0.02,{x},0,200,1"),
        ])
    };
    table! {
        // Untracked play: the device sounds without a finger, and says so;
        // what lmhost plays lasts while it holds the port (here briefly).
        UNTRACKED  "upload --port {dev} --freq 0.05 --untracked --hold 0.05" .ok()
                   .err("warning: playing untracked").out("playing slot 0, untracked")
                   .then("status --port {dev} --json", "\"mute_reason\":\"stopped\"");
        // 9. Play semantics: a free slot, the library's next free entry.
        PLAY       "upload --port {dev} --radius 2 --no-play" .ok().out("to slot 1")
                   .then("status --port {dev} --json", "\"slot\":0");
        PLAY       "play --port {dev} --slot 1 --hold 0.05" .ok().out("playing slot 1")
                   .then("status --port {dev} --json", "\"slot\":1");
        PLAY       "status --port {dev}" .ok().out("queued slot:      none");
        PLAY       "upload --port {dev} --no-play" .ok().out("to slot 0")
                   .then("status --port {dev} --json", "\"queued_slot\":null");
        PLAY       "upload --port {dev} --json --hold 0.05" .ok()
                   .out("\"mute_reason\":\"waiting_for_tracking\"")
                   .then("status --port {dev} --json", "\"state\":\"Stopped\"");
        // 10. The device's own answers, as the spec has them.
        SPEC       "play --port {dev} --slot 40" .err("32 slots");
        // A timed play needs a step count of at least 1, and plays from
        // silence or queued (never --immediate); lmhost holds it until the
        // device has stopped itself.
        PLAY       "play --port {dev} --slot 1 --steps 0" .err("--steps");
        PLAY       "play --port {dev} --slot 1 --steps -5" .err("--steps");
        PLAY       "play --port {dev} --slot 1 --steps 4294967296" .err("--steps");
        PLAY       "play --port {dev} --slot 1 --steps 10 --immediate" .err("--immediate");
        PLAY       "play --port {dev} --slot 1 --steps 10 --hold 1" .err("--hold");
        PLAY       "play --port {dev} --slot 1 --steps 10 --untracked" .ok()
                   .out("the device stops itself").out("stopped after cycle 0 step 10")
                   .then("status --port {dev} --json", "\"mute_reason\":\"stopped\"");
        // The host lease: 0.1 to 60 s, no "forever".
        PLAY       "play --port {dev} --slot 1 --lease 0" .err("0.1 to 60 s");
        PLAY       "play --port {dev} --slot 1 --lease 61" .err("0.1 to 60 s");
        PLAY       "upload --port {dev} --lease forever" .err("0.1 to 60 s");
        PLAY       "play --port {dev} --slot 1 --hold -1" .err("--hold");
        SPEC       "play --port {dev} --slot 32 --untracked" .err("32 slots");
        SPEC       "upload --port {dev} --slot 32" .err("32 slots");
        UNTRACKED  "stop --port {dev}" .ok()
                   .then("status --port {dev} --json", "\"mute_reason\":\"stopped\"");
        UNTRACKED  "status --port {dev}" .ok().out("mute reason:      stopped");
        UNTRACKED  "upload --port {dev} --hold 0.05" .ok().out("waiting for tracking")
                   .out("--untracked")
                   .then("status --port {dev} --json", "\"state\":\"Stopped\"");
        UNTRACKED  "stop --port {dev}" .ok()
                   .then("status --port {dev} --json", "\"state\":\"Stopped\"");
        UNTRACKED  "play --port {dev} --slot 1 --untracked --hold 0.05" .ok()
                   .err("warning: playing untracked")
                   .then("status --port {dev} --json", "\"lease_expiries\":0");
        UNTRACKED  "stop --port {dev}" .ok()
                   .then("status --port {dev} --json", "\"queued_slot\":null");
        // 11. One header, one validation, before any byte is sent.
        VALIDATION "upload --port {dev} --max-offset 0" .err("(0, 100] mm");
        VALIDATION "upload --port {dev} --max-offset 1e9" .err("(0, 100] mm");
        VALIDATION "upload --port {dev} --max-offset nan" .err("(0, 100] mm");
        VALIDATION "upload --port {dev} --max-offset -5" .err("(0, 100] mm");
        VALIDATION "upload --port {dev} --max-offset inf" .err("(0, 100] mm");
        VALIDATION "upload --port {dev} --max-offset -0" .err("(0, 100] mm");
        VALIDATION "upload --port {dev} --freq 20 --steps 100" .err("dwell");
        VALIDATION "upload --port {dev} --scene {dir}/short_dwell.toml --freq 20 --steps 100"
                   .err("does not fit").err("device's minimum 1000 µs");
        VALIDATION "upload --port {small}" .err("does not fit")
                   .then("status --port {small} --json", "\"nacks\":0");
        VALIDATION "upload --port {small} --foci 4 --slot 1" .err("does not fit")
                   .then("status --port {small} --json", "\"bad_frames\":0");
        VALIDATION "upload --port {small} --steps 10 --freq 1 --hold 0.05" .ok()
                   .then("status --port {small} --json", "\"nacks\":0");
        SPEC       "play --port {small} --slot 1" .code(1).err("refused play");
        // 5. The device's work volume: a centroid 30 mm off the planned
        // centre is refused (muted, counted), one inside unmutes.
        // Each stream plays the uploaded entry again and reports the
        // device's state before it leaves it silent.
        CENTROIDS  "upload --port {wv} --hold 0.05" .ok().out("within 20 mm of the centre");
        CENTROIDS  "stream --port {wv} --json" .stdin(at(30.0)).ok()
                   .out("\"outside_work_volume\":3")
                   .out("\"mute_reason\":\"centroid_out_of_range\"");
        CENTROIDS  "stream --port {wv}" .stdin(at(-25.0)).ok().out("outside").out("(Muted)");
        CENTROIDS  "stream --port {wv} --json" .stdin(at(0.0)).ok()
                   .out("\"outside_work_volume\":0").out("\"device_state\":\"Playing\"");
        CENTROIDS  "stream --port {wv} --json" .stdin(at(19.0)).ok()
                   .out("\"outside_work_volume\":0").out("\"mute_reason\":\"none\"")
                   .then("status --port {wv} --json", "\"state\":\"Stopped\"");
    }
}

pub(crate) fn cases() -> Vec<Case> {
    let wild = csv(&[
        "0.01,0,0,200,1",
        "0,0,0,200,1",
        "0.02,1e30,0,200,1",
        "0.03,0,0,200,1",
    ]);
    let mixed = [
        good_udp(2),
        garbage(50),
        vec![b"\xff\xfe".to_vec()],
        good_udp(2),
    ]
    .concat();
    let mut v = table! {
        // 1. Floats that become durations.
        DURATION   "stream --port {port} --input {dir}/gap.csv" .err("line 2").err("at most 60 s");
        DURATION   "stream --port {port} --input {dir}/gap100k.csv" .err("line 2");
        DURATION   "stream --port {port} --input {dir}/backwards.csv" .err("line 2");
        DURATION   "stream --port {port} --input {dir}/gap.csv --fast" .err("line 2");
        DURATION   "stream --port {port} --udp 47001 --seconds 1e30" .err("--seconds");
        DURATION   "stream --port {port} --synthetic --seconds 1e30" .err("at most 86400");
        DURATION   "stream --port {port} --synthetic --fast --seconds 1e30" .err("at most 3600");
        DURATION   "stream --port {port} --synthetic --seconds inf" .err("--seconds");
        DURATION   "stream --port {port} --synthetic --seconds nan" .err("--seconds");
        DURATION   "stream --port {port} --synthetic --seconds -1" .err("--seconds");
        DURATION   "stream --port {port} --synthetic --seconds 0" .err("--seconds");
        DURATION   "stream --port {port} --lead-ms 1e30" .err("--lead-ms");
        DURATION   "sim --seconds 1e30" .err("at most 86400");
        DURATION   "sim --seconds nan" .err("--seconds");
        DURATION   "sim --seconds 0" .err("--seconds");
        DURATION   "sim --seconds -5" .err("--seconds");
        DURATION   "demo --seconds 1e30" .err("--seconds");
        DURATION   "stream --port {port} --synthetic --fast --seconds 0.3" .ok();
        DURATION   "stream --port {port} --input {dir}/ok.csv" .ok().out("streamed 2 samples");
        DURATION   "sim --seconds 0.3" .ok();
        // 2. Output into a closed pipe ends quietly with exit 0.
        PIPE       "plan --json --phases" .closed_stdout();
        PIPE       "plan" .closed_stdout();
        PIPE       "plan --foci 4 --json" .closed_stdout();
        PIPE       "plan --method gspat --foci 2 --iterations 5 --json --phases" .closed_stdout();
        PIPE       "scene --json" .closed_stdout();
        PIPE       "scene" .closed_stdout();
        PIPE       "scene --scene {scenes}/paper.toml --json" .closed_stdout();
        PIPE       "status --port {port}" .closed_stdout();
        PIPE       "status --port {port} --json" .closed_stdout();
        PIPE       "info --port {port}" .closed_stdout();
        PIPE       "bench --quick --section planner" .closed_stdout();
        PIPE       "stream --port {port} --synthetic --fast --seconds 0.2" .closed_stdout();
        PIPE       "plan --help" .closed_stdout();
        PIPE       "simulate --plane-size 2 --plane-step 1 --out {dir}/pipe_sim" .closed_stdout();
        // 3. Unbounded memory.
        MEMORY     "stream --port {port}" .stdin(vec![0u8; 200_000]).err("4096 bytes");
        MEMORY     "stream --port {port}" .stdin("9".repeat(5000)).err("line 1");
        MEMORY     "stream --port {port} --input {dir}/long.csv" .err("line 2").err("4096");
        MEMORY     "stream --port {port} --json"
                   .stdin(format!("0,0,0,200,1\n{}\n", "1".repeat(4097))).err("4096");
        MEMORY     "sim --slot-steps 4000000000" .err("1..=65535");
        MEMORY     "sim --slot-steps 65536" .err("1..=65535");
        MEMORY     "sim --slot-steps 0" .err("1..=65535");
        MEMORY     "sim --slot-steps -1";
        MEMORY     "sim --centroid-timeout-ms 4000000000" .err("0..=3600000");
        MEMORY     "plan --steps 70000" .err("65535");
        MEMORY     "plan --steps 18446744073709551616";
        MEMORY     "plan --foci 100000" .err("1..=32");
        MEMORY     "plan --step 0.00001" .err("more than 65535");
        MEMORY     "stream --port {port} --udp 47002 --seconds 1 --json"
                   .udp(47002, vec![vec![b'5'; 5000], b"0,0,0,200,1".to_vec()]).ok()
                   .out("\"bad_datagrams\":1");
        // 4. Unbounded work.
        WORK       "plan --method gspat --iterations 100000000" .err("1..=1000");
        WORK       "plan --method gspat --iterations 0" .err("1..=1000");
        WORK       "simulate --plane-step 0.011 --out {dir}/w1" .err("exceeds the limit");
        WORK       "simulate --plane-step 0.001 --out {dir}/w2" .err("points");
        WORK       "simulate --reference --plane-size 60 --plane-step 0.1 --out {dir}/w3"
                   .err("--reference");
        WORK       "simulate --steps 60000 --freq 0.01 --plane-step 0.1 --out {dir}/w4"
                   .err("exceeds");
        WORK       "status --port {port} --timeout-ms 100000000000" .err("1..=60000");
        WORK       "status --port {port} --timeout-ms 0" .err("1..=60000");
        WORK       "status --port {port} --tries 4000000000" .err("1..=100");
        WORK       "status --port {port} --tries 0" .err("1..=100");
        WORK       "stream --port {port} --synthetic --fast --seconds 4000" .err("3600");
        WORK       "plan --freq 1e9" .err("..=1000 Hz");
        WORK       "plan --method gspat --foci 2 --iterations 1000 --steps 8 --freq 1 --radius 3"
                   .ok();
        // 5. Wild centroids: dropped and counted before the filters.
        CENTROIDS  "stream --port {port} --json" .stdin(&wild).ok().out("\"out_of_order\":1")
                   .out("\"out_of_range\":1")
                   .then("status --port {port} --json", "\"correction_um\":[0,0,0]");
        CENTROIDS  "stream --port {port} --json"
                   .stdin(csv(&["0,0,0,200,1", "0.01,500,0,200,1", "0.02,0,0,200,1"])).ok()
                   .out("\"jumps\":1");
        CENTROIDS  "stream --port {port} --json" .stdin(csv(&["0,2001,0,200,1", "0.01,0,0,200,1"]))
                   .ok().out("\"out_of_range\":1");
        CENTROIDS  "stream --port {port} --json"
                   .stdin(csv(&["0,1e300,1e300,1e300,0", "0.01,0,0,200,1"])).ok()
                   .out("\"out_of_range\":0");
        CENTROIDS  "stream --port {port} --filter one-euro --json" .stdin(&wild).ok()
                   .out("\"out_of_order\":1");
        CENTROIDS  "stream --port {port} --filter gaussian --json" .stdin(&wild).ok();
        CENTROIDS  "stream --port {port} --filter none --json" .stdin(&wild).ok();
        CENTROIDS  "stream --port {port}" .stdin(csv(&["0,0,0,nan,1"])).err("finite");
        CENTROIDS  "stream --port {port}" .stdin(csv(&["inf,0,0,200,1"])).err("finite");
        CENTROIDS  "stream --port {port}" .stdin(csv(&["0,-inf,0,200,1"])).err("line 1");
        CENTROIDS  "stream --port {port}" .stdin("{\"t\":0,\"x\":1e400,\"y\":0,\"z\":200}\n")
                   .err("line 1");
        CENTROIDS  "stream --port {port}" .stdin("{\"t\":0,\"x\":0}\n").err("line 1");
        CENTROIDS  "stream --port {port} --udp 47003 --seconds 1 --json"
                   .udp(47003, vec![b"0,0,0,200,1".to_vec(), b"0.01,1e30,0,200,1".to_vec()]).ok()
                   .out("\"out_of_range\":1");
        // 6. Silently wrong plans.
        PLANS      "plan --weights 0" .err("all zero");
        PLANS      "plan --foci 2 --weights 0,0" .err("all zero");
        PLANS      "plan --foci 2 --weights 1,nan" .err("out of range");
        PLANS      "plan --weights 1e300" .err("1e300");
        PLANS      "plan --z 1e12" .err("-100..=100 mm");
        PLANS      "plan --radius 1e30 --steps 4" .err("0..=100 mm");
        PLANS      "plan --radius 101" .err("0..=100 mm");
        PLANS      "plan --center 0,0,1e30" .err("±2000 mm");
        PLANS      "plan --center 0,0,1e12" .err("±2000 mm");
        PLANS      "plan --center 5000,0,200" .err("±2000 mm");
        // A bad plan on a scene that would also warn: the error alone.
        PLANS      "plan --scene {dir}/edge_on.toml --radius 1e30" .err("0..=100 mm");
        PLANS      "plan --scene {dir}/edge_on.toml --center 0,0,-5" .err("behind");
        PLANS      "plan --center 0,0,-100" .err("behind or in the plane");
        PLANS      "plan --center 0,0,0" .err("behind or in the plane");
        PLANS      "plan --foci 2 --spacing 1e9" .err("spacing");
        PLANS      "plan --step 1e30" .err("step");
        PLANS      "plan --freq 0" .err("frequency");
        PLANS      "plan --scene {dir}/same_pose.toml" .err("overlap");
        PLANS      "plan --scene {dir}/overlap.toml" .err("overlap");
        PLANS      "scene --scene {dir}/same_pose.toml --json" .err("overlap");
        PLANS      "plan --scene {dir}/far.toml" .err("±2000 mm");
        PLANS      "plan --scene {dir}/far_rig.toml" .err("±2000 mm");
        PLANS      "plan --scene {dir}/far_reflector.toml" .err("reflector");
        PLANS      "plan --scene {dir}/far_center.toml" .err("center_mm");
        PLANS      "plan --scene {dir}/facing_away.toml" .err("behind or in the plane");
        PLANS      "simulate --center 0,0,-100 --out {dir}/p1" .err("behind");
        PLANS      "upload --port {port} --center 0,0,-100" .err("behind");
        PLANS      "upload --port {port} --weights 0" .err("all zero");
        PLANS      "plan --scene {dir}/abutting.toml --center 96,0,200" .ok();
        PLANS      "plan --radius 100 --steps 4 --freq 1" .ok();
        PLANS      "plan --intensity 1.5" .err("0..=1");
        PLANS      "plan --intensity -0.1" .err("0..=1");
        PLANS      "plan --intensity nan" .err("0..=1");
        PLANS      "upload --port {port} --intensity 2" .err("0..=1");
        PLANS      "simulate --intensity 0.5 --out {dir}/p0" .err("full output");
        PLANS      "plan --intensity 0.25" .ok();
        PLANS      "stream --port {port} --intensity 3 --synthetic" .err("0..=1");
        PLANS      "simulate --alpha 1e300 --out {dir}/p2" .err("allowed above 0 and at most 2");
        PLANS      "simulate --calibration 1e300 --out {dir}/p3" .err("--calibration");
        PLANS      "simulate --calibration 0 --out {dir}/p3c" .err("--calibration");
        PLANS      "simulate --disk 1e300 --out {dir}/p4" .err("--disk");
        PLANS      "simulate --width-mm 10 --out {dir}/p4w" .err("--width-mm");
        PLANS      "simulate --width-mm nan --out {dir}/p4n" .err("--width-mm");
        PLANS      "simulate --plane-center 0,0,1e30 --out {dir}/p5" .err("±2000 mm");
        PLANS      "simulate --plane-size 1e9 --out {dir}/p6" .err("--plane-size");
        EXIT       "stream --port {port} --udp 0" .err("--udp");
        // 7. Exit codes: bad input is 2, a failed operation 1.
        EXIT       "status --port tcp:127.0.0.1" .err("no port");
        EXIT       "status --port tcp:127.0.0.1:99999" .err("1..=65535");
        EXIT       "status --port tcp:256.1.1.1:1" .err("IPv4");
        EXIT       "status --port tcp::4000" .err("no host");
        EXIT       "status --port tcp:127.0.0.1:0" .err("1..=65535");
        EXIT       "stop --port tcp:127.0.0.1:x" .err("1..=65535");
        EXIT       "stream --port {port} --input {dir}/a_directory" .err("directory");
        EXIT       "stream --port {port} --input {dir}/bin.csv" .err("not UTF-8");
        EXIT       "stream --port {port}" .stdin(b"\xff\xfe\n").err("not UTF-8");
        EXIT       "stream --port {port} --input {dir}/no_such.csv" .err("no such file");
        EXIT       "plan --scene {dir}/a_directory" .err("cannot read");
        EXIT       "plan --scene {dir}/bin.toml";
        EXIT       "plan --foci x" .err("--foci");
        EXIT       "plan --no-such-flag" .err("--no-such-flag");
        EXIT       "status --port tcp:127.0.0.1:1" .code(1).err("127.0.0.1:1");
        EXIT       "status --port /dev/lmhost-no-such-port" .code(1).err("lmhost-no-such-port");
        // 8. Streaming sessions.
        SESSIONS   "stream --port {port} --udp 47004 --seconds 1 --json"
                   .udp(47004, [garbage(1), good_udp(5)].concat()).ok().out("\"bad_datagrams\":1")
                   .out("\"samples\":5");
        SESSIONS   "stream --port {port} --udp 47005 --seconds 1 --json"
                   .udp(47005, mixed).ok().out("\"bad_datagrams\":51");
        SESSIONS   "stream --port {port} --udp 47006 --seconds 5" .udp(47006, garbage(1000))
                   .err("flood");
        SESSIONS   "stream --port {port}" .stdin(csv(&["0,0,0,200,1"])).hold_stdin()
                   .signal("INT", 700).ok().out("stopped by SIGINT; device muted")
                   .then("status --port {port} --json", "\"state\":\"Stopped\"");
        SESSIONS   "stream --port {port} --json" .stdin(csv(&["0,0,0,200,1"])).hold_stdin()
                   .signal("TERM", 700).ok().out("\"stopped\":true").out("\"muted_at_end\":true");
        SESSIONS   "stream --port {port} --udp 47007 --seconds 60" .signal("INT", 700).ok()
                   .out("stopped by SIGINT");
        SESSIONS   "stream --port {port} --input {dir}/pause50.csv" .signal("INT", 700).ok()
                   .out("device muted");
        SESSIONS   "stream --port {port} --synthetic --seconds 60" .signal("INT", 700).ok()
                   .out("stopped by SIGINT");
        SESSIONS   "stream --port {port} --away 1,2" .err("--synthetic");
        SESSIONS   "stream --port {port} --input {dir}/ok.csv" .ok()
                   .then("status --port {port} --json", "\"last_centroid_seq\"");
        // Paper fidelity.
        PAPER      "plan --scene {scenes}/paper.toml" .ok().check(no_warning);
        PAPER      "plan --scene {scenes}/paper.toml --foci 4 --json" .ok().check(no_warning);
        PAPER      "plan --scene {dir}/edge_on.toml" .ok().err("warning: the LM plane");
        PAPER      "plan --scene {dir}/tilted_45.toml" .ok().check(no_warning);
        PAPER      "plan" .ok().check(no_warning);
        PAPER      "simulate --compare --plane-size 2 --plane-step 1 --out {dir}/compare" .ok()
                   .check(compare_summary_is_true);
        PAPER      "simulate --plane-size 2 --plane-step 1 --out {dir}/single" .ok()
                   .check(single_summary_is_true);
    };
    v.extend(device_state_cases());
    v.extend(table! {
        // Scene files: capped in size, every number in a sane range.
        MEMORY     "plan --scene {dir}/many_devices.toml" .err("larger than 1048576 bytes");
        MEMORY     "plan --scene {dir}/huge_comment.toml" .err("larger than 1048576 bytes");
        PLANS      "plan --scene {dir}/spinning.toml" .err("±360°");
        PLANS      "plan --scene {dir}/slow_dwell.toml" .err("(0, 1000] ms");
        // Tracker files with a byte-order mark or CRLF line ends.
        EXIT       "stream --port {port} --input {dir}/bom.csv" .ok().out("streamed 2 samples");
        EXIT       "stream --port {port} --input {dir}/crlf.csv" .ok().out("streamed 2 samples");
        // Depth recordings: nothing allocated before the file's size
        // confirms the shape; every header lie refused.
        DURATION   "track" .depth("ok.npy", "cam.toml").ok().out("2 frames of 4×4");
        DURATION   "track" .depth("ok.npy", "cam.toml").args("--timestamps {dir}/gap_ts.npy")
                   .err("frame 1").err("at most 60 s");
        DURATION   "track" .depth("ok.npy", "cam.toml").args("--timestamps {dir}/gap100k_ts.npy")
                   .err("frame 1");
        DURATION   "track" .depth("ok.npy", "cam.toml")
                   .args("--timestamps {dir}/gap_ts.npy --port {port}").err("frame 1");
        DURATION   "track --depth {dir}/ok.npy --intrinsics {dir}/cam.toml --scene {scenes}/paper.toml --timestamps {dir}/gap100k_ts.npy"
                   .err("frame 1");
        MEMORY     "track" .depth("tb.npy", "cam.toml").err("truncated");
        MEMORY     "track" .depth("overflow.npy", "cam.toml").err("too large");
        MEMORY     "track" .depth("header_lie.npy", "cam.toml").err("header of 60000 bytes");
        EXIT       "track" .depth("negative.npy", "cam.toml").err("not a tuple of sizes");
        EXIT       "track" .depth("float.npy", "cam.toml").err("expected uint16");
        EXIT       "track" .depth("fortran.npy", "cam.toml").err("Fortran");
        EXIT       "track" .depth("truncated.npy", "cam.toml").err("truncated");
        EXIT       "track" .depth("long_tail.npy", "cam.toml").err("bytes after the data");
        EXIT       "track" .depth("twice.npy", "cam.toml").err("'descr' twice");
        EXIT       "track" .depth("a_directory", "cam.toml").err("a_directory");
        EXIT       "track" .depth("ok.npy", "cam_fx0.toml").err("`fx`");
        EXIT       "track" .depth("ok.npy", "cam_fxneg.toml").err("`fx`");
        PLANS      "track" .depth("ok.npy", "cam_fxhuge.toml").err("`fx`");
        PLANS      "track" .depth("ok.npy", "cam_ppx.toml").err("`ppx` must lie in the image");
        PLANS      "track" .depth("ok.npy", "cam_ppy.toml").err("`ppy` must lie in the image");
        EXIT       "track" .depth("ok.npy", "cam_nan.toml").err("depth_scale");
        EXIT       "track" .depth("ok.npy", "cam_wide.toml").err("the intrinsics say 8×4");
        EXIT       "track" .depth("ok.npy", "cam_str.toml").err("field `fy`: \"2\" is text, not a number: write `2` without quotes");
        EXIT       "track" .depth("ok.npy", "cam_dup.toml").err("duplicate key");
        EXIT       "track" .depth("ok.npy", "cam_unknown.toml").err("unknown field");
        EXIT       "track" .depth("ok.npy", "a_directory").err("a directory");
        // Output paths that cannot be written: a failed operation.
        EXIT       "track" .depth("ok.npy", "cam.toml").args("--record {dir}/no_such_dir/rec.npy")
                   .code(1).err("no_such_dir");
        EXIT       "track" .depth("ok.npy", "cam.toml").args("--record {dir}/a_directory").code(1)
                   .err("a_directory");
        EXIT       "track" .depth("ok.npy", "cam.toml").args("--plot {dir}/a_file").code(1)
                   .err("a_file");
        EXIT       "plan --out {dir}/a_directory" .code(1).err("a_directory");
        EXIT       "simulate --plane-size 2 --plane-step 1 --out {dir}/a_file" .code(1)
                   .err("a_file");
        PIPE       "track" .depth("ok.npy", "cam.toml").args("--json").closed_stdout();
        PIPE       "track --synthetic --seconds 0.3 --fast" .closed_stdout();
        PIPE       "upload --port {port} --no-play --slot 1" .closed_stdout();
        // Every track number flag: NaN, inf, negative, huge.
        WORK       "track --synthetic --seconds 1e30" .err("--seconds");
        PLANS      "track --synthetic --noise-mm nan" .err("--noise-mm");
        PLANS      "track --synthetic --holes 1.5" .err("--holes");
        PLANS      "track --synthetic --z-profile 3,8 --replan-mm nan" .err("--replan-mm");
        PLANS      "track --synthetic --z-profile inf,8" .err("--z-profile");
        MEMORY     "track --synthetic --z-profile 3,100000000" .err("--z-profile");
        EXIT       "track --synthetic --z-profile 3,8 --replan" .err("--port");
        EXIT       "sim --faults ber=1e-4,ber=1e-3" .err("given twice");
        WORK       "track --synthetic --enter-frames 4000000000" .err("--enter-frames");
    });
    v.extend(round3_cases());
    // Every plan flag with NaN: refused, never planned.
    for flag in ["--radius", "--spacing", "--freq", "--step"] {
        v.push(case(PLANS, "plan --foci 2").args(flag).args("NaN"));
    }
    // ... and with one focus, where --spacing cannot apply: refused.
    for bad in ["NaN", "inf", "-1", "1e308", "0"] {
        v.push(case(PLANS, "plan --spacing").args(bad).err("spacing"));
    }
    v
}
