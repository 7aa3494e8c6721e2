//! J_s in its block-triangular order (crate::decompose, issue 31): one
//! block of up to MASK coordinates whose pattern decomposes, its diagonal
//! blocks factorised one after the other, a 1x1 block as its entry and a
//! larger one in its own fixed pivot order (crate::order), each block's
//! positions in that order. A solve is block forward substitution: block
//! k's right side less the off-diagonal entries of its rows times the
//! coordinates already solved (a sparse product), then its diagonal
//! block's elimination, in place.
//!
//! When a block's order does not suit the values (a zero pivot, a
//! multiplier above crate::order::MULTIPLIER) or the pivots of all the
//! blocks span more than crate::lu::FALLBACK, the whole J_s is factorised
//! with partial pivoting in the model's own order instead (`whole`: LAPACK
//! getf2's pivots, as before the decomposition; on its nonzeros up to
//! MASK coordinates, dense above), so that every figure near the
//! acceptance test's floor is partial pivoting's.
use crate::lu::{dense_factor, dense_solve, masked_factor, masked_solve, Factors, FALLBACK, MASK};
use crate::order::{Order, Pivots, MULTIPLIER};
use crate::real::Real;

/// A division's value index with this bit set is the reciprocal of a pivot
/// that is a constant -1 of the formulation (a revolute's or a joint's -1
/// alone in its place, never written by the elimination: plan::negate),
/// which every factorisation checks (`Factoring::minus_entries`, the lanes'
/// too); that reciprocal is -1, set once (`Factoring::minus_recips`): the
/// scalar solve (`Program::run_negating`) negates there instead of
/// multiplying, x * -1 being -x to the bit; the other runs multiply by the
/// value under the bit.
pub const NEGATE: u32 = 1 << 31;

/// A solve's forward and back substitution as one flat program over the
/// places w (the positions, renumbered to the coordinates once built:
/// `Program::renumber`, `Triangular::run`) and the factors' values a (issue
/// 31 item 4): `divs[k] = [end, r, v]` runs the subtractions `subs[..end]`
/// not yet run (`[i, c, u]`: w[i] -= a[u] w[c]), then the division w[r] *=
/// a[v], a[v] being the reciprocal 1 / pivot that the factorisation keeps
/// (`Factoring::recips`, issue 31 round 21: a product instead of a
/// division in the solve's chain). The order and operands are the
/// elimination's (each division by the pivot a product with its
/// reciprocal), the same in every run: the scalar march, the lanes and the
/// sensitivities' right sides.
///
/// `run` walks them as one flat list laid out once (`ops`, `Program::lay`,
/// issue 31 rounds 27 and 28): the operations in the order above, those in
/// a row on one position as one run (`flat`), so that a run has no outer
/// loop over the divisions, no inner loop to set up per division, and
/// reads and writes each run's w[i] once; each list in the layout its
/// shape suits, chosen once (`Lay`, round 30: a short program of lone
/// operations with them as records of their own), which `run` tests once.
///
/// A 1x1 block whose pivot is a constant +1 (a ground's or a driver's row,
/// `Factoring::one_entries` checks it each factorisation) has no division: its
/// subtractions run with the next division's, or after the last one. A
/// pivot that is a constant -1 keeps its product (with -1), which the
/// scalar run makes a negation (`NEGATE`).
///
/// The quiet positions: 1x1 blocks whose row's nu was zero at every trial
/// and whose subtractions, if any, read quiet positions
/// (a ground's; a body pinned to it by its own origin, whose entries on
/// its angle are exact zeros, no part of the structure; an angle tied to
/// the ground's): their w is the gathered right side, zero in the rates'
/// solves and in a correction once the ground is met, and stays zero (a
/// product with the reciprocal of a pivot, nonzero and finite in a
/// factorisation taken, keeps it zero). Where every one is zero, `run` runs `short`, the
/// program without the subtractions that read them (w[i] -= a 0: the same
/// w[i], but for the sign of a zero) and without their divisions; the
/// others are kept in the same order, so the figures are the full program's.
///
/// Invariants, checked once by `Program::check` when the model is built
/// (and by debug assertions in `run`): every position i, c, r is below
/// `positions`, every value index u, v below `values`, the ends ascend up
/// to subs.len(), a value index carrying `NEGATE` below `values` without
/// it, and `ops`, `short_ops` are the lists laid out as `lays` says
/// (`lay`). `run` asserts
/// that its slices are that long.
#[derive(Clone, Debug, Default)]
pub struct Program {
    pub subs: Vec<[u32; 3]>,
    pub divs: Vec<[u32; 3]>,
    pub positions: usize,
    pub values: usize,
    pub quiet: Vec<u32>,
    /// (subs, divs) without the subtractions that read a quiet position
    pub short: (Vec<[u32; 3]>, Vec<[u32; 3]>),
    /// (subs, divs) and `short` laid out as the flat lists `run` walks
    /// (`Program::lay`, `flat`): runs on one position in the order the
    /// program runs them
    pub ops: Vec<[u32; 3]>,
    pub short_ops: Vec<[u32; 3]>,
    /// how `ops` and `short_ops` are laid out (`Lay::choose`, each list's own)
    pub lays: [Lay; 2],
}

/// A run's `v` where it ends without a division (no value index reaches
/// it), and in the lone layout a lone division's `c` (no position reaches it).
pub const DIV: u32 = u32::MAX;

/// In the lone layout, a run's `c` (no position reaches it: `Program::check`
/// keeps the positions below `NEGATE`).
pub const RUN: u32 = NEGATE;

/// How a flat list is laid out (issue 31 round 30), chosen once per list
/// by `Program::lay` (`Lay::choose`) and tested once per run of the program:
/// `Runs`, every operation in a run on its position (round 28: `[i, k, v]`
/// and its k subtractions), or `Lone`, a lone subtraction or division as a
/// record of its own and a run only where two or more operations share a
/// position (round 29's first layout). The same operations in the same order.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Lay {
    #[default]
    Runs,
    Lone,
}

/// One operation of a program, in `in_order`'s sequence: a subtraction
/// `[i, c, u]` (w[i] -= a[u] w[c]) or a division (r, v) (w[r] *= a[v]).
#[derive(Clone, Copy)]
enum Op {
    Sub([u32; 3]),
    Div(u32, u32),
}

/// subs and divs as one sequence in the order they run: each division
/// after the subtractions before its end (the ends clamped to the list, so
/// that `check` can lay out a list it has not yet found sound).
fn in_order(subs: &[[u32; 3]], divs: &[[u32; 3]]) -> Vec<Op> {
    let mut ops = Vec::with_capacity(subs.len() + divs.len());
    let mut from = 0;
    for &[end, r, v] in divs {
        let end = (end as usize).clamp(from, subs.len());
        ops.extend(subs[from..end].iter().map(|&s| Op::Sub(s)));
        ops.push(Op::Div(r, v));
        from = end;
    }
    ops.extend(subs[from..].iter().map(|&s| Op::Sub(s)));
    ops
}

/// subs and divs in the order they run (`in_order`) as runs on one
/// position: (position, its subtractions [c, u] in order, none reading the
/// position itself, its division's value index or DIV: none). Consecutive
/// operations on the same position make one run.
fn runs(subs: &[[u32; 3]], divs: &[[u32; 3]]) -> Vec<(u32, Vec<[u32; 2]>, u32)> {
    let mut runs: Vec<(u32, Vec<[u32; 2]>, u32)> = Vec::new();
    // whether the last run can take more subtractions
    let mut open = false;
    for op in in_order(subs, divs) {
        match op {
            Op::Sub([i, c, u]) => match runs.last_mut() {
                Some(run) if open && run.0 == i && c != i => run.1.push([c, u]),
                _ => {
                    open = c != i;
                    runs.push((i, vec![[c, u]], DIV));
                }
            },
            Op::Div(r, v) => {
                match runs.last_mut() {
                    Some(run) if open && run.0 == r => run.2 = v,
                    _ => runs.push((r, Vec::new(), v)),
                }
                open = false;
            }
        }
    }
    runs
}

/// A list's shape (issue 31 round 30): its operations, its runs of two or
/// more operations, its lone subtractions and its lone divisions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ListShape {
    pub ops: usize,
    pub runs: usize,
    pub lone_subs: usize,
    pub lone_divs: usize,
}

impl ListShape {
    pub fn of(subs: &[[u32; 3]], divs: &[[u32; 3]]) -> ListShape {
        let mut s = ListShape { ops: subs.len() + divs.len(), ..ListShape::default() };
        for (_, run, v) in runs(subs, divs) {
            match (run.len(), v) {
                (0, _) => s.lone_divs += 1,
                (1, DIV) => s.lone_subs += 1,
                _ => s.runs += 1,
            }
        }
        s
    }
}

impl Lay {
    /// The layout of a list of this shape: `Lone` where at least half of
    /// its records would be lone operations (its lone subtractions and
    /// divisions at least as many as its runs of two or more operations,
    /// some of them lone subtractions), else `Runs` (issue 31 round 30: the
    /// peers' slider-crank's quiet program 3 + 1 lone against 4 runs, the
    /// four-bar's 2 against 4, the Jansen leg's 3 against 15).
    pub fn choose(s: ListShape) -> Lay {
        if s.lone_subs > 0 && s.lone_subs + s.lone_divs >= s.runs {
            Lay::Lone
        } else {
            Lay::Runs
        }
    }
}

/// subs and divs as one flat list (`runs`), laid out as `lay` says: in
/// `Runs` (issue 31 round 28) a run `[i, k, v]` is followed by its k
/// subtractions `[c, u, last]` (w[i] -= a[u] w[c], in order; last = 1 on
/// the run's last one, 0 on the others) and ends with the division w[i] *=
/// a[v] (v = DIV: none), k = 0 for a division alone; in `Lone` (round 29's
/// first layout) a lone subtraction is `[i, c, u]`, a lone division
/// `[r, DIV, v]`, and a run of two or more operations `[i, RUN, v]`
/// followed by its subtractions `[c, u, last]` as above. w[i] is read once
/// and written once a record, the same operations in the same order.
fn flat(subs: &[[u32; 3]], divs: &[[u32; 3]], lay: Lay) -> Vec<[u32; 3]> {
    let mut ops: Vec<[u32; 3]> = Vec::with_capacity(2 * (subs.len() + divs.len()));
    for (i, run, v) in runs(subs, divs) {
        let k = run.len();
        match (lay, k, v) {
            (Lay::Lone, 0, v) => ops.push([i, DIV, v]),
            (Lay::Lone, 1, DIV) => ops.push([i, run[0][0], run[0][1]]),
            (Lay::Lone, _, v) => ops.push([i, RUN, v]),
            (Lay::Runs, k, v) => ops.push([i, k as u32, v]),
        }
        if lay == Lay::Runs || k > 1 || (k == 1 && v != DIV) {
            ops.extend(run.iter().enumerate().map(|(n, &[c, u])| [c, u, (n + 1 == k) as u32]));
        }
    }
    ops
}

impl Program {
    pub fn sub(&mut self, i: usize, c: usize, u: usize) {
        self.subs.push([i as u32, c as u32, u as u32]);
    }

    pub fn div(&mut self, r: usize, v: usize) {
        self.divs.push([self.subs.len() as u32, r as u32, v as u32]);
    }

    /// The program without the subtractions that read the quiet positions
    /// `quiet` and their divisions (each a position no subtraction writes
    /// but from a quiet position, and divided, if at all, by a pivot the
    /// factorisation checked nonzero and finite: where all of them are zero
    /// on entry they stay zero, but for a zero's sign), set as `short`; none
    /// where no subtraction reads one.
    pub fn quieten(&mut self, quiet: Vec<u32>) {
        let read = |s: &[u32; 3]| quiet.contains(&s[1]);
        if quiet.iter().any(|&q| self.subs.iter().any(|s| s[0] == q && !read(s))) || !self.subs.iter().any(read) {
            return self.lay();
        }
        let (mut subs, mut divs, mut from) = (Vec::new(), Vec::new(), 0);
        for &[end, r, v] in &self.divs {
            subs.extend(self.subs[from..end as usize].iter().filter(|s| !read(s)));
            // a quiet position's division (0 times 1 / a nonzero pivot: a zero) is left out too
            if !quiet.contains(&r) {
                divs.push([subs.len() as u32, r, v]);
            }
            from = end as usize;
        }
        subs.extend(self.subs[from..].iter().filter(|s| !read(s)));
        (self.quiet, self.short) = (quiet, (subs, divs));
        self.lay();
    }

    /// Lays (subs, divs) and `short` out as the flat lists `run` walks
    /// (`ops`, `short_ops`): to be called after any change of them
    /// (`quieten`, `renumber` and plan::negate call it); `check` finds
    /// lists not laid out again.
    pub fn lay(&mut self) {
        let shapes = [ListShape::of(&self.subs, &self.divs), ListShape::of(&self.short.0, &self.short.1)];
        self.lay_as(shapes.map(Lay::choose));
    }

    /// `lay` with the layouts given (`lays`: of `ops` and `short_ops`).
    pub fn lay_as(&mut self, lays: [Lay; 2]) {
        self.lays = lays;
        self.ops = flat(&self.subs, &self.divs, lays[0]);
        self.short_ops = flat(&self.short.0, &self.short.1, lays[1]);
    }

    /// The program over other places: position p becomes to[p] (a
    /// permutation of the positions), in every list; the same operations
    /// in the same order.
    pub fn renumber(&mut self, to: &[usize]) {
        let at = |p: &mut u32| *p = to[*p as usize] as u32;
        for [i, c, _] in self.subs.iter_mut().chain(self.short.0.iter_mut()) {
            at(i);
            at(c);
        }
        for [_, r, _] in self.divs.iter_mut().chain(self.short.1.iter_mut()) {
            at(r);
        }
        self.quiet.iter_mut().for_each(at);
        self.lay();
    }

    /// The invariants `run` relies on (see `Program`), of both lists.
    pub fn check(&self) -> Result<(), String> {
        let (p, v) = (self.positions, self.values);
        if p >= NEGATE as usize || v >= NEGATE as usize {
            return Err("program: too many positions or values".into());
        }
        if let Some(q) = self.quiet.iter().find(|&&q| q as usize >= p) {
            return Err(format!("program: quiet position {q} outside {p} positions"));
        }
        let lists = [(&self.subs, &self.divs, &self.ops), (&self.short.0, &self.short.1, &self.short_ops)];
        for ((subs, divs, ops), lay) in lists.into_iter().zip(self.lays) {
            if let Some(s) = subs.iter().find(|s| s[0] as usize >= p || s[1] as usize >= p || s[2] as usize >= v) {
                return Err(format!("program: subtraction {s:?} outside {p} positions, {v} values"));
            }
            if *ops != flat(subs, divs, lay) {
                return Err("program: its flat list is not its subtractions and divisions laid out as marked".into());
            }
            let mut end = 0;
            for d in divs {
                if d[0] < end || d[0] as usize > subs.len() || d[1] as usize >= p || (d[2] & !NEGATE) as usize >= v {
                    return Err(format!("program: division {d:?} out of order or range"));
                }
                end = d[0];
            }
        }
        Ok(())
    }

    /// Runs the program on w (positions) with the values a: over f64, over
    /// variants' lanes (crate::lane_lu) or over several right-hand sides
    /// at once (crate::sensitivity), the same operations in the same order
    /// (`short` where every quiet position is zero in every lane).
    #[inline]
    pub fn run<A: Copy, W: Cell<A>>(&self, a: &[A], w: &mut [W]) {
        self.run_as::<false, A, W>(a, w);
    }

    /// `run` over f64 on factors from `Factoring::run`, which checked every
    /// pivot under `NEGATE` to be -1: those products with -1 are negations
    /// (the same figures to the bit). Returns whether it ran `short`: every
    /// quiet position was zero on entry and is left as it was (no operation
    /// of `short` writes one), so each holds its entry's figure, to the bit.
    #[inline]
    pub fn run_negating(&self, a: &[f64], w: &mut [f64]) -> bool {
        self.run_as::<true, f64, f64>(a, w)
    }

    /// `run`, negating where NEG and the division's index carries `NEGATE`;
    /// whether it ran `short`.
    #[inline(always)]
    fn run_as<const NEG: bool, A: Copy, W: Cell<A>>(&self, a: &[A], w: &mut [W]) -> bool {
        assert!(a.len() >= self.values && w.len() >= self.positions);
        debug_assert!(self.check().is_ok());
        // SAFETY: Program::check (when built): every quiet position below `positions` <= w.len()
        let quiet = !self.quiet.is_empty() && self.quiet.iter().all(|&q| unsafe { w.get_unchecked(q as usize) }.zero());
        let (ops, lay) = if quiet { (&self.short_ops[..], self.lays[1]) } else { (&self.ops[..], self.lays[0]) };
        // SAFETY: Program::check (when built): ops is (subs, divs) laid out as lay says (`flat`)
        unsafe {
            match lay {
                Lay::Runs => run_runs::<NEG, A, W>(ops, a, w),
                Lay::Lone => run_lone::<NEG, A, W>(ops, a, w),
            }
        }
        quiet
    }

    /// The program for right sides that are zero but at the places
    /// `from` (issue 30: the places a design parameter reaches,
    /// crate::sensitivity): `reached[p]` for every place a run can make
    /// non-zero from them (in the program's order), and the program of the
    /// subtractions that read a reached place and of the divisions of
    /// reached places, the same operations in the same order. Every
    /// operation left out reads a place that is zero then (w[i] -= a 0,
    /// 0 / a): the figures are the full program's but for the sign of a
    /// zero, and the places not reached are not written. Its quiet
    /// positions are self's that are reached (`quieten`).
    pub fn reached(&self, from: &[bool]) -> (Vec<bool>, Program) {
        let mut reached = from.to_vec();
        reached.resize(self.positions, false);
        let mut p = Program { positions: self.positions, values: self.values, ..Program::default() };
        for op in in_order(&self.subs, &self.divs) {
            match op {
                Op::Sub([i, c, u]) if reached[c as usize] => {
                    reached[i as usize] = true;
                    p.sub(i as usize, c as usize, u as usize);
                }
                Op::Div(r, v) if reached[r as usize] => p.div(r as usize, v as usize),
                _ => {}
            }
        }
        p.quieten(self.quiet.iter().copied().filter(|&q| reached[q as usize]).collect());
        (reached, p)
    }

    /// The operations in the order `run` runs them (`short`: the short
    /// program's), read-only: `[i, c, u]` a subtraction w[i] -= a[u] w[c],
    /// `[r, DIV, v]` a division w[r] *= a[v] (crate::sensitivity resolves
    /// a restricted program from them once per set-up).
    pub fn operations(&self, short: bool) -> Vec<[u32; 3]> {
        let (subs, divs) = if short { (&self.short.0, &self.short.1) } else { (&self.subs, &self.divs) };
        let op = |op| match op {
            Op::Sub(s) => s,
            Op::Div(r, v) => [r, DIV, v],
        };
        in_order(subs, divs).into_iter().map(op).collect()
    }
}

/// The division ending a record: w[i] *= a[v] (v = DIV: none), a
/// negation where NEG and v carries `NEGATE`.
#[inline(always)]
unsafe fn divide<const NEG: bool, A: Copy, W: Cell<A>>(y: &mut W, a: &[A], v: u32) {
    if v != DIV {
        if NEG && v & NEGATE != 0 {
            y.negate();
        } else {
            y.mul(*a.get_unchecked((v & !NEGATE) as usize));
        }
    }
}

/// A run's subtractions from ops[k] to the one marked last: y -= a[u] w[c]
/// (the mark ends the loop: no count to unroll by); the next record's index.
#[inline(always)]
unsafe fn subtract<A: Copy, W: Cell<A>>(y: &mut W, ops: &[[u32; 3]], mut k: usize, a: &[A], w: &[W]) -> usize {
    loop {
        let [c, u, last] = *ops.get_unchecked(k);
        k += 1;
        y.sub_mul(*a.get_unchecked(u as usize), *w.get_unchecked(c as usize));
        if last != 0 {
            return k;
        }
    }
}

/// `Program::run` over a list laid out in `Lay::Runs`.
///
/// # Safety
/// ops is a program's (subs, divs) laid out in `Lay::Runs` (`flat`, as
/// `Program::check` finds it), each run's k subtractions following it,
/// every position below `positions` <= w.len(), every value below `values`
/// <= a.len(), no subtraction of a run reading its position (w[i] read
/// once and written once a run: a negation in memory would be a one-byte
/// store, which the next full load of w[i] waits for).
#[inline(always)]
unsafe fn run_runs<const NEG: bool, A: Copy, W: Cell<A>>(ops: &[[u32; 3]], a: &[A], w: &mut [W]) {
    let (mut k, end) = (0, ops.len());
    while k < end {
        let [i, count, v] = *ops.get_unchecked(k);
        let mut y = *w.get_unchecked(i as usize);
        k += 1;
        if count != 0 {
            k = subtract(&mut y, ops, k, a, w);
        }
        divide::<NEG, A, W>(&mut y, a, v);
        *w.get_unchecked_mut(i as usize) = y;
    }
}

/// `Program::run` over a list laid out in `Lay::Lone`.
///
/// # Safety
/// As `run_runs`, the list laid out in `Lay::Lone`: lone subtractions
/// `[i, c, u]` (c below `positions` < RUN), lone divisions `[r, DIV, v]`,
/// runs `[i, RUN, v]` each followed by its subtractions to the one marked last.
#[inline(always)]
unsafe fn run_lone<const NEG: bool, A: Copy, W: Cell<A>>(ops: &[[u32; 3]], a: &[A], w: &mut [W]) {
    let (mut k, end) = (0, ops.len());
    while k < end {
        let [i, c, v] = *ops.get_unchecked(k);
        let mut y = *w.get_unchecked(i as usize);
        k += 1;
        if c < RUN {
            // a lone subtraction [i, c, u]
            y.sub_mul(*a.get_unchecked(v as usize), *w.get_unchecked(c as usize));
        } else {
            if c == RUN {
                k = subtract(&mut y, ops, k, a, w);
            }
            divide::<NEG, A, W>(&mut y, a, v);
        }
        *w.get_unchecked_mut(i as usize) = y;
    }
}

/// What a solve's program works on, a factor's entry being `A`: a
/// position's value (f64, or variants' lanes: A = Self), or the same
/// position of N right-hand sides ([f64; N], A = f64). y.sub_mul(a, x) is
/// y = y - a x, y.mul(a) y = y a, each lane's as f64's, to the bit;
/// y.zero(): every lane is zero.
pub trait Cell<A>: Copy {
    fn sub_mul(&mut self, a: A, x: Self);
    fn mul(&mut self, a: A);
    /// y = -y (y * -1 to the bit)
    fn negate(&mut self);
    fn zero(&self) -> bool;
}

impl<S: Real> Cell<S> for S {
    #[inline(always)]
    fn zero(&self) -> bool {
        self.is_zero()
    }
    #[inline(always)]
    fn sub_mul(&mut self, a: S, x: S) {
        *self = *self - a * x;
    }
    #[inline(always)]
    fn mul(&mut self, a: S) {
        *self = *self * a;
    }
    #[inline(always)]
    fn negate(&mut self) {
        *self = -*self;
    }
}

impl<const N: usize> Cell<f64> for [f64; N] {
    #[inline(always)]
    fn zero(&self) -> bool {
        self.iter().all(|&y| y == 0.0)
    }
    #[inline(always)]
    fn sub_mul(&mut self, a: f64, x: Self) {
        for (y, x) in self.iter_mut().zip(x) {
            *y -= a * x;
        }
    }
    #[inline(always)]
    fn mul(&mut self, a: f64) {
        for y in self.iter_mut() {
            *y *= a;
        }
    }
    #[inline(always)]
    fn negate(&mut self) {
        for y in self.iter_mut() {
            *y = -*y;
        }
    }
}

/// The blocks' factorisation as flat lists over Factors::j (issue 31 item
/// 4): the fill to clear, every entry's placement (values[e] at `at`:
/// off-diagonal, 1x1 and larger blocks alike, but for the folded pivots:
/// `ones`), then each
/// elimination step `[pivot, end, recip]` of the larger blocks' fixed
/// orders (r = 1 / pivot, kept at `recip` for the solve), its multipliers
/// `mults[..end]` (`[at, end]`: l = a[at] r, then a[dst] -= l a[src] for
/// `pairs[..end]`), then the reciprocals of the other pivots (`recips`,
/// `[pivot, recip]`: the 1x1 blocks' and each larger block's last), then
/// the n pivots `diag` (position order) read for the figures. The same
/// operations, in the same order, as Order::numeric block after block (the
/// skip of a zero multiplier dropped; a multiplier above MULTIPLIER still
/// rejects the order, after the loop). Position p's reciprocal is at
/// `recip_at + p` (the program's division of p reads it: `Program`).
///
/// The factors are Phi_q's own, unscaled (issue 31 round 10): in the same
/// fixed order, Phi_q = L U where J_s = R^-1 Phi_q C (R, C: the rows' and
/// coordinates' scales, crate::lu) has L_s = R^-1 L R and U_s = R^-1 U C,
/// so the solve needs no scale. The checks keep J_s's meaning: multiplier
/// l_ik is tested as l_ik r_k / r_i (`mult_scale`), pivot p's figures are
/// u_pp c_p / r_p (`pivot_scale`): J_s's at rounding.
///
/// Invariants, checked once by `Factoring::check` when the model is built:
/// every index into the values below `values`, every entry below `entries`,
/// the ends ascend and the last ones are mults.len() and pairs.len().
#[derive(Clone, Debug, Default)]
pub struct Factoring {
    pub clear: Vec<u32>,
    pub place: Vec<[u32; 2]>,
    pub steps: Vec<[u32; 3]>,
    pub mults: Vec<[u32; 2]>,
    /// per multiplier: r_k / r_i (its row i's and pivot k's row scales)
    pub mult_scale: Vec<f64>,
    pub pairs: Vec<[u32; 2]>,
    pub diag: Vec<u32>,
    /// per position p: c_p / r_p (J_s's pivot over Phi_q's)
    pub pivot_scale: Vec<f64>,
    /// the pivots' reciprocals the elimination's steps do not take, after
    /// them: [pivot, recip], a[recip] = 1 / a[pivot]; position p's at
    /// recip_at + p
    pub recips: Vec<[u32; 2]>,
    pub recip_at: u32,
    /// the reciprocals of the pivots that are a constant -1 (`NEGATE`,
    /// `minus_entries`): set to -1 once (`init`), never computed (a step's
    /// is written, -1 again where its pivot is)
    pub minus_recips: Vec<u32>,
    /// the folded pivots (`Program`): their places, set to 1 once when the
    /// factors are made (`init`) and never written again, and their
    /// Jacobian entries: a factorisation where one is not exactly 1 is
    /// refused (the fallback takes it)
    pub ones: Vec<u32>,
    pub one_entries: Vec<u32>,
    /// the Jacobian entries of the pivots the solve negates by (`NEGATE`):
    /// a factorisation where one is not exactly -1 is refused
    pub minus_entries: Vec<u32>,
    /// an odd count of those pivots (not in `free`: their figures are
    /// folded with the ones', each |-1| c_p / r_p, and each flips the det sign)
    pub minus_odd: bool,
    /// a step of the elimination is on such a pivot (`NEGATE` in `steps`)
    pub negated_steps: bool,
    /// the Jacobian entries taken for exact zeros (Kin::zero_entries): no
    /// part of the blocks' structure (plan::triangulate_zero), never placed;
    /// a factorisation where one is not exactly 0 (a variant that moved a
    /// zero local point, on the nominal's layout) is refused where checked
    /// (Factors::zeros_hold false: the fallback takes it)
    pub zero_entries: Vec<u32>,
    /// the pivots not folded (value index, position, pivot_scale), and the
    /// folded ones' figures, constant (their pivots being 1): the first
    /// position of the smallest c_p / r_p (n: none), that one and the largest
    pub free: Vec<(u32, u32, f64)>,
    pub first_one: u32,
    pub ones_small: f64,
    pub ones_big: f64,
    pub values: usize,
    pub entries: usize,
    /// per placement (`place`): its place is written by no other placement,
    /// clear, step, multiplier, update or reciprocal, so that a constant
    /// entry placed there once stays (`Layout::place_once`)
    pub place_free: Vec<bool>,
}

impl Factoring {
    /// The invariants `run` relies on (see `Factoring`).
    pub fn check(&self) -> Result<(), String> {
        let v = self.values;
        let bad = |x: u32| x as usize >= v;
        if v >= NEGATE as usize
            || self.clear.iter().any(|&x| bad(x))
            || self.place.iter().any(|&[e, at]| e as usize >= self.entries || bad(at))
            || self.steps.iter().any(|s| bad(s[0] & !NEGATE) || bad(s[2]))
            || self.recips.iter().any(|r| bad(r[0]) || bad(r[1]))
            || self.minus_recips.iter().any(|&x| bad(x))
            || self.mults.iter().any(|m| bad(m[0]))
            || self.pairs.iter().any(|p| bad(p[0]) || bad(p[1]))
            || self.diag.iter().any(|&x| bad(x))
            || self.ones.iter().any(|&x| bad(x))
            || (self.one_entries.iter().chain(&self.zero_entries).chain(&self.minus_entries))
                .any(|&e| e as usize >= self.entries)
            || self.free.iter().any(|f| bad(f.0))
            || self.mult_scale.len() != self.mults.len()
            || self.pivot_scale.len() != self.diag.len()
        {
            return Err("factoring: an index out of range".into());
        }
        let ascending = |ends: &mut dyn Iterator<Item = u32>, len: usize| {
            let mut last = 0;
            for e in ends {
                if e < last || e as usize > len {
                    return false;
                }
                last = e;
            }
            last as usize == len
        };
        if !ascending(&mut self.steps.iter().map(|s| s[1]), self.mults.len())
            || !ascending(&mut self.mults.iter().map(|m| m[1]), self.pairs.len())
        {
            return Err("factoring: ends out of order".into());
        }
        Ok(())
    }

    /// The factors' storage a made ready: the folded pivots' places at 1
    /// and the reciprocals of the -1 pivots at -1 (`eliminate` never writes
    /// the former, nor the latter but as -1 where checked).
    pub fn init<S: Real>(&self, a: &mut [S]) {
        for &at in &self.ones {
            a[at as usize] = S::one();
        }
        for &at in &self.minus_recips {
            a[at as usize] = -S::one();
        }
    }

    /// Assembles and eliminates into a (Factors::j, `init` once) from the Jacobian's
    /// values, over f64 or over lanes (crate::lane_lu), the same operations
    /// in the same order; `multiplier` sees every multiplier with its
    /// `mult_scale` (the caller's check against MULTIPLIER).
    #[inline]
    pub fn eliminate<S: Real>(&self, values: &[S], a: &mut [S], multiplier: impl FnMut(S, f64)) {
        self.eliminate_as::<false, S>(values, &self.place, a, multiplier)
    }

    /// `eliminate`; where NEG (`run`, whose checks take every pivot under
    /// `NEGATE` for -1), a step's 1 / pivot there is -1 without the division
    /// (1 / -1 to the bit). Every step's and pivot's reciprocal is kept
    /// for the solve (`Program`).
    /// `place`: `self.place`, or the placements left where the others' constants
    /// are in a already (Factors::again: a sublist of it, in its order).
    #[inline(always)]
    fn eliminate_as<const NEG: bool, S: Real>(
        &self,
        values: &[S],
        place: &[[u32; 2]],
        a: &mut [S],
        mut multiplier: impl FnMut(S, f64),
    ) {
        assert!(a.len() >= self.values && values.len() >= self.entries);
        assert!(place.len() <= self.place.len());
        debug_assert!(self.check().is_ok());
        debug_assert!(place.iter().all(|x| self.place.contains(x)));
        // SAFETY (every unchecked index below): Factoring::check when built, and the lengths asserted above
        unsafe {
            for &at in &self.clear {
                *a.get_unchecked_mut(at as usize) = S::zero();
            }
            for &[e, at] in place {
                *a.get_unchecked_mut(at as usize) = *values.get_unchecked(e as usize);
            }
            let (mut m0, mut p0) = (0usize, 0usize);
            for &[kk, m1, at] in &self.steps {
                let r = if NEG && kk & NEGATE != 0 {
                    -S::one()
                } else {
                    S::one() / *a.get_unchecked((kk & !NEGATE) as usize)
                };
                *a.get_unchecked_mut(at as usize) = r;
                let scales = self.mult_scale.get_unchecked(m0..m1 as usize);
                for (&[at, p1], &scale) in self.mults.get_unchecked(m0..m1 as usize).iter().zip(scales) {
                    let l = *a.get_unchecked(at as usize) * r;
                    multiplier(l, scale);
                    *a.get_unchecked_mut(at as usize) = l;
                    for &[dst, src] in self.pairs.get_unchecked(p0..p1 as usize) {
                        let x = *a.get_unchecked(src as usize);
                        let y = a.get_unchecked_mut(dst as usize);
                        *y = *y - l * x;
                    }
                    p0 = p1 as usize;
                }
                m0 = m1 as usize;
            }
            for &[pivot, at] in &self.recips {
                *a.get_unchecked_mut(at as usize) = S::one() / *a.get_unchecked(pivot as usize);
            }
        }
    }

    /// Assembles and factorises into a (Factors::j) from the Jacobian's
    /// values; the pivots' figures (J_s's: det times `sign`), None where a
    /// pivot is zero or not finite, a multiplier of J_s above MULTIPLIER,
    /// a folded pivot not exactly 1, a negated one (`minus_entries`) not
    /// exactly -1, or an entry taken for zero that is not (checked where
    /// `zeros`: the values' Kin may not have those zeros). The steps on a
    /// negated pivot take 1 / -1 without the division (`NEGATE`).
    /// `place`: as `eliminate_as`'s.
    #[inline]
    pub fn run(
        &self,
        values: &[f64],
        place: &[[u32; 2]],
        a: &mut [f64],
        sign: i32,
        zeros: bool,
        signs: bool,
    ) -> Option<Pivots> {
        let mut ok = true;
        // false for a zero or non-finite pivot too
        let check = |l: f64, scale: f64| ok &= (l * scale).abs() <= MULTIPLIER;
        // the loop with the steps' negation test only where a step is negated (the others' loop is as before)
        if self.negated_steps {
            self.eliminate_as::<true, f64>(values, place, a, check);
        } else {
            self.eliminate_as::<false, f64>(values, place, a, check);
        }
        // SAFETY (every unchecked index below): Factoring::check when built, and eliminate's asserted lengths
        unsafe {
            // (not where the values keep them: `signs` false, Factors::signs_hold)
            if signs {
                for &e in &self.one_entries {
                    ok &= *values.get_unchecked(e as usize) == 1.0;
                }
                for &e in &self.minus_entries {
                    ok &= *values.get_unchecked(e as usize) == -1.0;
                }
            }
            if zeros {
                for &e in &self.zero_entries {
                    ok &= *values.get_unchecked(e as usize) == 0.0;
                }
            }
            if !ok {
                return None;
            }
            let det = if self.minus_odd { -sign } else { sign };
            let mut acc = Pivots { small: f64::INFINITY, big: 0.0, at: 0, det };
            for &(at, p, scale) in &self.free {
                let d = *a.get_unchecked(at as usize) * scale;
                let x = d.abs();
                if !(x > 0.0 && x <= f64::MAX) {
                    return None; // zero or not finite
                }
                if d < 0.0 {
                    acc.det = -acc.det;
                }
                acc.take(x, p as usize);
                if x > acc.big {
                    acc.big = x; // f64::max's figure: neither is NaN
                }
            }
            if (self.first_one as usize) < self.diag.len() {
                // the folded pivots, each exactly 1 (checked above): J_s's c_p / r_p, the
                // smallest at the first position of the least, as the loop over all of them takes it
                let p = self.first_one as usize;
                if self.ones_small < acc.small || (self.ones_small == acc.small && p < acc.at) {
                    (acc.small, acc.at) = (self.ones_small, p);
                }
                if self.ones_big > acc.big {
                    acc.big = self.ones_big; // f64::max's figure: neither is NaN
                }
            }
            Some(acc)
        }
    }
}

/// One diagonal block: its first position, size, where its s x s factors
/// start in Factors::j, and its fixed order (None for a 1x1 block).
#[derive(Clone, Debug)]
pub struct Diagonal {
    pub at: usize,
    pub s: usize,
    pub store: usize,
    pub order: Option<Order>,
    /// a 1x1 block's Jacobian entries: the last one sets it
    pub entries: Vec<u32>,
}

/// The blocks in solve order, the entries below them, and the whole
/// matrix's partial-pivoting fallback.
#[derive(Clone, Debug)]
pub struct Triangular {
    pub blocks: Vec<Diagonal>,
    /// the off-diagonal Jacobian entries: their values are stored in
    /// Factors::j from `off_at`, in this order
    pub off_entries: Vec<u32>,
    pub off_at: usize,
    /// the solve (`Program`) over Factors::j: block k's off-diagonal
    /// entries, then its division (1x1) or its elimination, block after
    /// block; its places are the coordinates (position p's is scatter[p]),
    /// so that it runs in the solution itself (`run`)
    pub program: Program,
    /// the blocks' factorisation (`Factoring`)
    pub factoring: Factoring,
    /// per position p: its model row gather[p] and coordinate scatter[p]
    pub gather: Vec<usize>,
    pub scatter: Vec<usize>,
    /// per model row i: the coordinate (the place of the program) that
    /// b[i] goes to (the factors being Phi_q's, unscaled: `Factoring`)
    pub into: Vec<u32>,
    /// the sign of the permutation into the blocks' order
    pub sign: i32,
    /// the fallback in the model's own order: positions of rows and
    /// coordinates, its entries (Jacobian entry, position r n + c, scale),
    /// row and column patterns (up to MASK coordinates; none above), the
    /// sign of the model's order
    pub whole_row: Vec<usize>,
    pub whole_col: Vec<usize>,
    pub whole_entries: Vec<(u32, u32, f64)>,
    pub whole_patterns: Vec<(u64, u64)>,
    pub whole_sign: i32,
    /// the position (in the blocks' order) of the coordinate at each of the fallback's positions
    pub whole_to_pos: Vec<usize>,
}

impl Triangular {
    /// The factors' storage: the fallback's n x n, then the blocks', then
    /// the off-diagonal values, then the pivots' reciprocals.
    pub fn stored(&self) -> usize {
        self.factoring.values
    }

    /// The invariants the solve relies on beyond its program's: gather and
    /// scatter are permutations of the n positions, and so is into.
    pub fn check(&self) -> Result<(), String> {
        let n = self.gather.len();
        let perm = |p: &[usize]| {
            let mut seen = vec![false; n];
            p.len() == n && p.iter().all(|&i| i < n && !std::mem::replace(&mut seen[i], true))
        };
        let into: Vec<usize> = self.into.iter().map(|&j| j as usize).collect();
        if !perm(&self.gather) || !perm(&self.scatter) || !perm(&into) {
            return Err("triangular: gather, scatter and into are not permutations of the positions".into());
        }
        self.program.check()?;
        self.factoring.check()
    }

    /// The program of the blocks' solve (off_at: where the off-diagonal
    /// values are stored; folded: the 1x1 blocks without a division; still:
    /// the blocks whose rows' nu was zero at every trial), its quiet positions (`Program`: the still 1x1 blocks whose
    /// off-diagonal entries, the zeros aside, all read quiet positions: a
    /// ground's, a body pinned at its origin to it, an angle tied to the
    /// ground's), checked (`Program::check`).
    pub fn program(
        blocks: &[Diagonal],
        off: &[(usize, usize, usize)],
        off_at: usize,
        n: usize,
        folded: &[bool],
        still: &[bool],
    ) -> Result<Program, String> {
        let recip_at = off_at + off.len();
        let mut p = Program { positions: n, values: recip_at + n, ..Program::default() };
        let (mut next, mut quiet) = (0, vec![false; n]);
        for (k, d) in blocks.iter().enumerate() {
            // off: (block of the row, row position, column position), sorted by block
            let mut reads_quiet = true;
            while next < off.len() && off[next].0 == k {
                p.sub(off[next].1, off[next].2, off_at + next);
                reads_quiet &= quiet[off[next].2];
                next += 1;
            }
            match &d.order {
                None if folded[k] => quiet[d.at] = still[k] && reads_quiet,
                None => {
                    p.div(d.at, d.store);
                    quiet[d.at] = still[k] && reads_quiet;
                }
                Some(o) => o.program(d.at, d.store, &mut p),
            }
        }
        if next != off.len() || p.divs.len() + folded.iter().filter(|&&f| f).count() != n {
            return Err("program: an off-diagonal entry out of order, or a position without its pivot".into());
        }
        // each division by position r's pivot: a product with its reciprocal (Factoring::recip_at)
        for d in &mut p.divs {
            d[2] = (recip_at + d[1] as usize) as u32;
        }
        p.quieten((0..n).filter(|&i| quiet[i]).map(|i| i as u32).collect());
        p.check()?;
        Ok(p)
    }

    /// The factorisation of the blocks (see `Factoring`) over `entries`
    /// Jacobian entries (folded: the 1x1 blocks whose pivot must be 1;
    /// row_scale, col_scale: per position, its row's and coordinate's
    /// scales), checked (`Factoring::check`).
    pub fn factoring(
        blocks: &[Diagonal],
        off: &[u32],
        off_at: usize,
        entries: usize,
        folded: &[bool],
        row_scale: &[f64],
        col_scale: &[f64],
    ) -> Result<Factoring, String> {
        let recip_at = off_at + off.len();
        let n = row_scale.len();
        let mut f = Factoring { values: recip_at + n, entries, recip_at: recip_at as u32, ..Factoring::default() };
        f.place.extend(off.iter().enumerate().map(|(x, &e)| [e, (off_at + x) as u32]));
        for (k, d) in blocks.iter().enumerate() {
            match &d.order {
                None if folded[k] => {
                    // one entry (plan::triangulate_still), checked instead of placed
                    f.one_entries.extend(&d.entries);
                    f.diag.push(d.store as u32);
                    f.ones.push(d.store as u32);
                }
                None => {
                    f.place.extend(d.entries.iter().map(|&e| [e, d.store as u32]));
                    f.diag.push(d.store as u32);
                    f.recips.push([d.store as u32, (recip_at + d.at) as u32]);
                }
                Some(o) => {
                    let from = f.mults.len();
                    o.factoring(d.store, recip_at + d.at, &mut f);
                    // multiplier (i, k) of the block at store + i s + k: rows d.at + i, d.at + k
                    let rows = |at: u32| {
                        let x = at as usize - d.store;
                        (d.at + x / d.s, d.at + x % d.s)
                    };
                    let scales = f.mults[from..].iter().map(|m| rows(m[0])).map(|(i, k)| row_scale[k] / row_scale[i]);
                    f.mult_scale.extend(scales.collect::<Vec<_>>());
                }
            }
        }
        if f.diag.len() != row_scale.len() || row_scale.len() != col_scale.len() {
            return Err("factoring: a scale per position needed".into());
        }
        f.pivot_scale = (0..f.diag.len()).map(|p| col_scale[p] / row_scale[p]).collect();
        let folded_at = |at: &u32| f.ones.contains(at);
        f.free = (f.diag.iter().enumerate())
            .filter(|(_, at)| !folded_at(at))
            .map(|(p, &at)| (at, p as u32, f.pivot_scale[p]))
            .collect();
        let ones = (f.diag.iter().enumerate()).filter(|(_, at)| folded_at(at)).map(|(p, _)| (f.pivot_scale[p], p));
        let (mut small, mut big, mut first) = (f64::INFINITY, 0.0f64, f.diag.len());
        for (x, p) in ones {
            if x < small {
                (small, first) = (x, p);
            }
            big = big.max(x);
        }
        (f.ones_small, f.ones_big, f.first_one) = (small, big, first as u32);
        // the places written by anything but one placement
        let mut writes = vec![0u32; f.values];
        let places = f.place.iter().map(|p| p[1]);
        let steps = f.steps.iter().map(|s| s[2]);
        let mults = f.mults.iter().map(|m| m[0]);
        let pairs = f.pairs.iter().map(|p| p[0]);
        let recips = f.recips.iter().map(|r| r[1]);
        let others = f.clear.iter().chain(&f.ones).chain(&f.minus_recips).copied();
        for at in places.chain(steps).chain(mults).chain(pairs).chain(recips).chain(others) {
            if let Some(w) = writes.get_mut(at as usize) {
                *w += 1;
            }
        }
        f.place_free = f.place.iter().map(|p| writes.get(p[1] as usize) == Some(&1)).collect();
        f.check()?;
        Ok(f)
    }

    /// The blocks factorised in order (f.fixed[0]: their pivots' figures),
    /// or the whole matrix with partial pivoting (f.fixed[0] None).
    /// Not inlined into Layout::factor (as it was not before round 21:
    /// inlined there, the four-bar's march took 3 to 5 % longer, the
    /// instructions the same).
    #[inline(never)]
    pub fn factor(&self, values: &[f64], f: &mut Factors) {
        f.fixed[0] = self.blocks_factor(values, f).filter(|p| p.ratio() >= FALLBACK);
        if f.fixed[0].is_some() {
            return;
        }
        // the whole matrix's factors overwrite the constants placed once (Factors::placed)
        f.placed = false;
        let n = self.gather.len();
        let a = &mut f.j[..n * n];
        a.fill(0.0);
        for &(e, pos, scale) in &self.whole_entries {
            a[pos as usize] = values[e as usize] * scale;
        }
        if n > MASK {
            return dense_factor(a, n, &mut f.piv);
        }
        for i in 0..n {
            (f.rm[i], f.cm[i]) = self.whole_patterns[i];
        }
        masked_factor(a, n, &mut f.piv, &mut f.rm, &mut f.cm);
    }

    /// Every placement, or where the constants placed once are in the
    /// factors (Factors::placed) the others (Factors::again).
    #[inline(always)]
    fn blocks_factor(&self, values: &[f64], f: &mut Factors) -> Option<Pivots> {
        let Factors { j, again, once, placed, zeros_hold, signs_hold, .. } = f;
        let place = if *placed {
            &again[..]
        } else {
            // every placement: the constants are in place again for the next
            *placed = *once;
            &self.factoring.place[..]
        };
        self.factoring.run(values, place, j, self.sign, !*zeros_hold, !*signs_hold)
    }

    /// x = Phi_q^-1 b (model rows in, coordinates out); scale, col_scale:
    /// the layout's (the fallback's solve is Layout::solve's, to the bit).
    pub fn solve(&self, f: &mut Factors, b: &[f64], x: &mut [f64], scale: &[f64], col_scale: &[f64]) {
        let n = self.gather.len();
        let (j, w) = (&f.j, &mut f.w[..n]);
        if f.fixed[0].is_none() {
            w.fill(0.0);
            for (i, &p) in self.whole_row.iter().enumerate() {
                w[p] = b[i] / scale[i];
            }
            if n > MASK {
                dense_solve(&j[..n * n], n, &f.piv, w);
            } else {
                masked_solve(&j[..n * n], n, &f.piv, &f.rm, w);
            }
            for (j, &p) in self.whole_col.iter().enumerate() {
                x[j] = w[p] * col_scale[j];
            }
            return;
        }
        self.run_negating(j, b, x);
    }

    /// x = Phi_q^-1 b with the blocks' factors a (block-triangular: not the
    /// whole matrix's fallback; Phi_q's own, unscaled: `Factoring`): each
    /// row's right side into its coordinate (`into`), then the program in x
    /// itself, without the scatter's permutation. Over f64, variants' lanes
    /// or several right-hand sides (`Cell`).
    #[inline(always)]
    pub fn run<A: Copy, W: Cell<A>>(&self, a: &[A], b: &[W], x: &mut [W]) {
        self.sides_into(b, x);
        self.program.run(a, x);
    }

    /// `run` over f64 on factors from `factor` (`Program::run_negating`):
    /// whether it ran quiet (every quiet position's x is its row's b, to the bit).
    #[inline(always)]
    pub fn run_negating(&self, a: &[f64], b: &[f64], x: &mut [f64]) -> bool {
        self.sides_into(b, x);
        self.program.run_negating(a, x)
    }

    /// Each row's right side b[i] into its coordinate x[into[i]].
    #[inline(always)]
    fn sides_into<W: Copy>(&self, b: &[W], x: &mut [W]) {
        let n = self.into.len();
        assert!(b.len() >= n && x.len() >= n);
        for (&v, &j) in b.iter().zip(&self.into) {
            // SAFETY: into holds coordinates below n (Triangular::check, when built); x.len() >= n asserted
            unsafe { *x.get_unchecked_mut(j as usize) = v };
        }
    }

    /// (pivot ratio, det sign, position of the smallest |pivot| in the
    /// blocks' order) of the factors.
    pub fn pivots(&self, f: &Factors) -> (f64, i32, usize) {
        if let Some(p) = &f.fixed[0] {
            return (p.ratio(), p.det, p.at);
        }
        let n = self.gather.len();
        let mut acc = Pivots { small: f64::INFINITY, big: 0.0, at: 0, det: self.whole_sign };
        for j in 0..n {
            if !acc.visit(f.j[j * n + j], f.piv[j] != j, true, self.whole_to_pos[j]) {
                return (0.0, acc.det, acc.at);
            }
        }
        (acc.ratio(), acc.det, acc.at)
    }
}
