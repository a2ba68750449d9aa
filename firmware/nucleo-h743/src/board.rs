//! The board's peripherals, on embassy-stm32's drivers: the host links
//! (USART3 to the ST-LINK virtual COM port, USB CDC-ACM on the user USB
//! connector), SPI1 and the chip select to the transducer driver, MCO2's
//! reference. Pins: `lm_fw_nucleo_h743_logic::pins` (the same MCU pins on
//! NUCLEO-H743ZI and -ZI2; a test there checks this file against it).

use embassy_executor::SendSpawner;
use embassy_stm32::gpio::{Level, Output, Pull, Speed};
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::rcc::{Mco, Mco2Source, McoConfig};
use embassy_stm32::spi::{self, Spi};
use embassy_stm32::time::Hertz;
use embassy_stm32::usart::{self, BufferedUart};
use embassy_stm32::usb::{self, Driver};
use embassy_stm32::{Peripherals, bind_interrupts, dma, interrupt, peripherals};
use lm_fw_core::TakeOnce;
use lm_fw_nucleo_h743_logic::clocks as plan;

use crate::clocks::Source;
use crate::link::{Links, UartLink};
use crate::output::DriverOutput;

bind_interrupts!(pub struct Irqs {
    USART3 => usart::BufferedInterruptHandler<peripherals::USART3>;
    OTG_FS => usb::InterruptHandler<peripherals::USB_OTG_FS>;
    DMA1_STREAM0 => dma::InterruptHandler<peripherals::DMA1_CH0>;
    DMA1_STREAM1 => dma::InterruptHandler<peripherals::DMA1_CH1>;
});

/// Bytes the UART receive ring holds: almost two full frames (the host has
/// one request in flight), so a long step never makes USART3 overrun.
const UART_RX_BYTES: usize = 2048;
/// Bytes of queued UART replies: many small responses.
const UART_TX_BYTES: usize = 1024;
static UART_RX: TakeOnce<[u8; UART_RX_BYTES]> = TakeOnce::new([0; UART_RX_BYTES]);
static UART_TX: TakeOnce<[u8; UART_TX_BYTES]> = TakeOnce::new([0; UART_TX_BYTES]);

/// The board, set up.
pub struct Board {
    /// The host links.
    pub link: Links,
    /// The transducer driver.
    pub output: DriverOutput,
}

/// Sets the peripherals up and starts the USB and SPI tasks. Call once,
/// after `embassy_stm32::init`.
pub fn init(
    p: Peripherals,
    source: Source,
    scb: cortex_m::peripheral::SCB,
    spi_spawner: SendSpawner,
    usb_spawner: SendSpawner,
) -> Board {
    // The driver boards' 10.24 MHz reference, PLL2 P on MCO2, on the
    // crystal only: on HSI PC9 stays an input, no clock reaches the driver
    // boards and their PLLs hold them silent (firmware/DRIVER.md, "Clock").
    // The `Mco` handle has no drop: the output keeps running without it.
    if source == Source::Crystal {
        let _ = Mco::new(p.MCO2, p.PC9, Mco2Source::PLL2_P, McoConfig::default());
    }

    let (Some(rx_buf), Some(tx_buf)) = (UART_RX.take(), UART_TX.take()) else {
        panic!("board::init called twice")
    };
    let mut uart_config = usart::Config::default();
    uart_config.baudrate = plan::BAUD;
    let uart = match BufferedUart::new(p.USART3, p.PD9, p.PD8, tx_buf, rx_buf, Irqs, uart_config) {
        Ok(u) => u,
        Err(e) => panic!("USART3: {:?}", e),
    };
    // Above the executors: the receive FIFO is drained before it fills.
    interrupt::USART3.set_priority(Priority::P1);
    let (tx, rx) = uart.split();
    defmt::info!(
        "USART3 (ST-LINK VCP): {=u32} baud 8N1 (USART3 makes {=u32})",
        plan::BAUD,
        plan::actual_baud(source.plan().usart3_hz, plan::BAUD).unwrap_or(0)
    );

    let mut usb_config = usb::Config::default();
    // PA9 senses VBUS on CN13 (UM2407 Table 12), but the board is powered
    // from the ST-LINK and the D+ pull-up may stay on: no sensing, as the
    // HAL recommends for boards it does not know.
    usb_config.vbus_detection = false;
    let driver = Driver::new_fs(
        p.USB_OTG_FS,
        Irqs,
        p.PA12,
        p.PA11,
        crate::usb::ep_out_buffer(),
        usb_config,
    );
    interrupt::OTG_FS.set_priority(Priority::P2);
    crate::usb::start(driver, usb_spawner);

    let mut spi_config = spi::Config::default();
    spi_config.mode = spi::MODE_0;
    spi_config.frequency = Hertz(plan::SPI_SCK_HZ);
    // MISO only reads the loopback wire; without it the test reads zeros,
    // not noise.
    spi_config.miso_pull = Pull::Down;
    let spi = Spi::new(
        p.SPI1, p.PA5, p.PB5, p.PA6, p.DMA1_CH0, p.DMA1_CH1, Irqs, spi_config,
    );
    let cs = Output::new(p.PD14, Level::High, Speed::VeryHigh);
    defmt::info!(
        "SPI1 to the driver: {=u32} Hz, mode 0, DMA; SCK PA5, MOSI PB5, MISO PA6, CS PD14",
        plan::SPI_SCK_HZ
    );
    let output = DriverOutput::new(spi, cs, spi_spawner, scb);

    Board {
        link: Links::new(UartLink { rx, tx }),
        output,
    }
}
