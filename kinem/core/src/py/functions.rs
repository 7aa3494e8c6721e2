//! The driving functions, outlines and trajectory columns as plain calls.
use super::*;

/// The functions of a table {kind, start, data} (kinem.functions.FunctionTable)
/// at the instants t (K,): their order-th derivative, (K, functions). The
/// driving functions' one implementation, for every caller outside the analysis too.
#[pyfunction]
pub(crate) fn functions<'py>(
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
pub(crate) fn outline_radius<'py>(
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

/// Whether t holds one or more instants, finite and each after the one
/// before (kinem.solver's check of a solve's times, which words the error
/// when not): the ends finite and every step positive (a NaN fails it).
#[pyfunction]
pub(crate) fn increasing(t: PyReadonlyArray1<'_, f64>) -> bool {
    let t = vec1(&t);
    match (t.first(), t.last()) {
        (Some(a), Some(b)) => a.is_finite() && b.is_finite() && t.windows(2).all(|w| w[1] > w[0]),
        _ => false,
    }
}

/// Panics inside the core with `message`, without the GIL or (`held`) with
/// it (tests/test_core.py: a panic reaches Python as
/// kinem.errors.CoreError, never an abort nor a PanicException).
#[pyfunction]
#[pyo3(signature = (message, held = false))]
pub(crate) fn _panic(py: Python<'_>, message: String, held: bool) -> PyResult<()> {
    if held {
        return guard_held(py, || -> PyResult<()> { panic!("{message}") });
    }
    guard(py, move || -> Result<(), String> { panic!("{message}") })
}

/// A trajectory's column sources and its points' body columns (columns::columns)
/// checked: every point on a body's x column (x, y, phi inside n), every
/// source inside the `stages` stages' coordinates and points' values.
pub(crate) fn sources(
    src: &[i64],
    pc: &[i64],
    n: usize,
    stages: usize,
) -> Result<(Vec<usize>, Vec<usize>), &'static str> {
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
pub(crate) fn columns<'py>(
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
