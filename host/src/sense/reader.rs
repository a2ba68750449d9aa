//! A source read on a thread of its own into a small bounded channel, so a
//! source blocked on input (stdin, a socket, a camera bridge) never holds
//! up the loop that consumes it: the device's housekeeping and stop
//! requests go on while it is silent. The one reader-thread helper: the
//! centroid samples of `stream` and the depth frames of `track` both use it.

use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender};
use std::time::Duration;

/// What a wait for the next item gave.
#[derive(Debug)]
pub enum Next<T> {
    /// The next item.
    Ready(T),
    /// Nothing yet; the source goes on.
    Idle,
    /// The source ended.
    End,
}

/// Items read on their own thread (made by [`spawn`]).
#[derive(Debug)]
pub struct Reader<T> {
    rx: Receiver<anyhow::Result<T>>,
}

/// Reads the items of the iterator `make` builds (built on the thread, so
/// it need not be `Send`) on a thread named `name`, at most `ahead` items
/// ahead of the consumer. The thread ends after the first error, when the
/// [`Reader`] is dropped (at its next item) or when a stop is requested
/// ([`crate::stop`]); it is never joined, so one blocked reading stdin
/// ends with the process.
pub fn spawn<T, I, F>(name: &str, ahead: usize, make: F) -> anyhow::Result<Reader<T>>
where
    T: Send + 'static,
    I: IntoIterator<Item = anyhow::Result<T>>,
    F: FnOnce() -> I + Send + 'static,
{
    let (tx, rx) = std::sync::mpsc::sync_channel(ahead);
    std::thread::Builder::new()
        .name(name.into())
        .spawn(move || pump(make(), &tx))
        .map_err(|e| anyhow::anyhow!("cannot start the {name} thread: {e}"))?;
    Ok(Reader { rx })
}

fn pump<T>(items: impl IntoIterator<Item = anyhow::Result<T>>, tx: &SyncSender<anyhow::Result<T>>) {
    for item in items {
        let end = item.is_err();
        if tx.send(item).is_err() || end || crate::stop::requested() {
            break;
        }
    }
}

impl<T> Reader<T> {
    /// The next item if one comes within `wait`.
    pub fn next_within(&self, wait: Duration) -> Next<anyhow::Result<T>> {
        match self.rx.recv_timeout(wait) {
            Ok(x) => Next::Ready(x),
            Err(RecvTimeoutError::Timeout) => Next::Idle,
            Err(RecvTimeoutError::Disconnected) => Next::End,
        }
    }

    /// The next item, waiting as long as it takes; `None` at the end.
    pub fn next_blocking(&self) -> Option<anyhow::Result<T>> {
        self.rx.recv().ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn items_arrive_in_order_and_an_error_ends_the_source() {
        let items: Vec<anyhow::Result<u32>> =
            vec![Ok(1), Ok(2), Err(anyhow::anyhow!("bad")), Ok(4)];
        let r = spawn("test-reader", 2, move || items).unwrap();
        let mut got = Vec::new();
        loop {
            match r.next_within(Duration::from_secs(5)) {
                Next::Ready(Ok(x)) => got.push(x),
                Next::Ready(Err(e)) => got.push(1000 + e.to_string().len() as u32),
                Next::Idle => panic!("a ready source idled"),
                Next::End => break,
            }
        }
        assert_eq!(got, [1, 2, 1003]);
    }

    #[test]
    fn a_silent_source_idles() {
        let r = spawn("test-silent", 1, || {
            std::thread::sleep(Duration::from_millis(300));
            std::iter::once(Ok(7u8))
        })
        .unwrap();
        assert!(matches!(
            r.next_within(Duration::from_millis(1)),
            Next::Idle
        ));
        assert!(matches!(r.next_blocking(), Some(Ok(7))));
        assert!(r.next_blocking().is_none());
    }
}
