//! Byte layouts of the frame header and of every message payload (SPEC
//! sections 1 and 3), each field a byte range, declared once: encoding and
//! parsing index the bytes with these ranges, and each `LEN` is the end of
//! the last field (the fields are checked to tile `0..LEN` at compile time),
//! so a length cannot disagree with its fields. [`crate::len`] lists the
//! lengths. Integers are little-endian; `[i32; 3]` is x, y, z.

pub use crate::wire::Field;
use crate::wire::layout;

layout! {
    /// The decoded frame's header, before the payload.
    pub mod frame {
        /// `PROTOCOL_VERSION`, u8.
        VERSION = 0..1,
        /// Message type, u8.
        TYPE = 1..2,
        /// Sequence number, u16.
        SEQ = 2..4,
    }
}

layout! {
    /// What every response echoes of the request it answers, between the
    /// header and the payload (SPEC section 2, "Binding").
    pub mod echo {
        /// The request's type byte, u8.
        REQUEST_TYPE = 0..1,
        /// The request frame's CRC-32 (its last four bytes), u32.
        REQUEST_CRC32 = 1..5,
    }
}

layout! {
    /// `BeginUpload`.
    pub mod begin_upload {
        /// Target slot, u8.
        SLOT = 0..1,
        /// Steps per cycle, u16.
        STEPS = 1..3,
        /// Transducers per step, u16.
        TRANSDUCERS = 3..5,
        /// Cycle period, µs, u32.
        PERIOD_US = 5..9,
        /// `Encoding`, u8.
        ENCODING = 9..10,
        /// Total bytes of the encoded stream, u32.
        ENCODED_LEN = 10..14,
        /// Planned centre, µm, `[i32; 3]`.
        CENTER_UM = 14..26,
        /// Foci per step, u8.
        FOCI_PER_STEP = 26..27,
        /// Speed of sound, mm/s, u32.
        SOUND_SPEED_MM_S = 27..31,
        /// Work volume, µm, u32.
        MAX_OFFSET_UM = 31..35,
        /// CRC-32 of the rig (positions table) the phases were planned for, u32.
        RIG_CRC32 = 35..39,
        /// Output intensity, 0-255 (255 = full), u8.
        INTENSITY = 39..40,
        /// Flag bits (`UPLOAD_FLAG_INTENSITY_TABLE`), u8.
        FLAGS = 40..41,
    }
}

layout! {
    /// `Geometry` before its positions (which run from `LEN` to the end).
    pub mod geometry {
        /// Index of the first transducer, u16.
        FIRST = 0..2,
    }
}

layout! {
    /// `BeginRig`.
    pub mod begin_rig {
        /// Transducers of the rig, u16.
        TRANSDUCERS = 0..2,
        /// CRC-32 of the positions table (12-byte records), u32.
        CRC32 = 2..6,
    }
}

layout! {
    /// `Chunk` before its data (which runs from `LEN` to the end).
    pub mod chunk {
        /// Slot of the upload, u8.
        SLOT = 0..1,
        /// Offset of the data in the encoded stream, u32.
        OFFSET = 1..5,
    }
}

layout! {
    /// `Intensity` before its table bytes (which run from `LEN` to the end).
    pub mod intensity {
        /// Slot of the upload, u8.
        SLOT = 0..1,
        /// Index of the first step the bytes are for, u16.
        OFFSET = 1..3,
    }
}

layout! {
    /// `Commit`.
    pub mod commit {
        /// Slot of the upload, u8.
        SLOT = 0..1,
        /// CRC-32 of the raw sequence, u32.
        CRC32 = 1..5,
    }
}

layout! {
    /// `Play`.
    pub mod play {
        /// Slot to play, u8.
        SLOT = 0..1,
        /// `PlayAt`, u8.
        AT = 1..2,
        /// Flag bits (`PLAY_FLAG_UNTRACKED`), u8.
        FLAGS = 2..3,
        /// Steps to play before stopping (0 = until `Stop`), u32.
        STEPS = 3..7,
        /// Host lease, ms (`LEASE_MS`), u16.
        LEASE_MS = 7..9,
    }
}

layout! {
    /// `Centroid`.
    pub mod centroid {
        /// Host's update counter, u32.
        SEQ = 0..4,
        /// LM centre, µm, `[i32; 3]`.
        POS_UM = 4..16,
        /// Finger present, bool (0 or 1).
        PRESENT = 16..17,
        /// Host clock at measurement, µs, u64.
        HOST_TIME_US = 17..25,
    }
}

layout! {
    /// `Nack`.
    pub mod nack {
        /// `NackCode`, u8.
        CODE = 0..1,
    }
}

layout! {
    /// `Info`.
    pub mod info {
        /// Protocol version, u8.
        PROTO_VERSION = 0..1,
        /// Firmware major, minor, patch, `[u8; 3]`.
        FW_VERSION = 1..4,
        /// Most transducers, u16.
        MAX_TRANSDUCERS = 4..6,
        /// Raw bytes one slot holds, u32.
        SLOT_BYTES = 6..10,
        /// Number of slots, u8.
        SLOTS = 10..11,
        /// Player timer frequency, Hz, u32.
        TIMER_HZ = 11..15,
        /// Shortest step dwell, µs, u32.
        MIN_DWELL_US = 15..19,
        /// Largest chunk accepted, u16.
        MAX_CHUNK = 19..21,
        /// Transducers of the rig the device holds (0 = none), u16.
        RIG_TRANSDUCERS = 21..23,
        /// CRC-32 of that rig's positions table (0 when none), u32.
        RIG_CRC32 = 23..27,
        /// Free library bytes now, u32.
        LIBRARY_FREE = 27..31,
        /// `ClockSource` of the player's timer, u8.
        CLOCK = 31..32,
    }
}

layout! {
    /// `Status`.
    pub mod status {
        /// `DeviceState`, u8.
        STATE = 0..1,
        /// Slot playing or last played (`NO_SLOT` = none), u8.
        SLOT = 1..2,
        /// Step within the cycle, u16.
        STEP = 2..4,
        /// Cycles since `Play`, u32.
        CYCLES = 4..8,
        /// Missed step deadlines, u32.
        MISSED_DEADLINES = 8..12,
        /// `seq` of the last accepted centroid, u32.
        LAST_CENTROID_SEQ = 12..16,
        /// Bad frames other than CRC errors, u32.
        BAD_FRAMES = 16..20,
        /// CRC errors, u32.
        CRC_ERRORS = 20..24,
        /// Nacks sent, u32.
        NACKS = 24..28,
        /// Correction applied, µm, `[i32; 3]`.
        CORRECTION_UM = 28..40,
        /// Slot queued for the next cycle boundary (`NO_SLOT` = none), u8.
        QUEUED_SLOT = 40..41,
        /// `MuteReason`, u8.
        MUTE_REASON = 41..42,
        /// Host lease of the play session, ms (0 = none yet), u16.
        LEASE_MS = 42..44,
        /// Plays stopped because their host lease expired, u32.
        LEASE_EXPIRIES = 44..48,
        /// Milliseconds since reset, wrapping, u32.
        UPTIME_MS = 48..52,
    }
}

layout! {
    /// `SelfTestResult`.
    pub mod self_test {
        /// `SelfTest` outcome: 0 unsupported, 1 passed, 2 failed, u8.
        OUTCOME = 0..1,
        /// Bytes sent and read back, u32.
        BYTES = 1..5,
        /// Bytes read back that differ from those sent, u32.
        MISMATCHES = 5..9,
        /// Index of the first such byte, u32.
        FIRST_MISMATCH = 9..13,
        /// The byte sent there, u8.
        SENT = 13..14,
        /// The byte read back there, u8.
        GOT = 14..15,
    }
}
