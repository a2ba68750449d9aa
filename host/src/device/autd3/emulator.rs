//! `autd3:emulator`: autd3's own CPU + FPGA firmware emulator as a link.
//!
//! `autd3::link::Audit` wraps the same emulator but always runs it at
//! system time zero, so its STM never advances and segment swaps never
//! happen. This link drives the emulated devices from a [`Clock`], and
//! shares them through an [`EmulatorHandle`] so the backend (and tests) can
//! read the FPGA memory back: STM phases per segment and index, the phase
//! correction table, the modulation, the silencer, the playing segment.
//! The link can be broken after a number of frames to test failed uploads,
//! and can damage one phase of the next GainSTM upload on its way to the
//! devices (a transfer fault only a read-back finds).

use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use autd3::core::ethercat::DcSysTime;
use autd3::core::geometry::Geometry;
use autd3::core::link::{Link, LinkError, RxMessage, TxBufferPoolSync, TxMessage};
use autd3_firmware_emulator::CPUEmulator;

use crate::clock::Clock;

#[derive(Default)]
struct State {
    cpus: Vec<CPUEmulator>,
    /// Frames delivered so far.
    frames: u64,
    /// Fail every send once `frames` reaches this.
    break_at: Option<u64>,
    /// Flip a bit of the first phase of the next GainSTM upload.
    damage_stm: bool,
    /// The devices' time at their last update (ns of `DcSysTime`).
    updated_ns: u64,
}

impl State {
    /// Brings every device to `t`. A real FPGA runs continuously; the
    /// emulator acts at the times it is updated, so a `SysTime` segment
    /// switch that falls between two updates is first played out at its
    /// own time (else a clock that jumped would switch late).
    fn update_to(&mut self, t: DcSysTime) {
        const TRANSITION_MODE_SYS_TIME: u8 = 0x01;
        let last = self.updated_ns;
        for cpu in self.cpus.iter_mut() {
            let f = cpu.fpga();
            let mut due: Vec<u64> = [f.modulation_transition_mode(), f.stm_transition_mode()]
                .into_iter()
                .filter(|m| m.mode == TRANSITION_MODE_SYS_TIME)
                .map(|m| m.value)
                .filter(|&v| v > last && v < t.sys_time())
                .collect();
            due.sort_unstable();
            for v in due {
                cpu.update_with_sys_time(DcSysTime::new(v));
            }
            cpu.update_with_sys_time(t);
        }
        self.updated_ns = self.updated_ns.max(t.sys_time());
    }
}

/// autd3 firmware's message tag of a GainSTM write, and its flag of the
/// first message of one (whose 16-byte head precedes the phases).
const TAG_GAIN_STM: u8 = 0x41;
const GAIN_STM_FLAG_BEGIN: u8 = 1 << 0;
const GAIN_STM_HEAD_BYTES: usize = 16;

/// Shared access to the emulated devices.
#[derive(Clone)]
pub struct EmulatorHandle {
    state: Arc<Mutex<State>>,
    clock: Clock,
}

impl EmulatorHandle {
    fn lock(&self) -> MutexGuard<'_, State> {
        // A panic while holding the lock leaves plain data; keep using it.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Runs `f` on the emulated devices after bringing them to the clock's time.
    pub fn with_cpus<R>(&self, f: impl FnOnce(&[CPUEmulator]) -> R) -> R {
        let mut s = self.lock();
        s.update_to(sys_time(self.clock.now()));
        f(&s.cpus)
    }

    /// Frames the link has delivered (one frame carries one message per device).
    pub fn frames(&self) -> u64 {
        self.lock().frames
    }

    /// Makes every send fail once `frames` frames have been delivered
    /// (`None` repairs the link).
    pub fn break_after(&self, frames: Option<u64>) {
        let mut s = self.lock();
        s.break_at = frames.map(|n| s.frames + n);
    }

    /// Damages the next GainSTM upload on its way: the first board gets
    /// the first transducer's phase of the first pattern with one bit
    /// flipped, as a transfer fault would (the upload itself succeeds).
    pub fn damage_next_stm_upload(&self) {
        self.lock().damage_stm = true;
    }

    /// The clock the devices run on.
    pub fn clock(&self) -> &Clock {
        &self.clock
    }
}

/// The emulator as an autd3 [`Link`].
pub struct EmulatorLink {
    handle: EmulatorHandle,
    pool: TxBufferPoolSync,
    open: bool,
}

/// EtherCAT DC system time for a clock reading.
pub fn sys_time(t: Duration) -> DcSysTime {
    DcSysTime::ZERO + t
}

impl EmulatorLink {
    /// A link on `clock`, and the handle to its devices.
    pub fn new(clock: Clock) -> (Self, EmulatorHandle) {
        let handle = EmulatorHandle {
            state: Arc::default(),
            clock,
        };
        (
            Self {
                handle: handle.clone(),
                pool: TxBufferPoolSync::new(),
                open: false,
            },
            handle,
        )
    }
}

impl Link for EmulatorLink {
    fn open(&mut self, geometry: &Geometry) -> Result<(), LinkError> {
        let mut s = self.handle.lock();
        s.cpus = geometry
            .iter()
            .enumerate()
            .map(|(i, d)| CPUEmulator::new(i, d.num_transducers()))
            .collect();
        self.pool.init(geometry);
        self.open = true;
        Ok(())
    }

    fn close(&mut self) -> Result<(), LinkError> {
        self.open = false;
        Ok(())
    }

    fn alloc_tx_buffer(&mut self) -> Result<Vec<TxMessage>, LinkError> {
        Ok(self.pool.borrow())
    }

    fn send(&mut self, mut tx: Vec<TxMessage>) -> Result<(), LinkError> {
        let mut s = self.handle.lock();
        if s.break_at.is_some_and(|n| s.frames >= n) {
            self.pool.return_buffer(tx);
            return Err(LinkError::new("emulated link is broken"));
        }
        if s.damage_stm
            && let Some(p) = tx.first_mut().map(TxMessage::payload_mut)
            && p.len() > GAIN_STM_HEAD_BYTES
            && p[0] == TAG_GAIN_STM
            && p[1] & GAIN_STM_FLAG_BEGIN != 0
        {
            p[GAIN_STM_HEAD_BYTES] ^= 0x10;
            s.damage_stm = false;
        }
        s.update_to(sys_time(self.handle.clock.now()));
        for cpu in s.cpus.iter_mut() {
            cpu.send(&tx);
        }
        s.frames += 1;
        drop(s);
        self.pool.return_buffer(tx);
        Ok(())
    }

    fn receive(&mut self, rx: &mut [RxMessage]) -> Result<(), LinkError> {
        let mut s = self.handle.lock();
        if s.break_at.is_some_and(|n| s.frames >= n) {
            return Err(LinkError::new("emulated link is broken"));
        }
        s.update_to(sys_time(self.handle.clock.now()));
        for cpu in s.cpus.iter_mut() {
            if let Some(r) = rx.get_mut(cpu.idx()) {
                *r = cpu.rx();
            }
        }
        Ok(())
    }

    fn is_open(&self) -> bool {
        self.open
    }
}
