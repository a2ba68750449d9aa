//! SPI1 to the transducer driver, by DMA, off the serve loop's time.
//!
//! [`DriverOutput`] is the core's `OutputDriver` on this board. Its
//! `write_frame` packs the frame into a buffer in the AXI SRAM, cleans the
//! D-cache over it and hands it to the SPI task (on the highest-priority
//! interrupt executor, src/main.rs), which lowers chip select, sends the
//! bytes with DMA1 and raises chip select (the driver's latch strobe,
//! `firmware/DRIVER.md`) as soon as the last bit is out. `write_frame`
//! returns at once: the serve loop reads the host link while the frame
//! goes out (about 0.5 ms for 996 transducers at 16 MHz). The next frame
//! waits for the previous one, so there is at most one in flight.
//!
//! [`DriverOutput::spi_loopback`] is the board's self-test: with a wire
//! from MOSI to MISO it sends `selftest::LOOPBACK_BYTES` of a known pattern
//! with chip select held high (the driver ignores the bus) and compares
//! what comes back.
//!
//! Coherence: the buffers are ordinary cacheable AXI SRAM (D-cache
//! write-back, write-allocate). Before the DMA reads the frame, the lines
//! it covers are cleaned; the loopback's receive buffer is invalidated
//! before the DMA writes it and again before the CPU reads it (a
//! speculative read may have pulled a line in meanwhile). Both buffers are
//! 32-byte aligned and whole lines long, so no maintenance reaches a
//! neighbour (`mem::AxiBytes`).

use core::sync::atomic::{AtomicBool, AtomicU8, Ordering};

use cortex_m::peripheral::SCB;
use embassy_executor::SendSpawner;
use embassy_stm32::gpio::Output;
use embassy_stm32::mode::Async;
use embassy_stm32::spi::Spi;
use embassy_stm32::spi::mode::Master;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::signal::Signal;
use embassy_time::{Duration, Instant};
use lm_fw_core::{OutputDriver, OutputFrame};
use lm_fw_nucleo_h743_logic::frame::{self, FRAME_BUFFER_BYTES};
use lm_fw_nucleo_h743_logic::selftest::{CHUNK, LOOPBACK_BYTES, LoopbackReport, Pattern};

use crate::mem::AxiBytes;

/// The frame (and loopback transmit) buffer.
#[unsafe(link_section = ".axisram.spi")]
static TX_BUF: AxiBytes<FRAME_BUFFER_BYTES> = AxiBytes::new();
/// The loopback receive buffer.
#[unsafe(link_section = ".axisram.spi")]
static RX_BUF: AxiBytes<CHUNK> = AxiBytes::new();

/// Set by the thread when it hands a job over, cleared by the SPI task when
/// the job is done: the buffers belong to whoever this says.
static BUSY: AtomicBool = AtomicBool::new(false);
/// The last job's outcome (`Outcome as u8`), until `wait_idle` takes it.
static OUTCOME: AtomicU8 = AtomicU8::new(Outcome::Done as u8);
/// The job for the SPI task.
static JOB: Signal<CriticalSectionRawMutex, Job> = Signal::new();
/// `DriverOutput::new` ran.
static CLAIMED: AtomicBool = AtomicBool::new(false);

/// The longest a job may take: 1056 bytes at 16 MHz are 0.53 ms.
const JOB_PATIENCE: Duration = Duration::from_millis(10);

#[derive(Debug, Clone, Copy)]
enum Job {
    /// Send `TX_BUF[..len]` with chip select low.
    Frame { len: usize },
    /// Exchange `TX_BUF[..len]` for `RX_BUF[..len]`, chip select high.
    Loopback { len: usize },
}

#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outcome {
    Done = 0,
    Failed = 1,
}

/// Why a frame did not go out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum SpiFault {
    /// More phases than the buffer holds (more than
    /// `lm_fw_core::MAX_TRANSDUCERS`).
    TooLong,
    /// The previous transfer reported an error.
    Transfer,
    /// The previous transfer did not finish in time; nothing more is sent.
    Stuck,
}

/// The transducer driver on SPI1 (see the module comment).
pub struct DriverOutput {
    scb: SCB,
    stuck: bool,
}

impl DriverOutput {
    /// Zeroes the DMA buffers and spawns the SPI task on `spawner`; once.
    pub fn new(
        spi: Spi<'static, Async, Master>,
        cs: Output<'static>,
        spawner: SendSpawner,
        mut scb: SCB,
    ) -> Self {
        if CLAIMED.swap(true, Ordering::AcqRel) {
            panic!("DriverOutput::new called twice");
        }
        // SAFETY: the task that shares these buffers is spawned below, so
        // nothing else touches them yet; the writes stay inside the statics.
        unsafe {
            TX_BUF.as_mut_ptr().write_bytes(0, FRAME_BUFFER_BYTES);
            RX_BUF.as_mut_ptr().write_bytes(0, CHUNK);
        }
        // No dirty line of either buffer may be evicted over DMA data later.
        scb.clean_dcache_by_address(TX_BUF.as_mut_ptr() as usize, FRAME_BUFFER_BYTES);
        scb.clean_dcache_by_address(RX_BUF.as_mut_ptr() as usize, CHUNK);
        spawner.spawn(spi_task(spi, cs).unwrap_or_else(|_| panic!("SPI task")));
        Self { scb, stuck: false }
    }

    /// Waits for the job in flight; the previous job's outcome.
    fn wait_idle(&mut self) -> Result<(), SpiFault> {
        if self.stuck {
            return Err(SpiFault::Stuck);
        }
        if BUSY.load(Ordering::Acquire) {
            let deadline = Instant::now() + JOB_PATIENCE;
            while BUSY.load(Ordering::Acquire) {
                if Instant::now() > deadline {
                    self.stuck = true;
                    defmt::error!("SPI1: a transfer did not finish; output stopped");
                    return Err(SpiFault::Stuck);
                }
            }
        }
        // Taken, so that each job's outcome is reported once.
        match OUTCOME.swap(Outcome::Done as u8, Ordering::Relaxed) {
            x if x == Outcome::Done as u8 => Ok(()),
            _ => Err(SpiFault::Transfer),
        }
    }

    fn start(job: Job) {
        BUSY.store(true, Ordering::Release);
        JOB.signal(job);
    }

    /// The loopback self-test (needs the MOSI-MISO wire): sends
    /// [`LOOPBACK_BYTES`] of the pattern in passes of [`CHUNK`] with the
    /// driver's chip select high, compares every byte read back. About
    /// 2 ms at 16 MHz; frames wait meanwhile.
    pub fn spi_loopback(&mut self) -> LoopbackReport {
        let mut report = LoopbackReport::new();
        let mut pattern = Pattern::new();
        for _ in 0..LOOPBACK_BYTES / CHUNK {
            if self.wait_idle() == Err(SpiFault::Stuck) {
                break;
            }
            let (tx, rx) = (TX_BUF.as_mut_ptr(), RX_BUF.as_mut_ptr());
            {
                // SAFETY: the task is idle (BUSY false, read with acquire),
                // so the thread alone uses TX_BUF until it hands the job
                // over; CHUNK <= FRAME_BUFFER_BYTES (checked in the logic
                // crate).
                let sent = unsafe { core::slice::from_raw_parts_mut(tx, CHUNK) };
                pattern.fill(sent);
            }
            self.scb.clean_dcache_by_address(tx as usize, CHUNK);
            // SAFETY: RX_BUF is 32-byte aligned and CHUNK long (whole lines),
            // so this discards only its own lines; its contents are about
            // to be overwritten by the DMA.
            unsafe { self.scb.invalidate_dcache_by_address(rx as usize, CHUNK) };
            Self::start(Job::Loopback { len: CHUNK });
            let outcome = self.wait_idle();
            if outcome == Err(SpiFault::Stuck) {
                break;
            }
            // SAFETY: as above: lines of RX_BUF only, now written by DMA.
            unsafe { self.scb.invalidate_dcache_by_address(rx as usize, CHUNK) };
            // SAFETY: the job is done (BUSY false, acquire): the thread alone
            // reads both buffers until the next hand-over.
            let (sent, got) = unsafe {
                (
                    core::slice::from_raw_parts(tx, CHUNK),
                    core::slice::from_raw_parts(rx, CHUNK),
                )
            };
            // A failed transfer read nothing: every byte of it counts.
            report.check(sent, if outcome.is_ok() { got } else { &[] });
        }
        report
    }
}

impl OutputDriver for DriverOutput {
    /// Reported one frame late: `write_frame` returns before the transfer
    /// ends, so an error of frame n shows at frame n + 1.
    type Error = SpiFault;

    fn write_frame(&mut self, frame: &OutputFrame<'_>) -> Result<(), SpiFault> {
        let previous = self.wait_idle();
        if previous == Err(SpiFault::Stuck) {
            return previous;
        }
        let tx = TX_BUF.as_mut_ptr();
        // SAFETY: the task is idle (wait_idle saw BUSY false with acquire),
        // so the thread alone uses TX_BUF until `start`.
        let buf = unsafe { core::slice::from_raw_parts_mut(tx, FRAME_BUFFER_BYTES) };
        let Some(len) = frame::pack(buf, frame) else {
            return Err(SpiFault::TooLong);
        };
        self.scb
            .clean_dcache_by_address(tx as usize, frame::whole_lines(len));
        Self::start(Job::Frame { len });
        previous
    }

    /// The protocol's `SelfTest` (the core asks only while nothing plays):
    /// the same loopback as at boot, its report as the host reads it.
    fn self_test(&mut self) -> lm_proto::SelfTest {
        self.spi_loopback().into()
    }
}

/// Runs the jobs `DriverOutput` hands over, one at a time.
#[embassy_executor::task]
async fn spi_task(mut spi: Spi<'static, Async, Master>, mut cs: Output<'static>) -> ! {
    loop {
        let job = JOB.wait().await;
        let result = match job {
            Job::Frame { len } => {
                // SAFETY: BUSY is set (the thread stored it with release
                // before signalling), so the thread does not touch TX_BUF
                // until this job ends; `len` <= FRAME_BUFFER_BYTES (pack).
                let bytes = unsafe { core::slice::from_raw_parts(TX_BUF.as_mut_ptr(), len) };
                cs.set_low();
                let r = spi.write(bytes).await;
                cs.set_high();
                r
            }
            Job::Loopback { len } => {
                drain_rx();
                // SAFETY: as above, for both buffers; `len` is CHUNK, the
                // receive buffer's size and at most the transmit buffer's.
                let (tx, rx) = unsafe {
                    (
                        core::slice::from_raw_parts(TX_BUF.as_mut_ptr(), len),
                        core::slice::from_raw_parts_mut(RX_BUF.as_mut_ptr(), len),
                    )
                };
                spi.transfer(rx, tx).await
            }
        };
        if let Err(e) = result {
            defmt::warn!("SPI1: {} failed: {}", job, e);
        }
        let outcome = match result {
            Ok(()) => Outcome::Done,
            Err(_) => Outcome::Failed,
        };
        OUTCOME.store(outcome as u8, Ordering::Relaxed);
        BUSY.store(false, Ordering::Release);
    }
}

/// Empties SPI1's receive side before a loopback. The frames before it were
/// sent without reading (the HAL's DMA write only transmits), so the
/// receive FIFO may still hold their last bytes and OVR may be set; either
/// would shift or stop what the loopback reads. Raw registers: the HAL has
/// no call for it. RM0433 "Serial peripheral interface", SPI_SR.RXP, SPI_RXDR and
/// SPI_IFCR; SPI1 is
/// disabled between transfers (the HAL clears SPE after each), and its
/// task alone touches it.
fn drain_rx() {
    use embassy_stm32::pac;
    let spi = pac::SPI1;
    while spi.sr().read().rxp() {
        let _ = spi.rxdr32().read();
    }
    spi.ifcr().write(|w| w.0 = 0xFFFF_FFFF);
}

impl defmt::Format for Job {
    fn format(&self, f: defmt::Formatter<'_>) {
        match self {
            Job::Frame { len } => defmt::write!(f, "frame of {=usize} bytes", len),
            Job::Loopback { len } => defmt::write!(f, "loopback of {=usize} bytes", len),
        }
    }
}

/// After a panic or a fault: stops SPI1 and raises the driver's chip
/// select, so the driver sees no more frames and, 100 ms later, silences
/// its outputs (`firmware/DRIVER.md`, "Faults").
///
/// Raw registers: the HAL's drivers are owned by tasks that will not run
/// again. RM0433, SPI_CR1.SPE and GPIOx_BSRR.
pub fn silence() {
    use embassy_stm32::pac;
    pac::SPI1.cr1().modify(|w| w.set_spe(false));
    pac::GPIOD.bsrr().write(|w| w.set_bs(14, true));
}
