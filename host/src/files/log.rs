//! [`AppendLog`]: lines appended whole.

use std::fs::File;
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use super::dest::open_log;
use super::{WriteError, not_an_input};

/// An append-only log of lines (events, trial rows): every line is written
/// whole or not at all. A line that fails (a full disk) is cut off again,
/// so the file ends at the last whole line; [`AppendLog::open`] drops a
/// torn last line a crash left behind. [`AppendLog::sync`] makes what was
/// written durable. A log is written in place (through a symlink, into
/// its target) and opened without blocking: a fresh one may also be a
/// character device or a FIFO with a reader; a FIFO with no reader fails
/// at once instead of hanging the command before it can be stopped.
#[derive(Debug)]
pub struct AppendLog {
    path: PathBuf,
    file: File,
    len: u64,
    /// A regular file (a device or a pipe has nothing to sync).
    regular: bool,
}

impl AppendLog {
    /// Starts `path` afresh (an existing file is emptied).
    pub fn create(path: &Path) -> anyhow::Result<Self> {
        not_an_input("output", path)?;
        let (file, regular) = open_log(path, true, true)?;
        Ok(Self {
            path: path.to_owned(),
            file,
            len: 0,
            regular,
        })
    }

    /// Opens `path` to start afresh later ([`PendingLog::start`]), changing
    /// nothing yet: a path that cannot be written fails now, before the
    /// work, and a run refused or failed before it starts leaves a file
    /// that was there as it was and makes none that was not.
    pub fn prepare(path: &Path) -> anyhow::Result<PendingLog> {
        not_an_input("output", path)?;
        let existed = std::fs::symlink_metadata(path).is_ok();
        let (file, regular) = open_log(path, true, false)?;
        Ok(PendingLog {
            log: Some(Self {
                path: path.to_owned(),
                file,
                len: 0,
                regular,
            }),
            made: !existed && regular,
        })
    }

    /// Opens `path` to append (creating it), first cutting off a torn last
    /// line (one without its newline). Returns the log and its whole lines.
    pub fn open(path: &Path) -> anyhow::Result<(Self, Vec<String>)> {
        use std::io::Read as _;
        not_an_input("output", path)?;
        let (mut file, regular) = open_log(path, false, false)?;
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
                regular,
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
        if !self.regular {
            return Ok(());
        }
        self.file
            .sync_data()
            .map_err(|e| WriteError::new(&self.path, e))
    }

    /// Where it is.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// A log opened by [`AppendLog::prepare`], not started: dropped so, it
/// leaves its file as it was, and removes it when it made it.
#[derive(Debug)]
pub struct PendingLog {
    log: Option<AppendLog>,
    /// The file did not exist: opening it made it.
    made: bool,
}

impl PendingLog {
    /// Starts the log afresh: a regular file is emptied now.
    pub fn start(mut self) -> Result<AppendLog, WriteError> {
        let mut log = self.log.take().expect("a pending log holds its log");
        if log.regular {
            log.file
                .set_len(0)
                .and_then(|()| log.file.seek(SeekFrom::Start(0)).map(|_| ()))
                .map_err(|e| WriteError::new(&log.path, e))?;
        }
        Ok(log)
    }
}

impl Drop for PendingLog {
    fn drop(&mut self) {
        if let Some(log) = self.log.take().filter(|_| self.made) {
            let _ = std::fs::remove_file(&log.path);
        }
    }
}
