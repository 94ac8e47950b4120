//! CPU twins of the WGSL kernels in `shaders/`, file for file (the way
//! `vello_shaders` pairs `shaders/*.wgsl` with `src/cpu/*.rs`).
//!
//! A twin computes exactly what its shader computes — same algorithm, same
//! precision, same order of operations where it matters — so that a parity
//! test can tell a kernel bug (GPU ≠ twin) from a precision limit of the
//! formulation (twin ≠ the `f64` reference in [`crate::helix`] / [`crate::euler`] /
//! [`crate::spline`]). Twins are generic over [`Real`], the scalar the
//! kernel is compiled with (`f32` everywhere, `f64` where the adapter offers
//! `SHADER_F64`).
//!
//! | shader                      | twin                    |
//! |-----------------------------|-------------------------|
//! | `shaders/real_f32.wgsl`, `shaders/real_f64.wgsl` | [`Real`] (this file) |
//! | `shaders/math.wgsl`         | [`math`]                |
//! | `shaders/ghosh_bisect.wgsl` | [`ghosh_bisect`]        |
//! | `shaders/helix_eval.wgsl`   | [`helix_eval`]          |
//! | `shaders/frenet_integrate.wgsl` | [`frenet_integrate`] |
//! | `shaders/spline_sample.wgsl` | [`spline_sample`]      |
//! | `shaders/atph_hermite.wgsl` | [`atph_hermite`]        |

pub mod arc_check;
pub mod atph_hermite;
pub mod frenet_integrate;
pub mod ghosh_bisect;
pub mod helix_eval;
pub mod math;
pub mod spline_sample;

use std::fmt::Debug;
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// The scalar a kernel runs in: `f32` or `f64`. Holds the per-precision
/// constants that the WGSL preludes (`shaders/real_f32.wgsl`,
/// `shaders/real_f64.wgsl`) define, so both sides read them from one place
/// (the preludes are generated from these values, see
/// [`crate::kernels::source`]).
pub trait Real:
    Copy
    + Debug
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + bytemuck::Pod
    + Send
    + Sync
    + 'static
{
    /// WGSL name of the type.
    const WGSL: &'static str;
    /// Machine epsilon.
    const EPSILON: Self;
    /// `π/2` split in three parts for Cody–Waite reduction: `q·PIO2_A` and
    /// `q·PIO2_B` are exact for the quotients `|q| < 2⁸` our kernels meet.
    const PIO2_A: f64;
    const PIO2_B: f64;
    const PIO2_C: f64;
    /// Cap on bisection steps. Bisection stops when the bracket is within
    /// `2ε` relative of its upper end, which takes ≈ `log₂(1/2ε)` steps plus
    /// one per halving of the root's scale below the interval's; roots at
    /// 0 (planar data) run to the cap. `f32`: 24 bits + 40 binades;
    /// `f64`: 53 bits + 47 binades.
    const BISECT_MAX: u32;

    fn from_f64(x: f64) -> Self;
    fn to_f64(self) -> f64;
    fn sqrt(self) -> Self;
    fn abs(self) -> Self;
    fn floor(self) -> Self;
    fn min(self, o: Self) -> Self;
    fn max(self, o: Self) -> Self;
    fn is_finite(self) -> bool;
    #[inline]
    fn zero() -> Self {
        Self::from_f64(0.0)
    }
    #[inline]
    fn one() -> Self {
        Self::from_f64(1.0)
    }
}

macro_rules! impl_real {
    ($t:ty, $wgsl:literal, $a:expr, $b:expr, $c:expr, $bmax:expr) => {
        impl Real for $t {
            const WGSL: &'static str = $wgsl;
            const EPSILON: Self = <$t>::EPSILON;
            const PIO2_A: f64 = $a;
            const PIO2_B: f64 = $b;
            const PIO2_C: f64 = $c;
            const BISECT_MAX: u32 = $bmax;
            #[inline]
            fn from_f64(x: f64) -> Self {
                x as $t
            }
            #[inline]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline]
            fn floor(self) -> Self {
                <$t>::floor(self)
            }
            #[inline]
            fn min(self, o: Self) -> Self {
                <$t>::min(self, o)
            }
            #[inline]
            fn max(self, o: Self) -> Self {
                <$t>::max(self, o)
            }
            #[inline]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
        }
    };
}

// f64: fdlibm's pio2_1 (33 bits), pio2_2 (33 bits), pio2_2t.
impl_real!(
    f64,
    "f64",
    1.570_796_326_734_125_614_17e0,
    6.077_100_506_303_965_976_6e-11,
    2.022_266_248_795_950_631_54e-21,
    100
);
// f32: π/2 = 1.5703125 (8 bits) + 4.837512969970703125e-4 (11 bits) + rest.
impl_real!(
    f32,
    "f32",
    1.570_312_5,
    4.837_512_969_970_703_125e-4,
    7.549_789_954_891_882e-8,
    64
);

/// Shorthand for a constant in the kernel's precision.
#[inline(always)]
pub fn r<R: Real>(x: f64) -> R {
    R::from_f64(x)
}
