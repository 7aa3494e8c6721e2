//! A point that moves on an outline of a body (Secs. 4.2.4-4.2.6): the
//! disk cam with a point follower (Eqs. 4.26, 4.27) and the point-follower,
//! a pin in a slot (Eq. 4.30); with the outline evaluation the cam
//! families (cam.rs) share.
//!
//! The outline body c, its outline (Eq. 4.25) and the artificial
//! coordinate theta (column ct) locate the point. With a = A_c p(theta),
//! g = A_c p'(theta) (the tangent g_c of Eq. 4.24 in global components),
//! h = A_c p'' and k = A_c p''' (crate::outline::Curve):
//!     da/dphi_c = i a,   da/dtheta = g,   dg/dphi_c = i g,   dg/dtheta = h,
//! and along a motion, without the terms in the accelerations,
//!     a'  = i w a + g th',   a''  = -w^2 a + 2 i w th' g + th'^2 h,
//!     g'  = i w g + h th',   g''  = -w^2 g + 2 i w th' h + th'^2 k.
use super::{i, iz, lane, At, Dir, Kept, Shared};
use crate::outline::{Curve, Piece};
use crate::real::{Lanes, Real};
use crate::table::Table;
use num_complex::{Complex, Complex64 as C64};

/// a', a'', g', g'' along a motion with w = phi_c', th = theta' (the
/// module's formulas).
pub struct Rates<S> {
    pub a1: Complex<S>,
    pub a2: Complex<S>,
    pub g1: Complex<S>,
    pub g2: Complex<S>,
}

#[inline(always)]
pub fn rates<S: Real>(p: &Curve<S>, w: S, th: S) -> Rates<S> {
    let i = i::<S>();
    Rates {
        a1: i * p.a * w + p.g * th,
        a2: -p.a * (w * w) + i * p.g * (w * th * 2.0) + p.h * (th * th),
        g1: i * p.g * w + p.h * th,
        g2: -p.g * (w * w) + i * p.h * (w * th * 2.0) + p.k * (th * th),
    }
}

/// The columns every curve family has: cc (the outline body's x column),
/// ct (theta's column), o (its outline, an index into the model's outlines).
pub struct Outline {
    pub cc: Vec<usize>,
    pub ct: Vec<usize>,
    pub o: Vec<usize>,
}

impl Outline {
    pub fn new(t: &Table, n: usize, outlines: usize) -> Result<Self, String> {
        let cc = t.index("cc", n.saturating_sub(2))?;
        t.same_length(cc.len(), &["ct", "outline"])?;
        Ok(Outline { cc, ct: t.index("ct", n)?, o: t.index("outline", outlines)? })
    }

    pub fn len(&self) -> usize {
        self.cc.len()
    }

    pub fn is_empty(&self) -> bool {
        self.cc.is_empty()
    }

    /// The outline's place at constraint c: its outline at theta = q[ct]
    /// (e^{i theta} is in `At::e`: the artificial columns are angle
    /// columns) on body cc, read without bounds checks.
    ///
    /// # Safety
    /// c < len() and `at.holds(n)` for the n the table was checked against (`new`).
    #[inline(always)]
    pub unsafe fn at_unchecked<S: Real>(&self, at: &At<S>, s: &Shared<S>, c: usize) -> Curve<S> {
        self.at_in_unchecked(at, s, c).0
    }

    /// `at_unchecked`, with the piece the outline was taken on.
    ///
    /// # Safety
    /// As `at_unchecked`.
    #[inline(always)]
    pub unsafe fn at_in_unchecked<S: Real>(&self, at: &At<S>, s: &Shared<S>, c: usize) -> (Curve<S>, Piece) {
        let (o, cc, ct) = (*self.o.get_unchecked(c), *self.cc.get_unchecked(c), *self.ct.get_unchecked(c));
        s.outlines.curve_in(o, *at.q.get_unchecked(ct), *at.e.get_unchecked(ct), at.rot_at(cc))
    }

    /// The outline's place at constraint c and its rates, unchecked as `at_unchecked`.
    ///
    /// # Safety
    /// c < len(), `at.holds(n)` and qd.len() >= n for the n the table was checked against (`new`).
    #[inline(always)]
    pub unsafe fn moving_unchecked<S: Real>(
        &self,
        at: &At<S>,
        qd: &[S],
        s: &Shared<S>,
        c: usize,
    ) -> (Curve<S>, Rates<S>) {
        let p = self.at_unchecked(at, s, c);
        let r =
            rates(&p, *qd.get_unchecked(*self.cc.get_unchecked(c) + 2), *qd.get_unchecked(*self.ct.get_unchecked(c)));
        (p, r)
    }
}

/// Phi = sigma (r_c + A_c p(theta) - r_b - A_b s'_b): two rows, x and y.
/// cam-point: c = cam i, b = follower j, sigma = +1 (Eq. 4.26);
/// point-follower: c = slotted body j, b = pin body i, sigma = -1 (Eq. 4.30).
/// Columns: cc, ct, outline (Outline), cb (b's x column), sb (s'_b), sign.
/// Each kernel checks `At::holds(n)` once per call, then reads the columns
/// its table was checked against n unchecked.
pub struct PointOnCurve<S = f64> {
    n: usize,
    curve: Outline,
    cb: Vec<usize>,
    sb: Vec<Complex<S>>,
    sign: Vec<f64>,
}

impl<S: Real> PointOnCurve<S> {
    pub fn new(t: &Table, n: usize, outlines: usize) -> Result<Self, String> {
        let curve = Outline::new(t, n, outlines)?;
        t.same_length(curve.len(), &["cb", "sb", "sign"])?;
        Ok(PointOnCurve {
            n,
            cb: t.index("cb", n.saturating_sub(2))?,
            sb: t.cplx_s("sb")?,
            sign: t.real("sign")?,
            curve,
        })
    }

    pub fn rows(&self) -> usize {
        2 * self.cb.len()
    }

    pub fn entries(&self) -> usize {
        10 * self.cb.len()
    }

    /// sigma (r_c + a - r_b - A_b s'_b), rows x and y (Eqs. 4.26, 4.30).
    pub fn phi(&self, at: &At<S>, s: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n) && out.len() >= 2 * self.cb.len());
        for (c, o) in out.chunks_exact_mut(2).take(self.cb.len()).enumerate() {
            // SAFETY: c < cb.len() (every column has its rows: new), q and e hold n (asserted above)
            let d = unsafe {
                let (x, y) = (*self.curve.cc.get_unchecked(c), *self.cb.get_unchecked(c));
                let a = self.curve.at_unchecked(at, s, c).a;
                let b = *self.sb.get_unchecked(c) * at.rot_at(y);
                (at.r_at(x) + a - at.r_at(y) - b) * S::c(*self.sign.get_unchecked(c))
            };
            (o[0], o[1]) = (d.re, d.im);
        }
    }

    /// sigma [I, i a, g, -I, -B_b s'_b] in columns [r_c, phi_c, theta, r_b, phi_b]
    /// (Eq. 4.27's Jacobian; pattern per constraint: row x then row y).
    pub fn jac(&self, at: &At<S>, s: &Shared<S>, out: &mut [S]) {
        self.jac_as::<false>(at, s, out, &mut [])
    }

    /// `jac`, keeping the piece each constraint's outline was taken on in
    /// pieces (two per constraint, its rows': the first) for the design
    /// sensitivities at the same q (crate::march hands them over).
    pub fn jac_keeping(&self, at: &At<S>, s: &Shared<S>, out: &mut [S], pieces: &mut [Piece]) {
        assert!(pieces.len() >= 2 * self.cb.len());
        self.jac_as::<true>(at, s, out, pieces)
    }

    /// `jac`, and `jac_keeping` when KEEP.
    #[inline(always)]
    fn jac_as<const KEEP: bool>(&self, at: &At<S>, s: &Shared<S>, out: &mut [S], pieces: &mut [Piece]) {
        assert!(at.holds(self.n) && out.len() >= 10 * self.cb.len());
        for (c, o) in out.chunks_exact_mut(10).take(self.cb.len()).enumerate() {
            // SAFETY: c < cb.len(), q and e hold n (asserted above); pieces 2 per constraint when KEEP (jac_keeping)
            let (p, b, k) = unsafe {
                let y = *self.cb.get_unchecked(c);
                let (p, piece) = self.curve.at_in_unchecked(at, s, c);
                if KEEP {
                    *pieces.get_unchecked_mut(2 * c) = piece;
                }
                (p, *self.sb.get_unchecked(c) * at.rot_at(y), *self.sign.get_unchecked(c))
            };
            let (a, g) = (p.a, p.g);
            o.copy_from_slice(&[
                S::c(k),
                a.im * -k,
                g.re * k,
                S::c(-k),
                b.im * k,
                S::c(k),
                a.re * k,
                g.im * k,
                S::c(-k),
                b.re * -k,
            ]);
        }
    }

    /// -sigma (a'' + A_b s'_b w_b^2).
    pub fn gamma(&self, at: &At<S>, qd: &[S], s: &Shared<S>, out: &mut [S]) {
        assert!(at.holds(self.n) && qd.len() >= self.n && out.len() >= 2 * self.cb.len());
        for (c, o) in out.chunks_exact_mut(2).take(self.cb.len()).enumerate() {
            // SAFETY: c < cb.len(), q, e and qd hold n (asserted above), cc, cb < n - 2, ct < n (new)
            let g = unsafe {
                let (y, cc, ct) =
                    (*self.cb.get_unchecked(c), *self.curve.cc.get_unchecked(c), *self.curve.ct.get_unchecked(c));
                let p = self.curve.at_unchecked(at, s, c);
                let r = rates(&p, *qd.get_unchecked(cc + 2), *qd.get_unchecked(ct));
                let w = *qd.get_unchecked(y + 2);
                (r.a2 + *self.sb.get_unchecked(c) * at.rot_at(y) * (w * w)) * S::c(-*self.sign.get_unchecked(c))
            };
            (o[0], o[1]) = (g.re, g.im);
        }
    }
}

/// A constraint's columns and values at the analysis (`PointOnCurve::place`).
struct Place<const N: usize> {
    y: usize,
    cc: usize,
    ct: usize,
    p: Curve<Lanes<N>>,
    eb: C64,
    sb: Complex<Lanes<N>>,
    k: f64,
}

/// Keeps constraint c's outline place p (a, g, h, k and the tangents of
/// a, g, h: `kept`'s layout, read by `place_kept`).
///
/// # Safety
/// keep holds 4 values and 6 tangents per constraint up to c.
#[inline(always)]
unsafe fn store<const N: usize>(p: &Curve<Lanes<N>>, c: usize, keep: &mut Kept<N>) {
    let z = |x: Complex<Lanes<N>>| (C64::new(x.re.v, x.im.v), x.re.d, x.im.d);
    let ((a, ar, ai), (g, gr, gi), (h, hr, hi)) = (z(p.a), z(p.g), z(p.h));
    keep.v.get_unchecked_mut(4 * c..4 * c + 4).copy_from_slice(&[a, g, h, z(p.k).0]);
    keep.d.get_unchecked_mut(6 * c..6 * c + 6).copy_from_slice(&[ar, ai, gr, gi, hr, hi]);
}

/// The direct tangent kernels (super::Family::phi_tangent, jac_products,
/// gamma_tangent) of Eqs. 4.26, 4.30 and their Jacobian and gamma: the
/// outline's a, g, h, k at the analysis' theta and phi_c (one evaluation
/// over the lanes at q' = 0: the values, and the outline table's tangents
/// where it is moved), then, lane by lane along q' = s (qd' = sd),
///     Da = i a s_phic + g s_th + d(a),   Dg = i g s_phic + h s_th + d(g),
///     Dh = i h s_phic + k s_th + d(h),   Db = i b s_phib + A_b d(s'_b),
/// with b = A_b s'_b and d(.) the tables' tangents.
impl<const N: usize> PointOnCurve<Lanes<N>> {
    /// The outline's place at constraint c with the tables' tangents alone
    /// (Outlines::handed); at the piece the analysis took (`pieces`, two
    /// per constraint: the march's) where pieces holds them, else found
    /// again (Outlines::piece).
    ///
    /// # Safety
    /// c < cb.len() and `at.holds(n)` (PointOnCurve's invariants); pieces
    /// empty or holding 2 per constraint.
    #[inline(always)]
    unsafe fn fixed(&self, at: &At, s: &Shared<Lanes<N>>, c: usize, pieces: &[Piece]) -> Curve<Lanes<N>> {
        let (o, cc, ct) =
            (*self.curve.o.get_unchecked(c), *self.curve.cc.get_unchecked(c), *self.curve.ct.get_unchecked(c));
        let piece =
            if pieces.is_empty() { s.outlines.piece(o, *at.q.get_unchecked(ct)) } else { *pieces.get_unchecked(2 * c) };
        s.outlines.handed(o, piece, *at.e.get_unchecked(ct), at.rot_at(cc))
    }

    /// Constraint c at the analysis: its columns, the outline's place with
    /// the tables' tangents (`fixed`), e^{i phi_b}, s'_b and the sign.
    ///
    /// # Safety
    /// As `fixed`.
    #[inline(always)]
    unsafe fn place(&self, at: &At, s: &Shared<Lanes<N>>, c: usize, pieces: &[Piece]) -> Place<N> {
        self.place_at(at, c, self.fixed(at, s, c, pieces))
    }

    /// `place` with the outline's place p (`fixed`'s) at hand.
    ///
    /// # Safety
    /// As `fixed`.
    #[inline(always)]
    unsafe fn place_at(&self, at: &At, c: usize, p: Curve<Lanes<N>>) -> Place<N> {
        let y = *self.cb.get_unchecked(c);
        Place {
            y,
            cc: *self.curve.cc.get_unchecked(c),
            ct: *self.curve.ct.get_unchecked(c),
            p,
            eb: at.rot_at(y),
            sb: *self.sb.get_unchecked(c),
            k: *self.sign.get_unchecked(c),
        }
    }

    /// Kept's sizes: per constraint the outline's a, g, h, k (values) and
    /// the tangents of a, g, h (re, im of each), as `fixed` gives them.
    pub fn kept(&self) -> (usize, usize) {
        (4 * self.cb.len(), 6 * self.cb.len())
    }

    /// The outline's place of constraint c from `kept` (jac_products').
    ///
    /// # Safety
    /// kept holds c's (`kept`), and `place`'s.
    #[inline(always)]
    unsafe fn place_kept(&self, at: &At, c: usize, kept: &Kept<N>) -> Place<N> {
        let (v, d) = (kept.v.get_unchecked(4 * c..4 * c + 4), kept.d.get_unchecked(6 * c..6 * c + 6));
        let z = |x: C64, re: [f64; N], im: [f64; N]| Complex::new(Lanes::of(x.re, re), Lanes::of(x.im, im));
        let p = Curve {
            a: z(v[0], d[0], d[1]),
            g: z(v[1], d[2], d[3]),
            h: z(v[2], d[4], d[5]),
            k: z(v[3], [0.0; N], [0.0; N]),
        };
        self.place_at(at, c, p)
    }

    /// d/dp of Eqs. 4.26, 4.30 at q' = 0: sigma (d(a) - A_b d(s'_b)); the
    /// outline's place kept where `keep` holds `kept`'s sizes (as
    /// jac_products keeps it: the same evaluation at the same q).
    pub fn phi_tangent(&self, at: &At, s: &Shared<Lanes<N>>, out: &mut [[f64; N]], mut keep: Kept<N>) {
        assert!(at.holds(self.n) && out.len() >= 2 * self.cb.len());
        let keeps = keep.v.len() >= 4 * self.cb.len() && keep.d.len() >= 6 * self.cb.len();
        assert!(keep.pieces.is_empty() || keep.pieces.len() >= 2 * self.cb.len());
        for (c, o) in out.chunks_exact_mut(2).take(self.cb.len()).enumerate() {
            // SAFETY: c < cb.len() (every column has its rows: new), q and e hold n, keep 4 and 6 per
            // constraint where it keeps, its pieces 2 where it holds them (asserted above)
            let Place { p, eb, sb, k, .. } = unsafe { self.place(at, s, c, keep.pieces) };
            if keeps {
                unsafe { store(&p, c, &mut keep) };
            }
            for l in 0..N {
                let d = (lane(p.a, l).1 - lane(sb, l).1 * eb) * k;
                (o[0][l], o[1][l]) = (-d.re, -d.im);
            }
        }
    }

    /// r2 -= D(J) v[0], r3 -= D(J) v[1]: D(J) w = sigma (i Da w_phic +
    /// Dg w_th - i Db w_phib).
    pub fn jac_products(
        &self,
        d: &Dir<N>,
        s: &Shared<Lanes<N>>,
        v: &[&[f64]],
        r2: &mut [[f64; N]],
        r3: &mut [[f64; N]],
        mut keep: Kept<N>,
    ) {
        let (at, sq, moved) = (&d.at, d.s, d.moved);
        let (n, count) = (self.n, self.cb.len());
        assert!(at.holds(n) && sq.len() >= n && v.iter().all(|x| x.len() >= n) && r2.len() >= 2 * count);
        assert!(v.len() < 2 || r3.len() >= 2 * count);
        let keeps = keep.v.len() >= 4 * count && keep.d.len() >= 6 * count;
        assert!(keep.pieces.is_empty() || keep.pieces.len() >= 2 * count);
        let held = keeps && keep.held;
        for c in 0..count {
            // SAFETY: c < cb.len(); cc, cb < n - 2, ct < n (new); e, s and v hold n, r2, r3 two rows per
            // constraint, keep 4 and 6 where it keeps (asserted above)
            unsafe {
                let Place { y, cc, ct, p, eb, sb, k } =
                    if held { self.place_kept(at, c, &keep) } else { self.place(at, s, c, keep.pieces) };
                if keeps && !held {
                    store(&p, c, &mut keep);
                }
                let (a, g, h) = (lane(p.a, 0).0, lane(p.g, 0).0, lane(p.h, 0).0);
                let b = C64::new(sb.re.v, sb.im.v) * eb;
                let (sc, st, sy) = (sq.get_unchecked(cc + 2), sq.get_unchecked(ct), sq.get_unchecked(y + 2));
                for l in 0..N {
                    let (mut da, mut dg, mut db) =
                        (iz(a) * sc[l] + g * st[l], iz(g) * sc[l] + h * st[l], iz(b) * sy[l]);
                    if moved {
                        (da, dg, db) = (da + lane(p.a, l).1, dg + lane(p.g, l).1, db + lane(sb, l).1 * eb);
                    }
                    for (w, r) in v.iter().zip([&mut *r2, &mut *r3]) {
                        let (wc, wt, wy) = (*w.get_unchecked(cc + 2), *w.get_unchecked(ct), *w.get_unchecked(y + 2));
                        let dv = (iz(da) * wc + dg * wt - iz(db) * wy) * k;
                        r.get_unchecked_mut(2 * c)[l] -= dv.re;
                        r.get_unchecked_mut(2 * c + 1)[l] -= dv.im;
                    }
                }
            }
        }
    }

    /// D(gamma) of -sigma (a'' + b w_b^2), a'' = -w^2 a + 2 i w th g + th^2 h;
    /// the outline's place from `kept` where it holds it (jac_products').
    pub fn gamma_tangent(&self, d: &Dir<N>, s: &Shared<Lanes<N>>, out: &mut [[f64; N]], kept: Kept<N>) {
        let (at, qd, sq, sd, moved) = (&d.at, d.qd, d.s, d.sd, d.moved);
        let (n, count) = (self.n, self.cb.len());
        assert!(at.holds(n) && qd.len() >= n && sq.len() >= n && sd.len() >= n && out.len() >= 2 * count);
        let keeps = kept.v.len() >= 4 * count && kept.d.len() >= 6 * count;
        for c in 0..count {
            // SAFETY: as in jac_products (qd, sd hold n too: asserted above)
            unsafe {
                let Place { y, cc, ct, p, eb, sb, k } =
                    if keeps { self.place_kept(at, c, &kept) } else { self.place(at, s, c, &[]) };
                let (a, g, h, kk) = (lane(p.a, 0).0, lane(p.g, 0).0, lane(p.h, 0).0, lane(p.k, 0).0);
                let b = C64::new(sb.re.v, sb.im.v) * eb;
                let (w, th, wb) = (*qd.get_unchecked(cc + 2), *qd.get_unchecked(ct), *qd.get_unchecked(y + 2));
                let (sc, st, sy) = (sq.get_unchecked(cc + 2), sq.get_unchecked(ct), sq.get_unchecked(y + 2));
                let (dwc, dth, dwb) = (sd.get_unchecked(cc + 2), sd.get_unchecked(ct), sd.get_unchecked(y + 2));
                for l in 0..N {
                    let (mut da, mut dg, mut dh, mut db) = (
                        iz(a) * sc[l] + g * st[l],
                        iz(g) * sc[l] + h * st[l],
                        iz(h) * sc[l] + kk * st[l],
                        iz(b) * sy[l],
                    );
                    if moved {
                        da += lane(p.a, l).1;
                        dg += lane(p.g, l).1;
                        dh += lane(p.h, l).1;
                        db += lane(sb, l).1 * eb;
                    }
                    let (dw, dt, dy) = (dwc[l], dth[l], dwb[l]);
                    let a2 = -a * (2.0 * w * dw) - da * (w * w)
                        + iz(g) * (2.0 * (dw * th + w * dt))
                        + iz(dg) * (2.0 * w * th)
                        + h * (2.0 * th * dt)
                        + dh * (th * th);
                    let dv = (a2 + db * (wb * wb) + b * (2.0 * wb * dy)) * -k;
                    out.get_unchecked_mut(2 * c)[l] += dv.re;
                    out.get_unchecked_mut(2 * c + 1)[l] += dv.im;
                }
            }
        }
    }
}
