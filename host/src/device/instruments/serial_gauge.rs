//! What the serial force gauges share: one request line, one reply line,
//! the reply's value and unit as a [`Reading`] stamped when it arrived. A
//! [`Dialect`] says what to ask and how to read the answer
//! ([`imada`](super::imada), [`mark10`](super::mark10)).

use std::marker::PhantomData;
use std::time::Duration;

use super::error::InstrumentError;
use super::gauge::{ForceGauge, Reading};
use super::port::{LineIo, Port, open_serial};
use super::unit::ForceUnit;
use crate::clock::Clock;

/// One gauge model's request and reply.
pub trait Dialect {
    /// The request for the displayed value (sent with CR).
    const REQUEST: &'static str;
    /// How long a reply may take.
    const REPLY_TIMEOUT: Duration;
    /// The value and unit a reply `line` gives, or why it gives none
    /// (`port` names the gauge in the error).
    fn reading(port: &str, line: &str) -> Result<(f64, ForceUnit), InstrumentError>;
}

/// A force gauge that answers each request with one line, in dialect `D`.
pub struct SerialGauge<P, D> {
    io: LineIo<P>,
    dialect: PhantomData<D>,
}

impl<D: Dialect> SerialGauge<Box<dyn serialport::SerialPort>, D> {
    /// Open the gauge at serial port `path` (`baud` as set on the gauge)
    /// and take one reading to check it answers.
    pub fn open(path: &str, baud: u32) -> Result<Self, InstrumentError> {
        let port = open_serial(path, baud)?;
        Self::connect(port, path, Clock::real(), D::REPLY_TIMEOUT)
    }
}

impl<P: Port, D: Dialect> SerialGauge<P, D> {
    /// The gauge over `port`, checked with one reading.
    pub fn connect(
        port: P,
        name: &str,
        clock: Clock,
        reply_timeout: Duration,
    ) -> Result<Self, InstrumentError> {
        let mut g = Self {
            io: LineIo::new(port, name, clock, reply_timeout),
            dialect: PhantomData,
        };
        g.read()?;
        Ok(g)
    }
}

impl<P: Port, D: Dialect> ForceGauge for SerialGauge<P, D> {
    fn port(&self) -> &str {
        self.io.name()
    }

    fn clock(&self) -> &Clock {
        self.io.clock()
    }

    fn read(&mut self) -> Result<Reading, InstrumentError> {
        let line = self.io.ask(D::REQUEST, "\r")?;
        let at_us = self.io.clock().now_us();
        let (value, unit) = D::reading(self.io.name(), &line)?;
        Ok(Reading {
            at_us,
            force_n: unit.to_newtons(value),
            value,
            unit,
        })
    }
}
