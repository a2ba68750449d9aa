//! Files lmhost reads and writes.
//!
//! - **Inputs** ([`open_input`], [`read_input`]): a path is checked by its
//!   metadata before it is opened, so a FIFO, a directory, a device node, a
//!   socket or a missing file is a one-line [`InputError`] at once (never an
//!   `open` that blocks); standard input stays the way to stream. Every
//!   input's identity (device and inode) is remembered.
//! - **Outputs** ([`Output`], [`write_whole`]): the destination is looked
//!   at first (`dest`). A regular file (or a new name) gets a temporary
//!   file beside it, synced and renamed over it on [`Output::commit`], so a
//!   file lmhost writes is whole or absent after a full disk, an error,
//!   Ctrl-C ([`crate::stop`] removes the temporary file) or `kill -9` (a
//!   leftover `.NAME.lmhost-PID.tmp.EXT`, never the named file, removed
//!   by the next write to that name once PID is gone); a failed
//!   overwrite leaves the previous file as it was. A symlink is followed
//!   and its target replaced (the link stays a link); the replaced file
//!   keeps its permission bits and owner; a file with other names (hard
//!   links) is replaced under this name only, and a note says so. A
//!   character device (`/dev/null`) or a FIFO with a reader is written in
//!   place; a FIFO with no reader, a block device, a socket or a directory
//!   is refused.
//! - **Logs** ([`AppendLog`]): lines appended whole to a file written in
//!   place, opened without blocking (a FIFO with no reader is refused).
//! - **Text** ([`text`]): every text input, a whole file or a line
//!   stream, read one way whatever wrote it (a byte-order mark, CRLF or
//!   CR line ends; UTF-16 and a foreign CSV refused saying what they are);
//!   every line stream (centroids, a UDP datagram's, session commands,
//!   study answers) split by one [`lines::LineReader`]: LF, CRLF and a
//!   lone CR end a line, an over-long one is refused at its limit.
//! - **Output = input**: an output that is one of this process's inputs
//!   (the same file, also through a link or another name) is refused
//!   before anything is written, as is an output given twice
//!   ([`distinct_outputs`]).

mod dest;
pub mod kind;
pub mod lines;
mod log;
mod output;
pub mod text;

pub use log::{AppendLog, PendingLog};
pub use output::{Output, replace_input, write_whole};

use std::fs::{File, Metadata};
use std::os::unix::fs::{FileTypeExt as _, MetadataExt as _, OpenOptionsExt as _};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::error::InputError;

/// What went wrong with an I/O call, in words (no `os error N`).
pub fn reason(e: &std::io::Error) -> String {
    use std::io::ErrorKind as K;
    match e.kind() {
        K::NotFound => "no such file or directory".into(),
        K::PermissionDenied => "permission denied".into(),
        K::IsADirectory => "it is a directory".into(),
        K::NotADirectory => "a part of the path is not a directory".into(),
        K::StorageFull => "no space left on device".into(),
        K::QuotaExceeded => "disk quota exceeded".into(),
        K::ReadOnlyFilesystem => "read-only file system".into(),
        K::AlreadyExists => "it already exists".into(),
        K::WriteZero => "the device accepted no more bytes".into(),
        K::ConnectionRefused => "connection refused".into(),
        K::TimedOut => "timed out".into(),
        K::AddrInUse => "address in use by another process".into(),
        _ => {
            let s = e.to_string();
            match s.find(" (os error") {
                Some(i) => s[..i].to_owned(),
                None => s,
            }
        }
    }
}

/// [`reason`] for an error from a library that wraps an I/O error (an
/// image encoder, say): the first `io::Error` in its source chain, else an
/// `os error N` in its text, else its text.
pub fn reason_of(e: &(dyn std::error::Error + 'static)) -> String {
    let mut cur = Some(e);
    while let Some(c) = cur {
        if let Some(io) = c.downcast_ref::<std::io::Error>() {
            return reason(io);
        }
        cur = c.source();
    }
    let text = e.to_string();
    let code = text
        .split("(os error ")
        .nth(1)
        .and_then(|t| t.split(')').next())
        .and_then(|n| n.parse::<i32>().ok());
    match code {
        Some(n) => reason(&std::io::Error::from_raw_os_error(n)),
        None => text,
    }
}

/// Identity of a file: (device, inode).
type Id = (u64, u64);

/// Inputs opened by this process (identity and the path given).
static INPUTS: Mutex<Vec<(Id, PathBuf)>> = Mutex::new(Vec::new());

fn id(m: &Metadata) -> Id {
    (m.dev(), m.ino())
}

/// What kind of non-regular file `m` is, in words (`None`: a regular
/// file).
fn kind(m: &Metadata) -> Option<String> {
    let t = m.file_type();
    Some(match what_is(t) {
        _ if t.is_file() => return None,
        _ if t.is_dir() => "it is a directory".into(),
        other => format!("it is {other}, not a regular file"),
    })
}

/// What a path is, in words: `a regular file`, `a directory`, `a FIFO
/// (named pipe)`, `a device node`, `a socket` or `something else`.
fn what_is(t: std::fs::FileType) -> &'static str {
    if t.is_file() {
        "a regular file"
    } else if t.is_dir() {
        "a directory"
    } else if t.is_fifo() {
        "a FIFO (named pipe)"
    } else if t.is_char_device() || t.is_block_device() {
        "a device node"
    } else if t.is_socket() {
        "a socket"
    } else {
        "something else"
    }
}

/// For a flag that takes `-` for standard input (`flag`, e.g. `--input`):
/// a FIFO at `path` refused saying so, and that `flag -` reads a pipe. A
/// flag that takes no `-` (`--scene`) gets no such advice: "pipe into
/// standard input instead" was said of every input, `--scene` too, which
/// reads no standard input.
pub fn not_a_pipe(what: &str, flag: &str, path: &Path) -> Result<(), InputError> {
    match std::fs::metadata(path) {
        Ok(m) if m.file_type().is_fifo() => Err(InputError::new(format!(
            "cannot read {what} {}: it is {}, not a regular file; give `{flag} -` and pipe into standard input instead",
            path.display(),
            what_is(m.file_type())
        ))),
        _ => Ok(()),
    }
}

/// Checks that `path` is an existing regular file (`what` names it in
/// errors, e.g. "--scene file") without opening it.
pub fn check_input(what: &str, path: &Path) -> Result<Metadata, InputError> {
    let cannot =
        |why: &str| InputError::new(format!("cannot read {what} {}: {why}", path.display()));
    let m = std::fs::metadata(path).map_err(|e| match e.kind() {
        // No file has that name: shown cut, however long it was given.
        std::io::ErrorKind::InvalidFilename => InputError::new(format!(
            "cannot read {what} {}: {}",
            too_long(path),
            reason(&e)
        )),
        _ => cannot(&reason(&e)),
    })?;
    if let Some(k) = kind(&m) {
        return Err(cannot(&k));
    }
    Ok(m)
}

/// A path the file system refused as too long, for a message: whole up to
/// [`crate::error::MAX_ECHO_CHARS`] characters, else cut around its
/// length (a pasted or generated name of thousands of characters with
/// spaces in it, which no cut of long words on stderr catches).
fn too_long(path: &Path) -> String {
    let shown = path.display().to_string();
    let n = shown.chars().count();
    if n <= crate::error::MAX_ECHO_CHARS {
        return shown;
    }
    let head: String = shown.chars().take(60).collect();
    let tail: String = shown.chars().skip(n - 20).collect();
    format!("{head}…({n} characters)…{tail}")
}

/// Opens the regular file `path` for reading (checked first, see
/// [`check_input`]) and remembers it as an input.
pub fn open_input(what: &str, path: &Path) -> Result<File, InputError> {
    let (f, m) = open_regular(what, path)?;
    // Once per file, however often it is read (a session reloading its
    // library): the list stays as long as the distinct inputs. The name
    // is the latest one read, for an identity seen before may have been a
    // deleted input's, given to this file.
    let mut inputs = INPUTS.lock().unwrap_or_else(|e| e.into_inner());
    match inputs.iter_mut().find(|(i, _)| *i == id(&m)) {
        Some(known) => known.1 = path.to_owned(),
        None => inputs.push((id(&m), path.to_owned())),
    }
    Ok(f)
}

/// Opens the regular file `path` for reading, not remembered as an input:
/// a file this command wrote and will go on writing (a study's
/// `trials.csv`, `session.json`, `events.jsonl` on `--resume`), which
/// [`open_input`] would then refuse as an output that is an input.
pub fn open_own(what: &str, path: &Path) -> Result<File, InputError> {
    open_regular(what, path).map(|(f, _)| f)
}

/// `path` checked a regular file by its metadata ([`check_input`]: a FIFO,
/// a device node, a directory refused at once) and opened, checked again.
fn open_regular(what: &str, path: &Path) -> Result<(File, Metadata), InputError> {
    let cannot =
        |why: &str| InputError::new(format!("cannot read {what} {}: {why}", path.display()));
    check_input(what, path)?;
    // O_NONBLOCK: should the path turn into a FIFO between the check and
    // the open, the open still returns at once (regular files ignore it).
    let f = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)
        .map_err(|e| cannot(&reason(&e)))?;
    let m = f.metadata().map_err(|e| cannot(&reason(&e)))?;
    if let Some(k) = kind(&m) {
        return Err(cannot(&k));
    }
    Ok((f, m))
}

/// Reads the whole input file `path`, refusing one longer than `max`
/// bytes before reading it.
pub fn read_input(what: &str, path: &Path, max: u64) -> Result<Vec<u8>, InputError> {
    use std::io::Read as _;
    let f = open_input(what, path)?;
    let mut bytes = Vec::new();
    f.take(max + 1).read_to_end(&mut bytes).map_err(|e| {
        InputError::new(format!(
            "cannot read {what} {}: {}",
            path.display(),
            reason(&e)
        ))
    })?;
    if bytes.len() as u64 > max {
        return Err(InputError::new(format!(
            "{what} {} is larger than {max} bytes, the most a {what} may be",
            path.display()
        )));
    }
    Ok(bytes)
}

/// The input `path` is, if it exists and was opened as one. Inputs are
/// regular files, so anything else at `path` (a fresh output folder that
/// the file system gave a deleted input's identity) is not one; nor is a
/// file whose identity an input had but no longer has under its name (the
/// input was deleted or replaced, and the file system gave its identity
/// to a new file).
fn input_named_by(path: &Path) -> Option<PathBuf> {
    let m = std::fs::metadata(path).ok().filter(Metadata::is_file)?;
    let inputs = INPUTS.lock().unwrap_or_else(|e| e.into_inner());
    inputs
        .iter()
        .find(|(i, p)| *i == id(&m) && std::fs::metadata(p).is_ok_and(|n| id(&n) == *i))
        .map(|(_, p)| p.clone())
}

/// `rel`, a path a file's field gives (`field` names it), in that file's
/// folder `dir`. An empty one (or one of spaces) is refused naming the
/// field: joined, it named the folder itself, refused as "a directory"
/// without a word of the field.
pub fn in_folder(dir: &Path, field: &str, rel: &Path) -> Result<PathBuf, String> {
    if rel.to_string_lossy().trim().is_empty() {
        return Err(format!("`{field}` is empty: give a file"));
    }
    Ok(dir.join(rel))
}

/// Refuses to write `path` when it is one of this process's inputs, or
/// when it is `-`: standard output for a person who types it (as `-` is
/// standard input for `--stream -`), which an output file is not; it made
/// a file named `-` in the working directory.
pub fn not_an_input(flag: &str, path: &Path) -> Result<(), InputError> {
    if path.as_os_str() == "-" {
        return Err(InputError::new(format!(
            "{flag} -: this output is a file, not standard output; give its path (./- for a file named -)"
        )));
    }
    match input_named_by(path) {
        Some(input) => Err(InputError::new(format!(
            "{flag} {} is the input {}: refusing to overwrite it; choose another output path",
            path.display(),
            input.display()
        ))),
        None => Ok(()),
    }
}

/// Refuses output `path` of `flag` when files are written beside it under
/// its name (a recording's `REC.timestamps.npy` and
/// `REC.intrinsics.toml`) and it is not a regular file or a free name:
/// `--record /dev/null` wrote `/dev/null.timestamps.npy` into `/dev`.
pub fn with_files_beside(flag: &str, path: &Path) -> Result<(), InputError> {
    let Ok(m) = std::fs::metadata(path) else {
        return Ok(());
    };
    let t = m.file_type();
    // A directory fails as any output's does (exit 1), before anything
    // is written beside it.
    if t.is_file() || t.is_dir() {
        return Ok(());
    }
    Err(InputError::new(format!(
        "{flag} {}: it is {}, and files are written beside it under its name: give a file path",
        path.display(),
        what_is(t)
    )))
}

/// Refuses outputs that are the same file as each other (by name after
/// resolving the directory, or by identity when they exist) or as an
/// input: `outputs` are (flag, path) pairs, a folder a run writes into
/// among them, checked before anything is written.
pub fn distinct_outputs<P: AsRef<Path>>(outputs: &[(&str, P)]) -> Result<(), InputError> {
    // By the name written: a symlink's target.
    let key = |p: &Path| -> PathBuf {
        let p = dest::follow(p).unwrap_or_else(|_| p.to_owned());
        let dir = p
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let dir = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_owned());
        dir.join(p.file_name().unwrap_or_default())
    };
    for (i, (flag, p)) in outputs.iter().enumerate() {
        let p = p.as_ref();
        not_an_input(flag, p)?;
        for (flag2, q) in &outputs[..i] {
            let q = q.as_ref();
            let same_id = match (std::fs::metadata(p), std::fs::metadata(q)) {
                (Ok(a), Ok(b)) => id(&a) == id(&b),
                _ => false,
            };
            if same_id || key(p) == key(q) {
                return Err(InputError::new(format!(
                    "{flag} {} and {flag2} {} are the same path; give each output its own",
                    p.display(),
                    q.display()
                )));
            }
        }
    }
    Ok(())
}

/// Makes the output directory `dir` (and its parents) that `flag` names,
/// refusing (exit 2) one that is an input; a failure names it (exit 1).
/// Hold what it returns while the directory is written: the directories
/// it made that are still empty when it drops (a run refused, failed or
/// stopped after making them, or one that wrote nothing) are removed.
pub fn output_dir(flag: &str, dir: &Path) -> anyhow::Result<MadeDirs> {
    not_an_input(flag, dir)?;
    // The ones to make, deepest first.
    let made: Vec<PathBuf> = dir
        .ancestors()
        .filter(|p| !p.as_os_str().is_empty())
        .take_while(|p| std::fs::symlink_metadata(p).is_err())
        .map(Path::to_path_buf)
        .collect();
    std::fs::create_dir_all(dir).map_err(|e| {
        anyhow::anyhow!(
            "cannot create the {flag} directory {}: {}",
            dir.display(),
            not_a_folder(dir).unwrap_or_else(|| reason_at(dir, &e))
        )
    })?;
    // A signal that ends the command at once removes them too.
    let guards = made
        .iter()
        .map(|d| crate::stop::TempGuard::register_dir(d))
        .collect();
    Ok(MadeDirs(made, guards))
}

/// What `dir` is, in words, when it exists and is not a folder (nor a
/// link to one): "it already exists" said only that, as though a folder
/// that exists could not be written into.
fn not_a_folder(dir: &Path) -> Option<String> {
    let link = std::fs::symlink_metadata(dir).ok()?;
    let Ok(m) = std::fs::metadata(dir) else {
        return link
            .file_type()
            .is_symlink()
            .then(|| "it is a symbolic link to nothing (its target is missing)".into());
    };
    let t = m.file_type();
    (!t.is_dir()).then(|| format!("it is {}, not a directory", what_is(t)))
}

/// [`reason`] for writing or making `path`, naming the part that is wrong
/// when its folder is missing or is not a folder: "a part of the path is
/// not a directory" and "no such file or directory" named none (which
/// part, or that `path` was a symbolic link whose target's folder is
/// missing).
pub fn reason_at(path: &Path, e: &std::io::Error) -> String {
    use std::io::ErrorKind as K;
    if !matches!(e.kind(), K::NotADirectory | K::NotFound) {
        return reason(e);
    }
    // A symbolic link is written through: its target's folders count.
    let (via, p) = match std::fs::read_link(path) {
        Ok(t) => {
            let t = path.parent().unwrap_or(Path::new("")).join(t);
            (format!("it is a symbolic link to {}, and ", t.display()), t)
        }
        Err(_) => (String::new(), path.to_owned()),
    };
    let mut folders: Vec<&Path> = p
        .ancestors()
        .skip(1)
        .filter(|a| !a.as_os_str().is_empty())
        .collect();
    folders.reverse();
    for a in folders {
        match std::fs::metadata(a) {
            Ok(m) if m.is_dir() => {}
            Ok(m) => {
                return format!(
                    "{via}{} is {}, not a folder",
                    a.display(),
                    what_is(m.file_type())
                );
            }
            Err(_) => return format!("{via}its folder {} does not exist", a.display()),
        }
    }
    reason(e)
}

/// The directories [`output_dir`] made, deepest first: removed when it
/// drops while still empty.
#[derive(Debug)]
#[must_use = "the directories made are removed, when still empty, as this drops"]
pub struct MadeDirs(Vec<PathBuf>, Vec<crate::stop::TempGuard>);

impl Drop for MadeDirs {
    fn drop(&mut self) {
        self.1.clear();
        // `remove_dir` removes an empty directory only: the first that
        // holds something (a file written, a folder kept) ends it.
        for d in &self.0 {
            if std::fs::remove_dir(d).is_err() {
                break;
            }
        }
    }
}

/// A write to `path` failed: exit 1, naming the file and the reason in
/// words, once (the I/O error is kept, not chained as a source, so the
/// one-line message does not say it again in the OS's words).
#[derive(Debug, thiserror::Error)]
#[error("cannot write {}: {why}", .path.display())]
pub struct WriteError {
    path: PathBuf,
    io: std::io::Error,
    /// [`reason_at`], when the error was made (the part of the path that
    /// is wrong, looked at then).
    why: String,
}

impl WriteError {
    /// The error of writing `path`.
    pub fn new(path: &Path, io: std::io::Error) -> Self {
        Self {
            path: path.to_owned(),
            why: reason_at(path, &io),
            io,
        }
    }

    /// The I/O error behind it.
    pub fn io(&self) -> &std::io::Error {
        &self.io
    }
}

/// For tests: a fresh, empty folder `lmhost-<name>-<pid>` in the
/// system's temporary folder (`name` unique within the crate's tests),
/// removed when the guard drops; kept, and its path said on stderr, when
/// the test failed, for a look. Folders of the same name whose process
/// has ended go first ([`sweep_ended`]).
#[cfg(test)]
pub(crate) fn scratch(name: &str) -> Scratch {
    let stem = format!("lmhost-{name}-");
    sweep_ended(&stem);
    let d = std::env::temp_dir().join(format!("{stem}{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    Scratch {
        path: d.clone(),
        dir: d,
    }
}

/// Removes the folders `<stem><pid>` in the temporary folder whose
/// process is no longer running (Linux's `/proc`; elsewhere nothing): a
/// guard that never dropped left them, one held by a `static` (the fuzz
/// harness's seed studies, run once per process) or a test process
/// killed.
#[cfg(test)]
fn sweep_ended(stem: &str) {
    let proc_fs = Path::new("/proc/self");
    let Ok(entries) = std::fs::read_dir(std::env::temp_dir()) else {
        return;
    };
    if !proc_fs.exists() {
        return;
    }
    for e in entries.flatten() {
        let name = e.file_name();
        let pid = name
            .to_str()
            .and_then(|n| n.strip_prefix(stem))
            .filter(|p| !p.is_empty() && p.bytes().all(|b| b.is_ascii_digit()));
        if let Some(pid) = pid
            && !Path::new("/proc").join(pid).exists()
        {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

/// For tests: the path of `file` in a fresh [`scratch`] folder of its
/// own (`<name>-<file>`), the folder removed as [`scratch`]'s is.
#[cfg(test)]
pub(crate) fn scratch_file(name: &str, file: &str) -> Scratch {
    let mut s = scratch(&format!("{name}-{file}"));
    s.path = s.dir.join(file);
    s
}

/// A test's scratch folder ([`scratch`]), or a file in one
/// ([`scratch_file`]); derefs to its path.
#[cfg(test)]
#[derive(Debug)]
pub(crate) struct Scratch {
    dir: std::path::PathBuf,
    path: std::path::PathBuf,
}

#[cfg(test)]
impl std::ops::Deref for Scratch {
    type Target = std::path::Path;
    fn deref(&self) -> &std::path::Path {
        &self.path
    }
}

#[cfg(test)]
impl AsRef<std::path::Path> for Scratch {
    fn as_ref(&self) -> &std::path::Path {
        &self.path
    }
}

#[cfg(test)]
impl Drop for Scratch {
    fn drop(&mut self) {
        if std::thread::panicking() {
            eprintln!(
                "scratch folder kept for the failed test: {}",
                self.dir.display()
            );
        } else {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}

#[cfg(test)]
mod tests;
