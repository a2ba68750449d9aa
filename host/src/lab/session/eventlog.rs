//! The event log (`--events`) written off the session's loop: a thread
//! appends whole lines ([`AppendLog`]) and syncs whenever its queue runs
//! empty, so a slow disk never holds up the loop; a log that falls
//! [`LOG_QUEUE`] lines behind, or fails, ends the session with its error.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::{SyncSender, TrySendError, sync_channel};
use std::thread::JoinHandle;

use crate::files::{AppendLog, PendingLog};

/// Lines the log may fall behind the loop.
pub const LOG_QUEUE: usize = 65_536;

/// An event log being written.
pub struct EventLog {
    path: PathBuf,
    queue: Option<SyncSender<Arc<str>>>,
    writer: Option<JoinHandle<anyhow::Result<()>>>,
}

/// An event log opened, not started ([`EventLog::prepare`]).
pub struct PendingEventLog(PendingLog);

impl PendingEventLog {
    /// Starts the log afresh (an existing file is emptied now).
    pub fn start(self) -> anyhow::Result<EventLog> {
        EventLog::begin(self.0.start()?)
    }
}

impl EventLog {
    /// Opens `path` to start afresh once the session has started
    /// ([`PendingEventLog::start`]): a path that cannot be written fails
    /// now, and a session refused or failed in its set-up leaves an
    /// earlier session's log as it was ([`AppendLog::prepare`]).
    pub fn prepare(path: &Path) -> anyhow::Result<PendingEventLog> {
        Ok(PendingEventLog(AppendLog::prepare(path)?))
    }

    /// The log writing into `log`.
    fn begin(mut log: AppendLog) -> anyhow::Result<Self> {
        let path = log.path().to_owned();
        let (queue, rx) = sync_channel::<Arc<str>>(LOG_QUEUE);
        let writer = std::thread::Builder::new()
            .name("lmhost-events".into())
            .spawn(move || -> anyhow::Result<()> {
                while let Ok(line) = rx.recv() {
                    log.line(&line)?;
                    while let Ok(more) = rx.try_recv() {
                        log.line(&more)?;
                    }
                    log.sync()?;
                }
                Ok(())
            })?;
        Ok(Self {
            path,
            queue: Some(queue),
            writer: Some(writer),
        })
    }

    /// Queues `line` without waiting; an error when the log failed or
    /// fell too far behind.
    pub fn line(&mut self, line: Arc<str>) -> anyhow::Result<()> {
        let Some(q) = &self.queue else {
            return Ok(());
        };
        match q.try_send(line) {
            Ok(()) => Ok(()),
            Err(TrySendError::Full(_)) => Err(anyhow::anyhow!(
                "the event log {} fell {LOG_QUEUE} lines behind (its disk does not keep up)",
                self.path.display()
            )),
            // The writer ended: its error says why.
            Err(TrySendError::Disconnected(_)) => self.finish(),
        }
    }

    /// Writes what is queued, syncs and returns the writer's first error.
    pub fn finish(&mut self) -> anyhow::Result<()> {
        self.queue = None;
        match self.writer.take().map(JoinHandle::join) {
            None => Ok(()),
            Some(Ok(r)) => r,
            Some(Err(_)) => Err(anyhow::anyhow!(
                "the event log {} writer failed",
                self.path.display()
            )),
        }
    }
}
