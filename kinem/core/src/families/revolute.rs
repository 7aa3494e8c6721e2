//! Revolute joint, Eqs. 4.7-4.9; Jacobian Eq. 4.46 (Table 4.2); gamma Eq. 4.47.
use super::{each_side, lane, sides, At, Dir, Kept, Shared, Sides};
use crate::real::{Lanes, Real};
use crate::table::Table;
use num_complex::{Complex, Complex64 as C64};

/// Phi = r_i + A_i s'_i^P - r_j - A_j s'_j^P (Eq. 4.7): two rows, x and y.
/// Columns: ci, cj the bodies' x columns; si, sj the joint centre on each.
/// Invariant (checked in `new`): every ci, cj below n - 2, so a kernel
/// that checked `At::holds(n)` reads their columns unchecked.
///
/// The value kernels (phi, jac, gamma) run over `groups`, the same joints
/// grouped by which local points are exactly zero (value and every
/// tangent: `Complex::is_zero`), each group by its own kernel without the
/// products with them (`Sides`); the direct tangent kernels read the columns.
pub struct Revolute<S = f64> {
    n: usize,
    ci: Vec<usize>,
    cj: Vec<usize>,
    si: Vec<Complex<S>>,
    sj: Vec<Complex<S>>,
    /// the joints by Sides<I, J>::GROUP
    groups: [Vec<Joint<S>>; 4],
}

/// One joint of a group: its columns and local points, and its place k
/// (rows 2k, 2k + 1; Jacobian entries 8k..8k + 8).
struct Joint<S> {
    ci: usize,
    cj: usize,
    si: Complex<S>,
    sj: Complex<S>,
    k: usize,
}

impl<S: Real> Revolute<S> {
    pub fn new(t: &Table, n: usize) -> Result<Self, String> {
        let ci = t.index("ci", n.saturating_sub(2))?;
        t.same_length(ci.len(), &["cj", "si", "sj"])?;
        let (cj, si, sj) = (t.index("cj", n.saturating_sub(2))?, t.cplx_s("si")?, t.cplx_s("sj")?);
        let groups = sides(&si, &sj, |k| Joint { ci: ci[k], cj: cj[k], si: si[k], sj: sj[k], k });
        Ok(Revolute { n, ci, cj, si, sj, groups })
    }

    pub fn rows(&self) -> usize {
        2 * self.ci.len()
    }

    pub fn entries(&self) -> usize {
        8 * self.ci.len()
    }

    /// Eq. 4.7.
    #[inline(always)]
    pub fn phi(&self, at: &At<S>, _: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n) && out.len() >= self.rows());
        each_side!(self.phi_of(at, out));
    }

    /// Eq. 4.7 over the joints of Sides<I, J>; out holds 2 rows per joint
    /// and `at` n coordinates (`phi` asserted both).
    #[inline(always)]
    fn phi_of<const I: bool, const J: bool>(&self, at: &At<S>, out: &mut [S]) {
        for p in &self.groups[Sides::<I, J>::GROUP] {
            // SAFETY: ci, cj < n - 2 and k < the joints' count (new); q, e hold n, out 2 rows per joint (phi)
            unsafe {
                let mut d = at.r_at(p.ci);
                if I {
                    d = d + p.si * at.rot_at(p.ci);
                }
                d = d - at.r_at(p.cj);
                if J {
                    d = d - p.sj * at.rot_at(p.cj);
                }
                *out.get_unchecked_mut(2 * p.k) = d.re;
                *out.get_unchecked_mut(2 * p.k + 1) = d.im;
            }
        }
    }

    /// Eq. 4.46: [I, B_i s'_i, -I, -B_j s'_j]; B s' = i A s'. Pattern per
    /// constraint: row x: x_i, phi_i, x_j, phi_j; row y: y_i, phi_i, y_j, phi_j.
    pub fn jac(&self, at: &At<S>, _: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n) && out.len() >= self.entries());
        each_side!(self.jac_of::<true>(at, out));
    }

    /// `jac` where out holds the family's Jacobian from an earlier `jac`
    /// (its constant entries kept): the B s' entries alone are written, and
    /// of those only the ones that are not constant zeros (`zero_entries`:
    /// B_i s'_i where s'_i is exactly zero, -B_j s'_j where s'_j is, which
    /// `jac` wrote as +0 and -0 as this would); the joints with neither
    /// local point (Sides<false, false>) are not visited.
    pub fn jac_over(&self, at: &At<S>, _: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n) && out.len() >= self.entries());
        self.jac_of::<true, true, false>(at, out);
        self.jac_of::<true, false, false>(at, out);
        self.jac_of::<false, true, false>(at, out);
    }

    /// The entries B_i s'_i (1, 5) where s'_i is exactly zero and -B_j s'_j
    /// (3, 7) where s'_j is (the groups `jac_of` writes as constant zeros),
    /// marked in out (8 per joint).
    pub fn zero_entries(&self, out: &mut [bool]) {
        for (g, group) in self.groups.iter().enumerate() {
            let (zi, zj) = (g & 2 != 0, g & 1 != 0); // Sides::<I, J>::GROUP = !I * 2 + !J
            for p in group {
                let o = &mut out[8 * p.k..8 * p.k + 8];
                (o[1], o[5]) = (o[1] || zi, o[5] || zi);
                (o[3], o[7]) = (o[3] || zj, o[7] || zj);
            }
        }
    }

    /// Eq. 4.46 over the joints of Sides<I, J> (B 0 = 0), the constant
    /// entries (I, -I) too when ALL; out holds 8 entries per joint and `at`
    /// n coordinates (`jac` asserted both).
    #[inline(always)]
    fn jac_of<const I: bool, const J: bool, const ALL: bool>(&self, at: &At<S>, out: &mut [S]) {
        let (one, minus, zero) = (S::one(), -S::one(), S::zero());
        for p in &self.groups[Sides::<I, J>::GROUP] {
            // SAFETY: ci, cj < n - 2 and k < the joints' count (new); e holds n, out 8 entries per joint (jac)
            unsafe {
                let a = if I { p.si * at.rot_at(p.ci) } else { Complex::new(zero, zero) };
                let b = if J { p.sj * at.rot_at(p.cj) } else { Complex::new(zero, zero) };
                let o = out.get_unchecked_mut(8 * p.k..8 * p.k + 8);
                if ALL {
                    o.copy_from_slice(&[one, -a.im, minus, b.im, one, a.re, minus, -b.re]);
                } else {
                    // the entries of a side whose point is zero are constants (jac_over)
                    if I {
                        (o[1], o[5]) = (-a.im, a.re);
                    }
                    if J {
                        (o[3], o[7]) = (b.im, -b.re);
                    }
                }
            }
        }
    }

    /// Eq. 4.47: A_i s'_i w_i^2 - A_j s'_j w_j^2; with `jac`, the family's
    /// Jacobian values at the same q (`jac`'s output), a = A_i s'_i and
    /// b = A_j s'_j are read from its B s' entries (a = (e5, -e1), b =
    /// (-e7, e3): exact negations, the same figures to the bit) instead of
    /// rotated again.
    pub fn gamma(&self, at: &At<S>, qd: &[S], jac: Option<&[S]>, out: &mut [S]) {
        assert!(at.holds(self.n) && qd.len() >= self.n && out.len() >= self.rows());
        match jac {
            Some(v) => {
                assert!(v.len() >= self.entries());
                each_side!(self.gamma_of::<true>(at, qd, v, out));
            }
            None => {
                each_side!(self.gamma_of::<false>(at, qd, &[], out));
            }
        }
    }

    /// `gamma` where out holds the family's gamma from an earlier one, or
    /// zeros (Kin::gamma_over's room): the rows of the joints with neither
    /// local point (Sides<false, false>), +0 at every instant, are not
    /// written again.
    pub fn gamma_over(&self, at: &At<S>, qd: &[S], jac: Option<&[S]>, out: &mut [S]) {
        assert!(at.holds(self.n) && qd.len() >= self.n && out.len() >= self.rows());
        match jac {
            Some(v) => {
                assert!(v.len() >= self.entries());
                self.gamma_of::<true, true, true>(at, qd, v, out);
                self.gamma_of::<true, false, true>(at, qd, v, out);
                self.gamma_of::<false, true, true>(at, qd, v, out);
            }
            None => {
                self.gamma_of::<true, true, false>(at, qd, &[], out);
                self.gamma_of::<true, false, false>(at, qd, &[], out);
                self.gamma_of::<false, true, false>(at, qd, &[], out);
            }
        }
    }

    /// Eq. 4.47 over the joints of Sides<I, J>, a and b from the Jacobian
    /// values v when K; out holds 2 rows per joint, v (when K) 8 entries,
    /// `at` and qd n coordinates (`gamma` asserted them).
    #[inline(always)]
    fn gamma_of<const I: bool, const J: bool, const K: bool>(&self, at: &At<S>, qd: &[S], v: &[S], out: &mut [S]) {
        for p in &self.groups[Sides::<I, J>::GROUP] {
            // SAFETY: ci, cj < n - 2 and k < the joints' count (new); e and qd hold n, out 2 rows per joint, v 8 (gamma)
            unsafe {
                let (wi, wj) = (*qd.get_unchecked(p.ci + 2), *qd.get_unchecked(p.cj + 2));
                let e = |x: usize| *v.get_unchecked(8 * p.k + x);
                let a = || if K { Complex::new(e(5), -e(1)) } else { p.si * at.rot_at(p.ci) };
                let b = || if K { Complex::new(-e(7), e(3)) } else { p.sj * at.rot_at(p.cj) };
                let g = match (I, J) {
                    (true, true) => a() * (wi * wi) - b() * (wj * wj),
                    (true, false) => a() * (wi * wi),
                    (false, true) => -(b() * (wj * wj)),
                    (false, false) => Complex::new(S::zero(), S::zero()),
                };
                *out.get_unchecked_mut(2 * p.k) = g.re;
                *out.get_unchecked_mut(2 * p.k + 1) = g.im;
            }
        }
    }
}

/// Whether a table's vector carries a tangent in any lane (a moved
/// family's other joints do not: their table terms are skipped).
#[inline(always)]
fn moves<const N: usize>(t: Complex<Lanes<N>>) -> bool {
    t.re.d.iter().chain(&t.im.d).any(|&x| x != 0.0)
}

/// The direct tangent kernels (super::Family::phi_tangent, jac_products,
/// gamma_tangent): a = A_i s'_i, b = A_j s'_j and their tangents
/// da = i a s_phi_i + d(s'_i) A_i (Eq. 4.44: dA s' = B s' dphi), lane by lane.
impl<const N: usize> Revolute<Lanes<N>> {
    /// -d/dp of Eq. 4.7 at q' = 0: -(d(s'_i) A_i - d(s'_j) A_j), by
    /// `phi_pins` over every joint (the sensitivity pass's own kernel).
    pub fn phi_tangent(&self, at: &At, out: &mut [[f64; N]]) {
        assert!(at.holds(self.n) && out.len() >= 2 * self.ci.len());
        // SAFETY: every joint's columns ci + 2, cj + 2 < n (new), which e holds, its rows below 2 ci.len() <=
        // out.len() (asserted above)
        unsafe { phi_pins(&self.phi_pins(0), at.e, out) }
    }

    /// Kept's sizes: per joint a, b and their tangents (re, im of each).
    pub fn kept(&self) -> (usize, usize) {
        (2 * self.ci.len(), 4 * self.ci.len())
    }

    /// r2 -= D(J) v[0], r3 -= D(J) v[1] (Eq. 4.46: the phi columns' -B s'
    /// entries alone have a tangent), by `pins_products` over every joint
    /// (the sensitivity pass's own kernel); a = A_i s'_i, b = A_j s'_j and
    /// their tangents into `keep` where it holds them (`kept`).
    pub fn jac_products(&self, d: &Dir<N>, v: &[&[f64]], r2: &mut [[f64; N]], r3: &mut [[f64; N]], keep: Kept<N>) {
        let (n, count) = (self.n, self.ci.len());
        assert!(d.at.holds(n) && d.s.len() >= n && !v.is_empty() && v.iter().all(|x| x.len() >= n));
        assert!(r2.len() >= 2 * count && (v.len() < 2 || r3.len() >= 2 * count));
        let keeps = keep.v.len() >= 2 * count && keep.d.len() >= 4 * count;
        let pins = self.pins(0, d.moved, |_| true);
        let mut kept = vec![PinKept::default(); count];
        // SAFETY: every joint's columns below n (new), which e, s and v hold, its rows below 2 count <= r2's,
        // r3's (or the scratch's) length, kept count long (asserted above)
        unsafe {
            if v.len() >= 2 {
                pins_products::<N, true, true>(&pins, d.at.e, d.s, v[0], v[1], r2, r3, &mut kept);
            } else if keeps {
                let mut scratch = vec![[0.0; N]; 2 * count];
                pins_products::<N, true, true>(&pins, d.at.e, d.s, v[0], v[0], r2, &mut scratch, &mut kept);
            } else {
                pins_products::<N, true, false>(&pins, d.at.e, d.s, v[0], &[], r2, &mut [], &mut kept);
            }
        }
        if keeps {
            for (c, k) in kept.iter().enumerate() {
                (keep.v[2 * c], keep.v[2 * c + 1]) = (k.a, k.b);
                keep.d[4 * c..4 * c + 4].copy_from_slice(&k.d);
            }
        }
    }

    /// D(gamma) of Eq. 4.47: d(a w_i^2) - d(b w_j^2), by `pins_gamma` over
    /// every joint; a, b and their tangents from `kept` where it holds them
    /// (jac_products' at the same s), else taken here.
    pub fn gamma_tangent(&self, d: &Dir<N>, out: &mut [[f64; N]], kept: Kept<N>) {
        let (n, count) = (self.n, self.ci.len());
        assert!(d.at.holds(n) && d.qd.len() >= n && d.s.len() >= n && d.sd.len() >= n && out.len() >= 2 * count);
        let pins = self.pins(0, d.moved, |_| true);
        let keeps = kept.v.len() >= 2 * count && kept.d.len() >= 4 * count;
        let mut k = vec![PinKept::default(); count];
        if keeps {
            for (c, k) in k.iter_mut().enumerate() {
                *k = PinKept { a: kept.v[2 * c], b: kept.v[2 * c + 1], d: std::array::from_fn(|m| kept.d[4 * c + m]) };
            }
        } else {
            let (mut r2, mut r3) = (vec![[0.0; N]; 2 * count], vec![[0.0; N]; 2 * count]);
            // SAFETY: as jac_products' (the scratch rows 2 count long)
            unsafe { pins_products::<N, true, true>(&pins, d.at.e, d.s, d.qd, d.qd, &mut r2, &mut r3, &mut k) };
        }
        // SAFETY: every joint's columns below n, which qd and sd hold, its rows below 2 count <= out.len(),
        // k count long (asserted above)
        unsafe { pins_gamma(&pins, d.qd, d.sd, out, &k) }
    }
}

/// A revolute joint in a per-set-up list of joints (crate::sensitivity's
/// `Reach`): its angle columns (ci + 2, cj + 2), its first row among the
/// model's, its local points' values and, per point whose table carries a
/// tangent in a moved family (`moved && moves(t)`), that point's
/// tangents (re, im per lane; `pins_products`' MOVED list alone reads them).
/// `lone`: j's angle is a place no restricted solve reaches (s_j = sd_j =
/// +0 at every instant) and sj carries no tangent: j's terms, products of
/// those zeros, are left out (`Pin::lone`).
pub struct Pin<const N: usize> {
    i: usize,
    j: usize,
    row: usize,
    si: C64,
    sj: C64,
    ti: Option<([f64; N], [f64; N])>,
    tj: Option<([f64; N], [f64; N])>,
    lone: bool,
}

/// What `pins_products` keeps per joint for `pins_gamma` (a = A_i s'_i,
/// b = A_j s'_j and their tangents ar, ai, br, bi).
#[derive(Clone, Copy)]
pub struct PinKept<const N: usize> {
    a: C64,
    b: C64,
    d: [[f64; N]; 4],
}

impl<const N: usize> Default for PinKept<N> {
    fn default() -> Self {
        PinKept { a: C64::new(0.0, 0.0), b: C64::new(0.0, 0.0), d: [[0.0; N]; 4] }
    }
}

impl<const N: usize> Pin<N> {
    /// Its rows' and columns' bounds: (the largest column read, the last row written).
    pub fn bounds(&self) -> (usize, usize) {
        (self.i.max(self.j), self.row + 1)
    }

    /// Whether it reads a point's tangents (the MOVED list's).
    pub fn moving(&self) -> bool {
        self.ti.is_some() || self.tj.is_some()
    }

    /// The joint with j's terms left out where `quiet(j's angle column)`
    /// (its s and sd +0 at every instant: a place the restricted solves do
    /// not reach) and sj has no tangent. Those terms are +-0 (b s_j, b sd_j
    /// and their products), so the rows take the same figures but for the
    /// sign of an exact zero (a sum that is itself zero).
    pub fn lone(self, quiet: impl Fn(usize) -> bool) -> Self {
        let lone = self.tj.is_none() && quiet(self.j);
        Pin { lone, ..self }
    }
}

impl<const N: usize> Revolute<Lanes<N>> {
    /// The joints c with `take(c)` as list entries (`Pin`), the family's
    /// first row `row0` among the model's, `moved` whether its tables carry tangents.
    pub fn pins(&self, row0: usize, moved: bool, take: impl Fn(usize) -> bool) -> Vec<Pin<N>> {
        let tangent = |t: Complex<Lanes<N>>| (moved && moves(t)).then_some((t.re.d, t.im.d));
        let value = |t: Complex<Lanes<N>>| C64::new(t.re.v, t.im.v);
        (0..self.ci.len())
            .filter(|&c| take(c))
            .map(|c| Pin {
                i: self.ci[c] + 2,
                j: self.cj[c] + 2,
                row: row0 + 2 * c,
                si: value(self.si[c]),
                sj: value(self.sj[c]),
                ti: tangent(self.si[c]),
                tj: tangent(self.sj[c]),
                lone: false,
            })
            .collect()
    }
}

/// D(J) over a list of joints (`Revolute::jac_products` runs it over
/// every joint): r2 -= D(J) qd and, where L3, r3 -= D(J) qdd at each
/// joint's rows, a, b and their tangents kept in `kept` (one per joint) where L3; MOVED: the joints'
/// points' tangents read (a list of joints whose `moving` is true).
///
/// # Safety
/// e, s, qd (and qdd where L3) hold every joint's columns, r2 (and r3
/// where L3) its rows (`Pin::bounds`), kept (where L3) pins.len() entries.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub unsafe fn pins_products<const N: usize, const MOVED: bool, const L3: bool>(
    pins: &[Pin<N>],
    e: &[C64],
    s: &[[f64; N]],
    qd: &[f64],
    qdd: &[f64],
    r2: &mut [[f64; N]],
    r3: &mut [[f64; N]],
    kept: &mut [PinKept<N>],
) {
    for (k, p) in pins.iter().enumerate() {
        let one = |e: C64, sp: &[f64; N], v: C64, t: Option<([f64; N], [f64; N])>| {
            let a = v * e;
            let (mut re, mut im) = (sp.map(|x| -a.im * x), sp.map(|x| a.re * x));
            if MOVED {
                if let Some((tr, ti)) = t {
                    for l in 0..N {
                        re[l] += tr[l] * e.re - ti[l] * e.im;
                        im[l] += tr[l] * e.im + ti[l] * e.re;
                    }
                }
            }
            (a, re, im)
        };
        let (i, j) = (p.i, p.j);
        let (a, ar, ai) = one(*e.get_unchecked(i), s.get_unchecked(i), p.si, p.ti);
        if p.lone {
            // j's terms +-0 (Pin::lone)
            let wi = *qd.get_unchecked(i);
            let rows = r2.get_unchecked_mut(p.row..p.row + 2);
            for l in 0..N {
                rows[0][l] += ai[l] * wi;
                rows[1][l] -= ar[l] * wi;
            }
            if L3 {
                let b = C64::new(0.0, 0.0);
                *kept.get_unchecked_mut(k) = PinKept { a, b, d: [ar, ai, [0.0; N], [0.0; N]] };
                let wi = *qdd.get_unchecked(i);
                let rows = r3.get_unchecked_mut(p.row..p.row + 2);
                for l in 0..N {
                    rows[0][l] += ai[l] * wi;
                    rows[1][l] -= ar[l] * wi;
                }
            }
            continue;
        }
        let (b, br, bi) = one(*e.get_unchecked(j), s.get_unchecked(j), p.sj, p.tj);
        let (wi, wj) = (*qd.get_unchecked(i), *qd.get_unchecked(j));
        let rows = r2.get_unchecked_mut(p.row..p.row + 2);
        for l in 0..N {
            rows[0][l] += ai[l] * wi - bi[l] * wj;
            rows[1][l] -= ar[l] * wi - br[l] * wj;
        }
        if L3 {
            *kept.get_unchecked_mut(k) = PinKept { a, b, d: [ar, ai, br, bi] };
            let (wi, wj) = (*qdd.get_unchecked(i), *qdd.get_unchecked(j));
            let rows = r3.get_unchecked_mut(p.row..p.row + 2);
            for l in 0..N {
                rows[0][l] += ai[l] * wi - bi[l] * wj;
                rows[1][l] -= ar[l] * wi - br[l] * wj;
            }
        }
    }
}

/// D(gamma) over a list of joints (`Revolute::gamma_tangent` runs it over
/// every joint), from what `pins_products` kept at the instant: out += D(gamma)
/// at each joint's rows.
///
/// # Safety
/// qd, sd hold every joint's columns, out its rows (`Pin::bounds`), kept
/// pins.len() entries.
#[inline(always)]
pub unsafe fn pins_gamma<const N: usize>(
    pins: &[Pin<N>],
    qd: &[f64],
    sd: &[[f64; N]],
    out: &mut [[f64; N]],
    kept: &[PinKept<N>],
) {
    for (k, p) in pins.iter().enumerate() {
        if p.lone {
            // j's terms +-0 (Pin::lone)
            let PinKept { a, d: [ar, ai, ..], .. } = *kept.get_unchecked(k);
            let (wi, vi) = (*qd.get_unchecked(p.i), sd.get_unchecked(p.i));
            let ww_i = wi * wi;
            let o = out.get_unchecked_mut(p.row..p.row + 2);
            for l in 0..N {
                let dwi = 2.0 * wi * vi[l];
                o[0][l] += ar[l] * ww_i + a.re * dwi;
                o[1][l] += ai[l] * ww_i + a.im * dwi;
            }
            continue;
        }
        let PinKept { a, b, d: [ar, ai, br, bi] } = *kept.get_unchecked(k);
        let (wi, wj) = (*qd.get_unchecked(p.i), *qd.get_unchecked(p.j));
        let (vi, vj) = (sd.get_unchecked(p.i), sd.get_unchecked(p.j));
        let (ww_i, ww_j) = (wi * wi, wj * wj);
        let o = out.get_unchecked_mut(p.row..p.row + 2);
        for l in 0..N {
            let (dwi, dwj) = (2.0 * wi * vi[l], 2.0 * wj * vj[l]);
            o[0][l] += (ar[l] * ww_i + a.re * dwi) - (br[l] * ww_j + b.re * dwj);
            o[1][l] += (ai[l] * ww_i + a.im * dwi) - (bi[l] * ww_j + b.im * dwj);
        }
    }
}

/// A joint of a moved revolute family in a per-set-up list for (S1)
/// (`phi_pins`): its angle columns, its first row
/// and its points' tangents per lane, or none where neither moves (its
/// rows -0).
pub struct PhiPin<const N: usize> {
    i: usize,
    j: usize,
    row: usize,
    d: Option<[(C64, C64); N]>,
}

impl<const N: usize> PhiPin<N> {
    /// (the largest column read, the last row written).
    pub fn bounds(&self) -> (usize, usize) {
        (self.i.max(self.j), self.row + 1)
    }
}

impl<const N: usize> Revolute<Lanes<N>> {
    /// Every joint as a `PhiPin`, the family's first row `row0`.
    pub fn phi_pins(&self, row0: usize) -> Vec<PhiPin<N>> {
        (0..self.ci.len())
            .map(|c| {
                let (si, sj) = (self.si[c], self.sj[c]);
                let d = (moves(si) || moves(sj)).then(|| std::array::from_fn(|l| (lane(si, l).1, lane(sj, l).1)));
                PhiPin { i: self.ci[c] + 2, j: self.cj[c] + 2, row: row0 + 2 * c, d }
            })
            .collect()
    }
}

/// -Phi_p over a list of joints (`Revolute::phi_tangent` runs it over
/// every joint) at each joint's rows.
///
/// # Safety
/// e holds every joint's columns, out its rows (`PhiPin::bounds`).
#[inline(always)]
pub unsafe fn phi_pins<const N: usize>(pins: &[PhiPin<N>], e: &[C64], out: &mut [[f64; N]]) {
    for p in pins {
        let o = out.get_unchecked_mut(p.row..p.row + 2);
        match &p.d {
            None => o.fill([-0.0; N]),
            Some(t) => {
                let (ei, ej) = (*e.get_unchecked(p.i), *e.get_unchecked(p.j));
                for l in 0..N {
                    let d = t[l].0 * ei - t[l].1 * ej;
                    o[0][l] = -d.re;
                    o[1][l] = -d.im;
                }
            }
        }
    }
}
