//! Round 16w: a device's replies, field by field (the device side's
//! round; the fakes of round 9 lie in new ways).
//!
//! - r16w-1: a `Status` that says Idle (nothing played since reset) with a
//!   step, cycles or a host lease, or a correction where none applies
//!   (idle, stopped, waiting for tracking, out of range) or beyond the
//!   largest work volume, was taken: `lmhost status` printed it. Refused,
//!   naming the port and the field (exit 1), as round 9's impossible
//!   states are.
//! - r16w-2: an `Info` with a rig CRC and no rig (`rig_crc32` is 0 when
//!   none) was taken. Refused the same way.
//!
//! The protocol's own classes of this round (an empty `Chunk` or
//! `Geometry`, a centroid numbered 0, a self-test whose counts contradict)
//! are checked by the vectors, the firmware's tests, the conformance
//! table and the link client's scripted device, below the binary.

use lm_proto::{Info, Status};

use super::cases_r9::Mutation;
use super::*;

/// This round's fakes, for `{fake:NAME}` (round 9's `expand_fakes` asks
/// here for a name it does not know).
pub(crate) fn mutation(name: &str) -> Option<Mutation> {
    Some(match name {
        "idle_step" => Mutation::Status(|s: &mut Status| s.step = 5),
        "idle_cycles" => Mutation::Status(|s: &mut Status| s.cycles = 3),
        "idle_lease" => Mutation::Status(|s: &mut Status| s.lease_ms = 1000),
        "idle_correction" => Mutation::Status(|s: &mut Status| s.correction_um = [0, 1, 0]),
        "rig_crc_no_rig" => Mutation::Info(|i: &mut Info| {
            i.rig_transducers = 0;
            i.rig_crc32 = 0x1234;
        }),
        _ => return None,
    })
}

pub(crate) fn round16w_cases() -> Vec<Case> {
    table! {
        // 1. A Status that holds at 0 what the firmware holds at 0.
        R16W_STATUS_ZERO "status --port {fake:idle_step}" .code(1).err("tcp:127.0.0.1:").err("step 5 in state idle");
        R16W_STATUS_ZERO "status --port {fake:idle_cycles}" .code(1).err("cycles 3 in state idle");
        R16W_STATUS_ZERO "status --port {fake:idle_lease}" .code(1).err("lease_ms 1000 in state idle");
        R16W_STATUS_ZERO "status --port {fake:idle_correction}" .code(1).err("correction_um [0, 1, 0] in state idle");
        R16W_STATUS_ZERO "stream --synthetic --seconds 0.3 --port {fake:idle_correction}" .code(1).err("tcp:127.0.0.1:").err("correction_um");
        // 2. An Info with a rig CRC and no rig.
        R16W_INFO_RIG "info --port {fake:rig_crc_no_rig}" .code(1).err("tcp:127.0.0.1:").err("rig_crc32 0x00001234 without a rig");
        R16W_INFO_RIG "upload --radius 3 --no-play --port {fake:rig_crc_no_rig}" .code(1).err("rig_crc32 0x00001234 without a rig");
    }
}
