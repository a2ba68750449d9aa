//! Round 4, the rig session (issues 30 and 31.3): clients that stall or
//! flood, unbounded lines, TCP control, a library larger than the device,
//! meaningless input, disconnects and replaced presentations, messages,
//! and inputs resolved before outputs. Clients of a running session are
//! the cases' `during` functions; their files are in `{dir}/s`.

use std::io::{BufReader, Write as _};
use std::net::TcpStream;
use std::os::unix::net::UnixStream;

use super::*;

/// The repository's paper library.
const LIB: &str = "{scenes}/../studies/paper-library.toml";

/// The session cases.
pub(crate) fn cases() -> Vec<Case> {
    let lib = |args: &str| args.replace("{lib}", LIB);
    let mut v = Vec::new();
    let mut add = |class, args: &str, f: fn(Case) -> Case| v.push(f(case(class, &lib(args))));
    // 1. No client slows the loop: eight subscribers that stop reading
    //    while another's tracked 0.5 s presentation plays.
    add(
        SESSION_STALLS,
        "session --library {lib} --port autd3:emulator --control {dir}/s/stall.sock --synthetic --events {dir}/s/stall.jsonl",
        |c| c.ok().during(stalled_clients_hold_nothing_up),
    );
    // 2. Bounded control lines, on a socket and on stdin.
    add(
        SESSION_LINES,
        "session --library {lib} --port {sess} --control {dir}/s/lines.sock",
        |c| c.ok().during(an_endless_line_is_not_buffered),
    );
    add(
        SESSION_LINES,
        "session --library {lib} --port autd3:emulator --control -",
        |c| {
            let mut input = vec![b'{'; 3 << 20];
            input.extend(b"\n{\"cmd\":\"status\"}\n");
            c.stdin(input)
                .ok()
                .out("longer than 4096 bytes")
                .out("\"state\":\"idle\"")
        },
    );
    // 3. TCP control needs the token from the 0600 file.
    add(
        SESSION_TCP,
        "session --library {lib} --port {sess} --control {dir}/s/tcp.sock --tcp {tcp}",
        |c| c.ok().during(tcp_needs_the_token).check(token_file_removed),
    );
    add(
        SESSION_TCP,
        "session --library {lib} --port autd3:emulator --control - --tcp {tcp}",
        |c| c.err("--tcp needs a socket --control"),
    );
    // 4. A library of 32 large entries on a device that holds a fraction.
    add(
        SESSION_LIBRARY,
        "session --library {dir}/s/lib32.toml --port {sess} --control -",
        |c| c.stdin(lib32_script()).ok().check(library_rotates),
    );
    // An AM entry the LM steps cannot carry is refused at start, naming
    // the frequencies that fit, never played at another; one that fits
    // plays on the simulated firmware as its intensity table (protocol v6).
    add(
        PLANS,
        "session --library {dir}/s/am200.toml --port {sess} --control -",
        |c| c.err("does not fit").err("nearest: 100 Hz"),
    );
    add(
        PLANS,
        "session --library {dir}/s/am12.toml --port {sess} --control -",
        |c| c.err("nearest: 10 or 15 Hz"),
    );
    add(
        PLANS,
        "session --library {dir}/s/am20.toml --port {sess} --control -",
        |c| {
            c.stdin(
                "{\"cmd\":\"present\",\"stimulus\":\"am\",\"gate\":\"untracked\"}\n\
                 {\"cmd\":\"stop\"}\n",
            )
            .ok()
            .out("\"cmd\":\"present\",\"ok\":true")
        },
    );
    // 5. Meaningless input is refused, not ignored.
    for (line, want) in [
        (r#"{"cmd":"stop","stimulus":"x"}"#, "`stop` takes no fields"),
        (
            r#"{"cmd":"status","verbose":true}"#,
            "`status` takes no fields",
        ),
        (r#"{"cmd":"quit","now":1}"#, "`quit` takes no fields"),
        (
            r#"{"cmd":"present","stimulus":"lms-5hz-a3","gate":"tracked"}"#,
            "no finger source",
        ),
        (
            r#"{"cmd":"present","stimulus":"lms-5hz-a3"}"#,
            "no finger source",
        ),
    ] {
        let input = format!("{line}\n");
        let want = want.to_owned();
        v.push(
            case(
                SESSION_MEANINGLESS,
                &lib("session --library {lib} --port autd3:emulator --control -"),
            )
            .stdin(input)
            .ok()
            .out(&want)
            .check(nothing_played),
        );
    }
    v.push(
        case(
            SESSION_MEANINGLESS,
            &lib("session --library {lib} --port autd3:emulator --control - --synthetic"),
        )
        .stdin("{\"cmd\":\"present\",\"stimulus\":\"lms-25hz-a3\",\"on_s\":0.1}\n")
        .ok()
        .out("\"event\":\"onset\""),
    );
    v.push(
        case(
            SESSION_MEANINGLESS,
            "study run {dir}/s/tracked-study.toml --participant P --out {dir}/s/study --port autd3:emulator",
        )
        .err("plays tracked, but there is no finger source"),
    );
    // 6. Session semantics: disconnects, a third present before the switch.
    let three = concat!(
        r#"{"cmd":"present","stimulus":"lms-5hz-a3","gate":"untracked"}"#,
        "\n",
        r#"{"cmd":"present","stimulus":"lmm-5hz-a3","gate":"untracked"}"#,
        "\n",
        r#"{"cmd":"present","stimulus":"lms-5hz-a4","gate":"untracked","on_s":0.3}"#,
        "\n",
    );
    v.push(
        case(
            SESSION_SEMANTICS,
            &lib("session --library {lib} --port {sess} --control {dir}/s/sem.sock"),
        )
        .ok()
        .during(a_disconnect_stops_only_its_own),
    );
    v.push(
        case(
            SESSION_SEMANTICS,
            &lib("session --library {lib} --port {sess} --control -"),
        )
        .stdin(three)
        .ok()
        .out(r#""event":"cancelled","stimulus":"lmm-5hz-a3""#)
        .check(third_present_replaced_the_waiting_one),
    );
    v.push(
        case(
            SESSION_SEMANTICS,
            &lib("session --library {lib} --port autd3:emulator --control -"),
        )
        .stdin(three)
        .ok()
        .out("cannot take a queued switch back"),
    );
    // 7. Messages: a socket path too long, an id too long to repeat.
    v.push(
        case(
            SESSION_MESSAGES,
            &lib(&format!(
                "session --library {{lib}} --port autd3:emulator --control {{dir}}/s/{}.sock",
                "x".repeat(120)
            )),
        )
        .err("a socket path is at most 107 bytes")
        .check(no_jargon),
    );
    for line in [
        format!(r#"{{"cmd":"present","stimulus":"{}"}}"#, "i".repeat(4000)),
        format!(r#"{{"cmd":"{}"}}"#, "c".repeat(4000)),
        format!(r#"{{"cmd":"stop","{}":1}}"#, "f".repeat(4000)),
    ] {
        v.push(
            case(
                SESSION_MESSAGES,
                &lib("session --library {lib} --port autd3:emulator --control -"),
            )
            .stdin(format!("{line}\n"))
            .ok()
            .out("(4000 bytes)")
            .check(short_lines),
        );
    }
    // 8. Every input, sidecars included, before any output: `--events`
    //    naming one is refused and leaves it as it was.
    for events in ["rec.timestamps.npy", "rec.intrinsics.toml", "rec.npy"] {
        v.push(
            case(
                SESSION_OUTPUTS,
                &lib(&format!(
                    "session --library {{lib}} --port autd3:emulator --control - --scene {{scenes}}/paper.toml --depth {{dir}}/s/rec.npy --events {{dir}}/s/{events}"
                )),
            )
            .err("is the input")
            .check(recording_intact),
        );
    }
    v.push(
        case(
            SESSION_OUTPUTS,
            &lib("session --library {lib} --port autd3:emulator --control - --stream {dir}/s/st.csv --events {dir}/s/st.csv"),
        )
        .err("is the input")
        .check(recording_intact),
    );
    v
}

/// The session cases' files, in `{dir}/s`.
pub(crate) fn fixtures(dir: &Path) {
    let d = dir.join("s");
    std::fs::create_dir_all(&d).unwrap();
    let w = |name: &str, body: &str| std::fs::write(d.join(name), body).unwrap();
    // 32 LM-S entries of 55 to 130 steps: about three times what the
    // simulated device's library holds, even as Delta streams.
    let mut lib = String::new();
    for i in 0..32 {
        lib += &format!(
            "[[stimulus]]\nid = \"e{i}\"\nradius = {:.1}\nfreq = 5\nstep = 0.23\nuntracked = true\n\n",
            2.0 + 0.25 * f64::from(i) / 2.0
        );
    }
    w("lib32.toml", &lib);
    for (name, freq) in [
        ("am200.toml", 200.0),
        ("am12.toml", 12.5),
        ("am20.toml", 20.0),
    ] {
        w(
            name,
            &format!(
                "[[stimulus]]\nid = \"am\"\nam = {{ shape = \"sine\", freq = {freq}, depth = 1.0 }}\n"
            ),
        );
    }
    w("st.csv", "0,0,0,200,1\n");
    // A study whose entries play tracked, with no wait for the finger.
    let library = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../studies/paper-library.toml"),
    )
    .unwrap();
    w("paper-library.toml", &library);
    w(
        "tracked-study.toml",
        concat!(
            "name = \"tracked\"\nlibrary = \"paper-library.toml\"\nsets = 1\nstimulus = \"lms-5hz-a{radius}\"\n\n",
            "[timeline]\nwait_for_finger = false\nwhile_touching = false\non_s = 1.0\niti_s = 0.5\ngate = \"tracked\"\n\n",
            "[[factor]]\nname = \"radius\"\nlevels = [\"2\", \"3\"]\n\n",
            "[[question]]\nid = \"q\"\nkind = \"likert\"\npoints = 7\nlow = \"no\"\nhigh = \"yes\"\ntext = \"Q?\"\n",
        ),
    );
    // A depth recording with its intrinsics and time stamps beside it.
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/paper.toml");
    let rec = d.join("rec.npy");
    ok(&[
        "track",
        "--synthetic",
        "--seconds",
        "0.3",
        "--scene",
        scene.to_str().unwrap(),
        "--record",
        rec.to_str().unwrap(),
    ]);
    for f in [
        "rec.npy",
        "rec.intrinsics.toml",
        "rec.timestamps.npy",
        "st.csv",
    ] {
        std::fs::copy(d.join(f), d.join(format!("{f}.orig"))).unwrap();
    }
}

/// A client of a session's Unix socket.
struct Client {
    w: UnixStream,
    r: BufReader<UnixStream>,
}

impl Client {
    /// Connects (the session may still be starting).
    fn connect(path: &Path) -> Result<Self, String> {
        let end = Instant::now() + Duration::from_secs(15);
        loop {
            match UnixStream::connect(path) {
                Ok(s) => {
                    s.set_read_timeout(Some(Duration::from_secs(10)))
                        .map_err(|e| e.to_string())?;
                    let r = BufReader::new(s.try_clone().map_err(|e| e.to_string())?);
                    return Ok(Self { w: s, r });
                }
                Err(e) if Instant::now() > end => {
                    return Err(format!("{}: {e}", path.display()));
                }
                Err(_) => std::thread::sleep(Duration::from_millis(50)),
            }
        }
    }

    /// The next line, as JSON.
    fn line(&mut self) -> Result<serde_json::Value, String> {
        read_json(&mut self.r)
    }

    /// Sends `cmd` and returns its reply (events before it skipped).
    fn ask(&mut self, cmd: &str) -> Result<serde_json::Value, String> {
        writeln!(self.w, "{cmd}").map_err(|e| format!("sending {cmd}: {e}"))?;
        loop {
            let v = self.line()?;
            if v.get("cmd").is_some() {
                return Ok(v);
            }
        }
    }

    /// Sends `cmd`, whose reply must be ok.
    fn ok(&mut self, cmd: &str) -> Result<serde_json::Value, String> {
        let v = self.ask(cmd)?;
        if v["ok"] != true {
            return Err(format!("{cmd}: {v}"));
        }
        Ok(v)
    }

    /// The next event named `name`.
    fn event(&mut self, name: &str) -> Result<serde_json::Value, String> {
        loop {
            let v = self.line()?;
            if v["event"] == name {
                return Ok(v);
            }
        }
    }

    fn state(&mut self) -> Result<serde_json::Value, String> {
        Ok(self.ok(r#"{"cmd":"status"}"#)?["status"].clone())
    }
}

fn read_json(r: &mut impl std::io::BufRead) -> Result<serde_json::Value, String> {
    let mut line = String::new();
    match r.read_line(&mut line) {
        Ok(0) => Err("the session closed the connection".into()),
        Ok(_) => serde_json::from_str(&line).map_err(|e| format!("{e}: {line}")),
        Err(e) => Err(format!("reading: {e}")),
    }
}

fn sock(ctx: &Ctx, name: &str) -> PathBuf {
    ctx.dir.join("s").join(name)
}

/// A tracked presentation with the synthetic finger repeats 0.5 s on-phases;
/// once it has begun, eight subscribers flood `library` commands and never
/// read their replies (their socket buffers fill). Every on-phase still
/// plays 0.5 s, unmuted, on the AUTD3 emulator (whose stop is the host's
/// own tick): no client waits hold the loop.
fn stalled_clients_hold_nothing_up(ctx: &Ctx, _: u32) -> Result<(), String> {
    let path = sock(ctx, "stall.sock");
    let mut b = Client::connect(&path)?;
    b.ok(r#"{"cmd":"subscribe"}"#)?;
    let (go, wait) = std::sync::mpsc::channel::<()>();
    let wait = std::sync::Arc::new(std::sync::Mutex::new(wait));
    let mut stalled = Vec::new();
    for _ in 0..8 {
        let mut c = Client::connect(&path)?;
        c.ok(r#"{"cmd":"subscribe"}"#)?;
        let mut w = c.w.try_clone().map_err(|e| e.to_string())?;
        let wait = wait.clone();
        stalled.push((
            c,
            std::thread::spawn(move || {
                let _ = wait.lock().map(|w| w.recv());
                for _ in 0..200 {
                    if writeln!(w, r#"{{"cmd":"library"}}"#).is_err() {
                        break;
                    }
                }
            }),
        ));
    }
    b.ok(r#"{"cmd":"present","stimulus":"lmm-5hz-a3","on_s":0.5,"off_s":0.1,"repeat":6}"#)?;
    b.event("onset")?;
    for _ in 0..stalled.len() {
        let _ = go.send(());
    }
    let mut offsets = Vec::new();
    loop {
        let v = b.line()?;
        match v["event"].as_str() {
            Some("offset") => offsets.push(v),
            Some("done") => break,
            _ => {}
        }
    }
    b.ok(r#"{"cmd":"quit"}"#)?;
    for (c, t) in stalled {
        drop(c);
        let _ = t.join();
    }
    for off in &offsets {
        let device = off["device_presented_s"].as_f64().unwrap_or(f64::NAN);
        let fraction = off["present_fraction"].as_f64().unwrap_or(0.0);
        if !(device <= 0.6 && fraction >= 0.8) {
            return Err(format!(
                "asked 0.5 s: played {device} s, present {fraction}: {off}"
            ));
        }
    }
    if offsets.len() != 6 {
        return Err(format!("{} on-phases of 6", offsets.len()));
    }
    Ok(())
}

/// The peak resident memory of `pid` (kB).
fn peak_kb(pid: u32) -> Result<u64, String> {
    let s = std::fs::read_to_string(format!("/proc/{pid}/status")).map_err(|e| e.to_string())?;
    s.lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .ok_or_else(|| "no VmHWM".into())
}

/// 64 MiB without a newline: one refusal, the rest read past without the
/// session's memory growing; the session answers the next line.
fn an_endless_line_is_not_buffered(ctx: &Ctx, pid: u32) -> Result<(), String> {
    let mut c = Client::connect(&sock(ctx, "lines.sock"))?;
    c.ok(r#"{"cmd":"status"}"#)?;
    let before = peak_kb(pid)?;
    let chunk = vec![b'x'; 1 << 20];
    let mut w = c.w.try_clone().map_err(|e| e.to_string())?;
    let writer = std::thread::spawn(move || -> std::io::Result<()> {
        for _ in 0..64 {
            w.write_all(&chunk)?;
        }
        w.write_all(b"\n{\"cmd\":\"status\"}\n")
    });
    let refused = c.line()?;
    writer
        .join()
        .map_err(|_| "writer panicked".to_string())?
        .map_err(|e| e.to_string())?;
    let next = c.line()?;
    let after = peak_kb(pid)?;
    c.ok(r#"{"cmd":"quit"}"#)?;
    if refused["ok"] != false
        || !refused["error"]
            .as_str()
            .unwrap_or("")
            .contains("longer than 4096")
    {
        return Err(format!("not refused: {refused}"));
    }
    if next["ok"] != true || next["cmd"] != "status" {
        return Err(format!("the next line was not answered: {next}"));
    }
    if after > before + 16 * 1024 {
        return Err(format!(
            "peak memory grew {} kB for the long line",
            after - before
        ));
    }
    Ok(())
}

/// Over TCP nothing but the right token is taken; with it, commands are.
fn tcp_needs_the_token(ctx: &Ctx, _: u32) -> Result<(), String> {
    let path = sock(ctx, "tcp.sock");
    let mut u = Client::connect(&path)?;
    let token_path = ctx.dir.join("s/tcp.sock.token");
    use std::os::unix::fs::PermissionsExt as _;
    let mode = std::fs::metadata(&token_path)
        .map_err(|e| format!("{}: {e}", token_path.display()))?
        .permissions()
        .mode();
    if mode & 0o777 != 0o600 {
        return Err(format!("token file mode {:o}", mode & 0o777));
    }
    let token = std::fs::read_to_string(&token_path).map_err(|e| e.to_string())?;
    let tcp = |first: &str| -> Result<(serde_json::Value, TcpStream), String> {
        let s = TcpStream::connect(("127.0.0.1", ctx.tcp)).map_err(|e| e.to_string())?;
        s.set_read_timeout(Some(Duration::from_secs(10)))
            .map_err(|e| e.to_string())?;
        let mut w = s.try_clone().map_err(|e| e.to_string())?;
        writeln!(w, "{first}").map_err(|e| e.to_string())?;
        let mut r = BufReader::new(s.try_clone().map_err(|e| e.to_string())?);
        Ok((read_json(&mut r)?, s))
    };
    let closed = |s: TcpStream| {
        let mut r = BufReader::new(s);
        read_json(&mut r).is_err()
    };
    let present = r#"{"cmd":"present","stimulus":"lms-5hz-a3","gate":"untracked"}"#;
    let (v, s) = tcp(present)?;
    if v["ok"] != false || !v["error"].as_str().unwrap_or("").contains("token") || !closed(s) {
        return Err(format!("a command before the token: {v}"));
    }
    if u.state()?["state"] == "playing" {
        return Err("an unauthenticated present played".into());
    }
    let (v, s) = tcp(&format!(r#"{{"cmd":"auth","token":"{}"}}"#, "0".repeat(32)))?;
    if v["ok"] != false || !closed(s) {
        return Err(format!("a wrong token: {v}"));
    }
    let (v, s) = tcp(&format!(r#"{{"cmd":"auth","token":"{}"}}"#, token.trim()))?;
    if v["ok"] != true {
        return Err(format!("the right token: {v}"));
    }
    let mut w = s.try_clone().map_err(|e| e.to_string())?;
    writeln!(w, "{present}").map_err(|e| e.to_string())?;
    let v = read_json(&mut BufReader::new(s))?;
    if v["ok"] != true || u.state()?["state"] != "playing" {
        return Err(format!("an authenticated present: {v}"));
    }
    u.ok(r#"{"cmd":"quit"}"#)?;
    Ok(())
}

fn token_file_removed(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let p = ctx.dir.join("s/tcp.sock.token");
    if p.exists() {
        return Err(format!("{} is left behind", p.display()));
    }
    Ok(())
}

/// Every entry twice, each over the one before.
fn lib32_script() -> String {
    (0..64)
        .map(|i| {
            format!(
                "{{\"cmd\":\"present\",\"stimulus\":\"e{}\",\"on_s\":0.05}}\n",
                (i * 7) % 32
            )
        })
        .collect()
}

fn stdout_json(r: &Run) -> Vec<serde_json::Value> {
    r.stdout
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

/// Every present was taken; the library could not all be resident, so
/// entries took others' places.
fn library_rotates(_: &Ctx, r: &Run) -> Result<(), String> {
    let v = stdout_json(r);
    let refused: Vec<_> = v.iter().filter(|x| x["ok"] == false).collect();
    if !refused.is_empty() {
        return Err(format!("{} refused, first: {}", refused.len(), refused[0]));
    }
    let ready = v
        .iter()
        .find(|x| x["event"] == "ready")
        .ok_or("no ready event")?;
    if ready["resident"].as_u64().unwrap_or(32) >= 32 {
        return Err(format!("the whole library fit: {ready}"));
    }
    let evictions = v
        .iter()
        .filter(|x| x["event"] == "preloaded")
        .filter(|x| x["evicted"].as_array().is_some_and(|a| !a.is_empty()))
        .count();
    let presents = v.iter().filter(|x| x["cmd"] == "present").count();
    if evictions == 0 || presents != 64 {
        return Err(format!("{evictions} evictions, {presents} replies"));
    }
    Ok(())
}

/// Nothing sounded: no onset event.
fn nothing_played(_: &Ctx, r: &Run) -> Result<(), String> {
    if r.stdout.contains("\"event\":\"onset\"") {
        return Err("a refused command played".into());
    }
    Ok(())
}

/// X presents; Y comes and goes: X plays on. Y presents over X, X goes:
/// Y plays on. Y goes: silent.
fn a_disconnect_stops_only_its_own(ctx: &Ctx, _: u32) -> Result<(), String> {
    let path = sock(ctx, "sem.sock");
    let mut x = Client::connect(&path)?;
    x.ok(r#"{"cmd":"present","stimulus":"lms-25hz-a3","gate":"untracked"}"#)?;
    {
        let mut y = Client::connect(&path)?;
        y.ok(r#"{"cmd":"stop"}"#)?;
        x.ok(r#"{"cmd":"present","stimulus":"lms-25hz-a3","gate":"untracked"}"#)?;
        y.ok(r#"{"cmd":"prepare","stimulus":"lms-25hz-a4"}"#)?;
    }
    std::thread::sleep(Duration::from_millis(300));
    let st = x.state()?;
    if st["state"] != "playing" || st["stimulus"] != "lms-25hz-a3" {
        return Err(format!("another client's leaving stopped X's: {st}"));
    }
    let mut y = Client::connect(&path)?;
    y.ok(r#"{"cmd":"subscribe"}"#)?;
    y.ok(r#"{"cmd":"present","stimulus":"lms-25hz-a4","gate":"untracked"}"#)?;
    y.event("switch")?;
    drop(x);
    std::thread::sleep(Duration::from_millis(300));
    let st = y.state()?;
    if st["state"] != "playing" || st["stimulus"] != "lms-25hz-a4" {
        return Err(format!("X's leaving stopped Y's: {st}"));
    }
    drop(y);
    let mut z = Client::connect(&path)?;
    let end = Instant::now() + Duration::from_secs(5);
    while z.state()?["state"] == "playing" {
        if Instant::now() > end {
            return Err("Y's presentation outlived Y".into());
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    z.ok(r#"{"cmd":"quit"}"#)?;
    Ok(())
}

/// The third present took the waiting one's place: the switch went to it.
fn third_present_replaced_the_waiting_one(_: &Ctx, r: &Run) -> Result<(), String> {
    let v = stdout_json(r);
    if v.iter().any(|x| x["ok"] == false) {
        return Err("a present was refused".into());
    }
    let switch = v
        .iter()
        .find(|x| x["event"] == "switch")
        .ok_or("no switch")?;
    if switch["to"] != "lms-5hz-a4" {
        return Err(format!("switched to the cancelled one: {switch}"));
    }
    if v.iter()
        .any(|x| x["event"] == "onset" && x["stimulus"] == "lmm-5hz-a3")
    {
        return Err("the cancelled one played".into());
    }
    Ok(())
}

fn no_jargon(_: &Ctx, r: &Run) -> Result<(), String> {
    if r.stderr.contains("SUN_LEN") {
        return Err(format!("jargon: {}", r.stderr));
    }
    Ok(())
}

/// No line of the reply repeats a value whole.
fn short_lines(_: &Ctx, r: &Run) -> Result<(), String> {
    match r.stdout.lines().map(str::len).max() {
        Some(n) if n > 600 => Err(format!("a line of {n} bytes")),
        _ => Ok(()),
    }
}

/// The recording, its sidecars and the stream file are as they were.
fn recording_intact(ctx: &Ctx, _: &Run) -> Result<(), String> {
    let d = ctx.dir.join("s");
    for f in [
        "rec.npy",
        "rec.intrinsics.toml",
        "rec.timestamps.npy",
        "st.csv",
    ] {
        let now = std::fs::read(d.join(f)).map_err(|e| format!("{f}: {e}"))?;
        let was = std::fs::read(d.join(format!("{f}.orig"))).map_err(|e| e.to_string())?;
        if now != was {
            return Err(format!("{f} was changed"));
        }
    }
    Ok(())
}
