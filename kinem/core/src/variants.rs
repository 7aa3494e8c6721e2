//! Many variants of one mechanism marched together (issue 31, "Variants as
//! lanes"; docs/solver.md, "Variants"). The model's tables are affine in the
//! case's numbers (kinem.sensitivity), so a variant's tables are the base
//! tables plus sum_p dv_p tangent_p over its design parameters' moves dv:
//! each variant's model is formed here from the base and the tangents,
//! marched by the one march (crate::march, through `run_rows`) from the
//! nominal's first state on the nominal's linear structure, and only the
//! asked columns (crate::columns) written into one (variants, instants,
//! columns) array; a group of WIDTH variants marched as lanes has its
//! tables formed over lanes at once (`moved_lanes`) and no scalar models.
//! Variants run on the thread pool, each converging and
//! failing on its own; a deadline or a signal (crate::watch) stops them all.
use crate::accept::Why;
use crate::columns::Columns;
use crate::lanes::{self, WIDTH};
use crate::lu::Layout;
use crate::march::{self, MarchState, Settings};
use crate::model::Kin;
use crate::table::Table;
use crate::watch::Watch;
use num_complex::Complex64 as C64;
use rayon::prelude::*;
use std::collections::HashMap;
use std::ops::{AddAssign, Mul};

/// A model's tables (every function and outline its own number:
/// kinem.moved_tables._tables) and their tangents along each design parameter.
pub struct Tables {
    pub n: usize,
    pub angles: Vec<i64>,
    pub families: Vec<(String, Table)>,
    pub functions: Table,
    pub outlines: Table,
    /// per parameter: the families' tangents (in the families' order), the functions', the outlines'
    pub tangents: Vec<(Vec<Table>, Table, Table)>,
}

/// columns[key][lane + stride i] += tangent[key][i] dv for every column of
/// the tangent (stride 1, lane 0: a table's own columns; stride WIDTH: one
/// lane of columns over lanes).
fn add<T: Copy + AddAssign + Mul<f64, Output = T>>(
    columns: &mut HashMap<String, Vec<T>>,
    tangent: &HashMap<String, Vec<T>>,
    stride: usize,
    lane: usize,
    dv: f64,
) -> Result<(), String> {
    for (key, d) in tangent {
        let v = columns.get_mut(key).filter(|v| v.len() == d.len() * stride);
        let v = v.ok_or_else(|| format!("variants: tangent column '{key}' fits no table column"))?;
        v.iter_mut().skip(lane).step_by(stride).zip(d).for_each(|(x, &dx)| *x += dx * dv);
    }
    Ok(())
}

/// base + sum_p dv_p tangent_p over the real and complex columns (a column
/// without a tangent keeps its values).
fn moved<'a>(base: &Table, tangents: impl Iterator<Item = (&'a Table, f64)>) -> Result<Table, String> {
    let mut out = base.clone();
    for (t, dv) in tangents.filter(|&(_, dv)| dv != 0.0) {
        add(&mut out.reals, &t.reals, 1, 0, dv)?;
        add(&mut out.complex, &t.complex, 1, 0, dv)?;
    }
    Ok(out)
}

/// WIDTH variants' tables at once, as one table over lanes (the columns'
/// values lane by lane in d_reals and d_complex, as crate::lanes::wide_kin
/// reads them; lane 0's in reals and complex): each entry of lane l is
/// `moved`'s for that lane, the same operations in the same order (to the
/// bit), without a table per variant.
fn moved_lanes<'a, 'v>(
    base: &Table,
    tangents: impl Iterator<Item = &'a Table>,
    dv: &dyn Fn(usize) -> &'v [f64],
) -> Result<Table, String> {
    fn spread<T: Copy>(v: &[T]) -> Vec<T> {
        v.iter().flat_map(|&x| [x; WIDTH]).collect()
    }
    let mut out = base.clone();
    out.d_reals = base.reals.iter().map(|(k, v)| (k.clone(), spread(v))).collect();
    out.d_complex = base.complex.iter().map(|(k, v)| (k.clone(), spread(v))).collect();
    for (p, t) in tangents.enumerate() {
        let lanes: Vec<(usize, f64)> = (0..WIDTH).map(|l| (l, dv(l)[p])).filter(|&(_, d)| d != 0.0).collect();
        if lanes.is_empty() {
            continue;
        }
        for &(l, dv) in &lanes {
            add(&mut out.d_reals, &t.reals, WIDTH, l, dv)?;
            add(&mut out.d_complex, &t.complex, WIDTH, l, dv)?;
        }
    }
    for (key, v) in out.reals.iter_mut() {
        *v = out.d_reals[key].iter().step_by(WIDTH).copied().collect();
    }
    for (key, v) in out.complex.iter_mut() {
        *v = out.d_complex[key].iter().step_by(WIDTH).copied().collect();
    }
    Ok(out)
}

impl Tables {
    /// The model over lanes of the WIDTH variants whose parameters moved by dv(l) from the nominal.
    pub fn kin_lanes<'v>(&self, dv: &dyn Fn(usize) -> &'v [f64]) -> Result<Kin<lanes::W>, String> {
        let tangents = &self.tangents;
        let families = self
            .families
            .iter()
            .enumerate()
            .map(|(k, (kind, t))| Ok((kind.clone(), moved_lanes(t, tangents.iter().map(|p| &p.0[k]), dv)?)))
            .collect::<Result<Vec<_>, String>>()?;
        let functions = moved_lanes(&self.functions, tangents.iter().map(|p| &p.1), dv)?;
        let outlines = moved_lanes(&self.outlines, tangents.iter().map(|p| &p.2), dv)?;
        Kin::new(self.n, families, &functions, &outlines, self.angles.clone())
    }

    /// The tables of the variant whose parameters moved by dv from the nominal.
    pub fn moved(&self, dv: &[f64]) -> Result<crate::lanes::Tables, String> {
        let tangents = &self.tangents;
        let families = self
            .families
            .iter()
            .enumerate()
            .map(|(k, (kind, t))| {
                Ok((kind.clone(), moved(t, tangents.iter().map(|p| &p.0[k]).zip(dv.iter().copied()))?))
            })
            .collect::<Result<Vec<_>, String>>()?;
        let functions = moved(&self.functions, tangents.iter().map(|p| &p.1).zip(dv.iter().copied()))?;
        let outlines = moved(&self.outlines, tangents.iter().map(|p| &p.2).zip(dv.iter().copied()))?;
        Ok((families, functions, outlines))
    }

    /// The model of the variant whose parameters moved by dv from the nominal.
    pub fn kin(&self, dv: &[f64]) -> Result<Kin, String> {
        let (families, functions, outlines) = self.moved(dv)?;
        Kin::new(self.n, families, &functions, &outlines, self.angles.clone())
    }

    pub fn count(&self) -> usize {
        self.tangents.len()
    }
}

/// The asked columns: sources `src` as crate::columns reads them from
/// `stages` stages (1: positions; 2, 3: with velocities, accelerations),
/// the named points' body columns `pc`, local coordinates `local` and
/// their tangents `dlocal` (per parameter, one per point).
pub struct Asked<'a> {
    pub stages: usize,
    pub src: &'a [usize],
    pub pc: &'a [usize],
    pub local: &'a [C64],
    pub dlocal: &'a [C64],
}

/// Per variant, written: its columns (instants, columns; NaN from its
/// first instant not taken on), its first state (n; NaN when it did not
/// assemble), the first instant not taken (instants: none), why (the code
/// of accept::Why) and the det sign of its first state (0: none).
pub struct Written<'a> {
    pub data: &'a mut [f64],
    pub start: &'a mut [f64],
    pub end: &'a mut [i64],
    pub why: &'a mut [u8],
    pub det: &'a mut [i8],
}

/// What every variant shares: the tables, the nominal's linear structure,
/// the output instants, the nominal's first state, the march's settings,
/// the asked columns and the watch.
pub struct Batch<'a> {
    pub tables: &'a Tables,
    pub layout: &'a Layout,
    pub times: &'a [f64],
    pub q0: &'a [f64],
    pub settings: &'a Settings,
    pub asked: &'a Asked<'a>,
    pub watch: &'a Watch<'a>,
    /// march WIDTH variants at a time as lanes (crate::lanes) where the model suits
    pub lanes: bool,
}

/// Marches every variant (values: N rows of the parameters' moves from the
/// nominal) over the batch's instants from the nominal's first state.
pub fn run(b: &Batch, values: &[f64], out: Written) -> Result<(), String> {
    let (n, kk, p, w) = (b.tables.n, b.times.len(), b.tables.count(), b.asked.src.len());
    let count = out.end.len();
    if kk == 0 || w == 0 || n == 0 || b.q0.len() != n || values.len() != count * p {
        return Err("variants: sizes do not fit".into());
    }
    if out.data.len() != count * kk * w
        || out.start.len() != count * n
        || out.why.len() != count
        || out.det.len() != count
    {
        return Err("variants: outputs of the wrong size".into());
    }
    let rows = Rows { cols: Columns::new(n, b.asked.stages, b.asked.src, b.asked.pc), stages: b.asked.stages, w };
    // groups of WIDTH variants as lanes, or of one (and the last, short, group) each alone
    let width = if b.lanes && lanes::suits(&b.tables.outlines) { WIDTH } else { 1 };
    let results: Vec<Vec<Verdict>> = b.watch.around(|| {
        out.data
            .par_chunks_mut(width * kk * w)
            .zip(out.start.par_chunks_mut(width * n))
            .enumerate()
            .map_init(
                || Scratch::new(n, b.asked),
                |scratch, (g, (data, start))| {
                    let (first, count) = (g * width, start.len() / n);
                    let dv = |i: usize| &values[(first + i) * p..(first + i + 1) * p];
                    if count == WIDTH && width == WIDTH {
                        return group(b, &rows, scratch, &dv, data, start);
                    }
                    let parts = data.chunks_mut(kk * w).zip(start.chunks_mut(n)).enumerate();
                    parts.map(|(i, (data, start))| one(b, &rows, scratch, dv(i), data, start)).collect()
                },
            )
            .collect()
    });
    for (v, r) in results.into_iter().flatten().enumerate() {
        let (end, why, det) = r?;
        out.end[v] = end as i64;
        out.why[v] = why as u8;
        out.det[v] = det;
    }
    Ok(())
}

/// WIDTH variants marched as lanes (crate::lanes), each lane's columns
/// written at every instant it takes; a lane that needs it alone marches
/// alone (its rows written again).
fn group<'v>(
    b: &Batch,
    rows: &Rows,
    s: &mut Scratch,
    dv: &dyn Fn(usize) -> &'v [f64],
    data: &mut [f64],
    start: &mut [f64],
) -> Vec<Verdict> {
    let (n, kk, w) = (b.tables.n, b.times.len(), b.asked.src.len());
    // the model over lanes only: no lane needs a scalar model (its Newton runs over the lanes too)
    let wide = match b.tables.kin_lanes(dv) {
        Ok(x) => x,
        Err(e) => return vec![Err(e)],
    };
    let locals: Vec<Vec<C64>> = (0..WIDTH).map(|l| local(b.asked, dv(l))).collect();
    let mut parts: Vec<(&mut [f64], &mut [f64])> = data.chunks_mut(kk * w).zip(start.chunks_mut(n)).collect();
    let pts = &mut s.pts;
    let marched = lanes::march(&wide, b.layout, b.times, b.q0, b.settings, b.watch, |l, k, st| {
        let (data, start) = &mut parts[l];
        rows.put(&locals[l], pts, k, st, data, start)
    });
    parts
        .into_iter()
        .enumerate()
        .map(|(i, (data, start))| match marched[i] {
            Some((end, why, det)) => Ok(rows.finish(data, start, end, why, det)),
            None => one(b, rows, s, dv(i), data, start),
        })
        .collect()
}

/// A variant's (first instant not taken, why, det sign at its first state).
type Verdict = Result<(usize, Why, i8), String>;

/// A thread's buffers for the march of one variant after another: the
/// march's state and one instant's named points (nothing per instant: the
/// columns are written as the instants are taken).
struct Scratch {
    state: MarchState,
    pts: Vec<f64>,
}

impl Scratch {
    fn new(n: usize, asked: &Asked) -> Scratch {
        Scratch { state: MarchState::new(&vec![0.0; n]), pts: vec![0.0; 2 * asked.stages * asked.pc.len()] }
    }
}

/// One variant: (the first instant not taken, why, det sign at its first state).
fn one(
    b: &Batch,
    rows: &Rows,
    s: &mut Scratch,
    dv: &[f64],
    data: &mut [f64],
    start: &mut [f64],
) -> Result<(usize, Why, i8), String> {
    let kin = b.tables.kin(dv)?;
    let local = local(b.asked, dv);
    // the state the march starts from: the estimates q0, no rates, no history
    s.state.q.copy_from_slice(b.q0);
    let (mut counts, mut det) = ([0i64; 2], 0i8);
    let pts = &mut s.pts;
    // k = 0: the variant assembles from the state's q
    let (end, why) = march::run_rows(
        &kin,
        b.layout,
        b.times,
        0,
        &mut s.state,
        b.settings,
        b.watch,
        false,
        &mut counts,
        false,
        &mut march::Room::new(&kin, b.layout),
        |k, st, o, _| {
            if k == 0 {
                det = o.det as i8;
            }
            rows.put(&local, pts, k, st, data, start)
        },
    );
    Ok(rows.finish(data, start, end, why, det))
}

/// A variant's named points' local coordinates, moved by dv along their tangents.
fn local(asked: &Asked, dv: &[f64]) -> Vec<C64> {
    (0..asked.local.len())
        .map(|j| asked.local[j] + (0..dv.len()).map(|k| asked.dlocal[k * asked.local.len() + j] * dv[k]).sum::<C64>())
        .collect()
}

/// The asked columns' writer: crate::columns's layout of them, the stages
/// they read and their count a row.
struct Rows<'a> {
    cols: Columns<'a>,
    stages: usize,
    w: usize,
}

impl Rows<'_> {
    /// Instant k taken by a variant: its asked columns (from the state, at
    /// its moved points `local`) into its row k of data; at k = 0, q into
    /// its first state.
    fn put(&self, local: &[C64], pts: &mut [f64], k: usize, st: &MarchState, data: &mut [f64], start: &mut [f64]) {
        let x: [&[f64]; 3] = [&st.q, &st.qd, &st.qdd];
        self.cols.row(&x[..self.stages], local, pts, &mut data[k * self.w..(k + 1) * self.w]);
        if k == 0 {
            start.copy_from_slice(&st.q);
        }
    }

    /// A variant's march ended at `end`: its rows from there NaN (they hold
    /// an earlier variant's values or none), its first state NaN when it did
    /// not assemble; (end, why, det sign at its first state).
    fn finish(&self, data: &mut [f64], start: &mut [f64], end: usize, why: Why, det: i8) -> (usize, Why, i8) {
        data[end * self.w..].fill(f64::NAN);
        if end == 0 {
            start.fill(f64::NAN);
        }
        (end, why, if end > 0 { det } else { 0 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(reals: &[(&str, Vec<f64>)], complex: &[(&str, Vec<C64>)]) -> Table {
        let mut t = Table::default();
        t.ints.insert("i".into(), vec![1, 2]);
        for (k, v) in reals {
            t.reals.insert(k.to_string(), v.clone());
        }
        for (k, v) in complex {
            t.complex.insert(k.to_string(), v.clone());
        }
        t
    }

    #[test]
    fn a_variants_table_is_the_base_plus_the_moves_along_the_tangents() {
        let base = table(&[("l", vec![1.0, 2.0]), ("r", vec![5.0, 6.0])], &[("s", vec![C64::new(1.0, -1.0); 2])]);
        let t1 = table(&[("l", vec![0.5, 0.0])], &[("s", vec![C64::new(0.0, 2.0); 2])]);
        let t2 = table(&[("l", vec![0.0, 1.0])], &[]);
        let m = moved(&base, [(&t1, 2.0), (&t2, -3.0)].into_iter()).unwrap();
        assert_eq!(m.reals["l"], vec![2.0, -1.0]);
        assert_eq!(m.reals["r"], base.reals["r"]);
        assert_eq!(m.complex["s"], vec![C64::new(1.0, 3.0); 2]);
        assert_eq!(m.ints["i"], base.ints["i"]);
        // a tangent column the table has not, or of another length: refused
        let stray = table(&[("x", vec![1.0, 1.0])], &[]);
        assert!(moved(&base, [(&stray, 1.0)].into_iter()).is_err());
        let short = table(&[("l", vec![1.0])], &[]);
        assert!(moved(&base, [(&short, 1.0)].into_iter()).is_err());
    }

    /// WIDTH variants' tables formed at once over lanes equal, to the bit,
    /// each variant's own (`moved`) stacked as crate::lanes reads them.
    #[test]
    fn the_tables_over_lanes_are_each_variants_stacked() {
        let base = table(&[("l", vec![1.0, 2.0]), ("r", vec![5.0, 6.0])], &[("s", vec![C64::new(1.0, -1.0); 2])]);
        let t1 = table(&[("l", vec![0.5, 0.3])], &[("s", vec![C64::new(0.1, 2.0); 2])]);
        let t2 = table(&[("l", vec![0.7, 1.0])], &[]);
        let dvs: Vec<Vec<f64>> =
            (0..WIDTH).map(|l| vec![0.1 * l as f64 - 0.2, if l == 3 { 0.0 } else { 0.3 / (1.0 + l as f64) }]).collect();
        let dv = |l: usize| -> &[f64] { &dvs[l] };
        let wide = moved_lanes(&base, [&t1, &t2].into_iter(), &dv).unwrap();
        let each: Vec<Table> =
            (0..WIDTH).map(|l| moved(&base, [(&t1, dvs[l][0]), (&t2, dvs[l][1])].into_iter()).unwrap()).collect();
        for (key, v) in &wide.d_reals {
            for (i, x) in v.iter().enumerate() {
                assert_eq!(x.to_bits(), each[i % WIDTH].reals[key][i / WIDTH].to_bits(), "{key} {i}");
            }
        }
        for (key, v) in &wide.d_complex {
            for (i, x) in v.iter().enumerate() {
                let y = each[i % WIDTH].complex[key][i / WIDTH];
                assert!(x.re.to_bits() == y.re.to_bits() && x.im.to_bits() == y.im.to_bits(), "{key} {i}");
            }
        }
        assert_eq!(wide.reals, each[0].reals);
        assert_eq!(wide.complex, each[0].complex);
        assert_eq!(wide.d_reals["r"], vec![5.0; WIDTH].into_iter().chain(vec![6.0; WIDTH]).collect::<Vec<_>>());
    }
}
