//! The host side of the link: byte transports ([`transport`]), which port
//! to open ([`discover`]), the request/response client with retries and
//! chunked upload ([`client`]), and a fault-injecting wrapper for tests
//! ([`proxy`]).
//!
//! Units convert here and only here: the library's millimetres and seconds
//! become the wire's micrometres and microseconds.

pub mod client;
pub mod discover;
pub mod proxy;
pub mod transport;

pub use client::{Client, LinkError, LinkStats, Reply, UploadReport, UploadSpec};
pub use transport::Transport;

/// Millimetres to whole micrometres (rounded, saturating).
pub fn mm_to_um(mm: f64) -> i32 {
    (mm * 1000.0).round().clamp(i32::MIN as f64, i32::MAX as f64) as i32
}
