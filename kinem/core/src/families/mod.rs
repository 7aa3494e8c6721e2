//! The constraint families of Chapter 4, each in its own module with its
//! Phi, Jacobian values, nu (= -Phi_t) and gamma, evaluated over all the
//! constraints of a type at once from its struct-of-arrays table. The
//! Jacobian values of a family come in the order of its structural pattern
//! (rows, cols), which kinem/constraints/*.py compute when the model is compiled.
//!
//! Planar vectors are complex numbers x + iy: A_i s' (Eq. 4.4) is
//! s' e^{i phi_i}, B_i s' (Eq. 4.44) is i A_i s', a . b = Re(conj(a) b),
//! and the scalar cross product a x b = Im(conj(a) b). e^{i phi} of every
//! angle column is computed once per configuration (`At::e`) and shared by
//! every family.
//!
//! Every kernel is written over a scalar S (crate::real): f64 in the
//! analysis, Dual for design sensitivities, where the same code carries the
//! tangents of the tables and of q, qd through Phi, the Jacobian, nu and gamma.
use crate::functions::Functions;
use crate::outline::{Outlines, Piece};
use crate::real::{Lanes, Real};
use crate::table::Table;
use num_complex::{Complex, Complex64 as C64};
use num_traits::Zero;

pub mod cam;
pub mod curve;
pub mod distance;
pub mod gear;
pub mod line;
pub mod rack;
pub mod revolute;
pub mod simple;

#[cfg(test)]
mod tests;

pub const I: C64 = C64 { re: 0.0, im: 1.0 };
pub use crate::real::i;

/// One configuration: coordinates q (n), e[j] = e^{i q[j]} at the angle
/// columns (other entries unspecified), and the time t.
pub struct At<'a, S = f64> {
    pub q: &'a [S],
    pub e: &'a [Complex<S>],
    pub t: f64,
}

impl<S: Real> At<'_, S> {
    /// r = x + iy of the body whose x column is c.
    #[inline(always)]
    pub fn r(&self, c: usize) -> Complex<S> {
        let p = &self.q[c..c + 2];
        Complex::new(p[0], p[1])
    }
    /// e^{i phi} of the body whose x column is c.
    #[inline(always)]
    pub fn rot(&self, c: usize) -> Complex<S> {
        self.e[c + 2]
    }

    /// Whether q and e hold n coordinates (a kernel checks it once per
    /// call, then reads the columns its table was checked against n
    /// without bounds checks: `r_at`, `rot_at`).
    #[inline(always)]
    pub fn holds(&self, n: usize) -> bool {
        self.q.len() >= n && self.e.len() >= n
    }

    /// `r` without a bounds check.
    ///
    /// # Safety
    /// c + 1 < q.len() (a body's x column c < n - 2 where `holds(n)`).
    #[inline(always)]
    pub unsafe fn r_at(&self, c: usize) -> Complex<S> {
        debug_assert!(c + 1 < self.q.len());
        Complex::new(*self.q.get_unchecked(c), *self.q.get_unchecked(c + 1))
    }

    /// `rot` without a bounds check.
    ///
    /// # Safety
    /// c + 2 < e.len() (a body's x column c < n - 2 where `holds(n)`).
    #[inline(always)]
    pub unsafe fn rot_at(&self, c: usize) -> Complex<S> {
        debug_assert!(c + 2 < self.e.len());
        *self.e.get_unchecked(c + 2)
    }
}

/// r' = xd + i yd of the body whose x column is c.
#[inline(always)]
pub fn rd<S: Real>(qd: &[S], c: usize) -> Complex<S> {
    Complex::new(qd[c], qd[c + 1])
}

#[inline(always)]
pub fn dot<S: Real>(a: Complex<S>, b: Complex<S>) -> S {
    a.re * b.re + a.im * b.im
}

#[inline(always)]
pub fn cross<S: Real>(a: Complex<S>, b: Complex<S>) -> S {
    a.re * b.im - a.im * b.re
}

/// What the families read besides their own tables.
pub struct Shared<'a, S = f64> {
    pub functions: &'a Functions<S>,
    pub outlines: &'a Outlines<S>,
}

/// The type switch: one variant per family, each holding its table (a
/// byte's tag: the switch reads it, not a niche in a table's fields).
#[repr(u8)]
pub enum Family<S = f64> {
    Simple(simple::Simple<S>),
    Revolute(revolute::Revolute<S>),
    Line(line::Line<S>),
    Distance(distance::Distance<S>),
    Gear(gear::Gear<S>),
    Rack(rack::Rack<S>),
    PointOnCurve(curve::PointOnCurve<S>),
    CamRoller(cam::Roller<S>),
    CamFlat(cam::Flat<S>),
}

/// The `kind` names Python's families hand over (kinem/constraints/*.py).
pub const KINDS: [&str; 9] =
    ["simple", "revolute", "line", "distance", "gear", "rack-pinion", "point-on-curve", "cam-roller", "cam-flat"];

/// The columns of a kind's table that hold coordinate indices; the first is
/// always used, so it places each constraint in its diagonal block
/// (crate::model::Kin::split). The others may hold any valid column where a
/// constraint does not use them (a ground row's k).
pub fn coordinate_columns(kind: &str) -> &'static [&'static str] {
    match kind {
        "simple" => &["a", "angle", "k"],
        "revolute" | "distance" | "rack-pinion" => &["ci", "cj"],
        "line" => &["ca", "cb", "ai", "aj"],
        "gear" => &["ai", "aj", "ak"],
        "point-on-curve" => &["cc", "ct", "cb"],
        "cam-roller" | "cam-flat" => &["cc", "ct", "cj"],
        _ => &[],
    }
}

/// Which of a constraint's two local vectors are not exactly zero (A:
/// the first, B: the second; the revolute's s'_i and s'_j, the line's base
/// point and the other body's point): a term A s' with s' = 0 is left out
/// of the group's kernels. The figures are those of the full kernel to the
/// bit but for the sign of an exact zero (x + A 0 = x for every x but a zero).
pub struct Sides<const A: bool, const B: bool>;

impl<const A: bool, const B: bool> Sides<A, B> {
    /// The group's place in the array `sides` makes.
    pub const GROUP: usize = (!A as usize) * 2 + (!B as usize);
}

/// Constraints 0..a.len() grouped by Sides<A, B>::GROUP of their vectors
/// a[k], b[k] (zero when the value and every tangent are: `is_zero`, so a
/// seeded design parameter keeps the full kernel), each made by `make`.
pub fn sides<S: Real, T>(a: &[Complex<S>], b: &[Complex<S>], make: impl Fn(usize) -> T) -> [Vec<T>; 4] {
    let group = |k: usize| (a[k].is_zero() as usize) * 2 + b[k].is_zero() as usize;
    std::array::from_fn(|g| (0..a.len()).filter(|&k| group(k) == g).map(&make).collect())
}

/// `$s.$f::<A, B>(args)` (`$f::<K>`: `$f::<A, B, K>`) for the four groups of `Sides`.
macro_rules! each_side {
    ($s:ident . $f:ident :: < $k:tt > ( $($a:expr),* )) => {
        $s.$f::<true, true, $k>($($a),*);
        $s.$f::<true, false, $k>($($a),*);
        $s.$f::<false, true, $k>($($a),*);
        $s.$f::<false, false, $k>($($a),*);
    };
    ($s:ident . $f:ident ( $($a:expr),* )) => {
        $s.$f::<true, true>($($a),*);
        $s.$f::<true, false>($($a),*);
        $s.$f::<false, true>($($a),*);
        $s.$f::<false, false>($($a),*);
    };
}
pub(crate) use each_side;

macro_rules! each {
    ($self:expr, $f:ident => $e:expr) => {
        match $self {
            Family::Simple($f) => $e,
            Family::Revolute($f) => $e,
            Family::Line($f) => $e,
            Family::Distance($f) => $e,
            Family::Gear($f) => $e,
            Family::Rack($f) => $e,
            Family::PointOnCurve($f) => $e,
            Family::CamRoller($f) => $e,
            Family::CamFlat($f) => $e,
        }
    };
}

impl<S: Real> Family<S> {
    /// The family of `kind` from its table; n: the model's coordinates (every
    /// column index is checked against it), functions and outlines: how many
    /// there are (every reference to one is checked).
    pub fn new(kind: &str, t: &Table, n: usize, functions: usize, outlines: usize) -> Result<Family<S>, String> {
        let r = match kind {
            "simple" => Family::Simple(simple::Simple::new(t, n, functions)?),
            "revolute" => Family::Revolute(revolute::Revolute::new(t, n)?),
            "line" => Family::Line(line::Line::new(t, n)?),
            "distance" => Family::Distance(distance::Distance::new(t, n, functions)?),
            "gear" => Family::Gear(gear::Gear::new(t, n)?),
            "rack-pinion" => Family::Rack(rack::Rack::new(t, n)?),
            "point-on-curve" => Family::PointOnCurve(curve::PointOnCurve::new(t, n, outlines)?),
            "cam-roller" => Family::CamRoller(cam::Roller::new(t, n, outlines)?),
            "cam-flat" => Family::CamFlat(cam::Flat::new(t, n, outlines)?),
            _ => return Err(format!("unknown family kind '{kind}'; valid: {}", KINDS.join(", "))),
        };
        Ok(r)
    }

    /// Binds the family to the model's functions and outlines (once, when the model is built).
    pub fn bind(&mut self, s: &Shared<S>) {
        if let Family::Simple(f) = self {
            f.bind(s);
        }
    }

    pub fn rows(&self) -> usize {
        each!(self, f => f.rows())
    }

    pub fn entries(&self) -> usize {
        each!(self, f => f.entries())
    }

    /// Whether nu can be non-zero (a driver).
    pub fn time_dependent(&self, s: &Shared<S>) -> bool {
        match self {
            Family::Simple(f) => f.time_dependent(s),
            Family::Distance(f) => f.time_dependent(s),
            _ => false,
        }
    }

    pub fn phi(&self, at: &At<S>, s: &Shared<S>, out: &mut [S]) {
        match self {
            Family::Simple(f) => f.phi(at, s, out),
            Family::Revolute(f) => f.phi(at, s, out),
            Family::Line(f) => f.phi(at, s, out),
            _ => self.phi_rare(at, s, out),
        }
    }

    /// `phi` of the other kinds, out of the callers' line of code.
    #[inline(never)]
    fn phi_rare(&self, at: &At<S>, s: &Shared<S>, out: &mut [S]) {
        match self {
            Family::Distance(f) => f.phi(at, s, out),
            Family::Gear(f) => f.phi(at, s, out),
            Family::Rack(f) => f.phi(at, s, out),
            Family::PointOnCurve(f) => f.phi(at, s, out),
            Family::CamRoller(f) => f.phi(at, s, out),
            Family::CamFlat(f) => f.phi(at, s, out),
            Family::Simple(_) | Family::Revolute(_) | Family::Line(_) => unreachable!(),
        }
    }

    pub fn jac(&self, at: &At<S>, s: &Shared<S>, out: &mut [S]) {
        each!(self, f => f.jac(at, s, out))
    }

    /// `jac` where out holds the family's Jacobian from an earlier `jac`:
    /// its constant entries are not written again (simple, revolute, line;
    /// the other kinds write every entry). Whether it writes any entry at
    /// all: `jac_moves`.
    pub fn jac_over(&self, at: &At<S>, s: &Shared<S>, out: &mut [S]) {
        match self {
            Family::Simple(f) => f.jac_over(at, s, out),
            Family::Revolute(f) => f.jac_over(at, s, out),
            Family::Line(f) => f.jac_over(at, s, out),
            _ => self.jac(at, s, out),
        }
    }

    /// Whether `jac_over` writes any entry: all but a simple family
    /// without a point or relative row (its entries are all 1, written by
    /// `jac`).
    pub fn jac_moves(&self) -> bool {
        match self {
            Family::Simple(f) => !f.jac_still(),
            _ => true,
        }
    }

    /// Marks (true) the family's Jacobian entries that are exactly zero at
    /// every configuration and time (out: one per entry): the revolute's
    /// B s' where s' = 0, the line's u . A_b s'_b where its point on b is
    /// (their `Sides` groups); none of the other kinds. The block-triangular
    /// layout is made without them (crate::plan::triangulate_zero).
    pub fn zero_entries(&self, out: &mut [bool]) {
        match self {
            Family::Revolute(f) => f.zero_entries(out),
            Family::Line(f) => f.zero_entries(out),
            _ => {}
        }
    }

    /// nu = -Phi_t (zero for families without drivers).
    pub fn nu(&self, t: f64, s: &Shared<S>, out: &mut [S]) {
        match self {
            Family::Simple(f) => f.nu(t, s, out),
            Family::Distance(f) => f.nu(t, s, out),
            _ => out.fill(S::zero()),
        }
    }

    #[inline(always)]
    pub fn gamma(&self, at: &At<S>, qd: &[S], s: &Shared<S>, out: &mut [S]) {
        self.gamma_with(at, qd, s, None, out)
    }

    /// `gamma_with` where out holds the family's gamma from an earlier
    /// one (or zeros): its constant rows (0: the simple family's grounds,
    /// the translational joints' angle rows, the revolutes with neither
    /// local point) are not written again.
    pub fn gamma_over(&self, at: &At<S>, qd: &[S], s: &Shared<S>, jac: Option<&[S]>, out: &mut [S]) {
        match self {
            Family::Simple(f) => f.gamma_over(at, qd, s, out),
            Family::Revolute(f) => f.gamma_over(at, qd, jac, out),
            Family::Line(f) => f.gamma_over(at, qd, s, out),
            _ => self.gamma_with(at, qd, s, jac, out),
        }
    }

    /// `gamma`; `jac`: the family's Jacobian values at the same q, if at
    /// hand (the revolute reads its rotated local points there).
    pub fn gamma_with(&self, at: &At<S>, qd: &[S], s: &Shared<S>, jac: Option<&[S]>, out: &mut [S]) {
        match self {
            Family::Simple(f) => f.gamma(at, qd, s, out),
            Family::Revolute(f) => f.gamma(at, qd, jac, out),
            Family::Line(f) => f.gamma(at, qd, s, out),
            Family::Distance(f) => f.gamma(at, qd, s, out),
            Family::Gear(f) => f.gamma(at, qd, s, out),
            Family::Rack(f) => f.gamma(at, qd, s, out),
            Family::PointOnCurve(f) => f.gamma(at, qd, s, out),
            Family::CamRoller(f) => f.gamma(at, qd, s, out),
            Family::CamFlat(f) => f.gamma(at, qd, s, out),
        }
    }
}

impl<S> Family<S> {
    /// Which of the model's tables besides its own the family reads (the
    /// functions' table, the outlines' table): the kinds Family::new hands
    /// the number of functions (simple, distance: a driver's f(t)) or of
    /// outlines (point-on-curve, the cams); a moved function or outline
    /// moves no other family (crate::sensitivity).
    pub fn reads(&self) -> (bool, bool) {
        (
            matches!(self, Family::Simple(_) | Family::Distance(_)),
            matches!(self, Family::PointOnCurve(_) | Family::CamRoller(_) | Family::CamFlat(_)),
        )
    }

    /// Whether its Jacobian is piecewise in q, not polynomial in e^{i q},
    /// q and its tables: the kinds that read an outline (its pieces).
    pub fn piecewise(&self) -> bool {
        self.reads().1
    }

    /// Whether the kind holds a ground's or a driver's rows whose Jacobian
    /// and gamma may read neither q nor qd (simple, gear: crate::sensitivity
    /// probes which do).
    pub fn may_be_fixed(&self) -> bool {
        matches!(self, Family::Simple(_) | Family::Gear(_))
    }

    /// Whether the kind has the direct tangent kernels (phi_tangent,
    /// jac_products, gamma_tangent over Lanes<N>): simple, revolute, line,
    /// point-on-curve.
    pub fn direct(&self) -> bool {
        matches!(self, Family::Simple(_) | Family::Revolute(_) | Family::Line(_) | Family::PointOnCurve(_))
    }
}

/// The direct tangent kernels of design sensitivities (crate::sensitivity,
/// docs/design.md Eqs. S1-S3): over the analysis' own values (q, e^{i q}:
/// an `At` of f64, the march's) and N lanes of tangents, s = dq/dp (and
/// sd = dqd/dp), the tables' tangents those of the seeded family (`moved`:
/// whether it carries any; else only the q' and qd' terms are taken). No
/// value is carried beside the tangents: each kernel takes the few values
/// its product rule needs. Each returns false for a kind without them
/// (the caller evaluates that family over Lanes<N>, crate::real).
impl<const N: usize> Family<Lanes<N>> {
    /// Phi's tangent along the tables alone (q' = 0), negated: -Phi_p,
    /// (S1)'s right-hand side (the sign taken in each store). Where `keep`
    /// holds the family's `kept` sizes and the kind `hands` its outline's
    /// place on, that place is written there (Kept::held) for
    /// `jac_products` at the same instant.
    pub fn phi_tangent(&self, at: &At, s: &Shared<Lanes<N>>, out: &mut [[f64; N]], keep: Kept<N>) -> bool {
        match self {
            Family::Simple(f) => f.phi_tangent(at, s, out),
            Family::Revolute(f) => f.phi_tangent(at, out),
            Family::Line(f) => f.phi_tangent(at, out),
            Family::PointOnCurve(f) => f.phi_tangent(at, s, out, keep),
            _ => return false,
        }
        true
    }

    /// The (S2), (S3) products with D(J) = D_s J + J_p, the Jacobian's
    /// tangent along q' = s and the tables: r2 -= D(J) v[0] (qd) and, when
    /// v[1] (qdd) is given, r3 -= D(J) v[1], over the family's rows. Where
    /// `keep` holds the family's `kept` sizes, the values and tangents it
    /// took per constraint are written there for `gamma_tangent`.
    pub fn jac_products(
        &self,
        d: &Dir<N>,
        s: &Shared<Lanes<N>>,
        v: &[&[f64]],
        r2: &mut [[f64; N]],
        r3: &mut [[f64; N]],
        keep: Kept<N>,
    ) -> bool {
        match self {
            Family::Simple(f) => f.jac_products(d, v, r2, r3),
            Family::Revolute(f) => f.jac_products(d, v, r2, r3, keep),
            Family::Line(f) => f.jac_products(d, v, r2, r3, keep),
            Family::PointOnCurve(f) => f.jac_products(d, s, v, r2, r3, keep),
            _ => return false,
        }
        true
    }

    /// D(gamma), gamma's tangent along q' = s, qd' = sd and the tables
    /// (S3), at qd; added to out. `kept`: what `jac_products` kept at the
    /// same instant and s (the same figures to the bit), or empty (then
    /// taken again).
    pub fn gamma_tangent(&self, d: &Dir<N>, s: &Shared<Lanes<N>>, out: &mut [[f64; N]], kept: Kept<N>) -> bool {
        match self {
            Family::Simple(f) => f.gamma_tangent(d, s, out),
            Family::Revolute(f) => f.gamma_tangent(d, out, kept),
            Family::Line(f) => f.gamma_tangent(d, out, kept),
            Family::PointOnCurve(f) => f.gamma_tangent(d, s, out, kept),
            _ => return false,
        }
        true
    }

    /// Whether `phi_tangent` keeps what `jac_products` keeps (the
    /// point-on-curve's outline place at q' = 0 with the tables' tangents:
    /// its two evaluations at the same q are one).
    pub fn hands(&self) -> bool {
        matches!(self, Family::PointOnCurve(_))
    }

    /// How many values and lanes of tangents `jac_products` keeps for
    /// `gamma_tangent` (Kept): (0, 0) where it keeps none.
    pub fn kept(&self) -> (usize, usize) {
        match self {
            Family::Revolute(f) => f.kept(),
            Family::Line(f) => f.kept(),
            Family::PointOnCurve(f) => f.kept(),
            _ => (0, 0),
        }
    }
}

/// A family's values and their tangents per constraint, taken by
/// `jac_products` and read again by `gamma_tangent` at the same instant
/// (its sizes `Family::kept`); empty slices: nothing kept. `held`: they
/// hold already what `phi_tangent` kept at the instant (Family::hands), for
/// `jac_products` to read rather than take.
/// `pieces`: the pieces the analysis' value pass took the family's outlines
/// on at the same q (crate::outline::Piece, the march's, two per
/// constraint: its rows'), or empty: the point-on-curve's phi_tangent and
/// jac_products then find them again.
pub struct Kept<'a, const N: usize> {
    pub v: &'a mut [C64],
    pub d: &'a mut [[f64; N]],
    pub held: bool,
    pub pieces: &'a [Piece],
}

impl<'a, const N: usize> Kept<'a, N> {
    /// Nothing kept.
    pub fn none() -> Self {
        Kept { v: &mut [], d: &mut [], held: false, pieces: &[] }
    }

    /// To be written (or read by gamma_tangent: what jac_products wrote).
    pub fn of(v: &'a mut [C64], d: &'a mut [[f64; N]]) -> Self {
        Kept { v, d, held: false, pieces: &[] }
    }
}

/// Where the direct tangent kernels evaluate: the analysis' values (q,
/// e^{i q}, t: `at`; qd), the lanes' tangents s = dq/dp and sd = dqd/dp
/// (sd empty before (S2) is solved: jac_products does not read it),
/// whether the family's tables carry tangents (`moved`), and whether a
/// function that is not a constant does (`drives`: else every f', f''
/// has a zero tangent).
pub struct Dir<'a, const N: usize> {
    pub at: At<'a>,
    pub qd: &'a [f64],
    pub s: &'a [[f64; N]],
    pub sd: &'a [[f64; N]],
    pub moved: bool,
    pub drives: bool,
}

/// i z, written out: (-Im z, Re z), where the product I * z also takes
/// 0 Re z and 0 Im z (the same figures but for the sign of an exact zero).
#[inline(always)]
pub fn iz(z: C64) -> C64 {
    C64::new(-z.im, z.re)
}

/// A planar vector of Lanes<N>: its value and its tangent in lane l.
#[inline(always)]
pub fn lane<const N: usize>(x: Complex<Lanes<N>>, l: usize) -> (C64, C64) {
    (C64::new(x.re.v, x.im.v), C64::new(x.re.d[l], x.im.d[l]))
}
