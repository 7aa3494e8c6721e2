//! The Python bindings (module kinem._core): a model's tables in, arrays
//! out. Every call runs without the GIL, and a panic inside the core comes
//! back as kinem.errors.CoreError (a KinemError) with a one-line message,
//! never an abort.
use crate::families::At;
use crate::model::Kin;
use crate::table::Table;
use num_complex::Complex64 as C64;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyType};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Arc;

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

/// Runs `f` without the GIL; a panic or an Err becomes a CoreError.
pub fn guard<T: Send>(py: Python<'_>, f: impl FnOnce() -> Result<T, String> + Send) -> PyResult<T> {
    match py.detach(|| catch_unwind(AssertUnwindSafe(f))) {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(core_error(py, e)),
        Err(p) => Err(core_error(py, panic_text(p))),
    }
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

fn rows<'a>(a: &'a PyReadonlyArray2<'a, f64>, width: usize, what: &str) -> PyResult<(&'a [f64], usize)> {
    let shape = a.shape();
    if shape[1] != width {
        return Err(pyo3::exceptions::PyValueError::new_err(format!("{what}: {} columns, expected {width}", shape[1])));
    }
    Ok((
        a.as_slice().map_err(|_| pyo3::exceptions::PyValueError::new_err(format!("{what}: not C-contiguous")))?,
        shape[0],
    ))
}

fn out2<'py>(py: Python<'py>, v: Vec<f64>, k: usize, w: usize) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_vec(py, v).reshape([k, w])?.into_any())
}

/// A model's evaluation (kinem.model.Model.core): Phi, the Jacobian's
/// values, nu and gamma at a batch of configurations.
#[pyclass(frozen, module = "kinem._core")]
pub struct Core {
    pub kin: Arc<Kin>,
}

#[pymethods]
impl Core {
    /// Core(n, families: [(kind, {column: array})], functions, outlines, angles)
    #[new]
    fn new(
        py: Python<'_>,
        n: usize,
        families: Vec<(String, Bound<'_, PyDict>)>,
        functions: Bound<'_, PyDict>,
        outlines: Bound<'_, PyDict>,
        angles: PyReadonlyArray1<i64>,
    ) -> PyResult<Self> {
        let fams = families.iter().map(|(k, d)| Ok((k.clone(), table(d)?))).collect::<PyResult<Vec<_>>>()?;
        let (f, o) = (table(&functions)?, table(&outlines)?);
        let a = angles.as_array().to_vec();
        let kin = guard(py, move || Kin::new(n, fams, &f, &o, a))?;
        Ok(Core { kin: Arc::new(kin) })
    }

    #[getter]
    fn m(&self) -> usize {
        self.kin.m
    }

    #[getter]
    fn nnz(&self) -> usize {
        self.kin.nnz
    }

    /// Phi at Q (K, n), T (K,): (K, m).
    fn phi<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<'py, f64>,
        t: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let kin = self.kin.clone();
        let (q, k) = rows(&q, kin.n, "q")?;
        let t = t.as_slice()?;
        let m = kin.m;
        let v = guard(py, || {
            check(t.len(), k)?;
            Ok(batch(&kin, q, k, m, |i, q, e, o| kin.phi(&At { q, e, t: t[i] }, o)))
        })?;
        out2(py, v, k, m)
    }

    /// Jacobian values at Q (K, n), T (K,): (K, nnz), in the model's pattern order.
    fn jac<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<'py, f64>,
        t: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let kin = self.kin.clone();
        let (q, k) = rows(&q, kin.n, "q")?;
        let t = t.as_slice()?;
        let w = kin.nnz;
        let v = guard(py, || {
            check(t.len(), k)?;
            Ok(batch(&kin, q, k, w, |i, q, e, o| kin.jac(&At { q, e, t: t[i] }, o)))
        })?;
        out2(py, v, k, w)
    }

    /// nu at T (K,): (K, m).
    fn nu<'py>(&self, py: Python<'py>, t: PyReadonlyArray1<'py, f64>) -> PyResult<Bound<'py, PyAny>> {
        let kin = self.kin.clone();
        let t = t.as_slice()?;
        let (k, m) = (t.len(), kin.m);
        let v = guard(py, || {
            let mut out = vec![0.0; k * m];
            for i in 0..k {
                kin.nu(t[i], &mut out[i * m..(i + 1) * m]);
            }
            Ok(out)
        })?;
        out2(py, v, k, m)
    }

    /// gamma at Q, QD (K, n), T (K,): (K, m).
    fn gamma<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<'py, f64>,
        qd: PyReadonlyArray2<'py, f64>,
        t: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let kin = self.kin.clone();
        let n = kin.n;
        let (q, k) = rows(&q, n, "q")?;
        let (qd, k2) = rows(&qd, n, "qd")?;
        let t = t.as_slice()?;
        let m = kin.m;
        let v = guard(py, || {
            check(t.len(), k)?;
            check(k2, k)?;
            Ok(batch(&kin, q, k, m, |i, q, e, o| kin.gamma(&At { q, e, t: t[i] }, &qd[i * n..(i + 1) * n], o)))
        })?;
        out2(py, v, k, m)
    }
}

fn check(a: usize, b: usize) -> Result<(), String> {
    if a == b {
        Ok(())
    } else {
        Err(format!("batch sizes differ: {a} and {b}"))
    }
}

/// K evaluations of width w at the configurations q (K, n), each with
/// e^{i q} at its angle columns: f(instant, q_i, e, out_i).
fn batch(kin: &Kin, q: &[f64], k: usize, w: usize, f: impl Fn(usize, &[f64], &[C64], &mut [f64])) -> Vec<f64> {
    let n = kin.n;
    let mut out = vec![0.0; k * w];
    let mut e = vec![C64::new(1.0, 0.0); n];
    for i in 0..k {
        let qi = &q[i * n..(i + 1) * n];
        kin.rotate(qi, &mut e);
        f(i, qi, &e, &mut out[i * w..(i + 1) * w]);
    }
    out
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // a panic's message reaches Python in the CoreError; nothing is printed
    std::panic::set_hook(Box::new(|_| {}));
    m.add_class::<Core>()?;
    m.add("KINDS", crate::families::KINDS.to_vec())?;
    Ok(())
}
