//! The Nucleo's user USB connector as a CDC-ACM serial port: OTG2 with its
//! internal full-speed PHY on PA11 (D−) / PA12 (D+), through
//! `synopsys-usb-otg`, `usb-device` and `usbd-serial`. The protocol is the
//! same as on the ST-LINK UART; lmhost finds the board by the USB id
//! [`VID_PID`] (`host/src/device/link/discover.rs`).
//!
//! USB needs an exact 48 MHz: PLL3 Q makes it from the crystal (8 MHz / 4
//! × 240 / 10), so the port exists only when the board runs from HSE; on
//! the HSI fallback the UART alone carries the link.

use synopsys_usb_otg::{UsbBus, UsbPeripheral};
use usb_device::bus::UsbBusAllocator;
use usb_device::device::{
    StringDescriptors, UsbDevice, UsbDeviceBuilder, UsbDeviceState, UsbVidPid,
};
use usbd_serial::{SerialPort, USB_CLASS_CDC};

use stm32h7::stm32h743v as pac;

/// ST's vendor id and its virtual COM port product id.
pub const VID_PID: (u16, u16) = (0x0483, 0x5740);
/// PLL3 dividers for the 48 MHz USB kernel clock from the 8 MHz HSE.
const DIVM3: u32 = 4;
const DIVN3: u32 = 240;
const DIVQ3: u32 = 10;

const _: () = {
    let reference = crate::clocks::HSE_HZ / DIVM3;
    assert!(reference >= 2_000_000 && reference <= 4_000_000);
    let vco = reference as u64 * DIVN3 as u64;
    assert!(vco >= 192_000_000 && vco <= 836_000_000);
    assert!(vco / DIVQ3 as u64 == 48_000_000, "USB needs 48 MHz exactly");
};

/// OTG2 (the FS core at 0x4008_0000) for `synopsys-usb-otg`.
pub struct Otg2 {
    ahb_hz: u32,
}

// SAFETY: the register block is OTG2's, owned by this driver alone (Board::init
// takes the peripherals once); its FIFO is 4 KiB and it has 9 endpoints
// (RM0433), as stm32h7xx-hal declares them.
unsafe impl UsbPeripheral for Otg2 {
    const REGISTERS: *const () = pac::OTG2_HS_GLOBAL::PTR as *const ();
    const HIGH_SPEED: bool = false;
    const FIFO_DEPTH_WORDS: usize = 1024;
    const ENDPOINT_COUNT: usize = 9;

    fn enable() {
        // SAFETY: single-bit read-modify-writes of RCC from the one thread
        // that configures clocks, before interrupts use RCC.
        let rcc = unsafe { &*pac::RCC::PTR };
        rcc.ahb1enr().modify(|_, w| w.usb2otgen().set_bit());
        rcc.ahb1rstr().modify(|_, w| w.usb2otgrst().set_bit());
        rcc.ahb1rstr().modify(|_, w| w.usb2otgrst().clear_bit());
    }

    fn ahb_frequency_hz(&self) -> u32 {
        self.ahb_hz
    }
}

/// The CDC-ACM port as a host link.
pub struct UsbLink {
    dev: UsbDevice<'static, UsbBus<Otg2>>,
    serial: SerialPort<'static, UsbBus<Otg2>>,
}

/// Sets up the 48 MHz clock, the pins and the device; `None` when the
/// board is not on the crystal. Call once, from `Board::init`.
pub fn init(
    clocks: &crate::clocks::Clocks,
    pwr: &pac::PWR,
    rcc: &pac::RCC,
    gpioa: &pac::GPIOA,
) -> Option<UsbLink> {
    if clocks.source != crate::clocks::Source::Crystal {
        return None;
    }
    // 48 MHz from PLL3 Q.
    rcc.pllckselr()
        // SAFETY: DIVM3 = 4 is in 1..=63 (checked above).
        .modify(|_, w| unsafe { w.divm3().bits(DIVM3 as u8) });
    rcc.pllcfgr().modify(|_, w| {
        w.pll3rge()
            .range2()
            .pll3vcosel()
            .wide_vco()
            .divq3en()
            .enabled()
    });
    rcc.pll3divr()
        // SAFETY: the fields hold divider − 1, in range (checked above).
        .write(|w| unsafe {
            w.divn3()
                .bits((DIVN3 - 1) as u16)
                .divq3()
                .bits((DIVQ3 - 1) as u8)
        });
    rcc.cr().modify(|_, w| w.pll3on().on());
    while !rcc.cr().read().pll3rdy().is_ready() {}
    rcc.d2ccip2r().modify(|_, w| w.usbsel().pll3_q());
    // The USB transceiver's 3.3 V supply detector.
    pwr.cr3().modify(|_, w| w.usb33den().set_bit());
    while pwr.cr3().read().usb33rdy().bit_is_clear() {}
    // PA11 D−, PA12 D+ on AF10.
    rcc.ahb4enr().modify(|_, w| w.gpioaen().set_bit());
    gpioa.afrh().modify(|_, w| w.afr11().af10().afr12().af10());
    gpioa.ospeedr().modify(|_, w| {
        w.ospeedr11()
            .very_high_speed()
            .ospeedr12()
            .very_high_speed()
    });
    gpioa
        .moder()
        .modify(|_, w| w.moder11().alternate().moder12().alternate());

    let ep_memory = cortex_m::singleton!(: [u32; 1024] = [0; 1024])?;
    let bus = UsbBus::new(
        Otg2 {
            ahb_hz: crate::clocks::AHB_HZ,
        },
        ep_memory,
    );
    let bus: &'static UsbBusAllocator<UsbBus<Otg2>> =
        cortex_m::singleton!(: UsbBusAllocator<UsbBus<Otg2>> = bus)?;
    let serial = SerialPort::new(bus);
    let dev = UsbDeviceBuilder::new(bus, UsbVidPid(VID_PID.0, VID_PID.1))
        .strings(&[StringDescriptors::default()
            .manufacturer("lmhost")
            .product("LM firmware (Nucleo-H743)")
            .serial_number("lm-fw")])
        .ok()?
        .device_class(USB_CLASS_CDC)
        .build();
    Some(UsbLink { dev, serial })
}

impl UsbLink {
    /// Services the bus (enumeration, transfers); cheap when idle.
    pub fn poll(&mut self) {
        self.dev.poll(&mut [&mut self.serial]);
    }

    /// Bytes that arrived, into `buf`.
    pub fn receive(&mut self, buf: &mut [u8]) -> usize {
        self.poll();
        self.serial.read(buf).unwrap_or(0)
    }

    /// Sends `bytes`, servicing the bus while the port's buffer is full; a
    /// reply to a host that went away (not configured) is dropped.
    pub fn send(&mut self, mut bytes: &[u8]) {
        let mut stalls = 0u32;
        while !bytes.is_empty() {
            if self.dev.state() != UsbDeviceState::Configured {
                return;
            }
            match self.serial.write(bytes) {
                Ok(n) if n > 0 => {
                    bytes = &bytes[n..];
                    stalls = 0;
                }
                _ => {
                    stalls += 1;
                    // A host that stopped reading: give up after ~1 M polls.
                    if stalls > 1_000_000 {
                        return;
                    }
                }
            }
            self.poll();
        }
    }

    /// Moves queued bytes on.
    pub fn flush(&mut self) {
        self.poll();
        let _ = self.serial.flush();
    }
}
