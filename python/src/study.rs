//! `lmhost.Study`: a study protocol run in process (`lmhost study run`'s
//! runner, [`lmhost::lab::study::run`]), its answers from a Python
//! callable, its rows handed to Python as they are written.
//!
//! The runner holds the device and polls it every millisecond, so it runs
//! on a thread of its own; Python's thread only waits (without the GIL)
//! for what the runner sends it: a question to answer or a row written.
//! The callback is therefore always called on the thread that iterates the
//! study — the one a PsychoPy window or a button box's driver lives on —
//! and never while the runner holds anything Python needs.
//!
//! A callback that raises ends the run (the array silent, the rows so far
//! on disk, resumable) and its exception propagates from the iteration;
//! so does a `KeyboardInterrupt` while waiting, after the runner has
//! stopped the array.

use std::path::PathBuf;
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, TryRecvError, channel};
use std::thread::JoinHandle;
use std::time::Duration;

use pyo3::exceptions::PyStopIteration;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use lmhost::device::link::PortSpec;
use lmhost::error::InputError;
use lmhost::lab::study::answers::{Accepts, Answers, Asked};
use lmhost::lab::study::options::{Hooks, RowFields};
use lmhost::lab::study::{AnswerSource, FingerSource, RunOptions, RunReport};

use super::{args, bad, panic_err, to_py, to_python};

/// What the runner sends the iterating thread.
enum Msg {
    /// A question and where its answer goes (`Err`: the callback raised).
    Ask(serde_json::Value, Sender<Result<String, String>>),
    /// A row, on disk.
    Row(RowFields),
}

/// The question as the callback gets it.
fn question(q: &Asked) -> serde_json::Value {
    let (kind, accepts) = match &q.accepts {
        Accepts::Likert(n) => ("likert", serde_json::json!({ "points": n })),
        Accepts::Choice(labels) => ("choice", serde_json::json!({ "labels": labels })),
        Accepts::Number(lo, hi) => ("number", serde_json::json!({ "min": lo, "max": hi })),
    };
    serde_json::json!({
        "column": q.column,
        "prompt": q.prompt,
        "kind": kind,
        "accepts": accepts,
        "not_perceived": q.not_perceived,
        "level": q.perceived_at,
    })
}

/// Answers from the iterating thread's callback.
struct Asking {
    tx: Sender<Msg>,
    pending: Option<Receiver<Result<String, String>>>,
}

impl Answers for Asking {
    fn poll(&mut self, q: &Asked) -> anyhow::Result<Option<String>> {
        let rx = match &self.pending {
            Some(rx) => rx,
            None => {
                let (tx, rx) = channel();
                self.tx
                    .send(Msg::Ask(question(q), tx))
                    .map_err(|_| anyhow::anyhow!("the Python study was dropped"))?;
                self.pending.insert(rx)
            }
        };
        let text = match rx.try_recv() {
            Ok(Ok(text)) => text,
            Ok(Err(raised)) => anyhow::bail!("the answer callback raised: {raised}"),
            Err(TryRecvError::Empty) => return Ok(None),
            Err(TryRecvError::Disconnected) => {
                anyhow::bail!(
                    "the Python study was dropped while `{}` was asked",
                    q.column
                )
            }
        };
        self.pending = None;
        q.parse(&text).map(Some).map_err(|m| {
            InputError::new(format!(
                "the answer callback's answer to `{}`: {m}",
                q.column
            ))
            .into()
        })
    }
}

/// A study running on a thread of its own.
#[pyclass(name = "Study", module = "lmhost._lmhost", unsendable)]
pub(crate) struct Study_ {
    rx: Receiver<Msg>,
    runner: Option<JoinHandle<std::thread::Result<anyhow::Result<RunReport>>>>,
    answer: PyObject,
    /// What the run did, once it has ended.
    report: Option<serde_json::Value>,
}

fn report_json(r: &RunReport) -> serde_json::Value {
    serde_json::json!({
        "dir": r.dir,
        "trials": r.trials,
        "first": r.first,
        "ran": r.ran,
        "seed": r.seed,
        "uploads": r.uploads,
    })
}

#[pymethods]
impl Study_ {
    #[new]
    #[pyo3(signature = (protocol, participant, out, port, answer, scene=None, seed=None, index=None, finger=None, time_scale=1.0, resume=false))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        protocol: PathBuf,
        participant: String,
        out: PathBuf,
        port: String,
        answer: PyObject,
        scene: Option<PathBuf>,
        seed: Option<u64>,
        index: Option<usize>,
        finger: Option<String>,
        time_scale: f64,
        resume: bool,
    ) -> PyResult<Self> {
        let protocol = args::path("protocol", protocol)?;
        let out = args::path("out", out)?;
        let scene = scene.map(|p| args::path("scene", p)).transpose()?;
        let finger = match finger.as_deref() {
            None => FingerSource::None,
            Some("synthetic") => FingerSource::Synthetic,
            Some(other) => {
                return Err(bad(format!(
                    "finger {other:?}: give None or \"synthetic\" (tracked sources: `lmhost study run --stream/--udp/--depth`)"
                )));
            }
        };
        let (tx, rx) = channel();
        let rows = tx.clone();
        let o = RunOptions {
            protocol,
            port: PortSpec::new(Some(port)),
            scene,
            participant,
            out,
            seed,
            index,
            answers: AnswerSource::Interactive,
            finger,
            time_scale,
            resume,
            resume_anyway: false,
            view: None,
            instruments: None,
            hooks: Hooks {
                answers: Some(Box::new(Asking { tx, pending: None })),
                rows: Some(Box::new(move |r| {
                    let _ = rows.send(Msg::Row(r));
                })),
            },
        };
        let runner = std::thread::Builder::new()
            .name("lmhost-study".into())
            .spawn(move || {
                std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    lmhost::lab::study::run(o)
                }))
            })
            .map_err(|e| bad(format!("starting the study: {e}")))?;
        Ok(Self {
            rx,
            runner: Some(runner),
            answer,
            report: None,
        })
    }

    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    /// The next row once it is written; answers questions on the way.
    fn __next__(&mut self, py: Python<'_>) -> PyResult<PyObject> {
        loop {
            if self.runner.is_none() {
                return Err(PyStopIteration::new_err(()));
            }
            let rx = &mut self.rx;
            let got = py.allow_threads(move || rx.recv_timeout(Duration::from_millis(50)));
            match got {
                Ok(Msg::Row(fields)) => {
                    let d = PyDict::new(py);
                    for (k, v) in fields {
                        d.set_item(k, v)?;
                    }
                    return Ok(d.into_any().unbind());
                }
                Ok(Msg::Ask(q, reply)) => {
                    let asked = to_python(py, &q)?;
                    match self
                        .answer
                        .call1(py, (asked,))
                        .and_then(|a| a.bind(py).str().map(|s| s.to_string()))
                    {
                        Ok(text) => {
                            let _ = reply.send(Ok(text));
                        }
                        Err(e) => {
                            let _ = reply.send(Err(e.to_string()));
                            // The runner silences the array and ends; the
                            // callback's own exception is what Python sees.
                            let _ = self.finish(py);
                            return Err(e);
                        }
                    }
                }
                Err(RecvTimeoutError::Timeout) => {
                    if let Err(e) = py.check_signals() {
                        lmhost::stop::request();
                        let _ = self.finish(py);
                        lmhost::stop::clear();
                        return Err(e);
                    }
                }
                Err(RecvTimeoutError::Disconnected) => {
                    self.finish(py)?;
                    return Err(PyStopIteration::new_err(()));
                }
            }
        }
    }

    /// What the run did (`None` until it has ended).
    #[getter]
    fn report(&self, py: Python<'_>) -> PyResult<Option<PyObject>> {
        self.report.as_ref().map(|r| to_python(py, r)).transpose()
    }
}

impl Study_ {
    /// Waits for the runner to end (it does once its channel is gone or
    /// it has been stopped); its error becomes Python's.
    fn finish(&mut self, py: Python<'_>) -> PyResult<()> {
        let Some(runner) = self.runner.take() else {
            return Ok(());
        };
        // Unblock a runner waiting for an answer that will not come.
        let rx = std::mem::replace(&mut self.rx, channel().1);
        drop(rx);
        let joined = py.allow_threads(|| runner.join());
        let result = match joined {
            Ok(r) => r,
            Err(p) => Err(p),
        };
        let report = result.map_err(panic_err)?.map_err(to_py)?;
        self.report = Some(report_json(&report));
        Ok(())
    }
}
