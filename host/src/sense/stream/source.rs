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
//! - CSV: `t,x,y,z,present`; the header line `t,x,y,z,present` is
//!   skipped; `#` starts a comment. A
//!   line separated by `;` or tabs (a European-locale spreadsheet, its
//!   `3,5` meaning 3.5) is refused as such.
//!
//! Lines are read as every text input is ([`crate::files::text`]): they
//! end at LF, CRLF or a lone CR; a byte-order mark opening the first is
//! skipped; UTF-16 and a NUL byte are refused naming the line.
//!
//! `present` is `true`, `false`, `1` or `0` in both forms (CSV's
//! `true`/`false` in any case, as spreadsheets write them), nothing else:
//! one set, refused in the same words (`presence`).
//!
//! `null` is never a key left out ([`crate::json`]'s rule): a plain
//! line's `present` and a track line's `gated_present` are left out for
//! their defaults, `null` refused; a track line's `centroid_mm` and
//! `filtered_mm` are `null` where `track` has none (as it writes them).
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
    /// Judged by [`presence`] (JSON `true`/`false` or `1`/`0`); `null`
    /// is refused, not taken for absent.
    #[serde(default = "a_finger")]
    present: serde_json::Value,
}

/// An absent `present`: a finger.
fn a_finger() -> serde_json::Value {
    serde_json::Value::Bool(true)
}

/// A line of `lmhost track --json` (the keys `track::session` prints).
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct TrackLine {
    t_s: f64,
    present: serde_json::Value,
    /// `null`: no centroid (what `track` writes without one).
    centroid_mm: Option<[f64; 3]>,
    /// Left out: the frame's own presence; `null` refused.
    #[serde(default, deserialize_with = "crate::json::no_null")]
    gated_present: Option<bool>,
    /// Left out or `null` (what `track` writes while its gate is closed):
    /// no filtered centre.
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
    /// Its sample: the filtered centre when the line has one, else the
    /// raw centroid; present as the presence gate said when the line has
    /// it (every `track --json` line does, filtered or not), else as the
    /// frame did; a finger needs a position.
    fn sample(self, line_no: usize) -> Result<Sample, InputError> {
        let pos = self.filtered_mm.or(self.centroid_mm);
        // Judged even where the gate's word is taken.
        let raw = json_presence(&self.present, line_no)?;
        let present = self.gated_present.unwrap_or(raw);
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

/// A sample's `present` as written: `true` or `1` (a finger), `false` or
/// `0` (none), in any case as a spreadsheet writes them into CSV (`TRUE`;
/// JSON's literals have one); anything else refused, in the same words
/// from JSON and CSV.
fn presence(written: &str, line_no: usize) -> Result<bool, InputError> {
    match written {
        "1" => Ok(true),
        "0" => Ok(false),
        w if w.eq_ignore_ascii_case("true") => Ok(true),
        w if w.eq_ignore_ascii_case("false") => Ok(false),
        _ => Err(InputError::new(format!(
            "line {line_no}: `{written}` is not a `present` value: give true, false, 1 or 0"
        ))),
    }
}

/// [`presence`] of a JSON value: the literal `true`/`false` or the whole
/// number `1`/`0` (not `1.0`, not the string `"1"`), shown as written.
fn json_presence(v: &serde_json::Value, line_no: usize) -> Result<bool, InputError> {
    match v {
        serde_json::Value::Bool(b) => Ok(*b),
        // `1` and `0` as written; `1.0`, `"1"` or `null` shown as JSON.
        other => presence(&other.to_string(), line_no),
    }
}

/// What a key of a centroid JSON object holds.
#[derive(Clone, Copy)]
enum Want {
    /// A number.
    Number,
    /// `[x, y, z]`, three numbers, or `null` (no position).
    Xyz,
    /// `true` or `false`; left out for its default, never `null`.
    Bool,
}

/// The values of a plain centroid line (`present` is judged by
/// [`json_presence`]).
const CENTROID_VALUES: &[(&str, Want)] = &[
    ("t", Want::Number),
    ("x", Want::Number),
    ("y", Want::Number),
    ("z", Want::Number),
];

/// The values of a `track --json` line this reader takes.
const TRACK_LINE_VALUES: &[(&str, Want)] = &[
    ("t_s", Want::Number),
    ("centroid_mm", Want::Xyz),
    ("filtered_mm", Want::Xyz),
    ("gated_present", Want::Bool),
];

/// Refuses a value of one of `keys` in the object `v` that its key cannot
/// hold, as a bad value of that key (not as a line that is no centroid
/// object): `line 3: `x`: "a" is not a number`.
fn check_values(
    v: &serde_json::Value,
    keys: &[(&str, Want)],
    line_no: usize,
) -> Result<(), InputError> {
    use serde_json::Value as V;
    for &(key, want) in keys {
        let Some(value) = v.get(key) else { continue };
        let (ok, what) = match want {
            Want::Number => (value.is_number(), "a number"),
            Want::Xyz => (
                match value {
                    V::Null => true,
                    V::Array(a) => a.len() == 3 && a.iter().all(V::is_number),
                    _ => false,
                },
                "[x, y, z] (three numbers) or null",
            ),
            Want::Bool if value.is_null() => {
                return Err(InputError::new(format!(
                    "line {line_no}: `{key}`: {}",
                    crate::json::NULL_REFUSED
                )));
            }
            Want::Bool => (value.is_boolean(), "true or false"),
        };
        if !ok {
            let shown = crate::error::short_echo(&value.to_string());
            return Err(InputError::new(format!(
                "line {line_no}: `{key}`: {shown} is not {what}"
            )));
        }
    }
    Ok(())
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
        return Err(InputError::new(crate::files::text::bom_inside(line_no)));
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
        // Well-formed JSON first, its numbers scanned and not yet read:
        // what is not JSON is not a centroid object. Then each value is
        // judged as a value of its key (`x`: 1e999 is too large …).
        serde_json::from_str::<serde::de::IgnoredAny>(line).map_err(bad)?;
        crate::json::exact_numbers(line)
            .map_err(|m| InputError::new(format!("line {line_no}: {m}")))?;
        let v = crate::json::from_str(line).map_err(bad)?;
        // `lmhost track --json` lines carry `t_s`; plain centroids `t`.
        if v.get("t_s").is_some() {
            check_values(&v, TRACK_LINE_VALUES, line_no)?;
            TrackLine::deserialize(v).map_err(bad)?.sample(line_no)?
        } else {
            check_values(&v, CENTROID_VALUES, line_no)?;
            let j = JsonSample::deserialize(v).map_err(bad)?;
            Sample {
                t_s: j.t,
                pos_mm: [j.x, j.y, j.z],
                present: json_presence(&j.present, line_no)?,
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
        if let Some(why) = crate::files::text::foreign_csv(line, "5 fields t,x,y,z,present") {
            return Err(InputError::new(format!("line {line_no}: {why}")));
        }
        if fields.len() != 5 {
            return Err(InputError::new(format!(
                "line {line_no}: expected 5 CSV fields t,x,y,z,present, found {}",
                fields.len()
            )));
        }
        let num = |i: usize, name: &str| {
            let v = fields[i].parse::<f64>().map_err(|_| {
                InputError::new(format!(
                    "line {line_no}: `{name}`: {}",
                    crate::limits::no_number(fields[i])
                ))
            })?;
            crate::limits::exact_literal(fields[i], v)
                .map_err(|m| InputError::new(format!("line {line_no}: {name} {m}")))?;
            Ok::<_, InputError>(v)
        };
        let present = presence(fields[4], line_no)?;
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
    /// Lines of at most [`MAX_LINE_BYTES`], split on LF, CRLF or a lone
    /// CR (a classic Mac file, Excel for Mac's CSV).
    lines: crate::files::lines::LineReader<R>,
    max_gap_s: Option<f64>,
    last_t_s: Option<f64>,
    done: bool,
}

impl<R: BufRead> Iterator for LineSource<R> {
    type Item = anyhow::Result<Sample>;

    fn next(&mut self) -> Option<Self::Item> {
        use crate::files::lines::Line;
        while !self.done {
            // The number of the line about to be read.
            let line_no = self.lines.line_no() + 1;
            match self.lines.next_line() {
                Ok(None) => self.done = true,
                Err(e) => {
                    self.done = true;
                    return Some(Err(anyhow::Error::new(e).context("reading centroid stream")));
                }
                Ok(Some(Line::TooLong)) => {
                    self.done = true;
                    return Some(Err(InputError::new(format!(
                        "line {line_no} is longer than {MAX_LINE_BYTES} bytes (the limit per sample line)"
                    ))
                    .into()));
                }
                Ok(Some(Line::Text(bytes))) => {
                    let text = match crate::files::text::stream_line(bytes, line_no) {
                        Ok(t) => t,
                        Err(e) => {
                            self.done = true;
                            return Some(Err(InputError::new(e).into()));
                        }
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
        lines: crate::files::lines::LineReader::new(reader, MAX_LINE_BYTES),
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
        lines: crate::files::lines::LineReader::new(reader, MAX_LINE_BYTES),
        max_gap_s: Some(MAX_REPLAY_GAP_S),
        last_t_s: None,
        done: false,
    }
}

/// [`replay_lines`] over the file at `path` given to `flag` (`--stream`,
/// `--input`: flags that take `-` for standard input), opened as an input
/// ([`crate::files::open_input`]); every error it yields names the file as
/// `FLAG file` and its path, for a bad line is read long after the command
/// started, its other output between.
pub fn replay_file(
    flag: &str,
    path: &std::path::Path,
) -> anyhow::Result<impl Iterator<Item = anyhow::Result<Sample>> + Send + use<>> {
    use anyhow::Context as _;
    let what = &format!("{flag} file");
    crate::files::not_a_pipe(what, flag, path)?;
    let reader = std::io::BufReader::new(crate::files::open_input(what, path)?);
    let name = format!("{what} {}", path.display());
    let samples = replay_lines(reader).map({
        let name = name.clone();
        move |r| r.with_context(|| name.clone())
    });
    Ok(not_empty(samples, name))
}

/// `items`, with an error in place of their end when they end before a
/// first sample: a recording (or piped input) of no centroids, empty or
/// only comments, is not a stream that tracked nothing (`lmhost stream`
/// exited 0 reporting 0 samples). The error names `what` it was.
pub fn not_empty<I>(items: I, what: String) -> impl Iterator<Item = anyhow::Result<Sample>>
where
    I: IntoIterator<Item = anyhow::Result<Sample>>,
{
    let mut items = items.into_iter();
    let (mut seen, mut done) = (false, false);
    std::iter::from_fn(move || {
        if done {
            return None;
        }
        match items.next() {
            Some(r) => {
                seen = true;
                Some(r)
            }
            None if !seen => {
                done = true;
                Some(Err(crate::InputError::new(format!(
                    "no centroids on input: {what} ended before its first sample line"
                ))
                .into()))
            }
            None => None,
        }
    })
}

/// The samples of `items` released at their time stamps on `clock`: the
/// first at once, each next one once as much time has passed since the
/// first as their stamps differ, so a 20 s recording plays for 20 s in a
/// session or study as in `lmhost stream`. Meant for a reader thread
/// (it sleeps) over [`replay_lines`], which bounds every gap. A stamp the
/// replay's time-stamp rule distrusts ([`super::plausible::Stamps`], what
/// the stream's gate drops) is passed on at once, never waited for nor
/// taken as the time the rest must catch up with: what is done with the
/// sample is the reader's to decide, as for a live source.
pub fn paced<I>(
    items: I,
    clock: crate::clock::Clock,
) -> impl Iterator<Item = anyhow::Result<Sample>>
where
    I: IntoIterator<Item = anyhow::Result<Sample>>,
{
    let mut first: Option<(std::time::Duration, f64)> = None;
    let mut stamps = super::plausible::Stamps::default();
    items.into_iter().map(move |item| {
        let s = item?;
        if stamps
            .check(s.t_s, super::plausible::Arrival::Replay)
            .is_err()
        {
            return Ok(s);
        }
        pace_one(s, &mut first, &clock)
    })
}

/// Waits on `clock` until `s` is due after the first sample (`first`: its
/// time on the clock and its stamp, set by the first call).
fn pace_one(
    s: Sample,
    first: &mut Option<(std::time::Duration, f64)>,
    clock: &crate::clock::Clock,
) -> anyhow::Result<Sample> {
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
}

/// Counters a UDP source keeps while it runs.
#[derive(Debug, Default)]
pub struct UdpCounts {
    /// Datagrams received.
    pub datagrams: std::sync::atomic::AtomicU64,
    /// Datagrams with at least one unusable line (skipped lines), or
    /// none at all (empty or blank).
    pub bad_datagrams: std::sync::atomic::AtomicU64,
    /// Datagrams the kernel dropped because the socket's buffer was full
    /// (a tracker sending faster than the stream reads), as the kernel
    /// counts them (`SO_RXQ_OVFL`). It tells with the next datagram that
    /// arrives, so drops after the last one are not in it.
    pub lost: std::sync::atomic::AtomicU64,
    /// Whether the kernel counts `lost` at all (Linux does); where it does
    /// not, a report says the loss was not counted rather than 0.
    pub lost_counted: std::sync::atomic::AtomicBool,
}

impl UdpCounts {
    /// Datagrams the kernel dropped, or `None` where it does not count them.
    pub fn lost(&self) -> Option<u64> {
        use std::sync::atomic::Ordering::Relaxed;
        self.lost_counted
            .load(Relaxed)
            .then(|| self.lost.load(Relaxed))
    }
}

/// One datagram into `buf`: its length, and the kernel's count of the
/// socket's dropped datagrams when it sent one along.
fn recv_counting_drops(
    sock: &std::net::UdpSocket,
    buf: &mut [u8],
) -> std::io::Result<(usize, Option<u32>)> {
    use nix::sys::socket::{ControlMessageOwned, MsgFlags, SockaddrStorage, recvmsg};
    use std::os::fd::AsRawFd as _;
    let mut cmsg = nix::cmsg_space!(u32);
    let mut iov = [std::io::IoSliceMut::new(buf)];
    let msg = recvmsg::<SockaddrStorage>(
        sock.as_raw_fd(),
        &mut iov,
        Some(&mut cmsg),
        MsgFlags::empty(),
    )
    .map_err(std::io::Error::from)?;
    let dropped = msg.cmsgs().ok().and_then(|mut c| {
        c.find_map(|m| match m {
            ControlMessageOwned::RxqOvfl(n) => Some(n),
            _ => None,
        })
    });
    Ok((msg.bytes, dropped))
}

/// Samples from UDP datagrams on 127.0.0.1:`port` (1..=65535), one line (or several,
/// newline-separated) per datagram. Ends after `idle` without a datagram,
/// or when a stop was requested ([`crate::stop::requested`]).
///
/// A bad line (garbage, not UTF-8, non-finite, longer than
/// [`MAX_LINE_BYTES`]) is skipped and its datagram counted in `counts`, as
/// is a datagram with no line at all (empty or blank);
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
    // Ask the kernel to count what it drops; a system that cannot leaves
    // the loss uncounted (and said to be) rather than the stream refused.
    if nix::sys::socket::setsockopt(&sock, nix::sys::socket::sockopt::RxqOvfl, &1).is_ok() {
        counts.lost_counted.store(true, Relaxed);
    }
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
            let n = match recv_counting_drops(&sock, &mut buf) {
                Ok((n, dropped)) => {
                    if let Some(d) = dropped {
                        counts.lost.fetch_max(u64::from(d), Relaxed);
                    }
                    n
                }
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
            // A datagram is one message, not a text file: one with no line
            // in it (empty, or only blanks) carries nothing and is bad like
            // any other unparsable one. A comment or the CSV header is a
            // line, kept as in a file.
            let mut bad = false;
            match std::str::from_utf8(&buf[..n]) {
                Err(_) => bad = true,
                Ok(text) if text.trim().is_empty() => bad = true,
                Ok(text) => {
                    // Its lines split as a stream's are (LF, CRLF or a
                    // lone CR).
                    use crate::files::lines::{Line, LineReader};
                    let mut lines = LineReader::new(text.as_bytes(), MAX_LINE_BYTES);
                    while let Ok(Some(line)) = lines.next_line() {
                        let parsed = match line {
                            Line::Text(l) => std::str::from_utf8(l)
                                .ok()
                                .and_then(|l| parse_line(l, number).ok()),
                            Line::TooLong => {
                                bad = true;
                                let _ = lines.skip_rest();
                                continue;
                            }
                        };
                        match parsed {
                            Some(Some(s)) => pending.push_back(s),
                            Some(None) => {}
                            None => bad = true,
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
mod tests;
