//! Hardware-free core of the LM firmware: the resident stimulus library
//! and the rig's positions, drift-free player, centroid correction, safety
//! gating and the protocol handler.
//!
//! It never touches hardware, never allocates and never panics on input:
//! a board (or the host simulator) owns the UART, the timer and the SPI
//! and hands the core bytes, timer counts and an [`OutputDriver`].
//! The wire format is [`lm_proto`]'s; nothing here re-declares it.
//!
//! # Driving a [`Device`]
//!
//! ```
//! use lm_fw_core::{Config, Device, RecordingDriver, memory_bytes};
//! use static_cell::ConstStaticCell;
//!
//! // Sequence memory: a 448 KiB library and a rig of up to 996 positions.
//! const BYTES: usize = memory_bytes(448 * 1024, 996);
//! static MEM: ConstStaticCell<[u8; BYTES]> = ConstStaticCell::new([0; BYTES]);
//! # fn main() {
//! let mem: &'static mut [u8] = MEM.take(); // once, in the board's main
//! let mut dev = Device::new(Config::new(1_000_000), mem).unwrap();
//! let mut out = RecordingDriver::<16>::new();
//! let now = 0u64; // free-running timer count at Config::timer_hz
//! let received: &[u8] = &[]; // bytes from the UART, any piece size
//! dev.feed(received, now, &mut out, &mut |reply: &[u8]| { /* write reply to the UART */ });
//! let next = dev.poll(now, &mut out); // Some(t): call poll again at t
//! assert_eq!(next, None); // nothing plays yet
//! # }
//! ```
//!
//! A board loop: on UART bytes call [`Device::feed`] then
//! [`Device::poll`]; on the timer compare match (set to the deadline
//! `poll` returned) call `poll` again. `now` is a `u64`; widen a 32-bit
//! counter with [`TimeExtender`].
//!
//! # API at a glance
//!
//! - [`Device::new`]`(`[`Config`]`, &mut mem)`: `mem` is the sequence memory,
//!   [`memory_bytes`]`(library_bytes, max_transducers)` long.
//! - [`Device::feed`]`(bytes, now, &mut driver, &mut |reply| ..)`: received
//!   bytes in, one encoded response frame out per request (the driver for
//!   `SelfTest`, [`OutputDriver::self_test`]).
//! - [`Device::poll`]`(now, &mut driver) -> Option<u64>`: writes due frames,
//!   returns the next deadline ([`Device::next_deadline`] peeks it).
//! - [`Device::info`], [`Device::status`], [`Device::counters`],
//!   [`Device::handle`] (a parsed request, for tests and other transports),
//!   [`Device::offsets`], [`Device::is_sounding`]; settable at run time:
//!   [`Device::set_centroid_timeout_us`], [`Device::set_min_dwell_us`],
//!   [`Device::set_require_tracking`].
//! - Output: [`OutputDriver`] receives a [`OutputFrame`] (phases with correction
//!   applied, amplitude 0 when muted, the entry's intensity, scaled by the
//!   step's level when the entry has an intensity table); [`SpiOutput`]
//!   sends it over an embedded-hal 1.0 `SpiDevice` as one transaction
//!   `[0xA5, amplitude, intensity, step u16 LE, transducers u16 LE, phases..]`;
//!   [`RecordingDriver`] keeps the last frames for tests. A board with an
//!   SPI loopback jumper overrides [`OutputDriver::self_test`] with
//!   [`output::loopback_test`] (the default answers `Unsupported`).
//!
//! # Behaviour
//!
//! - Library ([`store`]): [`SLOTS`] entries in one arena, each stored Raw
//!   or as its Delta stream (decoded step by step while it plays; the rule
//!   is in the module docs), first-fit with compaction, `LibraryFull` when
//!   an entry does not fit (nothing changes); `BeginUpload` checked by
//!   [`lm_proto::BeginUpload::validate`] (the host runs the same check),
//!   then the rig (`NoRig`, `RigMismatch`) and the space; one upload at a
//!   time; chunks in stream order; identical repeats of received data are
//!   acked; commit checks completeness and the raw CRC-32, and a repeated
//!   commit with the same CRC is acked again. Writes to the playing or
//!   queued slot get `SlotPlaying`.
//! - Rig: one positions table (`BeginRig`, `Geometry`, `CommitRig`, CRC-32
//!   checked) used by every entry's correction; another rig drops every
//!   entry and is refused with `Busy` while something plays.
//! - Player ([`player`], [`time`]): step k of a cycle at
//!   floor(k·P/N) counts after the cycle start, integer only; `Play` with
//!   `NextCycle` swaps at the cycle boundary; late polls count missed
//!   deadlines and skip. Steps shorter than [`Config::min_dwell_us`]
//!   are refused (`DwellTooShort`) at `BeginUpload` and `Play`.
//! - Correction ([`correction`]): a fresh centroid (with presence) sets
//!   per-transducer offsets k·(|x−c0| − |x−c|) in u8 LSB, added to every
//!   frame from the next step on.
//! - Work volume: a present centroid farther than the playing slot's
//!   `max_offset_um` from its planned centre (or one that overflows) is
//!   refused (`OutOfRange`) and mutes until an in-range one arrives; a
//!   queued slot taking over re-checks the last centroid against its own.
//! - Untracked play (`Play` flag): no gating, no correction, until `Stop`.
//! - Host lease (`Play.lease_ms`, [`policy`]): every accepted request
//!   renews it; a play whose host stays silent that long stops as `Stop`
//!   does (reason `LeaseExpired`, counted), at the expiry (it is one of
//!   [`Device::poll`]'s deadlines), before any later step or request.
//! - `SelfTest`: the output's self-test, `Busy` while a slot plays.
//! - `Status` reports the queued slot and why the output is muted; it is
//!   assembled once, in [`status`], from the player and the policy (the
//!   host's AUTD3 backend calls the same function).
//! - Gating ([`gate`]): presence false or a stale centroid (older than
//!   [`Config::centroid_timeout_us`]) mutes (amplitude 0) within one step;
//!   with [`Config::require_tracking`] (default) output stays muted from
//!   `Play` until the first centroid. `Stop` mutes on the next `poll`.
//!   A new play session (Play while not playing) forgets old centroids;
//!   Play while playing keeps the gate but accepts the next centroid
//!   whatever its sequence number (a restarted host counts from 0).
//! - Handler: every request gets `Ack`, `Nack(code)`, `Info` or `Status`;
//!   bad frames are counted ([`Counters`]); responses sent to the device
//!   get `Nack(UnknownType)`; stale centroids get `Nack(OutOfOrder)`.
//!
//! # Memory
//!
//! `size_of::<Device>()` is the core's whole state outside the sequence
//! memory: receive decoder (`MAX_FRAME`), send buffer (`MAX_ENCODED_FRAME`),
//! offset and frame tables ([`MAX_TRANSDUCERS`] bytes each), the library's
//! entry table, one upload state (codec decoders, running CRC, chunk log),
//! the rig's position bitmap and two three-step decode rings (upload check,
//! playback; 3 × [`MAX_TRANSDUCERS`] bytes each). 12,576 bytes on
//! thumbv7em (a compile-time assertion keeps it ≤ 16 KB). The sequence
//! memory is [`memory_bytes`]`(library_bytes, max_transducers)`: the rig's
//! 12 bytes per transducer, then the library's arena.
#![no_std]
#![warn(missing_docs)]

pub mod correction;
mod device;
pub mod gate;
pub mod output;
pub mod player;
pub mod policy;
pub mod serve;
pub mod status;
pub mod store;
mod take_once;
pub mod time;

pub use device::{
    Config, Counters, DEFAULT_CENTROID_TIMEOUT_US, DEFAULT_TRANSDUCERS, Device, DeviceError,
    FW_VERSION,
};
pub use output::{OutputDriver, OutputFrame, Record, RecordingDriver, SpiOutput};
pub use serve::{HostLink, Server, serve};
pub use store::{BOARD_LIBRARY_BYTES, CHUNK_LOG, Form, SLOTS, StoreError, memory_bytes};
pub use take_once::TakeOnce;
pub use time::TimeExtender;

/// Largest transducer count the core's tables hold (offsets, frame
/// buffer); a board's `Config::max_transducers` (its array, e.g. 996 for
/// four AUTD3) must not exceed it.
pub const MAX_TRANSDUCERS: usize = 1024;

// The core's own state (everything outside the sequence memory) stays
// within the 16 KB static RAM budget on every target.
const _: () = assert!(core::mem::size_of::<Device<'static>>() <= 16 * 1024);
