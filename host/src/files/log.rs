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
        let (file, regular) = open_log(path, true)?;
        Ok(Self {
            path: path.to_owned(),
            file,
            len: 0,
            regular,
        })
    }

    /// Opens `path` to append (creating it), first cutting off a torn last
    /// line (one without its newline). Returns the log and its whole lines.
    pub fn open(path: &Path) -> anyhow::Result<(Self, Vec<String>)> {
        use std::io::Read as _;
        not_an_input("output", path)?;
        let (mut file, regular) = open_log(path, false)?;
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
