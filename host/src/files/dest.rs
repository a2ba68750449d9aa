//! An output's destination, looked at before anything is written: what is
//! there decides how it is written ([`Dest`]).
//!
//! Renaming a temporary file over a path replaces whatever the path is: a
//! device node (as root, `--out /dev/null` would replace the system's
//! node), a symlink (the link, not its target), a file's mode and owner,
//! one name of a hard-linked file. So a symlink is followed to the file it
//! names, a regular file's permission bits and owner are kept, and
//! anything that is not a regular file is written in place or refused.

use std::fs::{File, Metadata, OpenOptions};
use std::os::unix::fs::{FileTypeExt as _, MetadataExt as _, OpenOptionsExt as _};
use std::path::{Path, PathBuf};

use super::WriteError;
use crate::error::InputError;

/// Most symlinks followed from one destination (Linux's own limit).
const MAX_LINKS: usize = 40;

/// How a destination is written.
#[derive(Debug)]
pub(super) enum Dest {
    /// A regular file, or a name that is free: a temporary file beside
    /// `path` (the destination with its symlinks followed) is renamed over
    /// it; `old` is the file it replaces, if any.
    Replace { path: PathBuf, old: Option<Old> },
    /// A character device (`/dev/null`, a terminal) or a FIFO with a
    /// reader, opened for writing: written in place.
    InPlace(File),
}

/// The regular file a [`Dest::Replace`] replaces: what the new one keeps.
#[derive(Debug, Clone, Copy)]
pub(super) struct Old {
    /// Permission bits (`0o777`; set-id bits are not carried over).
    pub mode: u32,
    pub uid: u32,
    pub gid: u32,
    /// Its names: more than one means the others keep the old contents.
    pub links: u64,
}

/// `path` with the symlinks of its last component followed: the name a
/// write through the link lands on (which need not exist yet).
pub(super) fn follow(path: &Path) -> std::io::Result<PathBuf> {
    let mut p = path.to_owned();
    for _ in 0..MAX_LINKS {
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let target = std::fs::read_link(&p)?;
                p = match p.parent() {
                    Some(dir) if target.is_relative() => dir.join(target),
                    _ => target,
                };
            }
            _ => return Ok(p),
        }
    }
    Err(std::io::Error::from_raw_os_error(libc::ELOOP))
}

/// Looks at `dest` and says how to write it. A directory or a FIFO with
/// no reader fails (exit 1); a block device or a socket is refused (exit 2).
pub(super) fn inspect(dest: &Path) -> anyhow::Result<Dest> {
    let fail = |e: std::io::Error| WriteError::new(dest, e);
    let m = match std::fs::metadata(dest) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            // A free name, or a symlink to one: create the link's target.
            let path = follow(dest).map_err(fail)?;
            return Ok(Dest::Replace { path, old: None });
        }
        Err(e) => return Err(fail(e).into()),
    };
    let t = m.file_type();
    if t.is_file() {
        let path = follow(dest).map_err(fail)?;
        // A name that does not follow as a path (`/proc/self/fd/N` of a
        // deleted file) is written in place rather than guessed at.
        if !std::fs::metadata(&path).is_ok_and(|p| same(&p, &m)) {
            return Ok(Dest::InPlace(open_in_place(dest)?));
        }
        let old = Old {
            mode: m.mode() & 0o777,
            uid: m.uid(),
            gid: m.gid(),
            links: m.nlink(),
        };
        check_owner(dest, &old)?;
        return Ok(Dest::Replace {
            path,
            old: Some(old),
        });
    }
    if t.is_dir() {
        return Err(fail(std::io::ErrorKind::IsADirectory.into()).into());
    }
    if t.is_char_device() || t.is_fifo() {
        return Ok(Dest::InPlace(open_in_place(dest)?));
    }
    Err(refusal(dest, &m, WRITES).into())
}

/// Opens `path` (a character device, a FIFO or an existing file) for
/// writing in place, never blocking: a FIFO with no reader fails at once
/// (exit 1) instead of waiting for one, and what turned out not to be
/// writable in place is refused.
pub(super) fn open_in_place(path: &Path) -> anyhow::Result<File> {
    let f = OpenOptions::new()
        .write(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)
        .map_err(|e| WriteError::new(path, no_reader(e)))?;
    let m = f.metadata().map_err(|e| WriteError::new(path, e))?;
    let t = m.file_type();
    if !(t.is_char_device() || t.is_fifo() || t.is_file()) {
        return Err(refusal(path, &m, WRITES).into());
    }
    blocking(&f).map_err(|e| WriteError::new(path, e))?;
    if t.is_file() {
        // Written from the start: nothing of the old contents stays.
        f.set_len(0).map_err(|e| WriteError::new(path, e))?;
    }
    Ok(f)
}

/// Opens the log `path` for writing without blocking (created when free,
/// truncated when `truncate`): a regular file, or for a `fresh` log a
/// character device or a FIFO with a reader. Returns the file and whether
/// it is a regular one.
pub(super) fn open_log(path: &Path, fresh: bool, truncate: bool) -> anyhow::Result<(File, bool)> {
    match std::fs::metadata(path) {
        Ok(m) if !m.is_file() => {
            if m.is_dir() {
                return Err(WriteError::new(path, std::io::ErrorKind::IsADirectory.into()).into());
            }
            if !fresh {
                return Err(refusal(path, &m, "a log to resume must be a regular file").into());
            }
            if !(m.file_type().is_char_device() || m.file_type().is_fifo()) {
                return Err(refusal(path, &m, WRITES).into());
            }
            Ok((open_in_place(path)?, false))
        }
        _ => {
            let f = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(truncate)
                .custom_flags(libc::O_NONBLOCK)
                .open(path)
                .map_err(|e| WriteError::new(path, no_reader(e)))?;
            let m = f.metadata().map_err(|e| WriteError::new(path, e))?;
            if !m.is_file() {
                return Err(refusal(path, &m, WRITES).into());
            }
            Ok((f, true))
        }
    }
}

/// Back to blocking writes once open: a slow reader then slows the writer
/// down instead of failing a write half way.
fn blocking(f: &File) -> std::io::Result<()> {
    use std::os::fd::AsRawFd as _;
    let fd = f.as_raw_fd();
    // SAFETY: fcntl on a descriptor this `File` owns, with plain flags.
    let flags = unsafe { libc::fcntl(fd, libc::F_GETFL) };
    if flags < 0 {
        return Err(std::io::Error::last_os_error());
    }
    // SAFETY: as above.
    if unsafe { libc::fcntl(fd, libc::F_SETFL, flags & !libc::O_NONBLOCK) } < 0 {
        return Err(std::io::Error::last_os_error());
    }
    Ok(())
}

/// ENXIO from a non-blocking open for writing: a FIFO nobody reads.
fn no_reader(e: std::io::Error) -> std::io::Error {
    if e.raw_os_error() == Some(libc::ENXIO) {
        std::io::Error::other("it is a FIFO (named pipe) with no reader")
    } else {
        e
    }
}

/// What [`Output`](super::Output) writes, for refusals.
pub(super) const WRITES: &str =
    "lmhost writes regular files, character devices such as /dev/null and pipes with a reader";

/// Refuses a destination that is not written this way (exit 2); `accepted`
/// says what is.
fn refusal(path: &Path, m: &Metadata, accepted: &str) -> InputError {
    let t = m.file_type();
    let what = if t.is_block_device() {
        "a block device"
    } else if t.is_socket() {
        "a socket"
    } else if t.is_dir() {
        "a directory"
    } else if t.is_fifo() {
        "a FIFO (named pipe)"
    } else if t.is_char_device() {
        "a character device"
    } else {
        "not a regular file"
    };
    InputError::new(format!(
        "cannot write {}: it is {what}; {accepted}",
        path.display()
    ))
}

/// Whether two metadata name the same file.
fn same(a: &Metadata, b: &Metadata) -> bool {
    (a.dev(), a.ino()) == (b.dev(), b.ino())
}

/// A replaced file keeps its owner: a file of another user can only be
/// given back to them by root, so anyone else is refused before the work.
fn check_owner(dest: &Path, old: &Old) -> Result<(), WriteError> {
    let me = euid();
    if me == 0 || old.uid == me {
        return Ok(());
    }
    Err(WriteError::new(
        dest,
        std::io::Error::other(format!(
            "it belongs to another user (uid {}) and replacing it would make it ours; \
             remove it first or write elsewhere",
            old.uid
        )),
    ))
}

/// Gives the new file `f` the replaced file's owner and permission bits.
/// Only root can give a file to another user ([`check_owner`] refused the
/// rest); anyone else keeps the group when they are in it, else the file
/// gets their own.
pub(super) fn keep(f: &File, old: &Old) -> std::io::Result<()> {
    use std::os::unix::fs::PermissionsExt as _;
    let m = f.metadata()?;
    if (m.uid(), m.gid()) != (old.uid, old.gid) {
        let r = std::os::unix::fs::fchown(f, Some(old.uid), Some(old.gid));
        if euid() == 0 {
            r?;
        }
    }
    f.set_permissions(std::fs::Permissions::from_mode(old.mode))
}

/// This process's effective user.
fn euid() -> u32 {
    // SAFETY: geteuid has no preconditions and cannot fail.
    unsafe { libc::geteuid() }
}
