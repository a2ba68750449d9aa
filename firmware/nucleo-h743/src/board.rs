//! Peripheral setup for the Nucleo-H743ZI(2), on the `stm32h7` PAC's typed
//! register fields, and the board's side of the traits the rest of the
//! firmware sees: SPI1 as an embedded-hal [`SpiBus`] with PD14 as its chip
//! select (together an `embedded-hal-bus` [`ExclusiveDevice`]), USART3 as
//! the serve loop's [`HostLink`].
//!
//! Clocks: [`crate::clocks`] puts the board on the ST-LINK's crystal
//! (400 MHz core, USART3 on the 100 MHz APB1, TIM2 from the 200 MHz timer
//! clock), or leaves it on HSI (64 MHz everywhere) if HSE does not start;
//! the dividers below follow whichever it reports. SPI1's kernel clock is
//! per_ck (HSI, 64 MHz) in both cases.

use core::cell::RefCell;
use core::convert::Infallible;

use critical_section::Mutex;
use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{self, OutputPin};
use embedded_hal::spi::{self, ErrorKind, SpiBus};
use embedded_hal_bus::spi::ExclusiveDevice;
use heapless::Deque;
use heapless::spsc::{Consumer, Producer, Queue};
use lm_fw_core::HostLink;
use stm32h7::stm32h743v as pac;

pub use crate::clocks::TIMER_HZ;
/// Baud rate of the ST-LINK virtual COM port link: `LM_BAUD` when the
/// firmware was built, else 115 200 (lmhost's default `--baud`). The
/// ST-LINK/V3's VCP goes far higher; USART3 (16× oversampling) takes up to
/// 4 Mbaud on either clock, checked here with the rate error on both.
pub const BAUD: u32 = match option_env!("LM_BAUD") {
    Some(s) => parse_baud(s),
    None => 115_200,
};

const _: () = {
    assert!(
        BAUD >= 1200 && BAUD <= 4_000_000,
        "LM_BAUD must be 1200..=4000000"
    );
    // The rate error from BRR's rounding, per mille, on the crystal's
    // 100 MHz APB1 and on HSI's 64 MHz: within 2 %.
    let mut i = 0;
    let clocks = [crate::clocks::APB1_HZ, crate::clocks::HSI_HZ];
    while i < clocks.len() {
        let brr = clocks[i].div_ceil(BAUD);
        let real = clocks[i] / brr;
        let err = (BAUD - real) as u64 * 1000 / BAUD as u64;
        assert!(
            err < 20,
            "LM_BAUD is more than 2 % off on one of the clocks"
        );
        i += 1;
    }
};

/// `LM_BAUD` as a number, at compile time.
const fn parse_baud(s: &str) -> u32 {
    let b = s.as_bytes();
    assert!(!b.is_empty(), "LM_BAUD is empty");
    let mut v: u32 = 0;
    let mut i = 0;
    while i < b.len() {
        assert!(b[i].is_ascii_digit(), "LM_BAUD must be a number of baud");
        v = v * 10 + (b[i] - b'0') as u32;
        assert!(v <= 100_000_000, "LM_BAUD is too large");
        i += 1;
    }
    v
}

/// SPI1 with chip select PD14 held low for each transaction: the
/// transducer driver, as the core's `SpiOutput` wants it.
pub type DriverSpi = ExclusiveDevice<Spi1, ChipSelect, CycleDelay>;

/// The board's peripherals, set up.
pub struct Board {
    /// The host link: the user USB port (when on the crystal) and USART3
    /// on PD8 (TX) / PD9 (RX), the ST-LINK virtual COM port.
    pub link: Links,
    /// TIM2, free-running 32-bit at [`TIMER_HZ`].
    pub timer: Timer,
    /// SPI1 (PA5 SCK, PA6 MISO, PB5 MOSI; PD14 chip select = Arduino D13/D12/D11/D10).
    pub spi: DriverSpi,
    /// The clocks, and which oscillator they come from (`Info.clock`).
    pub clocks: crate::clocks::Clocks,
}

impl Board {
    /// Enables the clocks and configures pins, USART3, TIM2 and SPI1.
    /// Call once: the receive queue is a singleton.
    pub fn init(dp: pac::Peripherals) -> Board {
        let clocks = crate::clocks::init(&dp.PWR, &dp.RCC, &dp.FLASH, &dp.GPIOC);
        let usb = crate::usb::init(&clocks, &dp.PWR, &dp.RCC, &dp.GPIOA);
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
        rcc.d2ccip1r().modify(|_, w| w.spi123sel().per());
        let _ = rcc.apb2enr().read(); // let the enables settle before touching the blocks

        // SPI1: PA5 SCK, PA6 MISO, PB5 MOSI on AF5.
        let (a, b, d) = (&dp.GPIOA, &dp.GPIOB, &dp.GPIOD);
        a.afrl().modify(|_, w| w.afr5().af5().afr6().af5());
        a.ospeedr()
            .modify(|_, w| w.ospeedr5().very_high_speed().ospeedr6().very_high_speed());
        a.moder()
            .modify(|_, w| w.moder5().alternate().moder6().alternate());
        b.afrl().modify(|_, w| w.afr5().af5());
        b.ospeedr().modify(|_, w| w.ospeedr5().very_high_speed());
        b.moder().modify(|_, w| w.moder5().alternate());
        // USART3: PD8 TX, PD9 RX on AF7; PD14 chip select, push-pull, idle high.
        d.afrh().modify(|_, w| w.afr8().af7().afr9().af7());
        d.ospeedr()
            .modify(|_, w| w.ospeedr8().very_high_speed().ospeedr9().very_high_speed());
        d.bsrr().write(|w| w.bs14().set_());
        d.moder().modify(|_, w| {
            w.moder8()
                .alternate()
                .moder9()
                .alternate()
                .moder14()
                .output()
        });

        let usart = dp.USART3;
        usart.cr1().write(|w| w.ue().clear_bit());
        usart
            .brr()
            // SAFETY: BRR takes any divisor; 100 or 64 MHz / 115200 fits its 16 bits.
            .write(|w| unsafe { w.bits(clocks.usart_hz.div_ceil(BAUD)) });
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
            // SAFETY: any 16-bit prescaler is valid; 200 (or 64) MHz / 1 MHz − 1
            // fits (checked at compile time in `clocks`).
            .write(|w| unsafe { w.bits(clocks.tim2_hz / TIMER_HZ - 1) });
        // SAFETY: TIM2 is 32 bits wide: every auto-reload value is valid.
        tim.arr().write(|w| unsafe { w.bits(u32::MAX) });
        tim.egr().write(|w| w.ug().set_bit()); // load PSC now
        tim.cr1().write(|w| w.cen().set_bit());

        let spi = dp.SPI1;
        spi.cr1().write(|w| w.spe().clear_bit());
        // 8-bit frames, kernel clock / 4, mode 0, software chip select.
        spi.cfg1()
            // SAFETY: DSIZE 7 (8-bit frames) and MBR 1 (/4) are valid field values.
            .write(|w| unsafe { w.dsize().bits(7).mbr().bits(1) });
        spi.cfg2()
            .write(|w| w.master().set_bit().ssm().set_bit().afcntr().set_bit());
        spi.cr1().write(|w| w.ssi().set_bit());
        spi.cr1().write(|w| w.ssi().set_bit().spe().set_bit());
        spi.cr1()
            .write(|w| w.ssi().set_bit().spe().set_bit().cstart().set_bit());

        let Some(queue) = cortex_m::singleton!(: Queue<u8, RX_RING> = Queue::new()) else {
            panic!("Board::init called twice")
        };
        let (producer, consumer) = queue.split();
        critical_section::with(|cs| RX.borrow(cs).replace(Some(producer)));
        let Ok(spi) = ExclusiveDevice::new(Spi1(spi), ChipSelect(dp.GPIOD), CycleDelay);
        Board {
            link: Links {
                uart: Link {
                    usart,
                    rx: consumer,
                    tx: Deque::new(),
                },
                usb,
                reply_usb: false,
            },
            timer: Timer(tim),
            spi,
            clocks,
        }
    }
}

/// Bytes the receive queue holds: almost two full frames (the host has one
/// request in flight), so a long SPI frame or step never makes the UART
/// overrun. 2 KiB rather than 4 keeps the statics outside the library
/// within 16 KB now that the core holds two decode rings.
const RX_RING: usize = 2048;
/// Bytes of queued replies: many small responses.
const TX_RING: usize = 1024;

/// The producer end of the receive queue, used by [`usart3_rx_isr`] only.
static RX: Mutex<RefCell<Option<Producer<'static, u8>>>> = Mutex::new(RefCell::new(None));

/// USART3 as the host link: received bytes come from the queue the
/// interrupt fills; replies are queued and moved into the transmit FIFO on
/// every pass, so a reply (4 ms for a status frame at 115 200 Bd) never
/// holds up a step.
pub struct Link {
    usart: pac::USART3,
    rx: Consumer<'static, u8>,
    tx: Deque<u8, TX_RING>,
}

impl Link {
    /// Moves queued bytes into the transmit FIFO while it has room.
    fn pump(&mut self) {
        while !self.tx.is_empty() && self.usart.isr().read().txe().bit_is_set() {
            if let Some(b) = self.tx.pop_front() {
                // SAFETY: TDR takes any byte in its low 9 bits.
                self.usart.tdr().write(|w| unsafe { w.bits(u32::from(b)) });
            }
        }
    }
}

impl HostLink for Link {
    fn receive(&mut self, buf: &mut [u8]) -> usize {
        let mut n = 0;
        while let Some(slot) = buf.get_mut(n) {
            let Some(b) = self.rx.dequeue() else { break };
            *slot = b;
            n += 1;
        }
        n
    }

    /// Queues `bytes`; only waits if the queue is full.
    fn send(&mut self, bytes: &[u8]) {
        for &b in bytes {
            let mut b = b;
            while let Err(back) = self.tx.push_back(b) {
                b = back;
                self.pump();
            }
        }
        self.pump();
    }

    fn flush(&mut self) {
        self.pump();
    }
}

/// The two host links the firmware serves: replies go back on the link
/// the last request came from. One host at a time: requests interleaved
/// from both would garble each other's frames (the decoder counts them).
pub struct Links {
    uart: Link,
    usb: Option<crate::usb::UsbLink>,
    reply_usb: bool,
}

impl HostLink for Links {
    fn receive(&mut self, buf: &mut [u8]) -> usize {
        if let Some(u) = &mut self.usb {
            let n = u.receive(buf);
            if n > 0 {
                self.reply_usb = true;
                return n;
            }
        }
        let n = self.uart.receive(buf);
        if n > 0 {
            self.reply_usb = false;
        }
        n
    }

    fn send(&mut self, bytes: &[u8]) {
        match &mut self.usb {
            Some(u) if self.reply_usb => u.send(bytes),
            _ => self.uart.send(bytes),
        }
    }

    fn flush(&mut self) {
        self.uart.flush();
        if let Some(u) = &mut self.usb {
            u.flush();
        }
    }
}

/// USART3 receive interrupt body: drains the receive FIFO into the receive
/// queue and clears overrun/framing/noise errors so reception continues.
/// A byte that finds the queue full is dropped: the frame decoder sees the
/// damage and counts it.
pub fn usart3_rx_isr() {
    // SAFETY: the interrupt only reads ISR/RDR and writes ICR; the main loop
    // only reads ISR.TXE and writes TDR. These accesses do not interfere.
    let usart = unsafe { pac::USART3::steal() };
    critical_section::with(|cs| {
        let mut rx = RX.borrow_ref_mut(cs);
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
            let b = usart.rdr().read().bits() as u8;
            if let Some(p) = rx.as_mut() {
                let _ = p.enqueue(b);
            }
        }
    });
}

/// TIM2 counting up at [`TIMER_HZ`], wrapping every 2^32 counts (71 min).
pub struct Timer(pac::TIM2);

impl Timer {
    /// The current count.
    pub fn now(&self) -> u32 {
        self.0.cnt().read().bits()
    }
}

/// SPI1 as an embedded-hal [`SpiBus`]: full duplex, byte by byte through
/// the FIFOs. Chip select is [`ChipSelect`]'s job.
pub struct Spi1(pac::SPI1);

/// Bytes in flight at most: the H743's SPI1 FIFO holds 16.
const FIFO_DEPTH: usize = 8;

impl Spi1 {
    /// Clocks `tx` out (0xFF after its end) and what comes back into `rx`
    /// (if given), `len` bytes in all.
    fn exchange(&mut self, len: usize, tx: &[u8], mut rx: Option<&mut [u8]>) {
        let (mut sent, mut got) = (0, 0);
        while got < len {
            let sr = self.0.sr().read();
            if sent < len && sent - got < FIFO_DEPTH && sr.txp().bit_is_set() {
                let b = tx.get(sent).copied().unwrap_or(0xFF);
                // SAFETY: the 8-bit data register takes any byte.
                self.0.txdr8().write(|w| unsafe { w.txdr().bits(b) });
                sent += 1;
            }
            if sr.rxp().bit_is_set() {
                let b = self.0.rxdr8().read().rxdr().bits();
                if let Some(slot) = rx.as_deref_mut().and_then(|r| r.get_mut(got)) {
                    *slot = b;
                }
                got += 1;
            }
        }
    }
}

impl spi::ErrorType for Spi1 {
    type Error = ErrorKind;
}

impl SpiBus for Spi1 {
    fn read(&mut self, words: &mut [u8]) -> Result<(), ErrorKind> {
        self.exchange(words.len(), &[], Some(words));
        Ok(())
    }

    fn write(&mut self, words: &[u8]) -> Result<(), ErrorKind> {
        self.exchange(words.len(), words, None);
        Ok(())
    }

    fn transfer(&mut self, read: &mut [u8], write: &[u8]) -> Result<(), ErrorKind> {
        self.exchange(read.len().max(write.len()), write, Some(read));
        Ok(())
    }

    fn transfer_in_place(&mut self, words: &mut [u8]) -> Result<(), ErrorKind> {
        // Each byte is read back before the FIFO can run FIFO_DEPTH ahead,
        // so exchanging chunk by chunk through a small copy is enough.
        for chunk in words.chunks_mut(FIFO_DEPTH) {
            let mut tx = [0u8; FIFO_DEPTH];
            tx[..chunk.len()].copy_from_slice(chunk);
            self.exchange(chunk.len(), &tx[..chunk.len()], Some(chunk));
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), ErrorKind> {
        while self.0.sr().read().txc().bit_is_clear() {}
        Ok(())
    }
}

/// PD14, the transducer driver's chip select (active low).
pub struct ChipSelect(pac::GPIOD);

impl digital::ErrorType for ChipSelect {
    type Error = Infallible;
}

impl OutputPin for ChipSelect {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.0.bsrr().write(|w| w.br14().reset());
        Ok(())
    }

    fn set_high(&mut self) -> Result<(), Infallible> {
        self.0.bsrr().write(|w| w.bs14().set_());
        Ok(())
    }
}

/// Busy-wait delays in core cycles, counted at the fastest core clock
/// ([`crate::clocks::SYS_HZ`], so at least as long on HSI), for a
/// transaction's `DelayNs` operations.
pub struct CycleDelay;

impl DelayNs for CycleDelay {
    fn delay_ns(&mut self, ns: u32) {
        cortex_m::asm::delay(
            (u64::from(ns) * u64::from(crate::clocks::SYS_HZ / 1_000_000) / 1000) as u32 + 1,
        );
    }
}
