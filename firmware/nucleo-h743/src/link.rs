//! The serve loop's [`HostLink`]: the ST-LINK virtual COM port (USART3)
//! and the user USB port (CDC-ACM), both read and written without waiting
//! on the host; a reply goes back on the link its request came from.

use embassy_stm32::usart::{BufferedUartRx, BufferedUartTx};
use embassy_time::{Duration, Instant};
use embedded_io::{Read, ReadReady, Write};
use lm_fw_core::HostLink;

/// How long a reply may wait for room in the USB pipe before the rest of
/// it is dropped: a host that holds the port open but stops reading must
/// not stop the steps.
const USB_SEND_PATIENCE: Duration = Duration::from_millis(50);

/// USART3 to the ST-LINK's virtual COM port, interrupt-driven with ring
/// buffers on both sides (embassy-stm32's `BufferedUart`: RXNE and IDLE
/// interrupts fill the receive ring, TXE drains the transmit ring).
pub struct UartLink {
    /// Receive half.
    pub rx: BufferedUartRx<'static>,
    /// Transmit half.
    pub tx: BufferedUartTx<'static>,
}

impl UartLink {
    fn receive(&mut self, buf: &mut [u8]) -> usize {
        // Only read when bytes are there: `read` returns at once then.
        match self.rx.read_ready() {
            Ok(true) => self.rx.read(buf).unwrap_or(0),
            _ => 0,
        }
    }

    /// Queues `bytes`; waits only while the transmit ring is full (the
    /// interrupt empties it at the line rate).
    fn send(&mut self, bytes: &[u8]) {
        if self.tx.write_all(bytes).is_err() {
            defmt::warn!("USART3: reply of {=usize} bytes not sent", bytes.len());
        }
    }
}

/// The CDC-ACM port, through the pipes its task fills and drains.
pub struct UsbLink;

impl UsbLink {
    fn receive(&mut self, buf: &mut [u8]) -> usize {
        crate::usb::RX.try_read(buf).unwrap_or(0)
    }

    /// Queues `bytes` for the host; drops them if no host is there, or
    /// what is left after [`USB_SEND_PATIENCE`] without room.
    fn send(&mut self, mut bytes: &[u8]) {
        if !crate::usb::connected() {
            return;
        }
        let deadline = Instant::now() + USB_SEND_PATIENCE;
        while !bytes.is_empty() {
            match crate::usb::TX.try_write(bytes) {
                Ok(n) => bytes = &bytes[n..],
                Err(_) if Instant::now() > deadline => {
                    defmt::warn!(
                        "USB CDC: host not reading, {=usize} reply bytes dropped",
                        bytes.len()
                    );
                    return;
                }
                Err(_) => {}
            }
        }
    }
}

/// Which link the last request came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
enum Active {
    /// None yet.
    None,
    /// The ST-LINK virtual COM port.
    Uart,
    /// The user USB port.
    Usb,
}

/// The two host links the firmware serves. One host at a time: requests
/// interleaved from both would garble each other's frames (the decoder
/// counts them).
pub struct Links {
    uart: UartLink,
    usb: UsbLink,
    active: Active,
}

impl Links {
    /// Both links; replies go to the UART until a request arrives.
    pub fn new(uart: UartLink) -> Self {
        Self {
            uart,
            usb: UsbLink,
            active: Active::None,
        }
    }

    fn switch(&mut self, to: Active) {
        if self.active != to {
            defmt::info!("host link: {} (was {})", to, self.active);
            self.active = to;
        }
    }
}

impl HostLink for Links {
    fn receive(&mut self, buf: &mut [u8]) -> usize {
        let n = self.usb.receive(buf);
        if n > 0 {
            self.switch(Active::Usb);
            return n;
        }
        let n = self.uart.receive(buf);
        if n > 0 {
            self.switch(Active::Uart);
        }
        n
    }

    fn send(&mut self, bytes: &[u8]) {
        defmt::trace!("reply: {=usize} bytes on {}", bytes.len(), self.active);
        match self.active {
            Active::Usb => self.usb.send(bytes),
            Active::Uart | Active::None => self.uart.send(bytes),
        }
    }
}
