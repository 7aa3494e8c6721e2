//! Many variants of one mechanism marched together (issue 31, "Variants as
//! lanes"; docs/solver.md, "Variants"). The model's tables are affine in the
//! case's numbers (kinem.sensitivity), so a variant's tables are the base
//! tables plus sum_p dv_p tangent_p over its design parameters' moves dv:
//! each variant's model is formed here from the base and the tangents,
//! marched by the one march (crate::march, through `march_one`) from the
//! nominal's first state on the nominal's linear structure, and only the
//! asked columns (crate::columns) written into one (variants, instants,
//! columns) array; a group of WIDTH variants marched as lanes has its
//! tables formed over lanes at once (`moved_lanes`) and no scalar models.
//! Variants run on the thread pool, each converging and
//! failing on its own; a deadline or a signal (crate::watch) stops them all.
use crate::accept::Why;
use crate::columns::columns;
use crate::lanes::{self, WIDTH};
use crate::lu::Layout;
use crate::march::{self, MarchState, Out, Settings};
use crate::model::Kin;
use crate::table::Table;
use crate::watch::Watch;
use num_complex::Complex64 as C64;
use rayon::prelude::*;
use std::collections::HashMap;
use std::ops::{AddAssign, Mul};
use std::sync::Mutex;

/// A model's tables (every function and outline its own number:
/// kinem.sensitivity._tables) and their tangents along each design parameter.
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
    // groups of WIDTH variants as lanes, or of one (and the last, short, group) each alone
    let width = if b.lanes && lanes::suits(&b.tables.outlines) { WIDTH } else { 1 };
    // rayon makes a scratch per job it splits off (many per thread): they are
    // kept in a pool, so a batch makes as many as run at once
    let pool = Mutex::new(Vec::new());
    let results: Vec<Vec<Verdict>> = b.watch.around(|| {
        out.data
            .par_chunks_mut(width * kk * w)
            .zip(out.start.par_chunks_mut(width * n))
            .enumerate()
            .map_init(
                || Pooled::take(&pool, || Scratch::new(n, kk, b.asked.stages)),
                |scratch, (g, (data, start))| {
                    let scratch = scratch.get();
                    let (first, count) = (g * width, start.len() / n);
                    let dv = |i: usize| &values[(first + i) * p..(first + i + 1) * p];
                    if count == WIDTH && width == WIDTH {
                        return group(b, scratch, &dv, data, start);
                    }
                    let parts = data.chunks_mut(kk * w).zip(start.chunks_mut(n)).enumerate();
                    parts.map(|(i, (data, start))| one(b, scratch, dv(i), data, start)).collect()
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

/// WIDTH variants marched as lanes (crate::lanes); a lane that needs it alone marches alone.
fn group<'v>(
    b: &Batch,
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
    let marched = lanes::march(&wide, b.layout, b.times, b.q0, b.settings, b.watch, &mut s.lanes);
    let parts = data.chunks_mut(kk * w).zip(start.chunks_mut(n)).enumerate();
    parts
        .map(|(i, (data, start))| match marched[i] {
            Some((end, why, det)) => Ok(write(b, dv(i), &s.lanes[i], end, why, det, data, start)),
            None => one(b, s, dv(i), data, start),
        })
        .collect()
}

/// A variant's (first instant not taken, why, det sign at its first state).
type Verdict = Result<(usize, Why, i8), String>;

/// A thread's buffers for the march of one variant after another: the
/// coordinates at every instant (Q, and QD, QDD with rates), the march's
/// per-instant figures and its state.
struct Scratch {
    x: Vec<f64>,
    iterations: Vec<i64>,
    residual: Vec<f64>,
    pivot: Vec<f64>,
    det: Vec<i8>,
    state: MarchState,
    /// each lane's coordinates at every instant, as x
    lanes: Vec<Vec<f64>>,
}

/// A scratch taken from a pool, put back when dropped.
struct Pooled<'p>(Option<Scratch>, &'p Mutex<Vec<Scratch>>);

impl<'p> Pooled<'p> {
    fn take(pool: &'p Mutex<Vec<Scratch>>, make: impl FnOnce() -> Scratch) -> Self {
        let kept = pool.lock().ok().and_then(|mut v| v.pop());
        Pooled(Some(kept.unwrap_or_else(make)), pool)
    }

    fn get(&mut self) -> &mut Scratch {
        self.0.as_mut().expect("a pooled scratch is held until dropped")
    }
}

impl Drop for Pooled<'_> {
    fn drop(&mut self) {
        if let (Some(s), Ok(mut v)) = (self.0.take(), self.1.lock()) {
            v.push(s);
        }
    }
}

impl Scratch {
    fn new(n: usize, kk: usize, stages: usize) -> Scratch {
        // zeroed by the allocator (pages touched only when written), never copied:
        // a thread's scratch is made before its first group even when a stop has come
        let len = if stages > 1 { 3 } else { 1 } * kk * n;
        Scratch {
            lanes: (0..WIDTH).map(|_| vec![0.0; len]).collect(),
            x: vec![0.0; len],
            iterations: vec![0; kk],
            residual: vec![0.0; kk],
            pivot: vec![0.0; kk],
            det: vec![0; kk],
            state: MarchState::new(&vec![0.0; n]),
        }
    }
}

/// One variant: (the first instant not taken, why, det sign at its first state).
fn one(
    b: &Batch,
    s: &mut Scratch,
    dv: &[f64],
    data: &mut [f64],
    start: &mut [f64],
) -> Result<(usize, Why, i8), String> {
    let kin = b.tables.kin(dv)?;
    let times = b.times;
    let (n, kk) = (b.tables.n, times.len());
    let (oq, rest) = s.x.split_at_mut(kk * n);
    let (oqd, oqdd) = rest.split_at_mut(rest.len() / 2);
    // the state the march starts from: the estimates q0, no rates, no history
    s.state.q.copy_from_slice(b.q0);
    let mut counts = [0i64; 2];
    let o = Out {
        q: oq,
        qd: oqd,
        qdd: oqdd,
        iterations: &mut s.iterations,
        residual: &mut s.residual,
        pivot: &mut s.pivot,
        det: &mut s.det,
        counts: &mut counts,
        first: 0,
    };
    let (end, why) = march_one(&kin, b, &mut s.state, o);
    Ok(write(b, dv, &s.x, end, why, if end > 0 { s.det[0] } else { 0 }, data, start))
}

/// A variant's asked columns from its coordinates x (Q, and QD, QDD with
/// rates, at every instant) up to `end`, NaN after; its first state (NaN
/// when it did not assemble); (end, why, det sign at its first state).
#[allow(clippy::too_many_arguments)]
fn write(
    b: &Batch,
    dv: &[f64],
    x: &[f64],
    end: usize,
    why: Why,
    det: i8,
    data: &mut [f64],
    start: &mut [f64],
) -> (usize, Why, i8) {
    let asked = b.asked;
    let (n, kk, stages) = (b.tables.n, b.times.len(), asked.stages);
    let local: Vec<C64> = (0..asked.local.len())
        .map(|j| asked.local[j] + (0..dv.len()).map(|k| asked.dlocal[k * asked.local.len() + j] * dv[k]).sum::<C64>())
        .collect();
    // the instants taken (rows from `end` on hold an earlier variant's values or none: NaN)
    let x: Vec<&[f64]> = x.chunks(kk * n).take(stages).map(|s| &s[..end * n]).collect();
    let (taken, rest) = data.split_at_mut(end * asked.src.len());
    columns(&x, n, asked.src, asked.pc, &local, taken);
    rest.fill(f64::NAN);
    if end > 0 {
        start.copy_from_slice(&x[0][..n]);
    } else {
        start.fill(f64::NAN);
    }
    (end, why, if end > 0 { det } else { 0 })
}

/// The one call of the march (k = 0: the variant assembles from the state's q).
fn march_one(kin: &Kin, b: &Batch, st: &mut MarchState, out: Out) -> (usize, Why) {
    march::run(kin, b.layout, b.times, 0, st, b.settings, out, b.watch, false)
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
