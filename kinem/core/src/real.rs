//! The scalar the families' kernels are written over: f64 for the analysis,
//! and `Dual` (forward-mode dual numbers v + d eps, eps^2 = 0) for design
//! sensitivities (crate::sensitivity). One kernel evaluates values and, with
//! Dual, their exact directional derivatives: the tangents of the tables (a
//! design parameter's seed) and of q, qd (dq/dp, dqd/dp) carry through
//! every operation by the chain rule. A planar vector is num_complex's
//! Complex<S>, as C64 = Complex<f64> is.
use num_complex::Complex;
use num_traits::{Num, One, Zero};
use std::ops::{Add, Div, Mul, Neg, Rem, Sub};

pub trait Real:
    Copy
    + Default
    + Num
    + Neg<Output = Self>
    + Mul<f64, Output = Self>
    + Add<f64, Output = Self>
    + Sub<f64, Output = Self>
    + Send
    + Sync
{
    /// v + d eps (f64: v, the tangent dropped).
    fn lift(v: f64, d: f64) -> Self;
    /// The value part.
    fn re(self) -> f64;
    /// The tangent part (f64: 0).
    fn tangent(self) -> f64;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    fn sqrt(self) -> Self;
    #[inline(always)]
    fn c(v: f64) -> Self {
        Self::lift(v, 0.0)
    }
}

impl Real for f64 {
    #[inline(always)]
    fn lift(v: f64, _: f64) -> f64 {
        v
    }
    #[inline(always)]
    fn re(self) -> f64 {
        self
    }
    #[inline(always)]
    fn tangent(self) -> f64 {
        0.0
    }
    #[inline(always)]
    fn sin(self) -> f64 {
        f64::sin(self)
    }
    #[inline(always)]
    fn cos(self) -> f64 {
        f64::cos(self)
    }
    #[inline(always)]
    fn sqrt(self) -> f64 {
        f64::sqrt(self)
    }
}

/// i = sqrt(-1) as a planar vector of S.
#[inline(always)]
pub fn i<S: Real>() -> Complex<S> {
    Complex::new(S::zero(), S::one())
}

/// e^{i x}.
#[inline(always)]
pub fn cis<S: Real>(x: S) -> Complex<S> {
    Complex::new(x.cos(), x.sin())
}

/// A complex of S from a C64 value and a C64 tangent.
#[inline(always)]
pub fn lift_c<S: Real>(v: Complex<f64>, d: Complex<f64>) -> Complex<S> {
    Complex::new(S::lift(v.re, d.re), S::lift(v.im, d.im))
}

/// v + d eps: a value and its derivative along one direction.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Dual {
    pub v: f64,
    pub d: f64,
}

impl Real for Dual {
    #[inline(always)]
    fn lift(v: f64, d: f64) -> Dual {
        Dual { v, d }
    }
    #[inline(always)]
    fn re(self) -> f64 {
        self.v
    }
    #[inline(always)]
    fn tangent(self) -> f64 {
        self.d
    }
    #[inline(always)]
    fn sin(self) -> Dual {
        Dual { v: self.v.sin(), d: self.d * self.v.cos() }
    }
    #[inline(always)]
    fn cos(self) -> Dual {
        Dual { v: self.v.cos(), d: -self.d * self.v.sin() }
    }
    #[inline(always)]
    fn sqrt(self) -> Dual {
        let r = self.v.sqrt();
        Dual { v: r, d: self.d / (2.0 * r) }
    }
}

impl Add for Dual {
    type Output = Dual;
    #[inline(always)]
    fn add(self, o: Dual) -> Dual {
        Dual { v: self.v + o.v, d: self.d + o.d }
    }
}
impl Sub for Dual {
    type Output = Dual;
    #[inline(always)]
    fn sub(self, o: Dual) -> Dual {
        Dual { v: self.v - o.v, d: self.d - o.d }
    }
}
impl Mul for Dual {
    type Output = Dual;
    #[inline(always)]
    fn mul(self, o: Dual) -> Dual {
        Dual { v: self.v * o.v, d: self.d * o.v + self.v * o.d }
    }
}
impl Div for Dual {
    type Output = Dual;
    #[inline(always)]
    fn div(self, o: Dual) -> Dual {
        Dual { v: self.v / o.v, d: (self.d * o.v - self.v * o.d) / (o.v * o.v) }
    }
}
impl Rem for Dual {
    type Output = Dual;
    /// x mod y = x - y trunc(x / y): the truncation is locally constant.
    #[inline(always)]
    fn rem(self, o: Dual) -> Dual {
        let k = (self.v / o.v).trunc();
        Dual { v: self.v % o.v, d: self.d - k * o.d }
    }
}
impl Neg for Dual {
    type Output = Dual;
    #[inline(always)]
    fn neg(self) -> Dual {
        Dual { v: -self.v, d: -self.d }
    }
}
impl Mul<f64> for Dual {
    type Output = Dual;
    #[inline(always)]
    fn mul(self, o: f64) -> Dual {
        Dual { v: self.v * o, d: self.d * o }
    }
}
impl Add<f64> for Dual {
    type Output = Dual;
    #[inline(always)]
    fn add(self, o: f64) -> Dual {
        Dual { v: self.v + o, d: self.d }
    }
}
impl Sub<f64> for Dual {
    type Output = Dual;
    #[inline(always)]
    fn sub(self, o: f64) -> Dual {
        Dual { v: self.v - o, d: self.d }
    }
}
impl Zero for Dual {
    fn zero() -> Dual {
        Dual { v: 0.0, d: 0.0 }
    }
    fn is_zero(&self) -> bool {
        self.v == 0.0 && self.d == 0.0
    }
}
impl One for Dual {
    fn one() -> Dual {
        Dual { v: 1.0, d: 0.0 }
    }
}
impl Num for Dual {
    type FromStrRadixErr = <f64 as Num>::FromStrRadixErr;
    fn from_str_radix(s: &str, radix: u32) -> Result<Dual, Self::FromStrRadixErr> {
        Ok(Dual::c(f64::from_str_radix(s, radix)?))
    }
}
