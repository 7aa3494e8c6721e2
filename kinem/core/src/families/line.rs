//! Point on a line fixed in a body: the translational joint (Eqs.
//! 4.10-4.12, Table 4.2) and the revolute-translational joint (Eq. 4.16);
//! gamma from Table 4.3.
//!
//! Both are the scalar cross product u x d = 0 of the line direction u (two
//! points of the line body a) and the vector d from the line's base point
//! to a point of the other body b: Eq. 4.12's first row with a = i,
//! u = P_i - Q_i, d = P_j - P_i, and Eq. 4.16 with a = j, u = Q_j - P_j,
//! d = P_i - P_j. A translational joint adds the row
//! phi_i - phi_j - (phi_i^0 - phi_j^0) = 0 (Eq. 4.10 as corrected).
use super::{cross, dot, each_side, i, iz, lane, sides, At, Dir, Kept, Shared, Sides};
use crate::real::{Lanes, Real};
use crate::table::Table;
use num_complex::{Complex, Complex64 as C64};

/// Columns: ca, cb the x columns of the line body a and the other body b;
/// pa (the line's base point on a), ua (its direction, local to a), ob
/// (the point on b); ai, aj, phi0 the angle row's columns and constant,
/// either all empty (revolute-translational: one row per constraint) or
/// one per constraint (translational: two rows); ai and aj are held in
/// the groups' rows alone (`Row`).
///
/// Invariants (checked in `new`): pa, ua, cb, ob as long as ca (and ai, aj,
/// phi0 when `angle`); every ca, cb below n - 2, every ai, aj below n; so a
/// kernel that checked `At::holds(n)` reads them unchecked.
///
/// The value kernels (phi, jac, gamma) run over `groups`, the same
/// constraints grouped by which of pa, ob are exactly zero (value and every
/// tangent: `Complex::is_zero`), each group by its own kernel without the
/// products with them (`Sides`); the direct tangent kernels read the columns.
pub struct Line<S = f64> {
    n: usize,
    ca: Vec<usize>,
    pa: Vec<Complex<S>>,
    ua: Vec<Complex<S>>,
    cb: Vec<usize>,
    ob: Vec<Complex<S>>,
    phi0: Vec<S>,
    angle: bool,
    /// the constraints by Sides<A, B>::GROUP
    groups: [Vec<Row<S>>; 4],
}

/// One constraint of a group: its columns and vectors, and its place c
/// (its u x d row, `per` c; its Jacobian entries from `width` c).
struct Row<S> {
    ca: usize,
    cb: usize,
    pa: Complex<S>,
    ua: Complex<S>,
    ob: Complex<S>,
    c: usize,
    /// the angle row's columns and constant (a translational joint's; 0
    /// and zero otherwise, not read)
    ai: usize,
    aj: usize,
    phi0: S,
}

/// u = A_a u'_a, d = r_b + A_b s'_b - r_a - A_a s'_a, A_a s'_a, A_b s'_b.
struct Parts<S> {
    u: Complex<S>,
    d: Complex<S>,
    sa: Complex<S>,
    sb: Complex<S>,
}

impl<S: Real> Line<S> {
    pub fn new(t: &Table, n: usize) -> Result<Self, String> {
        let ca = t.index("ca", n.saturating_sub(2))?;
        let c = ca.len();
        t.same_length(c, &["pa", "ua", "cb", "ob"])?;
        let ai = t.index("ai", n)?;
        let angle = !ai.is_empty();
        t.same_length(if angle { c } else { 0 }, &["ai", "aj", "phi0"])?;
        let (pa, ua, cb, ob) = (t.cplx_s("pa")?, t.cplx_s("ua")?, t.index("cb", n.saturating_sub(2))?, t.cplx_s("ob")?);
        let (aj, phi0): (Vec<usize>, Vec<S>) = (t.index("aj", n)?, t.real_s("phi0")?);
        let groups = sides(&pa, &ob, |k| Row {
            ca: ca[k],
            cb: cb[k],
            pa: pa[k],
            ua: ua[k],
            ob: ob[k],
            c: k,
            ai: if angle { ai[k] } else { 0 },
            aj: if angle { aj[k] } else { 0 },
            phi0: if angle { phi0[k] } else { S::zero() },
        });
        Ok(Line { phi0, n, ca, pa, ua, cb, ob, angle, groups })
    }

    /// The rows per constraint (2 for a translational joint, else 1).
    pub fn per(&self) -> usize {
        if self.angle {
            2
        } else {
            1
        }
    }

    fn width(&self) -> usize {
        if self.angle {
            8
        } else {
            6
        }
    }

    pub fn rows(&self) -> usize {
        self.per() * self.ca.len()
    }

    pub fn entries(&self) -> usize {
        self.width() * self.ca.len()
    }

    /// The parts of constraint r of Sides<A, B> (sa, sb zero where left out).
    ///
    /// # Safety
    /// `at.holds(n)` (Line's invariants: r.ca, r.cb < n - 2).
    #[inline(always)]
    unsafe fn parts<const A: bool, const B: bool>(at: &At<S>, r: &Row<S>) -> Parts<S> {
        let zero = Complex::new(S::zero(), S::zero());
        let ea = at.rot_at(r.ca);
        let (sa, sb) = (if A { r.pa * ea } else { zero }, if B { r.ob * at.rot_at(r.cb) } else { zero });
        let mut d = at.r_at(r.cb);
        if B {
            d = d + sb;
        }
        d = d - at.r_at(r.ca);
        if A {
            d = d - sa;
        }
        Parts { u: r.ua * ea, d, sa, sb }
    }

    /// u x d (Eqs. 4.12, 4.16), then phi_i - phi_j - phi0 for translational joints.
    pub fn phi(&self, at: &At<S>, _: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n) && out.len() >= self.rows());
        each_side!(self.phi_of(at, out));
    }

    /// u x d over the constraints of Sides<A, B>, then a translational
    /// joint's angle row in the same pass (`phi` asserted out's rows and n).
    #[inline(always)]
    fn phi_of<const A: bool, const B: bool>(&self, at: &At<S>, out: &mut [S]) {
        let per = self.per();
        for r in &self.groups[Sides::<A, B>::GROUP] {
            // SAFETY: r.c < ca.len(); q and e hold n, out per rows per constraint (phi); ai, aj < n (new)
            unsafe {
                let p = Self::parts::<A, B>(at, r);
                *out.get_unchecked_mut(per * r.c) = cross(p.u, p.d);
                if self.angle {
                    *out.get_unchecked_mut(2 * r.c + 1) =
                        *at.q.get_unchecked(r.ai) - *at.q.get_unchecked(r.aj) - r.phi0;
                }
            }
        }
    }

    /// Columns [x_a, y_a, phi_a, x_b, y_b, phi_b] of u x d (Table 4.2), then
    /// [phi_i, phi_j] = [1, -1] for translational joints.
    pub fn jac(&self, at: &At<S>, _: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n) && out.len() >= self.entries());
        each_side!(self.jac_of::<true>(at, out));
    }

    /// `jac` where out holds the family's Jacobian from an earlier `jac`
    /// (its constant entries kept): the angle rows' [1, -1] are not written again.
    pub fn jac_over(&self, at: &At<S>, _: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n) && out.len() >= self.entries());
        each_side!(self.jac_of::<false>(at, out));
    }

    /// The entry u . A_b s'_b (5: phi_b's) where ob is exactly zero (the
    /// groups `jac_of` writes it as a constant zero), marked in out.
    pub fn zero_entries(&self, out: &mut [bool]) {
        let width = self.width();
        for (g, group) in self.groups.iter().enumerate() {
            if g & 1 != 0 {
                // Sides::<A, B>::GROUP = !A * 2 + !B: ob is zero
                for r in group {
                    out[width * r.c + 5] = true;
                }
            }
        }
    }

    /// Table 4.2's row over the constraints of Sides<A, B> (d + sa = d
    /// where sa is left out, u . sb = 0 where sb is), the angle rows'
    /// constant entries when ALL; `jac` asserted out's entries and n.
    #[inline(always)]
    fn jac_of<const A: bool, const B: bool, const ALL: bool>(&self, at: &At<S>, out: &mut [S]) {
        let width = self.width();
        for r in &self.groups[Sides::<A, B>::GROUP] {
            // SAFETY: r.c < ca.len(); q and e hold n, out width entries per constraint (jac)
            unsafe {
                let p = Self::parts::<A, B>(at, r);
                let o = out.get_unchecked_mut(width * r.c..width * r.c + width);
                let ta = if A { dot(p.u, p.d + p.sa) } else { dot(p.u, p.d) };
                let tb = if B { dot(p.u, p.sb) } else { S::zero() };
                o[..6].copy_from_slice(&[p.u.im, -p.u.re, -ta, -p.u.im, p.u.re, tb]);
                if ALL && self.angle {
                    o[6] = S::one();
                    o[7] = -S::one();
                }
            }
        }
    }

    /// -(u x d)'' without the acceleration terms (Table 4.3), then 0.
    pub fn gamma(&self, at: &At<S>, qd: &[S], s: &Shared<S>, out: &mut [S]) {
        self.gamma_as::<true>(at, qd, s, out)
    }

    /// `gamma` where out holds 0 at the angle rows (an earlier `gamma`'s,
    /// or zeros), which are not written again.
    pub fn gamma_over(&self, at: &At<S>, qd: &[S], s: &Shared<S>, out: &mut [S]) {
        self.gamma_as::<false>(at, qd, s, out)
    }

    /// `gamma`, the angle rows (0) written when ALL.
    #[inline(always)]
    fn gamma_as<const ALL: bool>(&self, at: &At<S>, qd: &[S], _: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n) && qd.len() >= self.n && out.len() >= self.rows());
        each_side!(self.gamma_of(at, qd, out));
        if ALL && self.angle {
            for o in out.chunks_exact_mut(2).take(self.ca.len()) {
                o[1] = S::zero();
            }
        }
    }

    /// Table 4.3's row over the constraints of Sides<A, B>: the terms of sa,
    /// sb left out where they are (`gamma` asserted out's rows and n).
    #[inline(always)]
    fn gamma_of<const A: bool, const B: bool>(&self, at: &At<S>, qd: &[S], out: &mut [S]) {
        let per = self.per();
        for r in &self.groups[Sides::<A, B>::GROUP] {
            // SAFETY: r.c < ca.len(); q, e and qd hold n, out per rows per constraint (gamma)
            unsafe {
                let p = Self::parts::<A, B>(at, r);
                let (a, b) = (r.ca, r.cb);
                let wa = *qd.get_unchecked(a + 2);
                let (ra, rb) = (
                    Complex::new(*qd.get_unchecked(a), *qd.get_unchecked(a + 1)),
                    Complex::new(*qd.get_unchecked(b), *qd.get_unchecked(b + 1)),
                );
                let mut dd = rb;
                if B {
                    dd = dd + i::<S>() * p.sb * *qd.get_unchecked(b + 2);
                }
                dd = dd - ra;
                if A {
                    dd = dd - i::<S>() * p.sa * wa;
                }
                let mut g = wa * wa * cross(p.u, p.d) + wa * dot(p.u, dd) * 2.0;
                if A || B {
                    let wb = *qd.get_unchecked(b + 2);
                    let big = match (A, B) {
                        (true, true) => p.sb * (wb * wb) - p.sa * (wa * wa),
                        (false, true) => p.sb * (wb * wb),
                        _ => -(p.sa * (wa * wa)),
                    };
                    g = g + cross(p.u, big);
                }
                *out.get_unchecked_mut(per * r.c) = g;
            }
        }
    }
}

/// The direct tangent kernels (super::Family::phi_tangent, jac_products,
/// gamma_tangent) of u x d = 0: with dA = i A dphi (Eq. 4.44), du = i u
/// s_phi_a + d(u') A_a, dsa = i sa s_phi_a + d(s'_a) A_a, dsb likewise,
/// and dd = dr_b + dsb - dr_a - dsa, lane by lane (the translational
/// joint's angle row has no tangent but its phi0's).
impl<const N: usize> Line<Lanes<N>> {
    /// The values (u, d, sa, sb) of constraint c (`slides_products`' x).
    ///
    /// # Safety
    /// c < ca.len() and `at.holds(n)` (Line's invariants).
    #[inline(always)]
    unsafe fn values(&self, at: &At, c: usize) -> [C64; 4] {
        let (a, b) = (*self.ca.get_unchecked(c), *self.cb.get_unchecked(c));
        let (ea, eb) = (at.rot_at(a), at.rot_at(b));
        let v = |x: &Complex<Lanes<N>>| C64::new(x.re.v, x.im.v);
        let (sa, sb) = (v(self.pa.get_unchecked(c)) * ea, v(self.ob.get_unchecked(c)) * eb);
        [v(self.ua.get_unchecked(c)) * ea, at.r_at(b) + sb - at.r_at(a) - sa, sa, sb]
    }

    /// The tangents (du, dd) of constraint c in lane l along the tables
    /// alone (q' = 0: `phi_tangent`), each a sum over +0 as
    /// `slides_products`' MOVED terms are (a -0 tangent gives +0).
    ///
    /// # Safety
    /// As `values`'.
    #[inline(always)]
    unsafe fn table_tangents(&self, at: &At, c: usize, l: usize) -> [C64; 2] {
        let (ea, eb) = (at.rot_at(*self.ca.get_unchecked(c)), at.rot_at(*self.cb.get_unchecked(c)));
        let zero = C64::new(0.0, 0.0);
        let du = zero + lane(*self.ua.get_unchecked(c), l).1 * ea;
        let dsa = zero + lane(*self.pa.get_unchecked(c), l).1 * ea;
        let dsb = zero + lane(*self.ob.get_unchecked(c), l).1 * eb;
        [du, zero + dsb - dsa]
    }

    /// d/dp of Eqs. 4.12, 4.16 at q' = 0 (du x d + u x dd), then -d(phi0).
    pub fn phi_tangent(&self, at: &At, out: &mut [[f64; N]]) {
        let per = self.per();
        assert!(at.holds(self.n) && out.len() >= per * self.ca.len());
        for c in 0..self.ca.len() {
            // SAFETY: c < ca.len(), e holds n (asserted above)
            let x = unsafe { self.values(at, c) };
            for l in 0..N {
                // SAFETY: as above
                let [du, dd] = unsafe { self.table_tangents(at, c, l) };
                out[per * c][l] = -(cross(du, x[1]) + cross(x[0], dd));
                if self.angle {
                    out[2 * c + 1][l] = self.phi0[c].d[l]; // (-(-d(phi0)), exactly)
                }
            }
        }
    }

    /// Kept's sizes: per constraint its `values` (u, d, sa, sb) and their
    /// `tangents` (re, im of each).
    pub fn kept(&self) -> (usize, usize) {
        (4 * self.ca.len(), 8 * self.ca.len())
    }

    /// r2 -= D(J) v[0], r3 -= D(J) v[1]: the u x d row's six entries
    /// (Table 4.2); the angle row's are constant. By `slides_products` over
    /// every constraint (the sensitivity pass's own kernel); the
    /// constraints' values and tangents into `keep` where it holds them
    /// (`kept`).
    pub fn jac_products(&self, d: &Dir<N>, v: &[&[f64]], r2: &mut [[f64; N]], r3: &mut [[f64; N]], keep: Kept<N>) {
        let (n, per, count) = (self.n, self.per(), self.ca.len());
        assert!(d.at.holds(n) && d.s.len() >= n && !v.is_empty() && v.iter().all(|x| x.len() >= n));
        assert!(r2.len() >= per * count && (v.len() < 2 || r3.len() >= per * count));
        let keeps = keep.v.len() >= 4 * count && keep.d.len() >= 8 * count;
        let slides = self.slides(0, |_| true);
        let mut kept = vec![SlideKept::default(); count];
        let (q, e, s) = (d.at.q, d.at.e, d.s);
        let mut scratch = if v.len() < 2 && keeps { vec![[0.0; N]; per * count] } else { Vec::new() };
        let (qdd, r3): (&[f64], &mut [[f64; N]]) = if v.len() >= 2 { (v[1], r3) } else { (v[0], &mut scratch) };
        // SAFETY: every constraint's columns below n (new), which q, e, s and v hold, its row below per count <=
        // r2's, r3's (or the scratch's) length, kept count long (asserted above)
        unsafe {
            match (d.moved, v.len() >= 2 || keeps) {
                (true, true) => slides_products::<N, true, true>(&slides, q, e, s, v[0], qdd, r2, r3, &mut kept),
                (false, true) => slides_products::<N, false, true>(&slides, q, e, s, v[0], qdd, r2, r3, &mut kept),
                (true, false) => slides_products::<N, true, false>(&slides, q, e, s, v[0], qdd, r2, r3, &mut kept),
                (false, false) => slides_products::<N, false, false>(&slides, q, e, s, v[0], qdd, r2, r3, &mut kept),
            }
        }
        if keeps {
            for (c, k) in kept.iter().enumerate() {
                keep.v[4 * c..4 * c + 4].copy_from_slice(&k.v);
                for (l, t) in k.d.iter().enumerate() {
                    for (m, t) in t.iter().enumerate() {
                        (keep.d[8 * c + 2 * m][l], keep.d[8 * c + 2 * m + 1][l]) = (t.re, t.im);
                    }
                }
            }
        }
    }

    /// D(gamma) of Table 4.3's u x d row: d(wa^2 u x d + 2 wa u . d' +
    /// u x (sb wb^2 - sa wa^2)), d' = rb' + i sb wb - ra' - i sa wa; the
    /// angle row's 0. By `slides_gamma` over every constraint; the values
    /// and tangents from `kept` where it holds them (jac_products' at the
    /// same s), else taken here.
    pub fn gamma_tangent(&self, d: &Dir<N>, out: &mut [[f64; N]], kept: Kept<N>) {
        let (n, per, count) = (self.n, self.per(), self.ca.len());
        assert!(d.at.holds(n) && d.qd.len() >= n && d.s.len() >= n && d.sd.len() >= n && out.len() >= per * count);
        let slides = self.slides(0, |_| true);
        let keeps = kept.v.len() >= 4 * count && kept.d.len() >= 8 * count;
        let mut k = vec![SlideKept::default(); count];
        if keeps {
            for (c, k) in k.iter_mut().enumerate() {
                k.v.copy_from_slice(&kept.v[4 * c..4 * c + 4]);
                for (l, t) in k.d.iter_mut().enumerate() {
                    *t = std::array::from_fn(|m| C64::new(kept.d[8 * c + 2 * m][l], kept.d[8 * c + 2 * m + 1][l]));
                }
            }
        } else {
            let (mut r2, mut r3) = (vec![[0.0; N]; per * count], vec![[0.0; N]; per * count]);
            let (q, e, s, qd) = (d.at.q, d.at.e, d.s, d.qd);
            // SAFETY: as jac_products' (the scratch rows per count long)
            unsafe {
                if d.moved {
                    slides_products::<N, true, true>(&slides, q, e, s, qd, qd, &mut r2, &mut r3, &mut k);
                } else {
                    slides_products::<N, false, true>(&slides, q, e, s, qd, qd, &mut r2, &mut r3, &mut k);
                }
            }
        }
        // SAFETY: every constraint's columns below n, which qd and sd hold, its row below per count <= out.len(),
        // k count long (asserted above)
        unsafe { slides_gamma(&slides, d.qd, d.sd, out, &k) }
    }
}

/// A point-on-line constraint in a per-set-up list (crate::sensitivity's
/// `Reach`): its bodies' x columns (ca, cb), its u x d row among the
/// model's, its vectors' values (pa, ua, ob) and their tangents per lane
/// (ua, pa, ob: the table terms, read by `slides_products`'
/// MOVED list alone: the constraints of a moved family, every one of them).
pub struct Slide<const N: usize> {
    a: usize,
    b: usize,
    row: usize,
    pa: C64,
    ua: C64,
    ob: C64,
    t: [[C64; 3]; N],
}

/// What `slides_products` keeps per constraint for `slides_gamma` (its
/// `values` and, per lane, their `tangents`).
#[derive(Clone, Copy)]
pub struct SlideKept<const N: usize> {
    v: [C64; 4],
    d: [[C64; 4]; N],
}

impl<const N: usize> Default for SlideKept<N> {
    fn default() -> Self {
        SlideKept { v: [C64::new(0.0, 0.0); 4], d: [[C64::new(0.0, 0.0); 4]; N] }
    }
}

impl<const N: usize> Slide<N> {
    /// (the largest column read, the row written).
    pub fn bounds(&self) -> (usize, usize) {
        (self.a.max(self.b) + 2, self.row)
    }
}

impl<const N: usize> Line<Lanes<N>> {
    /// The constraints c with `take(c)` as list entries (`Slide`), the
    /// family's first row `row0` among the model's.
    pub fn slides(&self, row0: usize, take: impl Fn(usize) -> bool) -> Vec<Slide<N>> {
        let value = |t: &Complex<Lanes<N>>| C64::new(t.re.v, t.im.v);
        (0..self.ca.len())
            .filter(|&c| take(c))
            .map(|c| Slide {
                a: self.ca[c],
                b: self.cb[c],
                row: row0 + self.per() * c,
                pa: value(&self.pa[c]),
                ua: value(&self.ua[c]),
                ob: value(&self.ob[c]),
                t: std::array::from_fn(|l| [lane(self.ua[c], l).1, lane(self.pa[c], l).1, lane(self.ob[c], l).1]),
            })
            .collect()
    }
}

/// D(J) over a list of constraints (`Line::jac_products` runs it over
/// every constraint): r2 -= D(J) qd and, where L3, r3 -= D(J) qdd at each u x d row,
/// the values and tangents kept in `kept` (one per constraint) where L3;
/// MOVED: the tables' tangents taken (a moved family's constraints).
///
/// # Safety
/// q, e, s, qd (and qdd where L3) hold every constraint's columns, r2
/// (and r3 where L3) its row (`Slide::bounds`), kept (where L3)
/// slides.len() entries.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub unsafe fn slides_products<const N: usize, const MOVED: bool, const L3: bool>(
    slides: &[Slide<N>],
    q: &[f64],
    e: &[C64],
    s: &[[f64; N]],
    qd: &[f64],
    qdd: &[f64],
    r2: &mut [[f64; N]],
    r3: &mut [[f64; N]],
    kept: &mut [SlideKept<N>],
) {
    for (k, p) in slides.iter().enumerate() {
        let (a, b) = (p.a, p.b);
        let r = |c: usize| C64::new(*q.get_unchecked(c), *q.get_unchecked(c + 1));
        let (ea, eb) = (*e.get_unchecked(a + 2), *e.get_unchecked(b + 2));
        let (sa, sb) = (p.pa * ea, p.ob * eb);
        let x = [p.ua * ea, r(b) + sb - r(a) - sa, sa, sb];
        let [u, d, sa, sb] = x;
        let kept = kept.get_unchecked_mut(k);
        if L3 {
            kept.v = x;
        }
        for l in 0..N {
            let (pa, pb) = (s.get_unchecked(a + 2)[l], s.get_unchecked(b + 2)[l]);
            let (mut du, mut dsa, mut dsb) = (iz(u) * pa, iz(sa) * pa, iz(sb) * pb);
            let dd = C64::new(
                s.get_unchecked(b)[l] - s.get_unchecked(a)[l],
                s.get_unchecked(b + 1)[l] - s.get_unchecked(a + 1)[l],
            );
            if MOVED {
                let t = &p.t[l];
                du += t[0] * ea;
                dsa += t[1] * ea;
                dsb += t[2] * eb;
            }
            let dd = dd + dsb - dsa;
            if L3 {
                kept.d[l] = [du, dd, dsa, dsb];
            }
            let (ta, tb) = (-(dot(du, d + sa) + dot(u, dd + dsa)), dot(du, sb) + dot(u, dsb));
            let g = |k: usize| *qd.get_unchecked(k);
            let row = &mut r2.get_unchecked_mut(p.row)[l];
            *row -= du.im * (g(a) - g(b)) - du.re * (g(a + 1) - g(b + 1)) + ta * g(a + 2) + tb * g(b + 2);
            if L3 {
                let g = |k: usize| *qdd.get_unchecked(k);
                let row = &mut r3.get_unchecked_mut(p.row)[l];
                *row -= du.im * (g(a) - g(b)) - du.re * (g(a + 1) - g(b + 1)) + ta * g(a + 2) + tb * g(b + 2);
            }
        }
    }
}

/// D(gamma) of the u x d row over a list of constraints
/// (`Line::gamma_tangent` runs it over every constraint), from what
/// `slides_products` kept at the instant.
///
/// # Safety
/// qd, sd hold every constraint's columns, out its row (`Slide::bounds`),
/// kept slides.len() entries.
#[inline(always)]
pub unsafe fn slides_gamma<const N: usize>(
    slides: &[Slide<N>],
    qd: &[f64],
    sd: &[[f64; N]],
    out: &mut [[f64; N]],
    kept: &[SlideKept<N>],
) {
    for (k, p) in slides.iter().enumerate() {
        let (a, b) = (p.a, p.b);
        let kept = kept.get_unchecked(k);
        let [u, d, sa, sb] = kept.v;
        let (wa, wb) = (*qd.get_unchecked(a + 2), *qd.get_unchecked(b + 2));
        let rd = |k: usize| C64::new(*qd.get_unchecked(k), *qd.get_unchecked(k + 1));
        let rate = rd(b) + iz(sb) * wb - rd(a) - iz(sa) * wa;
        let big = sb * (wb * wb) - sa * (wa * wa);
        let (cr, dt) = (cross(u, d), dot(u, rate));
        for l in 0..N {
            let [du, dd, dsa, dsb] = kept.d[l];
            let (dwa, dwb) = (sd.get_unchecked(a + 2)[l], sd.get_unchecked(b + 2)[l]);
            let drd = |k: usize| C64::new(sd.get_unchecked(k)[l], sd.get_unchecked(k + 1)[l]);
            let drate = drd(b) + iz(dsb * wb + sb * dwb) - drd(a) - iz(dsa * wa + sa * dwa);
            let dbig = dsb * (wb * wb) + sb * (2.0 * wb * dwb) - dsa * (wa * wa) - sa * (2.0 * wa * dwa);
            let (dcr, ddt) = (cross(du, d) + cross(u, dd), dot(du, rate) + dot(u, drate));
            out.get_unchecked_mut(p.row)[l] +=
                (2.0 * wa * dwa) * cr + wa * wa * dcr + (dwa * dt + wa * ddt) * 2.0 + cross(du, big) + cross(u, dbig);
        }
    }
}
