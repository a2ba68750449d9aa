//! `lmhost.Device`: a device opened by its `--port` name, through the
//! library's `Backend` (upload, play, stop, centroids, tick), with the GIL
//! released around every call.
//!
//! A `Backend` is not `Send` (an AUTD3's link, a serial port), yet Python
//! may call a `Device` from any thread. So the backend lives on a thread
//! of its own, opened there and dropped there, and every call is a job
//! sent to it and answered over a channel: the pyclass holds only the
//! sending end, which is `Send`, and calls from several Python threads
//! run one after another in the order they arrive. No `unsafe`, and no
//! `PanicException` for a call from a thread other than the opener's.

use std::sync::Mutex;
use std::sync::mpsc::{Sender, channel};
use std::thread::JoinHandle;

use pyo3::prelude::*;

use lmhost::device::backend::Backend;
use lmhost::device::centroids::CentroidSender;
use lmhost::device::connect::DeviceKind;
use lmhost::device::link::PortSpec;
use lmhost::device::upload::Play;
use lmhost::plan::scene::Scene;

use super::{DeviceError, Plan_, Scene_, args, bad, panic_err, panic_msg, to_py, to_python};

/// What the device's thread owns.
struct Held {
    dev: Box<dyn Backend>,
    /// Numbers and sends centroids (the library's one sender).
    centroids: CentroidSender,
}

/// One call, run on the device's thread.
type Job = Box<dyn FnOnce(&mut Held) + Send>;

/// The device's thread and the way to reach it (`None` once closed).
struct Worker {
    jobs: Sender<Job>,
    thread: JoinHandle<()>,
}

/// A device opened by its `--port` name.
#[pyclass(name = "Device", module = "lmhost._lmhost", frozen)]
pub(crate) struct Device_ {
    worker: Mutex<Option<Worker>>,
    scene: Scene,
    port: String,
    /// What `port` names, as the library reads it.
    kind: DeviceKind,
}

impl Device_ {
    /// Runs `f` on the device's thread, without the GIL; a panic there is
    /// `RuntimeError`, a closed device `DeviceError`.
    fn with<T: Send + 'static>(
        &self,
        py: Python<'_>,
        f: impl FnOnce(&mut Held) -> anyhow::Result<T> + Send + 'static,
    ) -> PyResult<T> {
        let closed = || DeviceError::new_err(format!("{} is closed", self.port));
        let (tx, rx) = channel();
        let job: Job = Box::new(move |h| {
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| f(h)));
            let _ = tx.send(r);
        });
        {
            let w = self.worker.lock().map_err(|_| closed())?;
            w.as_ref()
                .ok_or_else(closed)?
                .jobs
                .send(job)
                .map_err(|_| closed())?;
        }
        py.allow_threads(move || rx.recv())
            .map_err(|_| closed())?
            .map_err(panic_err)?
            .map_err(to_py)
    }
}

/// Opens the device on a new thread that then serves its jobs until the
/// sending end is dropped; the backend is dropped on that thread too.
fn spawn(spec: PortSpec, scene: Scene) -> anyhow::Result<Worker> {
    let (jobs, rx) = channel::<Job>();
    let (opened_tx, opened) = channel();
    let thread = std::thread::Builder::new()
        .name("lmhost-device".into())
        .spawn(move || {
            let open = std::panic::catch_unwind(|| {
                lmhost::device::connect::open_with(&spec, &scene, lm_proto::Encoding::Delta, false)
            });
            let dev = match open {
                Ok(Ok(dev)) => {
                    let _ = opened_tx.send(Ok(()));
                    dev
                }
                Ok(Err(e)) => {
                    let _ = opened_tx.send(Err(e));
                    return;
                }
                Err(p) => {
                    let _ = opened_tx.send(Err(anyhow::anyhow!(
                        "lmhost internal error: {}",
                        panic_msg(&*p)
                    )));
                    return;
                }
            };
            let mut held = Held {
                dev,
                centroids: CentroidSender::default(),
            };
            for job in rx {
                job(&mut held);
            }
        })?;
    match opened.recv() {
        Ok(Ok(())) => Ok(Worker { jobs, thread }),
        Ok(Err(e)) => {
            let _ = thread.join();
            Err(e)
        }
        Err(_) => {
            let _ = thread.join();
            anyhow::bail!("the device's thread ended while opening it")
        }
    }
}

#[pymethods]
impl Device_ {
    /// Opens `port` (any `--port` form) for `scene`.
    #[new]
    #[pyo3(signature = (port, scene=None))]
    fn new(
        py: Python<'_>,
        port: &Bound<'_, PyAny>,
        scene: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let port: String = port
            .downcast::<pyo3::types::PyString>()
            .map_err(|_| {
                bad(format!(
                    "port must be a --port name (a string), got {}",
                    args::kind(port)
                ))
            })?
            .extract()?;
        let scene = match scene.filter(|s| !s.is_none()) {
            Some(s) => crate::args::class::<Scene_>("scene", s, crate::args::A_SCENE)?
                .get()
                .scene
                .clone(),
            None => Scene::default(),
        };
        let spec = PortSpec::new(Some(port.clone()));
        let kind = spec.device().map_err(|e| to_py(e.into()))?;
        let s = scene.clone();
        let worker = py.allow_threads(move || spawn(spec, s)).map_err(to_py)?;
        Ok(Self {
            worker: Mutex::new(Some(worker)),
            scene,
            port,
            kind,
        })
    }

    /// Identity and capabilities (dict).
    fn info(&self, py: Python<'_>) -> PyResult<PyObject> {
        let v = self.with(py, |h| Ok(serde_json::to_value(h.dev.info()?)?))?;
        to_python(py, &v)
    }

    /// The device's status (dict).
    fn status(&self, py: Python<'_>) -> PyResult<PyObject> {
        let v = self.with(py, |h| Ok(serde_json::to_value(h.dev.status()?)?))?;
        to_python(py, &v)
    }

    /// Uploads through `lmhost::device::upload::upload` (the `lmhost upload --json`
    /// report, as a JSON string). The plan must be for this device kind.
    #[pyo3(signature = (plan, slot=None, play=None, untracked=None))]
    fn upload(
        &self,
        py: Python<'_>,
        plan: &Bound<'_, PyAny>,
        slot: Option<&Bound<'_, PyAny>>,
        play: Option<&Bound<'_, PyAny>>,
        untracked: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<String> {
        let plan = crate::args::class::<Plan_>("plan", plan, crate::args::A_PLAN)?.get();
        let yes_no = |name, v: Option<&Bound<'_, PyAny>>, default| {
            v.map_or(Ok(default), |v| crate::args::bool_arg(name, v))
        };
        let play = yes_no("play", play, true)?;
        let untracked = yes_no("untracked", untracked, false)?;
        let slot = args::opt_int_in::<u8>("slot", slot, 0, u8::MAX.into())?;
        let kind = self.kind.target().name();
        if plan.target != self.kind.target() {
            return Err(bad(format!(
                "the plan is for target={:?} but {} is an {kind} device: plan with target={kind:?}",
                plan.target.name(),
                self.port
            )));
        }
        let planned = plan.planned.clone();
        let play = match (play, untracked) {
            // As `--untracked` with `--no-play`: a choice of how to play,
            // refused when nothing plays rather than dropped.
            (false, true) => {
                return Err(bad("untracked=True applies to a play: not with play=False"));
            }
            (false, false) => Play::No,
            (true, false) => Play::Tracked,
            (true, true) => Play::Untracked,
        };
        self.with(py, move |h| {
            let o = lmhost::device::upload::upload(h.dev.as_mut(), &planned, slot, play)?;
            Ok(serde_json::to_string(&o)?)
        })
    }

    /// Plays `slot` (tracked unless `untracked`).
    #[pyo3(signature = (slot, untracked=false))]
    fn play(&self, py: Python<'_>, slot: &Bound<'_, PyAny>, untracked: bool) -> PyResult<()> {
        let slot: u8 = args::int_in("slot", slot, 0, u8::MAX.into())?;
        self.with(py, move |h| Ok(h.dev.play(slot, untracked)?))
    }

    /// Stops playing: the array is silent.
    fn stop(&self, py: Python<'_>) -> PyResult<()> {
        self.with(py, |h| Ok(h.dev.stop()?))
    }

    /// Sends a finger centroid (mm, finger space); returns `"applied"` or
    /// `"out_of_range"`.
    #[pyo3(signature = (x, y, z, present=true))]
    fn centroid(
        &self,
        py: Python<'_>,
        x: &Bound<'_, PyAny>,
        y: &Bound<'_, PyAny>,
        z: &Bound<'_, PyAny>,
        present: bool,
    ) -> PyResult<&'static str> {
        let p = [
            args::float("x", x)?,
            args::float("y", y)?,
            args::float("z", z)?,
        ];
        let p = lmhost::limits::position_mm("centroid", p).map_err(|e| to_py(e.into()))?;
        let pos_um = present.then(|| self.scene.drive_point(p).map(lmhost::units::mm_to_um));
        let out = self.with(py, move |h| {
            Ok(h.centroids
                .send(h.dev.as_mut(), pos_um, lmhost::clock::monotonic_us())?)
        })?;
        Ok(match out {
            lmhost::device::backend::CentroidOutcome::Applied => "applied",
            lmhost::device::backend::CentroidOutcome::OutOfRange => "out_of_range",
        })
    }

    /// Keeps a host-driven link (AUTD3) ticking once: its safety gate,
    /// timed plays, queued switches and its lease renewal.
    fn tick(&self, py: Python<'_>) -> PyResult<()> {
        self.with(py, |h| Ok(h.dev.tick()?))
    }

    /// Where the device is.
    #[getter]
    fn port(&self) -> String {
        self.port.clone()
    }

    /// Stops what this host plays (an AUTD3, or the LM firmware under its
    /// lease: both play only while held) and closes the device: when it
    /// returns, the backend is dropped and the port is free.
    fn close(&self, py: Python<'_>) -> PyResult<()> {
        let needs_host = match self.with(py, |h| Ok(h.dev.needs_host())) {
            Ok(n) => n,
            Err(_) => return Ok(()), // already closed
        };
        let r = if needs_host {
            self.with(py, |h| Ok(h.dev.stop()?))
        } else {
            Ok(())
        };
        let worker = self.worker.lock().ok().and_then(|mut w| w.take());
        if let Some(Worker { jobs, thread }) = worker {
            drop(jobs);
            py.allow_threads(|| thread.join()).map_err(panic_err)?;
        }
        r
    }
}

impl Drop for Device_ {
    /// Collected without `close`: the thread ends and drops the backend
    /// (the sending end goes with `self`); waited for so the port is free.
    fn drop(&mut self) {
        if let Some(Worker { jobs, thread }) = self.worker.get_mut().ok().and_then(|w| w.take()) {
            drop(jobs);
            let _ = thread.join();
        }
    }
}
