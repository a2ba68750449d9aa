//! CHUO PRECISION (Chuo Seiki) QT-series stage controllers (QT-AMM3,
//! QT-ADM3, QT-ADM2, QT-AMH2A, QT-ADL1, …) over RS-232: one axis of the
//! controller as a [`Stage`].
//!
//! The command set is the one the manufacturer's own Micro-Manager device
//! adapter uses (`DeviceAdapters/ChuoSeiki_QT/ChuoSeiki_QT_XYZ.cpp` and
//! `ReadMe.txt` in micro-manager/mmCoreAndDevices, written by Chuo
//! Precision Industrial, LGPL): 9600 baud, 8N1, no handshake, commands end
//! in CR LF, replies end in CR LF, 500 ms reply timeout.
//!
//! | request | meaning | reply |
//! |---|---|---|
//! | `?:CHUOSEIKI` | identify | a line starting `CHUOSEIKI` |
//! | `X:1` | answer every command with a line | a line |
//! | `D:A<low>P<high>P<accel>` | speeds (pulses/s) and acceleration time (ms) of axis A | ack |
//! | `AGO:A<pulses>` | absolute move of axis A | ack |
//! | `Q:A0` | position and state of axis A | sign, 8 digits, a state letter (`D` driving, `H` homing) |
//! | `Q:A2` | state of axis A | one state letter |
//! | `H:A` | home axis A (mechanical origin) | ack |
//! | `L:` | stop all axes | ack |
//!
//! An ack is a line; an error is `!0`…`!9` (the adapter's table: not in
//! command mode, syntax, value overflow, axis, too many characters, stop
//! error, limit detected, alarm stop, communication or driver error,
//! other). The adapter accepts any other line as success; here only an
//! empty line is (after `X:1` the controller sends just CR LF), and any
//! other text is refused as a protocol error, so a confused link cannot
//! pass for a move that started. The position reply is documented in the
//! adapter as "(+ or -)(8 digits)(stage state keyword)"; it is parsed as a
//! sign, 1 to 9 digits and one upper-case letter, nothing else.
//!
//! Positions are pulses on the wire: the step (µm per pulse) depends on
//! the stage and the driver's micro-stepping (the adapter's default is
//! 1 µm), so it is configuration ([`QtConfig::step_um`]), never guessed.

use std::time::Duration;

use super::error::{InstrumentError, quote};
use super::port::{LineIo, Port, open_serial};
use super::stage::{
    Move, PAPER_SPEED_MM_S, Stage, StageLimits, check_speed, move_timeout, wait_idle,
};
use crate::clock::Clock;
use crate::limits::show;

/// The QT controllers' baud rate.
pub const QT_BAUD: u32 = 9600;
/// The QT controllers' reply timeout (the adapter's `AnswerTimeout`).
pub const QT_REPLY_TIMEOUT: Duration = Duration::from_millis(500);
/// Largest |position| the 8-digit position reply can carry, pulses.
pub const QT_MAX_PULSES: i64 = 99_999_999;
/// Highest pulse rate asked of the controller, pulses/s.
pub const QT_MAX_PPS: u32 = 999_999;
const TERM: &str = "\r\n";

/// Which axis of the controller pushes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// Channel A.
    A,
    /// Channel B.
    B,
    /// Channel C (three-axis controllers).
    C,
}

impl Axis {
    fn letter(self) -> char {
        match self {
            Self::A => 'A',
            Self::B => 'B',
            Self::C => 'C',
        }
    }

    /// An axis from `A`, `B` or `C` (any case).
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "A" | "a" => Some(Self::A),
            "B" | "b" => Some(Self::B),
            "C" | "c" => Some(Self::C),
            _ => None,
        }
    }
}

/// How a QT controller and its stage are set up.
#[derive(Debug, Clone)]
pub struct QtConfig {
    /// The pushing axis.
    pub axis: Axis,
    /// Micrometres per pulse (the stage's lead and the driver's
    /// micro-stepping).
    pub step_um: f64,
    /// Soft limits of the push axis, mm.
    pub limits: StageLimits,
    /// Speed of moves, mm/s (the paper's 5 by default).
    pub speed_mm_s: f64,
    /// Acceleration time, ms (the adapter's default, 100).
    pub accel_ms: u32,
    /// Baud rate ([`QT_BAUD`]).
    pub baud: u32,
    /// Reply timeout ([`QT_REPLY_TIMEOUT`]).
    pub reply_timeout: Duration,
}

impl QtConfig {
    /// Axis A, 1 µm per pulse, the given limits, 5 mm/s.
    pub fn new(limits: StageLimits) -> Self {
        Self {
            axis: Axis::A,
            step_um: 1.0,
            limits,
            speed_mm_s: PAPER_SPEED_MM_S,
            accel_ms: 100,
            baud: QT_BAUD,
            reply_timeout: QT_REPLY_TIMEOUT,
        }
    }

    /// Checks what the configuration says of the stage: a step the
    /// controller can be set to, soft limits within its pulse counter.
    /// `name` is the port, for the message. The simulated twin is checked
    /// the same way, so a rehearsal refuses what the rig would.
    pub fn check(&self, name: &str) -> Result<(), InstrumentError> {
        if !(self.step_um.is_finite() && (0.001..=1000.0).contains(&self.step_um)) {
            return Err(InstrumentError::limit(
                name,
                format!(
                    "stage step {} µm/pulse is outside 0.001..=1000 µm/pulse",
                    show(self.step_um)
                ),
            ));
        }
        for edge in [self.limits.min_mm, self.limits.max_mm] {
            if (edge * 1000.0 / self.step_um).abs() > QT_MAX_PULSES as f64 {
                return Err(InstrumentError::limit(
                    name,
                    format!(
                        "soft limit {} mm is beyond what the controller can count ({QT_MAX_PULSES} pulses of {} µm)",
                        show(edge),
                        show(self.step_um)
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// One axis of a QT controller.
pub struct ChuoQt<P> {
    io: LineIo<P>,
    cfg: QtConfig,
}

impl ChuoQt<Box<dyn serialport::SerialPort>> {
    /// Open the controller at serial port `path`, identify it, switch its
    /// replies on and set the speed.
    pub fn open(path: &str, cfg: QtConfig) -> Result<Self, InstrumentError> {
        // A bad step is the user's, whatever the port does: said first.
        cfg.check(path)?;
        let port = open_serial(path, cfg.baud)?;
        Self::connect(port, path, cfg, Clock::real())
    }
}

impl<P: Port> ChuoQt<P> {
    /// The controller over `port` (called `name` in messages): identify
    /// it, switch its replies on and set the speed.
    pub fn connect(
        port: P,
        name: &str,
        cfg: QtConfig,
        clock: Clock,
    ) -> Result<Self, InstrumentError> {
        cfg.check(name)?;
        let mut qt = Self {
            io: LineIo::new(port, name, clock, cfg.reply_timeout),
            cfg,
        };
        qt.identify()?;
        let on = qt.io.ask("X:1", TERM)?;
        qt.check_error("X:1", &on)?;
        let speed = qt.cfg.speed_mm_s;
        qt.set_speed(speed)?;
        Ok(qt)
    }

    /// The controller answers `?:CHUOSEIKI` with a line starting
    /// `CHUOSEIKI`; the first answer after power-up may be noise, so it is
    /// asked three times (the adapter asks five) before giving up.
    fn identify(&mut self) -> Result<(), InstrumentError> {
        let mut tries = 0;
        loop {
            tries += 1;
            let err = match self.io.ask("?:CHUOSEIKI", TERM) {
                Ok(reply) if reply.starts_with("CHUOSEIKI") => return Ok(()),
                Ok(reply) => InstrumentError::protocol(
                    self.io.name(),
                    format!(
                        "not a Chuo Seiki QT controller: ?:CHUOSEIKI answered {}",
                        quote(reply.as_bytes())
                    ),
                ),
                Err(e) if e.is_silence() => e,
                Err(e) => return Err(e),
            };
            if tries == 3 {
                return Err(err);
            }
        }
    }

    fn axis(&self) -> char {
        self.cfg.axis.letter()
    }

    fn pulses(&self, mm: f64) -> i64 {
        (mm * 1000.0 / self.cfg.step_um).round() as i64
    }

    fn mm(&self, pulses: i64) -> f64 {
        pulses as f64 * self.cfg.step_um / 1000.0
    }

    /// `Err` for a `!n` reply.
    fn check_error(&self, request: &str, reply: &str) -> Result<(), InstrumentError> {
        let b = reply.as_bytes();
        if b.len() == 2 && b[0] == b'!' && b[1].is_ascii_digit() {
            let what = match b[1] {
                b'0' => "not in command mode",
                b'1' => "command syntax error",
                b'2' => "value out of range",
                b'3' => "axis error",
                b'4' => "command too long",
                b'5' => "stop command error",
                b'6' => "limit switch reached",
                b'7' => "alarm stop",
                b'8' => "communication or driver error",
                _ => "other error",
            };
            return Err(InstrumentError::refused(
                self.io.name(),
                format!("controller refused {request}: {what} ({reply})"),
            ));
        }
        Ok(())
    }

    /// Send a control command and check its ack.
    fn command(&mut self, request: &str) -> Result<(), InstrumentError> {
        let reply = self.io.ask(request, TERM)?;
        self.check_error(request, &reply)?;
        if !reply.trim().is_empty() {
            return Err(InstrumentError::protocol(
                self.io.name(),
                format!("unexpected reply to {request}: {}", quote(reply.as_bytes())),
            ));
        }
        Ok(())
    }

    /// `Q:A0`: position (pulses) and state letter.
    fn query_position(&mut self) -> Result<(i64, u8), InstrumentError> {
        let request = format!("Q:{}0", self.axis());
        let reply = self.io.ask(&request, TERM)?;
        self.check_error(&request, &reply)?;
        parse_position(&reply).ok_or_else(|| {
            InstrumentError::protocol(
                self.io.name(),
                format!(
                    "position reply to {request} is not a sign, 8 digits and a state letter: {}",
                    quote(reply.as_bytes())
                ),
            )
        })
    }
}

/// `+00012345K` → (12345, b'K').
fn parse_position(reply: &str) -> Option<(i64, u8)> {
    let b = reply.trim_end_matches(' ').as_bytes();
    let (&sign, rest) = b.split_first()?;
    let (&state, digits) = rest.split_last()?;
    let neg = match sign {
        b'+' => false,
        b'-' => true,
        _ => return None,
    };
    if digits.is_empty() || digits.len() > 9 || !digits.iter().all(u8::is_ascii_digit) {
        return None;
    }
    if !state.is_ascii_uppercase() {
        return None;
    }
    let v: i64 = std::str::from_utf8(digits).ok()?.parse().ok()?;
    Some((if neg { -v } else { v }, state))
}

impl<P: Port> Stage for ChuoQt<P> {
    fn port(&self) -> &str {
        self.io.name()
    }

    fn clock(&self) -> &Clock {
        self.io.clock()
    }

    fn limits(&self) -> StageLimits {
        self.cfg.limits
    }

    fn speed_mm_s(&self) -> f64 {
        self.cfg.speed_mm_s
    }

    fn tolerance_mm(&self) -> f64 {
        // One pulse, and never below 1 µm of rounding.
        (self.cfg.step_um / 1000.0).max(0.001)
    }

    fn set_speed(&mut self, mm_s: f64) -> Result<(), InstrumentError> {
        check_speed(self.io.name(), mm_s)?;
        let high = (mm_s * 1000.0 / self.cfg.step_um).round();
        if !(1.0..=QT_MAX_PPS as f64).contains(&high) {
            return Err(InstrumentError::limit(
                self.io.name(),
                format!(
                    "{} mm/s at {} µm/pulse is {} pulses/s, outside 1..{QT_MAX_PPS}",
                    show(mm_s),
                    show(self.cfg.step_um),
                    show(high)
                ),
            ));
        }
        let high = high as u32;
        // The start speed must be below the running speed (the adapter's
        // note); its default is 500 pulses/s.
        let low = (high / 2).clamp(1, 500);
        let request = format!("D:{}{low}P{high}P{}", self.axis(), self.cfg.accel_ms);
        self.command(&request)?;
        self.cfg.speed_mm_s = mm_s;
        Ok(())
    }

    fn position_mm(&mut self) -> Result<f64, InstrumentError> {
        let (pulses, _) = self.query_position()?;
        Ok(self.mm(pulses))
    }

    fn start_move(&mut self, to_mm: f64) -> Result<(), InstrumentError> {
        self.cfg.limits.check(self.io.name(), to_mm)?;
        let request = format!("AGO:{}{}", self.axis(), self.pulses(to_mm));
        self.command(&request)
    }

    fn is_moving(&mut self) -> Result<bool, InstrumentError> {
        let request = format!("Q:{}2", self.axis());
        let reply = self.io.ask(&request, TERM)?;
        self.check_error(&request, &reply)?;
        match reply.trim_end_matches(' ').as_bytes() {
            // D: driving; H: homing in progress.
            [b'D'] | [b'H'] => Ok(true),
            [c] if c.is_ascii_uppercase() => Ok(false),
            _ => Err(InstrumentError::protocol(
                self.io.name(),
                format!(
                    "state reply to {request} is not one letter: {}",
                    quote(reply.as_bytes())
                ),
            )),
        }
    }

    fn stop(&mut self) -> Result<(), InstrumentError> {
        // `L:` stops every axis: on a rig pushing a finger, stopping all
        // of them is the safe reading of "stop".
        self.command("L:")
    }

    fn home(&mut self) -> Result<Move, InstrumentError> {
        let from_mm = self.position_mm()?;
        let request = format!("H:{}", self.axis());
        self.command(&request)?;
        // The origin search may run the whole travel and back.
        let timeout = move_timeout(2.0 * self.cfg.limits.span_mm(), self.cfg.speed_mm_s);
        let took = wait_idle(self, timeout, || "homing".to_owned())?;
        let at_mm = self.position_mm()?;
        Ok(Move {
            from_mm,
            at_mm,
            took_s: took.as_secs_f64(),
        })
    }
}

#[cfg(test)]
#[path = "chuo_tests.rs"]
mod tests;
