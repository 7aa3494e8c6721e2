//! Plan: the march's linear structure with its evaluation; the march, its
//! sensitivities and variants, the step.
use super::functions::sources;
use super::*;
use crate::outline::Piece;

pub(crate) fn positions(t: &Table, key: &str, bound: usize) -> PyResult<Vec<usize>> {
    t.index(key, bound).map_err(pyo3::exceptions::PyValueError::new_err)
}

pub(crate) fn reals(t: &Table, key: &str) -> PyResult<Vec<f64>> {
    t.real(key).map_err(pyo3::exceptions::PyValueError::new_err)
}

/// A model's linear structure (kinem.model.Blocks or Band) with its
/// evaluation: what the march and the step-by-step LU run on.
#[pyclass(frozen, module = "kinem._core")]
pub(crate) struct Plan {
    kin: Arc<Kin>,
    layout: Arc<Layout>,
    /// a model of several diagonal blocks as one model per block, built at
    /// its first march (crate::parts)
    parts: std::sync::OnceLock<Result<Vec<crate::parts::Part>, String>>,
    /// the march's room as made fresh (at the first march), and the one the
    /// last march left: each march sets it from the fresh one in place
    /// (`Plan::room`), no allocation, no evaluation
    fresh: std::sync::OnceLock<march::Room>,
    spare: std::sync::Mutex<Option<march::Room>>,
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
        Ok(Plan {
            kin,
            layout: Arc::new(layout),
            parts: std::sync::OnceLock::new(),
            fresh: std::sync::OnceLock::new(),
            spare: std::sync::Mutex::new(None),
        })
    }

    /// Design sensitivities (crate::sensitivity): tables, the model's
    /// (families [(kind, table)], functions, outlines) with every function
    /// and outline its own number (kinem.moved_tables._tables); tangents, one per
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
        let inputs = SensInputs::of(&self.kin, tables, tangents, (jac_rows, jac_cols), (src, pc, local, dlocal))?;
        let prepared = guard(py, move || inputs.prepare())?;
        self.separate(py, &prepared, times, x)
    }

    /// `sensitivity` from a kept set-up (this plan's `sensitivity_setup`,
    /// its columns for as many levels as x has): kinem.sensitivity's
    /// separate pass, its set-up made once per model and parameters as the
    /// fused pass's is. A set-up another plan made is refused.
    #[allow(clippy::type_complexity)]
    fn sensitivity_kept<'py>(
        &self,
        py: Python<'py>,
        setup: &Bound<'py, SensSetup>,
        times: PyReadonlyArray1<'py, f64>,
        x: Vec<PyReadonlyArray2<'py, f64>>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyArray1<f64>>)> {
        let setup = setup.get();
        if !Arc::ptr_eq(&setup.1, &self.layout) {
            return Err(value_error("sensitivity_kept: the set-up is not this model's (another plan made it)"));
        }
        self.separate(py, &setup.0, times, x)
    }

    /// What `march_sensitivity` is set up from, made once per model and
    /// parameters (kinem.sensitivity keeps it): tables, tangents, the
    /// Jacobian's pattern (jac_rows, jac_cols) and the columns (src, pc,
    /// local, dlocal), as `sensitivity`'s (crate::sensitivity::Prepared).
    #[allow(clippy::type_complexity)]
    fn sensitivity_setup<'py>(
        &self,
        py: Python<'py>,
        tables: SensTables<'py>,
        tangents: SensTangents<'py>,
        pattern: (PyReadonlyArray1<'py, i64>, PyReadonlyArray1<'py, i64>),
        columns: SensColumns<'py>,
    ) -> PyResult<SensSetup> {
        let inputs = SensInputs::of(&self.kin, tables, tangents, pattern, columns)?;
        Ok(SensSetup(guard(py, move || inputs.prepare())?, self.layout.clone(), std::sync::Mutex::new(None)))
    }

    /// The march (`march`, from k = 0: assembled from the estimates in
    /// state.q) with the design sensitivities of every instant it takes from
    /// its own factorisation of Phi_q there, the one its rates use
    /// (crate::march::run_hooked, crate::sensitivity::Instants); a model
    /// the march splits into parts is refused (Plan.sensitivity serves it).
    /// times, state, settings, out, figures, ints: as `march`; setup: this
    /// plan's `sensitivity_setup` (kept per model and parameters), its
    /// levels out's. Writes data (K, P W) and ratio (K) for the instants
    /// taken; returns (the first instant not taken, or K; why; the least
    /// ratio of the instants taken, NaN where one is NaN).
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
        setup: &Bound<'py, SensSetup>,
        data: Bound<'py, PyArray2<f64>>,
        ratio: Bound<'py, PyArray1<f64>>,
    ) -> PyResult<(usize, u8, f64)> {
        let (n, kk) = (self.kin.n, times.len());
        let bad = |what: &str| value_error(format!("march_sensitivity: {what} has the wrong shape"));
        if self.layout.count >= 2 && matches!(self.layout.shape, Shape::Blocks { .. }) {
            return Err(value_error("march_sensitivity: a model marched in parts (Plan.sensitivity serves it)"));
        }
        let setup = setup.get();
        if !Arc::ptr_eq(&setup.1, &self.layout) {
            return Err(value_error("march_sensitivity: the set-up is not this model's (another plan made it)"));
        }
        let prepared = &setup.0;
        let times = vec1(&times);
        let times: &[f64] = &times;
        let stages = if settings.4 { 3 } else { 1 };
        let mut state = state.try_borrow_mut()?;
        let mut outputs = MarchOutputs::of(&out, &figures, &ints, kk)?;
        let (mut data, mut ratio) = (writable(&data, "data")?, writable(&ratio, "ratio")?);
        let width = prepared.width();
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
        let mut room = self.room();
        let at_room = &mut room;
        let spare = setup.2.lock().ok().and_then(|mut s| s.take());
        let (end, why, least, spare) = guard(py, move || {
            let mut at = crate::sensitivity::Instants::enter(prepared, layout, stages, spare)?;
            let watch = Watch::new(seconds, Some(&poll));
            let (end, why) = {
                let mut hook =
                    |k: usize, s: &march::MarchState, f: &mut Factors, e: &[C64], pieces: &[Piece], pivot: f64| {
                        let x: [&[f64]; 3] = [&s.q, &s.qd, &s.qdd];
                        let row = &mut data[k * width..(k + 1) * width];
                        ratio[k] = at.at(times[k], &x[..stages], e, pieces, f, pivot, row);
                    };
                march::run_hooked(kin, layout, times, 0, st, &settings, out, &watch, true, at_room, Some(&mut hook))
            };
            let spare = at.leave(prepared, layout);
            // the least ratio of the instants taken, NaN where one is
            let least = ratio[..end.min(ratio.len())].iter().fold(f64::INFINITY, |a, &r| {
                if a.is_nan() || r.is_nan() {
                    f64::NAN
                } else {
                    a.min(r)
                }
            });
            Ok((end, why, least, spare))
        })?;
        self.keep(room);
        if let Ok(mut kept) = setup.2.lock() {
            *kept = Some(spare);
        }
        if why == Why::Interrupted {
            return Err(raised(&signal));
        }
        Ok((end, why as u8, least))
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
        let whole = layout.count < 2 || !matches!(layout.shape, Shape::Blocks { .. });
        let mut room = if whole { Some(self.room()) } else { None };
        let at_room = room.as_mut();
        let (end, why) = guard(py, move || {
            let watch = Watch::new(seconds, Some(&poll));
            if let Some(room) = at_room {
                return Ok(march::run(kin, layout, times, k, st, &settings, out, &watch, true, room));
            }
            let parts = parts.get_or_init(|| crate::parts::split(kin, layout)).as_ref()?;
            Ok(crate::parts::run_parts(parts, layout.sign, times, k, st, &settings, out, &watch))
        })?;
        if let Some(room) = room {
            self.keep(room);
        }
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
            let Ok(o) = march::step(&mut ops, st, t, &s, mode, &mut march::Work::new(kin.n, kin.smooth));
            Ok((o, ops.q, ops.counts))
        })?;
        Ok(Outcome::new(py, o, q, counts))
    }
}

/// Polls for a signal with the GIL re-acquired: true when one arrived, its
/// exception (KeyboardInterrupt for Ctrl-C) kept in `signal`.
pub(crate) fn signalled(signal: &std::sync::Mutex<Option<PyErr>>) -> bool {
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
pub(crate) fn raised(signal: &std::sync::Mutex<Option<PyErr>>) -> PyErr {
    let e = signal.lock().ok().and_then(|mut s| s.take());
    e.unwrap_or_else(|| pyo3::exceptions::PyKeyboardInterrupt::new_err(""))
}

pub(crate) fn mode_of(code: u8) -> PyResult<march::Mode> {
    march::Mode::ALL.get(code as usize).copied().ok_or_else(|| value_error(format!("step: no mode {code}")))
}

pub(crate) fn march_settings(s: (f64, usize, f64, f64, bool)) -> march::Settings {
    march::Settings { tolerance: s.0, max_iterations: s.1, max_step: s.2, floor: s.3, rates: s.4 }
}

/// Plan.march's outputs (out, figures, ints, as it documents) for K
/// instants, and room for the det signs.
pub(crate) struct MarchOutputs<'py> {
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

impl Plan {
    /// The march's room, set as made fresh: the one the last march left
    /// where no other march holds it, else a new one.
    fn room(&self) -> march::Room {
        let fresh = self.fresh.get_or_init(|| march::Room::new(&self.kin, &self.layout));
        match self.spare.lock().ok().and_then(|mut spare| spare.take()) {
            Some(mut room) => {
                room.clone_from(fresh);
                room
            }
            None => fresh.clone(),
        }
    }

    /// Keeps the room a march leaves for the next one.
    fn keep(&self, room: march::Room) {
        if let Ok(mut spare) = self.spare.lock() {
            *spare = Some(room);
        }
    }

    /// The separate pass (crate::sensitivity::sensitivities) from a set-up:
    /// x 1 to 3 arrays (K, n) at times; returns (data (K, P W), ratio (K)).
    #[allow(clippy::type_complexity)]
    fn separate<'py>(
        &self,
        py: Python<'py>,
        prepared: &crate::sensitivity::Prepared,
        times: PyReadonlyArray1<'py, f64>,
        x: Vec<PyReadonlyArray2<'py, f64>>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyArray1<f64>>)> {
        let times = times.as_slice()?.to_vec();
        let (n, kk) = (self.kin.n, times.len());
        let mut xs = Vec::new();
        for (k, a) in x.iter().enumerate() {
            let (v, r) = rows(a, n, &format!("sensitivity: x[{k}]"))?;
            if r != kk {
                return Err(pyo3::exceptions::PyValueError::new_err("sensitivity: one row per instant expected"));
            }
            xs.push(v.to_vec());
        }
        let (width, layout) = (prepared.width(), &self.layout);
        let (data, ratio) = guard(py, move || {
            let mut ratio = vec![0.0; kk];
            let x: Vec<&[f64]> = xs.iter().map(|v| v.as_slice()).collect();
            let mut data = vec![0.0; kk * width];
            crate::sensitivity::sensitivities(prepared, layout, &times, &x, &mut data, &mut ratio)?;
            Ok((data, ratio))
        })?;
        Ok((out2(py, data, kk, width)?, PyArray1::from_vec(py, ratio)))
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
pub(crate) struct SensInputs {
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

    /// The set-up: the model from the tables (every function and outline
    /// its own number), checked against the plan's, with the parameters'
    /// groups (crate::sensitivity::Prepared).
    fn prepare(self) -> Result<crate::sensitivity::Prepared, String> {
        let own = Kin::new(self.n, self.families, &self.functions, &self.outlines, self.angles)?;
        if (own.m, own.nnz) != self.m_nnz {
            return Err("sensitivity: the tables are not the model's".to_string());
        }
        let columns = (&self.src[..], &self.pc[..], &self.local[..], &self.dlocal[..]);
        crate::sensitivity::Prepared::new(own, &self.parts, &self.rows, &self.cols, columns)
    }
}

/// A model's sensitivities set up for some parameters (Plan.sensitivity_setup;
/// crate::sensitivity::Prepared) and the layout of the plan that made it:
/// read by that plan's march_sensitivity alone.
#[pyclass(frozen, module = "kinem._core")]
pub struct SensSetup(
    crate::sensitivity::Prepared,
    Arc<crate::lu::Layout>,
    /// the room the last march_sensitivity's run of instants left (crate::sensitivity::Room)
    std::sync::Mutex<Option<crate::sensitivity::Room>>,
);
