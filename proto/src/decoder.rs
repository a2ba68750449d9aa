//! Streaming frame decoder: fed arbitrary pieces of a byte stream, yields
//! each frame or the error that ended a bad one, and resyncs on the next
//! delimiter.

use crate::cobs;
use crate::frame::{Frame, FrameError, decode_frame};
use crate::{DELIMITER, MAX_FRAME};

/// Outcome of [`FrameDecoder::feed`].
#[derive(Debug)]
pub enum FeedResult<'buf, 'input> {
    /// All input was consumed without completing a frame.
    Consumed,
    /// A frame completed; `remaining` is the input after its delimiter.
    Frame {
        /// The checked frame (borrows the decoder until the next `feed`).
        frame: Frame<'buf>,
        /// Unconsumed input: feed it next.
        remaining: &'input [u8],
    },
    /// A bad frame ended; `remaining` is the input after its delimiter.
    Error {
        /// What was wrong.
        error: FrameError,
        /// Unconsumed input: feed it next.
        remaining: &'input [u8],
    },
}

enum Event {
    Frame(usize),
    Error(FrameError),
}

/// Streaming decoder with a fixed [`MAX_FRAME`]-byte buffer (no heap).
///
/// Every delimiter ends a frame: a good one is returned, a bad one is
/// reported once as a [`FrameError`] and dropped, and decoding restarts
/// clean, so a bad frame never costs the good frame after it. Empty frames
/// (consecutive delimiters) are skipped silently.
///
/// Byte at a time (UART interrupt):
/// ```
/// # use lm_proto::*;
/// # let mut wire = [0u8; MAX_ENCODED_FRAME];
/// # let n = encode_frame(7, &Message::GetInfo, &mut wire).unwrap();
/// let mut dec = FrameDecoder::new();
/// # let mut got = 0;
/// for &byte in &wire[..n] {
///     match dec.push(byte) {
///         Some(Ok(frame)) => { assert_eq!(frame.seq, 7); got += 1 }
///         Some(Err(e)) => { /* count it; NACK if e.nack() is Some */ }
///         None => {}
///     }
/// }
/// # assert_eq!(got, 1);
/// ```
/// Pieces from a host read loop:
/// ```
/// # use lm_proto::*;
/// # let mut wire = [0u8; 2 * MAX_ENCODED_FRAME];
/// # let n = encode_frame(1, &Message::Stop, &mut wire).unwrap();
/// # let echo = Echo { request_type: 0x07, request_crc32: 0 };
/// # let n = n + encode_frame(Head::reply(2, echo), &Message::Ack, &mut wire[n..]).unwrap();
/// let mut dec = FrameDecoder::new();
/// # let mut seqs = [0u16; 2]; let mut k = 0;
/// let mut input: &[u8] = &wire[..n]; // one read() worth of bytes
/// loop {
///     input = match dec.feed(input) {
///         FeedResult::Consumed => break,
///         FeedResult::Frame { frame, remaining } => { seqs[k] = frame.seq; k += 1; remaining }
///         FeedResult::Error { error, remaining } => { let _ = error; remaining }
///     };
/// }
/// # assert_eq!(seqs, [1, 2]);
/// ```
#[derive(Clone, Debug)]
pub struct FrameDecoder {
    buf: [u8; MAX_FRAME],
    len: usize,
    cobs: cobs::Decoder,
    overflow: bool,
}

impl Default for FrameDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameDecoder {
    /// An empty decoder (usable in a `static`).
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_FRAME],
            len: 0,
            cobs: cobs::Decoder::new(),
            overflow: false,
        }
    }

    /// Drops any partial frame (e.g. after a receive timeout).
    pub fn reset(&mut self) {
        self.len = 0;
        self.cobs = cobs::Decoder::new();
        self.overflow = false;
    }

    /// True when no partial frame is buffered.
    pub fn is_idle(&self) -> bool {
        !self.cobs.started()
    }

    fn push_inner(&mut self, b: u8) -> Option<Event> {
        if b == DELIMITER {
            let ev = if self.overflow {
                Some(Event::Error(FrameError::TooLong))
            } else if !self.cobs.started() {
                None
            } else if self.cobs.in_block() {
                Some(Event::Error(FrameError::Cobs))
            } else {
                Some(Event::Frame(self.len))
            };
            self.reset();
            return ev;
        }
        if self.overflow {
            return None;
        }
        if let Some(out) = self.cobs.step(b) {
            match self.buf.get_mut(self.len) {
                Some(slot) => {
                    *slot = out;
                    self.len += 1;
                }
                None => self.overflow = true,
            }
        }
        None
    }

    fn finish(&self, ev: Event) -> Result<Frame<'_>, FrameError> {
        match ev {
            Event::Frame(n) => decode_frame(self.buf.get(..n).ok_or(FrameError::TooLong)?),
            Event::Error(e) => Err(e),
        }
    }

    /// Feeds one byte; returns a frame or error when `byte` is a delimiter
    /// that ends a non-empty frame.
    pub fn push(&mut self, byte: u8) -> Option<Result<Frame<'_>, FrameError>> {
        let ev = self.push_inner(byte)?;
        Some(self.finish(ev))
    }

    /// Feeds bytes until a frame (good or bad) ends or the input runs out;
    /// hands back the unconsumed input (see the type docs for the loop).
    pub fn feed<'buf, 'input>(&'buf mut self, input: &'input [u8]) -> FeedResult<'buf, 'input> {
        for (i, &b) in input.iter().enumerate() {
            if let Some(ev) = self.push_inner(b) {
                let remaining = input.get(i + 1..).unwrap_or(&[]);
                return match self.finish(ev) {
                    Ok(frame) => FeedResult::Frame { frame, remaining },
                    Err(error) => FeedResult::Error { error, remaining },
                };
            }
        }
        FeedResult::Consumed
    }
}
