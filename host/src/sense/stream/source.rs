//! Where centroid samples come from: text lines (stdin or a recorded file,
//! JSON lines or CSV), UDP datagrams, or the synthetic finger.
//!
//! Text formats, one sample per line:
//! - JSON: `{"t": 0.011, "x": 1.2, "y": -0.4, "z": 201.0, "present": true}`
//!   (`present` defaults to true);
//! - JSON as `lmhost track --json` prints it (`{"t_s": .., "present": ..,
//!   "centroid_mm": [x, y, z] | null, ...}`): its time, and its filtered,
//!   gated centre (`filtered_mm`, `gated_present`) when the line has one,
//!   else its raw centroid; its other known keys are ignored, an unknown
//!   key is refused as in the plain form;
//! - CSV: `t,x,y,z,present` with `present` as `1`/`0`/`true`/`false`; the
//!   header line `t,x,y,z,present` is skipped; `#` starts a comment.
//!
//! Units: seconds and millimetres. A time stamp lies in 0 to
//! [`MAX_TIME_STAMP_S`]; a line beyond is refused (a datagram counted bad).

use std::io::BufRead;

use serde::Deserialize as _;

use super::Sample;
use crate::InputError;
use crate::limits::{
    MAX_BAD_DATAGRAMS_IN_A_ROW, MAX_LINE_BYTES, MAX_REPLAY_GAP_S, MAX_TIME_STAMP_S,
};

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct JsonSample {
    t: f64,
    x: f64,
    y: f64,
    z: f64,
    #[serde(default = "yes")]
    present: bool,
}

fn yes() -> bool {
    true
}

/// A line of `lmhost track --json` (the keys `track::session` prints).
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct TrackLine {
    t_s: f64,
    present: bool,
    centroid_mm: Option<[f64; 3]>,
    #[serde(default)]
    gated_present: Option<bool>,
    #[serde(default)]
    filtered_mm: Option<[f64; 3]>,
    #[serde(default, rename = "points")]
    _points: serde::de::IgnoredAny,
    #[serde(default, rename = "z_profile_mm")]
    _z_profile_mm: serde::de::IgnoredAny,
    #[serde(default, rename = "replan")]
    _replan: serde::de::IgnoredAny,
    #[serde(default, rename = "truth_present")]
    _truth_present: serde::de::IgnoredAny,
    #[serde(default, rename = "truth_mm")]
    _truth_mm: serde::de::IgnoredAny,
}

impl TrackLine {
    /// Its sample: the filtered, gated centre when the line has one, else
    /// the raw centroid; a finger needs a position.
    fn sample(self, line_no: usize) -> Result<Sample, InputError> {
        let (pos, present) = match self.gated_present {
            Some(g) => (self.filtered_mm, g),
            None => (self.centroid_mm, self.present),
        };
        match (pos, present) {
            (Some(p), present) => Ok(Sample {
                t_s: self.t_s,
                pos_mm: p,
                present,
            }),
            (None, false) => Ok(Sample {
                t_s: self.t_s,
                pos_mm: [0.0; 3],
                present: false,
            }),
            (None, true) => Err(InputError::new(format!(
                "line {line_no}: a track line with a finger present needs its centre (centroid_mm or filtered_mm)"
            ))),
        }
    }
}

/// Parse one line; `Ok(None)` for blank lines, comments and a CSV header.
/// `line_no` (1-based) goes into the error message.
pub fn parse_line(line: &str, line_no: usize) -> Result<Option<Sample>, InputError> {
    // A UTF-8 byte-order mark (spreadsheet exports) opens the first line
    // only; anywhere else it is an invisible stray character and refused.
    let line = match line_no {
        1 => line.strip_prefix('\u{feff}').unwrap_or(line),
        _ => line,
    };
    let line = line.trim();
    if line.is_empty() || line.starts_with('#') {
        return Ok(None);
    }
    // Said as what it is, not read as CSV and refused for a field it cut.
    if line.starts_with('\u{feff}') {
        return Err(InputError::new(format!(
            "line {line_no} starts with a byte-order mark (U+FEFF), which only the first line may"
        )));
    }
    if line.starts_with('[') {
        return Err(InputError::new(format!(
            "line {line_no}: not a centroid JSON object (a JSON array; give {{\"t\":..,\"x\":..,\"y\":..,\"z\":..}})"
        )));
    }
    let sample = if line.starts_with('{') {
        let bad = |e: serde_json::Error| {
            InputError::new(format!("line {line_no}: not a centroid JSON object ({e})"))
        };
        let v = crate::json::from_str(line).map_err(bad)?;
        // `lmhost track --json` lines carry `t_s`; plain centroids `t`.
        if v.get("t_s").is_some() {
            TrackLine::deserialize(v).map_err(bad)?.sample(line_no)?
        } else {
            let j = JsonSample::deserialize(v).map_err(bad)?;
            Sample {
                t_s: j.t,
                pos_mm: [j.x, j.y, j.z],
                present: j.present,
            }
        }
    } else {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        // The header, exactly (also where files were joined): any other
        // line starting `t` is a sample line to check, never skipped.
        const HEADER: [&str; 5] = ["t", "x", "y", "z", "present"];
        if fields.len() == HEADER.len()
            && fields
                .iter()
                .zip(HEADER)
                .all(|(f, h)| f.eq_ignore_ascii_case(h))
        {
            return Ok(None);
        }
        if fields.len() != 5 {
            return Err(InputError::new(format!(
                "line {line_no}: expected 5 CSV fields t,x,y,z,present, found {}",
                fields.len()
            )));
        }
        let num = |i: usize, name: &str| {
            fields[i].parse::<f64>().map_err(|_| {
                InputError::new(format!(
                    "line {line_no}: {name} `{}` is not a number",
                    fields[i]
                ))
            })
        };
        let present = crate::error::choose_any_case(
            "a `present` value",
            fields[4],
            &[("1", true), ("0", false), ("true", true), ("false", false)],
        )
        .map_err(|m| InputError::new(format!("line {line_no}: {m}")))?;
        Sample {
            t_s: num(0, "t")?,
            pos_mm: [num(1, "x")?, num(2, "y")?, num(3, "z")?],
            present,
        }
    };
    if !sample.t_s.is_finite() || sample.pos_mm.iter().any(|v| !v.is_finite()) {
        return Err(InputError::new(format!(
            "line {line_no}: values must be finite"
        )));
    }
    if !(0.0..=MAX_TIME_STAMP_S).contains(&sample.t_s) {
        return Err(InputError::new(format!(
            "line {line_no}: time stamp {} s is out of range: give 0 to {} s",
            crate::limits::show_beside(sample.t_s, 0.0, MAX_TIME_STAMP_S),
            crate::limits::show(MAX_TIME_STAMP_S)
        )));
    }
    Ok(Some(sample))
}

/// Lines of at most [`MAX_LINE_BYTES`] from a reader, parsed into samples;
/// with `max_gap_s`, a forward jump of the time stamps larger than that is
/// an error naming the line (replayed files: never a silent long sleep).
struct LineSource<R> {
    reader: R,
    line_no: usize,
    buf: Vec<u8>,
    max_gap_s: Option<f64>,
    last_t_s: Option<f64>,
    done: bool,
}

/// One line, or `None` at the end; a line longer than [`MAX_LINE_BYTES`]
/// is an error without reading the rest of it into memory.
fn next_line<R: BufRead>(
    reader: &mut R,
    buf: &mut Vec<u8>,
    line_no: usize,
) -> anyhow::Result<Option<()>> {
    buf.clear();
    loop {
        let avail = match reader.fill_buf() {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(anyhow::Error::new(e).context("reading centroid stream")),
        };
        if avail.is_empty() {
            return Ok((!buf.is_empty()).then_some(()));
        }
        let (take, end) = match avail.iter().position(|&b| b == b'\n') {
            Some(i) => (i, true),
            None => (avail.len(), false),
        };
        if buf.len() + take > MAX_LINE_BYTES {
            return Err(InputError::new(format!(
                "line {line_no} is longer than {MAX_LINE_BYTES} bytes (the limit per sample line)"
            ))
            .into());
        }
        buf.extend_from_slice(&avail[..take]);
        reader.consume(take + usize::from(end));
        if end {
            return Ok(Some(()));
        }
    }
}

impl<R: BufRead> Iterator for LineSource<R> {
    type Item = anyhow::Result<Sample>;

    fn next(&mut self) -> Option<Self::Item> {
        while !self.done {
            self.line_no += 1;
            let line_no = self.line_no;
            match next_line(&mut self.reader, &mut self.buf, line_no) {
                Ok(None) => self.done = true,
                Err(e) => {
                    self.done = true;
                    return Some(Err(e));
                }
                Ok(Some(())) => {
                    let Ok(text) = std::str::from_utf8(&self.buf) else {
                        self.done = true;
                        return Some(Err(InputError::new(format!(
                            "line {line_no} is not UTF-8 text"
                        ))
                        .into()));
                    };
                    match parse_line(text, line_no) {
                        Ok(None) => {}
                        Err(e) => {
                            self.done = true;
                            return Some(Err(e.into()));
                        }
                        Ok(Some(s)) => {
                            if let (Some(max), Some(prev)) = (self.max_gap_s, self.last_t_s)
                                && s.t_s - prev > max
                            {
                                self.done = true;
                                return Some(Err(InputError::new(format!(
                                    "line {line_no}: time stamp {} s is {} s after the previous \
                                     sample; a replayed stream may pause at most {max} s",
                                    crate::limits::show(s.t_s),
                                    crate::limits::show(s.t_s - prev)
                                ))
                                .into()));
                            }
                            self.last_t_s = Some(self.last_t_s.map_or(s.t_s, |p| p.max(s.t_s)));
                            return Some(Ok(s));
                        }
                    }
                }
            }
        }
        None
    }
}

/// Samples from a live line-oriented reader (stdin): lines of at most
/// [`MAX_LINE_BYTES`]; the first bad line ends the stream with an error
/// naming it.
pub fn read_lines<R: BufRead>(reader: R) -> impl Iterator<Item = anyhow::Result<Sample>> {
    LineSource {
        reader,
        line_no: 0,
        buf: Vec::new(),
        max_gap_s: None,
        last_t_s: None,
        done: false,
    }
}

/// Samples from a recorded file replayed at its time stamps: as
/// [`read_lines`], and a gap above [`MAX_REPLAY_GAP_S`] between consecutive
/// time stamps is an error naming the line.
pub fn replay_lines<R: BufRead>(reader: R) -> impl Iterator<Item = anyhow::Result<Sample>> {
    LineSource {
        reader,
        line_no: 0,
        buf: Vec::new(),
        max_gap_s: Some(MAX_REPLAY_GAP_S),
        last_t_s: None,
        done: false,
    }
}

/// [`replay_lines`] over the file at `path`, opened as an input
/// ([`crate::files::open_input`]); every error it yields names the file as
/// `what` (`--stream file`, `--input file`) and its path, for a bad line
/// is read long after the command started, its other output between.
pub fn replay_file(
    what: &str,
    path: &std::path::Path,
) -> anyhow::Result<impl Iterator<Item = anyhow::Result<Sample>> + Send + use<>> {
    use anyhow::Context as _;
    let reader = std::io::BufReader::new(crate::files::open_input(what, path)?);
    let name = format!("{what} {}", path.display());
    Ok(replay_lines(reader).map(move |r| r.with_context(|| name.clone())))
}

/// The samples of `items` released at their time stamps on `clock`: the
/// first at once, each next one once as much time has passed since the
/// first as their stamps differ, so a 20 s recording plays for 20 s in a
/// session or study as in `lmhost stream`. Meant for a reader thread
/// (it sleeps) over [`replay_lines`], which bounds every gap.
pub fn paced<I>(
    items: I,
    clock: crate::clock::Clock,
) -> impl Iterator<Item = anyhow::Result<Sample>>
where
    I: IntoIterator<Item = anyhow::Result<Sample>>,
{
    let mut first: Option<(std::time::Duration, f64)> = None;
    items.into_iter().map(move |item| {
        let s = item?;
        let (t0, first_t_s) = *first.get_or_insert((clock.now(), s.t_s));
        let after =
            std::time::Duration::try_from_secs_f64((s.t_s - first_t_s).max(0.0)).map_err(|_| {
                InputError::new(format!(
                    "time stamp {} s is too far from the first one to replay",
                    crate::limits::show(s.t_s)
                ))
            })?;
        let now = clock.now();
        if let Some(wait) = (t0 + after).checked_sub(now) {
            clock.sleep(wait);
        }
        Ok(s)
    })
}

/// Counters a UDP source keeps while it runs.
#[derive(Debug, Default)]
pub struct UdpCounts {
    /// Datagrams received.
    pub datagrams: std::sync::atomic::AtomicU64,
    /// Datagrams with at least one unusable line (skipped lines).
    pub bad_datagrams: std::sync::atomic::AtomicU64,
}

/// Samples from UDP datagrams on 127.0.0.1:`port` (1..=65535), one line (or several,
/// newline-separated) per datagram. Ends after `idle` without a datagram,
/// or when a stop was requested ([`crate::stop::requested`]).
///
/// A bad line (garbage, not UTF-8, non-finite, longer than
/// [`MAX_LINE_BYTES`]) is skipped and its datagram counted in `counts`;
/// only a flood of [`MAX_BAD_DATAGRAMS_IN_A_ROW`] bad datagrams in a row
/// ends the session (with an input error).
pub fn udp(
    port: u16,
    idle: std::time::Duration,
    counts: std::sync::Arc<UdpCounts>,
) -> anyhow::Result<impl Iterator<Item = anyhow::Result<Sample>>> {
    use anyhow::Context as _;
    use std::sync::atomic::Ordering::Relaxed;
    // Port 0 binds a port the system picks, which no tracker is told.
    if port == 0 {
        crate::bad_input!("--udp 0: give a port in 1..=65535 for the tracker to send to");
    }
    let sock = std::net::UdpSocket::bind(("127.0.0.1", port))
        .with_context(|| format!("binding UDP port 127.0.0.1:{port}"))?;
    // Wake often enough to notice Ctrl-C; idle is measured separately.
    let tick = idle.min(std::time::Duration::from_millis(100));
    sock.set_read_timeout(Some(tick))
        .context("setting UDP timeout")?;
    let mut pending: std::collections::VecDeque<Sample> = Default::default();
    let mut bad_in_a_row = 0u64;
    let mut last_datagram = std::time::Instant::now();
    let mut buf = vec![0u8; 65_536];
    let mut ended = false;
    Ok(std::iter::from_fn(move || {
        loop {
            if ended || crate::stop::requested() {
                return None;
            }
            if let Some(s) = pending.pop_front() {
                return Some(Ok(s));
            }
            let n = match sock.recv(&mut buf) {
                Ok(n) => n,
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock
                            | std::io::ErrorKind::TimedOut
                            | std::io::ErrorKind::Interrupted
                    ) =>
                {
                    if last_datagram.elapsed() >= idle {
                        return None;
                    }
                    continue;
                }
                Err(e) => return Some(Err(anyhow::Error::new(e).context("receiving UDP"))),
            };
            last_datagram = std::time::Instant::now();
            let number = counts.datagrams.fetch_add(1, Relaxed) as usize + 1;
            let mut bad = false;
            match std::str::from_utf8(&buf[..n]) {
                Err(_) => bad = true,
                Ok(text) => {
                    for line in text.lines() {
                        if line.len() > MAX_LINE_BYTES {
                            bad = true;
                            continue;
                        }
                        match parse_line(line, number) {
                            Ok(Some(s)) => pending.push_back(s),
                            Ok(None) => {}
                            Err(_) => bad = true,
                        }
                    }
                }
            }
            if bad {
                counts.bad_datagrams.fetch_add(1, Relaxed);
                bad_in_a_row += 1;
                if bad_in_a_row >= MAX_BAD_DATAGRAMS_IN_A_ROW {
                    ended = true;
                    return Some(Err(InputError::new(format!(
                        "UDP port {port}: {bad_in_a_row} bad datagrams in a row (a flood); \
                         stopping the session"
                    ))
                    .into()));
                }
            } else {
                bad_in_a_row = 0;
            }
        }
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_paced_recording_takes_as_long_as_its_time_stamps_say() {
        let clock = crate::clock::Clock::manual_at_us(5_000_000);
        // 20 s of samples at 2 Hz, starting at t = 100 s.
        let text: String = (0..=40)
            .map(|i| format!("{},0,0,200,1\n", 100.0 + i as f64 * 0.5))
            .collect();
        let mut seen = Vec::new();
        for s in paced(replay_lines(text.as_bytes()), clock.clone()) {
            let s = s.unwrap();
            seen.push((s.t_s, clock.now_us()));
        }
        assert_eq!(seen.len(), 41);
        // Each sample out when its stamp is due, not before.
        for (t_s, at_us) in &seen {
            let due = 5_000_000 + ((t_s - 100.0) * 1e6) as u64;
            assert_eq!(*at_us, due, "{t_s}");
        }
        assert_eq!(clock.now_us(), 25_000_000);
        // An error passes through and waits for nothing.
        let bad = "0,0,0,200,1\nx\n";
        let v: Vec<_> = paced(replay_lines(bad.as_bytes()), clock.clone()).collect();
        assert!(v[1].is_err());
    }

    #[test]
    fn a_time_stamp_outside_0_to_1e10_s_is_refused_in_every_form() {
        for t in ["1e300", "-1", "-1e-9", "10000000001"] {
            for line in [
                format!("{t},0,0,200,1"),
                format!(r#"{{"t":{t},"x":0,"y":0,"z":200}}"#),
                format!(r#"{{"t_s":{t},"present":false,"centroid_mm":null}}"#),
            ] {
                let e = parse_line(&line, 3).unwrap_err().to_string();
                assert!(e.starts_with("line 3: time stamp"), "{line}: {e}");
                assert!(e.contains("give 0 to 1e10 s") && e.len() < 100, "{e}");
            }
        }
        // Unix-epoch seconds, as a tracker's `time.time()` gives them.
        assert!(parse_line("1800000000.5,0,0,200,1", 1).unwrap().is_some());
        assert!(parse_line("0,0,0,200,1", 1).unwrap().is_some());
    }

    #[test]
    fn a_line_is_refused_for_what_it_is() {
        // Only the exact header is skipped.
        assert!(parse_line("T, X,y,z,Present", 4).unwrap().is_none());
        for (line, needle) in [
            ("t,whatever", "line 2: expected 5 CSV fields"),
            ("t,0,0,200,1", "line 2: t `t` is not a number"),
            (
                "\u{feff}{\"t\":0,\"x\":0,\"y\":0,\"z\":200}",
                "line 2 starts with a byte-order mark",
            ),
            (
                "[0,0,0,200,1]",
                "line 2: not a centroid JSON object (a JSON array",
            ),
        ] {
            let e = parse_line(line, 2).unwrap_err().to_string();
            assert!(e.contains(needle), "{line}: {e}");
        }
    }

    #[test]
    fn parses_track_json_lines() {
        // Raw centroid (no filter): `present` and `centroid_mm`.
        let raw = r#"{"t_s":0.25,"points":310,"present":true,"centroid_mm":[1.5,2,200],"truth_present":true,"truth_mm":[1,2,3],"z_profile_mm":null,"replan":false}"#;
        assert_eq!(
            parse_line(raw, 1).unwrap().unwrap(),
            Sample {
                t_s: 0.25,
                pos_mm: [1.5, 2.0, 200.0],
                present: true
            }
        );
        // The filtered, gated centre wins when the line has one.
        let f = r#"{"t_s":0.5,"points":3,"present":true,"centroid_mm":[1,2,3],"gated_present":false,"filtered_mm":null}"#;
        assert_eq!(
            parse_line(f, 1).unwrap().unwrap(),
            Sample {
                t_s: 0.5,
                pos_mm: [0.0; 3],
                present: false
            }
        );
        let f = r#"{"t_s":0.5,"points":3,"present":true,"centroid_mm":[1,2,3],"gated_present":true,"filtered_mm":[4,5,6]}"#;
        assert_eq!(parse_line(f, 1).unwrap().unwrap().pos_mm, [4.0, 5.0, 6.0]);
        let absent = r#"{"t_s":0.5,"points":0,"present":false,"centroid_mm":null}"#;
        assert!(!parse_line(absent, 1).unwrap().unwrap().present);
        for (bad, says) in [
            (
                r#"{"t_s":0.5,"present":true,"centroid_mm":[1,2,3],"colour":1}"#,
                "unknown field `colour`",
            ),
            (
                r#"{"t_s":0.5,"present":true,"centroid_mm":null}"#,
                "needs its centre",
            ),
            (
                r#"{"t_s":0.5,"centroid_mm":[1,2,3]}"#,
                "missing field `present`",
            ),
            (
                r#"{"t_s":0.5,"present":true,"centroid_mm":[1,2]}"#,
                "line 3",
            ),
        ] {
            let e = parse_line(bad, 3).unwrap_err().to_string();
            assert!(e.contains(says) && e.starts_with("line 3"), "{bad}: {e}");
        }
    }

    #[test]
    fn parses_json_and_csv() {
        let j = parse_line(r#"{"t":0.5,"x":1,"y":2,"z":3}"#, 1)
            .unwrap()
            .unwrap();
        assert_eq!(
            j,
            Sample {
                t_s: 0.5,
                pos_mm: [1.0, 2.0, 3.0],
                present: true
            }
        );
        let c = parse_line("0.5, 1, 2, 3, 0", 1).unwrap().unwrap();
        assert_eq!(
            c,
            Sample {
                t_s: 0.5,
                pos_mm: [1.0, 2.0, 3.0],
                present: false
            }
        );
        assert_eq!(parse_line("t,x,y,z,present", 1).unwrap(), None);
        assert_eq!(
            parse_line("\u{feff}0.5,1,2,3,0", 1).unwrap(),
            parse_line("0.5,1,2,3,0", 1).unwrap()
        );
        assert!(parse_line("\u{feff}0.5,1,2,3,0", 2).is_err());
        assert_eq!(parse_line("  # note", 1).unwrap(), None);
    }

    #[test]
    fn bad_lines_say_what_is_wrong() {
        let e = parse_line("0.5,1,2", 7).unwrap_err().to_string();
        assert!(e.contains("line 7") && e.contains("5 CSV fields"), "{e}");
        let e = parse_line("0.5,1,2,x,1", 3).unwrap_err().to_string();
        assert!(e.contains("z `x`"), "{e}");
        let e = parse_line(r#"{"t":1,"x":1}"#, 2).unwrap_err().to_string();
        assert!(e.starts_with("line 2: not a centroid JSON"), "{e}");
        assert!(parse_line("0,1,2,nan,1", 1).is_err());
        assert!(!e.contains('\n'));
    }

    #[test]
    fn reads_lines_with_errors_in_place() {
        let text = "t,x,y,z,present\n0,1,2,3,1\nbad\n";
        let v: Vec<_> = read_lines(text.as_bytes()).collect();
        assert_eq!(v.len(), 2);
        assert!(v[0].is_ok() && v[1].is_err());
    }

    #[test]
    fn long_lines_are_refused_without_reading_them_whole() {
        let mut text = "0,0,0,200,1\n".to_string();
        text.push_str(&"9".repeat(MAX_LINE_BYTES + 1));
        let v: Vec<_> = read_lines(text.as_bytes()).collect();
        assert!(v[0].is_ok());
        let e = v[1].as_ref().unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("4096 bytes"), "{e}");
        // An endless stream of zero bytes ends with the same error.
        let zeros = std::io::BufReader::new(std::io::repeat(0));
        let e = read_lines(zeros).next().unwrap().unwrap_err();
        assert!(e.downcast_ref::<InputError>().is_some(), "{e}");
    }

    #[test]
    fn replay_gaps_and_bad_bytes_are_errors_naming_the_line() {
        let text = "0,0,0,200,1\n1000,0,0,200,1\n";
        let v: Vec<_> = replay_lines(text.as_bytes()).collect();
        let e = v[1].as_ref().unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("at most 60 s"), "{e}");
        // Live streams do not pace, so a gap is fine there.
        assert!(read_lines(text.as_bytes()).all(|r| r.is_ok()));
        let bytes: &[u8] = b"0,0,0,200,1\n\xff\xfe\n";
        let v: Vec<_> = read_lines(bytes).collect();
        assert!(v[1].as_ref().unwrap_err().to_string().contains("not UTF-8"));
    }

    #[test]
    fn udp_port_zero_is_refused_as_input() {
        let idle = std::time::Duration::from_millis(10);
        let err = udp(0, idle, Default::default())
            .err()
            .expect("port 0 refused");
        assert!(err.is::<crate::InputError>(), "{err}");
        assert!(err.to_string().contains("--udp 0"), "{err}");
    }

    #[test]
    fn a_replayed_file_names_itself_in_its_errors() {
        let path = std::env::temp_dir().join(format!("lmhost-replay-{}.csv", std::process::id()));
        std::fs::write(&path, "0,0,0,200,1\n\u{1}garbage\n").unwrap();
        let v: Vec<_> = replay_file("--stream file", &path).unwrap().collect();
        let _ = std::fs::remove_file(&path);
        let err = v
            .into_iter()
            .find_map(Result::err)
            .expect("the garbage line refused");
        let msg = crate::error::one_line(&err);
        assert!(err.chain().any(|c| c.is::<InputError>()), "{msg}");
        let want = format!("--stream file {}: line 2: ", path.display());
        assert!(msg.starts_with(&want), "{msg}");
    }
}
