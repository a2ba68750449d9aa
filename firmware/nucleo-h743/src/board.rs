//! Peripheral setup for the Nucleo-H743ZI(2), straight on the `stm32h7` PAC.
//!
//! Clocks stay at their reset values: HSI 64 MHz, all bus prescalers 1, so
//! USART3's kernel clock (pclk1), TIM2's clock and SPI1's kernel clock
//! (per_ck = HSI) are all 64 MHz. The player needs no more than that.

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicUsize, Ordering};

use embedded_hal::spi::{self, ErrorKind, Operation, SpiDevice};
use stm32h7::stm32h743v as pac;

/// Kernel clock of USART3, TIM2 and SPI1 after reset (HSI).
pub const KERNEL_HZ: u32 = 64_000_000;
/// TIM2 count rate: the player's clock.
pub const TIMER_HZ: u32 = 1_000_000;
/// Baud rate of the ST-LINK virtual COM port link: lmhost's default.
pub const BAUD: u32 = 115_200;

/// The board's peripherals, set up.
pub struct Board {
    /// USART3 on PD8 (TX) / PD9 (RX): the ST-LINK virtual COM port.
    pub uart: Uart,
    /// TIM2, free-running 32-bit at [`TIMER_HZ`].
    pub timer: Timer,
    /// SPI1 (PA5 SCK, PA6 MISO, PB5 MOSI; PD14 chip select = Arduino D13/D12/D11/D10).
    pub spi: Spi1,
}

/// Alternate-function mode for one pin: MODER = 0b10, AFR = `af`.
macro_rules! alt_fn {
    ($gpio:expr, $pin:expr, $af:expr) => {{
        let (pin, af): (u32, u32) = ($pin, $af);
        $gpio
            .moder()
            .modify(|r, w| unsafe { w.bits((r.bits() & !(3 << (2 * pin))) | (2 << (2 * pin))) });
        $gpio
            .ospeedr()
            .modify(|r, w| unsafe { w.bits(r.bits() | (3 << (2 * pin))) });
        if pin < 8 {
            $gpio.afrl().modify(|r, w| unsafe {
                w.bits((r.bits() & !(0xF << (4 * pin))) | (af << (4 * pin)))
            });
        } else {
            let p = pin - 8;
            $gpio
                .afrh()
                .modify(|r, w| unsafe { w.bits((r.bits() & !(0xF << (4 * p))) | (af << (4 * p))) });
        }
    }};
}

impl Board {
    /// Enables the clocks and configures pins, USART3, TIM2 and SPI1.
    pub fn init(dp: pac::Peripherals) -> Board {
        let rcc = &dp.RCC;
        rcc.ahb4enr().modify(|_, w| {
            w.gpioaen()
                .set_bit()
                .gpioben()
                .set_bit()
                .gpioden()
                .set_bit()
        });
        rcc.apb1lenr()
            .modify(|_, w| w.usart3en().set_bit().tim2en().set_bit());
        rcc.apb2enr().modify(|_, w| w.spi1en().set_bit());
        // SPI1's kernel clock resets to PLL1Q, which is off: use per_ck (HSI).
        rcc.d2ccip1r()
            .modify(|_, w| unsafe { w.spi123sel().bits(4) });
        let _ = rcc.apb2enr().read(); // let the enables settle before touching the blocks

        // USART3: PD8 TX, PD9 RX, AF7.
        alt_fn!(dp.GPIOD, 8, 7);
        alt_fn!(dp.GPIOD, 9, 7);
        // SPI1: PA5 SCK, PA6 MISO, PB5 MOSI, AF5; PD14 chip select, push-pull, idle high.
        alt_fn!(dp.GPIOA, 5, 5);
        alt_fn!(dp.GPIOA, 6, 5);
        alt_fn!(dp.GPIOB, 5, 5);
        dp.GPIOD.bsrr().write(|w| unsafe { w.bits(1 << 14) });
        dp.GPIOD
            .moder()
            .modify(|r, w| unsafe { w.bits((r.bits() & !(3 << 28)) | (1 << 28)) });

        let usart = dp.USART3;
        usart.cr1().write(|w| w.ue().clear_bit());
        usart
            .brr()
            .write(|w| unsafe { w.bits(KERNEL_HZ.div_ceil(BAUD)) });
        usart.cr1().write(|w| {
            w.fifoen()
                .set_bit()
                .te()
                .set_bit()
                .re()
                .set_bit()
                .ue()
                .set_bit()
        });

        let tim = dp.TIM2;
        tim.cr1().write(|w| w.cen().clear_bit());
        tim.psc()
            .write(|w| unsafe { w.bits(KERNEL_HZ / TIMER_HZ - 1) });
        tim.arr().write(|w| unsafe { w.bits(u32::MAX) });
        tim.egr().write(|w| w.ug().set_bit()); // load PSC now
        tim.cr1().write(|w| w.cen().set_bit());

        let spi = dp.SPI1;
        spi.cr1().write(|w| w.spe().clear_bit());
        // 8-bit frames, kernel clock / 4, mode 0, software chip select.
        spi.cfg1()
            .write(|w| unsafe { w.dsize().bits(7).mbr().bits(1) });
        spi.cfg2()
            .write(|w| w.master().set_bit().ssm().set_bit().afcntr().set_bit());
        spi.cr1().write(|w| w.ssi().set_bit());
        spi.cr1().write(|w| w.ssi().set_bit().spe().set_bit());
        spi.cr1()
            .write(|w| w.ssi().set_bit().spe().set_bit().cstart().set_bit());

        Board {
            uart: Uart {
                usart,
                tx: [0; TX_RING],
                head: 0,
                tail: 0,
            },
            timer: Timer(tim),
            spi: Spi1 {
                spi,
                gpiod: dp.GPIOD,
            },
        }
    }
}

/// USART3's transmit side (reception runs in [`usart3_rx_isr`]).
///
/// Replies are queued and [`pump`](Uart::pump)ed from the main loop, so a
/// reply (4 ms for a status frame at 115 200 Bd) never holds up a step.
pub struct Uart {
    usart: pac::USART3,
    tx: [u8; TX_RING],
    head: usize,
    tail: usize,
}

/// Bytes of queued replies: many small responses.
const TX_RING: usize = 1024;

impl Uart {
    /// Queues `bytes` for sending; only waits if the queue is full.
    pub fn queue(&mut self, bytes: &[u8]) {
        for &b in bytes {
            while self.head.wrapping_sub(self.tail) >= TX_RING {
                self.pump();
            }
            self.tx[self.head % TX_RING] = b;
            self.head = self.head.wrapping_add(1);
        }
        self.pump();
    }

    /// Moves queued bytes into the transmit FIFO while it has room.
    pub fn pump(&mut self) {
        while self.tail != self.head && self.usart.isr().read().txe().bit_is_set() {
            let b = self.tx[self.tail % TX_RING];
            self.usart.tdr().write(|w| unsafe { w.bits(u32::from(b)) });
            self.tail = self.tail.wrapping_add(1);
        }
    }
}

/// Bytes the receive ring holds: more than one full frame, so a long SPI
/// frame or step never makes the UART overrun.
const RX_RING: usize = 4096;

/// Single-producer (the USART3 interrupt) single-consumer (the main loop)
/// byte ring.
pub struct RxRing {
    buf: UnsafeCell<[u8; RX_RING]>,
    head: AtomicUsize,
    tail: AtomicUsize,
    dropped: AtomicUsize,
}

// SAFETY: `push` runs only in the USART3 interrupt and `pop_into` only in
// the main loop; each index is written by one side only, and a byte is
// published (Release) before the other side may read it (Acquire).
unsafe impl Sync for RxRing {}

/// Received bytes, filled by [`usart3_rx_isr`].
pub static RX: RxRing = RxRing {
    buf: UnsafeCell::new([0; RX_RING]),
    head: AtomicUsize::new(0),
    tail: AtomicUsize::new(0),
    dropped: AtomicUsize::new(0),
};

impl RxRing {
    fn push(&self, b: u8) {
        let head = self.head.load(Ordering::Relaxed);
        if head.wrapping_sub(self.tail.load(Ordering::Acquire)) >= RX_RING {
            // Full: the frame decoder will see the damage and count it.
            self.dropped.fetch_add(1, Ordering::Relaxed);
            return;
        }
        // SAFETY: slot `head` is not readable by the consumer until published.
        unsafe { (*self.buf.get())[head % RX_RING] = b };
        self.head.store(head.wrapping_add(1), Ordering::Release);
    }

    /// Moves received bytes into `out`; returns how many.
    pub fn pop_into(&self, out: &mut [u8]) -> usize {
        let head = self.head.load(Ordering::Acquire);
        let mut tail = self.tail.load(Ordering::Relaxed);
        let mut n = 0;
        while tail != head && n < out.len() {
            // SAFETY: slots between tail and head are published and not written.
            out[n] = unsafe { (*self.buf.get())[tail % RX_RING] };
            tail = tail.wrapping_add(1);
            n += 1;
        }
        self.tail.store(tail, Ordering::Release);
        n
    }
}

/// USART3 receive interrupt body: drains the receive FIFO into [`RX`] and
/// clears overrun/framing/noise errors so reception continues.
pub fn usart3_rx_isr() {
    // SAFETY: the interrupt only reads ISR/RDR and writes ICR; the main loop
    // only reads ISR.TXE and writes TDR. These accesses do not interfere.
    let usart = unsafe { pac::USART3::steal() };
    loop {
        let isr = usart.isr().read();
        if isr.ore().bit_is_set() || isr.fe().bit_is_set() || isr.nf().bit_is_set() {
            usart.icr().write(|w| {
                w.orecf()
                    .clear_bit_by_one()
                    .fecf()
                    .clear_bit_by_one()
                    .ncf()
                    .clear_bit_by_one()
            });
        }
        if isr.rxne().bit_is_clear() {
            break;
        }
        RX.push(usart.rdr().read().bits() as u8);
    }
}

/// TIM2 counting up at [`TIMER_HZ`], wrapping every 2^32 counts (71 min).
pub struct Timer(pac::TIM2);

impl Timer {
    /// The current count.
    pub fn now(&self) -> u32 {
        self.0.cnt().read().bits()
    }
}

/// SPI1 as an embedded-hal [`SpiDevice`]: chip select PD14 is held low for
/// the whole transaction; full duplex, byte by byte through the FIFOs.
pub struct Spi1 {
    spi: pac::SPI1,
    gpiod: pac::GPIOD,
}

/// Bytes in flight at most: the H743's SPI1 FIFO holds 16.
const FIFO_DEPTH: usize = 8;

impl Spi1 {
    /// Clocks `tx` out (0xFF after its end) and what comes back into `rx`
    /// (if given), `len` bytes in all.
    fn exchange(&mut self, len: usize, tx: &[u8], mut rx: Option<&mut [u8]>) {
        let (mut sent, mut got) = (0, 0);
        while got < len {
            let sr = self.spi.sr().read();
            if sent < len && sent - got < FIFO_DEPTH && sr.txp().bit_is_set() {
                let b = tx.get(sent).copied().unwrap_or(0xFF);
                self.spi.txdr8().write(|w| unsafe { w.txdr().bits(b) });
                sent += 1;
            }
            if sr.rxp().bit_is_set() {
                let b = self.spi.rxdr8().read().rxdr().bits();
                if let Some(slot) = rx.as_deref_mut().and_then(|r| r.get_mut(got)) {
                    *slot = b;
                }
                got += 1;
            }
        }
    }

    fn transfer_in_place(&mut self, buf: &mut [u8]) {
        // Each byte is read back before the FIFO can run FIFO_DEPTH ahead,
        // so exchanging chunk by chunk through a small copy is enough.
        for chunk in buf.chunks_mut(FIFO_DEPTH) {
            let mut tx = [0u8; FIFO_DEPTH];
            tx[..chunk.len()].copy_from_slice(chunk);
            self.exchange(chunk.len(), &tx[..chunk.len()], Some(chunk));
        }
    }
}

impl spi::ErrorType for Spi1 {
    type Error = ErrorKind;
}

impl SpiDevice for Spi1 {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), ErrorKind> {
        self.gpiod
            .bsrr()
            .write(|w| unsafe { w.bits(1 << (14 + 16)) }); // CS low
        for op in operations {
            match op {
                Operation::Write(data) => self.exchange(data.len(), data, None),
                Operation::Read(buf) => {
                    let len = buf.len();
                    self.exchange(len, &[], Some(buf));
                }
                Operation::Transfer(read, write) => {
                    let len = read.len().max(write.len());
                    self.exchange(len, write, Some(read));
                }
                Operation::TransferInPlace(buf) => self.transfer_in_place(buf),
                Operation::DelayNs(ns) => cortex_m::asm::delay(
                    (u64::from(*ns) * u64::from(KERNEL_HZ / 1_000_000) / 1000) as u32 + 1,
                ),
            }
        }
        while self.spi.sr().read().txc().bit_is_clear() {}
        self.gpiod.bsrr().write(|w| unsafe { w.bits(1 << 14) }); // CS high
        Ok(())
    }
}
