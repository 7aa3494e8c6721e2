//! A compiled model's evaluation: its families laid end to end (rows and
//! Jacobian entries in the order of kinem.model.Model), the driving
//! functions and outlines they read, and the angle columns whose e^{i q}
//! the families share.
use crate::families::{coordinate_columns, At, Family, Shared};
use crate::functions::Functions;
use crate::outline::{Outlines, Piece};
use crate::real::{cis, Real};
use crate::table::Table;
use num_complex::{Complex, Complex64 as C64};

/// Over S = Dual (crate::real): the same model with its tables' tangents
/// along one design parameter (crate::sensitivity).
pub struct Kin<S = f64> {
    pub n: usize,
    pub m: usize,
    pub nnz: usize,
    pub families: Vec<Family<S>>,
    pub row_off: Vec<usize>,   // first row of each family (and m at the end)
    pub entry_off: Vec<usize>, // first Jacobian entry of each family (and nnz)
    pub angles: Vec<usize>,    // the angle columns (bodies' phi, outlines' theta)
    pub functions: Functions<S>,
    pub outlines: Outlines<S>,
    pub time_dependent: Vec<usize>, // families whose nu may be non-zero
    /// the simple families' driver rows (row, function): nu = f'(t) there
    drivers: Vec<(usize, usize)>,
    /// the other families whose nu may be non-zero
    timed: Vec<usize>,
    /// nu is the same at every instant: no timed family, every driver's
    /// d' the same figure at every t (Functions::rate_fixed; a crank at a
    /// constant speed): crate::march::Native writes it once
    pub nu_fixed: bool,
    /// the families `gamma_over` visits: all but the simple ones whose rows
    /// it would write +0 at every instant (Simple::gamma_still: grounds and
    /// cranks at a constant speed), which a room of zeros or of this
    /// model's earlier gamma already holds
    gamma_moving: Vec<usize>,
    /// the families `jac_over` visits: all but the simple ones without a
    /// point or relative row, whose entries are constants it never writes
    /// (Family::jac_moves)
    jac_moving: Vec<usize>,
    /// the entries `jac_over` never writes (`over_kept`, made at its first call)
    kept: std::sync::OnceLock<Vec<bool>>,
    /// no family reads an outline and no driving function is a table's
    /// pieces: q(t) as smooth as the drivers' polynomials and harmonics
    /// (the march's Hermite start then carries its last error: step::Bias)
    pub smooth: bool,
    /// the tables it was built from (Kin::split builds its parts from them)
    tables: Vec<(String, Table)>,
    function_table: Table,
    outline_table: Table,
}

impl<S: Real> Kin<S> {
    pub fn new(
        n: usize,
        families: Vec<(String, Table)>,
        functions_table: &Table,
        outlines_table: &Table,
        angles: Vec<i64>,
    ) -> Result<Kin<S>, String> {
        let functions = Functions::from_table(functions_table)?;
        let outlines = if outlines_table.ints.is_empty() && outlines_table.reals.is_empty() {
            Outlines::default()
        } else {
            Outlines::from_table(outlines_table)?
        };
        let mut list = Vec::new();
        let tables = families;
        for (kind, t) in &tables {
            list.push(Family::new(kind, t, n, functions.len(), outlines.len()).map_err(|e| format!("{kind}: {e}"))?);
        }
        let angles = angles
            .into_iter()
            .map(|a| {
                if a >= 0 && (a as usize) < n {
                    Ok(a as usize)
                } else {
                    Err(format!("angle column {a} outside 0..{n}"))
                }
            })
            .collect::<Result<Vec<_>, _>>()?;
        let (mut row_off, mut entry_off) = (vec![0], vec![0]);
        for f in &list {
            row_off.push(row_off.last().unwrap() + f.rows());
            entry_off.push(entry_off.last().unwrap() + f.entries());
        }
        let shared = Shared { functions: &functions, outlines: &outlines };
        for f in &mut list {
            f.bind(&shared);
        }
        let time_dependent: Vec<usize> = (0..list.len()).filter(|&k| list[k].time_dependent(&shared)).collect();
        let mut drivers = Vec::new();
        for (k, f) in list.iter().enumerate() {
            if let Family::Simple(f) = f {
                drivers.extend(f.drivers().iter().map(|&(r, g)| (row_off[k] + r, g)));
            }
        }
        let timed: Vec<usize> =
            time_dependent.iter().copied().filter(|&k| !matches!(list[k], Family::Simple(_))).collect();
        let nu_fixed = timed.is_empty() && drivers.iter().all(|&(_, f)| functions.rate_fixed(f));
        let still = |f: &Family<S>| matches!(f, Family::Simple(f) if f.gamma_still(&shared));
        let gamma_moving: Vec<usize> = (0..list.len()).filter(|&k| !still(&list[k])).collect();
        let jac_moving: Vec<usize> = (0..list.len()).filter(|&k| list[k].jac_moves()).collect();
        let pieces = functions_table.ints.get("kind").is_some_and(|k| k.contains(&crate::functions::PIECES));
        let smooth = !pieces && !list.iter().any(|f| f.piecewise());
        Ok(Kin {
            n,
            m: *row_off.last().unwrap(),
            nnz: *entry_off.last().unwrap(),
            families: list,
            row_off,
            entry_off,
            angles,
            functions,
            outlines,
            time_dependent,
            drivers,
            timed,
            nu_fixed,
            gamma_moving,
            jac_moving,
            kept: std::sync::OnceLock::new(),
            smooth,
            tables,
            function_table: functions_table.clone(),
            outline_table: outlines_table.clone(),
        })
    }

    fn shared(&self) -> Shared<'_, S> {
        Shared { functions: &self.functions, outlines: &self.outlines }
    }

    /// e[j] = e^{i q[j]} at the angle columns: once per configuration.
    #[inline]
    pub fn rotate(&self, q: &[S], e: &mut [Complex<S>]) {
        for &j in &self.angles {
            e[j] = cis(q[j]);
        }
    }

    pub fn phi(&self, at: &At<S>, out: &mut [S]) {
        assert!(out.len() >= self.m);
        let s = self.shared();
        for (f, r) in self.families.iter().zip(self.row_off.windows(2)) {
            // SAFETY: row_off ascends from 0 to m (new), out holds m (asserted above)
            f.phi(at, &s, unsafe { out.get_unchecked_mut(r[0]..r[1]) });
        }
    }

    pub fn jac(&self, at: &At<S>, out: &mut [S]) {
        assert!(out.len() >= self.nnz);
        let s = self.shared();
        for (f, e) in self.families.iter().zip(self.entry_off.windows(2)) {
            // SAFETY: entry_off ascends from 0 to nnz (new), out holds nnz (asserted above)
            f.jac(at, &s, unsafe { out.get_unchecked_mut(e[0]..e[1]) });
        }
    }

    /// `jac` into out that holds this model's Jacobian from an earlier
    /// `jac` (crate::march::Native's values, written by these two alone):
    /// the constant entries (Family::jac_over) are not written again, nor
    /// visited the families that write none (`jac_moving`).
    pub fn jac_over(&self, at: &At<S>, out: &mut [S]) {
        assert!(out.len() >= self.nnz);
        let s = self.shared();
        for &k in &self.jac_moving {
            // SAFETY: k < families.len() (new); entry_off holds families.len() + 1 ascending offsets
            // from 0 to nnz (new), out holds nnz (asserted above)
            unsafe {
                let f = self.families.get_unchecked(k);
                let (e0, e1) = (*self.entry_off.get_unchecked(k), *self.entry_off.get_unchecked(k + 1));
                f.jac_over(at, &s, out.get_unchecked_mut(e0..e1));
            }
        }
    }

    /// `jac_over`, the point-on-curve families keeping the piece each
    /// constraint's outline was taken on (crate::outline::Piece) in pieces,
    /// which holds m: a constraint's at its first row (crate::march::Native
    /// hands them to the design sensitivities at the same q). The same
    /// figures as `jac_over`; the other families by `jac` (every entry
    /// written again: Family::jac_over keeps `jac_over` its one caller, so
    /// the march's own code is as it was).
    pub fn jac_over_keeping(&self, at: &At<S>, out: &mut [S], pieces: &mut [Piece]) {
        assert!(out.len() >= self.nnz && pieces.len() >= self.m);
        let s = self.shared();
        for ((f, e), r) in self.families.iter().zip(self.entry_off.windows(2)).zip(self.row_off.windows(2)) {
            // SAFETY: entry_off ascends from 0 to nnz (new), out holds nnz (asserted above)
            let o = unsafe { out.get_unchecked_mut(e[0]..e[1]) };
            match f {
                Family::PointOnCurve(p) => p.jac_keeping(at, &s, o, &mut pieces[r[0]..r[1]]),
                _ => f.jac(at, &s, o),
            }
        }
    }

    /// Whether a family takes an outline's place in `jac` that
    /// `jac_over_keeping` keeps (a point-on-curve).
    pub fn keeps_pieces(&self) -> bool {
        self.families.iter().any(|f| matches!(f, Family::PointOnCurve(_)))
    }

    /// The Jacobian entries exactly zero at every configuration and time
    /// (Family::zero_entries), one flag per entry.
    pub fn zero_entries(&self) -> Vec<bool> {
        let mut zero = vec![false; self.nnz];
        for (f, e) in self.families.iter().zip(self.entry_off.windows(2)) {
            f.zero_entries(&mut zero[e[0]..e[1]]);
        }
        zero
    }

    pub fn nu(&self, t: f64, out: &mut [S]) {
        out.fill(S::zero());
        self.nu_over(t, out);
    }

    /// `nu` into a room whose rows outside the drivers' and the timed
    /// families' hold 0 (only `nu_over` writes it after it was zeroed:
    /// crate::march::Native's), without zeroing it again.
    #[inline]
    pub fn nu_over(&self, t: f64, out: &mut [S]) {
        let s = self.shared();
        for &(r, f) in &self.drivers {
            out[r] = self.functions.eval(f, t, 1);
        }
        for &k in &self.timed {
            self.families[k].nu(t, &s, &mut out[self.row_off[k]..self.row_off[k + 1]]);
        }
    }

    #[inline]
    pub fn gamma(&self, at: &At<S>, qd: &[S], out: &mut [S]) {
        self.gamma_with(at, qd, None, out)
    }

    /// `gamma`; `jac`: the Jacobian values at the same q (`jac`'s output),
    /// if at hand: the revolute joints read their rotated local points
    /// there (crate::march::Native: the rates follow the factorisation at
    /// the settled q), the same figures to the bit.
    pub fn gamma_with(&self, at: &At<S>, qd: &[S], jac: Option<&[S]>, out: &mut [S]) {
        self.gamma_as::<false>(at, qd, jac, out)
    }

    /// `gamma_with` into out that holds this model's gamma from an earlier
    /// one, or zeros (crate::march::Native's room, written by this alone):
    /// the constant rows (Family::gamma_over) are not written again, nor
    /// the families whose rows are +0 at every instant (`gamma_moving`).
    pub fn gamma_over(&self, at: &At<S>, qd: &[S], jac: Option<&[S]>, out: &mut [S]) {
        self.gamma_as::<true>(at, qd, jac, out)
    }

    /// `gamma_with`, or `gamma_over` when OVER.
    #[inline(always)]
    fn gamma_as<const OVER: bool>(&self, at: &At<S>, qd: &[S], jac: Option<&[S]>, out: &mut [S]) {
        assert!(out.len() >= self.m && jac.is_none_or(|v| v.len() >= self.nnz));
        let s = self.shared();
        if OVER {
            for &k in &self.gamma_moving {
                // SAFETY: k < families.len() (new); row_off and entry_off hold families.len() + 1
                // ascending offsets up to m and nnz; out holds m, jac nnz (asserted above)
                unsafe {
                    let f = self.families.get_unchecked(k);
                    let (r0, r1) = (*self.row_off.get_unchecked(k), *self.row_off.get_unchecked(k + 1));
                    let (e0, e1) = (*self.entry_off.get_unchecked(k), *self.entry_off.get_unchecked(k + 1));
                    let v = jac.map(|v| v.get_unchecked(e0..e1));
                    f.gamma_over(at, qd, &s, v, out.get_unchecked_mut(r0..r1));
                }
            }
            return;
        }
        for ((f, r), e) in self.families.iter().zip(self.row_off.windows(2)).zip(self.entry_off.windows(2)) {
            // SAFETY: row_off ascends from 0 to m, entry_off from 0 to nnz (new); out holds m, jac nnz (asserted above)
            let v = jac.map(|v| unsafe { v.get_unchecked(e[0]..e[1]) });
            f.gamma_with(at, qd, &s, v, unsafe { out.get_unchecked_mut(r[0]..r[1]) });
        }
    }
}

impl Kin {
    /// The Jacobian entries `jac_over` never writes (its constants, which
    /// `jac` wrote): those it leaves as they were at two configurations;
    /// made once per model (every march's `Native::new` asks).
    pub fn over_kept(&self) -> &[bool] {
        self.kept.get_or_init(|| self.kept_entries())
    }

    fn kept_entries(&self) -> Vec<bool> {
        // a NaN no evaluation makes (an operation's NaN is the default one)
        let mark = f64::from_bits(0x7ff8_dead_beef_0001);
        let mut kept = vec![true; self.nnz];
        for x in [0.0, 0.7] {
            let q: Vec<f64> = (0..self.n).map(|j| x * (1.0 + j as f64)).collect();
            let e: Vec<C64> = q.iter().map(|&v| cis(v)).collect();
            let mut out = vec![mark; self.nnz];
            self.jac_over(&At { q: &q, e: &e, t: x }, &mut out);
            for (k, v) in kept.iter_mut().zip(&out) {
                *k &= v.to_bits() == mark.to_bits();
            }
        }
        kept
    }

    /// The same model over another scalar S (Dual: its tables' tangents
    /// zero, for the tangents along q and qd alone; crate::sensitivity).
    pub fn over<S: Real>(&self) -> Result<Kin<S>, String> {
        let angles = self.angles.iter().map(|&a| a as i64).collect();
        Kin::new(self.n, self.tables.clone(), &self.function_table, &self.outline_table, angles)
    }

    /// The same model over S with its tables' tangents seeded (design
    /// sensitivities, crate::sensitivity): families [(place, tangent)] and
    /// the functions' and outlines' tangents, each a table of the tangents
    /// of some of its real and complex columns, S::WIDTH entries per entry
    /// of the column (crate::table::Table::real_s).
    pub fn seeded<S: Real>(
        &self,
        families: &[(usize, Table)],
        functions: &Table,
        outlines: &Table,
    ) -> Result<Kin<S>, String> {
        let mut tables = self.tables.clone();
        for (k, tangent) in families {
            let (kind, t) = tables.get_mut(*k).ok_or(format!("sensitivity: no family {k} in the model"))?;
            seed(t, tangent, S::WIDTH).map_err(|e| format!("{kind}: {e}"))?;
        }
        let (mut f, mut o) = (self.function_table.clone(), self.outline_table.clone());
        seed(&mut f, functions, S::WIDTH).map_err(|e| format!("functions: {e}"))?;
        seed(&mut o, outlines, S::WIDTH).map_err(|e| format!("outlines: {e}"))?;
        let angles = self.angles.iter().map(|&a| a as i64).collect();
        Kin::new(self.n, tables, &f, &o, angles)
    }

    /// The model's independent parts, one per diagonal block (cols[b]: the
    /// block's coordinates, ascending): each a Kin over its own coordinates
    /// (numbered in the same order) with the constraints whose first
    /// coordinate column is in the block, in the same order, so that its
    /// rows and Jacobian entries are the block's in ascending global order.
    pub fn split(&self, cols: &[Vec<usize>]) -> Result<Vec<Kin>, String> {
        const NONE: usize = usize::MAX;
        let (mut block, mut local) = (vec![NONE; self.n], vec![0usize; self.n]);
        for (b, c) in cols.iter().enumerate() {
            for (i, &g) in c.iter().enumerate() {
                block[g] = b;
                local[g] = i;
            }
        }
        let mut parts: Vec<Vec<(String, Table)>> = vec![Vec::new(); cols.len()];
        for (kind, t) in &self.tables {
            let coords = coordinate_columns(kind);
            let first = coords.first().and_then(|k| t.ints.get(*k)).ok_or(format!("{kind}: no coordinate column"))?;
            let count = first.len();
            let mut keep = vec![Vec::new(); cols.len()];
            for (r, &x) in first.iter().enumerate() {
                // x was checked against n when this Kin was built
                match block[x as usize] {
                    NONE => return Err(format!("{kind}: coordinate {x} is in no block")),
                    b => keep[b].push(r),
                }
            }
            for (b, rows) in keep.iter().enumerate().filter(|(_, r)| !r.is_empty()) {
                let pick = |len: usize| len == count;
                let mut s = Table::default();
                for (k, v) in &t.ints {
                    let mut w: Vec<i64> = if pick(v.len()) { rows.iter().map(|&r| v[r]).collect() } else { v.clone() };
                    if coords.contains(&k.as_str()) {
                        for x in &mut w {
                            let g = *x as usize;
                            // an unused column outside the block: any valid one
                            *x = if g < self.n && block[g] == b { local[g] as i64 } else { 0 };
                        }
                    }
                    s.ints.insert(k.clone(), w);
                }
                for (k, v) in &t.reals {
                    s.reals.insert(
                        k.clone(),
                        if pick(v.len()) { rows.iter().map(|&r| v[r]).collect() } else { v.clone() },
                    );
                }
                for (k, v) in &t.complex {
                    s.complex.insert(
                        k.clone(),
                        if pick(v.len()) { rows.iter().map(|&r| v[r]).collect() } else { v.clone() },
                    );
                }
                parts[b].push((kind.clone(), s));
            }
        }
        parts
            .into_iter()
            .enumerate()
            .map(|(b, fams)| {
                let angles = self.angles.iter().filter(|&&a| block[a] == b).map(|&a| local[a] as i64).collect();
                Kin::new(cols[b].len(), fams, &self.function_table, &self.outline_table, angles)
            })
            .collect()
    }

    /// `rotate` where q[j] has changed since `seen` (the angles e holds), as
    /// in a march: a grounded or sliding body's angle keeps its sin and cos;
    /// at a step's start (`Rotation::Fresh`) e is its anchor's turned by
    /// the angle since, after a correction (`Rotation::Turn`) e is turned by
    /// its small angle (`follow`). Python's operations (kinem.analysis.Steps)
    /// call the same, through kinem._core's Angles, so both steps agree to the bit.
    #[inline(always)]
    pub fn rotate_changed(&self, q: &[f64], e: &mut [C64], seen: &mut [f64], anchor: &mut [Anchor], how: Rotation) {
        assert!(q.len() >= self.n && e.len() >= self.n && seen.len() >= self.n && anchor.len() >= self.n);
        for &j in &self.angles {
            // SAFETY: every angle column is below n (checked in Kin::new), the slices' lengths asserted above
            unsafe {
                let (e, seen, anchor) =
                    (e.get_unchecked_mut(j), seen.get_unchecked_mut(j), anchor.get_unchecked_mut(j));
                follow(*q.get_unchecked(j), seen, e, anchor, how)
            };
        }
    }
}

/// How `follow` brings e^{i seen} to e^{i x}.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Rotation {
    /// x was set (a step's start): e^{i x} from the angle's anchor (an
    /// e^{i a} of sin_cos), so that turns never add up over the instants
    Fresh,
    /// x was corrected: e turned by the correction where it is small
    Turn,
}

/// The largest angle (rad) by which `follow` turns e after a correction
/// instead of calling sin_cos: cos d = 1 - d^2/2 and sin d = d - d^3/6 are
/// then within 5e-18 (d^4/24, d^5/120) of cos d and sin d, below rounding
/// of e's components.
pub const TURN: f64 = 1e-4;

/// Below this angle (2^-27 rad) a turn's 1 - d^2/2 is 1 and d - d^3/6 is d
/// in floating point (d^2/2 under half an ulp of 1): the turn is e (1 + i d).
const TINY: f64 = 7.450580596923828e-9;

/// The largest angle (rad) from its anchor at which a step's start takes
/// e^{i x} as the anchor's e^{i a} turned by x - a (`near`) instead of
/// calling sin_cos (which then anchors the angle again at x).
pub const NEAR: f64 = 0.125;

/// An angle column's last e^{i a} from sin_cos: a start's e^{i x} is
/// e^{i a} e^{i (x - a)}, within a few roundings of sin_cos of x however
/// many instants it has served (`follow`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Anchor {
    a: f64,
    e: C64,
}

impl Anchor {
    /// None yet: the next start calls sin_cos.
    pub const NONE: Anchor = Anchor { a: f64::NAN, e: C64::new(1.0, 0.0) };
}

/// e^{i q} at the angle columns as a march carries it from one
/// configuration to the next (`follow`): the angles it holds, each angle's
/// anchor, and whether q was set (a step's start) rather than corrected
/// since. march::Native and Python's Angles (py/step.rs) each hold one, so
/// that both steps agree to the bit.
pub struct Turning {
    pub e: Vec<C64>,
    /// the angles e holds (NaN: none yet)
    seen: Vec<f64>,
    /// each angle's last e^{i a} from sin_cos
    anchor: Vec<Anchor>,
    /// q was set, not corrected, since e was brought to it
    fresh: bool,
}

impl Clone for Turning {
    fn clone(&self) -> Self {
        let mut t = Turning { e: Vec::new(), seen: Vec::new(), anchor: Vec::new(), fresh: true };
        t.clone_from(self);
        t
    }

    /// Field by field, in the buffers self has (crate::march::Room::set: no allocation).
    fn clone_from(&mut self, s: &Self) {
        let Turning { e, seen, anchor, fresh } = self;
        e.clone_from(&s.e);
        seen.clone_from(&s.seen);
        anchor.clone_from(&s.anchor);
        *fresh = s.fresh;
    }
}

impl Turning {
    pub fn new(n: usize) -> Self {
        Turning { e: vec![C64::new(1.0, 0.0); n], seen: vec![f64::NAN; n], anchor: vec![Anchor::NONE; n], fresh: true }
    }

    /// q was set (a step's start): the next `to` takes e from the anchors.
    #[inline(always)]
    pub fn restart(&mut self) {
        self.fresh = true;
    }

    /// e = e^{i q} (Kin::rotate_changed: Fresh after a start, else Turn).
    #[inline(always)]
    pub fn to(&mut self, kin: &Kin, q: &[f64]) {
        let how = if self.fresh { Rotation::Fresh } else { Rotation::Turn };
        kin.rotate_changed(q, &mut self.e, &mut self.seen, &mut self.anchor, how);
        self.fresh = false;
    }
}

/// e^{i d} for |d| <= NEAR: cos d and sin d by their Taylor series to d^10
/// and d^11 (the next terms, d^12/12! and d^13/13!, below 1.5e-19 and 1e-21
/// at NEAR: under rounding of cos d and sin d).
#[inline(always)]
pub fn near(d: f64) -> C64 {
    let d2 = d * d;
    let c =
        1.0 + d2 * (-0.5 + d2 * (1.0 / 24.0 + d2 * (-1.0 / 720.0 + d2 * (1.0 / 40320.0 + d2 * (-1.0 / 3628800.0)))));
    let s = d + d
        * d2
        * (-1.0 / 6.0 + d2 * (1.0 / 120.0 + d2 * (-1.0 / 5040.0 + d2 * (1.0 / 362880.0 + d2 * (-1.0 / 39916800.0)))));
    C64::new(c, s)
}

/// e = e^{i x} from e = e^{i seen} (seen = x after): kept where x is seen
/// bit for bit; by Turn where d = x - seen is at most TURN, e times
/// (1 - d^2/2) + i (d - d^3/6) (a chord correction's Phi and the
/// factorisation after it need no sin_cos: a few roundings per turn, at
/// most CHORD_STEPS + a few turns per instant); by Fresh where x is within
/// NEAR of the anchor's a, the anchor's e^{i a} times e^{i (x - a)}
/// (`near`: a few roundings from sin_cos of x, whatever the instants
/// before); else sin_cos, and x is the anchor.
#[inline(always)]
pub fn follow(x: f64, seen: &mut f64, e: &mut C64, anchor: &mut Anchor, how: Rotation) {
    if x.to_bits() == seen.to_bits() && !x.is_nan() {
        return;
    }
    let d = x - *seen;
    let far = x - anchor.a;
    if how == Rotation::Turn && d.abs() <= TINY {
        // 1 - d^2/2 rounds to 1 and d - d^3/6 to d: the same figures as below, fewer operations
        *e = C64::new(e.re - e.im * d, e.re * d + e.im);
    } else if how == Rotation::Turn && d.abs() <= TURN {
        let d2 = d * d;
        *e *= C64::new(1.0 - 0.5 * d2, d - d * d2 * (1.0 / 6.0));
    } else if how == Rotation::Fresh && far.abs() <= NEAR {
        *e = anchor.e * near(far);
    } else {
        let (s, c) = x.sin_cos();
        *e = C64::new(c, s);
        *anchor = Anchor { a: x, e: *e };
    }
    *seen = x;
}

/// Sets t's tangents from `tangent`'s real and complex columns, `width` per
/// entry of t's column of the same name.
fn seed(t: &mut Table, tangent: &Table, width: usize) -> Result<(), String> {
    let bad = |key: &str| format!("tangent of column '{key}': not {width} per entry of the table's column");
    for (key, d) in &tangent.reals {
        if t.reals.get(key).map(|v| v.len() * width) != Some(d.len()) {
            return Err(bad(key));
        }
        t.d_reals.insert(key.clone(), d.clone());
    }
    for (key, d) in &tangent.complex {
        if t.complex.get(key).map(|v| v.len() * width) != Some(d.len()) {
            return Err(bad(key));
        }
        t.d_complex.insert(key.clone(), d.clone());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A turn by a correction's angle lands on sin_cos of the new angle to
    /// 2.5e-16 (a few roundings) per turn, through a chain of ten turns; a
    /// larger angle calls sin_cos (and anchors the angle there); an angle
    /// that has not moved keeps e bit for bit.
    #[test]
    fn a_turn_lands_on_sin_cos() {
        use Rotation::*;
        for k in 0..2000 {
            let x0 = -7.0 + 0.007 * k as f64;
            let (mut seen, mut e, mut anchor) = (f64::NAN, C64::new(1.0, 0.0), Anchor::NONE);
            follow(x0, &mut seen, &mut e, &mut anchor, Turn);
            assert_eq!(e, C64::new(x0.cos(), x0.sin()));
            let mut x = x0;
            for i in 0..10 {
                x += TURN * ((k * 7 + i * 3) % 11) as f64 / 10.0 * if i % 2 == 0 { 1.0 } else { -1.0 };
                follow(x, &mut seen, &mut e, &mut anchor, Turn);
                let err = (e - C64::new(x.cos(), x.sin())).norm();
                assert!(err <= 2.5e-16 * (i + 1) as f64, "{x}: {err} after {} turns", i + 1);
            }
            let kept = e;
            follow(x, &mut seen, &mut e, &mut anchor, Fresh);
            assert_eq!(kept, e);
            for (y, how) in [(x + 2.0 * TURN, Turn), (x + 2.0 * NEAR, Fresh)] {
                follow(y, &mut seen, &mut e, &mut anchor, how);
                assert_eq!(e, C64::new(y.cos(), y.sin()));
                assert_eq!(anchor, Anchor { a: y, e });
            }
        }
    }

    /// A turn by an angle below TINY is the general turn's figure to the
    /// bit (tolerance 0), for angles up to TINY of either sign.
    #[test]
    fn a_tiny_turn_is_the_general_one_to_the_bit() {
        for k in 0..=2000 {
            let small = TINY * (k as f64 / 1000.0 - 1.0) * if k % 3 == 0 { 1e-5 } else { 1.0 };
            for x in [-2.9, 0.3, 1.7, 5.1] {
                let e = C64::new(f64::cos(x), f64::sin(x));
                let (mut seen, mut f, mut anchor) = (x, e, Anchor::NONE);
                follow(x + small, &mut seen, &mut f, &mut anchor, Rotation::Turn);
                // the general turn by the angle follow sees, (x + small) - x
                let d = (x + small) - x;
                let d2 = d * d;
                let general = e * C64::new(1.0 - 0.5 * d2, d - d * d2 * (1.0 / 6.0));
                assert_eq!((f.re.to_bits(), f.im.to_bits()), (general.re.to_bits(), general.im.to_bits()), "{x} {d}");
            }
        }
    }

    /// A march's starts (Fresh) over 20,000 instants of steps up to past
    /// NEAR, with up to five turns between them: every start's e^{i x}
    /// within 2 ulps of 1 (4.5e-16, each component) of sin_cos of x however
    /// long its anchor has served, no drift; `near` within 1.2e-16 of
    /// sin_cos over |d| <= NEAR.
    #[test]
    fn a_start_from_its_anchor_lands_on_sin_cos_without_drift() {
        use Rotation::*;
        for k in 0..=10_000 {
            let d = NEAR * (k as f64 / 5_000.0 - 1.0);
            let (s, c) = d.sin_cos();
            let z = near(d);
            assert!((z.re - c).abs() <= 1.2e-16 && (z.im - s).abs() <= 1.2e-16, "{d}: {z} against {c} {s}");
        }
        let (mut seen, mut e, mut anchor) = (f64::NAN, C64::new(1.0, 0.0), Anchor::NONE);
        let (mut x, mut worst) = (-3.0f64, 0.0f64);
        for i in 0..20_000u64 {
            // a step's motion: swinging, up to 0.15 rad (past NEAR), and back
            let h = 0.15 * ((i as f64) * 0.0137).sin() * ((i * 7919 % 101) as f64 / 100.0);
            x += h;
            follow(x, &mut seen, &mut e, &mut anchor, Fresh);
            let (s, c) = x.sin_cos();
            worst = worst.max((e.re - c).abs()).max((e.im - s).abs());
            assert!((e.re - c).abs() <= 4.5e-16 && (e.im - s).abs() <= 4.5e-16, "{i}: {x}: {e} against {c} {s}");
            for j in 0..(i % 6) {
                x += 1e-6 * (j as f64 - 2.5);
                follow(x, &mut seen, &mut e, &mut anchor, Turn);
            }
        }
        assert!(worst > 0.0);
    }
}
