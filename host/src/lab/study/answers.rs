//! What the participant is asked and how answers come in: from a
//! responses file (one answer per line, in the order asked), from stdin
//! lines, or from single keys at the terminal.

use std::io::{BufRead as _, Read as _};
use std::path::Path;
use std::sync::mpsc::{Receiver, TryRecvError, channel};

use super::protocol::{Kind, Question};
use crate::error::InputError;

/// One thing asked: a question, a Likert item or an adjustment.
#[derive(Debug, Clone, PartialEq)]
pub struct Asked {
    /// The `trials.csv` column (the adjustment's: `adjust`).
    pub column: String,
    /// The prompt.
    pub prompt: String,
    /// What is accepted.
    pub accepts: Accepts,
}

/// What an answer may be.
#[derive(Debug, Clone, PartialEq)]
pub enum Accepts {
    /// 1..=points.
    Likert(u32),
    /// One of these labels (in the order shown) or its 1-based index.
    Choice(Vec<String>),
    /// A number in the range.
    Number(f64, f64),
}

impl Asked {
    /// The items asked for question `q` with its shown `order`.
    pub fn of(q: &Question, order: &[usize]) -> Vec<Asked> {
        let text = if q.text.is_empty() { &q.id } else { &q.text };
        match &q.kind {
            Kind::Likert {
                points,
                low,
                high,
                items,
            } => {
                let scale = if low.is_empty() && high.is_empty() {
                    format!("1-{points}")
                } else {
                    format!("1 = {low} ... {points} = {high}")
                };
                if items.is_empty() {
                    return vec![Asked {
                        column: q.id.clone(),
                        prompt: format!("{text} [{scale}]"),
                        accepts: Accepts::Likert(*points),
                    }];
                }
                order
                    .iter()
                    .map(|&i| Asked {
                        column: format!("{}_{}", q.id, items[i]),
                        prompt: format!("{text} ({}) [{scale}]", items[i]),
                        accepts: Accepts::Likert(*points),
                    })
                    .collect()
            }
            Kind::Choice { options } => {
                let shown: Vec<String> = order.iter().map(|&i| options[i].clone()).collect();
                let list = shown
                    .iter()
                    .enumerate()
                    .map(|(i, o)| format!("{} = {o}", i + 1))
                    .collect::<Vec<_>>()
                    .join(", ");
                vec![Asked {
                    column: q.id.clone(),
                    prompt: format!("{text} [{list}]"),
                    accepts: Accepts::Choice(shown),
                }]
            }
            Kind::Number { min, max } => vec![Asked {
                column: q.id.clone(),
                prompt: format!(
                    "{text} [{} to {}]",
                    crate::limits::show(*min),
                    crate::limits::show(*max)
                ),
                accepts: Accepts::Number(*min, *max),
            }],
        }
    }

    /// Checks `text` and returns the value recorded: a Likert point, a
    /// choice's label, a number as given.
    pub fn parse(&self, text: &str) -> Result<String, String> {
        let t = text.trim();
        if t.len() > MAX_ANSWER_BYTES {
            return Err(format!(
                "an answer to `{}` of {} bytes: at most {MAX_ANSWER_BYTES}",
                self.column,
                t.len()
            ));
        }
        match &self.accepts {
            Accepts::Likert(points) => match t.parse::<u32>() {
                Ok(v) if (1..=*points).contains(&v) => Ok(v.to_string()),
                _ => Err(format!(
                    "`{}` is not an answer to `{}`: give 1 to {points}",
                    t.escape_debug(),
                    self.column
                )),
            },
            Accepts::Choice(options) => {
                if let Some(o) = options.iter().find(|o| o.eq_ignore_ascii_case(t)) {
                    return Ok(o.clone());
                }
                match t.parse::<usize>() {
                    Ok(i) if (1..=options.len()).contains(&i) => Ok(options[i - 1].clone()),
                    _ => Err(format!(
                        "`{}` is not an answer to `{}`: give one of {} or its number 1 to {}",
                        t.escape_debug(),
                        self.column,
                        options.join(", "),
                        options.len()
                    )),
                }
            }
            Accepts::Number(min, max) => match t.parse::<f64>() {
                Ok(v) if v.is_finite() && *min <= v && v <= *max => Ok(t.to_owned()),
                _ => Err(format!(
                    "`{}` is not an answer to `{}`: give a number from {} to {}",
                    t.escape_debug(),
                    self.column,
                    crate::limits::show(*min),
                    crate::limits::show(*max)
                )),
            },
        }
    }

    /// Whether one key answers it (Likert and choices of at most 9).
    fn single_key(&self) -> bool {
        match &self.accepts {
            Accepts::Likert(p) => *p <= 9,
            Accepts::Choice(o) => o.len() <= 9,
            Accepts::Number(..) => false,
        }
    }
}

/// Longest answer, bytes (a label's longest; numbers are shorter).
pub const MAX_ANSWER_BYTES: usize = super::columns::MAX_LABEL_BYTES;

/// Where answers come from.
pub trait Answers {
    /// The answer to `q` if one is ready (`Ok(None)`: not yet; the caller
    /// keeps the device polled and asks again).
    fn poll(&mut self, q: &Asked) -> anyhow::Result<Option<String>>;
}

/// Answers from a file or stdin, one per line, checked as they are used.
#[derive(Debug, Clone)]
pub struct Lines {
    name: String,
    lines: Vec<String>,
    next: usize,
    /// Line number of the first line (after skipped answers on resume).
    pub first: usize,
}

/// Most bytes of a responses file.
pub const MAX_RESPONSES_BYTES: u64 = 16 << 20;

impl Lines {
    /// From a file (`-`: stdin, read to its end).
    pub fn open(path: &Path) -> anyhow::Result<Self> {
        let (name, text) = if path.as_os_str() == "-" {
            let mut s = String::new();
            std::io::stdin()
                .lock()
                .take(MAX_RESPONSES_BYTES + 1)
                .read_to_string(&mut s)
                .map_err(|e| {
                    InputError::new(format!("--responses -: {}", crate::files::reason(&e)))
                })?;
            if s.len() as u64 > MAX_RESPONSES_BYTES {
                return Err(InputError::new(format!(
                    "--responses -: more than {MAX_RESPONSES_BYTES} bytes, the most a responses file may be"
                ))
                .into());
            }
            ("--responses -".to_owned(), s)
        } else {
            let b = crate::files::read_input("--responses file", path, MAX_RESPONSES_BYTES)?;
            let s = String::from_utf8(b).map_err(|_| {
                InputError::new(format!("--responses {}: not UTF-8 text", path.display()))
            })?;
            (format!("--responses {}", path.display()), s)
        };
        Ok(Self::from_text(name, &text))
    }

    /// From text (`name` in errors).
    pub fn from_text(name: String, text: &str) -> Self {
        Self {
            name,
            lines: text.lines().map(|l| l.trim().to_owned()).collect(),
            next: 0,
            first: 1,
        }
    }

    /// Skips `n` answers (those of trials already on disk); more than the
    /// file holds is the error.
    pub fn skip(&mut self, n: usize) -> Result<(), InputError> {
        match self.next.checked_add(n).filter(|&k| k <= self.lines.len()) {
            Some(k) => {
                self.next = k;
                Ok(())
            }
            None => Err(InputError::new(format!(
                "{} has {} answers, fewer than the {n} the finished trials took",
                self.name,
                self.lines.len()
            ))),
        }
    }

    /// Refuses answers left after the last one used (blank lines at the
    /// end are not answers).
    pub fn check_used_up(&self) -> Result<(), InputError> {
        let rest = &self.lines[self.next.min(self.lines.len())..];
        match rest.iter().position(|l| !l.is_empty()) {
            None => Ok(()),
            Some(i) => Err(InputError::new(format!(
                "{} line {}: `{}` is left over: the session asks for {} answers{}",
                self.name,
                self.next + i + 1,
                rest[i].chars().take(60).collect::<String>().escape_debug(),
                self.next,
                match rest[i + 1..].iter().filter(|l| !l.is_empty()).count() {
                    0 => String::new(),
                    n => format!(" ({n} more follow)"),
                }
            ))),
        }
    }
}

impl Answers for Lines {
    fn poll(&mut self, q: &Asked) -> anyhow::Result<Option<String>> {
        let n = self.next;
        let Some(line) = self.lines.get(n) else {
            return Err(InputError::new(format!(
                "{} ended at line {}: an answer to `{}` is needed",
                self.name,
                n + 1,
                q.column
            ))
            .into());
        };
        self.next += 1;
        q.parse(line)
            .map(Some)
            .map_err(|m| InputError::new(format!("{} line {}: {m}", self.name, n + 1)).into())
    }
}

/// Single keys (Likert, choices) or a line (numbers) at the terminal, in
/// raw mode; the terminal's mode comes back when dropped.
pub struct Terminal {
    keys: Receiver<u8>,
    saved: Option<nix::sys::termios::Termios>,
    line: String,
    asked: Option<String>,
}

impl Terminal {
    /// Takes over stdin (a terminal) in raw mode.
    pub fn open() -> anyhow::Result<Self> {
        use nix::sys::termios::{LocalFlags, SetArg, tcgetattr, tcsetattr};
        let stdin = std::io::stdin();
        let saved = tcgetattr(&stdin).ok();
        if let Some(t) = &saved {
            let mut raw = t.clone();
            raw.local_flags
                .remove(LocalFlags::ICANON | LocalFlags::ECHO);
            let _ = tcsetattr(&stdin, SetArg::TCSANOW, &raw);
        }
        let (tx, rx) = channel();
        std::thread::Builder::new()
            .name("lmhost-keys".into())
            .spawn(move || {
                let mut b = [0u8; 1];
                let mut i = std::io::stdin().lock();
                loop {
                    match i.read(&mut b) {
                        Ok(1) => {
                            if tx.send(b[0]).is_err() {
                                break;
                            }
                        }
                        // A signal landed on this thread: read on.
                        Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                        _ => break,
                    }
                }
            })?;
        Ok(Self {
            keys: rx,
            saved,
            line: String::new(),
            asked: None,
        })
    }
}

impl Drop for Terminal {
    fn drop(&mut self) {
        if let Some(t) = &self.saved {
            let _ = nix::sys::termios::tcsetattr(
                std::io::stdin(),
                nix::sys::termios::SetArg::TCSANOW,
                t,
            );
        }
    }
}

impl Answers for Terminal {
    fn poll(&mut self, q: &Asked) -> anyhow::Result<Option<String>> {
        if self.asked.as_deref() != Some(&q.prompt) {
            // Keys typed before the question are not answers to it; drop
            // them before it is shown, so a key pressed the moment it
            // appears counts.
            while self.keys.try_recv().is_ok() {}
            self.line.clear();
            crate::errln!("{}", q.prompt);
            self.asked = Some(q.prompt.clone());
        }
        loop {
            let k = match self.keys.try_recv() {
                Ok(k) => k,
                Err(TryRecvError::Empty) => return Ok(None),
                Err(TryRecvError::Disconnected) => {
                    return Err(InputError::new(format!(
                        "the terminal closed before `{}` was answered",
                        q.column
                    ))
                    .into());
                }
            };
            if q.single_key() && k.is_ascii_alphanumeric() {
                let s = (k as char).to_string();
                match q.parse(&s) {
                    Ok(v) => {
                        crate::errln!("  -> {v}");
                        self.asked = None;
                        return Ok(Some(v));
                    }
                    Err(m) => crate::errln!("  {m}"),
                }
                continue;
            }
            match k {
                b'\n' | b'\r' => {
                    let l = std::mem::take(&mut self.line);
                    match q.parse(&l) {
                        Ok(v) => {
                            crate::errln!("  -> {v}");
                            self.asked = None;
                            return Ok(Some(v));
                        }
                        Err(m) => crate::errln!("  {m}"),
                    }
                }
                0x7f | 0x08 => {
                    self.line.pop();
                }
                // One byte past the longest answer is enough to refuse it.
                k if (k.is_ascii_graphic() || k == b' ') && self.line.len() <= MAX_ANSWER_BYTES => {
                    self.line.push(k as char);
                }
                _ => {}
            }
        }
    }
}

/// Reads stdin lines lazily (a pipe that is not a terminal, no
/// `--responses`): answers as they arrive. A line longer than
/// [`crate::limits::MAX_LINE_BYTES`] ends the stream with an error, read
/// no further.
pub fn stdin_lines() -> anyhow::Result<Receiver<Result<String, String>>> {
    let (tx, rx) = channel();
    std::thread::Builder::new()
        .name("lmhost-answers".into())
        .spawn(move || {
            let mut stdin = std::io::stdin().lock();
            loop {
                let mut line = Vec::new();
                let max = crate::limits::MAX_LINE_BYTES as u64;
                match (&mut stdin).take(max + 1).read_until(b'\n', &mut line) {
                    Ok(0) | Err(_) => break,
                    Ok(_) => {}
                }
                let ended = line.last() == Some(&b'\n');
                let item = if !ended && line.len() as u64 > max {
                    Err(format!("a line longer than {max} bytes"))
                } else {
                    String::from_utf8(line)
                        .map(|l| l.trim_end_matches(['\n', '\r']).to_owned())
                        .map_err(|_| "a line that is not UTF-8 text".to_owned())
                };
                let stop = item.is_err();
                if tx.send(item).is_err() || stop {
                    break;
                }
            }
        })?;
    Ok(rx)
}

/// Answers as stdin lines arrive.
pub struct Piped {
    rx: Receiver<Result<String, String>>,
    n: usize,
}

impl Piped {
    /// Starts reading stdin.
    pub fn open() -> anyhow::Result<Self> {
        Ok(Self {
            rx: stdin_lines()?,
            n: 0,
        })
    }
}

impl Answers for Piped {
    fn poll(&mut self, q: &Asked) -> anyhow::Result<Option<String>> {
        match self.rx.try_recv() {
            Ok(l) => {
                self.n += 1;
                let n = self.n;
                let bad = |m: String| InputError::new(format!("stdin line {n}: {m}"));
                q.parse(&l.map_err(bad)?)
                    .map(Some)
                    .map_err(|m| bad(m).into())
            }
            Err(TryRecvError::Empty) => Ok(None),
            Err(TryRecvError::Disconnected) => Err(InputError::new(format!(
                "stdin ended: an answer to `{}` is needed",
                q.column
            ))
            .into()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn likert() -> Asked {
        Asked {
            column: "vibration".into(),
            prompt: String::new(),
            accepts: Accepts::Likert(7),
        }
    }

    #[test]
    fn answers_parse_by_kind_and_bad_ones_name_the_line() {
        assert_eq!(likert().parse(" 7 ").unwrap(), "7");
        assert!(likert().parse("8").unwrap_err().contains("1 to 7"));
        assert!(likert().parse("0").is_err());
        assert!(likert().parse("x").is_err());
        let c = Asked {
            column: "shape".into(),
            prompt: String::new(),
            accepts: Accepts::Choice(vec!["convex".into(), "flat".into()]),
        };
        assert_eq!(c.parse("flat").unwrap(), "flat");
        assert_eq!(c.parse("FLAT").unwrap(), "flat");
        assert_eq!(c.parse("1").unwrap(), "convex");
        assert!(c.parse("3").unwrap_err().contains("convex, flat"));
        let n = Asked {
            column: "depth".into(),
            prompt: String::new(),
            accepts: Accepts::Number(0.0, 10.0),
        };
        assert_eq!(n.parse("2.5").unwrap(), "2.5");
        assert!(n.parse("11").is_err());
        assert!(n.parse("nan").is_err());
        // A shuffled choice: numbers index the order shown, labels record.
        let q = Question {
            id: "shape".into(),
            text: String::new(),
            kind: Kind::Choice {
                options: vec!["flat".into(), "convex".into(), "concave".into()],
            },
            shuffle: true,
        };
        let asked = Asked::of(&q, &[2, 0, 1]);
        assert_eq!(asked.len(), 1);
        assert!(
            asked[0]
                .prompt
                .contains("1 = concave, 2 = flat, 3 = convex")
        );
        assert_eq!(asked[0].parse("1").unwrap(), "concave");
        assert_eq!(asked[0].parse("convex").unwrap(), "convex");
        let q = Question {
            id: "shape".into(),
            text: "match?".into(),
            kind: Kind::Likert {
                points: 7,
                low: "no".into(),
                high: "yes".into(),
                items: vec!["flat".into(), "convex".into()],
            },
            shuffle: true,
        };
        let cols: Vec<String> = Asked::of(&q, &[1, 0])
            .into_iter()
            .map(|a| a.column)
            .collect();
        assert_eq!(cols, ["shape_convex", "shape_flat"]);
        let mut l = Lines::from_text("--responses r.txt".into(), "3\n9\n");
        assert_eq!(l.poll(&likert()).unwrap().as_deref(), Some("3"));
        let e = l.poll(&likert()).unwrap_err().to_string();
        assert!(e.starts_with("--responses r.txt line 2: `9`"), "{e}");
        let e = l.poll(&likert()).unwrap_err().to_string();
        assert!(e.contains("ended at line 3"), "{e}");
        // Every answer used: nothing left over; a blank tail is no answer.
        let mut l = Lines::from_text("--responses r.txt".into(), "3\n4\n\n");
        l.skip(1).unwrap();
        let e = l.check_used_up().unwrap_err().to_string();
        assert!(e.contains("line 2: `4` is left over"), "{e}");
        l.poll(&likert()).unwrap();
        l.check_used_up().unwrap();
        assert!(l.skip(2).is_err(), "skipping past the end");
        let long = "7".repeat(MAX_ANSWER_BYTES + 1);
        assert!(likert().parse(&long).unwrap_err().contains("bytes"));
    }
}
