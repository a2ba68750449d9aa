//! What the participant is asked and how answers come in: from a
//! responses file (one answer per line, in the order asked), from stdin
//! lines, or from single keys at the terminal.

use std::io::Read as _;
use std::path::Path;
use std::sync::mpsc::{Receiver, TryRecvError, channel};

use super::protocol::{Kind, Question};
use crate::error::InputError;
pub use crate::lab::study::columns::NOT_PERCEIVED;

mod stdin;
pub use stdin::stdin_lines;

/// One thing asked: a question, a Likert item or an adjustment.
#[derive(Debug, Clone, PartialEq)]
pub struct Asked {
    /// The `trials.csv` column (the adjustment's: `adjust`).
    pub column: String,
    /// The prompt.
    pub prompt: String,
    /// What is accepted.
    pub accepts: Accepts,
    /// The label of the "not perceived" answer, typed as
    /// [`NOT_PERCEIVED`], when the question allows it.
    pub not_perceived: Option<String>,
    /// Set when the question asks whether a stimulus at this level (in
    /// the procedure's unit) was perceived: the first choice means yes,
    /// the second no (what a simulated observer answers from).
    pub perceived_at: Option<f64>,
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
        let mut v = Self::of_kind(q, order);
        if let Some(label) = &q.not_perceived {
            for a in &mut v {
                a.prompt = format!("{} [{NOT_PERCEIVED} = {label}]", a.prompt);
                a.not_perceived = Some(label.clone());
            }
        }
        v
    }

    fn of_kind(q: &Question, order: &[usize]) -> Vec<Asked> {
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
                        not_perceived: None,
                        perceived_at: None,
                    }];
                }
                order
                    .iter()
                    .map(|&i| Asked {
                        column: format!("{}_{}", q.id, items[i]),
                        prompt: format!("{text} ({}) [{scale}]", items[i]),
                        accepts: Accepts::Likert(*points),
                        not_perceived: None,
                        perceived_at: None,
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
                    not_perceived: None,
                    perceived_at: None,
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
                not_perceived: None,
                perceived_at: None,
            }],
        }
    }

    /// Checks `text` and returns the value recorded: a Likert point, a
    /// choice's label, a number as given, [`NOT_PERCEIVED`] where allowed.
    pub fn parse(&self, text: &str) -> Result<String, String> {
        let t = text.trim();
        if t.len() > MAX_ANSWER_BYTES {
            return Err(format!(
                "an answer to `{}` of {} bytes: at most {MAX_ANSWER_BYTES}",
                self.column,
                t.len()
            ));
        }
        if self.not_perceived.is_some() && t.eq_ignore_ascii_case(NOT_PERCEIVED) {
            return Ok(NOT_PERCEIVED.to_owned());
        }
        self.parse_kind(t).map_err(|m| match &self.not_perceived {
            Some(l) => format!("{m}, or {NOT_PERCEIVED} ({l})"),
            None => m,
        })
    }

    fn parse_kind(&self, t: &str) -> Result<String, String> {
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
                    "`{}` is not an answer to `{}`: give a number from {} to {}{}",
                    t.escape_debug(),
                    self.column,
                    crate::limits::show(*min),
                    crate::limits::show(*max),
                    crate::files::text::number_hint(t)
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
    /// From a file, read whole (and dry-run before the device opens);
    /// `--responses -` is not a file but answers as asked ([`Piped`]).
    pub fn open(path: &Path) -> anyhow::Result<Self> {
        crate::files::not_a_pipe("--responses file", "--responses", path)?;
        let text =
            crate::limits::read_text_file_up_to("--responses file", path, MAX_RESPONSES_BYTES)?;
        Ok(Self::from_text(
            format!("--responses {}", path.display()),
            &text,
        ))
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

    /// `text` as an answer to `q`, echoed; or why not, on stderr.
    fn take(&mut self, q: &Asked, text: &str) -> Option<String> {
        match q.parse(text) {
            Ok(v) => {
                crate::errln!("  -> {v}");
                self.asked = None;
                Some(v)
            }
            Err(m) => {
                crate::errln!("  {m}");
                None
            }
        }
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
            // Digits answer at once; letters build a word, and `na`
            // answers as soon as it is whole where the question allows it.
            if q.single_key() && k.is_ascii_alphabetic() && q.not_perceived.is_some() {
                self.line.push(k as char);
                if self.line.eq_ignore_ascii_case(NOT_PERCEIVED) {
                    self.line.clear();
                    crate::errln!("  -> {NOT_PERCEIVED}");
                    self.asked = None;
                    return Ok(Some(NOT_PERCEIVED.to_owned()));
                }
                if !NOT_PERCEIVED.starts_with(&self.line.to_ascii_lowercase()) {
                    crate::errln!("  `{}` is not an answer", self.line);
                    self.line.clear();
                }
                continue;
            }
            if q.single_key() && k.is_ascii_alphanumeric() {
                self.line.clear();
                let s = (k as char).to_string();
                if let Some(v) = self.take(q, &s) {
                    return Ok(Some(v));
                }
                continue;
            }
            match k {
                b'\n' | b'\r' => {
                    let l = std::mem::take(&mut self.line);
                    if let Some(v) = self.take(q, &l) {
                        return Ok(Some(v));
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

/// Answers as stdin lines arrive (no `--responses`, or `--responses -`):
/// one line per question as it is asked, so a button box or a GUI can
/// answer while trials run. Each question is printed to stderr when it is
/// first asked (without the stimulus, as the participant sees it).
pub struct Piped {
    rx: Receiver<Result<String, String>>,
    n: usize,
    name: &'static str,
    asked: Option<String>,
}

impl Piped {
    /// Starts reading stdin.
    pub fn open() -> anyhow::Result<Self> {
        Self::named("stdin")
    }

    /// Starts reading stdin, called `name` in errors (`--responses -`).
    pub fn named(name: &'static str) -> anyhow::Result<Self> {
        Ok(Self::from_lines(stdin_lines()?, name))
    }

    /// Answers from `rx`'s lines (what [`stdin_lines`] sends).
    pub fn from_lines(rx: Receiver<Result<String, String>>, name: &'static str) -> Self {
        Self {
            rx,
            n: 0,
            name,
            asked: None,
        }
    }
}

impl Answers for Piped {
    fn poll(&mut self, q: &Asked) -> anyhow::Result<Option<String>> {
        if self.asked.as_deref() != Some(&q.prompt) {
            crate::errln!("{}", q.prompt);
            self.asked = Some(q.prompt.clone());
        }
        match self.rx.try_recv() {
            Ok(l) => {
                self.n += 1;
                self.asked = None;
                let (n, name) = (self.n, self.name);
                let bad = |m: String| InputError::new(format!("{name} line {n}: {m}"));
                q.parse(&l.map_err(bad)?)
                    .map(Some)
                    .map_err(|m| bad(m).into())
            }
            Err(TryRecvError::Empty) => Ok(None),
            Err(TryRecvError::Disconnected) => Err(InputError::new(format!(
                "{} ended: an answer to `{}` is needed",
                self.name, q.column
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
            not_perceived: None,
            perceived_at: None,
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
            not_perceived: None,
            perceived_at: None,
        };
        assert_eq!(c.parse("flat").unwrap(), "flat");
        assert_eq!(c.parse("FLAT").unwrap(), "flat");
        assert_eq!(c.parse("1").unwrap(), "convex");
        assert!(c.parse("3").unwrap_err().contains("convex, flat"));
        let n = Asked {
            column: "depth".into(),
            prompt: String::new(),
            accepts: Accepts::Number(0.0, 10.0),
            not_perceived: None,
            perceived_at: None,
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
            not_perceived: None,
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
            not_perceived: None,
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

    #[test]
    fn not_perceived_is_its_own_answer_where_a_question_allows_it() {
        let q = Question {
            id: "vibration".into(),
            text: "Q1".into(),
            kind: Kind::Likert {
                points: 7,
                low: String::new(),
                high: String::new(),
                items: Vec::new(),
            },
            shuffle: false,
            not_perceived: Some("could not perceive".into()),
        };
        let a = &Asked::of(&q, &[])[0];
        assert!(
            a.prompt.ends_with("[na = could not perceive]"),
            "{}",
            a.prompt
        );
        assert_eq!(a.parse("na").unwrap(), NOT_PERCEIVED);
        assert_eq!(a.parse(" NA ").unwrap(), NOT_PERCEIVED);
        assert_eq!(a.parse("4").unwrap(), "4");
        let e = a.parse("8").unwrap_err();
        assert!(e.contains("1 to 7, or na (could not perceive)"), "{e}");
        // Where it is not allowed, `na` is no answer.
        assert!(likert().parse("na").is_err());
        let mut l = Lines::from_text("--responses r.txt".into(), "na\n");
        assert_eq!(l.poll(a).unwrap().as_deref(), Some("na"));
    }

    #[test]
    fn piped_answers_come_one_line_at_a_time_as_asked() {
        let (tx, rx) = channel();
        let mut p = Piped::from_lines(rx, "--responses -");
        // Nothing yet: the caller keeps the device served and asks again.
        assert_eq!(p.poll(&likert()).unwrap(), None);
        tx.send(Ok("5".into())).unwrap();
        assert_eq!(p.poll(&likert()).unwrap().as_deref(), Some("5"));
        assert_eq!(p.poll(&likert()).unwrap(), None);
        tx.send(Ok("9".into())).unwrap();
        let e = p.poll(&likert()).unwrap_err().to_string();
        assert!(e.starts_with("--responses - line 2: `9`"), "{e}");
        drop(tx);
        let e = p.poll(&likert()).unwrap_err().to_string();
        assert!(e.contains("--responses - ended"), "{e}");
    }
}
