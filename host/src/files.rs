//! Files lmhost reads and writes.
//!
//! - **Inputs** ([`open_input`], [`read_input`]): a path is checked by its
//!   metadata before it is opened, so a FIFO, a directory, a device node, a
//!   socket or a missing file is a one-line [`InputError`] at once (never an
//!   `open` that blocks); standard input stays the way to stream. Every
//!   input's identity (device and inode) is remembered.
//! - **Outputs** ([`Output`], [`write_whole`]): bytes go to a temporary file
//!   in the destination's directory, which is synced and renamed over the
//!   destination on [`Output::commit`]. A file lmhost writes is therefore
//!   whole or absent, after a full disk, an error, Ctrl-C
//!   ([`crate::stop`] removes the temporary file) or `kill -9` (a leftover
//!   `.NAME.lmhost-PID.tmp.EXT`, never the named file). A failed overwrite
//!   leaves the previous file as it was.
//! - **Output = input**: an output that is one of this process's inputs
//!   (the same file, also through a link or another name) is refused
//!   before anything is written, as is an output given twice
//!   ([`distinct_outputs`]).

use std::fs::{File, Metadata};
use std::io::{Seek, SeekFrom, Write};
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

/// What kind of non-regular file `m` is, in words.
fn kind(m: &Metadata) -> Option<&'static str> {
    let t = m.file_type();
    if t.is_file() {
        None
    } else if t.is_dir() {
        Some("it is a directory")
    } else if t.is_fifo() {
        Some("it is a FIFO (named pipe), not a regular file; pipe into standard input instead")
    } else if t.is_char_device() || t.is_block_device() {
        Some("it is a device node, not a regular file")
    } else if t.is_socket() {
        Some("it is a socket, not a regular file")
    } else {
        Some("it is not a regular file")
    }
}

/// Checks that `path` is an existing regular file (`what` names it in
/// errors, e.g. "--scene file") without opening it.
pub fn check_input(what: &str, path: &Path) -> Result<Metadata, InputError> {
    let cannot =
        |why: &str| InputError::new(format!("cannot read {what} {}: {why}", path.display()));
    let m = std::fs::metadata(path).map_err(|e| cannot(&reason(&e)))?;
    if let Some(k) = kind(&m) {
        return Err(cannot(k));
    }
    Ok(m)
}

/// Opens the regular file `path` for reading (checked first, see
/// [`check_input`]) and remembers it as an input.
pub fn open_input(what: &str, path: &Path) -> Result<File, InputError> {
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
        return Err(cannot(k));
    }
    INPUTS
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push((id(&m), path.to_owned()));
    Ok(f)
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

/// The input `path` is, if it exists and was opened as one.
fn input_named_by(path: &Path) -> Option<PathBuf> {
    let m = std::fs::metadata(path).ok()?;
    let inputs = INPUTS.lock().unwrap_or_else(|e| e.into_inner());
    inputs
        .iter()
        .find(|(i, _)| *i == id(&m))
        .map(|(_, p)| p.clone())
}

/// Refuses to write `path` when it is one of this process's inputs.
pub fn not_an_input(flag: &str, path: &Path) -> Result<(), InputError> {
    match input_named_by(path) {
        Some(input) => Err(InputError::new(format!(
            "{flag} {} is the input {}: refusing to overwrite it; choose another output path",
            path.display(),
            input.display()
        ))),
        None => Ok(()),
    }
}

/// Refuses outputs that are the same file as each other (by name after
/// resolving the directory, or by identity when they exist) or as an
/// input: `outputs` are (flag, path) pairs, checked before anything is
/// written.
pub fn distinct_outputs(outputs: &[(&str, &Path)]) -> Result<(), InputError> {
    let key = |p: &Path| -> PathBuf {
        let dir = p
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let dir = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_owned());
        dir.join(p.file_name().unwrap_or_default())
    };
    for (i, (flag, p)) in outputs.iter().enumerate() {
        not_an_input(flag, p)?;
        for (flag2, q) in &outputs[..i] {
            let same_id = match (std::fs::metadata(p), std::fs::metadata(q)) {
                (Ok(a), Ok(b)) => id(&a) == id(&b),
                _ => false,
            };
            if same_id || key(p) == key(q) {
                return Err(InputError::new(format!(
                    "{flag} {} and {flag2} {} are the same file; give each output its own path",
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
pub fn output_dir(flag: &str, dir: &Path) -> anyhow::Result<()> {
    not_an_input(flag, dir)?;
    std::fs::create_dir_all(dir).map_err(|e| {
        anyhow::anyhow!(
            "cannot create the {flag} directory {}: {}",
            dir.display(),
            reason(&e)
        )
    })
}

/// A write to `path` failed: exit 1, naming the file.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {}: {}", .path.display(), reason(.source))]
pub struct WriteError {
    path: PathBuf,
    source: std::io::Error,
}

impl WriteError {
    /// The error of writing `path`.
    pub fn new(path: &Path, source: std::io::Error) -> Self {
        Self {
            path: path.to_owned(),
            source,
        }
    }
}

/// An append-only log of lines (events, trial rows): every line is written
/// whole or not at all. A line that fails (a full disk) is cut off again,
/// so the file ends at the last whole line; [`AppendLog::open`] drops a
/// torn last line a crash left behind. [`AppendLog::sync`] makes what was
/// written durable.
#[derive(Debug)]
pub struct AppendLog {
    path: PathBuf,
    file: File,
    len: u64,
}

impl AppendLog {
    /// Starts `path` afresh (an existing file is replaced).
    pub fn create(path: &Path) -> anyhow::Result<Self> {
        not_an_input("output", path)?;
        let file = std::fs::OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(true)
            .open(path)
            .map_err(|e| WriteError::new(path, e))?;
        Ok(Self {
            path: path.to_owned(),
            file,
            len: 0,
        })
    }

    /// Opens `path` to append (creating it), first cutting off a torn last
    /// line (one without its newline). Returns the log and its whole lines.
    pub fn open(path: &Path) -> anyhow::Result<(Self, Vec<String>)> {
        use std::io::Read as _;
        not_an_input("output", path)?;
        let mut file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(path)
            .map_err(|e| WriteError::new(path, e))?;
        let mut text = Vec::new();
        file.read_to_end(&mut text)
            .map_err(|e| WriteError::new(path, e))?;
        let whole = text.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        file.set_len(whole as u64)
            .and_then(|()| file.seek(SeekFrom::End(0)).map(|_| ()))
            .map_err(|e| WriteError::new(path, e))?;
        let lines = String::from_utf8_lossy(&text[..whole])
            .lines()
            .map(str::to_owned)
            .collect();
        Ok((
            Self {
                path: path.to_owned(),
                file,
                len: whole as u64,
            },
            lines,
        ))
    }

    /// Appends `line` and a newline in one write; on failure the file is
    /// cut back to where it was.
    pub fn line(&mut self, line: &str) -> Result<(), WriteError> {
        let mut buf = Vec::with_capacity(line.len() + 1);
        buf.extend_from_slice(line.as_bytes());
        buf.push(b'\n');
        match self.file.write_all(&buf) {
            Ok(()) => {
                self.len += buf.len() as u64;
                Ok(())
            }
            Err(e) => {
                let _ = self.file.set_len(self.len);
                let _ = self.file.seek(SeekFrom::Start(self.len));
                Err(WriteError::new(&self.path, e))
            }
        }
    }

    /// Makes every line written so far durable (fsync).
    pub fn sync(&mut self) -> Result<(), WriteError> {
        self.file
            .sync_data()
            .map_err(|e| WriteError::new(&self.path, e))
    }

    /// Where it is.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// A file being written: a temporary file beside the destination until
/// [`Output::commit`] renames it into place. Dropped uncommitted, it
/// removes the temporary file and leaves the destination untouched.
#[derive(Debug)]
pub struct Output {
    dest: PathBuf,
    tmp: PathBuf,
    file: std::io::BufWriter<File>,
    _guard: crate::stop::TempGuard,
}

impl Output {
    /// Starts writing `dest`. Refuses (exit 2) a destination that is one of
    /// this process's inputs; fails (exit 1, naming `dest`) when the
    /// directory cannot take a file or `dest` is a directory.
    pub fn create(dest: &Path) -> anyhow::Result<Output> {
        not_an_input("output", dest)?;
        Self::open(dest)
    }

    /// [`Output::create`] without the input check.
    fn open(dest: &Path) -> anyhow::Result<Output> {
        if std::fs::metadata(dest).is_ok_and(|m| m.is_dir()) {
            return Err(WriteError::new(dest, std::io::ErrorKind::IsADirectory.into()).into());
        }
        let name = dest
            .file_name()
            .ok_or_else(|| WriteError::new(dest, std::io::ErrorKind::InvalidInput.into()))?;
        // `.NAME.lmhost-PID.tmp.EXT`: hidden, and with the destination's
        // extension, for writers that pick the format by it (PNG plots).
        let mut tmp_name = std::ffi::OsString::from(".");
        tmp_name.push(name);
        tmp_name.push(format!(".lmhost-{}.tmp", std::process::id()));
        if let Some(ext) = dest.extension() {
            tmp_name.push(".");
            tmp_name.push(ext);
        }
        let tmp = dest.with_file_name(tmp_name);
        // Registered before it exists, so a signal never leaves it behind.
        let guard = crate::stop::TempGuard::register(&tmp);
        let file = std::fs::OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(true)
            .open(&tmp)
            .map_err(|e| WriteError::new(dest, e))?;
        Ok(Output {
            dest: dest.to_owned(),
            tmp,
            file: std::io::BufWriter::new(file),
            _guard: guard,
        })
    }

    /// Where the file will be.
    pub fn path(&self) -> &Path {
        &self.dest
    }

    /// Writes `bytes`; an error names the destination.
    pub fn write_bytes(&mut self, bytes: &[u8]) -> Result<(), WriteError> {
        self.file
            .write_all(bytes)
            .map_err(|e| WriteError::new(&self.dest, e))
    }

    /// Overwrites `bytes` at `offset` (a header rewritten at the end) and
    /// returns to the end of the file.
    pub fn write_at(&mut self, offset: u64, bytes: &[u8]) -> Result<(), WriteError> {
        let w = |f: &mut std::io::BufWriter<File>| -> std::io::Result<()> {
            f.flush()?;
            let f = f.get_mut();
            let end = f.seek(SeekFrom::End(0))?;
            f.seek(SeekFrom::Start(offset))?;
            f.write_all(bytes)?;
            f.seek(SeekFrom::Start(end.max(offset + bytes.len() as u64)))?;
            Ok(())
        };
        w(&mut self.file).map_err(|e| WriteError::new(&self.dest, e))
    }

    /// Flushes, syncs and renames the file into place: from here on the
    /// destination holds exactly what was written.
    pub fn commit(mut self) -> Result<(), WriteError> {
        let dest = self.dest.clone();
        let err = |e| WriteError::new(&dest, e);
        self.file.flush().map_err(err)?;
        self.file.get_ref().sync_all().map_err(err)?;
        std::fs::rename(&self.tmp, &self.dest).map_err(err)?;
        if let Some(dir) = self.dest.parent() {
            let dir = if dir.as_os_str().is_empty() {
                Path::new(".")
            } else {
                dir
            };
            // Best effort: the rename itself survives a crash once synced.
            if let Ok(d) = File::open(dir) {
                let _ = d.sync_all();
            }
        }
        // Renamed: nothing left to remove.
        self.tmp = PathBuf::new();
        Ok(())
    }
}

impl Write for Output {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.file.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

impl Drop for Output {
    fn drop(&mut self) {
        if !self.tmp.as_os_str().is_empty() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Runs `write`, which writes the file at the path it is given (a library
/// that takes a path, such as the PNG encoder), then moves that file into
/// place at `dest` whole (see [`Output`]); on error nothing is left.
pub fn write_via(
    dest: &Path,
    write: impl FnOnce(&Path) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let out = Output::create(dest)?;
    write(&out.tmp)?;
    out.commit()?;
    Ok(())
}

/// Replaces `path`, one of this process's inputs, deliberately (a command
/// that updates the file it read, such as `calibrate --write`): whole or
/// not at all, as [`write_whole`].
pub fn replace_input(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let mut out = Output::open(path)?;
    out.write_bytes(bytes)?;
    out.commit()?;
    Ok(())
}

/// Writes `bytes` to `path` whole or not at all (see [`Output`]).
pub fn write_whole(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let mut out = Output::create(path)?;
    out.write_bytes(bytes)?;
    out.commit()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("lmhost-files-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn an_uncommitted_output_leaves_nothing_and_keeps_the_old_file() {
        let d = scratch("uncommitted");
        let p = d.join("out.bin");
        std::fs::write(&p, b"old").unwrap();
        let mut o = Output::create(&p).unwrap();
        o.write_bytes(b"new, half").unwrap();
        drop(o);
        assert_eq!(names(&d), ["out.bin"]);
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
        write_whole(&p, b"new").unwrap();
        assert_eq!(names(&d), ["out.bin"]);
        assert_eq!(std::fs::read(&p).unwrap(), b"new");
    }

    #[test]
    fn a_header_rewritten_at_the_end_lands_at_its_offset() {
        let d = scratch("write_at");
        let p = d.join("h.bin");
        let mut o = Output::create(&p).unwrap();
        o.write_bytes(b"....tail").unwrap();
        o.write_at(0, b"HEAD").unwrap();
        o.write_bytes(b"+more").unwrap();
        o.commit().unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"HEADtail+more");
    }

    #[test]
    fn a_wrapped_io_error_is_said_in_words() {
        #[derive(Debug, thiserror::Error)]
        #[error("encoder: {0}")]
        struct Wrapped(#[source] std::io::Error);
        let w = Wrapped(std::io::Error::from_raw_os_error(libc::ENOSPC));
        assert_eq!(reason_of(&w), "no space left on device");
        #[derive(Debug, thiserror::Error)]
        #[error("{0}")]
        struct Text(&'static str);
        let text = Text(
            "ImageError(IoError(Custom { error: \"No space left on device (os error 28)\" }))",
        );
        assert_eq!(reason_of(&text), "no space left on device");
        let plain = std::fmt::Error;
        assert_eq!(reason_of(&plain), plain.to_string());
    }

    #[test]
    fn odd_inputs_are_refused_by_kind_without_blocking() {
        let d = scratch("inputs");
        let fifo = d.join("fifo");
        nix::unistd::mkfifo(&fifo, nix::sys::stat::Mode::S_IRWXU).unwrap();
        let e = open_input("--scene file", &fifo).unwrap_err().to_string();
        assert!(e.contains("FIFO") && e.contains("fifo"), "{e}");
        let e = open_input("--scene file", &d).unwrap_err().to_string();
        assert!(e.contains("directory"), "{e}");
        let e = open_input("--scene file", Path::new("/dev/null"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("device node"), "{e}");
        let e = open_input("--scene file", &d.join("missing"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("no such file"), "{e}");
    }

    #[test]
    fn an_output_onto_an_input_is_refused_also_through_a_link() {
        let d = scratch("same");
        let input = d.join("scene.toml");
        std::fs::write(&input, b"x = 1\n").unwrap();
        std::os::unix::fs::symlink(&input, d.join("link.toml")).unwrap();
        std::fs::hard_link(&input, d.join("hard.toml")).unwrap();
        open_input("--scene file", &input).unwrap();
        for p in ["scene.toml", "link.toml", "hard.toml"] {
            let e = Output::create(&d.join(p)).unwrap_err();
            assert!(e.is::<InputError>(), "{e}");
        }
        assert_eq!(std::fs::read(&input).unwrap(), b"x = 1\n");
        Output::create(&d.join("other.toml")).unwrap();
        let a = d.join("a.npy");
        let e = distinct_outputs(&[("--record", &a), ("--plot", &d.join(".").join("a.npy"))]);
        assert!(e.unwrap_err().to_string().contains("same file"));
    }
}
