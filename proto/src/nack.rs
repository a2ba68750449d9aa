//! Why a request was refused: the `Nack` payload byte (SPEC section 3).
//! Its own module, so the header check ([`crate::HeaderError::nack`]) and
//! the messages both use it without importing each other.

use crate::wire::wire_enum;

wire_enum! {
    /// Why a request was refused (`Nack` payload byte).
    pub enum NackCode {
        /// 1: message type unknown to the device.
        UnknownType = 1 => "unknown message type",
        /// 2: payload has the wrong length or an invalid field value.
        Malformed = 2 => "malformed request",
        /// 3: frame carries another protocol version.
        BadVersion = 3 => "unsupported protocol version",
        /// 4: slot number does not exist.
        BadSlot = 4 => "no such slot",
        /// 5: the slot is playing (stop or use another slot first).
        SlotPlaying = 5 => "slot is playing or queued",
        /// 6: sequence exceeds `slot_bytes` or `max_transducers`.
        TooLarge = 6 => "sequence too large for the device",
        /// 7: a field is outside its allowed range (zero steps, offset past
        /// `encoded_len`, geometry index past `transducers`, ...).
        OutOfRange = 7 => "field out of range",
        /// 8: out of sequence: a chunk or intensity levels not at the next
        /// expected offset (gap, or an overlap with different data), or a
        /// centroid whose `seq` is not newer than the last accepted one.
        OutOfOrder = 8 => "out of order: not the next chunk offset, or a stale centroid",
        /// 9: commit CRC differs from the CRC of the decoded raw sequence.
        CrcMismatch = 9 => "sequence CRC mismatch",
        /// 10: play of a slot that holds no committed sequence.
        NotCommitted = 10 => "slot holds no committed sequence",
        /// 11: `period_us / steps` is below the device's `min_dwell_us`.
        DwellTooShort = 11 => "dwell time below the device minimum",
        /// 12: chunk, geometry or commit without a matching `BeginUpload`.
        NoUpload = 12 => "no upload in progress for this slot",
        /// 13: device cannot take the request now; retry later.
        Busy = 13 => "device busy",
        /// 14: commit before all `encoded_len` bytes (or all geometry) arrived.
        Incomplete = 14 => "upload incomplete",
        /// 15: the encoded sequence stream is invalid for its encoding.
        BadStream = 15 => "invalid encoded sequence stream",
        /// 16: the library has no room for the entry (even after freeing
        /// the slot's old entry and compacting); overwrite or free another.
        LibraryFull = 16 => "stimulus library full",
        /// 17: `BeginUpload` before the device holds a rig (send `BeginRig`,
        /// `Geometry`, `CommitRig` first).
        NoRig = 17 => "device holds no rig (transducer positions)",
        /// 18: `BeginUpload` planned for another rig than the device holds
        /// (CRC or transducer count differ).
        RigMismatch = 18 => "sequence planned for another rig than the device holds",
    } else {
        /// A code this version does not know (from a newer peer). Never
        /// constructed with a known code's value.
        Other(u8) => "unknown nack code {}",
    }
}
