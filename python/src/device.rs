//! `lmhost.Device`: a device opened by its `--port` name, through the
//! library's `Backend` (upload, play, stop, centroids, tick), with the GIL
//! released around every call.

use pyo3::prelude::*;

use lmhost::device::backend::Backend;
use lmhost::device::link::PortSpec;
use lmhost::device::upload::Play;
use lmhost::plan::scene::Scene;
use lmhost::plan::target::Target;

use super::{DeviceError, Plan_, Scene_, bad, run, to_py, to_python};

/// Moves a value the GIL-free closure uses on this same thread.
struct OnThisThread<T>(T);
// SAFETY: `allow_threads` runs its closure on the calling thread; the value
// never reaches another thread (the pyclass holding it is `unsendable`).
unsafe impl<T> Send for OnThisThread<T> {}

/// A device opened by its `--port` name.
#[pyclass(name = "Device", module = "lmhost._lmhost", unsendable)]
pub(crate) struct Device_ {
    dev: Option<Box<dyn Backend>>,
    scene: Scene,
    port: String,
    /// What `port` names, as the library reads it.
    kind: lmhost::device::connect::DeviceKind,
    /// Numbers and sends centroids (the library's one sender).
    centroids: lmhost::device::centroids::CentroidSender,
}

impl Device_ {
    fn with<T: Send>(
        &mut self,
        py: Python<'_>,
        f: impl FnOnce(&mut dyn Backend) -> anyhow::Result<T> + Send,
    ) -> PyResult<T> {
        let dev = self
            .dev
            .as_mut()
            .ok_or_else(|| DeviceError::new_err(format!("{} is closed", self.port)))?;
        let dev = OnThisThread(dev);
        run(py, move || {
            let dev = dev;
            f(dev.0.as_mut())
        })
    }
}

#[pymethods]
impl Device_ {
    /// Opens `port` (any `--port` form) for `scene`.
    #[new]
    fn new(py: Python<'_>, port: String, scene: Option<&Scene_>) -> PyResult<Self> {
        let scene = scene.map_or_else(Scene::default, |s| s.scene.clone());
        let spec = PortSpec::new(Some(port.clone()));
        let kind = spec.device().map_err(|e| to_py(e.into()))?;
        let s = scene.clone();
        let dev = run(py, move || {
            Ok(OnThisThread(lmhost::device::connect::open_with(
                &spec,
                &s,
                lm_proto::Encoding::Delta,
                false,
            )?))
        })?
        .0;
        Ok(Self {
            dev: Some(dev),
            scene,
            port,
            kind,
            centroids: Default::default(),
        })
    }

    /// Identity and capabilities (dict).
    fn info(&mut self, py: Python<'_>) -> PyResult<PyObject> {
        let v = self.with(py, |d| Ok(serde_json::to_value(d.info()?)?))?;
        to_python(py, &v)
    }

    /// The device's status (dict).
    fn status(&mut self, py: Python<'_>) -> PyResult<PyObject> {
        let v = self.with(py, |d| Ok(serde_json::to_value(d.status()?)?))?;
        to_python(py, &v)
    }

    /// Uploads through `lmhost::device::upload::upload` (the `lmhost upload --json`
    /// report, as a JSON string). The plan must be for this device kind.
    fn upload(
        &mut self,
        py: Python<'_>,
        plan: &Plan_,
        slot: Option<u8>,
        play: bool,
        untracked: bool,
    ) -> PyResult<String> {
        let kind = match self.kind.target() {
            Target::Lm => "lm",
            Target::Autd3 => "autd3",
        };
        if plan.target_kind() != self.kind.target() {
            return Err(bad(format!(
                "the plan is for target={:?} but {} is an {kind} device: plan with target={kind:?}",
                plan.target, self.port
            )));
        }
        let planned = &plan.planned;
        let play = match (play, untracked) {
            (false, _) => Play::No,
            (true, false) => Play::Tracked,
            (true, true) => Play::Untracked,
        };
        self.with(py, move |d| {
            let o = lmhost::device::upload::upload(d, planned, slot, play)?;
            Ok(serde_json::to_string(&o)?)
        })
    }

    /// Plays `slot` (tracked unless `untracked`).
    #[pyo3(signature = (slot, untracked=false))]
    fn play(&mut self, py: Python<'_>, slot: u8, untracked: bool) -> PyResult<()> {
        self.with(py, |d| Ok(d.play(slot, untracked)?))
    }

    /// Stops playing: the array is silent.
    fn stop(&mut self, py: Python<'_>) -> PyResult<()> {
        self.with(py, |d| Ok(d.stop()?))
    }

    /// Sends a finger centroid (mm, finger space); returns `"applied"` or
    /// `"out_of_range"`.
    #[pyo3(signature = (x, y, z, present=true))]
    fn centroid(
        &mut self,
        py: Python<'_>,
        x: f64,
        y: f64,
        z: f64,
        present: bool,
    ) -> PyResult<&'static str> {
        let p = lmhost::limits::position_mm("centroid", [x, y, z]).map_err(|e| to_py(e.into()))?;
        let pos_um = present.then(|| self.scene.drive_point(p).map(lmhost::units::mm_to_um));
        let mut sender = self.centroids.clone();
        let out = self.with(py, move |d| {
            let r = sender.send(d, pos_um, lmhost::clock::monotonic_us());
            Ok((sender, r))
        })?;
        self.centroids = out.0;
        Ok(match out.1.map_err(|e| to_py(e.into()))? {
            lmhost::device::backend::CentroidOutcome::Applied => "applied",
            lmhost::device::backend::CentroidOutcome::OutOfRange => "out_of_range",
        })
    }

    /// Keeps a host-driven link (AUTD3) ticking once: its safety gate,
    /// timed plays, queued switches and its lease renewal.
    fn tick(&mut self, py: Python<'_>) -> PyResult<()> {
        self.with(py, |d| Ok(d.tick()?))
    }

    /// Where the device is.
    #[getter]
    fn port(&self) -> String {
        self.port.clone()
    }

    /// Stops what this host plays (an AUTD3, or the LM firmware under its
    /// lease: both play only while held) and closes the device.
    fn close(&mut self, py: Python<'_>) -> PyResult<()> {
        let needs_host = self.dev.as_ref().is_some_and(|d| d.needs_host());
        if needs_host {
            let r = self.with(py, |d| Ok(d.stop()?));
            self.dev = None;
            r
        } else {
            self.dev = None;
            Ok(())
        }
    }
}
