//! Where centroid samples come from: text lines (stdin or a recorded file,
//! JSON lines or CSV), UDP datagrams, or the synthetic finger.
//!
//! Text formats, one sample per line:
//! - JSON: `{"t": 0.011, "x": 1.2, "y": -0.4, "z": 201.0, "present": true}`
//!   (`present` defaults to true);
//! - CSV: `t,x,y,z,present` with `present` as `1`/`0`/`true`/`false`; an
//!   optional header line starting with `t` is skipped; `#` starts a comment.
//!
//! Units: seconds and millimetres.

use std::io::BufRead;

use super::Sample;
use crate::InputError;

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

/// Parse one line; `Ok(None)` for blank lines, comments and a CSV header.
/// `line_no` (1-based) goes into the error message.
pub fn parse_line(line: &str, line_no: usize) -> Result<Option<Sample>, InputError> {
    let line = line.trim();
    if line.is_empty() || line.starts_with('#') {
        return Ok(None);
    }
    let sample = if line.starts_with('{') {
        let j: JsonSample = serde_json::from_str(line).map_err(|e| {
            InputError::new(format!("line {line_no}: not a centroid JSON object ({e})"))
        })?;
        Sample {
            t_s: j.t,
            pos_mm: [j.x, j.y, j.z],
            present: j.present,
        }
    } else {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields[0].eq_ignore_ascii_case("t") {
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
        let present = match fields[4].to_ascii_lowercase().as_str() {
            "1" | "true" => true,
            "0" | "false" => false,
            other => {
                return Err(InputError::new(format!(
                    "line {line_no}: present `{other}` must be 1, 0, true or false"
                )));
            }
        };
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
    Ok(Some(sample))
}

/// Samples from any line-oriented reader (stdin, a recorded file).
pub fn read_lines<R: BufRead>(reader: R) -> impl Iterator<Item = anyhow::Result<Sample>> {
    reader
        .lines()
        .enumerate()
        .filter_map(|(i, line)| match line {
            Err(e) => Some(Err(anyhow::Error::new(e).context("reading centroid stream"))),
            Ok(l) => parse_line(&l, i + 1)
                .map_err(anyhow::Error::new)
                .transpose(),
        })
}

/// Samples from UDP datagrams on 127.0.0.1:`port`, one line (or several,
/// newline-separated) per datagram. Ends after `idle` without a datagram.
pub fn udp(
    port: u16,
    idle: std::time::Duration,
) -> anyhow::Result<impl Iterator<Item = anyhow::Result<Sample>>> {
    use anyhow::Context as _;
    let sock = std::net::UdpSocket::bind(("127.0.0.1", port))
        .with_context(|| format!("binding UDP port 127.0.0.1:{port}"))?;
    sock.set_read_timeout(Some(idle))
        .context("setting UDP timeout")?;
    let mut pending: std::collections::VecDeque<anyhow::Result<Sample>> = Default::default();
    let mut datagrams = 0usize;
    let mut buf = vec![0u8; 65_536];
    Ok(std::iter::from_fn(move || {
        loop {
            if let Some(s) = pending.pop_front() {
                return Some(s);
            }
            let n = match sock.recv(&mut buf) {
                Ok(n) => n,
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) =>
                {
                    return None;
                }
                Err(e) => return Some(Err(anyhow::Error::new(e).context("receiving UDP"))),
            };
            datagrams += 1;
            let text = String::from_utf8_lossy(&buf[..n]);
            for line in text.lines() {
                match parse_line(line, datagrams) {
                    Ok(Some(s)) => pending.push_back(Ok(s)),
                    Ok(None) => {}
                    Err(e) => pending.push_back(Err(e.into())),
                }
            }
        }
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
