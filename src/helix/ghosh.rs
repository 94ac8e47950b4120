//! Ghosh's unique short helix through two points and two tangents (paper
//! 000): `interpolate`, whose documentation states the theorem and the
//! numerical formulation, and Ghosh's basis for the GPU kernel's host side.

use glam::DVec3;

use super::element::HelixElement;
use super::HelixError;

/// Tangents closer than this (`|t₁ − t₀|`, ≈ the angle in radians) are treated
/// as parallel: the segment must then be straight. Below it the direction of
/// `t₁ × t₀` is dominated by rounding, and `φ*` is ill-conditioned anyway
/// (ERRATA: a tiny change of the input can move it by a full turn) while the
/// curve it describes is straight to within `|t₁ − t₀|·|d|`.
pub const PARALLEL_EPS: f64 = 1e-12;

/// Default relative co-helicity tolerance: `|⟨d, t₁ − t₀⟩|/(|d||t₁ − t₀|)`,
/// which is the relative distance by which the interpolating helix would
/// miss `p₁`.
pub const DEFAULT_COHELICAL_TOL: f64 = 1e-6;

pub use crate::pair::HermitePair;

impl HermitePair {
    /// Ghosh's short helix [`interpolate`] on this pair.
    ///
    /// ```
    /// use strandfit::{helix, DVec3, HermitePair};
    ///
    /// // A quarter of the unit circle.
    /// let pair = HermitePair::new(DVec3::X, DVec3::Y, DVec3::Y, -DVec3::X);
    /// let h = pair.interpolate(helix::DEFAULT_COHELICAL_TOL).unwrap();
    /// assert!((h.element.curvature - 1.0).abs() < 1e-12);
    /// assert!(h.element.torsion.abs() < 1e-12);
    /// assert!((h.element.length - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    /// ```
    pub fn interpolate(&self, tol: f64) -> Result<ShortHelix, HelixError> {
        interpolate(self.p0, self.t0, self.p1, self.t1, tol)
    }
}

/// The short helix of Algorithm 2 with its characterising quantities.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShortHelix {
    /// The helix as an element (start point, frame, κ, τ, length).
    pub element: HelixElement,
    /// Turning angle `φ* ∈ I₀` (0 for a straight segment).
    pub phi: f64,
    /// Unit axis `Ω̄` (the tangent for a straight segment).
    pub axis: DVec3,
    /// `ω = √(κ² + τ²)`.
    pub omega: f64,
    /// `τ̄ = τ/ω`.
    pub tau_bar: f64,
    /// `χ` of Eq. (10) (∞ in the planar case, NaN where undefined).
    pub chi: f64,
}

/// Interpolate `(p0, t0)` → `(p1, t1)` by the unique short helix.
///
/// Tangents need not be unit. `tol` is the relative co-helicity tolerance
/// (see [`DEFAULT_COHELICAL_TOL`]).
///
/// Two points a quarter turn apart on the helix of radius 1 and pitch `2π·0.5`
/// about `z` give back its `κ = 0.8`, `τ = 0.4` and `φ* = π/2`:
/// ```
/// use strandfit::helix::{interpolate, DEFAULT_COHELICAL_TOL};
/// use strandfit::DVec3;
/// use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
///
/// let (p0, t0) = (DVec3::X, DVec3::new(0.0, 1.0, 0.5));
/// let (p1, t1) = (DVec3::new(0.0, 1.0, FRAC_PI_4), DVec3::new(-1.0, 0.0, 0.5));
/// let h = interpolate(p0, t0, p1, t1, DEFAULT_COHELICAL_TOL).unwrap();
/// assert!((h.element.curvature - 0.8).abs() < 1e-12 && (h.element.torsion - 0.4).abs() < 1e-12);
/// assert!((h.phi - FRAC_PI_2).abs() < 1e-12 && (h.axis - DVec3::Z).length() < 1e-12);
/// ```
///
/// # Method
///
/// Ghosh's unique short helix through two points and two tangents
/// (paper 000, Theorem 5.1, Lemma 5.2 and Algorithm 2, with the corrections
/// of `shared/papers/ERRATA.md`).
///
/// Given `p₀ ≠ p₁` and unit `t₀, t₁` with `⟨p₁ − p₀, t₁ − t₀⟩ = 0`, there is
/// exactly one helix that starts at `p₀` with tangent `t₀`, ends at `p₁` with
/// tangent `t₁`, and turns by `φ* ∈ I₀ = [θ, 2π − θ]` about its axis, where
/// `θ = arccos⟨t₀, t₁⟩`. `φ*` is the root of `H(φ) = N(φ)/D(φ) = −χ`.
///
/// ## Numerical formulation
/// `H` has poles at both ends of `I₀`, so we solve the equivalent
/// `G(φ) = A·N(φ) + B·D(φ) = 0` (ERRATA, "numerical advice"), finite on the
/// closed interval, with `G(θ) > 0 > G(2π − θ)` whenever `A > 0`. With Ghosh's
/// orthonormal basis `e₁ ∝ t₁ + t₀`, `e₂ ∝ t₁ × t₀`, `e₃ ∝ t₁ − t₀` and
/// `d = p₁ − p₀`, dividing `A = √2|⟨d, t₁×t₀⟩|`, `B = (1−t₀·t₁)⟨d, t₁+t₀⟩` by
/// `sin θ > 0` gives `A = √2|d·e₂|`, `B = 2 sin(θ/2) d·e₁`.
///
/// The unknown is measured from the nearer end of `I₀` (`φ = θ + w` or
/// `φ = 2π − θ − w`, `w ∈ [0, β]`, `β = π − θ`), so that the factors that
/// vanish at the ends keep full relative precision:
/// `t₀·t₁ − cos φ = 2 sin(β − w/2) sin(w/2)` on both sides, and the half-angle
/// quantities `sin(θ/2) = |t₁ − t₀|/2`, `cos(θ/2) = |t₁ + t₀|/2` come straight
/// from the data. The root is bracketed and found by Brent's method to full
/// `f64` precision in `w`.
///
/// Results (Lemma 5.2, corrected):
/// `τ̄ = sign⟨d, e₂⟩ √((t₀·t₁ − cos φ*)/(1 − cos φ*))`,
/// `κ̄ = sin(θ/2)/sin(φ*/2)` (so `κ̄² + τ̄² = 1`),
/// `ω = √(4 sin²(θ/2) + (τ̄φ*)²)/|d|`,
/// `Ω̄ = τ̄/cos(θ/2) e₁ − tan(θ/2) cot(φ*/2) e₂` (ERRATA 1: minus sign), and
/// `κ = ωκ̄`, `τ = ωτ̄`, `L = φ*/ω`.
pub fn interpolate(
    p0: DVec3,
    t0: DVec3,
    p1: DVec3,
    t1: DVec3,
    tol: f64,
) -> Result<ShortHelix, HelixError> {
    if !(p0.is_finite() && p1.is_finite() && t0.is_finite() && t1.is_finite()) {
        return Err(HelixError::NonFinite);
    }
    let (l0, l1) = (t0.length(), t1.length());
    if l0 == 0.0 || l1 == 0.0 || !l0.is_normal() || !l1.is_normal() {
        return Err(HelixError::ZeroTangent);
    }
    let t0 = t0 / l0;
    let t1 = t1 / l1;
    let d = p1 - p0;
    let dist = d.length();
    if dist == 0.0 || !dist.is_normal() {
        return Err(HelixError::CoincidentPoints);
    }
    let diff = t1 - t0;
    let sum = t1 + t0;
    let nd = diff.length(); // 2 sin(θ/2)
    let ns = sum.length(); // 2 cos(θ/2)

    if nd <= PARALLEL_EPS {
        return straight(p0, t0, d, dist, tol);
    }
    // Co-helicity (Theorem 5.1, Eq. (6)), relative to |d||t₁ − t₀|.
    let e3_raw = diff / nd;
    let residual = d.dot(e3_raw).abs() / dist;
    if residual > tol {
        return Err(HelixError::NotCoHelical {
            residual,
            tolerance: tol,
        });
    }
    if ns <= PARALLEL_EPS {
        return half_circle(p0, t0, d, dist);
    }

    let sin_half = 0.5 * nd; // sin(θ/2)
    let cos_half = 0.5 * ns; // cos(θ/2)
    let theta = 2.0 * sin_half.atan2(cos_half);
    let beta = std::f64::consts::PI - theta;
    let cos_theta = t0.dot(t1);

    let (e1, e2) = ghosh_basis(t0, t1, diff, sum, nd, ns);
    let de1 = d.dot(e1);
    let de2 = d.dot(e2);
    let a = std::f64::consts::SQRT_2 * de2.abs();
    let b = 2.0 * sin_half * de1;
    let chi = if a == 0.0 {
        f64::INFINITY.copysign(b)
    } else {
        // χ = (1−c)⟨d,t₁+t₀⟩ / (√2|⟨d,t₁×t₀⟩|) = B/A after the common scaling.
        b / a
    };

    let g = GFunction {
        a,
        b,
        theta,
        sin_half,
        cos_half,
        one_minus_c: 2.0 * sin_half * sin_half,
    };
    // Which half of I₀ holds the root: G(π) > 0 ⇒ (π, 2π − θ].
    let g_mid = g.eval(1.0, beta);
    // G behaves like √w near the end (D ∝ √(c − cos φ)), which slows
    // secant/inverse-quadratic steps; in z = √w it is smooth, so Brent
    // converges superlinearly right up to the poles of H.
    let (side, w) = if g_mid == 0.0 {
        (1.0, beta)
    } else {
        let side = if g_mid > 0.0 { -1.0 } else { 1.0 };
        let f = |z: f64| g.eval(side, z * z);
        let z = brent(f, 0.0, beta.sqrt(), f(0.0), g_mid);
        (side, z * z)
    };

    // φ* and its half-angle functions from (side, w).
    let phi = if side > 0.0 {
        theta + w
    } else {
        2.0 * std::f64::consts::PI - theta - w
    };
    let hw = g.half_angles(side, w);
    let (sin_half_phi, cos_half_phi, q) = (hw.sin_half_phi, hw.cos_half_phi, hw.q);
    let one_minus_cos_phi = 2.0 * sin_half_phi * sin_half_phi;
    let tau_abs = (q.max(0.0) / one_minus_cos_phi).sqrt().min(1.0);
    let tau_bar = if de2 < 0.0 { -tau_abs } else { tau_abs };
    let kappa_bar = (sin_half / sin_half_phi).min(1.0);
    let omega = (4.0 * sin_half * sin_half + (tau_bar * phi).powi(2)).sqrt() / dist;

    // Ω̄ in Ghosh's basis (ERRATA 1: the cot term carries a minus sign).
    let a1 = tau_bar / cos_half;
    let a2 = -(sin_half / cos_half) * (cos_half_phi / sin_half_phi);
    let axis = (a1 * e1 + a2 * e2).normalize();
    // κ̄ n₀ = Ω̄ × t₀ (paper, proof of (A.9)); κ̄ > 0 here because θ > 0.
    let normal = orthonormalize(axis.cross(t0), t0);
    let _ = cos_theta;

    let element = HelixElement {
        start: p0,
        tangent: t0,
        normal,
        curvature: omega * kappa_bar,
        torsion: omega * tau_bar,
        length: phi / omega,
    };
    Ok(ShortHelix {
        element,
        phi,
        axis,
        omega,
        tau_bar,
        chi,
    })
}

/// Ghosh's `e₁ ∝ t₁ + t₀`, `e₂ ∝ t₁ × t₀`, made exactly orthonormal starting
/// from whichever of `t₁ ± t₀` is longer (the more accurate one).
pub(crate) fn ghosh_basis(
    t0: DVec3,
    t1: DVec3,
    diff: DVec3,
    sum: DVec3,
    nd: f64,
    ns: f64,
) -> (DVec3, DVec3) {
    let cross = t1.cross(t0);
    if ns >= nd {
        let e1 = sum / ns;
        let e2 = orthonormalize(cross, e1);
        (e1, e2)
    } else {
        let e3 = diff / nd;
        let e2 = orthonormalize(cross, e3);
        (e2.cross(e3), e2)
    }
}

/// `v` with its component along unit `u` removed, normalised.
#[inline]
pub(crate) fn orthonormalize(v: DVec3, u: DVec3) -> DVec3 {
    (v - v.dot(u) * u).normalize()
}

/// Parallel tangents: the only short helix is the straight segment, which
/// exists when the chord runs along the tangent.
fn straight(p0: DVec3, t0: DVec3, d: DVec3, dist: f64, tol: f64) -> Result<ShortHelix, HelixError> {
    let off = d.cross(t0).length() / dist;
    if off > tol || d.dot(t0) <= 0.0 {
        let deviation = d.dot(t0).clamp(-dist, dist).acos().max((off).asin());
        return Err(HelixError::ParallelTangentsOffChord { deviation });
    }
    Ok(ShortHelix {
        element: HelixElement::straight(p0, t0, dist),
        phi: 0.0,
        axis: t0,
        omega: 0.0,
        tau_bar: 0.0,
        chi: f64::NAN,
    })
}

/// Opposite tangents with the chord ⊥ `t₀`: `I₀ = {π}`, `τ̄ = 0`, a half circle
/// of diameter `|d|` in the plane of `t₀` and `d`.
fn half_circle(p0: DVec3, t0: DVec3, d: DVec3, dist: f64) -> Result<ShortHelix, HelixError> {
    let normal = orthonormalize(d, t0);
    let omega = 2.0 / dist;
    let element = HelixElement {
        start: p0,
        tangent: t0,
        normal,
        curvature: omega,
        torsion: 0.0,
        length: std::f64::consts::PI / omega,
    };
    Ok(ShortHelix {
        element,
        phi: std::f64::consts::PI,
        axis: t0.cross(normal),
        omega,
        tau_bar: 0.0,
        chi: f64::NAN,
    })
}

/// `G(φ) = A·N(φ) + B·D(φ)` with `φ` given as (side, offset from that end).
struct GFunction {
    a: f64,
    b: f64,
    theta: f64,
    /// `sin(θ/2)`, `cos(θ/2)` straight from the data (`|t₁ ∓ t₀|/2`).
    sin_half: f64,
    cos_half: f64,
    one_minus_c: f64,
}

/// The trigonometric quantities at `φ = θ + w` (side +1) or `2π − θ − w`
/// (side −1), all from the data's half angles and `w`, never from the
/// rounded `β = π − θ`: `sin(β − x) = sin(θ + x)` is `O(θ)` for a short arc
/// while `β` carries an absolute rounding of `ulp(π)`, which would cost
/// `ε/θ` relative (the reference's κ and τ were only good to ~1e-10 on
/// elements turning by 1e-6 rad before this).
struct HalfAngles {
    /// `sin(φ/2) ∈ (0, 1]`.
    sin_half_phi: f64,
    /// `cos(φ/2)`.
    cos_half_phi: f64,
    /// `sin φ`.
    sin_phi: f64,
    /// `c − cos φ = 2 sin(θ + w/2) sin(w/2) ≥ 0` (`c = t₀·t₁`).
    q: f64,
}

impl GFunction {
    #[inline]
    fn half_angles(&self, side: f64, w: f64) -> HalfAngles {
        let (sh, ch) = (0.5 * w).sin_cos();
        let (sw, cw) = w.sin_cos();
        let (s, c) = (self.sin_half, self.cos_half);
        let sin_theta = 2.0 * s * c;
        let cos_theta = (c - s) * (c + s);
        // sin(θ + w/2) and sin(θ + w) = sin|π − φ|.
        let sin_tpw2 = sin_theta * ch + cos_theta * sh;
        let sin_tpw = sin_theta * cw + cos_theta * sw;
        HalfAngles {
            // φ/2 = π/2 ∓ (β − w)/2 and (β − w)/2 = π/2 − (θ + w)/2.
            sin_half_phi: s * ch + c * sh,
            cos_half_phi: side * (c * ch - s * sh),
            sin_phi: side * sin_tpw,
            q: 2.0 * sin_tpw2 * sh,
        }
    }

    /// `side = +1`: `φ = θ + w`; `side = −1`: `φ = 2π − θ − w`; `w ∈ [0, β]`.
    #[inline]
    fn eval(&self, side: f64, w: f64) -> f64 {
        let phi = if side > 0.0 {
            self.theta + w
        } else {
            2.0 * std::f64::consts::PI - self.theta - w
        };
        let HalfAngles { sin_phi, q, .. } = self.half_angles(side, w);
        // N(φ) = (1 − c) sin φ + φ (c − cos φ)   (A.14)
        let n = self.one_minus_c * sin_phi + phi * q;
        // D(φ) = (φ cos(φ/2) − 2 sin(φ/2)) √(c − cos φ)   (A.15)
        let d = half_angle_defect(phi) * q.max(0.0).sqrt();
        self.a * n + self.b * d
    }
}

/// `φ cos(φ/2) − 2 sin(φ/2) = 2(x cos x − sin x)`, `x = φ/2`; negative on
/// `(0, 2π]`. Near 0 the difference cancels (it is `−φ³/12 + …`), so there we
/// use the series `Σₖ≥₁ (−1)ᵏ 2k x²ᵏ⁺¹/(2k+1)!`.
#[inline]
fn half_angle_defect(phi: f64) -> f64 {
    let x = 0.5 * phi;
    if x < 0.5 {
        let x2 = x * x;
        // terms k = 1..=8: (−1)^k 2k/(2k+1)!
        let mut term = x * x2; // x^(2k+1) for k = 1
        let mut fact = 6.0; // (2k+1)! for k = 1
        let mut sum = 0.0;
        for k in 1..=8 {
            let sign = if k % 2 == 1 { -1.0 } else { 1.0 };
            sum += sign * (2 * k) as f64 * term / fact;
            term *= x2;
            fact *= ((2 * k + 2) * (2 * k + 3)) as f64;
        }
        2.0 * sum
    } else {
        phi * x.cos() - 2.0 * x.sin()
    }
}

/// Brent's method (zeroin) on a bracket `[a, b]` with `f(a)`, `f(b)` of
/// opposite signs (or one of them zero). Converges to full relative precision
/// in the abscissa (`tol = 2ε|x|`), with a hard cap on iterations.
fn brent(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64, mut fa: f64, mut fb: f64) -> f64 {
    if fa == 0.0 {
        return a;
    }
    if fb == 0.0 {
        return b;
    }
    let mut c = a;
    let mut fc = fa;
    let mut d = b - a;
    let mut e = d;
    for _ in 0..300 {
        if (fb > 0.0) == (fc > 0.0) {
            c = a;
            fc = fa;
            d = b - a;
            e = d;
        }
        if fc.abs() < fb.abs() {
            a = b;
            b = c;
            c = a;
            fa = fb;
            fb = fc;
            fc = fa;
        }
        let tol1 = 2.0 * f64::EPSILON * b.abs() + 1e-300;
        let xm = 0.5 * (c - b);
        if xm.abs() <= tol1 || fb == 0.0 {
            return b;
        }
        if e.abs() >= tol1 && fa.abs() > fb.abs() {
            let s = fb / fa;
            let (mut p, mut q);
            if a == c {
                p = 2.0 * xm * s;
                q = 1.0 - s;
            } else {
                let qq = fa / fc;
                let r = fb / fc;
                p = s * (2.0 * xm * qq * (qq - r) - (b - a) * (r - 1.0));
                q = (qq - 1.0) * (r - 1.0) * (s - 1.0);
            }
            if p > 0.0 {
                q = -q;
            } else {
                p = -p;
            }
            if 2.0 * p < (3.0 * xm * q - (tol1 * q).abs()).min((e * q).abs()) {
                e = d;
                d = p / q;
            } else {
                d = xm;
                e = d;
            }
        } else {
            d = xm;
            e = d;
        }
        a = b;
        fa = fb;
        b += if d.abs() > tol1 { d } else { tol1.copysign(xm) };
        fb = f(b);
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_angle_defect_series_matches_direct() {
        for &phi in &[0.99f64, 0.9, 0.5, 0.999999] {
            let x = 0.5 * phi;
            let direct = phi * x.cos() - 2.0 * x.sin();
            assert!(
                (half_angle_defect(phi) - direct).abs() < 1e-14 * direct.abs(),
                "{phi}"
            );
        }
        let small = half_angle_defect(1e-6);
        assert!((small + 1e-18 / 12.0).abs() < 1e-30);
    }

    #[test]
    fn brent_finds_roots_to_full_precision() {
        let r = brent(|x| x * x - 2.0, 0.0, 2.0, -2.0, 2.0);
        assert!((r - 2f64.sqrt()).abs() <= 4.0 * f64::EPSILON);
        let tiny = 1e-200;
        let r = brent(|x| x - tiny, 0.0, 1.0, -tiny, 1.0 - tiny);
        assert!((r - tiny).abs() <= 1e-14 * tiny);
    }
}
