//! Which header pin drives which transducer: the map a rig builder wires
//! the driver boards from (`lmhost wiring`, `firmware/DRIVER.md`).
//!
//! Frame channel `i` of the LM firmware's SPI frame is the scene's
//! transducer `i` (global index order, [`Scene::transducers`]). The array
//! is split onto iCE40-HX8K breakout boards of at most
//! [`MAX_CHANNELS_PER_BOARD`] channels, the last taking the remainder
//! (`cargo xtask bitstream --all` builds the same split); board channel
//! `k` is the design's `out[k]`, whose header and pin come from the
//! board's pin constraints (`gateware/ice40hx8k-b-evn.pcf`, read here so
//! the map and the bitstreams cannot disagree).

use std::sync::OnceLock;

use serde::Serialize;

use crate::InputError;
use crate::plan::array::AUTD3_TRANSDUCERS;
use crate::plan::scene::Scene;

/// The driver board's pin constraints, as the bitstreams are built with.
const PCF: &str = include_str!("../../../gateware/ice40hx8k-b-evn.pcf");

/// Channels of one iCE40-HX8K breakout board (the outputs its headers
/// bring out in `hx8k.py`).
pub const MAX_CHANNELS_PER_BOARD: usize = 64;

/// Where one board output leaves the board.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Pin {
    /// Header name (`J2`, `J3`, `J4`).
    pub header: String,
    /// Pin number on that header.
    #[serde(rename = "header_pin")]
    pub pin: u8,
    /// CT256 ball of the FPGA.
    pub ball: String,
}

/// One channel of the map.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Channel {
    /// Frame channel = the scene's global transducer index.
    pub channel: usize,
    /// Driver board (0-based, in bus order).
    pub board: usize,
    /// The board's output (`out[k]`).
    pub board_channel: usize,
    /// Where that output leaves the board.
    #[serde(flatten)]
    pub pin: Pin,
    /// Scene device (AUTD3 board) the transducer sits on.
    pub device: usize,
    /// The transducer's index on that device (AUTD3 order, x fastest).
    pub device_transducer: usize,
    /// Centre of the transducer's face in scene coordinates (mm).
    pub pos_mm: [f64; 3],
}

/// `out[k]` → its header pin, parsed once from the pin constraints.
pub fn board_pins() -> Result<&'static [Pin], InputError> {
    static PINS: OnceLock<Result<Vec<Pin>, String>> = OnceLock::new();
    PINS.get_or_init(|| parse_pcf(PCF))
        .as_deref()
        .map_err(|e| InputError::new(format!("the driver board's pin table: {e}")))
}

/// The `out[k]` lines of a PCF (`set_io out[K] BALL  # JX pin P`), in
/// output order; every output from 0 up must be there once.
fn parse_pcf(text: &str) -> Result<Vec<Pin>, String> {
    let mut pins: Vec<Option<Pin>> = Vec::new();
    for line in text.lines() {
        let (code, comment) = line.split_once('#').unwrap_or((line, ""));
        let words: Vec<&str> = code.split_whitespace().collect();
        let ["set_io", name, ball] = words[..] else {
            continue;
        };
        let Some(k) = name.strip_prefix("out[").and_then(|n| n.strip_suffix(']')) else {
            continue;
        };
        let k: usize = k.parse().map_err(|_| format!("bad output name `{name}`"))?;
        let mut c = comment.split_whitespace();
        let (Some(header), Some("pin"), Some(pin)) = (c.next(), c.next(), c.next()) else {
            return Err(format!("`{name}` does not say its header pin"));
        };
        let pin = pin
            .trim_end_matches(',')
            .parse()
            .map_err(|_| format!("`{name}`: bad pin number `{pin}`"))?;
        if k >= MAX_CHANNELS_PER_BOARD {
            return Err(format!(
                "`{name}` is beyond the board's {MAX_CHANNELS_PER_BOARD} outputs"
            ));
        }
        if pins.len() <= k {
            pins.resize(k + 1, None);
        }
        if pins[k].is_some() {
            return Err(format!("`{name}` is placed twice"));
        }
        pins[k] = Some(Pin {
            header: header.to_string(),
            pin,
            ball: ball.to_string(),
        });
    }
    if pins.len() != MAX_CHANNELS_PER_BOARD {
        return Err(format!(
            "{} outputs placed, not {MAX_CHANNELS_PER_BOARD}",
            pins.len()
        ));
    }
    pins.into_iter()
        .enumerate()
        .map(|(k, p)| p.ok_or_else(|| format!("out[{k}] is not placed")))
        .collect()
}

/// The map for `scene` on boards of `per_board` channels (1 to
/// [`MAX_CHANNELS_PER_BOARD`]).
pub fn map(scene: &Scene, per_board: usize) -> Result<Vec<Channel>, InputError> {
    if !(1..=MAX_CHANNELS_PER_BOARD).contains(&per_board) {
        return Err(InputError::new(format!(
            "--channels-per-board must be 1 to {MAX_CHANNELS_PER_BOARD} (the breakout board's outputs), not {per_board}"
        )));
    }
    let pins = board_pins()?;
    Ok(scene
        .transducers()
        .iter()
        .enumerate()
        .map(|(i, t)| Channel {
            channel: i,
            board: i / per_board,
            board_channel: i % per_board,
            pin: pins[i % per_board].clone(),
            device: i / AUTD3_TRANSDUCERS,
            device_transducer: i % AUTD3_TRANSDUCERS,
            pos_mm: t.pos_mm,
        })
        .collect())
}

/// The CSV header of [`to_csv`].
pub const CSV_HEADER: &str =
    "channel,board,board_channel,header,header_pin,ball,device,device_transducer,x_mm,y_mm,z_mm";

/// The map as CSV, one line per channel after [`CSV_HEADER`] (positions
/// to the micrometre, as the wire carries them).
pub fn to_csv(map: &[Channel]) -> String {
    let mut s = String::with_capacity(64 * (map.len() + 1));
    s.push_str(CSV_HEADER);
    s.push('\n');
    for c in map {
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{},{:.3},{:.3},{:.3}\n",
            c.channel,
            c.board,
            c.board_channel,
            c.pin.header,
            c.pin.pin,
            c.pin.ball,
            c.device,
            c.device_transducer,
            c.pos_mm[0],
            c.pos_mm[1],
            c.pos_mm[2]
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_output_has_one_header_pin() {
        let pins = board_pins().unwrap();
        assert_eq!(pins.len(), MAX_CHANNELS_PER_BOARD);
        let mut seen = std::collections::BTreeSet::new();
        for p in pins {
            assert!(["J2", "J3", "J4"].contains(&p.header.as_str()), "{p:?}");
            assert!((1..=40).contains(&p.pin), "{p:?}");
            assert!(seen.insert((p.header.clone(), p.pin)), "{p:?} used twice");
        }
        // As DRIVER.md's table has them: out[0] on J2 pin 4.
        assert_eq!((pins[0].header.as_str(), pins[0].pin), ("J2", 4));
    }

    #[test]
    fn the_paper_array_splits_as_the_bitstreams_do() {
        let m = map(&Scene::default(), MAX_CHANNELS_PER_BOARD).unwrap();
        assert_eq!(m.len(), 996);
        let boards = m.iter().map(|c| c.board).max().unwrap() + 1;
        assert_eq!(boards, 16);
        let last: Vec<_> = m.iter().filter(|c| c.board == 15).collect();
        assert_eq!((last.len(), last[0].channel), (36, 960));
        // Channel 250 is device 1's transducer 1, on board 3's output 58.
        let c = &m[250];
        assert_eq!((c.device, c.device_transducer), (1, 1));
        assert_eq!((c.board, c.board_channel), (3, 58));
        assert_eq!(c.pos_mm, Scene::default().transducers()[250].pos_mm);
        let csv = to_csv(&m);
        assert_eq!(csv.lines().count(), 997);
        assert!(csv.lines().nth(1).unwrap().starts_with("0,0,0,J2,4,"));
    }

    #[test]
    fn a_broken_pin_table_is_an_error() {
        assert!(parse_pcf("set_io out[0] A1 # J2 pin 4\n").is_err());
        let dup = "set_io out[0] A1 # J2 pin 4\nset_io out[0] A2 # J2 pin 5\n";
        assert!(parse_pcf(dup).unwrap_err().contains("twice"));
        assert!(
            parse_pcf("set_io out[0] A1\n")
                .unwrap_err()
                .contains("header pin")
        );
        assert!(map(&Scene::default(), 0).is_err());
        assert!(map(&Scene::default(), 65).is_err());
    }
}
