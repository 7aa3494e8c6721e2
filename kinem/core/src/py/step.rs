//! The step-by-step analysis's kernels: LU factors, Newton and the step on
//! Python's operations, the march's state and a step's outcome.
use super::plan::{march_settings, mode_of};
use super::*;

/// LU factors of J_s (Plan.factor): solve, pivot ratio and det sign.
#[pyclass(frozen, module = "kinem._core")]
pub(crate) struct Lu {
    pub(crate) layout: Arc<Layout>,
    pub(crate) f: std::sync::Mutex<Factors>,
    #[pyo3(get)]
    pub(crate) pivot_ratio: f64,
    #[pyo3(get)]
    pub(crate) det_sign: i32,
    /// the coordinate whose column holds the smallest |pivot| (None: a padding position)
    #[pyo3(get)]
    pub(crate) smallest: Option<usize>,
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

/// e^{i q} at a step's q as the core's march holds it (march::Native,
/// Kin::rotate_changed): kept where q has not moved, after `start` its
/// anchor's e^{i a} turned by the angle since (sin_cos where it is far),
/// turned by a correction's small angle after one (model::follow);
/// Phi and the Jacobian's values with it. kinem.analysis.Steps evaluates
/// with it (Core.angles()), and the step's rates read its e, so that its
/// steps agree with the core's to the bit.
#[pyclass(module = "kinem._core")]
pub(crate) struct Angles {
    kin: Arc<Kin>,
    turning: Turning,
}

impl Angles {
    pub(crate) fn new(kin: Arc<Kin>) -> Self {
        let turning = Turning::new(kin.n);
        Angles { kin, turning }
    }

    /// e at q as march::Native brings it there.
    fn at(&mut self, q: &[f64]) -> PyResult<()> {
        if q.len() != self.kin.n {
            return Err(value_error("Angles: q has the wrong size"));
        }
        self.turning.to(&self.kin, q);
        Ok(())
    }

    fn eval<'py>(&mut self, py: Python<'py>, q: &[f64], t: f64, jac: bool) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.at(q)?;
        let Angles { kin, turning } = self;
        let at = At { q, e: &turning.e, t };
        let v = guard(py, || {
            let mut out = vec![0.0; if jac { kin.nnz } else { kin.m }];
            if jac {
                kin.jac(&at, &mut out)
            } else {
                kin.phi(&at, &mut out)
            }
            Ok(out)
        })?;
        Ok(PyArray1::from_vec(py, v))
    }
}

#[pymethods]
impl Angles {
    /// q was set, not corrected: the next evaluation calls sin_cos where it moved.
    fn start(&mut self) {
        self.turning.restart();
    }

    /// Phi at q, t.
    fn phi<'py>(
        &mut self,
        py: Python<'py>,
        q: PyReadonlyArray1<'py, f64>,
        t: f64,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.eval(py, &vec1(&q), t, false)
    }

    /// The Jacobian's values at q, t, in the model's pattern order.
    fn jac<'py>(
        &mut self,
        py: Python<'py>,
        q: PyReadonlyArray1<'py, f64>,
        t: f64,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.eval(py, &vec1(&q), t, true)
    }
}

/// settle's operations as a Python object's methods (the step-by-step
/// analysis, kinem.analysis): evaluate(it) -> residual, factor(last),
/// correct(limit) -> step size.
pub(crate) struct PyOps<'a, 'py> {
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
pub(crate) fn settle(
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
pub(crate) struct PySteps<'a, 'py> {
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
        // e as the operations' evaluations hold it (their Angles), else e^{i q}
        match self.ops.ops.getattr("angles").ok().and_then(|a| a.extract::<PyRefMut<Angles>>().ok()) {
            Some(mut a) => {
                a.at(&self.q)?;
                self.e.copy_from_slice(&a.turning.e);
            }
            None => self.kin.rotate(&self.q, &mut self.e),
        }
        let PySteps { ops, kin, q, e, t, nu, gamma, .. } = self;
        let at = At { q: &q[..], e: &e[..], t: *t };
        march::rates_with(kin, &at, None, nu, gamma, qd, qdd, |b, x| {
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
pub(crate) fn step<'py>(
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
    let (n, m, smooth) = (kin.n, kin.m, kin.smooth);
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
    let outcome = guard_held(py, || march::step(&mut o, st, t, &s, mode, &mut march::Work::new(n, smooth)))?;
    let q = o.q.clone();
    Ok(Outcome::new(py, outcome, q, [0, 0]))
}

/// The accepted state of a march and its steps (step::MarchState):
/// MarchState(q) holds the estimates q, nothing accepted yet; a step or a
/// march moves it to each instant it accepts.
#[pyclass(module = "kinem._core")]
pub(crate) struct MarchState(pub(crate) march::MarchState);

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
pub(crate) struct Outcome {
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
    pub(crate) fn new(py: Python<'_>, o: march::Outcome, q: Vec<f64>, counts: [i64; 2]) -> Self {
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
