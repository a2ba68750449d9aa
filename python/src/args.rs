//! Arguments from Python, checked in one place: every integer and float
//! any entry point takes goes through [`int_in`] or [`float`] (and the
//! pure-Python `Session` reaches them as `_lmhost.int_arg` and
//! `_lmhost.float_arg`), so bad input is always `ValueError` naming the
//! parameter — never an `OverflowError` or `TypeError` from the
//! conversion, never a float silently truncated to an int, never a NaN or
//! infinity passed on towards the wire.
//!
//! Also the keyword API's defaults ([`defaults`], `_lmhost.DEFAULTS`),
//! read from the library's constants so a change there changes Python.

use pyo3::exceptions::{PyOverflowError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat};

use lmhost::field;
use lmhost::plan::stimulus::Stimulus;
use lmhost::plan::trajectory::Steps;
use lmhost::sense::track::presence::Hysteresis;

/// A value for a message: its repr on one line, cut short (a 4000-digit
/// integer or a long string is not echoed whole, a numpy array's rows
/// not over several lines). The package's Python code shows values by it
/// too (`_lmhost.shown`, [`shown_arg`]).
pub(crate) fn shown(v: &Bound<'_, PyAny>) -> String {
    const MAX: usize = 40;
    // One line: a numpy array's repr spans several.
    let r = v
        .repr()
        .map(|r| {
            r.to_string()
                .lines()
                .map(str::trim)
                .collect::<Vec<_>>()
                .join(" ")
        })
        .unwrap_or_else(|_| "?".into());
    if r.chars().count() <= MAX {
        r
    } else {
        format!(
            "{}… ({} characters)",
            r.chars().take(MAX).collect::<String>(),
            r.len()
        )
    }
}

/// Whether `v` is a yes-or-no value: Python's `bool` or numpy's
/// (`np.True_`, of type `numpy.bool`, `numpy.bool_` before numpy 2),
/// which is no `bool` subclass and whose `__float__` made it 1.0.
fn is_bool(v: &Bound<'_, PyAny>) -> bool {
    if v.is_instance_of::<PyBool>() {
        return true;
    }
    let t = v.get_type();
    let named = |attr: &str, want: &[&str]| {
        t.getattr(attr)
            .and_then(|a| a.extract::<String>())
            .is_ok_and(|n| want.contains(&n.as_str()))
    };
    named("__module__", &["numpy"]) && named("__name__", &["bool", "bool_"])
}

/// Whether `v` is a complex number that is not a real one (numbers'
/// `Complex` and not `Real`): Python's `complex` and numpy's, whose
/// `__float__` dropped the imaginary part (`np.complex128(1+2j)` was 1.0).
fn is_complex(v: &Bound<'_, PyAny>) -> bool {
    let Ok(numbers) = v.py().import("numbers") else {
        return false;
    };
    let is = |abc: &str| {
        numbers
            .getattr(abc)
            .and_then(|c| v.is_instance(&c))
            .unwrap_or(false)
    };
    is("Complex") && !is("Real")
}

/// An integer parameter in `lo..=hi` (the caller's type holds that range).
/// Python ints and anything with `__index__` (numpy integers) are taken;
/// a bool (numpy's too), a float (even `4.0`: an int was meant) or
/// anything else is `ValueError`, as is a value out of range, however
/// large.
pub(crate) fn int_in<T: TryFrom<i64>>(
    name: &str,
    v: &Bound<'_, PyAny>,
    lo: i64,
    hi: i64,
) -> PyResult<T> {
    // The library's form ("foci must be 1..=32, got 0"), so a value the
    // library would refuse reads the same from either side.
    let out_of_range =
        || PyValueError::new_err(format!("{name} must be {lo}..={hi}, got {}", shown(v)));
    if is_bool(v) || v.is_instance_of::<PyFloat>() {
        return Err(PyValueError::new_err(format!(
            "{name} must be an integer, got {}",
            shown(v)
        )));
    }
    let n: i64 = match v.extract() {
        Ok(n) => n,
        Err(e) if e.is_instance_of::<PyOverflowError>(v.py()) => return Err(out_of_range()),
        Err(_) => {
            return Err(PyValueError::new_err(format!(
                "{name} must be an integer, got {}",
                shown(v)
            )));
        }
    };
    if !(lo..=hi).contains(&n) {
        return Err(out_of_range());
    }
    T::try_from(n).map_err(|_| out_of_range())
}

/// An optional [`int_in`].
pub(crate) fn opt_int_in<T: TryFrom<i64>>(
    name: &str,
    v: Option<&Bound<'_, PyAny>>,
    lo: i64,
    hi: i64,
) -> PyResult<Option<T>> {
    v.filter(|v| !v.is_none())
        .map(|v| int_in(name, v, lo, hi))
        .transpose()
}

/// A finite float parameter (ints and numpy's numbers taken; a bool or a
/// complex number, numpy's too, refused); its range is the library's to
/// check, with the library's message.
pub(crate) fn float(name: &str, v: &Bound<'_, PyAny>) -> PyResult<f64> {
    if is_bool(v) || is_complex(v) {
        return Err(PyValueError::new_err(format!(
            "{name} must be a number, got {}",
            shown(v)
        )));
    }
    let x: f64 = match v.extract() {
        Ok(x) => x,
        Err(e) if e.is_instance_of::<PyOverflowError>(v.py()) => {
            return Err(PyValueError::new_err(format!(
                "{name} {} is out of range: give a finite number",
                shown(v)
            )));
        }
        Err(_) => {
            return Err(PyValueError::new_err(format!(
                "{name} must be a number, got {}",
                shown(v)
            )));
        }
    };
    if !x.is_finite() {
        return Err(PyValueError::new_err(format!(
            "{name} must be a finite number, got {}",
            lmhost::limits::show(x)
        )));
    }
    // Negative zero is zero: taken as 0 (where 0 is allowed; refused as
    // 0 where it is not), never carried on to be reported as `-0.0`
    // (`radius_mm: -0.0` in a plan's summary).
    Ok(x + 0.0)
}

/// An optional [`float`].
pub(crate) fn opt_float(name: &str, v: Option<&Bound<'_, PyAny>>) -> PyResult<Option<f64>> {
    v.filter(|v| !v.is_none())
        .map(|v| float(name, v))
        .transpose()
}

/// `n` finite floats from any sequence (a tuple, a list, a numpy array).
pub(crate) fn floats(name: &str, v: &Bound<'_, PyAny>, n: usize) -> PyResult<Vec<f64>> {
    let wrong = || PyValueError::new_err(format!("{name} takes {n} numbers, got {}", shown(v)));
    if v.is_instance_of::<pyo3::types::PyString>() {
        return Err(wrong());
    }
    let len = v.len().map_err(|_| wrong())?;
    if len != n {
        return Err(wrong());
    }
    (0..n)
        .map(|i| {
            let x = v.get_item(i).map_err(|_| wrong())?;
            float(&format!("{name}[{i}]"), &x)
        })
        .collect()
}

/// An optional [`floats`].
pub(crate) fn opt_floats(
    name: &str,
    v: Option<&Bound<'_, PyAny>>,
    n: usize,
) -> PyResult<Option<Vec<f64>>> {
    v.filter(|v| !v.is_none())
        .map(|v| floats(name, v, n))
        .transpose()
}

/// [`shown`] for the package's Python code: every value a Python-side
/// message repeats is shown as the extension's are.
#[pyfunction]
#[pyo3(name = "shown")]
pub(crate) fn shown_arg(value: &Bound<'_, PyAny>) -> String {
    shown(value)
}

/// [`int_in`] for Python code (the `Session` client).
#[pyfunction]
pub(crate) fn int_arg(name: &str, value: &Bound<'_, PyAny>, lo: i64, hi: i64) -> PyResult<i64> {
    int_in(name, value, lo, hi)
}

/// A yes-or-no parameter: `True` or `False` (a numpy bool too), never the
/// truth of another value (`present="no"` or `None` is not a choice).
#[pyfunction]
pub(crate) fn bool_arg(name: &str, value: &Bound<'_, PyAny>) -> PyResult<bool> {
    if is_bool(value) {
        return value.is_truthy();
    }
    Err(PyValueError::new_err(format!(
        "{name} must be True or False, got {}",
        shown(value)
    )))
}

/// A session command's `repeat`, judged before it is sent by the rule the
/// session applies ([`lmhost::lab::session::protocol::repeat::check`]), in
/// its words ("repeat 1e30 is out of range: allowed 1..=10000"), not by
/// the width of a type on the way: an integer of any size (numpy's too);
/// a bool, a float or anything else refused by name, as [`int_in`] does.
#[pyfunction]
pub(crate) fn repeat_arg(value: &Bound<'_, PyAny>) -> PyResult<u32> {
    let not_int =
        || PyValueError::new_err(format!("repeat must be an integer, got {}", shown(value)));
    if is_bool(value) || value.is_instance_of::<PyFloat>() {
        return Err(not_int());
    }
    let n: serde_json::Value = match value.extract::<i64>() {
        Ok(n) => n.into(),
        // Beyond an i64: a float, as the session reads such a number.
        Err(e) if e.is_instance_of::<PyOverflowError>(value.py()) => {
            let f = value
                .call_method0("__float__")
                .and_then(|f| f.extract::<f64>())
                .ok()
                .and_then(serde_json::Number::from_f64);
            match f {
                Some(f) => f.into(),
                None => {
                    return Err(PyValueError::new_err(format!(
                        "repeat {} is out of range: allowed 1..={}",
                        shown(value),
                        lmhost::lab::session::MAX_REPEAT
                    )));
                }
            }
        }
        Err(_) => return Err(not_int()),
    };
    lmhost::lab::session::protocol::repeat::check(&n).map_err(PyValueError::new_err)
}

/// [`float`] for Python code (the `Session` client).
#[pyfunction]
pub(crate) fn float_arg(name: &str, value: &Bound<'_, PyAny>) -> PyResult<f64> {
    float(name, value)
}

/// The session's limits on what a control line carries, from the
/// library, so `Session` refuses a value by its own limit, in its own
/// words, before it builds the line (not by the line's length after).
pub(crate) fn control_limits(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("id_chars", lmhost::plan::library::MAX_ID_LEN)?;
    d.set_item("token_chars", lmhost::lab::session::serve::TOKEN_CHARS)?;
    d.set_item(
        "line_bytes",
        lmhost::lab::session::protocol::MAX_COMMAND_BYTES,
    )?;
    Ok(d)
}

/// The keyword API's defaults, from the library: the stimulus `lmhost
/// plan` plans without flags, `lmhost simulate`'s view, the tracker's
/// presence hysteresis and the device lease.
pub(crate) fn defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let s = Stimulus::default();
    let step = match s.cycle.steps {
        Steps::Width(w) => w,
        Steps::Count(_) => lmhost::plan::trajectory::paper::STEP_MM,
    };
    let h = Hysteresis::default();
    let d = PyDict::new(py);
    d.set_item("radius", s.cycle.radius_mm)?;
    d.set_item("foci", s.cycle.foci)?;
    d.set_item("spacing", s.cycle.spacing_mm)?;
    d.set_item("freq", s.cycle.freq_hz)?;
    d.set_item("step", step)?;
    d.set_item("intensity", s.intensity)?;
    d.set_item("target", "lm")?;
    d.set_item("plane_size", field::study::PLANE_SIZE_MM)?;
    d.set_item("plane_step", field::study::PLANE_STEP_MM)?;
    d.set_item("alpha", field::DEFAULT_RADIATION_ALPHA)?;
    d.set_item("density", field::DEFAULT_DENSITY_KG_M3)?;
    d.set_item("disk", field::study::DISK_MM)?;
    d.set_item("enter_frames", h.enter())?;
    d.set_item("leave_frames", h.leave())?;
    d.set_item(
        "lease_s",
        lmhost::device::backend::DEFAULT_LEASE.as_secs_f64(),
    )?;
    Ok(d)
}

/// What kind of Python value `v` is, for a message (`int`, `None`).
pub(crate) fn kind(v: &Bound<'_, PyAny>) -> String {
    match v.is_none() {
        true => "None".into(),
        false => v
            .get_type()
            .name()
            .map_or_else(|_| "?".into(), |n| n.to_string()),
    }
}

/// What a [`Scene`](crate::Scene_) parameter takes, for its message.
pub(crate) const A_SCENE: &str = "a Scene (lmhost.Scene.load(path) or lmhost.Scene.flat())";
/// What a [`Plan`](crate::Plan_) parameter takes, for its message.
pub(crate) const A_PLAN: &str = "a Plan (from lmhost.plan())";

/// A parameter of one of the package's classes: another kind of value is
/// `ValueError` naming the parameter and what it must be (`what`), as
/// every other bad argument; pyo3's own conversion raised `TypeError`
/// "argument 'scene': 'int' object cannot be converted to 'Scene'".
pub(crate) fn class<'a, 'py, T: pyo3::PyClass>(
    name: &str,
    v: &'a Bound<'py, PyAny>,
    what: &str,
) -> PyResult<&'a Bound<'py, T>> {
    v.downcast::<T>()
        .map_err(|_| PyValueError::new_err(format!("{name} must be {what}, got {}", kind(v))))
}

/// A path parameter given as any Python value: a `str` or an
/// `os.PathLike` naming one (a `pathlib.Path`), then as [`path`]; bytes
/// and every other kind refused naming the parameter and what it takes
/// (pyo3's conversion said "'bytes' object cannot be converted to
/// 'PyString'").
pub(crate) fn path_of(name: &str, v: &Bound<'_, PyAny>) -> PyResult<std::path::PathBuf> {
    let not_path = || {
        PyValueError::new_err(format!(
            "{name} must be a path (a str or pathlib.Path), got {}",
            kind(v)
        ))
    };
    let text = match v.downcast::<pyo3::types::PyString>() {
        Ok(s) => s.extract::<String>()?,
        Err(_) if !v.is_instance_of::<pyo3::types::PyBytes>() && v.hasattr("__fspath__")? => {
            let p = v.call_method0("__fspath__").map_err(|_| not_path())?;
            let s = p
                .downcast::<pyo3::types::PyString>()
                .map_err(|_| not_path())?;
            s.extract::<String>()?
        }
        Err(_) => return Err(not_path()),
    };
    path(name, text.into())
}

/// A path parameter: an empty one is refused naming `name`, as the CLI
/// refuses an empty path flag (`--out ""`), never taken as the working
/// directory (a study's `out=""` wrote its folder there) or handed to the
/// OS (`save("")` was a `DeviceError`, "invalid input parameter").
pub(crate) fn path(name: &str, p: std::path::PathBuf) -> PyResult<std::path::PathBuf> {
    if p.as_os_str().is_empty() {
        return Err(PyValueError::new_err(format!(
            "{name} must be a path, got an empty string"
        )));
    }
    Ok(p)
}
