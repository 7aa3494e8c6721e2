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
        self.at_configurations(py, q, t, false)
    }

    /// Jacobian values at Q (K, n), T (K,): (K, nnz), in the model's pattern order.
    fn jac<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<'py, f64>,
        t: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.at_configurations(py, q, t, true)
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

impl Core {
    /// Phi (jac false) or the Jacobian's values (jac true) at Q (K, n), T (K,).
    fn at_configurations<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<'py, f64>,
        t: PyReadonlyArray1<'py, f64>,
        jac: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let kin = self.kin.clone();
        let (q, k) = rows(&q, kin.n, "q")?;
        let t = t.as_slice()?;
        let w = if jac { kin.nnz } else { kin.m };
        let v = guard(py, || {
            check(t.len(), k)?;
            Ok(batch(&kin, q, k, w, |i, q, e, o| {
                let at = At { q, e, t: t[i] };
                if jac {
                    kin.jac(&at, o)
                } else {
                    kin.phi(&at, o)
                }
            }))
        })?;
        out2(py, v, k, w)
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
    register(m)?;
    m.add("KINDS", crate::families::KINDS.to_vec())?;
    Ok(())
}

// ---- the march's linear structure, the march, and the step-by-step kernels ----

use crate::accept;
use crate::lu::{Factors, Layout, Shape};
use crate::march;
use crate::newton::{self, Ops};
use numpy::PyReadwriteArray1;
use numpy::PyReadwriteArray2;
use numpy::PyReadwriteArray3;

fn positions(t: &Table, key: &str, bound: usize) -> PyResult<Vec<usize>> {
    t.index(key, bound).map_err(pyo3::exceptions::PyValueError::new_err)
}

fn reals(t: &Table, key: &str) -> PyResult<Vec<f64>> {
    t.real(key).map_err(pyo3::exceptions::PyValueError::new_err)
}

/// A model's linear structure (kinem.model.Blocks or Band) with its
/// evaluation: what the march and the step-by-step LU run on.
#[pyclass(frozen, module = "kinem._core")]
pub struct Plan {
    kin: Arc<Kin>,
    layout: Arc<Layout>,
    /// a model of several diagonal blocks as one model per block, built at
    /// its first march (crate::parts)
    parts: std::sync::OnceLock<Result<Vec<crate::parts::Part>, String>>,
}

#[pymethods]
impl Plan {
    /// Plan(core, band, count, size, height, width, kl, ku, sign, columns): band
    /// False: `count` diagonal blocks of `size` (columns pad, rows_mask,
    /// cols_mask (count size, the patterns as int64 bits)); True: the band
    /// (kl, ku, size: the reduced system; columns couple_row, couple_col).
    /// Columns for both: block, row, col (per Jacobian entry), entry_scale,
    /// row_pos, col_pos, real, scale, col_scale.
    #[new]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        core: &Core,
        band: bool,
        count: usize,
        size: usize,
        height: usize,
        width: usize,
        kl: usize,
        ku: usize,
        sign: i32,
        columns: Bound<'_, PyDict>,
    ) -> PyResult<Self> {
        let kin = core.kin.clone();
        let t = table(&columns)?;
        let (n, m, nnz) = (kin.n, kin.m, kin.nnz);
        t.same_length(nnz, &["block", "row", "col", "entry_scale"]).map_err(pyo3::exceptions::PyValueError::new_err)?;
        let block = positions(&t, "block", count.max(1))?;
        let row = positions(&t, "row", height.max(1))?;
        let col = positions(&t, "col", width.max(1))?;
        let stored = if band { n.max(size) } else { count * size };
        let shape = if band {
            if 2 * kl + ku + 3 != height || size > n || width < size.max(n - size) {
                return Err(pyo3::exceptions::PyValueError::new_err("plan: band dimensions do not fit"));
            }
            let couple_row = positions(&t, "couple_row", size.max(1))?;
            let couple_col = positions(&t, "couple_col", (n - size).max(1))?;
            if couple_row.len() != couple_col.len() || couple_row.len() > width {
                return Err(pyo3::exceptions::PyValueError::new_err("plan: coupling columns do not fit"));
            }
            Shape::Band { kl, ku, size, singles: n - size, couple_row, couple_col }
        } else {
            if height != size || width != size || count * size < n.max(m) || size > 4096 {
                return Err(pyo3::exceptions::PyValueError::new_err("plan: block dimensions do not fit"));
            }
            let pad = positions(&t, "pad", count * size)?;
            let rm = t.int("rows_mask").map_err(pyo3::exceptions::PyValueError::new_err)?;
            let cm = t.int("cols_mask").map_err(pyo3::exceptions::PyValueError::new_err)?;
            let patterns = if size <= crate::lu::MASK {
                if rm.len() != count * size || cm.len() != count * size {
                    return Err(pyo3::exceptions::PyValueError::new_err("plan: masks do not fit"));
                }
                rm.iter().zip(&cm).map(|(&a, &b)| (a as u64, b as u64)).collect()
            } else {
                Vec::new()
            };
            Shape::Blocks { count, size, pad, patterns, orders: Vec::new() }
        };
        let real = t.flags("real").map_err(pyo3::exceptions::PyValueError::new_err)?;
        if real.len() != stored.max(n) && real.len() != stored {
            return Err(pyo3::exceptions::PyValueError::new_err("plan: real has the wrong length"));
        }
        let mut layout = Layout {
            shape,
            n,
            m,
            height,
            width,
            count: if band { 1 } else { count },
            at: (0..nnz).map(|e| (block[e], row[e], col[e])).collect(),
            entry_scale: reals(&t, "entry_scale")?,
            row_pos: positions(&t, "row_pos", stored.max(1))?,
            col_pos: positions(&t, "col_pos", stored.max(1))?,
            real,
            sign,
            scale: reals(&t, "scale")?,
            col_scale: reals(&t, "col_scale")?,
            by_block: Vec::new(),
            block_start: Vec::new(),
        };
        if layout.row_pos.len() != m
            || layout.col_pos.len() != n
            || layout.scale.len() != m
            || layout.col_scale.len() != n
        {
            return Err(pyo3::exceptions::PyValueError::new_err("plan: positions or scales have the wrong length"));
        }
        layout.group();
        let kin2 = kin.clone();
        let layout = guard(py, move || {
            crate::plan::order_blocks(&kin2, &mut layout);
            Ok(layout)
        })?;
        Ok(Plan { kin, layout: Arc::new(layout), parts: std::sync::OnceLock::new() })
    }

    /// Design sensitivities (crate::sensitivity): tangents, one per
    /// parameter: (families [(kind, table, tangent)], (functions, tangent),
    /// (outlines, tangent)), the model's tables with their tangents along
    /// the parameter; x: 1 to 3 arrays (K, n) (q, qd, qdd at times); rows,
    /// cols: the Jacobian's pattern. Returns (out (levels, P, K, n), pivot
    /// ratio (K)).
    #[allow(clippy::type_complexity)]
    fn sensitivity<'py>(
        &self,
        py: Python<'py>,
        tangents: Vec<(
            Vec<(String, Bound<'py, PyDict>, Bound<'py, PyDict>)>,
            (Bound<'py, PyDict>, Bound<'py, PyDict>),
            (Bound<'py, PyDict>, Bound<'py, PyDict>),
        )>,
        times: PyReadonlyArray1<'py, f64>,
        x: Vec<PyReadonlyArray2<'py, f64>>,
        jac_rows: PyReadonlyArray1<'py, i64>,
        jac_cols: PyReadonlyArray1<'py, i64>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyArray1<f64>>)> {
        let with = |d: &Bound<'py, PyDict>, dd: &Bound<'py, PyDict>| -> PyResult<Table> {
            let mut t = table(d)?;
            let tan = table(dd)?;
            t.d_reals = tan.reals;
            t.d_complex = tan.complex;
            Ok(t)
        };
        let mut parts = Vec::new();
        for (fams, (fd, fdd), (od, odd)) in &tangents {
            let fams = fams.iter().map(|(k, d, dd)| Ok((k.clone(), with(d, dd)?))).collect::<PyResult<Vec<_>>>()?;
            parts.push((fams, with(fd, fdd)?, with(od, odd)?));
        }
        let times = times.as_slice()?.to_vec();
        let (n, kk, levels, np) = (self.kin.n, times.len(), x.len(), parts.len());
        let mut xs = Vec::new();
        for (k, a) in x.iter().enumerate() {
            let (v, r) = rows(a, n, &format!("sensitivity: x[{k}]"))?;
            if r != kk {
                return Err(pyo3::exceptions::PyValueError::new_err("sensitivity: one row per instant expected"));
            }
            xs.push(v.to_vec());
        }
        let to_usize = |a: PyReadonlyArray1<'py, i64>| -> Vec<usize> {
            a.as_array().iter().map(|&v| if v < 0 { usize::MAX } else { v as usize }).collect()
        };
        let (r, c) = (to_usize(jac_rows), to_usize(jac_cols));
        let (kin, layout) = (self.kin.clone(), self.layout.clone());
        let (out, ratio) = guard(py, move || {
            let angles: Vec<i64> = kin.angles.iter().map(|&a| a as i64).collect();
            let mut tans = Vec::new();
            for (fams, f, o) in parts {
                tans.push(Kin::<crate::real::Dual>::new(kin.n, fams, &f, &o, angles.clone())?);
            }
            let mut out = vec![0.0; levels * np * kk * n];
            let mut ratio = vec![0.0; kk];
            let x: Vec<&[f64]> = xs.iter().map(|v| v.as_slice()).collect();
            crate::sensitivity::sensitivities(&kin, &layout, &tans, &r, &c, &times, &x, &mut out, &mut ratio)?;
            Ok((out, ratio))
        })?;
        let out = PyArray1::from_vec(py, out).reshape([levels, np, kk, n])?.into_any();
        Ok((out, PyArray1::from_vec(py, ratio)))
    }

    /// The LU of J_s at these Jacobian values (nnz).
    fn factor(&self, py: Python<'_>, values: PyReadonlyArray1<'_, f64>) -> PyResult<Lu> {
        let v = values.as_slice()?;
        if v.len() != self.kin.nnz {
            return Err(pyo3::exceptions::PyValueError::new_err("factor: wrong number of values"));
        }
        let layout = self.layout.clone();
        let (f, stats) = guard(py, move || {
            let mut f = layout.factors();
            layout.factor(v, &mut f);
            let s = layout.pivots(&f);
            Ok((f, s))
        })?;
        Ok(Lu {
            layout: self.layout.clone(),
            f: std::sync::Mutex::new(f),
            pivot_ratio: stats.0,
            det_sign: stats.1,
            // the coordinate stored where the smallest pivot is (None: padding)
            smallest: self.layout.col_pos.iter().position(|&p| p == stats.2),
        })
    }

    /// March from `state` over times[k:], until an instant is not accepted.
    /// state (6 n + 5): q, qd, qdd (n each), last (2: time and det sign),
    /// H (3 n: the last three q, oldest first), T (3: their times), left at
    /// the last instant taken; settings: (tolerance, max_iterations,
    /// max_step, floor, rates); out (3, K, n): Q, QD, QDD ((1, K, n): Q
    /// without rates); figures (2, K):
    /// residual and pivot ratio; ints (K + 2): Newton iterations per instant,
    /// then the Jacobian evaluations and factorisations, added to. Returns
    /// (the first instant not taken, or K; why: 0 or the acceptance code).
    #[allow(clippy::too_many_arguments)]
    fn march(
        &self,
        py: Python<'_>,
        times: PyReadonlyArray1<'_, f64>,
        k: usize,
        mut state: PyReadwriteArray1<'_, f64>,
        settings: (f64, usize, f64, f64, bool),
        mut out: PyReadwriteArray3<'_, f64>,
        mut figures: PyReadwriteArray2<'_, f64>,
        mut ints: PyReadwriteArray1<'_, i64>,
    ) -> PyResult<(usize, u8)> {
        let (n, kk) = (self.kin.n, times.len());
        let bad = |what: &str| pyo3::exceptions::PyValueError::new_err(format!("march: {what} has the wrong shape"));
        let times = times.as_slice()?;
        let stages = if settings.4 { 3 } else { 1 };
        if state.len() != 6 * n + 5
            || out.shape() != [stages, kk, n]
            || figures.shape() != [2, kk]
            || ints.len() != kk + 2
            || k > kk
        {
            return Err(bad("state, out, figures, ints or k"));
        }
        let (tolerance, max_iterations, max_step, floor, rates) = settings;
        let settings = march::Settings { tolerance, max_iterations, max_step, floor, rates };
        let (kin, layout) = (self.kin.clone(), self.layout.clone());
        let (q, rest) = state.as_slice_mut().map_err(|_| bad("state"))?.split_at_mut(n);
        let (qd, rest) = rest.split_at_mut(n);
        let (qdd, rest) = rest.split_at_mut(n);
        let (last, rest) = rest.split_at_mut(2);
        let (h, tt) = rest.split_at_mut(3 * n);
        let st = march::State { q, qd, qdd, last, h, tt };
        let (oq, rest) = out.as_slice_mut().map_err(|_| bad("out"))?.split_at_mut(kk * n);
        let (oqd, oqdd) = rest.split_at_mut(rest.len() / 2);
        let (residual, pivot) = figures.as_slice_mut().map_err(|_| bad("figures"))?.split_at_mut(kk);
        let (iterations, counts) = ints.as_slice_mut().map_err(|_| bad("ints"))?.split_at_mut(kk);
        let mut det = vec![0i8; kk];
        let out =
            march::Out { q: oq, qd: oqd, qdd: oqdd, iterations, residual, pivot, det: &mut det, counts, first: 0 };
        let parts = &self.parts;
        guard(py, move || {
            if layout.count < 2 || !matches!(layout.shape, Shape::Blocks { .. }) {
                return Ok(march::run(&kin, &layout, times, k, st, &settings, out));
            }
            let parts = parts.get_or_init(|| crate::parts::split(&kin, &layout)).as_ref()?;
            Ok(crate::parts::run_parts(parts, layout.sign, times, k, st, &settings, out))
        })
    }
}

/// LU factors of J_s (Plan.factor): solve, pivot ratio and det sign.
#[pyclass(frozen, module = "kinem._core")]
pub struct Lu {
    layout: Arc<Layout>,
    f: std::sync::Mutex<Factors>,
    #[pyo3(get)]
    pivot_ratio: f64,
    #[pyo3(get)]
    det_sign: i32,
    /// the coordinate whose column holds the smallest |pivot| (None: a padding position)
    #[pyo3(get)]
    smallest: Option<usize>,
}

#[pymethods]
impl Lu {
    /// x with Phi_q x = b (b: m rows).
    fn solve<'py>(&self, py: Python<'py>, b: PyReadonlyArray1<'py, f64>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let b = b.as_slice()?;
        if b.len() != self.layout.m {
            return Err(pyo3::exceptions::PyValueError::new_err("solve: wrong number of rows"));
        }
        let layout = self.layout.clone();
        let f = &self.f;
        let x = guard(py, move || {
            let mut x = vec![0.0; layout.n];
            let mut g = f.lock().map_err(|_| "LU factors poisoned by an earlier fault".to_string())?;
            layout.solve(&mut g, b, &mut x);
            Ok(x)
        })?;
        Ok(PyArray1::from_vec(py, x))
    }
}

/// settle's operations as a Python object's methods (the step-by-step
/// analysis, kinem.analysis): evaluate(it) -> residual, factor(last),
/// correct(limit) -> step size.
struct PyOps<'a, 'py> {
    ops: &'a Bound<'py, PyAny>,
}

impl Ops for PyOps<'_, '_> {
    type Error = PyErr;
    fn evaluate(&mut self, it: i64) -> PyResult<f64> {
        self.ops.call_method1("evaluate", (it,))?.extract()
    }
    fn factor(&mut self, last: bool) -> PyResult<()> {
        self.ops.call_method1("factor", (last,)).map(|_| ())
    }
    fn correct(&mut self, limit: f64) -> PyResult<f64> {
        self.ops.call_method1("correct", (limit,))?.extract()
    }
}

/// The one Newton-Raphson (newton::settle) on a Python object's operations:
/// returns (iterations, residual, converged, last step).
#[pyfunction]
fn settle(
    ops: &Bound<'_, PyAny>,
    tolerance: f64,
    max_iterations: usize,
    max_step: f64,
    finish: bool,
) -> PyResult<(usize, f64, bool, f64)> {
    let mut o = PyOps { ops };
    let s = newton::settle(&mut o, tolerance, max_iterations, max_step, finish)?;
    Ok((s.iterations, s.residual, s.converged, s.last_step))
}

/// The acceptance test (accept::rejected).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn rejected(
    pivot: f64,
    correction: f64,
    det: i32,
    previous_det: i32,
    corr: f64,
    motion: f64,
    judge_jump: bool,
    floor: f64,
    tolerance: f64,
    allow_flip: bool,
) -> u8 {
    accept::rejected(pivot, correction, det, previous_det, corr, motion, judge_jump, floor, tolerance, allow_flip)
}

/// (correction from the predictor, predicted motion), dimensionless.
#[pyfunction]
fn jump_sizes(
    q: PyReadonlyArray1<'_, f64>,
    q_pred: PyReadonlyArray1<'_, f64>,
    q_last: PyReadonlyArray1<'_, f64>,
    col_scale: PyReadonlyArray1<'_, f64>,
) -> PyResult<(f64, f64)> {
    let (a, b, c, d) = (q.as_slice()?, q_pred.as_slice()?, q_last.as_slice()?, col_scale.as_slice()?);
    if b.len() != a.len() || c.len() != a.len() || d.len() != a.len() {
        return Err(pyo3::exceptions::PyValueError::new_err("jump_sizes: lengths differ"));
    }
    Ok(accept::jump_sizes(a, b, c, d))
}

/// q at t extrapolated through the states H (3, n) at T (3) (accept::lagrange):
/// (q, order).
#[pyfunction]
fn lagrange<'py>(
    py: Python<'py>,
    t: f64,
    tt: PyReadonlyArray1<'py, f64>,
    h: PyReadonlyArray2<'py, f64>,
) -> PyResult<(Bound<'py, PyArray1<f64>>, i32)> {
    let tt = tt.as_slice()?;
    let shape = h.shape();
    if tt.len() != 3 || shape[0] != 3 {
        return Err(pyo3::exceptions::PyValueError::new_err("lagrange: T (3,) and H (3, n)"));
    }
    let mut q = vec![0.0; shape[1]];
    let order = accept::lagrange(t, &[tt[0], tt[1], tt[2]], h.as_slice()?, &mut q);
    Ok((PyArray1::from_vec(py, q), order))
}

/// The functions of a table {kind, start, data} (kinem.functions.FunctionTable)
/// at the instants t (K,): their order-th derivative, (K, functions). The
/// driving functions' one implementation, for every caller outside the analysis too.
#[pyfunction]
fn functions<'py>(
    py: Python<'py>,
    table: Bound<'py, PyDict>,
    t: PyReadonlyArray1<'py, f64>,
    order: u8,
) -> PyResult<Bound<'py, PyAny>> {
    let tb = self::table(&table)?;
    let t = t.as_slice()?;
    if order > 2 {
        return Err(pyo3::exceptions::PyValueError::new_err("functions: order 0, 1 or 2"));
    }
    let (v, w) = guard(py, || {
        let f = crate::functions::Functions::from_table(&tb)?;
        let w = f.len();
        let mut out = vec![0.0; t.len() * w];
        for (k, &tk) in t.iter().enumerate() {
            for j in 0..w {
                out[k * w + j] = f.eval(j, tk, order);
            }
        }
        Ok((out, w))
    })?;
    out2(py, v, t.len(), w)
}

/// s and its first three derivatives (4, N) of outline which[j] at theta[j]
/// (a table of kinem.outline.OutlineTable): the outlines' one implementation.
#[pyfunction]
fn outline_radius<'py>(
    py: Python<'py>,
    table: Bound<'py, PyDict>,
    which: PyReadonlyArray1<'py, i64>,
    theta: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let tb = self::table(&table)?;
    let (which, theta) = (which.as_slice()?, theta.as_slice()?);
    let n = theta.len();
    let v = guard(py, || {
        let o = crate::outline::Outlines::from_table(&tb)?;
        if which.len() != n || which.iter().any(|&w| w < 0 || w as usize >= o.len()) {
            return Err("outline_radius: which out of range or of another length than theta".to_string());
        }
        let mut out = vec![0.0; 4 * n];
        for j in 0..n {
            let r = o.radius(which[j] as usize, theta[j]);
            for d in 0..4 {
                out[d * n + j] = r[d];
            }
        }
        Ok(out)
    })?;
    out2(py, v, 4, n)
}

/// Panics inside the core with `message` (tests/test_core.py: a panic
/// reaches Python as kinem.errors.CoreError, never an abort).
#[pyfunction]
fn _panic(py: Python<'_>, message: String) -> PyResult<()> {
    guard(py, move || -> Result<(), String> { panic!("{message}") })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(_panic, m)?)?;
    m.add_function(wrap_pyfunction!(functions, m)?)?;
    m.add_function(wrap_pyfunction!(outline_radius, m)?)?;
    m.add_class::<Plan>()?;
    m.add_class::<Lu>()?;
    m.add_function(wrap_pyfunction!(settle, m)?)?;
    m.add_function(wrap_pyfunction!(columns, m)?)?;
    m.add_function(wrap_pyfunction!(rejected, m)?)?;
    m.add_function(wrap_pyfunction!(jump_sizes, m)?)?;
    m.add_function(wrap_pyfunction!(lagrange, m)?)?;
    m.add("MAX_STEP", newton::MAX_STEP)?;
    m.add("POLISH", newton::POLISH)?;
    m.add("KAPPA", accept::KAPPA)?;
    m.add("REGULAR", accept::REGULAR)?;
    m.add("NEAR_SINGULAR", accept::NEAR_SINGULAR)?;
    m.add("DET_FLIP", accept::DET_FLIP)?;
    m.add("JUMP", accept::JUMP)?;
    m.add("NOT_CONVERGED", accept::NOT_CONVERGED)?;
    Ok(())
}

/// A trajectory's columns (columns::columns): X a list of 1 to 3 arrays (K,
/// n) (positions, velocities, accelerations), src (C,), pc (P,), local (P,).
/// With tangents (dx: as X, dlocal: as local): the columns' tangents along
/// them (over dual numbers), not the columns.
#[pyfunction]
#[pyo3(signature = (x, src, pc, local, tangents=None))]
fn columns<'py>(
    py: Python<'py>,
    x: Vec<PyReadonlyArray2<'py, f64>>,
    src: PyReadonlyArray1<'py, i64>,
    pc: PyReadonlyArray1<'py, i64>,
    local: PyReadonlyArray1<'py, C64>,
    tangents: Option<(Vec<PyReadonlyArray2<'py, f64>>, PyReadonlyArray1<'py, C64>)>,
) -> PyResult<Bound<'py, PyAny>> {
    let bad = |w: &str| pyo3::exceptions::PyValueError::new_err(format!("columns: {w}"));
    if x.is_empty() || x.len() > 3 {
        return Err(bad("one to three stages"));
    }
    let shape = x[0].shape().to_vec();
    let (k, n) = (shape[0], shape[1]);
    let stages: Vec<&[f64]> = x.iter().map(|a| a.as_slice()).collect::<Result<_, _>>()?;
    if x.iter().any(|a| a.shape() != [k, n]) {
        return Err(bad("stages differ in shape"));
    }
    let (pc, local) = (pc.as_slice()?, local.as_slice()?);
    if pc.len() != local.len() || pc.iter().any(|&c| c < 0 || c as usize + 2 >= n.max(1)) {
        return Err(bad("point columns out of range"));
    }
    let limit = (stages.len() * (n + 2 * pc.len())) as i64;
    let src = src.as_slice()?;
    if src.iter().any(|&j| j < 0 || j >= limit) {
        return Err(bad("a source out of range"));
    }
    let src: Vec<usize> = src.iter().map(|&j| j as usize).collect();
    let pc: Vec<usize> = pc.iter().map(|&c| c as usize).collect();
    let w = src.len();
    if let Some((dx, dlocal)) = &tangents {
        let dstages: Vec<&[f64]> = dx.iter().map(|a| a.as_slice()).collect::<Result<_, _>>()?;
        let dlocal = dlocal.as_slice()?;
        if dx.len() != x.len() || dx.iter().any(|a| a.shape() != [k, n]) || dlocal.len() != local.len() {
            return Err(bad("tangents differ in shape from the coordinates"));
        }
        let v = guard(py, || {
            use crate::real::{lift_c, Dual};
            let xs: Vec<Vec<Dual>> = stages
                .iter()
                .zip(&dstages)
                .map(|(a, b)| a.iter().zip(b.iter()).map(|(&v, &d)| Dual { v, d }).collect())
                .collect();
            let xs: Vec<&[Dual]> = xs.iter().map(|v| v.as_slice()).collect();
            let loc: Vec<_> = local.iter().zip(dlocal).map(|(&v, &d)| lift_c::<Dual>(v, d)).collect();
            let mut out = vec![Dual::default(); k * w];
            crate::columns::columns(&xs, n, &src, &pc, &loc, &mut out);
            Ok(out.iter().map(|d| d.d).collect::<Vec<f64>>())
        })?;
        return out2(py, v, k, w);
    }
    let v = guard(py, || {
        let mut out = vec![0.0; k * w];
        crate::columns::columns(&stages, n, &src, &pc, local, &mut out);
        Ok(out)
    })?;
    out2(py, v, k, w)
}
