//! The IMADA and Mark-10 drivers against fake gauges that speak their
//! documented replies, with unit changes, malformed replies and silence.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::port::fake::{Engine, FakePort};
use super::{ForceGauge, ForceUnit, Imada, InstrumentError, Mark10};
use crate::clock::Clock;

/// What a fake gauge sends.
#[derive(Debug, Clone, PartialEq)]
enum Mode {
    /// A reading of the true force in the gauge's unit.
    Normal,
    /// Nothing.
    Silent,
    /// This exact line.
    Line(&'static str),
}

struct FakeGauge {
    force_n: f64,
    unit: ForceUnit,
    mode: Mode,
    /// IMADA (`D`) or Mark-10 (`?`).
    imada: bool,
}

impl Engine for FakeGauge {
    fn answer(&mut self, request: &str) -> Vec<u8> {
        let expected = if self.imada { "D" } else { "?" };
        let (term, unknown) = if self.imada {
            ("\r", "")
        } else {
            ("\r\n", "*10")
        };
        let body = match (&self.mode, request == expected) {
            (Mode::Silent, _) => return Vec::new(),
            (_, false) => unknown.to_owned(),
            (Mode::Line(l), true) => (*l).to_owned(),
            (Mode::Normal, true) => {
                let v = self.force_n / self.unit.newtons();
                match (self.imada, self.unit) {
                    (true, ForceUnit::N) => format!("{v:+.2}NTO"),
                    (true, ForceUnit::Kgf) => format!("{v:+.3}KTO"),
                    (true, ForceUnit::Lbf) => format!("{v:+.2}OTO"),
                    (true, u) => panic!("IMADA has no {u}"),
                    (false, ForceUnit::N) => format!("{v:.3} N"),
                    (false, ForceUnit::Kgf) => format!("{v:.4} kgF"),
                    (false, ForceUnit::Lbf) => format!("{v:.3} lbF"),
                    (false, u) => format!("{v:.3} {u}"),
                }
            }
        };
        format!("{body}{term}").into_bytes()
    }
}

type Shared = Arc<Mutex<FakeGauge>>;

fn fake(imada: bool) -> (FakePort<FakeGauge>, Shared) {
    let port = FakePort::new(FakeGauge {
        force_n: 0.24,
        unit: ForceUnit::N,
        mode: Mode::Normal,
        imada,
    });
    let engine = port.engine.clone();
    (port, engine)
}

const T: Duration = Duration::from_millis(500);

fn imada() -> (Imada<FakePort<FakeGauge>>, Shared) {
    let (port, e) = fake(true);
    (
        Imada::connect(port, "/dev/ttyUSB1", Clock::manual(), T).unwrap(),
        e,
    )
}

fn mark10() -> (Mark10<FakePort<FakeGauge>>, Shared) {
    let (port, e) = fake(false);
    (
        Mark10::connect(port, "/dev/ttyACM0", Clock::manual(), T).unwrap(),
        e,
    )
}

#[test]
fn both_gauges_convert_every_unit_to_newtons() {
    let (mut im, ie) = imada();
    let (mut mk, me) = mark10();
    for unit in [ForceUnit::N, ForceUnit::Kgf, ForceUnit::Lbf] {
        for (gauge, engine) in [
            (&mut im as &mut dyn ForceGauge, &ie),
            (&mut mk as &mut dyn ForceGauge, &me),
        ] {
            {
                let mut e = engine.lock().unwrap();
                e.unit = unit;
                e.force_n = 1.5;
            }
            let r = gauge.read().unwrap();
            assert_eq!(r.unit, unit);
            // Within half a displayed digit (0.01 lbf is 0.044 N).
            assert!(
                (r.force_n - 1.5).abs() < 0.025,
                "{} {unit}: {}",
                gauge.port(),
                r.force_n
            );
            assert!((r.value - 1.5 / unit.newtons()).abs() <= 0.005 + 1e-12);
        }
    }
}

#[test]
fn a_unit_change_mid_series_keeps_the_series_in_newtons() {
    let (mut g, e) = imada();
    e.lock().unwrap().force_n = 0.5;
    let first = g.sample(0.1, 100.0).unwrap();
    e.lock().unwrap().unit = ForceUnit::Kgf;
    let second = g.sample(0.1, 100.0).unwrap();
    assert_eq!(first.samples[0].unit, ForceUnit::N);
    assert_eq!(second.samples[0].unit, ForceUnit::Kgf);
    assert!((first.median_n().unwrap() - second.median_n().unwrap()).abs() < 0.005);
    // Requested every 10 ms on the gauge's clock.
    assert_eq!(second.samples[1].at_us - second.samples[0].at_us, 10_000);
}

/// Each reply line, sent by the gauge, is refused with its message.
fn refuses_each(g: &mut impl ForceGauge, e: &Shared, cases: &[(&'static str, &str)]) {
    for &(line, msg) in cases {
        e.lock().unwrap().mode = Mode::Line(line);
        assert_eq!(g.read().unwrap_err().to_string(), msg, "{line}");
    }
}

#[test]
fn imada_peak_mode_overload_and_garbage_are_refused() {
    let (mut g, e) = imada();
    let cases = [
        (
            "+12.34NPO",
            "/dev/ttyUSB1: gauge is in peak mode (+12.34NPO); set it to real time (T)",
        ),
        (
            "+50.01NTE",
            "/dev/ttyUSB1: gauge reports an overload (+50.01NTE); unload it",
        ),
        (
            "12.34 N",
            "/dev/ttyUSB1: reply to D is not sign, value, unit N/K/O (mode, judgement): '12.34 N'",
        ),
    ];
    refuses_each(&mut g, &e, &cases);
    e.lock().unwrap().mode = Mode::Silent;
    let err = g.read().unwrap_err();
    assert!(matches!(err, InstrumentError::Timeout { .. }), "{err}");
    // It answers again once the fault is gone: no state was left behind.
    e.lock().unwrap().mode = Mode::Normal;
    assert!((g.read().unwrap().force_n - 0.24).abs() < 1e-9);
}

#[test]
fn mark10_missing_or_unknown_units_and_error_codes_are_refused() {
    let (mut g, e) = mark10();
    let cases = [
        (
            "12.34",
            "/dev/ttyACM0: reply '12.34' has no unit; include units in the gauge's Serial/USB data format",
        ),
        (
            "1.50 psi",
            "/dev/ttyACM0: reply '1.50 psi' is in unit 'psi', which is not a force unit lmhost knows",
        ),
        (
            "*10",
            "/dev/ttyACM0: gauge answered ? with error *10 (*10: illegal command)",
        ),
        (
            "N 12",
            "/dev/ttyACM0: reply to ? is not a value and a unit: 'N 12'",
        ),
    ];
    refuses_each(&mut g, &e, &cases);
}

#[test]
fn a_silent_gauge_is_refused_at_connect() {
    let (port, e) = fake(false);
    e.lock().unwrap().mode = Mode::Silent;
    let Err(err) = Mark10::connect(port, "/dev/ttyACM0", Clock::manual(), T) else {
        panic!("connected to nothing")
    };
    assert!(
        err.to_string()
            .starts_with("/dev/ttyACM0: no reply to ? within 500 ms"),
        "{err}"
    );
    // An IMADA on a Mark-10 port (or the reverse) is refused too.
    let (port, _) = fake(true);
    let Err(err) = Mark10::connect(port, "/dev/ttyACM0", Clock::manual(), T) else {
        panic!("an IMADA passed for a Mark-10")
    };
    assert!(
        matches!(
            err,
            InstrumentError::Timeout { .. } | InstrumentError::Protocol { .. }
        ),
        "{err}"
    );
}
