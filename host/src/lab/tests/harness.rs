//! The readers' fuzz run: each case in `catch_unwind`, its verdict checked
//! (a refusal is one line, an acceptance keeps the reader's invariants),
//! its allocations watched, every distinct failure kept with the input
//! that made it.

use std::cell::{Cell, RefCell};
use std::panic::{AssertUnwindSafe, catch_unwind};

use super::mutate;
use crate::rng::SplitMix64;

/// What a reader made of an input.
pub enum Verdict {
    /// Read; its value kept the invariants the reader documents.
    Accepted,
    /// Refused, with this message.
    Refused(String),
}

/// A reader's verdict, or the invariant its accepted value broke.
pub type Outcome = Result<Verdict, String>;

/// A reader as the run calls it: the input's bytes in, its outcome out.
pub type Read = Box<dyn Fn(&[u8]) -> Outcome>;

/// One reader of user input, its valid seeds and its run's full size.
pub struct Reader {
    /// Its name in the report (and in `LM_HOST_FUZZ_ONLY`).
    pub name: &'static str,
    /// Valid inputs, each accepted.
    pub seeds: Vec<Vec<u8>>,
    /// Mutants at full size (`LM_LONG_SCALE` 1).
    pub cases: usize,
    /// The reader.
    pub read: Read,
}

/// Longest refusal as shown (characters, after [`crate::out::tidy`]): a
/// line a reader can take in (a session's reply line is held to 600 bytes
/// by the hostile suite), long enough
/// for a path, a value cut to [`crate::error::MAX_ECHO_CHARS`] and serde's
/// list of the keys a file may have (a plan report's 19 take ~250).
pub const MAX_SHOWN_CHARS: usize = 600;

/// Largest single allocation a case may make (bytes): far above what any
/// mutant (at most [`mutate::MAX_MUTANT`] bytes) needs, far below what a
/// size read from the input could ask for.
const MAX_ALLOC: usize = 64 << 20;

thread_local! {
    static ALLOC_LIMIT: Cell<usize> = const { Cell::new(usize::MAX) };
    static ALLOC_OVER: Cell<usize> = const { Cell::new(0) };
    static QUIET: Cell<bool> = const { Cell::new(false) };
    static PANIC: RefCell<Option<String>> = const { RefCell::new(None) };
}

/// The system allocator, noting on this thread any single request above
/// the limit a fuzz case sets.
pub struct Watch;

fn note(size: usize) {
    let _ = ALLOC_LIMIT.try_with(|l| {
        if size > l.get() {
            let _ = ALLOC_OVER.try_with(|o| o.set(o.get().max(size)));
        }
    });
}

// SAFETY: every call is passed on to `System` unchanged.
unsafe impl std::alloc::GlobalAlloc for Watch {
    unsafe fn alloc(&self, layout: std::alloc::Layout) -> *mut u8 {
        note(layout.size());
        // SAFETY: the caller's layout, as `GlobalAlloc::alloc` was given it.
        unsafe { std::alloc::System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: std::alloc::Layout) -> *mut u8 {
        note(layout.size());
        // SAFETY: the caller's layout, as given.
        unsafe { std::alloc::System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: std::alloc::Layout, new: usize) -> *mut u8 {
        note(new);
        // SAFETY: `ptr` came from `System` through this allocator with `layout`.
        unsafe { std::alloc::System.realloc(ptr, layout, new) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: std::alloc::Layout) {
        // SAFETY: `ptr` came from `System` through this allocator with `layout`.
        unsafe { std::alloc::System.dealloc(ptr, layout) }
    }
}

/// A panic in a case is recorded, not printed; any other thread's panic
/// goes to the hook that was there.
fn quiet_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let before = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if QUIET.with(Cell::get) {
                let msg = info
                    .payload()
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| info.payload().downcast_ref::<String>().cloned())
                    .unwrap_or_default();
                let at = info
                    .location()
                    .map(|l| format!("{}:{}", l.file(), l.line()))
                    .unwrap_or_default();
                PANIC.with(|p| *p.borrow_mut() = Some(format!("panic at {at}: {msg}")));
            } else {
                before(info);
            }
        }));
    });
}

/// Why a refusal's message is not one readable line, if it is not: as
/// the library makes it, one line, not empty; as a person sees it
/// ([`crate::out::tidy`], what stderr and Python's exceptions show), no
/// number of 20 digits it did not take from the input (the hostile
/// suite's rule) and at most
/// [`MAX_SHOWN_CHARS`] characters.
pub fn bad_message(msg: &str, input: &[u8]) -> Option<String> {
    if msg.trim().is_empty() {
        return Some("empty refusal".into());
    }
    if msg.contains(['\n', '\r']) {
        return Some("refusal of more than one line".into());
    }
    let shown = crate::out::tidy(msg);
    // Digits the input holds as they are are its own, echoed.
    let made = shown
        .split(|c: char| !c.is_ascii_digit())
        .find(|run| run.len() >= 20 && !input.windows(run.len()).any(|w| w == run.as_bytes()));
    if let Some(run) = made {
        return Some(format!("a number of {} digits shown", run.len()));
    }
    let n = shown.chars().count();
    (n > MAX_SHOWN_CHARS)
        .then(|| format!("refusal of {n} characters shown (over {MAX_SHOWN_CHARS})"))
}

/// One input through `read`: the failure, if any (a panic, a bad
/// refusal, a broken invariant, an allocation over the limit).
fn one_case(read: &dyn Fn(&[u8]) -> Outcome, input: &[u8]) -> (Option<String>, bool) {
    quiet_panics();
    QUIET.with(|q| q.set(true));
    ALLOC_OVER.with(|o| o.set(0));
    ALLOC_LIMIT.with(|l| l.set(MAX_ALLOC));
    let got = catch_unwind(AssertUnwindSafe(|| read(input)));
    ALLOC_LIMIT.with(|l| l.set(usize::MAX));
    QUIET.with(|q| q.set(false));
    let over = ALLOC_OVER.with(Cell::get);
    let panic = PANIC.with(|p| p.borrow_mut().take());
    let accepted = matches!(got, Ok(Ok(Verdict::Accepted)));
    let failure = match got {
        Err(_) => Some(panic.unwrap_or_else(|| "panic".into())),
        Ok(Err(broken)) => Some(format!("accepted, but {broken}")),
        Ok(Ok(Verdict::Refused(m))) => bad_message(&m, input).map(|why| format!("{why}: {m}")),
        Ok(Ok(Verdict::Accepted)) => None,
    };
    let failure = failure.or_else(|| {
        (over > 0).then(|| format!("one allocation of {over} bytes (over {MAX_ALLOC})"))
    });
    let accepted = accepted && failure.is_none();
    (failure, accepted)
}

/// A failure's class: its text with the numbers and the quoted parts
/// taken out, so one defect is reported once however many inputs hit it.
fn class(failure: &str) -> String {
    let mut out = String::new();
    let mut quoted = false;
    for c in failure.chars() {
        match c {
            '`' => quoted = !quoted,
            c if quoted || c.is_ascii_digit() => {}
            c => out.push(c),
        }
        if out.len() >= 90 {
            break;
        }
    }
    out
}

/// One distinct failure and how often its class came up.
pub struct Failure {
    /// The reader.
    pub reader: &'static str,
    /// The case (`LM_HOST_FUZZ_CASE` replays it).
    pub case: u64,
    /// What went wrong.
    pub what: String,
    /// The input.
    pub input: Vec<u8>,
    /// Cases of the same class.
    pub count: usize,
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let text = String::from_utf8_lossy(&self.input);
        let shown: String = text.chars().take(1500).collect();
        write!(
            f,
            "{} case {} ({} like it): {}\n  input ({} bytes): \"{}\"{}",
            self.reader,
            self.case,
            self.count,
            self.what.chars().take(1000).collect::<String>(),
            self.input.len(),
            shown.escape_debug(),
            if shown.len() < text.len() { " …" } else { "" }
        )
    }
}

/// What one reader's run did.
#[derive(Default)]
pub struct Tally {
    /// Inputs read.
    pub cases: u64,
    /// Of which accepted.
    pub accepted: u64,
}

/// The case's own generator: `seed`, the reader and the case number, so
/// one case replays alone.
fn case_rng(seed: u64, reader: &str, case: u64) -> SplitMix64 {
    let h = reader.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    });
    let mut r = SplitMix64::new(seed ^ h ^ case.wrapping_mul(0x9e37_79b9_7f4a_7c15));
    r.next_u64();
    r
}

/// Runs `reader`: every seed (each must be accepted), a truncation sweep
/// of each seed (every `stride`-th boundary), then `mutants` mutants;
/// `only_case` runs that case alone. Failures go into `failures`, one per
/// class.
pub fn run(
    reader: &Reader,
    seed: u64,
    mutants: u64,
    stride: usize,
    only_case: Option<u64>,
    failures: &mut Vec<Failure>,
) -> Tally {
    let mut tally = Tally::default();
    let mut record = |case: u64, input: &[u8], tally: &mut Tally| {
        let (failure, accepted) = one_case(&*reader.read, input);
        tally.cases += 1;
        tally.accepted += u64::from(accepted);
        let Some(what) = failure else { return };
        let k = class(&what);
        match failures
            .iter_mut()
            .find(|f| f.reader == reader.name && class(&f.what) == k)
        {
            Some(f) => f.count += 1,
            None => failures.push(Failure {
                reader: reader.name,
                case,
                what,
                input: input.to_vec(),
                count: 1,
            }),
        }
    };
    if let Some(c) = only_case {
        let input = mutate::mutant(&mut case_rng(seed, reader.name, c), &reader.seeds);
        record(c, &input, &mut tally);
        return tally;
    }
    for (i, s) in reader.seeds.iter().enumerate() {
        let why = match (reader.read)(s) {
            Ok(Verdict::Accepted) => continue,
            Ok(Verdict::Refused(m)) => m,
            Err(broken) => broken,
        };
        panic!("{} seed {i} is not read as valid: {why}", reader.name);
    }
    for s in &reader.seeds {
        for cut in mutate::boundaries(s).into_iter().step_by(stride.max(1)) {
            // Truncations are numbered apart from the mutants.
            record(u64::MAX - cut as u64, &s[..cut], &mut tally);
        }
    }
    for c in 0..mutants {
        let input = mutate::mutant(&mut case_rng(seed, reader.name, c), &reader.seeds);
        record(c, &input, &mut tally);
    }
    tally
}

/// The run's own checks: each kind of failure is caught and reported with
/// its input, a good reader passes.
#[test]
fn the_run_catches_a_panic_a_bad_refusal_a_broken_invariant_and_a_huge_allocation() {
    let read: Read = Box::new(|b: &[u8]| match b.first() {
        Some(b'p') => panic!("index out of bounds"),
        Some(b'l') => Ok(Verdict::Refused("line 1\nline 2".into())),
        // A number the tidying of numbers does not see (after a brace),
        // not in the input.
        Some(b'n') => Ok(Verdict::Refused("got {12345678901234567890123}".into())),
        Some(b'w') => Ok(Verdict::Refused("w ".repeat(400))),
        Some(b'i') => Err("a NaN accepted".into()),
        Some(b'a') => {
            let v: Vec<u8> = Vec::with_capacity(MAX_ALLOC + 1);
            Ok(Verdict::Refused(format!("reserved {}", v.capacity())))
        }
        Some(_) => Ok(Verdict::Refused("a short refusal".into())),
        None => Ok(Verdict::Accepted),
    });
    let failure = |input: &[u8]| one_case(&read, input).0.unwrap_or_default();
    assert!(failure(b"p").starts_with("panic at "), "{}", failure(b"p"));
    assert!(failure(b"p").ends_with("index out of bounds"));
    assert!(failure(b"l").starts_with("refusal of more than one line"));
    assert!(
        failure(b"n").starts_with("a number of "),
        "{}",
        failure(b"n")
    );
    // The input's own digits, echoed, are its own.
    assert_eq!(
        bad_message(
            "got {12345678901234567890123}",
            b"n{12345678901234567890123}"
        ),
        None
    );
    assert!(failure(b"w").starts_with("refusal of 800 characters"));
    assert_eq!(failure(b"i"), "accepted, but a NaN accepted");
    assert!(
        failure(b"a").starts_with("one allocation of "),
        "{}",
        failure(b"a")
    );
    assert_eq!(one_case(&read, b"x"), (None, false));
    assert_eq!(one_case(&read, b""), (None, true));
    // A run reports each class once, with the input that showed it.
    let r = Reader {
        name: "test",
        seeds: vec![Vec::new()],
        cases: 0,
        read,
    };
    let mut failures = Vec::new();
    let t = run(&r, 1, 200, 1, None, &mut failures);
    assert_eq!(t.cases, 200);
    assert!(failures.iter().all(|f| f.count >= 1 && !f.input.is_empty()));
    let panics: Vec<&Failure> = failures
        .iter()
        .filter(|f| f.what.starts_with("panic"))
        .collect();
    assert!(panics.len() <= 1);
}

/// A refusal, as the reader worded it.
pub fn refused(e: impl std::fmt::Display) -> Outcome {
    Ok(Verdict::Refused(e.to_string()))
}

/// `Ok` when every value of `v` is finite, else what is not.
pub fn finite(what: &str, v: &[f64]) -> Result<(), String> {
    match v.iter().all(|x| x.is_finite()) {
        true => Ok(()),
        false => Err(format!("{what} {v:?} is not finite")),
    }
}
