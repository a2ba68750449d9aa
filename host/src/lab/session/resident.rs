//! Which library entries are on the device: preloaded at start as far as
//! its slots and its memory go, loaded on demand, and, when the device's
//! library memory is full, put in place of the least recently used entry
//! that neither plays nor waits.
//!
//! The LM firmware keeps its entries in one arena (`lm_fw_core::store`):
//! an upload that does not fit is refused with `LibraryFull` before
//! anything changes, and an upload into a slot frees that slot's entry
//! first. So a load that does not fit beside the others is tried again in
//! place of one idle entry, least recently used first; where no single one
//! makes room, the next idle entries, least recently used first, are
//! overwritten by a one-step placeholder (the wire has no erase; one
//! step of phases is what an entry takes at least) until it fits. An
//! AUTD3's two segments are two slots with no shared memory.

use lm_proto::NackCode;

use super::Session;
use super::protocol::{EventKind, Gate, LibraryItem};
use crate::device::backend::BackendError;
use crate::error::InputError;
use crate::plan::stimulus::TargetPlan;

/// A library entry planned for this device, and where it is on it.
#[derive(Debug, Clone)]
pub struct Loaded {
    /// The entry's id.
    pub id: String,
    /// The stimulus.
    pub stimulus: crate::plan::stimulus::Stimulus,
    /// Its plan on this device's grid.
    pub planned: TargetPlan,
    /// Its default gate.
    pub untracked: bool,
    /// The slot holding it now, if any.
    pub slot: Option<u8>,
    /// CRC-32 of its phases.
    pub crc32: u32,
    /// When it was last presented or prepared (session clock, µs): the
    /// least recently used idle entry makes room first.
    pub used_us: u64,
}

/// Why a load did not happen.
enum LoadError {
    /// The device's library memory has no room for it in that slot.
    Full,
    /// Anything else (the session reports it).
    Other(anyhow::Error),
}

impl Session {
    /// Uploads the first entries, one slot each, as far as the device's
    /// slots and library memory go; the rest stay on the host until
    /// presented or prepared.
    pub(super) fn preload(&mut self) -> anyhow::Result<()> {
        let n = self.loaded.len().min(usize::from(self.info.slots));
        // A stop is looked at between entries (an upload stops between
        // its frames by itself): nothing half-uploaded is committed, and
        // the device was stopped before the first.
        for i in 0..n {
            let loaded = (!crate::stop::requested()).then(|| self.load_into(i, i as u8));
            match loaded {
                Some(Ok(())) => {}
                // What fits is resident; the others load on demand.
                Some(Err(LoadError::Full)) => break,
                Some(Err(LoadError::Other(e))) if !crate::stop::requested() => return Err(e),
                // A stop asked before this entry, or one that cut its
                // upload short.
                _ => {
                    let id = &self.loaded[i].id;
                    let doing = format!("uploading stimulus `{id}`, {} of {n}", i + 1);
                    return Err(crate::stop::SetUpInterrupted::new(doing).into());
                }
            }
        }
        Ok(())
    }

    /// Uploads entry `i` into `slot`, which no longer holds the entry it
    /// held (`preloaded`, naming it as `evicted`).
    fn load_into(&mut self, i: usize, slot: u8) -> Result<(), LoadError> {
        let t0 = self.clock.now_us();
        let r = match self.dev.upload(&self.loaded[i].planned.plan, Some(slot)) {
            Ok(r) => r,
            Err(e) if e.refusal() == Some(NackCode::LibraryFull) => return Err(LoadError::Full),
            Err(e) => {
                let e: BackendError = e;
                return Err(LoadError::Other(
                    e.context(format!("uploading stimulus `{}`", self.loaded[i].id))
                        .into(),
                ));
            }
        };
        let mut evicted = None;
        for (j, l) in self.loaded.iter_mut().enumerate() {
            if l.slot == Some(r.slot) && j != i {
                l.slot = None;
                evicted = Some(l.id.clone());
            }
        }
        self.loaded[i].slot = Some(r.slot);
        let mut evicted: Vec<String> = evicted.into_iter().collect();
        evicted.append(&mut self.shrunk);
        let kind = EventKind::Preloaded {
            stimulus: self.loaded[i].id.clone(),
            slot: r.slot,
            seconds: self.clock.now_us().saturating_sub(t0) as f64 / 1e6,
            wire_bytes: r.wire().map(|w| w.wire_bytes_sent),
            readback_mismatches: r.readback_mismatches(),
            evicted,
        };
        self.emit(kind);
        Ok(())
    }

    /// Marks entry `i` used now (least recently used goes first).
    pub(super) fn touch(&mut self, i: usize) {
        self.loaded[i].used_us = self.clock.now_us();
    }

    /// Makes entry `i` resident (a no-op when it is) in a slot that
    /// neither plays nor waits: a slot holding no entry of the library
    /// first, else in place of the idle entries, least recently used
    /// first, until the device's memory takes it.
    pub(super) fn ensure_loaded(&mut self, i: usize) -> anyhow::Result<u8> {
        if let Some(s) = self.loaded[i].slot {
            return Ok(s);
        }
        let busy = self.stage.busy_slots();
        let holder = |s: u8| self.loaded.iter().position(|l| l.slot == Some(s));
        let free: Vec<u8> = (0..self.info.slots).filter(|s| !busy.contains(s)).collect();
        // Slots of no entry: one try (they hold nothing of ours, perhaps an
        // earlier session's entries); then the idle entries' slots, least
        // recently used first; then the other empty slots.
        let (empty, mut idle): (Vec<u8>, Vec<u8>) =
            free.iter().partition(|&&s| holder(s).is_none());
        idle.sort_by_key(|&s| holder(s).map_or(0, |h| self.loaded[h].used_us));
        let order: Vec<u8> = empty
            .iter()
            .take(1)
            .chain(&idle)
            .chain(empty.iter().skip(1))
            .copied()
            .collect();
        let id = super::protocol::clip(&self.loaded[i].id);
        if order.is_empty() {
            return Err(InputError::new(format!(
                "stimulus `{id}` cannot be loaded now: every slot of the device plays or waits to play"
            ))
            .into());
        }
        for &slot in &order {
            match self.load_into(i, slot) {
                Ok(()) => return Ok(slot),
                Err(LoadError::Full) => continue,
                Err(LoadError::Other(e)) => return Err(e),
            }
        }
        // No single idle entry makes room: the next ones, least recently
        // used first, shrink to a placeholder until it fits in place of
        // the first.
        if let Some((&target, rest)) = idle.split_first() {
            for &slot in rest {
                self.shrink(slot)?;
                match self.load_into(i, target) {
                    Ok(()) => return Ok(target),
                    Err(LoadError::Full) => continue,
                    Err(LoadError::Other(e)) => return Err(e),
                }
            }
        }
        // What was shrunk is on the host now (the `library` command says
        // so); the refusal names what keeps the room.
        self.shrunk.clear();
        let resident: Vec<&str> = self
            .loaded
            .iter()
            .filter(|l| l.slot.is_some_and(|s| busy.contains(&s)))
            .map(|l| l.id.as_str())
            .collect();
        Err(anyhow::anyhow!(
            "stimulus `{id}` does not fit the device's library memory, not even in place of an idle entry{}",
            if resident.is_empty() {
                String::new()
            } else {
                format!(" (beside `{}`, which play or wait)", resident.join("`, `"))
            }
        ))
    }
}

impl Session {
    /// Frees most of `slot`'s memory: its entry is overwritten by the
    /// first step of its own plan (a valid one-step sequence, never
    /// played) and is on the host only from now on.
    fn shrink(&mut self, slot: u8) -> anyhow::Result<()> {
        let Some(h) = self.loaded.iter().position(|l| l.slot == Some(slot)) else {
            return Ok(());
        };
        let mut plan = self.loaded[h].planned.plan.clone();
        let hd = &mut plan.sequence.header;
        let t = usize::from(hd.transducers);
        hd.period_us = hd.period_us.div_ceil(u32::from(hd.steps.max(1)));
        hd.steps = 1;
        plan.sequence.phases.truncate(t);
        self.dev
            .upload(&plan, Some(slot))
            .map_err(|e| e.context(format!("freeing slot {slot}")))?;
        self.loaded[h].slot = None;
        let id = self.loaded[h].id.clone();
        self.shrunk.push(id);
        Ok(())
    }
}

impl LibraryItem {
    /// An entry as the `library` command lists it.
    pub(super) fn of(l: &Loaded) -> Self {
        Self {
            id: l.id.clone(),
            slot: l.slot,
            gate: if l.untracked {
                Gate::Untracked
            } else {
                Gate::Tracked
            },
            timing: l.planned.timing.clone(),
            foci: l.planned.plan.trajectory.foci,
            radius_mm: l.stimulus.cycle.radius_mm,
            crc32: l.crc32,
        }
    }
}

/// The library's entries with their plans, none resident yet.
pub(super) fn entries(
    library: &crate::plan::library::Library,
    plans: Vec<TargetPlan>,
) -> Vec<Loaded> {
    library
        .entries
        .iter()
        .zip(plans)
        .map(|(e, planned)| Loaded {
            id: e.id.clone(),
            crc32: planned.plan.sequence.crc32(),
            stimulus: e.stimulus.clone(),
            planned,
            untracked: e.untracked,
            slot: None,
            used_us: 0,
        })
        .collect()
}
