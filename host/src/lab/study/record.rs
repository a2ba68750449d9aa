//! What a participant's run leaves on disk: `trials.csv` (a row per
//! finished trial, appended whole and synced before the next trial),
//! `session.json` (written whole) and `events.jsonl`; and reading them back
//! for `--resume` and the report.

use serde::{Deserialize, Serialize};

use super::design::Planned;
use super::protocol::Protocol;

/// `trials.csv`'s own columns before the factors.
pub const HEAD: [&str; 4] = ["participant", "trial", "set", "stimulus"];
/// Its own columns after the factors (timing as realised and played).
pub const TIMING: [&str; 12] = [
    "steps",
    "dwell_us",
    "freq_hz",
    "step_mm",
    "onset_us",
    "offset_us",
    "device_presented_s",
    "presented_s",
    "present_fraction",
    "on_phases",
    "mutes",
    "switch_ms",
];
/// The adjustment's columns, where used.
pub const ADJUST: [&str; 4] = [
    "start_depth_mm",
    "adjustments",
    "adjust_answers",
    "depths_mm",
];
/// The final depth column.
pub const FINAL_DEPTH: &str = "final_depth_mm";

/// The header of `trials.csv` for `p`.
pub fn header(p: &Protocol) -> Vec<String> {
    let mut h: Vec<String> = HEAD.iter().map(|s| (*s).to_owned()).collect();
    h.extend(p.factors.iter().map(|f| f.name.clone()));
    h.extend(TIMING.iter().map(|s| (*s).to_owned()));
    for q in &p.questions {
        h.extend(q.columns());
        if q.shuffle {
            h.push(format!("{}_order", q.id));
        }
    }
    if p.adjustment.is_some() {
        h.extend(ADJUST.iter().map(|s| (*s).to_owned()));
        h.push(FINAL_DEPTH.into());
    }
    h
}

/// One CSV field, quoted when it holds a comma, quote or line break.
pub fn field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

/// A CSV line from fields.
pub fn line(fields: &[String]) -> String {
    fields
        .iter()
        .map(|f| field(f))
        .collect::<Vec<_>>()
        .join(",")
}

/// Splits one CSV line (quoted fields as [`field`] writes them).
pub fn split(line: &str) -> Result<Vec<String>, String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut chars = line.chars().peekable();
    let mut quoted = false;
    let mut start = true;
    while let Some(c) = chars.next() {
        if quoted {
            if c == '"' {
                if chars.peek() == Some(&'"') {
                    chars.next();
                    cur.push('"');
                } else {
                    quoted = false;
                }
            } else {
                cur.push(c);
            }
        } else if c == '"' && start {
            quoted = true;
            start = false;
        } else if c == ',' {
            out.push(std::mem::take(&mut cur));
            start = true;
        } else {
            cur.push(c);
            start = false;
        }
    }
    if quoted {
        return Err("a quoted field is not closed".into());
    }
    out.push(cur);
    Ok(out)
}

/// One run of the session (the first, and one per `--resume`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Run {
    /// Wall clock at its start (s since 1970).
    pub started_unix_s: u64,
    /// First trial it ran (1-based).
    pub first_trial: usize,
    /// lmhost's version.
    pub lmhost_version: String,
    /// The device, as it described itself.
    pub device: serde_json::Value,
    /// Every library entry as planned for it: id, CRC-32, realised timing.
    pub library: Vec<serde_json::Value>,
    /// `--time-scale`.
    pub time_scale: f64,
    /// `--finger`.
    pub finger: String,
}

/// `session.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SessionFile {
    /// The protocol's name.
    pub protocol_name: String,
    /// The protocol file as given.
    pub protocol_file: String,
    /// Its text, verbatim (a different text refuses `--resume`).
    pub protocol: String,
    /// The library file.
    pub library_file: String,
    /// The participant.
    pub participant: String,
    /// The seed of the order.
    pub seed: u64,
    /// Questions in the order asked.
    pub question_order: Vec<String>,
    /// `trials.csv`'s condition and answer columns and their kinds
    /// (`factor`, `likert`, `choice`, `number`, `depth`).
    pub columns: Vec<(String, String)>,
    /// Every trial in order, with shown item and option orders.
    pub trials: Vec<Planned>,
    /// The runs so far.
    pub runs: Vec<Run>,
}

/// The condition and answer columns of `p` with their kinds.
pub fn columns(p: &Protocol) -> Vec<(String, String)> {
    let mut v: Vec<(String, String)> = p
        .factors
        .iter()
        .map(|f| (f.name.clone(), "factor".to_owned()))
        .collect();
    for q in &p.questions {
        let kind = match q.kind {
            super::protocol::Kind::Likert { .. } => "likert",
            super::protocol::Kind::Choice { .. } => "choice",
            super::protocol::Kind::Number { .. } => "number",
        };
        v.extend(q.columns().into_iter().map(|c| (c, kind.to_owned())));
    }
    if p.adjustment.is_some() {
        v.push((FINAL_DEPTH.to_owned(), "depth".to_owned()));
    }
    v
}

/// The answers a finished row used (to skip them in a responses file on
/// `--resume`): one per question column, plus its adjustment answers.
pub fn answers_used(p: &Protocol, header: &[String], row: &[String]) -> usize {
    let q: usize = p.questions.iter().map(|q| q.columns().len()).sum();
    let adj = header
        .iter()
        .position(|h| h == "adjust_answers")
        .and_then(|i| row.get(i))
        .map_or(0, |s| s.split('|').filter(|x| !x.is_empty()).count());
    q + adj
}

/// Checks the whole rows of a `trials.csv` being resumed: its header is
/// `header` and its rows are trials 1, 2, … of `plan`, in order. Returns
/// the rows (fields split).
pub fn check_rows(
    lines: &[String],
    header: &[String],
    plan: &[Planned],
    file: &str,
) -> Result<Vec<Vec<String>>, String> {
    let Some(first) = lines.first() else {
        return Ok(Vec::new());
    };
    if split(first)? != header {
        return Err(format!("{file}: its header is not this protocol's columns"));
    }
    let mut rows = Vec::new();
    for (i, l) in lines[1..].iter().enumerate() {
        let r = split(l).map_err(|m| format!("{file} line {}: {m}", i + 2))?;
        let want = plan.get(i).ok_or_else(|| {
            format!(
                "{file} line {}: more rows than the session has trials",
                i + 2
            )
        })?;
        if r.len() != header.len() || r[1] != want.trial.to_string() || r[3] != want.stimulus {
            return Err(format!(
                "{file} line {}: expected trial {} ({}), found `{}`",
                i + 2,
                want.trial,
                want.stimulus,
                l.chars().take(60).collect::<String>()
            ));
        }
        rows.push(r);
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_fields_quote_what_needs_it_and_split_back() {
        let f = vec![
            "plain".to_owned(),
            "a,b".to_owned(),
            "say \"hi\"".to_owned(),
            String::new(),
            "1|2".to_owned(),
        ];
        let l = line(&f);
        assert_eq!(l, "plain,\"a,b\",\"say \"\"hi\"\"\",,1|2");
        assert_eq!(split(&l).unwrap(), f);
        assert!(split("\"open").is_err());
        assert_eq!(split("").unwrap(), vec![String::new()]);
    }
}
