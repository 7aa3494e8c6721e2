//! The Python bindings (module kinem._core): a model's tables in, arrays
//! out. Every call runs without the GIL (the march re-acquires it briefly to
//! poll for signals), and a panic inside the core comes back as
//! kinem.errors.CoreError (a KinemError: exit code 3) with a one-line
//! message, never an abort nor PyO3's PanicException. Sizes computed from
//! inputs are checked (an error, never an overflow); 2-d inputs are read in
//! C order whatever their layout (copied when Fortran-ordered or strided);
//! outputs must be C-contiguous and writable.
use crate::accept::{self, Why};
use crate::families::At;
use crate::lu::{Factors, Layout, Shape};
use crate::march;
use crate::model::{Kin, Turning};
use crate::newton::{self, Ops};
use crate::table::Table;
use crate::watch::Watch;
use num_complex::Complex64 as C64;
use numpy::{
    PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyReadwriteArray,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyType};
use std::borrow::Cow;
use std::cell::Cell;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Arc;

fn value_error(msg: impl Into<String>) -> PyErr {
    pyo3::exceptions::PyValueError::new_err(msg.into())
}

/// kinem.errors.CoreError with `msg`.
pub fn core_error(py: Python<'_>, msg: String) -> PyErr {
    match py.import("kinem.errors").and_then(|m| m.getattr("CoreError")) {
        Ok(cls) => match cls.cast_into::<PyType>() {
            Ok(t) => PyErr::from_type(t, msg),
            Err(_) => pyo3::exceptions::PyRuntimeError::new_err(msg),
        },
        Err(_) => pyo3::exceptions::PyRuntimeError::new_err(msg),
    }
}

fn panic_text(p: Box<dyn std::any::Any + Send>) -> String {
    let what = p
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into());
    format!("internal error in kinem's compiled core: {}", what.replace('\n', " "))
}

thread_local! {
    /// This thread runs a guarded call: its panic's message goes into the CoreError, not to standard error.
    static GUARDED: Cell<u32> = const { Cell::new(0) };
}

/// f() with panics caught (not printed: the message reaches the CoreError).
fn shielded<T>(f: impl FnOnce() -> T) -> std::thread::Result<T> {
    GUARDED.with(|g| g.set(g.get() + 1));
    let r = catch_unwind(AssertUnwindSafe(f));
    GUARDED.with(|g| g.set(g.get() - 1));
    r
}

/// The panic hook, once: quiet for a panic of a guarded call or on the
/// core's thread pool (its message reaches Python in the CoreError), the
/// hook that was there before for any other (this process's other Rust
/// code keeps its messages).
fn quiet_guarded_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let before = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if GUARDED.with(|g| g.get()) == 0 && rayon::current_thread_index().is_none() {
                before(info);
            }
        }));
    });
}

/// Runs `f` without the GIL; a panic or an Err becomes a CoreError.
pub fn guard<T: Send>(py: Python<'_>, f: impl FnOnce() -> Result<T, String> + Send) -> PyResult<T> {
    match py.detach(|| shielded(f)) {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(core_error(py, e)),
        Err(p) => Err(core_error(py, panic_text(p))),
    }
}

/// Runs `f` with the GIL held (it calls Python, or is too short to let go
/// of it); a panic becomes a CoreError.
fn guard_held<T>(py: Python<'_>, f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    shielded(f).unwrap_or_else(|p| Err(core_error(py, panic_text(p))))
}

/// A 1-d array's values in order (copied when strided).
fn vec1<'a>(a: &'a PyReadonlyArray1<'_, f64>) -> Cow<'a, [f64]> {
    match a.as_slice() {
        Ok(s) => Cow::Borrowed(s),
        Err(_) => Cow::Owned(a.as_array().iter().copied().collect()),
    }
}

/// A 2-d array's values in C order (copied when Fortran-ordered or strided).
fn vec2<'a>(a: &'a PyReadonlyArray2<'_, f64>) -> Cow<'a, [f64]> {
    match a.as_slice() {
        Ok(s) if a.is_c_contiguous() => Cow::Borrowed(s),
        _ => Cow::Owned(a.as_array().iter().copied().collect()),
    }
}

/// An output array, written in place: C-contiguous and writable, else a ValueError.
fn writable<'py, T: numpy::Element, D: numpy::ndarray::Dimension>(
    a: &Bound<'py, numpy::PyArray<T, D>>,
    what: &str,
) -> PyResult<PyReadwriteArray<'py, T, D>> {
    if !a.is_c_contiguous() {
        return Err(value_error(format!("{what}: expected a C-contiguous array")));
    }
    a.try_readwrite().map_err(|e| value_error(format!("{what}: not writable ({e})")))
}

/// A dict of numpy arrays (int64, float64, complex128) as a Table.
pub fn table(d: &Bound<'_, PyDict>) -> PyResult<Table> {
    let mut t = Table::default();
    for (k, v) in d.iter() {
        let key: String = k.extract()?;
        if let Ok(a) = v.extract::<PyReadonlyArray1<i64>>() {
            t.ints.insert(key, a.as_array().to_vec());
        } else if let Ok(a) = v.extract::<PyReadonlyArray1<f64>>() {
            t.reals.insert(key, a.as_array().to_vec());
        } else if let Ok(a) = v.extract::<PyReadonlyArray1<C64>>() {
            t.complex.insert(key, a.as_array().to_vec());
        } else {
            return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                "table column '{key}': expected a 1-d int64, float64 or complex128 array"
            )));
        }
    }
    Ok(t)
}

/// A (K, width) array's values in C order, and K.
fn rows<'a>(a: &'a PyReadonlyArray2<'_, f64>, width: usize, what: &str) -> PyResult<(Cow<'a, [f64]>, usize)> {
    let shape = a.shape();
    if shape[1] != width {
        return Err(value_error(format!("{what}: {} columns, expected {width}", shape[1])));
    }
    Ok((vec2(a), shape[0]))
}

fn out2<'py>(py: Python<'py>, v: Vec<f64>, k: usize, w: usize) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_vec(py, v).reshape([k, w])?.into_any())
}

mod evaluate;
mod functions;
mod plan;
mod step;

use evaluate::Core;
use plan::Plan;
use step::{Angles, Lu, MarchState, Outcome};

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    quiet_guarded_panics();
    let (threads, cores) = pool();
    m.add("THREADS", threads)?;
    m.add("CORES", cores)?;
    m.add_class::<Core>()?;
    register(m)?;
    m.add("KINDS", crate::families::KINDS.to_vec())?;
    Ok(())
}

/// The core's thread pool, sized once: RAYON_NUM_THREADS when set, at most
/// the machine's cores (more threads than cores only wait on each other);
/// (threads, cores).
fn pool() -> (usize, usize) {
    let cores = std::thread::available_parallelism().map(|c| c.get()).unwrap_or(1);
    let asked = std::env::var("RAYON_NUM_THREADS").ok().and_then(|v| v.trim().parse::<usize>().ok()).filter(|&v| v > 0);
    let threads = asked.unwrap_or(cores).min(cores);
    // already built (a second import in one process): rayon keeps the first
    let _ = rayon::ThreadPoolBuilder::new().num_threads(threads).build_global();
    (rayon::current_num_threads(), cores)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(functions::_panic, m)?)?;
    m.add_function(wrap_pyfunction!(functions::functions, m)?)?;
    m.add_function(wrap_pyfunction!(functions::outline_radius, m)?)?;
    m.add_function(wrap_pyfunction!(functions::increasing, m)?)?;
    m.add_class::<Plan>()?;
    m.add_class::<plan::SensSetup>()?;
    m.add_class::<Lu>()?;
    m.add_class::<Angles>()?;
    m.add_function(wrap_pyfunction!(step::settle, m)?)?;
    m.add_function(wrap_pyfunction!(functions::columns, m)?)?;
    m.add_function(wrap_pyfunction!(step::step, m)?)?;
    m.add_class::<MarchState>()?;
    m.add_class::<Outcome>()?;
    m.add("MAX_STEP", newton::MAX_STEP)?;
    m.add("POLISH", newton::POLISH)?;
    m.add("KAPPA", accept::KAPPA)?;
    m.add("REGULAR", accept::REGULAR)?;
    // the codes of accept::Why, (name, code) in order: kinem.native.Why mirrors them
    m.add("WHY", Why::ALL.iter().map(|&w| (w.name(), w as u8)).collect::<Vec<_>>())?;
    // the codes of step::Mode: kinem.native.Mode mirrors them
    m.add("MODES", march::Mode::ALL.iter().map(|&w| (w.name(), w as u8)).collect::<Vec<_>>())?;
    m.add("SINGULAR", march::SINGULAR)?;
    Ok(())
}
