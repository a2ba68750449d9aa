//! The board main loop, written once for every board: bytes from the host
//! into [`Device::feed`] (replies back out), then [`Device::poll`] against
//! the board's timer, on every pass. A board supplies a [`HostLink`] and a
//! way to read its free-running 32-bit counter; nothing here touches a
//! register.

use crate::{Device, OutputDriver, TimeExtender};

/// The byte link to the host (a UART), as the serve loop sees it.
pub trait HostLink {
    /// Moves bytes that have arrived into `buf`, without waiting; returns
    /// how many.
    fn receive(&mut self, buf: &mut [u8]) -> usize;
    /// Sends, or queues for sending, one reply.
    fn send(&mut self, bytes: &[u8]);
    /// Called once per pass after the step: moves queued bytes on. Links
    /// that send in [`send`](Self::send) keep the default (nothing).
    fn flush(&mut self) {}
}

/// Bytes taken from the link per pass: small, so a pass (and with it the
/// next step) is never held up long by a burst of input.
pub const RX_CHUNK: usize = 64;

/// The serve loop's state between passes: the widened timer count.
#[derive(Debug, Default)]
pub struct Server {
    clock: TimeExtender,
}

impl Server {
    /// A loop starting at count 0.
    pub const fn new() -> Self {
        Self {
            clock: TimeExtender::new(),
        }
    }

    /// One pass: take what has arrived (at most [`RX_CHUNK`] bytes), read
    /// the counter, feed the device, play what is due, flush the link.
    pub fn pass(
        &mut self,
        link: &mut impl HostLink,
        count: &mut impl FnMut() -> u32,
        dev: &mut Device<'_>,
        out: &mut impl OutputDriver,
    ) {
        let mut rx = [0u8; RX_CHUNK];
        let n = link.receive(&mut rx);
        let now = self.clock.extend(count());
        if n > 0 {
            dev.feed(&rx[..n], now, out, &mut |reply: &[u8]| link.send(reply));
        }
        dev.poll(now, out);
        link.flush();
    }
}

/// The firmware's main loop: [`Server::pass`] forever. `count` reads the
/// board's free-running counter at [`Config::timer_hz`](crate::Config::timer_hz).
pub fn serve(
    mut link: impl HostLink,
    mut count: impl FnMut() -> u32,
    dev: &mut Device<'_>,
    out: &mut impl OutputDriver,
) -> ! {
    let mut server = Server::new();
    loop {
        server.pass(&mut link, &mut count, dev, out);
    }
}
