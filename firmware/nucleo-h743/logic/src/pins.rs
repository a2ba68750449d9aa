//! Where the firmware's signals leave the board, on both board revisions.
//!
//! One firmware runs on both: every MCU pin below reaches a header pin on
//! the NUCLEO-H743ZI (MB1137, user manual UM1974) and on the
//! NUCLEO-H743ZI2 (MB1364, UM2407) without changing a solder bridge. The
//! one pin that moved between them is the ARDUINO D11 position (CN7 pin
//! 14): PA7 on MB1137 (shared with the Ethernet PHY's RMII CRS_DV while JP6
//! is fitted), PB5 on MB1364. SPI1's MOSI is therefore PB5, taken from CN7
//! pin 13 (D22, SPI_B_MOSI), which is PB5 on both boards.
//!
//! The 10.24 MHz reference on PC9 (MCO2) is taken from the Zio connector,
//! CN8 pin 4 (D44), on both boards: on MB1364 PC9 reaches the ST morpho
//! pin CN12-1 only through SB15 (UM2407 Table 14), which the shipped board
//! leaves open.
//!
//! [`markdown`] renders the tables the board's README carries; a test
//! checks that the README holds exactly this text, and another that the
//! board crate's peripheral setup uses these MCU pins.

use core::fmt::{self, Write};

/// A board revision.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Revision {
    /// NUCLEO-H743ZI: board MB1137, ST-LINK/V2-1, user manual UM1974.
    Zi,
    /// NUCLEO-H743ZI2: board MB1364, STLINK-V3E, user manual UM2407.
    Zi2,
}

impl Revision {
    /// Both, in the order the README lists them.
    pub const ALL: [Revision; 2] = [Revision::Zi, Revision::Zi2];

    /// The order code printed on the box.
    pub const fn order_code(self) -> &'static str {
        match self {
            Self::Zi => "NUCLEO-H743ZI",
            Self::Zi2 => "NUCLEO-H743ZI2",
        }
    }

    /// The board reference on its sticker.
    pub const fn board(self) -> &'static str {
        match self {
            Self::Zi => "MB1137",
            Self::Zi2 => "MB1364",
        }
    }

    /// The user manual and the revision the table rows cite.
    pub const fn manual(self) -> &'static str {
        match self {
            Self::Zi => "UM1974 Rev 11",
            Self::Zi2 => "UM2407 Rev 5",
        }
    }

    /// The pin table for this board.
    pub const fn rows(self) -> &'static [Row] {
        match self {
            Self::Zi => &ZI,
            Self::Zi2 => &ZI2,
        }
    }

    /// Ground pins near the signals, with their table.
    pub const fn grounds(self) -> &'static [Ground] {
        match self {
            Self::Zi => &ZI_GROUNDS,
            Self::Zi2 => &ZI2_GROUNDS,
        }
    }
}

/// A connector of the board.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Connector {
    /// ST Zio, right upper (ARDUINO D8-D15 and the SPI/I2S extension).
    Cn7,
    /// ST Zio, left upper (ARDUINO power and the SDMMC extension).
    Cn8,
    /// ST morpho, left.
    Cn11,
    /// ST morpho, right.
    Cn12,
    /// The user USB connector (USB OTG FS, micro-AB).
    Cn13,
}

impl Connector {
    /// Its silkscreen name.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Cn7 => "CN7",
            Self::Cn8 => "CN8",
            Self::Cn11 => "CN11",
            Self::Cn12 => "CN12",
            Self::Cn13 => "CN13",
        }
    }
}

/// One pin of one connector.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pin {
    /// The connector.
    pub connector: Connector,
    /// The pin number printed in the manual's connector table.
    pub number: u8,
}

impl fmt::Display for Pin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} pin {}", self.connector.name(), self.number)
    }
}

const fn pin(connector: Connector, number: u8) -> Pin {
    Pin { connector, number }
}

/// What a signal does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Signal {
    /// SPI1 SCK to the driver boards.
    Sck,
    /// SPI1 MOSI to the driver boards (and the loopback wire's start).
    Mosi,
    /// SPI1 MISO: the loopback wire's end only (the driver never answers).
    Miso,
    /// The driver's chip select, active low, a GPIO.
    ChipSelect,
    /// The 10.24 MHz reference to the driver boards (MCO2, crystal only).
    Reference,
    /// USART3 TX to the ST-LINK virtual COM port.
    UartTx,
    /// USART3 RX from the ST-LINK virtual COM port.
    UartRx,
    /// USB OTG FS D-, the user USB connector.
    UsbDm,
    /// USB OTG FS D+, the user USB connector.
    UsbDp,
}

impl Signal {
    /// Every signal, in table order.
    pub const ALL: [Signal; 9] = [
        Signal::Sck,
        Signal::Mosi,
        Signal::Miso,
        Signal::ChipSelect,
        Signal::Reference,
        Signal::UartTx,
        Signal::UartRx,
        Signal::UsbDm,
        Signal::UsbDp,
    ];

    /// The MCU pin the firmware drives it on: the same on both boards.
    pub const fn mcu(self) -> &'static str {
        match self {
            Self::Sck => "PA5",
            Self::Mosi => "PB5",
            Self::Miso => "PA6",
            Self::ChipSelect => "PD14",
            Self::Reference => "PC9",
            Self::UartTx => "PD8",
            Self::UartRx => "PD9",
            Self::UsbDm => "PA11",
            Self::UsbDp => "PA12",
        }
    }

    /// What it is, for the table.
    pub const fn describe(self) -> &'static str {
        match self {
            Self::Sck => "SPI1 SCK → driver SCK",
            Self::Mosi => "SPI1 MOSI → driver MOSI",
            Self::Miso => "SPI1 MISO (loopback wire only)",
            Self::ChipSelect => "driver chip select (active low)",
            Self::Reference => "10.24 MHz reference, MCO2 → driver CLK",
            Self::UartTx => "USART3 TX → ST-LINK VCP",
            Self::UartRx => "USART3 RX ← ST-LINK VCP",
            Self::UsbDm => "USB OTG FS D−",
            Self::UsbDp => "USB OTG FS D+",
        }
    }

    /// True for the signals wired to the driver boards.
    pub const fn to_driver(self) -> bool {
        matches!(
            self,
            Self::Sck | Self::Mosi | Self::ChipSelect | Self::Reference
        )
    }
}

/// Where a signal is reached on the board.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Place {
    /// A header pin, with the Zio / ARDUINO name the manual gives it.
    Header {
        /// The pin.
        pin: Pin,
        /// Its Zio name (D13, D22, ...).
        name: &'static str,
    },
    /// A connector pin that is not a Zio pin (the user USB connector).
    Connector(Pin),
    /// Wired on the board (nothing for the rig builder to connect).
    OnBoard(&'static str),
}

/// The signal's ST morpho pin.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Morpho {
    /// Connected by default.
    Pin(Pin),
    /// Present in the morpho table but not connected as shipped.
    NotFitted(Pin, &'static str),
}

/// One row of a board's pin table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Row {
    /// The signal.
    pub signal: Signal,
    /// Where to take it from.
    pub place: Place,
    /// Its ST morpho pin.
    pub morpho: Morpho,
    /// The manual tables this row comes from, and anything to know.
    pub note: &'static str,
}

/// A ground pin and the table that lists it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ground {
    /// The pin.
    pub pin: Pin,
    /// The manual table.
    pub source: &'static str,
}

use Connector::{Cn7, Cn8, Cn11, Cn12, Cn13};

/// Zio header pin `number` of `connector`, called `name`.
const fn header(connector: Connector, number: u8, name: &'static str) -> Place {
    Place::Header {
        pin: pin(connector, number),
        name,
    }
}

// Where the signals are reached: the same header and connector positions on
// both boards (UM1974 Table 20, UM2407 Tables 16, 18, 19), so both tables
// take them from here; what differs between the revisions (the morpho
// pins' solder bridges, the virtual COM port, the manuals' tables) stays
// in each row.
const SCK_AT: Place = header(Cn7, 10, "D13");
const MOSI_AT: Place = header(Cn7, 13, "D22");
const MISO_AT: Place = header(Cn7, 12, "D12");
const CHIP_SELECT_AT: Place = header(Cn7, 16, "D10");
const REFERENCE_AT: Place = header(Cn8, 4, "D44");
const USB_DM_AT: Place = Place::Connector(pin(Cn13, 2));
const USB_DP_AT: Place = Place::Connector(pin(Cn13, 3));

/// NUCLEO-H743ZI (MB1137): UM1974 Rev 11, Table 20 (ST Zio connectors,
/// NUCLEO-H743ZI pin assignments) and Table 21 (ST morpho connector).
const ZI: [Row; 9] = [
    Row {
        signal: Signal::Sck,
        place: SCK_AT,
        morpho: Morpho::Pin(pin(Cn12, 11)),
        note: "UM1974 Tables 20, 21; LD1 stays on PB0 (SB120 ON, SB119 OFF, UM1974 \"LEDs\")",
    },
    Row {
        signal: Signal::Mosi,
        place: MOSI_AT,
        morpho: Morpho::Pin(pin(Cn12, 29)),
        note: "UM1974 Tables 20, 21; not D11 (CN7 pin 14 is PA7 on this board, shared with the Ethernet PHY's RMII CRS_DV while JP6 is fitted)",
    },
    Row {
        signal: Signal::Miso,
        place: MISO_AT,
        morpho: Morpho::Pin(pin(Cn12, 13)),
        note: "UM1974 Tables 20, 21",
    },
    Row {
        signal: Signal::ChipSelect,
        place: CHIP_SELECT_AT,
        morpho: Morpho::Pin(pin(Cn12, 46)),
        note: "UM1974 Tables 20, 21",
    },
    Row {
        signal: Signal::Reference,
        place: REFERENCE_AT,
        morpho: Morpho::Pin(pin(Cn12, 1)),
        note: "UM1974 Tables 20, 21 (SDMMC_D1 position)",
    },
    Row {
        signal: Signal::UartTx,
        place: Place::OnBoard("ST-LINK/V2-1 virtual COM port"),
        morpho: Morpho::Pin(pin(Cn12, 10)),
        note: "UM1974 Table 21; on the ST-LINK line: do not drive it",
    },
    Row {
        signal: Signal::UartRx,
        place: Place::OnBoard("ST-LINK/V2-1 virtual COM port"),
        morpho: Morpho::Pin(pin(Cn11, 69)),
        note: "UM1974 Table 21; on the ST-LINK line: do not drive it",
    },
    Row {
        signal: Signal::UsbDm,
        place: USB_DM_AT,
        morpho: Morpho::Pin(pin(Cn12, 14)),
        note: "UM1974 Table 21 (USB OTG FS micro-AB connector)",
    },
    Row {
        signal: Signal::UsbDp,
        place: USB_DP_AT,
        morpho: Morpho::Pin(pin(Cn12, 12)),
        note: "UM1974 Table 21 (USB OTG FS micro-AB connector)",
    },
];

/// NUCLEO-H743ZI2 (MB1364): UM2407 Rev 5, Table 18 (CN7), Table 19 (CN8),
/// Table 22 (ST morpho), Table 14 (solder bridges), Table 10 (USART3),
/// Table 16 (CN13).
const ZI2: [Row; 9] = [
    Row {
        signal: Signal::Sck,
        place: SCK_AT,
        morpho: Morpho::Pin(pin(Cn12, 11)),
        note: "UM2407 Tables 18, 22; LD1 stays on PB0 (SB39 ON, SB47 OFF, Table 14)",
    },
    Row {
        signal: Signal::Mosi,
        place: MOSI_AT,
        morpho: Morpho::Pin(pin(Cn12, 29)),
        note: "UM2407 Tables 18, 22; also on D11 (CN7 pin 14, SB33 OFF, SB35 ON, Table 14): use one of the two",
    },
    Row {
        signal: Signal::Miso,
        place: MISO_AT,
        morpho: Morpho::Pin(pin(Cn12, 13)),
        note: "UM2407 Tables 18, 22",
    },
    Row {
        signal: Signal::ChipSelect,
        place: CHIP_SELECT_AT,
        morpho: Morpho::Pin(pin(Cn12, 46)),
        note: "UM2407 Tables 18, 22",
    },
    Row {
        signal: Signal::Reference,
        place: REFERENCE_AT,
        morpho: Morpho::NotFitted(pin(Cn12, 1), "SB15"),
        note: "UM2407 Tables 19, 22; CN12 pin 1 needs SB15 (Table 14), which the MB1364 schematic marks not fitted: use CN8 pin 4",
    },
    Row {
        signal: Signal::UartTx,
        place: Place::OnBoard("STLINK-V3E virtual COM port (SB19 ON)"),
        morpho: Morpho::NotFitted(pin(Cn12, 10), "SB82"),
        note: "UM2407 Tables 10, 14, 22",
    },
    Row {
        signal: Signal::UartRx,
        place: Place::OnBoard("STLINK-V3E virtual COM port (SB12 ON)"),
        morpho: Morpho::NotFitted(pin(Cn11, 69), "SB81"),
        note: "UM2407 Tables 10, 14, 22",
    },
    Row {
        signal: Signal::UsbDm,
        place: USB_DM_AT,
        morpho: Morpho::NotFitted(pin(Cn12, 14), "SB16"),
        note: "UM2407 Tables 12, 16, 22 (SB21 ON)",
    },
    Row {
        signal: Signal::UsbDp,
        place: USB_DP_AT,
        morpho: Morpho::NotFitted(pin(Cn12, 12), "SB17"),
        note: "UM2407 Tables 12, 16, 22 (SB22 ON)",
    },
];

/// The ground pins near the signals: the same six on both boards, each
/// cited from the manual table of its connector (`cn7`, `cn8`, `cn12`).
const fn grounds(cn7: &'static str, cn8: &'static str, cn12: &'static str) -> [Ground; 6] {
    const fn at(connector: Connector, number: u8, source: &'static str) -> Ground {
        Ground {
            pin: pin(connector, number),
            source,
        }
    }
    [
        at(Cn7, 8, cn7),
        at(Cn8, 11, cn8),
        at(Cn8, 13, cn8),
        at(Cn12, 9, cn12),
        at(Cn12, 20, cn12),
        at(Cn12, 39, cn12),
    ]
}

const ZI_GROUNDS: [Ground; 6] = grounds("UM1974 Table 20", "UM1974 Table 20", "UM1974 Table 21");

const ZI2_GROUNDS: [Ground; 6] = grounds("UM2407 Table 18", "UM2407 Table 19", "UM2407 Table 22");

/// The loopback self-test's wire, the same on both boards: MOSI (CN7 pin
/// 13, D22, PB5) to MISO (CN7 pin 12, D12, PA6).
pub const LOOPBACK_WIRE: (Pin, Pin) = (pin(Cn7, 13), pin(Cn7, 12));

/// The row for `signal` on `rev`.
pub fn row(rev: Revision, signal: Signal) -> Option<&'static Row> {
    rev.rows().iter().find(|r| r.signal == signal)
}

/// The header pin (or connector pin) a signal is reached at.
pub fn header_pin(rev: Revision, signal: Signal) -> Option<Pin> {
    match row(rev, signal)?.place {
        Place::Header { pin, .. } | Place::Connector(pin) => Some(pin),
        Place::OnBoard(_) => None,
    }
}

/// Writes `rev`'s pin table and ground pins as Markdown (the README's
/// text).
pub fn markdown(rev: Revision, out: &mut impl Write) -> fmt::Result {
    writeln!(
        out,
        "{} ({}, {}):",
        rev.order_code(),
        rev.board(),
        rev.manual()
    )?;
    writeln!(out)?;
    writeln!(
        out,
        "| signal | MCU pin | connector pin | Zio name | ST morpho pin | source, notes |"
    )?;
    writeln!(out, "|---|---|---|---|---|---|")?;
    for r in rev.rows() {
        let (place, name) = match r.place {
            Place::Header { pin, name } => (Some(pin), name),
            Place::Connector(pin) => (Some(pin), "—"),
            Place::OnBoard(_) => (None, "—"),
        };
        write!(out, "| {} | {} | ", r.signal.describe(), r.signal.mcu())?;
        match (place, r.place) {
            (Some(p), _) => write!(out, "{p}")?,
            (None, Place::OnBoard(what)) => write!(out, "on board: {what}")?,
            (None, _) => write!(out, "—")?,
        }
        write!(out, " | {name} | ")?;
        match r.morpho {
            Morpho::Pin(p) => write!(out, "{p}")?,
            Morpho::NotFitted(p, sb) => write!(out, "{p}, not connected as shipped ({sb} open)")?,
        }
        writeln!(out, " | {} |", r.note)?;
    }
    writeln!(out)?;
    write!(out, "Ground:")?;
    for (i, g) in rev.grounds().iter().enumerate() {
        let sep = if i == 0 { " " } else { ", " };
        write!(out, "{sep}{} ({})", g.pin, g.source)?;
    }
    writeln!(out, ".")?;
    Ok(())
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::string::String;

    #[test]
    fn every_signal_is_reachable_on_both_boards_on_the_same_mcu_pin() {
        for rev in Revision::ALL {
            assert_eq!(rev.rows().len(), Signal::ALL.len());
            for s in Signal::ALL {
                let r = row(rev, s).unwrap_or_else(|| panic!("{rev:?}: no row for {s:?}"));
                assert_eq!(r.signal.mcu(), s.mcu());
                if s.to_driver() || s == Signal::Miso {
                    // A rig builder wires these: a Zio header pin each.
                    assert!(
                        matches!(r.place, Place::Header { .. }),
                        "{rev:?} {s:?} must be on a Zio header"
                    );
                }
            }
        }
    }

    #[test]
    fn the_driver_wires_go_to_the_same_pins_on_both_boards() {
        for s in Signal::ALL.iter().filter(|s| s.to_driver()) {
            assert_eq!(
                header_pin(Revision::Zi, *s),
                header_pin(Revision::Zi2, *s),
                "{s:?}"
            );
        }
    }

    #[test]
    fn mosi_avoids_the_ethernet_shared_d11_of_the_zi() {
        // MB1137's D11 (CN7 pin 14) is PA7, shared with the PHY's CRS_DV.
        assert_eq!(Signal::Mosi.mcu(), "PB5");
        let mosi = header_pin(Revision::Zi, Signal::Mosi).unwrap();
        assert_ne!(mosi, pin(Cn7, 14));
        assert_eq!(mosi, pin(Cn7, 13));
    }

    #[test]
    fn the_loopback_wire_joins_mosi_and_miso_on_both_boards() {
        for rev in Revision::ALL {
            assert_eq!(Some(LOOPBACK_WIRE.0), header_pin(rev, Signal::Mosi));
            assert_eq!(Some(LOOPBACK_WIRE.1), header_pin(rev, Signal::Miso));
        }
    }

    #[test]
    fn no_pin_is_used_twice_and_grounds_are_not_signals() {
        for rev in Revision::ALL {
            let mut used = std::vec::Vec::new();
            for r in rev.rows() {
                if let Some(p) = header_pin(rev, r.signal) {
                    used.push(p);
                }
                match r.morpho {
                    Morpho::Pin(p) | Morpho::NotFitted(p, _) => used.push(p),
                }
            }
            for g in rev.grounds() {
                used.push(g.pin);
            }
            for (i, a) in used.iter().enumerate() {
                assert!(!used[i + 1..].contains(a), "{rev:?}: {a} twice");
            }
        }
    }

    /// The README's pin tables are this module's, rendered.
    #[test]
    fn the_readme_carries_these_tables() {
        let readme = include_str!("../../README.md");
        for rev in Revision::ALL {
            let mut want = String::new();
            markdown(rev, &mut want).unwrap();
            let start = std::format!("<!-- pins:{} -->\n", rev.board());
            let end = "<!-- /pins -->";
            let at = readme
                .find(&start)
                .unwrap_or_else(|| panic!("README: no `{}` marker", start.trim()))
                + start.len();
            let len = readme[at..].find(end).expect("README: no end marker");
            assert!(
                readme[at..at + len] == want,
                "firmware/nucleo-h743/README.md: the {} table differs from \
                 pins::markdown; it should read:\n{want}",
                rev.board()
            );
        }
    }

    /// The board crate takes its peripherals on these MCU pins.
    #[test]
    fn the_board_crate_uses_these_pins() {
        let src: String = include_str!("../../src/board.rs")
            .chars()
            .filter(|c| !c.is_whitespace())
            .collect();
        let p = |s: Signal| std::format!("p.{}", s.mcu());
        let spi = std::format!(
            "Spi::new(p.SPI1,{},{},{},",
            p(Signal::Sck),
            p(Signal::Mosi),
            p(Signal::Miso)
        );
        assert!(src.contains(&spi), "board.rs: {spi}");
        let cs = std::format!("Output::new({},Level::High", p(Signal::ChipSelect));
        assert!(src.contains(&cs), "board.rs: {cs}");
        let mco = std::format!("Mco::new(p.MCO2,{},", p(Signal::Reference));
        assert!(src.contains(&mco), "board.rs: {mco}");
        let uart = std::format!(
            "BufferedUart::new(p.USART3,{},{},",
            p(Signal::UartRx),
            p(Signal::UartTx)
        );
        assert!(src.contains(&uart), "board.rs: {uart}");
        let usb = std::format!(
            "Driver::new_fs(p.USB_OTG_FS,Irqs,{},{},",
            p(Signal::UsbDp),
            p(Signal::UsbDm)
        );
        assert!(src.contains(&usb), "board.rs: {usb}");
    }
}
