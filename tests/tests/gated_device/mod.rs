//! A device that holds one upload: the simulated firmware core behind a
//! local TCP port (one core for every connection, so `lmhost status`
//! afterwards reads what the command before left), which keeps the
//! host's `nth` `BeginUpload` unanswered until the test releases it. A
//! test signals a command while it waits there: during its set-up, for
//! sure, with no timing. [`Gated::restart`] resets the device mid-run, as
//! a power glitch or a watchdog would. The device has been on for an hour
//! when the fake starts ([`UP_BEFORE`]), so a restart sets its uptime
//! back whenever it comes.

use std::io::Write as _;
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use lm_proto::{FeedResult, FrameDecoder, MessageType};
use lmhost::device::simdev::{Core as _, FwCore, SimConfig};

/// How long the fake holds an upload at most (a test that failed before
/// releasing it must not hang the device thread forever).
const HOLD_AT_MOST: Duration = Duration::from_secs(120);

/// How long the device has been on when the fake starts, µs.
const UP_BEFORE: u64 = 3_600_000_000;

/// The running fake.
pub struct Gated {
    /// Its `--port`.
    pub port: String,
    reached: Receiver<()>,
    release: SyncSender<()>,
    shared: Arc<Shared>,
}

/// What the connections share.
struct Shared {
    core: Mutex<FwCore>,
    t0: Instant,
    uploads: AtomicUsize,
    nth: usize,
    reached: SyncSender<()>,
    release: Mutex<Receiver<()>>,
}

impl Gated {
    /// Starts a fake holding the `nth` `BeginUpload` (from 1, over all
    /// connections; 0: none).
    pub fn start(nth: usize) -> Gated {
        let listener = TcpListener::bind("127.0.0.1:0").expect("a local TCP port");
        let port = listener.local_addr().unwrap().port();
        let (reached_tx, reached) = sync_channel(1);
        let (release, release_rx) = sync_channel(1);
        let mut core = FwCore::new(SimConfig::default()).expect("the simulated firmware");
        core.set_epoch(0);
        let shared = Arc::new(Shared {
            core: Mutex::new(core),
            t0: Instant::now(),
            uploads: AtomicUsize::new(0),
            nth,
            reached: reached_tx,
            release: Mutex::new(release_rx),
        });
        let served = shared.clone();
        std::thread::spawn(move || {
            for conn in listener.incoming().flatten() {
                let _ = serve(conn, &served);
            }
        });
        Gated {
            port: format!("tcp:127.0.0.1:{port}"),
            reached,
            release,
            shared,
        }
    }

    /// Resets the device: a fresh firmware, its library empty and its
    /// counters at 0, on the same connection.
    pub fn restart(&self) {
        *self.shared.core.lock().unwrap() =
            FwCore::new(SimConfig::default()).expect("the simulated firmware");
    }

    /// Waits until the host sent the held upload (panics after `within`).
    pub fn wait_held(&self, within: Duration) {
        self.reached
            .recv_timeout(within)
            .expect("the host never sent the upload the fake holds");
    }

    /// Lets the held upload through.
    pub fn release(&self) {
        let _ = self.release.try_send(());
    }
}

/// One connection: frame by frame to the shared core, its replies back.
fn serve(mut conn: TcpStream, s: &Shared) -> std::io::Result<()> {
    conn.set_read_timeout(Some(Duration::from_millis(1)))?;
    let (mut buf, mut out, mut frame) = (vec![0u8; 4096], Vec::new(), Vec::new());
    loop {
        let now = || UP_BEFORE + s.t0.elapsed().as_micros() as u64;
        s.core.lock().unwrap().poll(now());
        let n = match crate::link_support::read_within(&mut conn, &mut buf)? {
            Some(0) => return Ok(()),
            Some(n) => n,
            None => continue,
        };
        for &b in &buf[..n] {
            frame.push(b);
            if b != 0 {
                continue;
            }
            if is_begin_upload(&frame) && s.uploads.fetch_add(1, Ordering::SeqCst) + 1 == s.nth {
                let _ = s.reached.try_send(());
                let _ = s.release.lock().unwrap().recv_timeout(HOLD_AT_MOST);
            }
            out.clear();
            s.core.lock().unwrap().receive(now(), &frame, &mut out);
            frame.clear();
            conn.write_all(&out)?;
        }
    }
}

/// Whether `bytes` (one frame up to its closing delimiter) is a
/// `BeginUpload`.
fn is_begin_upload(bytes: &[u8]) -> bool {
    let mut d = FrameDecoder::new();
    let mut input = bytes;
    loop {
        input = match d.feed(input) {
            FeedResult::Consumed => return false,
            FeedResult::Frame { frame, .. } => {
                return frame.message.msg_type() == MessageType::BeginUpload;
            }
            FeedResult::Error { remaining, .. } => remaining,
        };
    }
}
