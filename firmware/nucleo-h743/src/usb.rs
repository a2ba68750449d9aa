//! The Nucleo's user USB connector (CN13, micro-AB) as a CDC-ACM serial
//! port: USB OTG FS (the H743's OTG2 core with its internal full-speed PHY
//! on PA11/PA12), embassy-stm32's driver and embassy-usb's CDC-ACM class.
//! The protocol is the same as on the ST-LINK UART; lmhost finds the board
//! by the USB id [`VID_PID`] (`host/src/device/link/discover.rs`).
//!
//! The USB device and the class run as tasks on an interrupt executor
//! (src/main.rs); bytes cross to the thread-mode serve loop through two
//! pipes, [`RX`] and [`TX`], which the serve loop reads and writes without
//! waiting (`src/link.rs`).
//!
//! Clock: PLL3 Q, 48 MHz from the crystal; on the HSI fallback HSI48 with
//! its CRS trimming to the host's start-of-frame packets
//! (src/clocks.rs), so the port exists on both.

use core::sync::atomic::{AtomicBool, Ordering};

use embassy_executor::SendSpawner;
use embassy_futures::join::join;
use embassy_futures::select::select;
use embassy_stm32::peripherals;
use embassy_stm32::usb::Driver;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::pipe::Pipe;
use embassy_usb::Builder;
use embassy_usb::class::cdc_acm::{CdcAcmClass, Receiver, Sender, State};
use embassy_usb::driver::EndpointError;
use lm_fw_core::TakeOnce;
use static_cell::StaticCell;

/// ST's vendor id and its virtual COM port product id.
pub const VID_PID: (u16, u16) = (0x0483, 0x5740);

/// The driver on the user USB connector.
pub type UsbDriver = Driver<'static, peripherals::USB_OTG_FS>;

/// Full-speed bulk packets.
const PACKET: usize = 64;
/// Bytes each pipe holds: several requests' worth (a chunk frame is at
/// most a few hundred bytes), so the host never waits on a step.
const PIPE_BYTES: usize = 2048;

/// Bytes from the host, for the serve loop.
pub static RX: Pipe<CriticalSectionRawMutex, PIPE_BYTES> = Pipe::new();
/// Replies from the serve loop, for the host.
pub static TX: Pipe<CriticalSectionRawMutex, PIPE_BYTES> = Pipe::new();
/// A host has the port configured: replies are worth queueing.
pub static CONNECTED: AtomicBool = AtomicBool::new(false);

/// OUT endpoint buffer for the driver (all OUT packets pass through it).
static EP_OUT: TakeOnce<[u8; 256]> = TakeOnce::new([0; 256]);

/// The OUT endpoint buffer `Driver::new_fs` wants; once.
pub fn ep_out_buffer() -> &'static mut [u8] {
    match EP_OUT.take() {
        Some(b) => b,
        None => panic!("USB endpoint buffer taken twice"),
    }
}

/// Spawns the USB task on `spawner`: it builds the device (ids, strings,
/// one CDC-ACM function) and runs it. The device and the class are built
/// inside the task, on the executor that runs them, because they are not
/// `Send`; their buffers live in the task's own (static) memory.
pub fn start(driver: UsbDriver, spawner: SendSpawner) {
    spawner.spawn(run(driver).unwrap_or_else(|_| panic!("USB task")));
    defmt::info!(
        "USB CDC-ACM on the user USB connector (CN13): {=u16:04x}:{=u16:04x}",
        VID_PID.0,
        VID_PID.1
    );
}

/// The descriptors and the class state, built in the task on first run.
/// `StaticCell` because `State` is not `Sync` (a `TakeOnce` wants it): it
/// is created and used on the USB executor only.
static USB_MEM: StaticCell<UsbMem> = StaticCell::new();

struct UsbMem {
    config_descriptor: [u8; 256],
    bos_descriptor: [u8; 256],
    control_buf: [u8; 64],
    state: State<'static>,
}

#[embassy_executor::task]
async fn run(driver: UsbDriver) -> ! {
    let mem = USB_MEM.init(UsbMem {
        config_descriptor: [0; 256],
        bos_descriptor: [0; 256],
        control_buf: [0; 64],
        state: State::new(),
    });
    let mut config = embassy_usb::Config::new(VID_PID.0, VID_PID.1);
    config.manufacturer = Some("lmhost");
    config.product = Some("LM firmware Nucleo-H743");
    config.serial_number = Some("lm-fw");
    // Self-powered from the ST-LINK's USB; draws nothing from CN13.
    config.self_powered = true;
    config.max_power = 0;
    // A CDC-ACM function with an interface association descriptor, which
    // Windows needs and Linux and macOS accept.
    config.device_class = 0xEF;
    config.device_sub_class = 0x02;
    config.device_protocol = 0x01;
    config.composite_with_iads = true;
    let mut builder = Builder::new(
        driver,
        config,
        &mut mem.config_descriptor,
        &mut mem.bos_descriptor,
        &mut [],
        &mut mem.control_buf,
    );
    let class = CdcAcmClass::new(&mut builder, &mut mem.state, PACKET as u16);
    let mut device = builder.build();
    join(device.run(), serial(class)).await;
    unreachable!("the USB device and the serial loop run forever")
}

/// Moves packets between the endpoints and the pipes while a host is
/// there; on a disconnect drops what was queued for it.
async fn serial(class: CdcAcmClass<'static, UsbDriver>) -> ! {
    let (mut tx, mut rx) = class.split();
    loop {
        rx.wait_connection().await;
        CONNECTED.store(true, Ordering::Release);
        defmt::info!("USB CDC: host connected");
        select(host_to_core(&mut rx), core_to_host(&mut tx)).await;
        CONNECTED.store(false, Ordering::Release);
        TX.clear();
        defmt::info!("USB CDC: host gone");
    }
}

async fn host_to_core(rx: &mut Receiver<'static, UsbDriver>) -> EndpointError {
    let mut buf = [0u8; PACKET];
    loop {
        match rx.read_packet(&mut buf).await {
            // Waits while the serve loop has not taken the previous bytes:
            // the host's OUT packets are NAKed meanwhile, nothing is lost.
            Ok(n) => RX.write_all(&buf[..n]).await,
            Err(e) => return e,
        }
    }
}

async fn core_to_host(tx: &mut Sender<'static, UsbDriver>) -> EndpointError {
    let mut buf = [0u8; PACKET];
    loop {
        let n = TX.read(&mut buf).await;
        if let Err(e) = tx.write_packet(&buf[..n]).await {
            return e;
        }
        // A full packet with nothing behind it ends with a zero-length one,
        // so the host hands the reply over now.
        if n == PACKET
            && TX.is_empty()
            && let Err(e) = tx.write_packet(&[]).await
        {
            return e;
        }
    }
}

/// Whether a host has the port configured.
pub fn connected() -> bool {
    CONNECTED.load(Ordering::Acquire)
}
