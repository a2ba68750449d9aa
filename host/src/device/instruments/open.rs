//! Opening an instrument a port names: a serial path for a real one, or
//! `sim` for its simulated twin, so the bench commands and the study open
//! both the same way.

use super::chuo::{Axis, ChuoQt, QT_BAUD, QT_REPLY_TIMEOUT, QtConfig};
use super::contact::FingerPad;
use super::gauge::ForceGauge;
use super::imada::{IMADA_BAUD, Imada};
use super::mark10::{MARK10_BAUD, Mark10};
use super::sim_gauge::{GaugeSpec, SimGauge};
use super::sim_stage::SimStage;
use super::stage::{Stage, StageLimits};
use crate::clock::Clock;
use crate::error::InputError;
use crate::limits::show;

/// The port name that opens a simulated twin.
pub const SIM: &str = "sim";

/// Deepest `--sim-depth` the gauge twin is opened at, mm. The twin's
/// finger pad ([`FingerPad::TYPICAL`], exponential in depth) reaches the
/// simulated gauge's 50 N capacity at 7.49 mm and its force grows by
/// e^0.8 per further millimetre (1.1 MN at 20 mm, deeper than any
/// fingertip's pulp): at 7 mm it reads 33.7 N, a reading, where a deeper
/// depth could only ever be an overload. Tied to the model by a test.
pub const SIM_DEPTH_MAX_MM: f64 = 7.0;

/// Which gauge protocol a port speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GaugeModel {
    /// IMADA ZTS/ZTA ([`Imada`]).
    Imada,
    /// Mark-10 Series 4/5/7 ([`Mark10`]).
    Mark10,
}

impl GaugeModel {
    /// The model's factory baud rate.
    pub fn default_baud(self) -> u32 {
        match self {
            Self::Imada => IMADA_BAUD,
            Self::Mark10 => MARK10_BAUD,
        }
    }
}

/// How to open a gauge.
#[derive(Debug, Clone)]
pub struct GaugeOptions {
    /// A serial port path, or [`SIM`].
    pub port: String,
    /// Its protocol [default: [`GaugeModel::Imada`]]; the twin has none
    /// and refuses one given.
    pub model: Option<GaugeModel>,
    /// Baud rate; the model's factory rate when `None`. The twin has no
    /// serial link and refuses one given.
    pub baud: Option<u32>,
    /// For the twin: how deep its probe sits in the finger pad, mm.
    pub sim_depth_mm: Option<f64>,
    /// For the twin: the noise seed [default: 1]; a real gauge refuses one.
    pub seed: Option<u64>,
    /// How the command line names `model` and `baud`: `--` + `model`
    /// (`lmhost gauge read`), or with a prefix (`--gauge-` in `study run`).
    pub flags: &'static str,
}

impl GaugeOptions {
    /// The simulated twin (port [`SIM`]), every setting its default, its
    /// flags named as `flags` says.
    pub fn twin(flags: &'static str) -> Self {
        Self {
            port: SIM.into(),
            model: None,
            baud: None,
            sim_depth_mm: None,
            seed: None,
            flags,
        }
    }
}

/// The one refusal of a real instrument's setting given to its simulated
/// twin (`twin`), which would ignore it: the first of `settings` (its
/// flag's name after `prefix`, whether it was given) given.
fn twin_refuses(
    prefix: &str,
    settings: &[(&str, bool)],
    twin: &str,
    has_not: &str,
) -> Result<(), InputError> {
    match settings.iter().find(|(_, given)| *given) {
        None => Ok(()),
        Some((name, _)) => Err(InputError::new(format!(
            "{prefix}{name} does not apply to the simulated {twin} (port {SIM}), which has no {has_not}: leave it out, or give the real one's serial port"
        ))),
    }
}

/// Refuses a gauge port of a form no port has (as [`StagePort::parse`]
/// does the stage's): empty, spaces at an end, a control character.
fn check_gauge_port(port: &str) -> Result<(), InputError> {
    if port.is_empty() {
        return Err(InputError::new(
            "gauge: give sim or a serial port, not an empty name",
        ));
    }
    crate::device::link::discover::check_name("gauge", port)
}

/// Open the gauge `o` names.
pub fn open_gauge(o: &GaugeOptions) -> anyhow::Result<Box<dyn ForceGauge>> {
    check_gauge_port(&o.port)?;
    if o.port == SIM {
        sim_gauge_check(o)?;
        let depth = o.sim_depth_mm.unwrap_or(0.0);
        if !(depth.is_finite() && (0.0..=SIM_DEPTH_MAX_MM).contains(&depth)) {
            let full = FingerPad::TYPICAL.depth_for_force_mm(GaugeSpec::ZTS_50N.capacity_n);
            return Err(InputError::new(format!(
                "simulated depth {} mm is outside 0..={} mm (the simulated pad reaches the gauge's {} N capacity at {:.1} mm)",
                show(depth),
                show(SIM_DEPTH_MAX_MM),
                show(GaugeSpec::ZTS_50N.capacity_n),
                full
            ))
            .into());
        }
        // A stage twin parked at the depth, the pad touching at 0.
        let limits = StageLimits::new(-10.0, 30.0)?;
        let stage = SimStage::new(Clock::real(), limits, depth)?;
        return Ok(Box::new(SimGauge::new(
            stage.probe(),
            FingerPad::TYPICAL,
            o.seed.unwrap_or(1),
        )));
    }
    for (given, what) in [
        (o.sim_depth_mm.is_some(), "a simulated depth (--sim-depth)"),
        (o.seed.is_some(), "a noise seed (--seed)"),
    ] {
        if given {
            return Err(InputError::new(format!("{what} needs port {SIM}, not {}", o.port)).into());
        }
    }
    let model = o.model.unwrap_or(GaugeModel::Imada);
    let baud = o.baud.unwrap_or(model.default_baud());
    Ok(match model {
        GaugeModel::Imada => Box::new(Imada::open(&o.port, baud)?),
        GaugeModel::Mark10 => Box::new(Mark10::open(&o.port, baud)?),
    })
}

/// Refuses what the gauge twin would ignore: a protocol, a baud rate.
fn sim_gauge_check(o: &GaugeOptions) -> Result<(), InputError> {
    twin_refuses(
        o.flags,
        &[("model", o.model.is_some()), ("baud", o.baud.is_some())],
        "gauge",
        "protocol or serial link",
    )
}

/// What a stage's port names: `sim`, `sim:fail-after=N` (the twin, silent
/// after N moves: a failure on cue for tests and rehearsals), or a serial
/// path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum StagePort {
    /// The simulated twin; `Some(n)`: it stops answering after `n` moves.
    Sim(Option<u32>),
    /// A serial port path.
    Serial(String),
}

impl StagePort {
    /// Reads a `--stage` value.
    pub fn parse(s: &str) -> Result<Self, InputError> {
        if s == SIM {
            return Ok(Self::Sim(None));
        }
        if let Some(rest) = s.strip_prefix("sim:") {
            let n = rest
                .strip_prefix("fail-after=")
                .and_then(|n| n.parse::<u32>().ok().filter(|_| !n.starts_with('+')));
            return match n {
                Some(n) => Ok(Self::Sim(Some(n))),
                None => Err(InputError::new(format!(
                    "stage `{}`: give sim, sim:fail-after=N (N moves, then silent) or a serial port",
                    s.escape_debug()
                ))),
            };
        }
        if s.is_empty() {
            return Err(InputError::new(
                "stage: give sim or a serial port, not an empty name",
            ));
        }
        crate::device::link::discover::check_name("stage", s)?;
        Ok(Self::Serial(s.to_owned()))
    }
}

/// How to open a stage.
#[derive(Debug, Clone)]
pub struct StageOptions {
    /// A serial port path, or [`SIM`].
    pub port: String,
    /// Soft limits of the push axis, mm.
    pub limits: StageLimits,
    /// Speed, mm/s.
    pub speed_mm_s: f64,
    /// The controller's pushing axis [default: A].
    pub axis: Option<Axis>,
    /// Micrometres per pulse [default: 1].
    pub step_um: Option<f64>,
    /// Baud rate ([`QT_BAUD`] when `None`).
    pub baud: Option<u32>,
    /// How the command line names `axis`, `step_um` and `baud`: `--` +
    /// `axis`, `step-um`, `baud` (`lmhost stage`), or with a prefix
    /// (`--stage-` in `study run`).
    pub flags: &'static str,
}

impl StageOptions {
    /// The simulated twin (port [`SIM`]) between `limits` at `speed_mm_s`,
    /// every controller setting its default, its flags named as `flags`
    /// says.
    pub fn twin(limits: StageLimits, speed_mm_s: f64, flags: &'static str) -> Self {
        Self {
            port: SIM.into(),
            limits,
            speed_mm_s,
            axis: None,
            step_um: None,
            baud: None,
            flags,
        }
    }
}

/// Open the stage `o` names; a twin starts at 0, or at the soft limit
/// nearest to it.
pub fn open_stage(o: &StageOptions) -> anyhow::Result<Box<dyn Stage>> {
    if let StagePort::Sim(fail) = StagePort::parse(&o.port)? {
        return Ok(Box::new(sim_stage(o, fail)?));
    }
    Ok(Box::new(ChuoQt::open(&o.port, qt_config(o))?))
}

/// The controller's configuration `o` gives.
fn qt_config(o: &StageOptions) -> QtConfig {
    QtConfig {
        axis: o.axis.unwrap_or(Axis::A),
        step_um: o.step_um.unwrap_or(1.0),
        limits: o.limits,
        speed_mm_s: o.speed_mm_s,
        accel_ms: 100,
        baud: o.baud.unwrap_or(QT_BAUD),
        reply_timeout: QT_REPLY_TIMEOUT,
    }
}

/// The twin of the stage `o` names; its options are checked as the
/// controller's are (a step the rig would refuse is refused as such), then
/// a setting of the controller's the twin would ignore is refused.
fn sim_stage(o: &StageOptions, fail_after: Option<u32>) -> anyhow::Result<SimStage> {
    sim_stage_check(o)?;
    let home = 0.0f64.clamp(o.limits.min_mm, o.limits.max_mm);
    let mut stage = SimStage::new(Clock::real(), o.limits, home)?;
    stage.set_speed(o.speed_mm_s)?;
    if let Some(n) = fail_after {
        stage.fail_after_moves(n);
    }
    Ok(stage)
}

/// The stage twin's checks: `o` as the controller would check it, then
/// the controller's settings the twin would ignore.
fn sim_stage_check(o: &StageOptions) -> anyhow::Result<()> {
    qt_config(o).check(&o.port)?;
    twin_refuses(
        o.flags,
        &[
            ("axis", o.axis.is_some()),
            ("step-um", o.step_um.is_some()),
            ("baud", o.baud.is_some()),
        ],
        "stage",
        "axes, pulses or serial link",
    )?;
    Ok(())
}

/// Refuses, before anything opens or is written, a setting of a real
/// stage or gauge given to its twin (which would ignore it): what
/// [`open_rig`] checks first.
pub fn check_rig(stage: &StageOptions, gauge: &GaugeOptions) -> anyhow::Result<()> {
    if let StagePort::Sim(_) = StagePort::parse(&stage.port)? {
        sim_stage_check(stage)?;
    }
    check_gauge_port(&gauge.port)?;
    if gauge.port == SIM {
        sim_gauge_check(gauge)?;
    }
    Ok(())
}

/// Opens the stage and gauge of one rig, so that a simulated gauge reads
/// the stage it is pushed by: with `--stage sim` and `--gauge sim`, the
/// gauge twin measures `pad` at the stage twin's position. A simulated
/// gauge on a real stage (or the reverse of a real gauge on the twin)
/// would measure nothing real: refused.
pub fn open_rig(
    stage: &StageOptions,
    gauge: &GaugeOptions,
    pad: FingerPad,
) -> anyhow::Result<(Box<dyn Stage>, Box<dyn ForceGauge>)> {
    check_rig(stage, gauge)?;
    let sim_stage_port = StagePort::parse(&stage.port)?;
    match (sim_stage_port, gauge.port == SIM) {
        (StagePort::Sim(fail), true) => {
            let s = sim_stage(stage, fail)?;
            let g = SimGauge::new(s.probe(), pad, gauge.seed.unwrap_or(1));
            Ok((Box::new(s), Box::new(g)))
        }
        (StagePort::Serial(_), false) => Ok((open_stage(stage)?, open_gauge(gauge)?)),
        (StagePort::Sim(_), false) => Err(InputError::new(format!(
            "a real gauge ({}) on the simulated stage measures nothing the stage does: give both as sim, or both as serial ports",
            gauge.port
        ))
        .into()),
        (StagePort::Serial(p), true) => Err(InputError::new(format!(
            "the simulated gauge cannot see the real stage on {p}: give both as sim, or both as serial ports"
        ))
        .into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gauge(port: &str, depth: Option<f64>) -> anyhow::Result<Box<dyn ForceGauge>> {
        open_gauge(&GaugeOptions {
            port: port.into(),
            sim_depth_mm: depth,
            ..GaugeOptions::twin("--")
        })
    }

    #[test]
    fn sim_opens_the_twins_and_checks_its_depth() {
        let mut g = gauge(SIM, Some(2.0)).unwrap();
        let f = g.read().unwrap().force_n;
        assert!(
            (f - FingerPad::TYPICAL.force_at_depth_n(2.0)).abs() <= 0.03,
            "{f}"
        );
        for bad in [Some(-1.0), Some(f64::NAN), Some(7.01), Some(25.0)] {
            let err = gauge(SIM, bad).err().unwrap();
            assert!(err.chain().any(|c| c.is::<InputError>()), "{err}");
        }
        let err = gauge(SIM, Some(20.0)).err().unwrap();
        assert_eq!(
            crate::error::one_line(&err),
            "simulated depth 20 mm is outside 0..=7 mm (the simulated pad reaches the gauge's 50 N capacity at 7.5 mm)"
        );
        // Every depth the range allows is a reading, the deepest included.
        for depth in [0.0, 3.5, SIM_DEPTH_MAX_MM] {
            let f = gauge(SIM, Some(depth)).unwrap().read().unwrap().force_n;
            let want = FingerPad::TYPICAL.force_at_depth_n(depth);
            assert!((f - want).abs() <= 0.03, "{depth} mm: {f} vs {want}");
        }
        let err = gauge("/dev/null", Some(1.0)).err().unwrap();
        assert!(err.chain().any(|c| c.is::<InputError>()), "{err}");
    }

    #[test]
    fn stage_ports_name_the_twin_its_failure_or_a_path() {
        assert_eq!(StagePort::parse("sim").unwrap(), StagePort::Sim(None));
        assert_eq!(
            StagePort::parse("sim:fail-after=3").unwrap(),
            StagePort::Sim(Some(3))
        );
        assert_eq!(
            StagePort::parse("/dev/ttyUSB0").unwrap(),
            StagePort::Serial("/dev/ttyUSB0".into())
        );
        for bad in [
            "",
            "sim:",
            "sim:fail-after=",
            "sim:fail-after=-1",
            "sim:fail-after=+1",
            "sim:x=1",
        ] {
            assert!(StagePort::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn a_rig_of_twins_measures_the_pad_where_the_stage_pushes() {
        let stage = StageOptions::twin(StageLimits::new(0.0, 20.0).unwrap(), 50.0, "--stage-");
        let gauge_o = GaugeOptions::twin("--gauge-");
        let pad = FingerPad::TYPICAL.at(5.0);
        let (mut s, mut g) = open_rig(&stage, &gauge_o, pad).unwrap();
        assert!(g.read().unwrap().force_n.abs() <= 0.02);
        s.move_to(7.0).unwrap();
        let f = g.read().unwrap().force_n;
        assert!((f - pad.force_at_depth_n(2.0)).abs() <= 0.03, "{f}");
        let mixed = GaugeOptions {
            port: "/dev/null".into(),
            ..gauge_o
        };
        let err = open_rig(&stage, &mixed, pad).err().unwrap();
        assert!(err.chain().any(|c| c.is::<InputError>()), "{err}");
    }

    #[test]
    fn a_missing_port_is_an_io_error_naming_it() {
        let err = gauge("/dev/lmhost-no-such-gauge", None).err().unwrap();
        let msg = crate::error::one_line(&err);
        assert!(msg.starts_with("/dev/lmhost-no-such-gauge: "), "{msg}");
        assert!(!err.chain().any(|c| c.is::<InputError>()), "{msg}");
    }

    #[test]
    fn the_twin_refuses_the_step_the_controller_would() {
        for step_um in [f64::NAN, f64::INFINITY, 0.0, -1.0, 1e300] {
            for port in [SIM, "sim:fail-after=3", "/dev/lmhost-no-such-stage"] {
                let o = StageOptions {
                    port: port.into(),
                    step_um: Some(step_um),
                    ..StageOptions::twin(StageLimits::new(0.0, 20.0).unwrap(), 5.0, "--")
                };
                let err = open_stage(&o).err().expect("a bad step is refused");
                let msg = crate::error::one_line(&err);
                assert!(err.chain().any(|c| c.is::<InputError>()), "{msg}");
                assert!(msg.contains("µm/pulse is outside"), "{msg}");
            }
        }
    }

    /// Sets one setting of an instrument's options.
    type Set<T> = fn(&mut T);

    /// Each setting of `cases` refused for the simulated `twin` by its flag:
    /// prefixed (`--stage-axis`) with the twin in a rig, bare (`--axis`)
    /// with it alone.
    fn each_refused<T>(
        cases: &[(Set<T>, &str)],
        twin: &str,
        in_rig: impl Fn(Set<T>) -> anyhow::Error,
        alone: impl Fn(Set<T>) -> anyhow::Error,
    ) {
        let refused = |e: anyhow::Error, flag: &str| {
            let msg = crate::error::one_line(&e);
            assert!(e.chain().any(|c| c.is::<InputError>()), "{msg}");
            assert!(
                msg.starts_with(&format!(
                    "{flag} does not apply to the simulated {twin} (port sim)"
                )),
                "{msg}"
            );
        };
        for &(set, name) in cases {
            refused(in_rig(set), &format!("--{twin}-{name}"));
            refused(alone(set), &format!("--{name}"));
        }
    }

    #[test]
    fn a_twin_refuses_each_setting_of_the_real_one_by_its_flag() {
        let stage = |f: fn(&mut StageOptions)| {
            let mut o = StageOptions::twin(StageLimits::new(0.0, 20.0).unwrap(), 5.0, "--stage-");
            f(&mut o);
            o
        };
        let gauge = |f: fn(&mut GaugeOptions)| {
            let mut o = GaugeOptions::twin("--gauge-");
            f(&mut o);
            o
        };
        let pad = FingerPad::TYPICAL;
        each_refused::<StageOptions>(
            &[
                (|o| o.axis = Some(Axis::B), "axis"),
                (|o| o.step_um = Some(0.5), "step-um"),
                (|o| o.baud = Some(9600), "baud"),
            ],
            "stage",
            |set| open_rig(&stage(set), &gauge(|_| {}), pad).err().unwrap(),
            |set| {
                let alone = StageOptions {
                    flags: "--",
                    ..stage(set)
                };
                open_stage(&alone).err().unwrap()
            },
        );
        each_refused::<GaugeOptions>(
            &[
                (|o| o.model = Some(GaugeModel::Mark10), "model"),
                (|o| o.baud = Some(19200), "baud"),
            ],
            "gauge",
            |set| open_rig(&stage(|_| {}), &gauge(set), pad).err().unwrap(),
            |set| {
                let alone = GaugeOptions {
                    flags: "--",
                    ..gauge(set)
                };
                open_gauge(&alone).err().unwrap()
            },
        );
        // None given: the twins open.
        assert!(open_rig(&stage(|_| {}), &gauge(|_| {}), pad).is_ok());
    }
}
