//! The QT driver against a fake controller that speaks the command set of
//! the module docs over a simulated stage (pulses of 1 µm), on a manual
//! clock; and once over a real pty through `serialport`.

use std::sync::{Arc, Mutex};

use super::*;
use crate::device::instruments::port::fake::{Engine, FakePort};
use crate::device::instruments::{SimStage, Stage};

/// What the fake controller does wrong.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Fault {
    None,
    /// Answers nothing at all.
    Silent,
    /// Identifies as something else.
    NotChuo,
    /// Position replies are garbage.
    GarbagePosition,
    /// Claims to drive forever.
    StuckDriving,
    /// Refuses moves with `!6` (limit switch).
    LimitSwitch,
    /// Stops every move 1 mm short.
    StopsShort,
}

pub(crate) struct QtController {
    pub stage: SimStage,
    pub fault: Fault,
    replies_on: bool,
}

impl QtController {
    pub fn new(clock: Clock) -> Self {
        let stage = SimStage::new(clock, StageLimits::new(-50.0, 50.0).unwrap(), 0.0).unwrap();
        Self {
            stage,
            fault: Fault::None,
            replies_on: false,
        }
    }

    fn ack(&self) -> Vec<u8> {
        if self.replies_on {
            b"\r\n".to_vec()
        } else {
            Vec::new()
        }
    }
}

impl Engine for QtController {
    fn answer(&mut self, request: &str) -> Vec<u8> {
        if self.fault == Fault::Silent {
            return Vec::new();
        }
        let line = |s: &str| format!("{s}\r\n").into_bytes();
        let pulses = |mm: f64| (mm * 1000.0).round() as i64;
        match request {
            "?:CHUOSEIKI" if self.fault == Fault::NotChuo => line("OK"),
            "?:CHUOSEIKI" => line("CHUOSEIKI QT-AMM3 V1.00"),
            "X:1" => {
                self.replies_on = true;
                self.ack()
            }
            "L:" => {
                self.stage.stop().unwrap();
                self.ack()
            }
            "Q:A0" if self.fault == Fault::GarbagePosition => line("+12AB"),
            "Q:A0" => {
                let p = pulses(self.stage.position_mm().unwrap());
                let state = if self.stage.is_moving().unwrap() {
                    'D'
                } else {
                    'K'
                };
                line(&format!(
                    "{}{:08}{state}",
                    if p < 0 { '-' } else { '+' },
                    p.abs()
                ))
            }
            "Q:A2" if self.fault == Fault::StuckDriving => line("D"),
            "Q:A2" => line(if self.stage.is_moving().unwrap() {
                "D"
            } else {
                "K"
            }),
            "H:A" => {
                self.stage.start_move(0.0).unwrap();
                self.ack()
            }
            _ => {
                if let Some(rest) = request.strip_prefix("AGO:A") {
                    if self.fault == Fault::LimitSwitch {
                        return line("!6");
                    }
                    let Ok(p) = rest.parse::<i64>() else {
                        return line("!1");
                    };
                    let mut mm = p as f64 / 1000.0;
                    if self.fault == Fault::StopsShort {
                        mm -= 1.0;
                    }
                    self.stage.start_move(mm).unwrap();
                    return self.ack();
                }
                if let Some(rest) = request.strip_prefix("D:A") {
                    let parts: Vec<&str> = rest.split('P').collect();
                    let [low, high, _accel] = parts[..] else {
                        return line("!1");
                    };
                    let (Ok(low), Ok(high)) = (low.parse::<u32>(), high.parse::<u32>()) else {
                        return line("!1");
                    };
                    if low >= high {
                        return line("!2");
                    }
                    self.stage.set_speed(high as f64 / 1000.0).unwrap();
                    return self.ack();
                }
                line("!1")
            }
        }
    }
}

fn cfg() -> QtConfig {
    QtConfig::new(StageLimits::new(0.0, 25.0).unwrap())
}

/// What a test holds of the fake controller: its engine (to inject a
/// fault) and the log of requests.
struct Handle {
    engine: Arc<Mutex<QtController>>,
    log: Arc<Mutex<Vec<String>>>,
}

impl Handle {
    fn fault(&self, f: Fault) {
        self.engine.lock().unwrap().fault = f;
    }
    fn log(&self) -> Vec<String> {
        self.log.lock().unwrap().clone()
    }
}

fn connect(fault: Fault) -> Result<(ChuoQt<FakePort<QtController>>, Handle), InstrumentError> {
    let clock = Clock::manual();
    let mut ctl = QtController::new(clock.clone());
    ctl.fault = fault;
    let port = FakePort::new(ctl);
    let handle = Handle {
        engine: port.engine.clone(),
        log: port.log.clone(),
    };
    Ok((ChuoQt::connect(port, "/dev/ttyUSB0", cfg(), clock)?, handle))
}

#[test]
fn connect_identifies_switches_replies_on_and_sets_the_papers_speed() {
    let (qt, handle) = connect(Fault::None).unwrap();
    let log = handle.log();
    assert_eq!(log, ["?:CHUOSEIKI", "X:1", "D:A500P5000P100"]);
    assert_eq!(qt.speed_mm_s(), 5.0);
}

#[test]
fn a_move_is_sent_in_pulses_and_waited_for() {
    let (mut qt, handle) = connect(Fault::None).unwrap();
    let m = qt.move_to(12.5).unwrap();
    assert_eq!((m.from_mm, m.at_mm), (0.0, 12.5));
    // 12.5 mm at 5 mm/s, polled every 20 ms plus the replies' own time.
    assert!((2.5..2.6).contains(&m.took_s), "{}", m.took_s);
    assert!(handle.log().contains(&"AGO:A12500".to_owned()));
    qt.set_speed(10.0).unwrap();
    let m = qt.move_to(2.5).unwrap();
    assert!((1.0..1.1).contains(&m.took_s), "{}", m.took_s);
    assert_eq!(qt.position_mm().unwrap(), 2.5);
}

#[test]
fn soft_limits_refuse_before_anything_is_sent() {
    let (mut qt, handle) = connect(Fault::None).unwrap();
    let before = handle.log().len();
    let err = qt.move_to(25.5).unwrap_err();
    assert!(matches!(err, InstrumentError::Limit { .. }), "{err}");
    assert_eq!(handle.log().len(), before);
    assert!(qt.set_speed(0.0).is_err() && qt.set_speed(f64::NAN).is_err());
}

#[test]
fn a_stuck_move_is_stopped_and_reported() {
    let (mut qt, handle) = connect(Fault::None).unwrap();
    handle.fault(Fault::StuckDriving);
    let err = qt.move_to(10.0).unwrap_err();
    assert!(matches!(err, InstrumentError::Timeout { .. }), "{err}");
    // 10 mm at 5 mm/s: 1.5 × 2 s + 1 s.
    assert_eq!(
        err.to_string(),
        "/dev/ttyUSB0: move from 0 to 10 mm not finished within 4 s (stopped)"
    );
    assert_eq!(handle.log().last().unwrap(), "L:");
}

#[test]
fn controller_errors_are_named() {
    let (mut qt, handle) = connect(Fault::None).unwrap();
    handle.fault(Fault::LimitSwitch);
    let err = qt.move_to(10.0).unwrap_err();
    assert_eq!(
        err.to_string(),
        "/dev/ttyUSB0: controller refused AGO:A10000: limit switch reached (!6)"
    );
    handle.fault(Fault::StopsShort);
    let err = qt.move_to(10.0).unwrap_err();
    assert!(
        err.to_string().contains("move to 10 mm stopped at 9 mm"),
        "{err}"
    );
}

#[test]
fn garbage_and_silence_are_protocol_errors_and_timeouts() {
    let (mut qt, handle) = connect(Fault::None).unwrap();
    handle.fault(Fault::GarbagePosition);
    let err = qt.position_mm().unwrap_err();
    assert!(matches!(err, InstrumentError::Protocol { .. }), "{err}");
    assert!(err.to_string().contains("'+12AB'"), "{err}");
    handle.fault(Fault::Silent);
    let err = qt.position_mm().unwrap_err();
    assert!(matches!(err, InstrumentError::Timeout { .. }), "{err}");
    assert!(
        err.to_string()
            .starts_with("/dev/ttyUSB0: no reply to Q:A0 within 500 ms"),
        "{err}"
    );
}

#[test]
fn not_a_qt_controller_is_refused_at_connect() {
    let Err(err) = connect(Fault::NotChuo) else {
        panic!("connected")
    };
    assert!(
        err.to_string().contains("not a Chuo Seiki QT controller"),
        "{err}"
    );
    let Err(err) = connect(Fault::Silent) else {
        panic!("connected")
    };
    assert!(matches!(err, InstrumentError::Timeout { .. }), "{err}");
}

#[test]
fn homing_waits_for_the_origin() {
    let (mut qt, _handle) = connect(Fault::None).unwrap();
    qt.move_to(5.0).unwrap();
    let h = qt.home().unwrap();
    assert_eq!((h.from_mm, h.at_mm), (5.0, 0.0));
    assert!(h.took_s >= 1.0, "{}", h.took_s);
}

#[test]
fn position_replies_parse_strictly() {
    assert_eq!(parse_position("+00012345K"), Some((12345, b'K')));
    assert_eq!(parse_position("-00000010D"), Some((-10, b'D')));
    for bad in [
        "",
        "+",
        "00012345K",
        "+00012345",
        "+0001x345K",
        "+00012345k",
        "+1234567890K",
    ] {
        assert_eq!(parse_position(bad), None, "{bad:?}");
    }
}

/// The real open path: `serialport` on a pty, a controller thread on the
/// other side, real time (a 0.2 mm move at 5 mm/s).
#[test]
fn the_driver_runs_over_a_real_pty() {
    use std::io::{Read, Write};
    use std::os::fd::AsFd;
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};

    let (master, slave, path) = crate::device::simdev::raw_pty().unwrap();
    let done = Arc::new(AtomicBool::new(false));
    let stop = done.clone();
    let peer = std::thread::spawn(move || {
        let mut ctl = QtController::new(Clock::real());
        let mut file = std::fs::File::from(master);
        let mut line = Vec::new();
        while !stop.load(Ordering::SeqCst) {
            let mut fds = [nix::poll::PollFd::new(
                file.as_fd(),
                nix::poll::PollFlags::POLLIN,
            )];
            if nix::poll::poll(&mut fds, 50u16).unwrap_or(0) == 0 {
                continue;
            }
            let mut b = [0u8; 64];
            let Ok(n) = file.read(&mut b) else { break };
            for &c in &b[..n] {
                if c == b'\n' || c == b'\r' {
                    if !line.is_empty() {
                        let req = String::from_utf8_lossy(&line).into_owned();
                        let reply = ctl.answer(&req);
                        file.write_all(&reply).unwrap();
                        line.clear();
                    }
                } else {
                    line.push(c);
                }
            }
        }
    });
    let result = (|| {
        let mut qt = ChuoQt::open(&path, cfg())?;
        // The controller is idle no sooner than 40 ms after the command
        // arrives, which is after this instant: a lower bound that holds
        // however late this thread runs (`took_s` starts after the reply).
        let t0 = std::time::Instant::now();
        let m = qt.move_to(0.2)?;
        Ok::<_, InstrumentError>((m, t0.elapsed(), qt.position_mm()?))
    })();
    done.store(true, Ordering::SeqCst);
    peer.join().unwrap();
    drop(slave);
    let (m, waited, at) = result.unwrap();
    assert_eq!((m.at_mm, at), (0.2, 0.2));
    assert!(waited.as_secs_f64() >= 0.04, "{waited:?}");
    assert!(
        m.took_s > 0.0 && m.took_s <= waited.as_secs_f64(),
        "{}",
        m.took_s
    );
}
