//! Round 4, the device's decisions: a port whose holder was killed, and
//! the AUTD3 backend's slots, segments and in-process emulator.

use super::*;

/// Issue 30.15 and the AUTD3 cases of issues 26 and 31.
pub(crate) fn round4_device_cases() -> Vec<Case> {
    table! {
        // 30.15: a lock dies with its holder ({stale}'s was kill -9'd).
        STALE_LOCK "status --port {stale}" .ok().out("state");
        STALE_LOCK "info --port {stale} --json" .ok().out("max_transducers");
        STALE_LOCK "upload --port {stale} --no-play --slot 1" .ok();
        STALE_LOCK "status --port {stale} --json" .ok().out("\"state\"");
        // ... while a live holder still keeps its port.
        STALE_LOCK "status --port {busy} --json" .code(1).err("in use by another process");
        // The AUTD3 backend's slots and segments.
        AUTD3_SLOTS "upload --port autd3:emulator --slot 2" .err("slots 0 and 1");
        AUTD3_SLOTS "upload --port autd3:emulator --slot 255 --untracked" .err("slots 0 and 1");
        AUTD3_SLOTS "play --port autd3:emulator --slot 1" .code(1).err("is empty");
        AUTD3_SLOTS "play --port autd3:emulator --slot 0 --immediate" .code(1).err("is empty");
        AUTD3_SLOTS "play --port autd3:emulator --slot 7" .err("slots 0 and 1");
        // The emulator lives in this process (a typed query, the rig form
        // too): an upload reads back and exits at once, left silent.
        AUTD3_SLOTS "upload --port autd3:emulator --untracked" .ok().err("lives in this process");
        AUTD3_SLOTS "upload --port autd3:emulator:4 --untracked --json" .ok()
                    .err("lives in this process").out("\"readback_mismatches\":0");
        AUTD3_SLOTS "upload --port autd3:emulator --no-play --slot 1" .ok().out("read back");
        AUTD3_SLOTS "upload --port autd3:emulator --untracked --hold 0.3 --json" .ok()
                    .out("\"counters\":\"host clock\"");
    }
}
