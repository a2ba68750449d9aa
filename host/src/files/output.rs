//! [`Output`]: one file lmhost writes, whole or absent.

use std::fs::File;
use std::io::{Seek, SeekFrom, Write};
use std::os::unix::fs::OpenOptionsExt as _;
use std::path::{Path, PathBuf};

use super::dest::{self, Dest, Old};
use super::{WriteError, not_an_input};

/// A file being written. For a regular file (or a new name): a temporary
/// file beside the destination until [`Output::commit`] renames it into
/// place; dropped uncommitted, it removes the temporary file and leaves
/// the destination untouched. For a character device or a FIFO with a
/// reader: the destination itself. See [`super`] for the rules.
#[derive(Debug)]
pub struct Output {
    /// The path as given, for messages.
    dest: PathBuf,
    how: How,
    file: std::io::BufWriter<File>,
    _guard: Option<crate::stop::TempGuard>,
}

#[derive(Debug)]
enum How {
    /// `tmp` is renamed over `target` (the destination, symlinks followed)
    /// on commit; emptied once renamed.
    Replace {
        target: PathBuf,
        tmp: PathBuf,
        old: Option<Old>,
    },
    /// Written where it is.
    InPlace,
}

impl Output {
    /// Starts writing `dest`. Refuses (exit 2) a destination that is one of
    /// this process's inputs, a block device or a socket; fails (exit 1,
    /// naming `dest`) when the directory cannot take a file, `dest` is a
    /// directory or a FIFO with no reader, or it is another user's file.
    pub fn create(dest: &Path) -> anyhow::Result<Output> {
        not_an_input("output", dest)?;
        Self::open(dest)
    }

    /// [`Output::create`] without the input check.
    fn open(dest: &Path) -> anyhow::Result<Output> {
        let (target, old) = match dest::inspect(dest)? {
            Dest::InPlace(f) => {
                return Ok(Output {
                    dest: dest.to_owned(),
                    how: How::InPlace,
                    file: std::io::BufWriter::new(f),
                    _guard: None,
                });
            }
            Dest::Replace { path, old } => (path, old),
        };
        let name = target
            .file_name()
            .ok_or_else(|| WriteError::new(dest, std::io::ErrorKind::InvalidInput.into()))?;
        // `.NAME.lmhost-PID.tmp.EXT`: hidden, and with the destination's
        // extension, for tools that pick the format by it.
        let mut tmp_name = std::ffi::OsString::from(".");
        tmp_name.push(name);
        tmp_name.push(format!(".lmhost-{}.tmp", std::process::id()));
        if let Some(ext) = target.extension() {
            tmp_name.push(".");
            tmp_name.push(ext);
        }
        let tmp = target.with_file_name(tmp_name);
        remove_stale_temporaries(&target);
        // Registered before it exists, so a signal never leaves it behind.
        let guard = crate::stop::TempGuard::register(&tmp);
        // A file that replaces another is private until it has the old
        // one's bits (set on commit); a new one gets the umask's.
        let file = std::fs::OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(true)
            .mode(if old.is_some() { 0o600 } else { 0o666 })
            .open(&tmp)
            .map_err(|e| WriteError::new(dest, e))?;
        let out = Output {
            dest: dest.to_owned(),
            how: How::Replace { target, tmp, old },
            file: std::io::BufWriter::new(file),
            _guard: Some(guard),
        };
        if let Some(old) = &old {
            // The owner now, so a file that cannot keep it fails before the work.
            dest::keep(
                out.file.get_ref(),
                &Old {
                    mode: 0o600,
                    ..*old
                },
            )
            .map_err(|e| WriteError::new(dest, e))?;
        }
        Ok(out)
    }

    /// Where the file will be (the path as given).
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
    /// returns to the end of the file. A pipe cannot go back: an error.
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

    /// Flushes, syncs and renames the file into place (a file written in
    /// place is flushed): from here on the destination holds exactly what
    /// was written. A replaced file with other names is said on stderr.
    pub fn commit(mut self) -> Result<(), WriteError> {
        let dest = self.dest.clone();
        let err = |e| WriteError::new(&dest, e);
        self.file.flush().map_err(err)?;
        let How::Replace { target, tmp, old } = &mut self.how else {
            return Ok(());
        };
        if let Some(old) = old {
            dest::keep(self.file.get_ref(), old).map_err(err)?;
        }
        self.file.get_ref().sync_all().map_err(err)?;
        std::fs::rename(&*tmp, &*target).map_err(err)?;
        // Renamed: nothing left to remove.
        *tmp = PathBuf::new();
        if let Some(dir) = target.parent() {
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
        if let Some(old) = (*old).filter(|o| o.links > 1) {
            crate::errln!(
                "note: {} was one of {} names of a file (hard links); it now names the new \
                 contents, the other names keep the old",
                dest.display(),
                old.links
            );
        }
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
        if let How::Replace { tmp, .. } = &self.how
            && !tmp.as_os_str().is_empty()
        {
            let _ = std::fs::remove_file(tmp);
        }
    }
}

/// Removes the temporary files an lmhost killed with `kill -9` (or by a
/// power cut) left beside `target`: `.NAME.lmhost-PID.tmp[.EXT]` whose
/// process is gone. Without this a recording killed that way leaves its
/// whole size on the disk under a hidden name for good; with it, at most
/// until the next write to the same name. A temporary file of a process
/// still running (another lmhost writing the same name) is left alone, as
/// is anything not exactly of that form or not a regular file. Best
/// effort: a folder that cannot be listed is the next step's error.
fn remove_stale_temporaries(target: &Path) {
    let (Some(dir), Some(name)) = (target.parent(), target.file_name()) else {
        return;
    };
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let Some(name) = name.to_str() else {
        return;
    };
    let prefix = format!(".{name}.lmhost-");
    let ext = target
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| format!(".tmp.{e}"));
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let Some(rest) = file_name.to_str().and_then(|n| n.strip_prefix(&prefix)) else {
            continue;
        };
        let pid = match &ext {
            Some(ext) => rest.strip_suffix(ext.as_str()),
            None => rest.strip_suffix(".tmp"),
        };
        let Some(pid) = pid
            .filter(|p| !p.is_empty() && p.bytes().all(|b| b.is_ascii_digit()))
            .and_then(|p| p.parse::<i32>().ok())
            .filter(|p| *p > 0)
        else {
            continue;
        };
        if process_is_gone(pid) && entry.file_type().is_ok_and(|t| t.is_file()) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// Whether no process `pid` exists (`kill(pid, 0)` says `ESRCH`). A
/// process of another user (`EPERM`) exists.
fn process_is_gone(pid: i32) -> bool {
    matches!(
        nix::sys::signal::kill(nix::unistd::Pid::from_raw(pid), None),
        Err(nix::errno::Errno::ESRCH)
    )
}

/// Replaces `path`, one of this process's inputs, deliberately (a command
/// that updates the file it read, such as `calibrate --write`): whole or
/// not at all, as [`write_whole`]; through a symlink, its target.
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
