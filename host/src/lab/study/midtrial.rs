//! A trial cut short mid-way (`kill -9`, a power cut, a lost device): its
//! adaptive procedure is rebuilt from what `events.jsonl` logged of it as
//! it happened, so `--resume` continues that trial at the level it had
//! reached instead of starting it again.
//!
//! The runner writes a `level` line per answer (the answer and the level
//! it led to) before the next presentation; a staircase or QUEST+ is
//! deterministic given its answers, so replaying the logged answers into
//! a fresh procedure gives back its state, and every logged level is
//! checked against the replay (a log that does not follow from its own
//! answers is refused, nothing changed). Only what the log holds whole
//! counts: a torn last line (the write a kill cut short) is not an
//! answer. The replayed answers stay in the trial's row, counted once.

use std::io::BufRead as _;
use std::path::Path;

use super::procedure::{Procedure, Step};
use crate::error::InputError;

/// Longest line read back from an event log (a session event is a few
/// hundred bytes; the library's records are in `session.json`).
const MAX_LINE: usize = 1 << 20;

/// The answers `events.jsonl` logged for trial `trial`'s procedure, whose
/// level event is called `event` and its level field `field`: each answer
/// and the level it led to, in order.
pub fn logged(
    events: &Path,
    trial: usize,
    event: &str,
    field: &str,
) -> Result<Vec<(String, f64)>, InputError> {
    let what = || format!("event log {}", events.display());
    if std::fs::symlink_metadata(events).is_err() {
        return Ok(Vec::new());
    }
    // Not remembered as an input: the run appends to it afterwards.
    let f = crate::files::open_own("event log", events)?;
    let mut r = std::io::BufReader::new(f);
    let mut out = Vec::new();
    let mut line = Vec::new();
    for n in 1.. {
        line.clear();
        let read = std::io::Read::take(&mut r, MAX_LINE as u64 + 1)
            .read_until(b'\n', &mut line)
            .map_err(|e| {
                InputError::new(format!(
                    "cannot read {}: {}",
                    what(),
                    crate::files::reason(&e)
                ))
            })?;
        // The end, or a torn last line: what a kill cut short is not logged.
        if read == 0 || line.last() != Some(&b'\n') {
            if line.len() > MAX_LINE {
                return Err(InputError::new(format!(
                    "{} line {n}: longer than {MAX_LINE} bytes",
                    what()
                )));
            }
            break;
        }
        let v: serde_json::Value = serde_json::from_slice(&line)
            .map_err(|e| InputError::new(format!("{} line {n}: {e}", what())))?;
        if v["trial"].as_u64() != Some(trial as u64) {
            continue;
        }
        // Each run of the trial starts with a `trial` line saying how
        // many answers it carried over: none when it started afresh (a
        // run of a version that could not continue, or a procedure that
        // cannot), so earlier answers no longer count.
        if v["event"] == "trial" {
            // A count as written: `-1`, `2.5` or `null` is refused, not
            // taken for 0 (left out, it is 0).
            let kept = match v.get("resumed_presentations") {
                None => 0,
                Some(k) => crate::json::no_null::<_, crate::whole::FileNumber>(k)
                    .map_err(|e| e.to_string())
                    .and_then(|c| c.map_or(Ok(0), |c| c.whole_in(0, u64::from(u32::MAX))))
                    .map_err(|m| {
                        InputError::new(format!(
                            "{} line {n}: field `resumed_presentations`: {m}",
                            what()
                        ))
                    })?,
            };
            out.truncate(usize::try_from(kept).unwrap_or(usize::MAX));
            continue;
        }
        if v["event"] != event {
            continue;
        }
        // The first level of each run of the trial has no answer.
        let Some(answer) = v["answer"].as_str() else {
            continue;
        };
        let level = v[field]
            .as_f64()
            .ok_or_else(|| InputError::new(format!("{} line {n}: no number `{field}`", what())))?;
        out.push((answer.to_owned(), level));
    }
    Ok(out)
}

/// Gives `pr` the `logged` answers in order, each checked as the
/// participant's would be and its level against the logged one; says
/// which does not follow.
pub fn replay(pr: &mut dyn Procedure, logged: &[(String, f64)]) -> Result<(), String> {
    for (k, (answer, level)) in logged.iter().enumerate() {
        if pr.finished() {
            return Err(format!(
                "answer {} ({answer}) comes after the procedure ended",
                k + 1
            ));
        }
        let given = pr
            .asked()
            .parse(answer)
            .map_err(|m| format!("answer {} `{}`: {m}", k + 1, answer.escape_debug()))?;
        let now = match pr.respond(&given) {
            Step::Next(l) | Step::Last { level: l, .. } => Some(l),
            Step::Done => None,
        };
        if now.is_some_and(|l| l != *level) {
            return Err(format!(
                "answer {} ({answer}) leads to level {}, not the logged {level}",
                k + 1,
                now.unwrap_or(f64::NAN)
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lab::study::procedure::quest::Quest;

    fn quest() -> Quest {
        Quest::new(
            &crate::lab::study::procedure::quest::tests::spec(11, &[12.0], 6, None),
            0,
        )
    }

    #[test]
    fn a_replayed_procedure_continues_where_the_log_left_it() {
        let dir = crate::lab::study::test_files::scratch("midtrial");
        let events = dir.join("events.jsonl");
        // Trial 2 answered three times, then a kill cut the fourth line.
        let mut q = quest();
        let mut text = String::from(
            "{\"event\":\"trial\",\"trial\":1}\n{\"event\":\"level\",\"trial\":1,\"answer\":\"yes\",\"level_intensity\":0.1}\n",
        );
        // A first run of trial 2 that a run started afresh replaced.
        text += "{\"event\":\"trial\",\"trial\":2}\n";
        text += "{\"event\":\"level\",\"trial\":2,\"answer\":\"yes\",\"level_intensity\":0.7}\n";
        text += "{\"event\":\"trial\",\"trial\":2}\n";
        text += "{\"event\":\"level\",\"trial\":2,\"answer\":null,\"level_intensity\":0.5}\n";
        let mut levels = Vec::new();
        for a in ["no", "yes", "no"] {
            let Step::Next(l) = q.respond(a) else {
                panic!()
            };
            levels.push(l);
            text += &format!(
                "{{\"t_host_us\":1,\"event\":\"level\",\"trial\":2,\"answer\":\"{a}\",\"level_intensity\":{l}}}\n"
            );
        }
        // A run that continued after two answers, then cut mid-line.
        let two = text
            .match_indices("\"answer\":\"")
            .nth(3)
            .map(|(i, _)| i)
            .unwrap();
        let at = text[two..].find('\n').unwrap() + two + 1;
        text.insert_str(
            at,
            "{\"event\":\"trial\",\"trial\":2,\"resumed_presentations\":2}\n",
        );
        text += "{\"event\":\"level\",\"trial\":2,\"answer\":\"ye";
        std::fs::write(&events, &text).unwrap();
        let got = logged(&events, 2, "level", "level_intensity").unwrap();
        assert_eq!(got.len(), 3);
        assert_eq!(got[2], ("no".to_owned(), levels[2]));
        let mut r = quest();
        replay(&mut r, &got).unwrap();
        assert_eq!(r.answers(), 3);
        assert_eq!(r.next(), q.next());
        assert_eq!(r.posterior(), q.posterior());
        // A level that does not follow from its answer is refused.
        let mut bad = got.clone();
        bad[1].1 += 0.1;
        let e = replay(&mut quest(), &bad).unwrap_err();
        assert!(e.starts_with("answer 2 (yes) leads to level"), "{e}");
        assert!(replay(&mut quest(), &[("maybe".into(), 0.5)]).is_err());
        // More answers than the procedure takes.
        let many: Vec<(String, f64)> = (0..7).map(|_| ("no".to_owned(), 1.0)).collect();
        assert!(replay(&mut quest(), &many).is_err());
        // A count that is no count is refused, not taken for none.
        for (c, said) in [
            ("-1", "-1 is out of range: allowed 0..=4294967295"),
            ("2.5", "2.5 is not a whole number: allowed 0..=4294967295"),
            ("\"2\"", "expected a whole number"),
            ("null", crate::json::NULL_REFUSED),
        ] {
            let line =
                format!("{{\"event\":\"trial\",\"trial\":2,\"resumed_presentations\":{c}}}\n");
            std::fs::write(&events, line).unwrap();
            let e = logged(&events, 2, "level", "level_intensity")
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("line 1: field `resumed_presentations`: ") && e.contains(said),
                "{e}"
            );
        }
        // A line that is not JSON is named.
        std::fs::write(&events, "{\"event\":\"trial\"}\nnot json\n").unwrap();
        let e = logged(&events, 2, "level", "level_intensity").unwrap_err();
        assert!(e.to_string().contains("line 2"), "{e}");
        assert!(
            logged(&dir.join("none"), 1, "level", "x")
                .unwrap()
                .is_empty()
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
