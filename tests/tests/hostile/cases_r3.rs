//! Round 3 (issue 18): output errors, odd paths, numbers, ports, stalls,
//! and round 4's stimulus flags and files.

use super::*;

/// Issue 18's classes 1, 3, 4, 5 and 11 for plan, scene, simulate, stream
/// and the device commands.
pub(crate) fn round3_cases() -> Vec<Case> {
    let mut v = table! {
        // 1. Every write to stdout goes one way: a full disk is one line, exit 1.
        OUTPUT_ERRORS "plan" .full_stdout();
        OUTPUT_ERRORS "plan --json --phases" .full_stdout();
        OUTPUT_ERRORS "plan --foci 4 --out {dir}/full_stdout.npy" .full_stdout();
        OUTPUT_ERRORS "scene" .full_stdout();
        OUTPUT_ERRORS "scene --scene {scenes}/paper.toml --json" .full_stdout();
        OUTPUT_ERRORS "plan --help" .full_stdout();
        OUTPUT_ERRORS "--version" .full_stdout();
        OUTPUT_ERRORS "status --port {port}" .full_stdout();
        OUTPUT_ERRORS "status --port {port} --json" .full_stdout();
        OUTPUT_ERRORS "info --port {port}" .full_stdout();
        OUTPUT_ERRORS "bench --quick --section planner" .full_stdout();
        OUTPUT_ERRORS "simulate --plane-size 2 --plane-step 1 --out {dir}/full_stdout_sim"
                      .full_stdout();
        OUTPUT_ERRORS "stream --port {port} --input {dir}/ok.csv" .full_stdout();
        OUTPUT_ERRORS "stream --port {port} --input {dir}/ok.csv --json" .full_stdout();
        OUTPUT_ERRORS "upload --port {port} --no-play --slot 1" .full_stdout();
        OUTPUT_ERRORS "sim --seconds 0.3" .full_stdout();
        OUTPUT_ERRORS "track" .depth("ok.npy", "cam.toml").full_stdout();
        OUTPUT_ERRORS "track" .depth("ok.npy", "cam.toml").args("--json").full_stdout();
        // ... and a lost stderr changes nothing but what can be said.
        OUTPUT_ERRORS "plan --radius nan" .full_stderr();
        OUTPUT_ERRORS "plan --no-such-flag" .full_stderr();
        OUTPUT_ERRORS "plan" .full_stderr().ok();
        OUTPUT_ERRORS "plan --scene {dir}/edge_on.toml" .full_stderr().ok();
        OUTPUT_ERRORS "status --port /dev/lmhost-no-such-port" .full_stderr().code(1);
        OUTPUT_ERRORS "stream --port {port} --input {dir}/ok.csv" .full_stderr().ok();
        OUTPUT_ERRORS "plan" .full_stdout().full_stderr();
        // 3. An output that is an input is refused before anything is written.
        SAME_FILE     "plan --scene {dir}/scene_copy.toml --out {dir}/scene_copy.toml"
                      .err("scene_copy.toml").check(scene_copy_intact);
        SAME_FILE     "plan --scene {dir}/scene_copy.toml --out {dir}/scene_link.toml"
                      .err("scene_link.toml").check(scene_copy_intact);
        SAME_FILE     "plan --scene {dir}/scene_link.toml --out {dir}/scene_hard.toml"
                      .err("scene_hard.toml").check(scene_copy_intact);
        SAME_FILE     "plan --scene {dir}/scene_copy.toml --out {dir}/./scene_copy.toml"
                      .check(scene_copy_intact);
        SAME_FILE     "simulate --scene {dir}/scene_copy.toml --plane-size 2 --plane-step 1 --out {dir}/scene_copy.toml"
                      .check(scene_copy_intact);
        SAME_FILE     "plan --scene {dir}/scene_copy.toml --out {dir}/scene_copy_out.npy" .ok()
                      .check(scene_copy_intact);
        // 4. No partial outputs: a directory that is not there leaves nothing.
        PARTIAL       "plan --out {dir}/no_such_dir/p.npy" .code(1).err("no_such_dir/p.npy")
                      .check(dir_whole);
        PARTIAL       "plan --out {dir}/a_directory" .code(1).err("a_directory").check(dir_whole);
        PARTIAL       "plan --out {dir}/whole.npy" .ok().check(dir_whole);
        PARTIAL       "plan --out {dir}/whole.json" .ok().check(dir_whole);
        PARTIAL       "simulate --plane-size 2 --plane-step 1 --out {dir}/whole_sim" .ok()
                      .check(dir_whole);
        // ... and a full disk (a 32 KiB tmpfs) leaves nothing that looks complete.
        PARTIAL       "plan --out {full}/p.npy" .code(1).err("p.npy").err("no space left")
                      .check(full_whole);
        PARTIAL       "plan --out {full}/p.json" .code(1).err("p.json").err("no space left")
                      .check(full_whole);
        PARTIAL       "plan --out {full}/p.bin --foci 4" .code(1).err("no space left")
                      .check(full_whole);
        PARTIAL       "plan --out {full}/keep.bin" .code(1).err("keep.bin").check(full_whole);
        PARTIAL       "simulate --plane-size 20 --plane-step 1 --out {full}/sim" .code(1)
                      .err("no space left").check(full_whole);
        PARTIAL       "simulate --compare --plane-size 2 --plane-step 1 --out {full}/cmp" .code(1)
                      .err("no space left").check(full_whole);
        // 5. Odd input paths: refused at once, with the path and the reason.
        ODD_PATHS     "plan --scene {dir}/fifo" .err("fifo").err("FIFO");
        ODD_PATHS     "simulate --scene {dir}/fifo --out {dir}/odd_sim" .err("FIFO");
        ODD_PATHS     "scene --scene {dir}/fifo" .err("FIFO");
        ODD_PATHS     "upload --port {port} --scene {dir}/fifo" .err("FIFO");
        ODD_PATHS     "stream --port {port} --input {dir}/fifo" .err("FIFO");
        ODD_PATHS     "track" .depth("ok.npy", "fifo").err("FIFO");
        ODD_PATHS     "plan --scene /dev/null" .err("/dev/null").err("device node");
        ODD_PATHS     "plan --scene /dev/zero" .err("/dev/zero").err("device node");
        ODD_PATHS     "stream --port {port} --input /dev/zero" .err("device node");
        ODD_PATHS     "track --depth {dir}/ok.npy --intrinsics /dev/zero --scene {scenes}/paper.toml"
                      .err("device node");
        ODD_PATHS     "scene --scene {dir}/a_directory" .err("a_directory").err("directory");
        ODD_PATHS     "plan --scene {dir}/no_such.toml" .err("no_such.toml").err("no such file");
        ODD_PATHS     "stream --port {port} --input {dir}/stream_copy.csv" .ok()
                      .out("streamed 2 samples");
        ODD_PATHS     "stream --port {port} --input -" .stdin(csv(&["0,0,0,200,1"])).ok()
                      .out("streamed 1 sample ");
        // 11. Input-path messages keep the path and the reason.
        PATH_MESSAGES "stream --port {port} --input {dir}/a_directory" .err("a_directory")
                      .err("directory");
        PATH_MESSAGES "stream --port {port} --input {dir}/no_such.csv" .err("no_such.csv")
                      .err("no such file");
        PATH_MESSAGES "plan --scene {dir}/a_file/x.toml" .err("a_file/x.toml")
                      .err("not a directory");
        PATH_MESSAGES "track --depth {dir}/no_such.npy --intrinsics {dir}/cam.toml --scene {scenes}/paper.toml"
                      .err("no_such.npy").err("no such file");
        PATH_MESSAGES "track" .depth("ok.npy", "no_such.toml").err("no_such.toml")
                      .err("no such file");
    };
    // 7. One formatter for every number in a message; ranges checked before rounding.
    v.extend(table! {
        // The frequency's own range since round 13 (a period was derived).
        NUMBERS "plan --freq 1e-300" .err("frequency 1e-300 Hz").err("allowed 0.000232831..=").check(short_numbers);
        NUMBERS "plan --freq 1e300" .check(short_numbers);
        NUMBERS "plan --step 1e-300" .err("1e-300").check(short_numbers);
        NUMBERS "plan --step 5e-324" .check(short_numbers);
        NUMBERS "plan --spacing 1e-300 --foci 2" .err("1e-300").check(short_numbers);
        NUMBERS "plan --radius -1e300" .check(short_numbers);
        NUMBERS "plan --center 0,0,1e300" .check(short_numbers);
        NUMBERS "simulate --plane-step 1e-300 --out {dir}/n1" .err("points").check(short_numbers);
        NUMBERS "simulate --plane-step 1e-308 --out {dir}/n1" .err("cannot be held exactly")
                .check(short_numbers);
        NUMBERS "simulate --plane-step 5e-324 --out {dir}/n2" .check(short_numbers);
        NUMBERS "simulate --alpha -1e300 --out {dir}/n3" .check(short_numbers);
        NUMBERS "simulate --density 1e300 --out {dir}/n4" .check(short_numbers);
        NUMBERS "simulate --disk 1e-300 --plane-size 2 --plane-step 1 --out {dir}/n5" .ok()
                .check(short_numbers);
        NUMBERS "upload --port {port} --max-offset 100.0004 --no-play" .err("100.0004")
                .err("(0, 100] mm").check(short_numbers);
        NUMBERS "upload --port {port} --max-offset 1e-300 --no-play" .check(short_numbers);
        NUMBERS "upload --port {port} --max-offset 0.0004 --no-play" .err("0.001 mm");
        NUMBERS "upload --port {port} --max-offset 1e300 --no-play" .check(short_numbers);
        NUMBERS "upload --port autd3:emulator --freq 1e-300" .check(short_numbers);
        NUMBERS "upload --port autd3:emulator --freq 1e300" .check(short_numbers);
        NUMBERS "stream --port {port} --lead-ms 1e300" .check(short_numbers);
        NUMBERS "track --synthetic --fast --seconds 1e300" .check(short_numbers);
        NUMBERS "sim --faults ber=1e300" .check(short_numbers);
        NUMBERS "sim --faults ber=-1e300" .check(short_numbers);
        NUMBERS "demo --seconds 1e300" .check(short_numbers);
        NUMBERS "demo --seconds 0.9999999" .err("0.9999999");
    });
    // 10. Port strings: checked as input, wrong case hinted, a held port said.
    v.extend(table! {
        PORTS "status --port tcp:127.0.0.1:80:90" .err("colon");
        PORTS "status --port tcp:127.0.0.1:4000:" .err("tcp:HOST:PORT");
        PORTS "status --port tcp:my%20host:4000" .err("host");
        PORTS "status --port tcp:[::1]:x" .err("1..=65535");
        PORTS "status --port tcp:[::1:4000" .err("tcp:HOST:PORT");
        PORTS "status --port tcp:a/b:4000" .err("host");
        PORTS "status --port TCP:127.0.0.1:1" .err("lowercase").err("tcp:HOST:PORT");
        PORTS "status --port Tcp:127.0.0.1:1" .err("lowercase");
        PORTS "status --port AUTD3:emulator" .err("lowercase").err("autd3:emulator");
        PORTS "upload --port Autd3:emulator" .err("lowercase");
        PORTS "stream --port AUTD3:emulator --synthetic --seconds 1" .err("lowercase");
        PORTS "status --port autd3:remote:127.0.0.1:1" .code(1).check(cause_once);
        PORTS "status --port tcp:127.0.0.1:1" .code(1).err("connection refused");
        PORTS "status --port {busy}" .code(1).err("in use by another process");
        PORTS "upload --port {busy}" .code(1).err("in use by another process");
    });
    // A space inside one argument (the table splits on whitespace).
    v.push(Case {
        args: vec!["status".into(), "--port".into(), "tcp:my host:4000".into()],
        ..case(PORTS, "").err("host `my host`")
    });
    // A header and half of frame 0 of a 4×4 LMDEPTH1 stream: it stalls.
    let mut half = b"LMDEPTH1".to_vec();
    half.extend(4u32.to_le_bytes());
    half.extend(4u32.to_le_bytes());
    for x in [2.0f64, 2.0, 1.5, 1.5, 0.001] {
        half.extend(x.to_le_bytes());
    }
    half.extend(0f64.to_le_bytes());
    half.extend([0u8; 10]);
    v.extend(table! {
        // 2. A recording stopped by a signal is finished and replays.
        REC_SIGNAL "track --synthetic --seconds 60 --record {dir}/sig_int.npy" .signal("INT", 1500)
                   .ok().out("recorded").out("stopped by SIGINT").check(sig_int_replays);
        REC_SIGNAL "track --synthetic --seconds 60 --json --record {dir}/sig_term.npy"
                   .signal("TERM", 1500).ok().check(sig_term_replays);
        REC_SIGNAL "track --synthetic --seconds 60 --port {port} --record {dir}/sig_dev.npy"
                   .signal("INT", 1500).ok().out("stopped by SIGINT; device muted")
                   .then("status --port {port} --json", "\"state\":\"Stopped\"");
        REC_SIGNAL "track --synthetic --seconds 60" .signal("TERM", 1000).ok()
                   .out("stopped by SIGTERM");
        // 3. An output that is an input, refused before anything is written.
        SAME_FILE  "track --depth {dir}/in.npy --intrinsics {dir}/cam.toml --scene {scenes}/paper.toml --record {dir}/in.npy"
                   .err("in.npy").check(in_npy_intact);
        SAME_FILE  "track --depth {dir}/ok.npy --intrinsics {dir}/cam.toml --scene {scenes}/paper.toml --timestamps {dir}/rec2.timestamps.npy --record {dir}/rec2.npy"
                   .err("rec2.timestamps.npy").check(rec2_ts_intact);
        SAME_FILE  "track --depth {dir}/in.npy --intrinsics {dir}/cam.toml --scene {scenes}/paper.toml --plot {dir}/in.npy"
                   .err("in.npy").check(in_npy_intact);
        // 4. A failed recording leaves nothing under its name.
        PARTIAL    "track --synthetic --seconds 2 --record {full}/r.npy" .code(1)
                   .err("no space left").check(full_whole);
        // 5. Odd input paths for every track input.
        ODD_PATHS  "track --depth {dir}/fifo --intrinsics {dir}/cam.toml --scene {scenes}/paper.toml"
                   .err("FIFO");
        ODD_PATHS  "track --depth {dir}/ok.npy --intrinsics {dir}/cam.toml --scene {scenes}/paper.toml --timestamps {dir}/fifo"
                   .err("FIFO");
        ODD_PATHS  "track --stream {dir}/fifo --scene {scenes}/paper.toml" .err("FIFO");
        ODD_PATHS  "track --stream /dev/zero --scene {scenes}/paper.toml" .err("device node");
        ODD_PATHS  "track --stream {dir}/a_directory --scene {scenes}/paper.toml" .err("directory");
        PATH_MESSAGES "track --stream {dir}/no_such.bin --scene {scenes}/paper.toml"
                   .err("no_such.bin").err("no such file");
        // 6. Stalls end in bounded time with a clear error.
        STALLS     "track --camera --scene {scenes}/paper.toml" .code(1).err("no LMDEPTH1 header")
                   .env("LMHOST_PYTHON", "{dir}/stalled_bridge.sh");
        STALLS     "track --stream - --scene {scenes}/paper.toml --intrinsics {dir}/cam.toml"
                   .stdin(half.clone()).hold_stdin().code(1).err("stalled");
        STALLS     "track --stream - --scene {scenes}/paper.toml" .stdin(b"LMDEPTH1")
                   .hold_stdin().code(1).err("no LMDEPTH1 header");
        // 8. Rigs no frame can find a finger in: said, never silent.
        RIG        "track" .depth("ok.npy", "cam.toml").ok().err("warning: ").err("min_points");
        RIG        "track --synthetic --fast --seconds 0.5 --intrinsics {dir}/cam_tiny_scale.toml"
                   .ok().err("depth_scale");
        RIG        "track --synthetic --seconds 1e-300" .err("no frame");
        // The synthetic finger's own flags with another source: a conflict.
        RIG        "track" .depth("ok.npy", "cam.toml").args("--seconds 3")
                   .err("'--depth <FILE.npy>' cannot be used with '--seconds <S>'");
        RIG        "track" .depth("ok.npy", "cam.toml").args("--noise-mm 1")
                   .err("'--depth <FILE.npy>' cannot be used with '--noise-mm <MM>'");
        RIG        "track --camera --holes 0.5 --scene {scenes}/paper.toml"
                   .err("'--camera' cannot be used with '--holes <FRACTION>'");
        // 11. A --plot that would write nothing says so (a recording of
        //     no frames is refused before it is made: round 13).
        PATH_MESSAGES "track" .depth("empty.npy", "cam.toml").args("--plot {dir}/noplot")
                   .err("the recording holds no frames");
        // 9. What the device refused is said.
        REFUSALS   "track --synthetic --fast --seconds 1 --port {port}" .ok()
                   .out("device refusals:").out("outside the work volume");
        REFUSALS   "track --synthetic --fast --seconds 1 --port {port} --json" .ok()
                   .err("device refusals:");
    });
    // Round 4: a stimulus flag is never silently ignored; stimulus files
    // get the planned stimulus's checks, one line naming the file.
    v.extend(table! {
        STIMULI    "stream --port {port} --synthetic --iterations 5" .err("--iterations applies to --method gspat only");
        STIMULI    "stream --port {port} --synthetic --radius -1" .err("radius");
        STIMULI    "stream --port {port} --synthetic --step 0.2 --steps 8" .err("--step");
        STIMULI    "stream --port autd3:emulator --synthetic --freq 100 --steps 82" .err("25 µs");
        STIMULI    "track --synthetic --seconds 0.1 --radius 4" .err("--radius applies with --port only");
        STIMULI    "track --synthetic --seconds 0.1 --foci 4 --scene {scenes}/paper.toml" .err("--foci applies with --port only");
        STIMULI    "track --synthetic --seconds 0.1 --port {port} --z-profile 3,8 --replan --z 1" .err("--z cannot apply with --replan");
        STIMULI    "track --synthetic --seconds 0.1 --port {port} --z-profile 3,8 --replan --step 0.2" .err("--step cannot apply");
        STIMULI    "track --synthetic --seconds 0.1 --port {port} --z-profile 3,8 --replan --radius 4" .err("differs from --z-profile");
        STIMULI    "track --synthetic --seconds 0.1 --port {port} --z-profile 3,8 --replan --steps 9" .err("differs from --z-profile");
        STIMULI    "track --synthetic --seconds 0.1 --port autd3:emulator --z-profile 3,1 --replan" .err("--replan").err("2..=1024");
        STIMULI    "plan --target lm3" .err("--target");
        STIMULI    "upload --port {port} --phases {dir}/nope.npy --freq 5" .err("cannot read --phases file");
        STIMULI    "upload --port {port} --phases {dir}/a_directory --freq 5" .err("it is a directory");
        STIMULI    "upload --port {port} --phases {dir}/ph_short.json" .err("ph_short.json").err("996 transducers");
        STIMULI    "upload --port {port} --phases {dir}/ph_notime.json" .err("ph_notime.json").err("no timing");
        STIMULI    "upload --port {port} --phases {dir}/ph_2010.json --freq 5" .err("give one");
        STIMULI    "upload --port autd3:emulator --phases {dir}/ph_2010.json" .err("ph_2010.json").err("25 µs grid");
        STIMULI    "upload --port {port} --phases {dir}/ph_nan.phases" .err("ph_nan.phases").err("not a phases JSON");
        STIMULI    "upload --port {port} --phases {dir}/ph_neg.json" .err("above 0");
        STIMULI    "upload --port {port} --phases {dir}/ph_empty.json" .err("no steps");
        STIMULI    "upload --port {port} --phases {dir}/ph_big.json" .err("ph_big.json");
        STIMULI    "upload --port {port} --phases {dir}/ok.csv" .err("ok.csv").err("not a phases JSON");
        STIMULI    "upload --port {port} --phases {dir}/ph_10.npy --freq 5" .err("ph_10.npy").err("996 transducers");
        STIMULI    "upload --port {port} --phases {dir}/ph_trunc.npy --freq 5" .err("ph_trunc.npy").err("needs");
        STIMULI    "upload --port {port} --phases {dir}/ph_1d.npy --freq 5" .err("(steps, transducers)");
        STIMULI    "upload --port {port} --phases {dir}/ph_ok.npy --freq 1e300" .err("--freq");
        STIMULI    "upload --port {port} --phases {dir}/ph_10.npy --freq 5 --radius 3" .err("--radius");
        STIMULI    "upload --port {port} --phases {dir}/ph_10.npy --foci-file {dir}/fo_far.json" .err("--foci-file");
        STIMULI    "upload --port {port} --foci-file {dir}/fo_behind.json" .err("fo_behind.json").err("behind");
        STIMULI    "upload --port {port} --foci-file {dir}/fo_far.json" .err("fo_far.json").err("±2000");
        STIMULI    "upload --port {port} --foci-file {dir}/fo_many.json" .err("at most 32");
        STIMULI    "upload --port {port} --foci-file {dir}/fo_short.json" .err("dwell_us 10 over 1 step is out of range: allowed 1000..=");
        STIMULI    "upload --port {port} --foci-file {dir}/fo_far.json --method gspat" .err("--method");
        STIMULI    "stream --port {port} --input {dir}/track_extra.jsonl" .err("line 1").err("unknown field `colour`");
        STIMULI    "stream --port {port} --input {dir}/track_nopos.jsonl" .err("line 1").err("needs its centre");
    });
    // Every output error names what failed and nothing panics.
    for c in &mut v {
        if c.stdout_to.is_some() && c.code == 1 && c.stderr_to.is_some() {
            c.stderr_has.clear();
        }
    }
    v
}
