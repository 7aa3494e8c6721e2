//! Core: a model's evaluation at a batch of configurations.
use super::*;

/// A model's evaluation (kinem.model.Model.core): Phi, the Jacobian's
/// values, nu and gamma at a batch of configurations.
#[pyclass(frozen, module = "kinem._core")]
pub(crate) struct Core {
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

    /// e^{i q} as a step holds it, with Phi and the Jacobian at it
    /// (Angles: kinem.analysis.Steps).
    fn angles(&self) -> Angles {
        Angles::new(self.kin.clone())
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

pub(crate) fn check(a: usize, b: usize) -> Result<(), String> {
    if a == b {
        Ok(())
    } else {
        Err(format!("batch sizes differ: {a} and {b}"))
    }
}

/// K evaluations of width w at the configurations q (K, n), each with
/// e^{i q} at its angle columns: f(instant, q_i, e, out_i).
pub(crate) fn batch(
    kin: &Kin,
    q: &[f64],
    k: usize,
    w: usize,
    f: impl Fn(usize, &[f64], &[C64], &mut [f64]),
) -> Vec<f64> {
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
