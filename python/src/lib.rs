//! `lmhost._lmhost`: the Python binding of the lmhost library.
//!
//! Thin on purpose: every function here calls the library the way the
//! `lmhost` binary's `cmd/` modules do (`Stimulus::plan_for`,
//! `field::study::simulate_plan`, `track::Pipeline`, `connect::open`,
//! `upload::upload`) and converts values at the boundary. It never plans,
//! simulates or tracks on its own. The pythonic surface (keyword defaults,
//! `Session`, context managers) lives in `python/lmhost/__init__.py`.
//!
//! Errors: an [`InputError`] anywhere in a chain raises `ValueError` with
//! the line the CLI prints ([`one_line`]); any other failure raises
//! `lmhost.DeviceError` (an `OSError`); a panic raises `RuntimeError`,
//! never unwinds into the interpreter. Long calls release the GIL.

use lmhost::sense::track::settings_file::SettingsFile as _;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;
use std::sync::Mutex;
use std::time::Instant;

use numpy::{PyArray1, PyArray2, PyArray3, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::{PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;

use lmhost::device::backend::{BackendError, ErrorKind};
use lmhost::error::{InputError, one_line};
use lmhost::field::Radiation;
use lmhost::field::study::{View, simulate_plan};
use lmhost::plan::scene::Scene;
use lmhost::plan::stimulus::{Stimulus, TargetPlan};
use lmhost::plan::target::Target;
use lmhost::plan::trajectory::{Cycle, MAX_FOCI, MAX_STEPS};
use lmhost::sense::track::Pipeline;
use lmhost::sense::track::camera::CameraSetup;
use lmhost::sense::track::contact::Tracker as ContactTracker;
use lmhost::sense::track::intrinsics::Intrinsics;
use lmhost::sense::track::presence::{Hysteresis, MAX_FRAMES};

mod args;
mod device;
mod study;
use device::Device_;

create_exception!(
    _lmhost,
    DeviceError,
    PyOSError,
    "A device or I/O fault (the CLI's exit code 1)."
);

/// Whether the chain says the input was bad (exit code 2 in the CLI).
fn is_input(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.is::<InputError>()
            || c.downcast_ref::<BackendError>()
                .is_some_and(|b| b.kind() == ErrorKind::Input)
    })
}

fn to_py(e: anyhow::Error) -> PyErr {
    // The CLI's message rules: numbers tidied, overlong words cut.
    let line = lmhost::out::tidy(&one_line(&e));
    if is_input(&e) {
        PyValueError::new_err(line)
    } else {
        DeviceError::new_err(line)
    }
}

fn bad(msg: impl Into<String>) -> PyErr {
    // One line whatever it repeats: a value's line break escaped and a
    // long quoted value cut, as the library's echoes are.
    PyValueError::new_err(lmhost::out::tidy(&lmhost::error::one_line_echo(msg.into())))
}

/// What a caught panic says.
fn panic_msg(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}

fn panic_err(p: Box<dyn std::any::Any + Send>) -> PyErr {
    PyRuntimeError::new_err(format!("lmhost internal error: {}", panic_msg(&*p)))
}

/// Runs `f` without the GIL, a panic caught as `RuntimeError`.
fn run<T: Send>(py: Python<'_>, f: impl FnOnce() -> anyhow::Result<T> + Send) -> PyResult<T> {
    py.allow_threads(|| catch_unwind(AssertUnwindSafe(f)))
        .map_err(panic_err)?
        .map_err(to_py)
}

/// `serde_json::Value` → Python (through `json.loads`: one parser).
fn to_python(py: Python<'_>, v: &serde_json::Value) -> PyResult<PyObject> {
    let json = py.import("json")?;
    Ok(json.call_method1("loads", (v.to_string(),))?.unbind())
}

fn vec3(what: &str, v: Vec<f64>) -> PyResult<[f64; 3]> {
    v.try_into()
        .map_err(|_| bad(format!("{what} takes three numbers (x, y, z) in mm")))
}

/// Two (N, 3) arrays.
type Pair<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>);

/// A scene: transducers, reflector, LM plane and the rig's camera.
#[pyclass(name = "Scene", module = "lmhost._lmhost", frozen)]
#[derive(Clone)]
struct Scene_ {
    scene: Scene,
}

#[pymethods]
impl Scene_ {
    /// Load and check a TOML scene file (`ValueError` when it is bad).
    #[staticmethod]
    fn load(py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<Self> {
        let path = args::path_of("path", path)?;
        let scene = run(py, || Ok(Scene::load(&path)?))?;
        Ok(Self { scene })
    }

    /// The built-in scene: four AUTD3 in a flat 2 × 2 facing +z.
    #[staticmethod]
    fn flat() -> Self {
        Self {
            scene: Scene::default(),
        }
    }

    /// The scene's name.
    #[getter]
    fn name(&self) -> String {
        self.scene.name.clone()
    }

    /// The default LM centre (mm).
    #[getter]
    fn center_mm(&self) -> [f64; 3] {
        self.scene.center_mm
    }

    /// Transducer positions (N, 3) in mm and unit normals (N, 3).
    #[getter]
    fn transducers<'py>(&self, py: Python<'py>) -> PyResult<Pair<'py>> {
        let t = self.scene.transducers();
        let pos: Vec<Vec<f64>> = t.iter().map(|t| t.pos_mm.to_vec()).collect();
        let nrm: Vec<Vec<f64>> = t.iter().map(|t| t.normal.to_vec()).collect();
        Ok((
            PyArray2::from_vec2(py, &pos).map_err(|e| bad(e.to_string()))?,
            PyArray2::from_vec2(py, &nrm).map_err(|e| bad(e.to_string()))?,
        ))
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene({:?}, {} transducers)",
            self.scene.name,
            self.scene.transducer_count()
        )
    }
}

/// A planned stimulus: phases, timing and trajectory for one device kind.
#[pyclass(name = "Plan", module = "lmhost._lmhost", frozen)]
struct Plan_ {
    planned: TargetPlan,
    radius_mm: f64,
    target: Target,
}

#[pymethods]
impl Plan_ {
    /// Phases, uint8, shape (steps, transducers).
    #[getter]
    fn phases<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<u8>>> {
        let s = &self.planned.plan.sequence;
        let n = self.planned.plan.trajectory.steps;
        PyArray1::from_slice(py, &s.phases).reshape([n, s.phases.len() / n.max(1)])
    }

    /// Steps per LM cycle N.
    #[getter]
    fn steps(&self) -> usize {
        self.planned.plan.trajectory.steps
    }

    /// Dwell per step as the device plays it (µs).
    #[getter]
    fn dwell_us(&self) -> f64 {
        self.planned.timing.dwell_us
    }

    /// LM frequency as the device plays it (Hz).
    #[getter]
    fn freq_hz(&self) -> f64 {
        self.planned.timing.freq_hz
    }

    /// Step width along the circle (mm).
    #[getter]
    fn step_mm(&self) -> f64 {
        self.planned.plan.trajectory.step_mm
    }

    /// Index offset l between neighbouring foci (LM-M).
    #[getter]
    fn index_offset(&self) -> usize {
        self.planned.plan.trajectory.index_offset
    }

    /// Circle radius A asked (mm).
    #[getter]
    fn radius_mm(&self) -> f64 {
        self.radius_mm
    }

    /// LM centre (mm, finger space).
    #[getter]
    fn center_mm(&self) -> [f64; 3] {
        self.planned.plan.trajectory.center_mm
    }

    /// `"lm"` or `"autd3"`: the device kind planned for.
    #[getter]
    fn target(&self) -> String {
        self.target.name().to_owned()
    }

    /// Transducers in the plan's scene.
    #[getter]
    fn transducers(&self) -> usize {
        usize::from(self.planned.plan.sequence.header.transducers)
    }

    /// CRC-32 of the phases (as the device checks it).
    #[getter]
    fn crc32(&self) -> u32 {
        self.planned.plan.sequence.crc32()
    }

    /// One-line warnings about the stimulus in this scene.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.planned.warnings.clone()
    }

    /// Realised against requested timing (dict, as `lmhost plan --json`).
    #[getter]
    fn timing(&self, py: Python<'_>) -> PyResult<PyObject> {
        let v = serde_json::to_value(&self.planned.timing).map_err(|e| bad(e.to_string()))?;
        to_python(py, &v)
    }

    /// Foci per step (mm, finger space), shape (steps, foci, 3).
    #[getter]
    fn foci_mm<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let t = &self.planned.plan.trajectory;
        let flat: Vec<f64> = (0..t.steps)
            .flat_map(|j| t.foci_step(j).iter().flatten().copied().collect::<Vec<_>>())
            .collect();
        PyArray1::from_vec(py, flat).reshape([t.steps, t.foci, 3])
    }

    /// Writes the files `lmhost plan --out PATH` writes: `.json` (summary
    /// with phases), `.npy` (uint8, steps × transducers) or anything else
    /// as raw step-major bytes; whole or absent.
    fn save(&self, py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let path = args::path_of("path", path)?;
        run(py, || {
            let bytes = self.planned.out_bytes(&path, &self.target)?;
            lmhost::files::write_whole(&path, &bytes)
        })
    }

    /// The summary `lmhost plan --json` prints (`phases=True` adds them).
    #[pyo3(signature = (phases=None))]
    fn summary(&self, py: Python<'_>, phases: Option<&Bound<'_, PyAny>>) -> PyResult<PyObject> {
        let phases = phases
            .map(|p| args::bool_arg("phases", p))
            .transpose()?
            .unwrap_or(false);
        to_python(py, &self.planned.summary_json(&self.target, phases))
    }
}

/// Plans a stimulus: `Stimulus::plan_for` the target in the scene, as
/// `lmhost plan` does. Every number is checked by [`args`] first; one not
/// given (`None`) is the library's default, as a flag not given is, so
/// `Cycle::given` refuses what cannot apply (a spacing with one focus, a
/// step width beside a step count) as it does for the flags.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (radius, foci, spacing, freq, step, steps, center, scene, intensity, target))]
fn plan(
    py: Python<'_>,
    radius: Option<&Bound<'_, PyAny>>,
    foci: Option<&Bound<'_, PyAny>>,
    spacing: Option<&Bound<'_, PyAny>>,
    freq: Option<&Bound<'_, PyAny>>,
    step: Option<&Bound<'_, PyAny>>,
    steps: Option<&Bound<'_, PyAny>>,
    center: Option<&Bound<'_, PyAny>>,
    scene: Option<&Bound<'_, PyAny>>,
    intensity: Option<&Bound<'_, PyAny>>,
    target: &Bound<'_, PyAny>,
) -> PyResult<Plan_> {
    let target = target
        .downcast::<pyo3::types::PyString>()
        .map_err(|_| {
            bad(format!(
                "target must be 'lm' or 'autd3', got {}",
                args::kind(target)
            ))
        })?
        .extract::<String>()?;
    let target = lmhost::error::choose("a target", &target, &Target::ALL.map(|t| (t.name(), t)))
        .map_err(bad)?;
    let radius = args::opt_float("radius", radius)?;
    let spacing = args::opt_float("spacing", spacing)?;
    let freq = args::opt_float("freq", freq)?;
    let step = args::opt_float("step", step)?;
    let intensity = args::opt_float("intensity", intensity)?;
    let foci = args::opt_int_in::<usize>("foci", foci, 1, MAX_FOCI as i64)?;
    let steps = args::opt_int_in::<usize>("steps", steps, 1, MAX_STEPS as i64)?;
    let center_mm = args::opt_floats("center", center, 3)?
        .map(|c| vec3("center", c))
        .transpose()?;
    let scene = match scene.filter(|s| !s.is_none()) {
        Some(s) => args::class::<Scene_>("scene", s, args::A_SCENE)?
            .get()
            .scene
            .clone(),
        None => Scene::default(),
    };
    let cycle =
        Cycle::given(radius, foci, spacing, freq, step, steps).map_err(|e| bad(e.to_string()))?;
    let radius = cycle.radius_mm;
    let planned = run(py, || {
        let d = Stimulus::default();
        let intensity = intensity.unwrap_or(d.intensity);
        let stimulus = Stimulus {
            cycle,
            center_mm,
            intensity: lmhost::limits::in_range("--intensity", intensity, 0.0, 1.0, "")?,
            ..d
        };
        stimulus.plan_for(&target, scene)
    })?;
    Ok(Plan_ {
        planned,
        radius_mm: radius,
        target,
    })
}

/// The field on the observation plane: maps (rows v, columns u) and force.
#[pyclass(name = "Field", module = "lmhost._lmhost", frozen)]
struct Field_ {
    #[pyo3(get)]
    mean_pressure: PyObject,
    #[pyo3(get)]
    lm_power: PyObject,
    #[pyo3(get)]
    pressure: PyObject,
    #[pyo3(get)]
    amplitude: PyObject,
    #[pyo3(get)]
    max_pressure: PyObject,
    #[pyo3(get)]
    u_mm: PyObject,
    #[pyo3(get)]
    v_mm: PyObject,
    #[pyo3(get)]
    force_n: f64,
    #[pyo3(get)]
    summary: PyObject,
}

/// Simulates a plan's field as `lmhost simulate` does (same checks, same
/// summary); the CLI's `--plane-size W,H` is `plane_size=(w, h)`.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (plan, plane_size, plane_step, plane_center, plane_axes, alpha, density, disk, calibration, reference))]
fn simulate(
    py: Python<'_>,
    plan: &Bound<'_, PyAny>,
    plane_size: &Bound<'_, PyAny>,
    plane_step: &Bound<'_, PyAny>,
    plane_center: Option<&Bound<'_, PyAny>>,
    plane_axes: Option<&Bound<'_, PyAny>>,
    alpha: &Bound<'_, PyAny>,
    density: &Bound<'_, PyAny>,
    disk: &Bound<'_, PyAny>,
    calibration: Option<&Bound<'_, PyAny>>,
    reference: &Bound<'_, PyAny>,
) -> PyResult<Field_> {
    let plan = args::class::<Plan_>("plan", plan, args::A_PLAN)?.get();
    let reference = args::bool_arg("reference", reference)?;
    // One number is a square plane; else (width, height).
    let size_mm = if plane_size.is_instance_of::<pyo3::types::PyFloat>()
        || plane_size.is_instance_of::<pyo3::types::PyInt>()
    {
        let s = args::float("plane_size", plane_size)?;
        (s, s)
    } else {
        let v = args::floats("plane_size", plane_size, 2)?;
        (v[0], v[1])
    };
    let axes = args::opt_floats("plane_axes", plane_axes, 6)?
        .map(|v| ([v[0], v[1], v[2]], [v[3], v[4], v[5]]));
    let view = View {
        size_mm,
        step_mm: args::float("plane_step", plane_step)?,
        center_mm: args::opt_floats("plane_center", plane_center, 3)?
            .map(|c| vec3("plane_center", c))
            .transpose()?,
        axes,
        rad: Radiation {
            alpha: args::float("alpha", alpha)?,
        },
        density: args::float("density", density)?,
        disk_mm: args::float("disk", disk)?,
        calibration: args::opt_float("calibration", calibration)?,
        reference,
    };
    let p = &plan.planned.plan;
    let (sim, summary) = run(py, || {
        view.check()?;
        let sim = simulate_plan(p, &view)?;
        let summary = sim.summary_json(p, &view, plan.radius_mm);
        Ok((sim, summary))
    })?;
    let m = &sim.maps;
    let map = |v: &[f64]| -> PyResult<PyObject> {
        Ok(PyArray1::from_slice(py, v)
            .reshape([m.nv, m.nu])?
            .into_any()
            .unbind())
    };
    let u: Vec<f64> = (0..sim.plane.nu()).map(|i| sim.plane.u_mm(i)).collect();
    let v: Vec<f64> = (0..sim.plane.nv()).map(|i| sim.plane.v_mm(i)).collect();
    Ok(Field_ {
        mean_pressure: map(&m.mean_pressure_pa)?,
        lm_power: map(&m.lm_power_pa2)?,
        pressure: map(&m.pressure_pa)?,
        amplitude: map(&m.amplitude_pa)?,
        max_pressure: map(&m.max_pressure_pa)?,
        u_mm: PyArray1::from_vec(py, u).into_any().unbind(),
        v_mm: PyArray1::from_vec(py, v).into_any().unbind(),
        force_n: sim.force_mean_n,
        summary: to_python(py, &summary)?,
    })
}

/// The paper's contact-area tracker with presence hysteresis, as
/// `lmhost track` runs it on recorded frames (no filter).
#[pyclass(name = "Tracker", module = "lmhost._lmhost", frozen)]
struct Tracker_ {
    /// The pipeline, the frames it took and the last one's time stamp.
    pipe: Mutex<(Pipeline, u64, f64)>,
    width: usize,
    height: usize,
    min_points: u32,
    started: Instant,
}

#[pymethods]
impl Tracker_ {
    /// `intrinsics_toml` is TOML text (`origin` names it in messages), or
    /// `intrinsics_path` a file read as `lmhost track --intrinsics` reads
    /// it (a byte-order mark, CRLF, UTF-16 as every text file); the scene
    /// needs `[camera]` and `[tracking]`.
    #[new]
    #[pyo3(signature = (scene, intrinsics_toml, origin, enter_frames=None, leave_frames=None, intrinsics_path=None))]
    fn new(
        scene: &Bound<'_, PyAny>,
        intrinsics_toml: Option<&str>,
        origin: &str,
        enter_frames: Option<&Bound<'_, PyAny>>,
        leave_frames: Option<&Bound<'_, PyAny>>,
        intrinsics_path: Option<PathBuf>,
    ) -> PyResult<Self> {
        // The range `lmhost track` allows, refused under the Python names
        // (`Hysteresis::new` names the CLI's flags).
        let scene = args::class::<Scene_>("scene", scene, args::A_SCENE)?.get();
        let h = Hysteresis::default();
        let frames = |name, v, default: u32| -> PyResult<u32> {
            Ok(args::opt_int_in(name, v, 1, i64::from(MAX_FRAMES))?.unwrap_or(default))
        };
        let intrinsics_path = intrinsics_path
            .map(|p| args::path("intrinsics", p))
            .transpose()?;
        let enter_frames = frames("enter_frames", enter_frames, h.enter())?;
        let leave_frames = frames("leave_frames", leave_frames, h.leave())?;
        let intr = match (&intrinsics_path, intrinsics_toml) {
            (Some(path), _) => Intrinsics::load(path),
            (None, Some(text)) => Intrinsics::from_toml(text, origin),
            (None, None) => Err(InputError::new(
                "intrinsics: give their TOML text or their file's path",
            )),
        }
        .map_err(|e| to_py(e.into()))?;
        let rig = CameraSetup::of_scene(&scene.scene).map_err(|e| to_py(e.into()))?;
        let tracker = ContactTracker::new(intr, rig);
        let min_points = tracker.setup().track_box.min_points;
        let pipe = Pipeline::new(
            tracker,
            Hysteresis::new(enter_frames, leave_frames).map_err(|e| to_py(e.into()))?,
            lmhost::sense::stream::filter::FilterKind::None.build(),
        );
        Ok(Self {
            pipe: Mutex::new((pipe, 0, f64::NEG_INFINITY)),
            width: intr.pinhole.width as usize,
            height: intr.pinhole.height as usize,
            min_points,
            started: Instant::now(),
        })
    }

    /// Frame shape (height, width) the intrinsics describe.
    #[getter]
    fn shape(&self) -> (usize, usize) {
        (self.height, self.width)
    }

    /// Points needed for a contact (the scene's `min_points`).
    #[getter]
    fn min_points(&self) -> u32 {
        self.min_points
    }

    /// One frame: `(t_s, points, present, centroid_mm, gated)`.
    #[pyo3(signature = (depth, t=None))]
    #[allow(clippy::type_complexity)]
    fn process(
        &self,
        py: Python<'_>,
        depth: &Bound<'_, PyAny>,
        t: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<(f64, u32, bool, Option<[f64; 3]>, bool)> {
        let t = args::opt_float("t", t)?;
        let arr = depth.downcast::<PyArray2<u16>>().map_err(|_| {
            bad(format!(
                "depth frame must be a numpy uint16 array of shape ({}, {})",
                self.height, self.width
            ))
        })?;
        let shape = arr.shape();
        if shape != [self.height, self.width] {
            return Err(bad(format!(
                "depth frame has shape {shape:?} but the intrinsics say ({}, {})",
                self.height, self.width
            )));
        }
        let ro = arr.readonly();
        let owned;
        let slice: &[u16] = match ro.as_slice() {
            Ok(s) => s,
            Err(_) => {
                owned = ro.as_array().iter().copied().collect::<Vec<u16>>();
                &owned
            }
        };
        let t_s = t.unwrap_or_else(|| self.started.elapsed().as_secs_f64());
        let r = run(py, || {
            let mut guard = self
                .pipe
                .lock()
                .map_err(|_| anyhow::anyhow!("tracker poisoned by an earlier panic"))?;
            let (pipe, frames, last_t) = &mut *guard;
            // The rule of every depth frame's stamp, a recording's too.
            lmhost::sense::track::wire::frame_stamp("t", *frames, "", t_s, *last_t)?;
            (*frames, *last_t) = (*frames + 1, t_s);
            Ok(pipe.step(t_s, slice))
        })?;
        Ok((r.t_s, r.contact.points, r.present, r.centroid_mm(), r.gated))
    }
}

/// Rust-side timings for the benchmark: `plan` and `Tracker.process`
/// without Python in between (seconds per call, best of `repeats`).
#[pyfunction]
fn _bench_rust(
    py: Python<'_>,
    scene: &Scene_,
    intrinsics_toml: &str,
    depth: &Bound<'_, PyArray2<u16>>,
    repeats: usize,
) -> PyResult<(f64, f64)> {
    let intr = Intrinsics::from_toml(intrinsics_toml, "bench").map_err(|e| to_py(e.into()))?;
    let rig = CameraSetup::of_scene(&scene.scene).map_err(|e| to_py(e.into()))?;
    let ro = depth.readonly();
    let frame = ro.as_slice().map_err(|e| bad(e.to_string()))?;
    let flat = Scene::default();
    run(py, || {
        let best = |f: &mut dyn FnMut() -> anyhow::Result<()>| -> anyhow::Result<f64> {
            let mut best = f64::INFINITY;
            for _ in 0..repeats.max(1) {
                let t0 = Instant::now();
                f()?;
                best = best.min(t0.elapsed().as_secs_f64());
            }
            Ok(best)
        };
        let plan_s = best(&mut || {
            let s = Stimulus::paper_lm_m();
            std::hint::black_box(s.plan_for(&Target::Lm, flat.clone())?);
            Ok(())
        })?;
        let mut pipe = Pipeline::new(
            ContactTracker::new(intr, rig),
            Hysteresis::default(),
            lmhost::sense::stream::filter::FilterKind::None.build(),
        );
        let mut t = 0.0;
        let track_s = best(&mut || {
            t += 1.0 / 90.0;
            std::hint::black_box(pipe.step(t, frame));
            Ok(())
        })?;
        Ok((plan_s, track_s))
    })
}

/// Panics inside the library, for the test that a panic becomes
/// `RuntimeError` and never unwinds into the interpreter.
#[pyfunction]
fn _panic_for_test(py: Python<'_>) -> PyResult<()> {
    run(py, || -> anyhow::Result<()> {
        panic!("a panic inside lmhost")
    })
}

/// The extension module behind `import lmhost`.
#[pymodule]
fn _lmhost(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("DeviceError", m.py().get_type::<DeviceError>())?;
    m.add_class::<Scene_>()?;
    m.add_class::<Plan_>()?;
    m.add_class::<Field_>()?;
    m.add_class::<Tracker_>()?;
    m.add_class::<Device_>()?;
    m.add_class::<study::Study_>()?;
    m.add_function(wrap_pyfunction!(plan, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(args::int_arg, m)?)?;
    m.add_function(wrap_pyfunction!(args::float_arg, m)?)?;
    m.add_function(wrap_pyfunction!(args::bool_arg, m)?)?;
    m.add_function(wrap_pyfunction!(args::repeat_arg, m)?)?;
    m.add_function(wrap_pyfunction!(args::shown_arg, m)?)?;
    m.add("DEFAULTS", args::defaults(m.py())?)?;
    m.add("CONTROL_LIMITS", args::control_limits(m.py())?)?;
    m.add_function(wrap_pyfunction!(_bench_rust, m)?)?;
    m.add_function(wrap_pyfunction!(_panic_for_test, m)?)?;
    Ok(())
}
