//! The USB serial console (issue #27 point 2): the board's USB connector as a CDC-ACM serial
//! port, with the ecosystem's stack (the HAL's `stm32-usbd` peripheral, `usb-device`,
//! `usbd-serial`). The decisions (which port a reply goes to, what is dropped when the port is
//! closed or full) are the library's [`inemo_ahrs::console`], host-tested; this only moves
//! bytes between the USB device and it.
//!
//! Stale output (issue #37 point 4): the class is usbd-serial's bare `CdcAcmClass`, not its
//! `SerialPort`, whose 128-byte write buffer kept whatever a closed port had not read, so the
//! next program to open the port read half a sentence first. The only buffer is the library's
//! queue, which a change of DTR empties ([`UsbOut::set_host`]), and the one packet armed on
//! the IN endpoint, which is taken back then too (the endpoint set to NAK: RM0008's `STAT_TX`,
//! through `usb-device`'s stall and unstall). Every packet is short ([`CHUNK`] = 63 bytes), so
//! each ends its transfer and no zero-length packet is ever owed.
//!
//! The D+ pull-up: ST's firmware for this board switches the 1.5 kΩ pull-up on D+ with
//! [`PullUp`] (PA10, high = connected; `docs/firmware.md`, "USB serial console", cites the
//! source). Not verified on a board.

use inemo_ahrs::console::{Port, PortLines, Received, UsbOut};
use stm32f1xx_hal::{
    gpio::{Floating, Input, Output, PinState, PushPull, PA10, PA11, PA12},
    pac,
    usb::{Peripheral, UsbBus, UsbBusType},
};
use usb_device::{bus::UsbBusAllocator, prelude::*};
use usbd_serial::{CdcAcmClass, USB_CLASS_CDC};

/// The pin that switches the D+ pull-up (ST's `iNEMO_USB_DISCONNECT_PIN`: GPIOA pin 10),
/// driven high to connect. The one place the pin is named.
pub type PullUp = PA10<Output<PushPull>>;

/// Bytes waiting for the USB port: 12 of the longest sentences (82 bytes), more than a cycle's
/// output (at most 7 sentences and a reply), so a host that keeps reading loses nothing.
pub const USB_OUT_LEN: usize = 1024;
/// The queue the filter task fills and the USB task drains.
pub type UsbQueue = UsbOut<USB_OUT_LEN>;

/// USB IDs: pid.codes' test VID/PID (0x1209:0x0001), for a bench device that is not sold.
/// Hosts bind the CDC-ACM class by its descriptors, not by these.
const VID_PID: UsbVidPid = UsbVidPid(0x1209, 0x0001);

/// The bulk endpoints' packet size (full speed).
const MAX_PACKET: u16 = 64;
/// Bytes copied out of the queue per write: one packet, one byte short of full, so that every
/// packet ends its transfer (a full one would owe the host a zero-length packet when nothing
/// follows).
pub const CHUNK: usize = MAX_PACKET as usize - 1;

/// The USB device and its serial port.
pub struct UsbConsole {
    dev: UsbDevice<'static, UsbBusType>,
    serial: CdcAcmClass<'static, UsbBusType>,
    lines: PortLines,
    pull_up: PullUp,
}

impl UsbConsole {
    /// The device on the USB peripheral, with D+ still disconnected: [`UsbConsole::connect`]
    /// lets the host see it. `alloc` is the bus allocator's static home (RTIC's init local).
    pub fn new(
        usb: pac::USB,
        dm: PA11<Input<Floating>>,
        dp: PA12<Input<Floating>>,
        pull_up: PullUp,
        alloc: &'static mut Option<UsbBusAllocator<UsbBusType>>,
    ) -> Self {
        let alloc: &'static UsbBusAllocator<UsbBusType> =
            alloc.insert(UsbBus::new(Peripheral { usb, pin_dm: dm, pin_dp: dp }));
        let serial = CdcAcmClass::new(alloc, MAX_PACKET);
        let strings = StringDescriptors::default().manufacturer("Seahog").product("iNEMO AHRS");
        // `strings` fails only for more than 16 languages (one here); should it ever, the
        // device enumerates without names rather than the firmware stopping.
        let builder = match UsbDeviceBuilder::new(alloc, VID_PID).strings(&[strings]) {
            Ok(builder) => builder,
            Err(_) => UsbDeviceBuilder::new(alloc, VID_PID),
        };
        let dev = builder.device_class(USB_CLASS_CDC).build();
        UsbConsole { dev, serial, lines: PortLines::new(Port::Usb), pull_up }
    }

    /// Switches the D+ pull-up on: the host sees the device and enumerates it.
    pub fn connect(&mut self) {
        self.pull_up.set_state(PinState::High);
    }

    /// Services the USB device (enumeration, control requests, the bulk endpoints); every
    /// command line received goes to `on_line`. Returns whether a host has configured the
    /// device, and DTR (for [`UsbOut::set_host`](inemo_ahrs::console::UsbOut::set_host)).
    pub fn poll(&mut self, mut on_line: impl FnMut(Received)) -> (bool, bool) {
        if self.dev.poll(&mut [&mut self.serial]) {
            let mut buf = [0u8; MAX_PACKET as usize];
            // Bounded: one packet a poll is what the endpoint holds; a few for good measure.
            for _ in 0..4 {
                match self.serial.read_packet(&mut buf) {
                    Ok(n) if n > 0 => {
                        for &b in buf.iter().take(n) {
                            if let Some(r) = self.lines.push(b) {
                                on_line(r);
                            }
                        }
                    }
                    _ => break,
                }
            }
        }
        (self.dev.state() == UsbDeviceState::Configured, self.serial.dtr())
    }

    /// Hands up to [`CHUNK`] of `bytes` to the IN endpoint as one packet without waiting: how
    /// many it took (0 while the last packet is still armed, or when the endpoint failed).
    pub fn write(&mut self, bytes: &[u8]) -> usize {
        let packet = bytes.get(..bytes.len().min(CHUNK)).unwrap_or(&[]);
        if packet.is_empty() {
            return 0;
        }
        self.serial.write_packet(packet).unwrap_or(0)
    }

    /// Takes back the packet armed on the IN endpoint, if any (what the host has not read of
    /// the old output when the queue discards the rest: [`UsbOut::set_host`]'s answer).
    pub fn discard_armed(&mut self) {
        let ep = self.serial.write_ep();
        ep.stall();
        ep.unstall();
    }
}
