//! How a request on the link failed: each error names the port (the
//! device's fault may be that it is not our device at all), and a timeout
//! says what came instead of the reply.

use lm_proto::NackCode;
use lm_proto::codec::CodecError;

/// Link failures (the operation failed; exit 1). Each names the port
/// (the device's fault may be that it is not our device at all).
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    /// No valid response after all retries.
    #[error(
        "no response from {port} to {what} after {tries} tries ({timeout_ms} ms each){heard}; \
         check the port, cable and that the firmware runs"
    )]
    Timeout {
        /// The port.
        port: String,
        /// The request.
        what: &'static str,
        /// Attempts made.
        tries: u32,
        /// Per-attempt timeout.
        timeout_ms: u64,
        /// What came back instead.
        heard: Heard,
    },
    /// The device refused a request.
    #[error("{port} refused {what}: {code}")]
    Nack {
        /// The port.
        port: String,
        /// The request.
        what: &'static str,
        /// Its reason.
        code: NackCode,
    },
    /// A response of the wrong kind.
    #[error("{port} answered {what} with {got}")]
    Unexpected {
        /// The port.
        port: String,
        /// The request.
        what: &'static str,
        /// What came back.
        got: &'static str,
    },
    /// A response of the right kind that the LM firmware never sends
    /// ([`super::reply`]).
    #[error("the {reply} from {port} is not one this lmhost's LM firmware sends: {why}")]
    BadReply {
        /// The port.
        port: String,
        /// The reply's kind.
        reply: &'static str,
        /// What is impossible about it.
        why: String,
    },
    /// The device restarted since the last `Status` this client read
    /// ([`super::reply::restarted`]): the sequences uploaded before are
    /// gone, so nothing that counts on them can go on.
    #[error(
        "the device on {port} restarted ({why}): the sequences lmhost uploaded are gone; \
         run the command again"
    )]
    Restarted {
        /// The port.
        port: String,
        /// What said so.
        why: String,
    },
    /// The transport failed.
    #[error("link I/O with {port} failed during {what}: {source}")]
    Io {
        /// The port.
        port: String,
        /// The request.
        what: &'static str,
        /// The cause.
        source: std::io::Error,
    },
    /// A stop was requested (Ctrl-C, SIGTERM, ...) in the middle of a
    /// transfer of many requests; what it sent is not committed.
    #[error("{what} to {port} stopped by a signal before it was committed")]
    Stopped {
        /// The port.
        port: String,
        /// The transfer.
        what: &'static str,
    },
    /// The sequence could not be encoded (its phases are not steps ×
    /// transducers, or the positions do not match the transducers).
    #[error("the sequence cannot be encoded: {0}")]
    Codec(#[from] CodecError),
    /// The upload could not be completed within its restart budget.
    #[error("upload failed after {attempts} attempts; last error: {last}")]
    UploadGaveUp {
        /// Whole-upload attempts made.
        attempts: u32,
        /// Why the last one failed.
        last: Box<LinkError>,
    },
}

/// What the port sent while a request went unanswered: a timeout says
/// whether nothing came, or what came instead of the reply.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Heard {
    /// Bytes read.
    pub bytes: u64,
    /// Frames that decoded.
    pub frames: u64,
    /// Of those, requests (lmhost's own frames, echoed).
    pub echoes: u64,
    /// Of those, replies carrying another request's seq.
    pub other_seq: u64,
    /// Frames that failed to decode (COBS, length, CRC, version, type).
    pub bad_frames: u64,
}

impl std::fmt::Display for Heard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.bytes == 0 {
            Ok(())
        } else if self.echoes > 0 && self.echoes == self.frames {
            f.write_str(
                ": the port echoed lmhost's own frames back (a loopback, or a serial adapter \
                 with no device behind it)",
            )
        } else if self.other_seq > 0 {
            write!(
                f,
                ": {} replies came with another request's seq",
                self.other_seq
            )
        } else if self.bad_frames > 0 {
            write!(
                f,
                ": {} frames failed their checks (COBS, length, CRC, protocol version)",
                self.bad_frames
            )
        } else {
            write!(
                f,
                ": {} bytes came, none an LM protocol frame (another program on the port, or \
                 another baud rate)",
                self.bytes
            )
        }
    }
}
