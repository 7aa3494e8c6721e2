//! The Python bindings (module kinem._core): a model's tables in, arrays
//! out. Every call runs without the GIL (the march re-acquires it briefly to
//! poll for signals), and a panic inside the core comes back as
//! kinem.errors.CoreError (a KinemError: exit code 3) with a one-line
//! message, never an abort nor PyO3's PanicException. Sizes computed from
//! inputs are checked (an error, never an overflow); 2-d inputs are read in
//! C order whatever their layout (copied when Fortran-ordered or strided);
//! outputs must be C-contiguous and writable.
use crate::families::At;
use crate::model::Kin;
use crate::table::Table;
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
        let kin = &self.kin;
        let t = vec1(&t);
        let (k, m) = (t.len(), kin.m);
        let size = k.checked_mul(m).ok_or_else(|| value_error("nu: too many instants"))?;
        let v = guard(py, || {
            let mut out = vec![0.0; size];
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
        let kin = &self.kin;
        let n = kin.n;
        let (q, k) = rows(&q, n, "q")?;
        let (qd, k2) = rows(&qd, n, "qd")?;
        let t = vec1(&t);
        let m = kin.m;
        k.checked_mul(m.max(n)).ok_or_else(|| value_error("gamma: too many configurations"))?;
        let (q, qd, t): (&[f64], &[f64], &[f64]) = (&q, &qd, &t);
        let v = guard(py, || {
            check(t.len(), k)?;
            check(k2, k)?;
            Ok(batch(kin, q, k, m, |i, q, e, o| kin.gamma(&At { q, e, t: t[i] }, &qd[i * n..(i + 1) * n], o)))
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
        let kin = &self.kin;
        let (q, k) = rows(&q, kin.n, "q")?;
        let t = vec1(&t);
        let w = if jac { kin.nnz } else { kin.m };
        k.checked_mul(w.max(kin.n)).ok_or_else(|| value_error("too many configurations"))?;
        let (q, t): (&[f64], &[f64]) = (&q, &t);
        let v = guard(py, || {
            check(t.len(), k)?;
            Ok(batch(kin, q, k, w, |i, q, e, o| {
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

// ---- the march's linear structure, the march, and the step-by-step kernels ----

use crate::accept::{self, Why};
use crate::lu::{Factors, Layout, Shape};
use crate::march;
use crate::newton::{self, Ops};
use crate::watch::Watch;

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
        // every size below from these, checked: a layout larger than the model is refused, never allocated
        let big = n.max(m).max(nnz).max(1);
        let count = if band { 1 } else { count };
        if count > big || size > big || height > 3 * big + 3 || width > big || kl > big || ku > big {
            return Err(value_error("plan: dimensions larger than the model"));
        }
        let stored_blocks = count.checked_mul(size).ok_or_else(|| value_error("plan: count x size overflows"))?;
        let factors = count.checked_mul(height).and_then(|v| v.checked_mul(width));
        if factors.is_none_or(|v| v > 4 * big * big + 16) {
            return Err(value_error("plan: count x height x width larger than the model"));
        }
        t.same_length(nnz, &["block", "row", "col", "entry_scale"]).map_err(pyo3::exceptions::PyValueError::new_err)?;
        let block = positions(&t, "block", count.max(1))?;
        let row = positions(&t, "row", height.max(1))?;
        let col = positions(&t, "col", width.max(1))?;
        let stored = if band { n.max(size) } else { stored_blocks };
        let shape = if band {
            if kl.checked_mul(2).and_then(|v| v.checked_add(ku)).and_then(|v| v.checked_add(3)) != Some(height)
                || size > n
                || width < size.max(n - size)
            {
                return Err(pyo3::exceptions::PyValueError::new_err("plan: band dimensions do not fit"));
            }
            let couple_row = positions(&t, "couple_row", size.max(1))?;
            let couple_col = positions(&t, "couple_col", (n - size).max(1))?;
            if couple_row.len() != couple_col.len() || couple_row.len() > width {
                return Err(pyo3::exceptions::PyValueError::new_err("plan: coupling columns do not fit"));
            }
            Shape::Band { kl, ku, size, singles: n - size, couple_row, couple_col }
        } else {
            if height != size || width != size || stored_blocks < n.max(m) || size > 4096 {
                return Err(pyo3::exceptions::PyValueError::new_err("plan: block dimensions do not fit"));
            }
            let pad = positions(&t, "pad", stored_blocks)?;
            let rm = t.int("rows_mask").map_err(pyo3::exceptions::PyValueError::new_err)?;
            let cm = t.int("cols_mask").map_err(pyo3::exceptions::PyValueError::new_err)?;
            let patterns = if size <= crate::lu::MASK {
                if rm.len() != stored_blocks || cm.len() != stored_blocks {
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
        let kin2 = kin.clone();
        let layout = guard(py, move || {
            layout.group();
            crate::plan::order_blocks(&kin2, &mut layout);
            Ok(layout)
        })?;
        Ok(Plan { kin, layout: Arc::new(layout), parts: std::sync::OnceLock::new() })
    }

    /// Design sensitivities (crate::sensitivity): tables, the model's
    /// (families [(kind, table)], functions, outlines) with every function
    /// and outline its own number (kinem.sensitivity._tables); tangents, one per
    /// parameter: (families [(place, tangent)], functions' tangent,
    /// outlines' tangent), the families the parameter moves (their places
    /// among the model's) with the tangents of their tables' real and
    /// complex columns, and those of the functions and outlines ({} where
    /// it moves none); x: 1
    /// to 3 arrays (K, n) (q, qd, qdd at times); rows, cols: the Jacobian's
    /// pattern; src, pc, local: the trajectory's columns (as `columns`),
    /// dlocal (P, points): each parameter's tangent of the named points'
    /// local coordinates. Returns (the columns' tangents (K, P W), every
    /// column of the first parameter then of the second ..., the pivot
    /// ratio (K)). Phi_q is factorised again at every instant
    /// (`march_sensitivity` uses the march's own factorisation).
    #[allow(clippy::type_complexity, clippy::too_many_arguments)]
    fn sensitivity<'py>(
        &self,
        py: Python<'py>,
        tables: SensTables<'py>,
        tangents: SensTangents<'py>,
        times: PyReadonlyArray1<'py, f64>,
        x: Vec<PyReadonlyArray2<'py, f64>>,
        jac_rows: PyReadonlyArray1<'py, i64>,
        jac_cols: PyReadonlyArray1<'py, i64>,
        src: PyReadonlyArray1<'py, i64>,
        pc: PyReadonlyArray1<'py, i64>,
        local: PyReadonlyArray1<'py, C64>,
        dlocal: numpy::PyReadonlyArray2<'py, C64>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyArray1<f64>>)> {
        let times = times.as_slice()?.to_vec();
        let (n, kk, levels) = (self.kin.n, times.len(), x.len());
        let inputs = SensInputs::of(&self.kin, tables, tangents, (jac_rows, jac_cols), (src, pc, local, dlocal))?;
        let mut xs = Vec::new();
        for (k, a) in x.iter().enumerate() {
            let (v, r) = rows(a, n, &format!("sensitivity: x[{k}]"))?;
            if r != kk {
                return Err(pyo3::exceptions::PyValueError::new_err("sensitivity: one row per instant expected"));
            }
            xs.push(v.to_vec());
        }
        let width = inputs.parts.len() * inputs.src.len();
        let layout = self.layout.clone();
        let (data, ratio) = guard(py, move || {
            let own = inputs.kin(levels)?;
            let mut ratio = vec![0.0; kk];
            let x: Vec<&[f64]> = xs.iter().map(|v| v.as_slice()).collect();
            let mut data = vec![0.0; kk * width];
            let (r, c) = (&inputs.rows, &inputs.cols);
            let columns = inputs.columns();
            crate::sensitivity::sensitivities(
                &own,
                &layout,
                &inputs.parts,
                r,
                c,
                &times,
                &x,
                columns,
                &mut data,
                &mut ratio,
            )?;
            Ok((data, ratio))
        })?;
        Ok((out2(py, data, kk, width)?, PyArray1::from_vec(py, ratio)))
    }

    /// The march (`march`, from k = 0: assembled from the estimates in
    /// state.q) with the design sensitivities of every instant it takes from
    /// its own factorisation of Phi_q there, the one its rates use
    /// (crate::march::run_hooked, crate::sensitivity::Instants); a model
    /// the march splits into parts is refused (Plan.sensitivity serves it).
    /// times, state, settings, out, figures, ints: as `march`; tables,
    /// tangents, jac_rows, jac_cols, src, pc, local, dlocal: as
    /// `sensitivity`, its levels out's. Writes data (K, P W) and ratio (K)
    /// for the instants taken; returns (the first instant not taken, or K;
    /// why).
    #[allow(clippy::type_complexity, clippy::too_many_arguments)]
    fn march_sensitivity<'py>(
        &self,
        py: Python<'py>,
        times: PyReadonlyArray1<'py, f64>,
        state: &Bound<'py, MarchState>,
        settings: (f64, usize, f64, f64, bool, f64),
        out: Bound<'py, PyArray3<f64>>,
        figures: Bound<'py, PyArray2<f64>>,
        ints: Bound<'py, PyArray1<i64>>,
        tables: SensTables<'py>,
        tangents: SensTangents<'py>,
        pattern: (PyReadonlyArray1<'py, i64>, PyReadonlyArray1<'py, i64>),
        columns: SensColumns<'py>,
        data: Bound<'py, PyArray2<f64>>,
        ratio: Bound<'py, PyArray1<f64>>,
    ) -> PyResult<(usize, u8)> {
        let (n, kk) = (self.kin.n, times.len());
        let bad = |what: &str| value_error(format!("march_sensitivity: {what} has the wrong shape"));
        if self.layout.count >= 2 && matches!(self.layout.shape, Shape::Blocks { .. }) {
            return Err(value_error("march_sensitivity: a model marched in parts (Plan.sensitivity serves it)"));
        }
        let inputs = SensInputs::of(&self.kin, tables, tangents, pattern, columns)?;
        let times = vec1(&times);
        let times: &[f64] = &times;
        let stages = if settings.4 { 3 } else { 1 };
        let mut state = state.try_borrow_mut()?;
        let mut outputs = MarchOutputs::of(&out, &figures, &ints, kk)?;
        let (mut data, mut ratio) = (writable(&data, "data")?, writable(&ratio, "ratio")?);
        let width = inputs.parts.len() * inputs.src.len();
        if state.0.q.len() != n || data.shape() != [kk, width] || ratio.len() != kk {
            return Err(bad("state, data or ratio"));
        }
        let (settings, seconds) =
            (march_settings((settings.0, settings.1, settings.2, settings.3, settings.4)), settings.5);
        let (kin, layout) = (&self.kin, &self.layout);
        let st = &mut state.0;
        let (data, ratio) =
            (data.as_slice_mut().map_err(|_| bad("data"))?, ratio.as_slice_mut().map_err(|_| bad("ratio"))?);
        let out = outputs.out(n, stages, "march_sensitivity")?;
        let signal: std::sync::Mutex<Option<PyErr>> = std::sync::Mutex::new(None);
        let poll = || signalled(&signal);
        let (end, why) = guard(py, move || {
            let own = inputs.kin(stages)?;
            let setup = crate::sensitivity::Setup {
                kin: &own,
                layout,
                tangents: &inputs.parts,
                rows: &inputs.rows,
                cols: &inputs.cols,
                levels: stages,
                columns: inputs.columns(),
            };
            let mut at = crate::sensitivity::Instants::new(setup)?;
            let mut hook = |k: usize, s: &march::MarchState, f: &mut Factors, e: &[C64]| {
                let x: [&[f64]; 3] = [&s.q, &s.qd, &s.qdd];
                ratio[k] = at.at(times[k], &x[..stages], e, f, &mut data[k * width..(k + 1) * width]);
            };
            let watch = Watch::new(seconds, Some(&poll));
            Ok(march::run_hooked(kin, layout, times, 0, st, &settings, out, &watch, true, Some(&mut hook)))
        })?;
        if why == Why::Interrupted {
            return Err(raised(&signal));
        }
        Ok((end, why as u8))
    }

    /// The structural decomposition of an m x n Jacobian pattern (rows,
    /// cols; crate::decompose), any model's (a static method: models
    /// without a plan too): (exact, what the pattern allows, the structural
    /// rank, the blocks in solve order as (rows, coordinates), and the
    /// connected component of each coordinate).
    #[staticmethod]
    #[allow(clippy::type_complexity)]
    fn blocks(
        py: Python<'_>,
        m: usize,
        n: usize,
        rows: PyReadonlyArray1<'_, i64>,
        cols: PyReadonlyArray1<'_, i64>,
    ) -> PyResult<(bool, &'static str, usize, Vec<(Vec<usize>, Vec<usize>)>, Vec<usize>)> {
        let index = |a: PyReadonlyArray1<'_, i64>, bound: usize| -> PyResult<Vec<usize>> {
            let bad = || value_error("blocks: index out of range");
            a.as_array().iter().map(|&v| usize::try_from(v).ok().filter(|&v| v < bound).ok_or_else(bad)).collect()
        };
        let (rows, cols) = (index(rows, m)?, index(cols, n)?);
        if rows.len() != cols.len() {
            return Err(value_error("blocks: rows and cols differ in length"));
        }
        let (d, connected) = guard(py, move || {
            Ok((crate::decompose::decompose(m, n, &rows, &cols), crate::decompose::connected(m, n, &rows, &cols)))
        })?;
        let exact = d.kind == crate::decompose::Kind::Exact;
        let blocks = d.blocks.into_iter().map(|b| (b.rows, b.cols)).collect();
        Ok((exact, d.kind.message(), d.rank, blocks, connected))
    }

    /// The LU of J_s at these Jacobian values (nnz).
    fn factor(&self, py: Python<'_>, values: PyReadonlyArray1<'_, f64>) -> PyResult<Lu> {
        let v = vec1(&values);
        let v: &[f64] = &v;
        if v.len() != self.kin.nnz {
            return Err(pyo3::exceptions::PyValueError::new_err("factor: wrong number of values"));
        }
        let layout = &self.layout;
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

    /// March from `state` (a MarchState, left at the last instant taken)
    /// over times[k:], until an instant is not accepted (k = 0: it assembles
    /// from the estimates in state.q first); settings: (tolerance,
    /// max_iterations, max_step, floor, rates, seconds: the time left, inf
    /// for no limit); out (3, K, n): Q, QD, QDD ((1, K, n): Q without
    /// rates); figures (2, K): residual and pivot ratio; ints (K + 2): Newton
    /// iterations per instant, then the Jacobian evaluations and
    /// factorisations, added to. Every output C-contiguous and writable.
    /// Returns (the first instant not taken, or K; why: the code of
    /// accept::Why, kinem.native.Why). A signal (Ctrl-C) polled every few
    /// milliseconds stops it: its exception (KeyboardInterrupt) is raised,
    /// the state left at the last instant taken.
    #[allow(clippy::too_many_arguments)]
    fn march(
        &self,
        py: Python<'_>,
        times: PyReadonlyArray1<'_, f64>,
        k: usize,
        state: &Bound<'_, MarchState>,
        settings: (f64, usize, f64, f64, bool, f64),
        out: Bound<'_, PyArray3<f64>>,
        figures: Bound<'_, PyArray2<f64>>,
        ints: Bound<'_, PyArray1<i64>>,
    ) -> PyResult<(usize, u8)> {
        let (n, kk) = (self.kin.n, times.len());
        let times = vec1(&times);
        let times: &[f64] = &times;
        let stages = if settings.4 { 3 } else { 1 };
        let mut state = state.try_borrow_mut()?;
        let mut outputs = MarchOutputs::of(&out, &figures, &ints, kk)?;
        if state.0.q.len() != n || k > kk {
            return Err(value_error("march: state or k has the wrong shape"));
        }
        let (settings, seconds) =
            (march_settings((settings.0, settings.1, settings.2, settings.3, settings.4)), settings.5);
        let (kin, layout) = (&self.kin, &self.layout);
        let st = &mut state.0;
        let out = outputs.out(n, stages, "march")?;
        let parts = &self.parts;
        // the signal's exception, from the poll (the GIL re-acquired for it)
        let signal: std::sync::Mutex<Option<PyErr>> = std::sync::Mutex::new(None);
        let poll = || signalled(&signal);
        let (end, why) = guard(py, move || {
            let watch = Watch::new(seconds, Some(&poll));
            if layout.count < 2 || !matches!(layout.shape, Shape::Blocks { .. }) {
                return Ok(march::run(kin, layout, times, k, st, &settings, out, &watch, true));
            }
            let parts = parts.get_or_init(|| crate::parts::split(kin, layout)).as_ref()?;
            Ok(crate::parts::run_parts(parts, layout.sign, times, k, st, &settings, out, &watch))
        })?;
        if why == Why::Interrupted {
            return Err(raised(&signal));
        }
        Ok((end, why as u8))
    }

    /// Variants of this model marched together (crate::variants): the
    /// model's tables (families [(kind, table)], functions, outlines: every
    /// function and outline its own number) and per parameter their
    /// tangents ([family tangents], functions', outlines'); asked: (stages,
    /// src (C,), pc (P,), local (P,), dlocal (parameters, P)); values (N,
    /// parameters): each variant's moves from the nominal; q0 (n): the
    /// nominal's first state; settings: (tolerance, max_iterations,
    /// max_step, floor, seconds). Writes out (N, K, C), start (N, n), end
    /// (N), why (N), det (N) (crate::variants::Written). A signal stops
    /// every variant and raises its exception. lanes: march them 8 at a
    /// time as lanes where the model suits (crate::lanes), else one by one.
    #[allow(clippy::too_many_arguments, clippy::type_complexity)]
    #[pyo3(signature = (families, functions, outlines, tangents, asked, values, times, q0, settings, out, lanes = true))]
    fn variants<'py>(
        &self,
        py: Python<'py>,
        families: Vec<(String, Bound<'py, PyDict>)>,
        functions: Bound<'py, PyDict>,
        outlines: Bound<'py, PyDict>,
        tangents: Vec<(Vec<Bound<'py, PyDict>>, Bound<'py, PyDict>, Bound<'py, PyDict>)>,
        asked: (
            usize,
            PyReadonlyArray1<'py, i64>,
            PyReadonlyArray1<'py, i64>,
            PyReadonlyArray1<'py, C64>,
            PyReadonlyArray2<'py, C64>,
        ),
        values: PyReadonlyArray2<'py, f64>,
        times: PyReadonlyArray1<'py, f64>,
        q0: PyReadonlyArray1<'py, f64>,
        settings: (f64, usize, f64, f64, f64),
        out: (
            Bound<'py, PyArray3<f64>>,
            Bound<'py, PyArray2<f64>>,
            Bound<'py, PyArray1<i64>>,
            Bound<'py, PyArray1<u8>>,
            Bound<'py, PyArray1<i8>>,
        ),
        lanes: bool,
    ) -> PyResult<()> {
        let bad = |what: &str| value_error(format!("variants: {what}"));
        let fams = families.iter().map(|(k, d)| Ok((k.clone(), table(d)?))).collect::<PyResult<Vec<_>>>()?;
        let mut tans = Vec::new();
        for (f, fd, od) in &tangents {
            if f.len() != fams.len() {
                return Err(bad("one tangent per family expected"));
            }
            tans.push((f.iter().map(table).collect::<PyResult<Vec<_>>>()?, table(fd)?, table(od)?));
        }
        let (n, p) = (self.kin.n, tans.len());
        let tables = crate::variants::Tables {
            n,
            angles: self.kin.angles.iter().map(|&a| a as i64).collect(),
            families: fams,
            functions: table(&functions)?,
            outlines: table(&outlines)?,
            tangents: tans,
        };
        let (stages, src, pc, local, dlocal) = asked;
        let points = local.len();
        let (pc, local) = (pc.as_array().to_vec(), local.as_array().to_vec());
        let dlocal: Vec<C64> = dlocal.as_array().iter().copied().collect();
        if !(1..=3).contains(&stages) || pc.len() != points || dlocal.len() != p * points {
            return Err(bad("stages 1 to 3, one body column and local point per point, dlocal (parameters, points)"));
        }
        let (src, pc) = sources(&src.as_array().to_vec(), &pc, n, stages).map_err(&bad)?;
        let (values, count) = rows(&values, p, "variants: values")?;
        let (times, q0) = (vec1(&times), vec1(&q0));
        let (times, q0, values): (&[f64], &[f64], &[f64]) = (&times, &q0, &values);
        let kk = times.len();
        let (mut data, mut start) = (writable(&out.0, "variants: out")?, writable(&out.1, "variants: start")?);
        let (mut end, mut why) = (writable(&out.2, "variants: end")?, writable(&out.3, "variants: why")?);
        let mut det = writable(&out.4, "variants: det")?;
        if data.shape() != [count, kk, src.len()]
            || start.shape() != [count, n]
            || end.len() != count
            || why.len() != count
            || det.len() != count
        {
            return Err(bad("outputs of the wrong shape"));
        }
        let (tolerance, max_iterations, max_step, floor, seconds) = settings;
        let s = march::Settings { tolerance, max_iterations, max_step, floor, rates: stages > 1 };
        let written = crate::variants::Written {
            data: data.as_slice_mut().map_err(|_| bad("out"))?,
            start: start.as_slice_mut().map_err(|_| bad("start"))?,
            end: end.as_slice_mut().map_err(|_| bad("end"))?,
            why: why.as_slice_mut().map_err(|_| bad("why"))?,
            det: det.as_slice_mut().map_err(|_| bad("det"))?,
        };
        let asked = crate::variants::Asked { stages, src: &src, pc: &pc, local: &local, dlocal: &dlocal };
        let (kin, layout) = (&self.kin, &self.layout);
        let signal: std::sync::Mutex<Option<PyErr>> = std::sync::Mutex::new(None);
        let poll = || signalled(&signal);
        let stopped = guard(py, move || {
            let nominal = tables.kin(&vec![0.0; p])?;
            if (nominal.n, nominal.m, nominal.nnz) != (kin.n, kin.m, kin.nnz) {
                return Err("variants: the tables do not make this model".to_string());
            }
            let watch = Watch::new(seconds, Some(&poll));
            let batch = crate::variants::Batch {
                tables: &tables,
                layout,
                times,
                q0,
                settings: &s,
                asked: &asked,
                watch: &watch,
                lanes,
            };
            crate::variants::run(&batch, values, written)
        });
        stopped?;
        if why.as_slice().map_err(|_| bad("why"))?.contains(&(Why::Interrupted as u8)) {
            return Err(raised(&signal));
        }
        Ok(())
    }

    /// One instant t from `state` (step::step on the core's operations),
    /// the state moved to it when accepted; settings: (tolerance,
    /// max_iterations, max_step, floor, rates); mode: the code of
    /// step::Mode (kinem.native.Mode). Returns its Outcome.
    #[pyo3(signature = (state, t, settings, mode = 0))]
    fn step(
        &self,
        py: Python<'_>,
        state: &Bound<'_, MarchState>,
        t: f64,
        settings: (f64, usize, f64, f64, bool),
        mode: u8,
    ) -> PyResult<Outcome> {
        let mode = mode_of(mode)?;
        let mut state = state.try_borrow_mut()?;
        if state.0.q.len() != self.kin.n {
            return Err(value_error("step: the state has the wrong size"));
        }
        let s = march_settings(settings);
        let (kin, layout, st) = (&*self.kin, &*self.layout, &mut state.0);
        let (o, q, counts) = guard(py, move || {
            let mut ops = march::Native::new(kin, layout);
            let Ok(o) = march::step(&mut ops, st, t, &s, mode, &mut march::Work::new(kin.n));
            Ok((o, ops.q, ops.counts))
        })?;
        Ok(Outcome::new(py, o, q, counts))
    }
}

/// Polls for a signal with the GIL re-acquired: true when one arrived, its
/// exception (KeyboardInterrupt for Ctrl-C) kept in `signal`.
fn signalled(signal: &std::sync::Mutex<Option<PyErr>>) -> bool {
    match Python::attach(|py| py.check_signals()) {
        Ok(()) => false,
        Err(e) => {
            if let Ok(mut s) = signal.lock() {
                *s = Some(e);
            }
            true
        }
    }
}

/// The signal's exception kept by `signalled` (KeyboardInterrupt without one).
fn raised(signal: &std::sync::Mutex<Option<PyErr>>) -> PyErr {
    let e = signal.lock().ok().and_then(|mut s| s.take());
    e.unwrap_or_else(|| pyo3::exceptions::PyKeyboardInterrupt::new_err(""))
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
        let b = vec1(&b);
        let b: &[f64] = &b;
        if b.len() != self.layout.m {
            return Err(pyo3::exceptions::PyValueError::new_err("solve: wrong number of rows"));
        }
        let layout = &self.layout;
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
    let s = guard_held(ops.py(), || newton::settle(&mut o, tolerance, max_iterations, max_step, finish))?;
    Ok((s.iterations, s.residual, s.converged, s.last_step))
}

/// A step's operations as a Python object's (kinem.analysis.Steps: any
/// linear solver): its settle operations and start(q, t), q, stats() ->
/// (pivot ratio, det sign), solve(b) -> x, probe() -> size, col_scale; the
/// rates from its solve with the model's own nu and gamma.
struct PySteps<'a, 'py> {
    ops: PyOps<'a, 'py>,
    kin: &'a Kin,
    col_scale: Vec<f64>,
    q: Vec<f64>,
    e: Vec<C64>,
    t: f64,
    nu: Vec<f64>,
    gamma: Vec<f64>,
}

impl Ops for PySteps<'_, '_> {
    type Error = PyErr;
    fn evaluate(&mut self, it: i64) -> PyResult<f64> {
        self.ops.evaluate(it)
    }
    fn factor(&mut self, last: bool) -> PyResult<()> {
        self.ops.factor(last)
    }
    fn correct(&mut self, limit: f64) -> PyResult<f64> {
        self.ops.correct(limit)
    }
}

impl march::Step for PySteps<'_, '_> {
    fn start(&mut self, q: &[f64], t: f64) -> PyResult<()> {
        self.t = t;
        let py = self.ops.ops.py();
        self.ops.ops.call_method1("start", (PyArray1::from_slice(py, q), t)).map(|_| ())
    }
    fn fetch(&mut self) -> PyResult<()> {
        let q: PyReadonlyArray1<f64> = self.ops.ops.getattr("q")?.extract()?;
        if q.len() != self.q.len() {
            return Err(value_error("step: the operations' q has the wrong size"));
        }
        self.q.copy_from_slice(&vec1(&q));
        Ok(())
    }
    fn q(&self) -> &[f64] {
        &self.q
    }
    fn stats(&mut self) -> PyResult<(f64, i32)> {
        self.ops.ops.call_method0("stats")?.extract()
    }
    fn rates(&mut self, qd: &mut [f64], qdd: &mut [f64]) -> PyResult<()> {
        self.fetch()?;
        self.kin.rotate(&self.q, &mut self.e);
        let PySteps { ops, kin, q, e, t, nu, gamma, .. } = self;
        let at = At { q: &q[..], e: &e[..], t: *t };
        march::rates_with(kin, &at, nu, gamma, qd, qdd, |b, x| {
            let py = ops.ops.py();
            let r: PyReadonlyArray1<f64> = ops.ops.call_method1("solve", (PyArray1::from_slice(py, b),))?.extract()?;
            if r.len() != x.len() {
                return Err(value_error("step: solve gave the wrong size"));
            }
            x.copy_from_slice(&vec1(&r));
            Ok(())
        })
    }
    fn probe(&mut self) -> PyResult<f64> {
        self.ops.ops.call_method0("probe")?.extract()
    }
    fn col_scale(&self) -> &[f64] {
        &self.col_scale
    }
}

/// One instant t from `state` (step::step) on the Python operations `ops`
/// (kinem.analysis.Steps) of the model evaluated by `core`; settings and
/// mode as Plan.step's. Returns its Outcome (q: the operations' last).
#[pyfunction]
#[pyo3(signature = (ops, core, state, t, settings, mode = 0))]
fn step<'py>(
    ops: &Bound<'py, PyAny>,
    core: &Core,
    state: &Bound<'py, MarchState>,
    t: f64,
    settings: (f64, usize, f64, f64, bool),
    mode: u8,
) -> PyResult<Outcome> {
    let py = ops.py();
    let mode = mode_of(mode)?;
    let kin = &*core.kin;
    let mut state = state.try_borrow_mut()?;
    let col_scale: Vec<f64> = ops.getattr("col_scale")?.extract()?;
    if state.0.q.len() != kin.n || col_scale.len() != kin.n {
        return Err(value_error("step: the state or col_scale has the wrong size"));
    }
    let s = march_settings(settings);
    let (n, m) = (kin.n, kin.m);
    let mut o = PySteps {
        ops: PyOps { ops },
        kin,
        col_scale,
        q: vec![0.0; n],
        e: vec![C64::new(1.0, 0.0); n],
        t,
        nu: vec![0.0; m],
        gamma: vec![0.0; m],
    };
    let st = &mut state.0;
    let outcome = guard_held(py, || march::step(&mut o, st, t, &s, mode, &mut march::Work::new(n)))?;
    let q = o.q.clone();
    Ok(Outcome::new(py, outcome, q, [0, 0]))
}

fn mode_of(code: u8) -> PyResult<march::Mode> {
    march::Mode::ALL.get(code as usize).copied().ok_or_else(|| value_error(format!("step: no mode {code}")))
}

fn march_settings(s: (f64, usize, f64, f64, bool)) -> march::Settings {
    march::Settings { tolerance: s.0, max_iterations: s.1, max_step: s.2, floor: s.3, rates: s.4 }
}

/// Plan.march's outputs (out, figures, ints, as it documents) for K
/// instants, and room for the det signs.
struct MarchOutputs<'py> {
    out: PyReadwriteArray<'py, f64, numpy::Ix3>,
    figures: PyReadwriteArray<'py, f64, numpy::Ix2>,
    ints: PyReadwriteArray<'py, i64, numpy::Ix1>,
    det: Vec<i8>,
    kk: usize,
}

impl<'py> MarchOutputs<'py> {
    fn of(
        out: &Bound<'py, PyArray3<f64>>,
        figures: &Bound<'py, PyArray2<f64>>,
        ints: &Bound<'py, PyArray1<i64>>,
        kk: usize,
    ) -> PyResult<Self> {
        let (out, figures) = (writable(out, "march: out")?, writable(figures, "march: figures")?);
        Ok(MarchOutputs { out, figures, ints: writable(ints, "march: ints")?, det: vec![0i8; kk], kk })
    }

    /// The outputs as march::Out, checked against n coordinates and `stages`.
    fn out(&mut self, n: usize, stages: usize, what: &str) -> PyResult<march::Out<'_>> {
        let kk = self.kk;
        let bad = |part: &str| value_error(format!("{what}: {part} has the wrong shape"));
        if self.out.shape() != [stages, kk, n]
            || self.figures.shape() != [2, kk]
            || Some(self.ints.len()) != kk.checked_add(2)
        {
            return Err(bad("out, figures or ints"));
        }
        let (oq, rest) = self.out.as_slice_mut().map_err(|_| bad("out"))?.split_at_mut(kk * n);
        let (qd, qdd) = rest.split_at_mut(rest.len() / 2);
        let (residual, pivot) = self.figures.as_slice_mut().map_err(|_| bad("figures"))?.split_at_mut(kk);
        let (iterations, counts) = self.ints.as_slice_mut().map_err(|_| bad("ints"))?.split_at_mut(kk);
        Ok(march::Out { q: oq, qd, qdd, iterations, residual, pivot, det: &mut self.det, counts, first: 0 })
    }
}

/// Plan.sensitivity's tables: (families [(kind, table)], functions, outlines).
type SensTables<'py> = (Vec<(String, Bound<'py, PyDict>)>, Bound<'py, PyDict>, Bound<'py, PyDict>);
/// Per parameter: (families [(place, tangent)], functions', outlines').
type SensTangents<'py> = Vec<(Vec<(usize, Bound<'py, PyDict>)>, Bound<'py, PyDict>, Bound<'py, PyDict>)>;
/// The trajectory's column sources, points' body columns, local coordinates, dlocal (P, points).
type SensColumns<'py> = (
    PyReadonlyArray1<'py, i64>,
    PyReadonlyArray1<'py, i64>,
    PyReadonlyArray1<'py, C64>,
    numpy::PyReadonlyArray2<'py, C64>,
);

/// The inputs of the sensitivities (Plan.sensitivity, Plan.march_sensitivity) read from Python.
struct SensInputs {
    n: usize,
    angles: Vec<i64>,
    m_nnz: (usize, usize),
    families: Vec<(String, Table)>,
    functions: Table,
    outlines: Table,
    parts: Vec<crate::sensitivity::Tangent>,
    rows: Vec<usize>,
    cols: Vec<usize>,
    src: Vec<usize>,
    pc: Vec<usize>,
    local: Vec<C64>,
    dlocal: Vec<C64>,
}

impl SensInputs {
    fn of<'py>(
        kin: &Kin,
        tables: SensTables<'py>,
        tangents: SensTangents<'py>,
        pattern: (PyReadonlyArray1<'py, i64>, PyReadonlyArray1<'py, i64>),
        columns: SensColumns<'py>,
    ) -> PyResult<SensInputs> {
        let families = tables.0.iter().map(|(k, d)| Ok((k.clone(), table(d)?))).collect::<PyResult<Vec<_>>>()?;
        let (functions, outlines) = (table(&tables.1)?, table(&tables.2)?);
        let mut parts = Vec::new();
        for (fams, fd, od) in &tangents {
            let families = fams.iter().map(|(k, d)| Ok((*k, table(d)?))).collect::<PyResult<Vec<_>>>()?;
            parts.push(crate::sensitivity::Tangent { families, functions: table(fd)?, outlines: table(od)? });
        }
        let to_usize = |a: PyReadonlyArray1<'py, i64>| -> Vec<usize> {
            a.as_array().iter().map(|&v| if v < 0 { usize::MAX } else { v as usize }).collect()
        };
        let (src, pc, local, dlocal) = columns;
        let local = local.as_array().to_vec();
        if dlocal.shape() != [parts.len(), local.len()] {
            return Err(value_error("sensitivity: dlocal must have one row per parameter, one entry per point"));
        }
        Ok(SensInputs {
            n: kin.n,
            angles: kin.angles.iter().map(|&a| a as i64).collect(),
            m_nnz: (kin.m, kin.nnz),
            families,
            functions,
            outlines,
            parts,
            rows: to_usize(pattern.0),
            cols: to_usize(pattern.1),
            src: to_usize(src),
            pc: to_usize(pc),
            local,
            dlocal: dlocal.as_array().iter().copied().collect(),
        })
    }

    /// The model from the tables (every function and outline its own
    /// number), checked against the plan's and the columns against `levels`.
    fn kin(&self, levels: usize) -> Result<Kin, String> {
        crate::columns::check(self.n, levels, &self.src, &self.pc, self.local.len())?;
        let families = self.families.clone();
        let own = Kin::new(self.n, families, &self.functions, &self.outlines, self.angles.clone())?;
        if (own.m, own.nnz) != self.m_nnz {
            return Err("sensitivity: the tables are not the model's".to_string());
        }
        Ok(own)
    }

    fn columns(&self) -> crate::sensitivity::Cols<'_> {
        (&self.src, &self.pc, &self.local, &self.dlocal)
    }
}

/// The accepted state of a march and its steps (step::MarchState):
/// MarchState(q) holds the estimates q, nothing accepted yet; a step or a
/// march moves it to each instant it accepts.
#[pyclass(module = "kinem._core")]
pub struct MarchState(march::MarchState);

#[pymethods]
impl MarchState {
    #[new]
    fn new(q: PyReadonlyArray1<'_, f64>) -> Self {
        MarchState(march::MarchState::new(&vec1(&q)))
    }

    /// Back to the estimates q (None: the state's q), nothing accepted.
    #[pyo3(signature = (q = None))]
    fn restart(&mut self, q: Option<PyReadonlyArray1<'_, f64>>) -> PyResult<()> {
        if let Some(q) = q {
            if q.len() != self.0.q.len() {
                return Err(value_error("restart: q has the wrong size"));
            }
            self.0.q.copy_from_slice(&vec1(&q));
        }
        self.0.restart();
        Ok(())
    }

    /// An accepted state at t (tests: a state made by hand): q, its rates, det sign.
    #[staticmethod]
    fn of(
        t: f64,
        q: PyReadonlyArray1<'_, f64>,
        qd: PyReadonlyArray1<'_, f64>,
        qdd: PyReadonlyArray1<'_, f64>,
        det: i32,
    ) -> PyResult<Self> {
        let mut s = march::MarchState::new(&vec1(&q));
        if qd.len() != s.q.len() || qdd.len() != s.q.len() {
            return Err(value_error("MarchState.of: q, qd and qdd differ in size"));
        }
        s.qd.copy_from_slice(&vec1(&qd));
        s.qdd.copy_from_slice(&vec1(&qdd));
        (s.rates, s.t, s.det) = (true, t, det);
        Ok(MarchState(s))
    }

    fn copy(&self) -> Self {
        MarchState(self.0.clone())
    }

    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.0.q)
    }

    /// The velocities at q (None when the state holds no rates).
    #[getter]
    fn qd<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.0.rates.then(|| PyArray1::from_slice(py, &self.0.qd))
    }

    #[getter]
    fn qdd<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.0.rates.then(|| PyArray1::from_slice(py, &self.0.qdd))
    }

    /// The accepted state's time (NaN: none yet).
    #[getter]
    fn t(&self) -> f64 {
        self.0.t
    }

    #[getter]
    fn det(&self) -> i32 {
        self.0.det
    }

    /// The det sign a least-squares model monitors (kinem.linalg.monitor_rows), set after its assembly.
    #[setter]
    fn set_det(&mut self, det: i32) {
        self.0.det = det;
    }
}

/// How a step ended (step::Outcome): why (the code of accept::Why), its
/// Newton iterations and residual, pivot ratio and det sign, last Newton
/// correction, correction from the predictor and predicted motion, the
/// final q (the state's when accepted) and the Jacobian evaluations and
/// factorisations it made (the core's operations; 0 for Python's).
#[pyclass(frozen, module = "kinem._core")]
pub struct Outcome {
    #[pyo3(get)]
    why: u8,
    #[pyo3(get)]
    iterations: usize,
    #[pyo3(get)]
    residual: f64,
    #[pyo3(get)]
    pivot: f64,
    #[pyo3(get)]
    det: i32,
    #[pyo3(get)]
    correction: f64,
    #[pyo3(get)]
    corr: f64,
    #[pyo3(get)]
    motion: f64,
    #[pyo3(get)]
    q: Py<PyArray1<f64>>,
    #[pyo3(get)]
    counts: (i64, i64),
}

impl Outcome {
    fn new(py: Python<'_>, o: march::Outcome, q: Vec<f64>, counts: [i64; 2]) -> Self {
        Outcome {
            why: o.why as u8,
            iterations: o.iterations,
            residual: o.residual,
            pivot: o.pivot,
            det: o.det,
            correction: o.correction,
            corr: o.corr,
            motion: o.motion,
            q: PyArray1::from_vec(py, q).unbind(),
            counts: (counts[0], counts[1]),
        }
    }
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
    let t = vec1(&t);
    let t: &[f64] = &t;
    if order > 2 {
        return Err(pyo3::exceptions::PyValueError::new_err("functions: order 0, 1 or 2"));
    }
    let (v, w) = guard(py, || {
        let f = crate::functions::Functions::from_table(&tb)?;
        let w = f.len();
        let mut out = vec![0.0; t.len().checked_mul(w).ok_or("functions: too many values")?];
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
    let (which, theta) = (which.as_array().to_vec(), vec1(&theta));
    let theta: &[f64] = &theta;
    let n = theta.len();
    let v = guard(py, || {
        let o = crate::outline::Outlines::from_table(&tb)?;
        if which.len() != n || which.iter().any(|&w| w < 0 || w as usize >= o.len()) {
            return Err("outline_radius: which out of range or of another length than theta".to_string());
        }
        let mut out = vec![0.0; n.checked_mul(4).ok_or("outline_radius: too many values")?];
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

/// Panics inside the core with `message`, without the GIL or (`held`) with
/// it (tests/test_core.py: a panic reaches Python as
/// kinem.errors.CoreError, never an abort nor a PanicException).
#[pyfunction]
#[pyo3(signature = (message, held = false))]
fn _panic(py: Python<'_>, message: String, held: bool) -> PyResult<()> {
    if held {
        return guard_held(py, || -> PyResult<()> { panic!("{message}") });
    }
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
    m.add_function(wrap_pyfunction!(step, m)?)?;
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

/// A trajectory's column sources and its points' body columns (columns::columns)
/// checked: every point on a body's x column (x, y, phi inside n), every
/// source inside the `stages` stages' coordinates and points' values.
fn sources(src: &[i64], pc: &[i64], n: usize, stages: usize) -> Result<(Vec<usize>, Vec<usize>), &'static str> {
    if pc.iter().any(|&c| c < 0 || c as usize + 2 >= n.max(1)) {
        return Err("point columns out of range");
    }
    let limit = pc.len().checked_mul(2).and_then(|v| v.checked_add(n)).and_then(|v| v.checked_mul(stages));
    let limit = limit.and_then(|v| i64::try_from(v).ok()).ok_or("too many columns")?;
    if src.iter().any(|&j| j < 0 || j >= limit) {
        return Err("a source out of range");
    }
    Ok((src.iter().map(|&j| j as usize).collect(), pc.iter().map(|&c| c as usize).collect()))
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
    let stages: Vec<Cow<[f64]>> = x.iter().map(vec2).collect();
    let stages: Vec<&[f64]> = stages.iter().map(|s| &**s).collect();
    if x.iter().any(|a| a.shape() != [k, n]) {
        return Err(bad("stages differ in shape"));
    }
    let (pc, local) = (pc.as_array().to_vec(), local.as_array().to_vec());
    if pc.len() != local.len() {
        return Err(bad("point columns out of range"));
    }
    let src = src.as_array().to_vec();
    k.checked_mul(src.len()).ok_or_else(|| bad("too many values"))?;
    let (src, pc) = sources(&src, &pc, n, stages.len()).map_err(&bad)?;
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
        crate::columns::columns(&stages, n, &src, &pc, &local, &mut out);
        Ok(out)
    })?;
    out2(py, v, k, w)
}
