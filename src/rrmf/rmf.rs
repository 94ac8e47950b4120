//! The rational rotation-minimising frame of a class I RRMF quintic
//! (Proposition 2.7): `ℬ = 𝒜𝒲` with `𝒲 = a + 𝐢b` quadratic, and
//!
//! ```text
//! 𝐟₁ = ℬ𝐢ℬ*/|ℬ|² (= 𝐭),   𝐟₂ = ℬ𝐣ℬ*/|ℬ|²,   𝐟₃ = ℬ𝐤ℬ*/|ℬ|²,
//! ```
//!
//! rational of degree 8. Since `𝒲` commutes with `𝐢`, the frame is the
//! Euler–Rodrigues frame turned about the tangent by `2ψ`, `ψ = arg w`
//! (`w = a + ib` as a complex polynomial), and it is rotation-minimising iff
//! `ψ′ = scal(𝒜′𝐢𝒜*)/|𝒜|²` — condition (2.5) with the sign of ERRATA 001.1
//! (as printed it would double the twist instead of cancelling it).
//!
//! **Finding 𝒲.** The paper does not spell it out; we derive it. With
//! `w = c(t − ζ₁)(t − ζ₂)`, `ψ′ = Σ Im ζₖ / |t − ζₖ|²`, a rational function
//! with denominator `|w|²`; matching `scal(𝒜′𝐢𝒜*)/|𝒜|²` forces `|w|² ∝
//! |𝒜|²`, so `ζ₁, ζ₂` are roots of the real quartic `σ = |𝒜|²` (no real
//! roots: the curve is regular), one from each conjugate pair. Of the four
//! choices exactly one satisfies the condition for a class I quintic (2.17)
//! — the one we keep, checked at three parameters. The roots come from
//! Aberth–Ehrlich iteration polished by Newton steps; `𝒲` is scaled so
//! that `𝒲(0) = 1`, which makes the frame start as the Euler–Rodrigues frame
//! (Section 4 places that on the prescribed initial frame with `α₀`).

use glam::DVec3;

use super::quat::{Quat, I, J, K};
use super::quintic::{bernstein2, PhQuintic};

/// A complex number `re + i·im`, `i` identified with the quaternion `𝐢`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct C64 {
    re: f64,
    im: f64,
}

impl C64 {
    const fn new(re: f64, im: f64) -> Self {
        C64 { re, im }
    }
    fn add(self, o: C64) -> C64 {
        C64::new(self.re + o.re, self.im + o.im)
    }
    fn sub(self, o: C64) -> C64 {
        C64::new(self.re - o.re, self.im - o.im)
    }
    fn mul(self, o: C64) -> C64 {
        C64::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
    fn div(self, o: C64) -> C64 {
        let d = o.re * o.re + o.im * o.im;
        C64::new(
            (self.re * o.re + self.im * o.im) / d,
            (self.im * o.re - self.re * o.im) / d,
        )
    }
    fn conj(self) -> C64 {
        C64::new(self.re, -self.im)
    }
    fn abs(self) -> f64 {
        self.re.hypot(self.im)
    }
}

/// `p(z)` and `p′(z)` for real monomial coefficients `c₀ … c₄`.
fn eval_quartic(c: &[f64; 5], z: C64) -> (C64, C64) {
    let mut p = C64::new(c[4], 0.0);
    let mut dp = C64::default();
    for k in (0..4).rev() {
        dp = dp.mul(z).add(p);
        p = p.mul(z).add(C64::new(c[k], 0.0));
    }
    (p, dp)
}

/// The four complex roots of `c₀ + c₁z + … + c₄z⁴` (`c₄ ≠ 0`).
fn quartic_roots(c: &[f64; 5]) -> [C64; 4] {
    // Cauchy-style radius for the starting circle.
    let r = 1.0 + (0..4).map(|k| (c[k] / c[4]).abs()).fold(0.0f64, f64::max);
    let mut z: [C64; 4] = std::array::from_fn(|k| {
        let a = 0.4 + k as f64 * std::f64::consts::FRAC_PI_2;
        C64::new(0.5 * r * a.cos(), 0.5 * r * a.sin())
    });
    for _ in 0..200 {
        let mut moved = 0.0f64;
        for k in 0..4 {
            let (p, dp) = eval_quartic(c, z[k]);
            if p.abs() == 0.0 {
                continue;
            }
            let ratio = p.div(dp);
            let mut s = C64::default();
            for j in 0..4 {
                if j != k {
                    s = s.add(C64::new(1.0, 0.0).div(z[k].sub(z[j])));
                }
            }
            let step = ratio.div(C64::new(1.0, 0.0).sub(ratio.mul(s)));
            z[k] = z[k].sub(step);
            moved = moved.max(step.abs() / z[k].abs().max(1e-300));
        }
        if moved < 1e-16 {
            break;
        }
    }
    // Newton polish on the full polynomial.
    for zk in z.iter_mut() {
        for _ in 0..3 {
            let (p, dp) = eval_quartic(c, *zk);
            if dp.abs() > 0.0 {
                *zk = zk.sub(p.div(dp));
            }
        }
    }
    z
}

/// Why no rational RMF was found.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RmfError {
    #[error("the pre-image vanishes on [0, 1] (a degenerate PH quintic, Definition 2.3)")]
    Degenerate,
    #[error(
        "no quadratic W satisfies condition (2.5) (residual {0:.3e}): not a class I RRMF quintic"
    )]
    NotRrmf(f64),
}

/// A class I RRMF quintic with its rational RMF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RrmfQuintic {
    pub curve: PhQuintic,
    /// Bernstein coefficients of `𝒲 = a + 𝐢b`, as quaternions `a + b𝐢`.
    pub w: [Quat; 3],
}

impl RrmfQuintic {
    /// Find `𝒲` for `curve` (module docs). `NotRrmf` when the best of the four
    /// root pairings leaves a relative residual above `1e-8` in (2.5).
    pub fn new(curve: PhQuintic) -> Result<Self, RmfError> {
        // σ = |𝒜|² in monomial form from its Bernstein weights (2.12).
        let wts = curve.speed_weights();
        const B4: [[f64; 5]; 5] = [
            [1.0, -4.0, 6.0, -4.0, 1.0],
            [0.0, 4.0, -12.0, 12.0, -4.0],
            [0.0, 0.0, 6.0, -12.0, 6.0],
            [0.0, 0.0, 0.0, 4.0, -4.0],
            [0.0, 0.0, 0.0, 0.0, 1.0],
        ];
        let mut c = [0.0; 5];
        for i in 0..5 {
            for k in 0..5 {
                c[k] += wts[i] * B4[i][k];
            }
        }
        if !(c[4].abs() > 0.0) || !c.iter().all(|v| v.is_finite()) {
            return Err(RmfError::Degenerate);
        }
        let roots = quartic_roots(&c);
        // One root of each conjugate pair: the two with the largest |Im|
        // that are not conjugates of each other.
        let mut upper: Vec<C64> = roots
            .iter()
            .map(|z| if z.im < 0.0 { z.conj() } else { *z })
            .collect();
        upper.sort_by(|a, b| b.im.total_cmp(&a.im));
        // Pairs come twice (z and z̄ fold onto one); keep the two distinct.
        let z1 = upper[0];
        let z2 = *upper[1..]
            .iter()
            .max_by(|a, b| a.sub(z1).abs().total_cmp(&b.sub(z1).abs()))
            .unwrap_or(&upper[1]);
        if z1.im.abs() < 1e-14 * (1.0 + z1.abs()) || z2.im.abs() < 1e-14 * (1.0 + z2.abs()) {
            return Err(RmfError::Degenerate);
        }
        let target = |t: f64| {
            let a = curve.pre_image_at(t);
            let da = curve.pre_image_derivative(t);
            (da * Quat::pure(I) * a.conj()).s / a.norm2()
        };
        let mut best: Option<(f64, [C64; 3])> = None;
        for (s1, s2) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
            let r1 = C64::new(z1.re, s1 * z1.im);
            let r2 = C64::new(z2.re, s2 * z2.im);
            // w(t) = (t − r1)(t − r2) = r1r2 − (r1 + r2) t + t².
            let m = [
                r1.mul(r2),
                C64::new(0.0, 0.0).sub(r1.add(r2)),
                C64::new(1.0, 0.0),
            ];
            let mut res = 0.0f64;
            for t in [0.0, 0.5, 1.0] {
                let w = m[0]
                    .add(m[1].mul(C64::new(t, 0.0)))
                    .add(C64::new(t * t, 0.0));
                let dw = m[1].add(C64::new(2.0 * t, 0.0));
                let psi_dot = dw.div(w).im;
                let want = target(t);
                res = res.max((psi_dot - want).abs() / (1.0 + want.abs()));
            }
            if best.map_or(true, |(r, _)| res < r) {
                best = Some((res, m));
            }
        }
        let (res, m) = best.unwrap_or((f64::INFINITY, [C64::default(); 3]));
        if !(res < 1e-8) {
            return Err(RmfError::NotRrmf(res));
        }
        // Monomial → Bernstein (quadratic): b₀ = m₀, b₁ = m₀ + m₁/2,
        // b₂ = m₀ + m₁ + m₂; then scale by conj(w(0))/|w(0)|² so 𝒲(0) = 1.
        let half = C64::new(0.5, 0.0);
        let b = [m[0], m[0].add(m[1].mul(half)), m[0].add(m[1]).add(m[2])];
        let scale = C64::new(1.0, 0.0).div(b[0]);
        let w = b.map(|z| {
            let z = z.mul(scale);
            Quat::new(z.re, I * z.im)
        });
        Ok(RrmfQuintic { curve, w })
    }

    /// `𝒲(t)`.
    pub fn w_at(&self, t: f64) -> Quat {
        let b = bernstein2(t);
        self.w[0] * b[0] + self.w[1] * b[1] + self.w[2] * b[2]
    }

    fn w_derivative(&self, t: f64) -> Quat {
        (self.w[1] - self.w[0]) * (2.0 * (1.0 - t)) + (self.w[2] - self.w[1]) * (2.0 * t)
    }

    /// `ℬ(t) = 𝒜(t)𝒲(t)`.
    pub fn b_at(&self, t: f64) -> Quat {
        self.curve.pre_image_at(t) * self.w_at(t)
    }

    /// The RMF `(𝐟₁, 𝐟₂, 𝐟₃)` at `t`.
    pub fn frame(&self, t: f64) -> [DVec3; 3] {
        let b = self.b_at(t);
        let n = b.norm2();
        [b.sandwich(I) / n, b.sandwich(J) / n, b.sandwich(K) / n]
    }

    /// `(𝐟₁, 𝐟₂, 𝐟₃)′(t)`, exactly (quotient rule on the rational form).
    pub fn frame_derivative(&self, t: f64) -> [DVec3; 3] {
        let b = self.b_at(t);
        let db = self.curve.pre_image_derivative(t) * self.w_at(t)
            + self.curve.pre_image_at(t) * self.w_derivative(t);
        let d = b.norm2();
        let dd = 2.0 * (db.s * b.s + db.v.dot(b.v));
        [I, J, K].map(|e| {
            let n = b.sandwich(e);
            let dn = (db * Quat::pure(e) * b.conj() + b * Quat::pure(e) * db.conj()).v;
            (dn * d - n * dd) / (d * d)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rrmf::quintic::tests::{class_one, sample};
    use proptest::prelude::*;

    #[test]
    fn quartic_roots_are_roots() {
        let c = [2.0, -1.0, 3.0, 0.5, 1.5];
        for z in quartic_roots(&c) {
            let (p, _) = eval_quartic(&c, z);
            assert!(p.abs() < 1e-13, "{z:?}");
        }
    }

    /// The rotation-minimising frame by double reflection (Wang, Jüttler,
    /// Zheng & Liu 2008), `n` steps, from `f` at `t = 0`.
    fn double_reflection(c: &PhQuintic, f: [DVec3; 3], n: usize) -> [DVec3; 3] {
        let (mut r, mut t, mut u) = (c.position(0.0), c.tangent(0.0), f[1]);
        for k in 1..=n {
            let x = k as f64 / n as f64;
            let (r1, t1) = (c.position(x), c.tangent(x));
            let v1 = r1 - r;
            let c1 = v1.dot(v1);
            let rl = u - (2.0 / c1) * v1.dot(u) * v1;
            let tl = t - (2.0 / c1) * v1.dot(t) * v1;
            let v2 = t1 - tl;
            let c2 = v2.dot(v2);
            u = rl - (2.0 / c2) * v2.dot(rl) * v2;
            (r, t) = (r1, t1);
        }
        [t, u, t.cross(u)]
    }

    #[test]
    fn the_frame_is_rotation_minimising_and_rational() {
        let r = RrmfQuintic::new(sample()).unwrap();
        let mut worst = 0.0f64;
        for i in 0..=100 {
            let t = i as f64 / 100.0;
            let f = r.frame(t);
            let df = r.frame_derivative(t);
            // Orthonormal and adapted.
            assert!((f[0] - r.curve.tangent(t)).length() < 1e-14);
            assert!(f[1].dot(f[2]).abs() < 1e-14 && (f[0].cross(f[1]) - f[2]).length() < 1e-14);
            // RMF: no rotation about the tangent, f₂′·f₃ = 0.
            worst = worst.max((df[1].dot(f[2]) / df[0].length().max(1.0)).abs());
        }
        assert!(worst < 1e-12, "{worst:e}");
        // W(0) = 1: the frame starts as the Euler–Rodrigues frame.
        let e = r.curve.euler_rodrigues_frame(0.0);
        let f = r.frame(0.0);
        for k in 0..3 {
            assert!((e[k] - f[k]).length() < 1e-15);
        }
        // Agrees with a numerically integrated RMF (double reflection,
        // fourth order: 4000 steps leave ~1e-12).
        let num = double_reflection(&r.curve, f, 4000);
        let end = r.frame(1.0);
        assert!(
            (num[1] - end[1]).length() < 1e-9,
            "{:e}",
            (num[1] - end[1]).length()
        );
        // The ERF is not rotation-minimising here: it turns about 𝐭.
        let e1 = r.curve.euler_rodrigues_frame(1.0);
        assert!((e1[1] - end[1]).length() > 1e-3);
    }

    #[test]
    fn not_class_one_is_refused() {
        let mut c = sample();
        c.pre_image[1] = c.pre_image[1] + Quat::from_array([0.0, 0.3, 0.0, 0.1]);
        assert!(matches!(RrmfQuintic::new(c), Err(RmfError::NotRrmf(_))));
    }

    proptest! {
        #[test]
        fn random_class_one_quintics_have_rational_rmf(
            a0 in prop::array::uniform4(-1.0f64..1.0),
            a2 in prop::array::uniform4(-1.0f64..1.0),
            theta in -3.0f64..3.0,
        ) {
            let c = class_one(Quat::from_array(a0), Quat::from_array(a2), theta);
            prop_assume!(c.pre_image[0].norm() > 0.1 && c.pre_image[2].norm() > 0.1);
            // Keep regular curves with a speed bounded away from zero.
            let min_speed = (0..=50).map(|i| c.speed(i as f64 / 50.0)).fold(f64::INFINITY, f64::min);
            let max_speed = (0..=50).map(|i| c.speed(i as f64 / 50.0)).fold(0.0, f64::max);
            prop_assume!(min_speed > 1e-2 * max_speed);
            let r = RrmfQuintic::new(c).unwrap();
            for i in 0..=20 {
                let t = i as f64 / 20.0;
                let f = r.frame(t);
                let df = r.frame_derivative(t);
                let scale = df[0].length().max(1.0);
                prop_assert!((df[1].dot(f[2]) / scale).abs() < 1e-10, "{}", df[1].dot(f[2]));
            }
        }
    }
}
