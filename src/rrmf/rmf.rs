//! The rational rotation-minimising frame of a class I RRMF quintic
//! (Proposition 2.7): the frame is described on `RrmfQuintic`, how `𝒲` is
//! found on `RrmfQuintic::new`.

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

/// `Σ bᵢ Bᵢⁿ(z)` for complex `z` by de Casteljau (stable near `[0, 1]`,
/// where the monomial form of `σ` cancels).
fn bernstein_complex<const N: usize>(b: [f64; N], z: C64) -> C64 {
    let mut c: [C64; N] = b.map(|v| C64::new(v, 0.0));
    let one_minus = C64::new(1.0 - z.re, -z.im);
    for r in 1..N {
        for j in 0..N - r {
            c[j] = one_minus.mul(c[j]).add(z.mul(c[j + 1]));
        }
    }
    c[0]
}

/// Newton steps on `σ(z) = Σ wᵢBᵢ⁴(z)` evaluated in Bernstein form.
fn polish_bernstein(w: &[f64; 5], z: C64) -> C64 {
    let dw: [f64; 4] = std::array::from_fn(|i| 4.0 * (w[i + 1] - w[i]));
    let mut z = z;
    for _ in 0..4 {
        let p = bernstein_complex(*w, z);
        let dp = bernstein_complex(dw, z);
        if dp.abs() == 0.0 {
            break;
        }
        let step = p.div(dp);
        z = z.sub(step);
        if step.abs() <= 1e-17 * z.abs() {
            break;
        }
    }
    z
}

/// The four complex roots of `c₀ + c₁z + … + c₄z⁴` (`c₄ ≠ 0`).
fn quartic_roots(c: &[f64; 5]) -> [C64; 4] {
    // Cauchy-style radius for the starting circle.
    let r = 1.0 + (0..4).map(|k| (c[k] / c[4]).abs()).fold(0.0f64, f64::max);
    let mut z: [C64; 4] = std::array::from_fn(|k| {
        let a = 0.4 + k as f64 * std::f64::consts::FRAC_PI_2;
        C64::new(0.5 * r * a.cos(), 0.5 * r * a.sin())
    });
    // Aberth converges cubically; rounding keeps the steps from reaching
    // zero, so stop at 1e-12 relative (the Bernstein-form Newton polish and
    // the refinements take it from there) or after 60 sweeps.
    for _ in 0..60 {
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
        if moved < 1e-12 {
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

/// Newton refinement of `w`, normalised to `w(0) = 1`, on the RMF
/// condition itself. From `ψ′ = scal(𝒜′𝐢𝒜*)/σ` and `|w|² ∝ σ = |𝒜|²`,
/// `w′/w = P/σ` with the complex cubic `P = scal(𝒜′𝒜*) + i scal(𝒜′𝐢𝒜*)`,
/// so `P = c w′ w̄` (`w̄`: conjugated coefficients): `w̄ = 1 + b₁t + b₂t²`
/// divides `P`. Writing `P = (αt + β) w̄` gives `β = P₀`, `α = P₁ − P₀b₁`
/// and two complex equations,
/// `E₁ = (P₁ − P₀b₁)b₁ + P₀b₂ − P₂ = 0`, `E₂ = (P₁ − P₀b₁)b₂ − P₃ = 0`,
/// solved by Newton from the roots' estimate. The normalised form keeps
/// every unknown O(1) even when the roots of `σ` are far from `[0, 1]`
/// (nearly constant speed), where the monic form loses `|ζ|²` in relative
/// precision; the equations are the condition itself, so the digits the
/// roots lose (close or near-real roots) come back too.
fn refine(curve: &PhQuintic, m: [C64; 3]) -> [C64; 3] {
    let [a0, a1, a2] = curve.pre_image;
    // 𝒜 = c₀ + c₁t + c₂t², 𝒜′ = d₀ + d₁t.
    let c = [a0, (a1 - a0) * 2.0, a0 - a1 * 2.0 + a2];
    let d = [c[1], c[2] * 2.0];
    let mut pc = [C64::default(); 4];
    for (i, di) in d.iter().enumerate() {
        for (j, cj) in c.iter().enumerate() {
            let re = di.s * cj.s + di.v.dot(cj.v);
            let im = (*di * Quat::pure(I) * cj.conj()).s;
            pc[i + j] = pc[i + j].add(C64::new(re, im));
        }
    }
    let zero = C64::default();
    let eqs = |b1: C64, b2: C64| {
        let alpha = pc[1].sub(pc[0].mul(b1));
        let e1 = alpha.mul(b1).add(pc[0].mul(b2)).sub(pc[2]);
        let e2 = alpha.mul(b2).sub(pc[3]);
        (e1, e2, alpha)
    };
    // w = m₀ + m₁t + m₂t² → w/m₀; w̄'s coefficients are the conjugates.
    let mut b1 = m[1].div(m[0]).conj();
    let mut b2 = m[2].div(m[0]).conj();
    let size = |e1: C64, e2: C64| e1.abs() + e2.abs();
    let (e1, e2, _) = eqs(b1, b2);
    let mut err = size(e1, e2);
    for _ in 0..8 {
        let (e1, e2, alpha) = eqs(b1, b2);
        // ∂E₁/∂b₁ = P₁ − 2P₀b₁, ∂E₁/∂b₂ = P₀, ∂E₂/∂b₁ = −P₀b₂, ∂E₂/∂b₂ = α.
        let j11 = pc[1].sub(pc[0].mul(b1).mul(C64::new(2.0, 0.0)));
        let j12 = pc[0];
        let j21 = zero.sub(pc[0].mul(b2));
        let j22 = alpha;
        let det = j11.mul(j22).sub(j12.mul(j21));
        if det.abs() == 0.0 {
            break;
        }
        let d1 = e1.mul(j22).sub(j12.mul(e2)).div(det);
        let d2 = j11.mul(e2).sub(e1.mul(j21)).div(det);
        let (n1, n2) = (b1.sub(d1), b2.sub(d2));
        let (f1, f2, _) = eqs(n1, n2);
        let e = size(f1, f2);
        if !(e < err) {
            break;
        }
        (b1, b2, err) = (n1, n2, e);
    }
    [C64::new(1.0, 0.0), b1.conj(), b2.conj()]
}

/// Gauss–Newton on the phase condition alone, `Im(w′/w) = T(t) =
/// scal(𝒜′𝐢𝒜*)/σ`, at `t = k/8`, for `w = 1 + β₁t + β₂t²` (four real
/// unknowns). The frame depends only on the phase of `w` (`|𝒲|` cancels in
/// `ℬ𝐞ℬ*/|ℬ|²`), and for a pre-image that is class I only up to rounding the
/// modulus condition `|w|² ∝ σ` and the phase condition can disagree in the
/// last digits — by up to 1e-12 on nearly constant-speed quintics, where
/// the identity is ill-conditioned. Fitting the phase is what makes the
/// frame rotation-minimising to rounding.
fn refine_phase(curve: &PhQuintic, m: [C64; 3]) -> [C64; 3] {
    let target = |t: f64| {
        let a = curve.pre_image_at(t);
        let da = curve.pre_image_derivative(t);
        (da * Quat::pure(I) * a.conj()).s / a.norm2()
    };
    let ts: [f64; 9] = std::array::from_fn(|k| k as f64 / 8.0);
    let tv = ts.map(target);
    let one = C64::new(1.0, 0.0);
    let (mut b1, mut b2) = (m[1].div(m[0]), m[2].div(m[0]));
    let residuals = |b1: C64, b2: C64| -> [f64; 9] {
        std::array::from_fn(|k| {
            let t = C64::new(ts[k], 0.0);
            let w = one.add(b1.mul(t)).add(b2.mul(t).mul(t));
            let dw = b1.add(b2.mul(t).mul(C64::new(2.0, 0.0)));
            dw.div(w).im - tv[k]
        })
    };
    let norm = |r: &[f64; 9]| r.iter().map(|v| v * v).sum::<f64>();
    let mut err = norm(&residuals(b1, b2));
    for _ in 0..6 {
        let r = residuals(b1, b2);
        // Jacobian rows: ∂Im g/∂(Re β₁, Im β₁, Re β₂, Im β₂) with
        // ∂g/∂β₁ = (w − t w′)/w², ∂g/∂β₂ = (2t w − t² w′)/w².
        let mut jtj = [[0.0f64; 4]; 4];
        let mut jtr = [0.0f64; 4];
        for k in 0..9 {
            let t = C64::new(ts[k], 0.0);
            let w = one.add(b1.mul(t)).add(b2.mul(t).mul(t));
            let dw = b1.add(b2.mul(t).mul(C64::new(2.0, 0.0)));
            let w2 = w.mul(w);
            let g1 = w.sub(t.mul(dw)).div(w2);
            let g2 = t
                .mul(w)
                .mul(C64::new(2.0, 0.0))
                .sub(t.mul(t).mul(dw))
                .div(w2);
            let row = [g1.im, g1.re, g2.im, g2.re];
            for i in 0..4 {
                jtr[i] += row[i] * r[k];
                for j in 0..4 {
                    jtj[i][j] += row[i] * row[j];
                }
            }
        }
        let Some(step) = solve4(jtj, jtr) else { break };
        let n1 = b1.sub(C64::new(step[0], step[1]));
        let n2 = b2.sub(C64::new(step[2], step[3]));
        let e = norm(&residuals(n1, n2));
        if !(e < err) {
            break;
        }
        (b1, b2, err) = (n1, n2, e);
    }
    [one, b1, b2]
}

/// `A x = b` for a 4×4 system (partial pivoting); `None` if singular.
fn solve4(mut a: [[f64; 4]; 4], mut b: [f64; 4]) -> Option<[f64; 4]> {
    for k in 0..4 {
        let p = (k..4).max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))?;
        a.swap(p, k);
        b.swap(p, k);
        if a[k][k] == 0.0 {
            return None;
        }
        for i in k + 1..4 {
            let f = a[i][k] / a[k][k];
            for j in k..4 {
                a[i][j] -= f * a[k][j];
            }
            b[i] -= f * b[k];
        }
    }
    let mut x = [0.0; 4];
    for k in (0..4).rev() {
        let s: f64 = (k + 1..4).map(|j| a[k][j] * x[j]).sum();
        x[k] = (b[k] - s) / a[k][k];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Why no rational RMF was found.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RmfError {
    #[error("the pre-image vanishes on [0, 1] (a degenerate PH quintic, Definition 2.3)")]
    /// The pre-image vanishes on `[0, 1]` (a degenerate PH quintic, Definition 2.3).
    Degenerate,
    #[error(
        "no quadratic W satisfies condition (2.5) (residual {0:.3e}): not a class I RRMF quintic"
    )]
    /// No quadratic `𝒲` satisfies condition (2.5) (by this residual): not a class I RRMF quintic.
    NotRrmf(f64),
}

/// A class I RRMF quintic with its rational RMF.
///
/// The rational rotation-minimising frame (Proposition 2.7): `ℬ = 𝒜𝒲` with
/// `𝒲 = a + 𝐢b` quadratic, and
///
/// ```text
/// 𝐟₁ = ℬ𝐢ℬ*/|ℬ|² (= 𝐭),   𝐟₂ = ℬ𝐣ℬ*/|ℬ|²,   𝐟₃ = ℬ𝐤ℬ*/|ℬ|²,
/// ```
///
/// rational of degree 8. Since `𝒲` commutes with `𝐢`, the frame is the
/// Euler–Rodrigues frame turned about the tangent by `2ψ`, `ψ = arg w`
/// (`w = a + ib` as a complex polynomial), and it is rotation-minimising iff
/// `ψ′ = scal(𝒜′𝐢𝒜*)/|𝒜|²` — condition (2.5) with the sign of ERRATA 001.1
/// (as printed it would double the twist instead of cancelling it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RrmfQuintic {
    /// The PH quintic.
    pub curve: PhQuintic,
    /// Bernstein coefficients of `𝒲 = a + 𝐢b`, as quaternions `a + b𝐢`.
    pub w: [Quat; 3],
}

impl RrmfQuintic {
    /// Find `𝒲` for `curve` (see **Finding 𝒲** below). `NotRrmf` when the best
    /// of the four root pairings leaves a relative residual above `1e-8` in
    /// (2.5).
    ///
    /// A class I quintic (`𝒜₁ = √(vect(𝒜₂𝐢𝒜₀*))`) has its rational RMF, starting
    /// as the Euler–Rodrigues frame; a generic PH quintic has none:
    /// ```
    /// use strandfit::rrmf::{sqrt_wrt_i, PhQuintic, Quat, RmfError, RrmfQuintic};
    /// use strandfit::DVec3;
    ///
    /// let (a0, a2) = (Quat::from_array([0.3, 1.0, -0.2, 0.4]), Quat::from_array([1.0, 0.5, 0.2, -0.1]));
    /// let a1 = sqrt_wrt_i((a2 * Quat::pure(DVec3::X) * a0.conj()).v).unwrap();
    /// let r = RrmfQuintic::new(PhQuintic::new(DVec3::ZERO, [a0, a1, a2])).unwrap();
    /// assert!((0..=4).all(|k| r.rmf_residual(k as f64 / 4.0) < 1e-12));
    /// assert!((r.frame(0.0)[1] - r.curve.euler_rodrigues_frame(0.0)[1]).length() < 1e-14);
    /// let generic = PhQuintic::new(DVec3::ZERO, [a0, Quat::ONE, a2]);
    /// assert!(matches!(RrmfQuintic::new(generic), Err(RmfError::NotRrmf(_))));
    /// ```
    ///
    /// **Finding 𝒲.** The paper does not spell it out; we derive it. With
    /// `w = c(t − ζ₁)(t − ζ₂)`, `ψ′ = Σ Im ζₖ / |t − ζₖ|²`, a rational function
    /// with denominator `|w|²`; matching `scal(𝒜′𝐢𝒜*)/|𝒜|²` forces `|w|² ∝
    /// |𝒜|²`, so `ζ₁, ζ₂` are roots of the real quartic `σ = |𝒜|²` (no real
    /// roots: the curve is regular), one from each conjugate pair. Of the four
    /// choices exactly one satisfies the condition for a class I quintic (2.17)
    /// — the one we keep, checked at three parameters. The roots come from
    /// Aberth–Ehrlich iteration polished by Newton steps; `𝒲` is scaled so
    /// that `𝒲(0) = 1`, which makes the frame start as the Euler–Rodrigues frame
    /// (Section 4 places that on the prescribed initial frame with `α₀`).
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
        let scale = wts.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if !(scale > 0.0) || !c.iter().all(|v| v.is_finite()) {
            return Err(RmfError::Degenerate);
        }
        let min_speed = (0..=64)
            .map(|k| curve.speed(k as f64 / 64.0))
            .fold(f64::INFINITY, f64::min);
        if !(min_speed > 1e-12 * scale) {
            return Err(RmfError::Degenerate);
        }
        let target = |t: f64| {
            let a = curve.pre_image_at(t);
            let da = curve.pre_image_derivative(t);
            (da * Quat::pure(I) * a.conj()).s / a.norm2()
        };
        let one = C64::new(1.0, 0.0);
        // Start: the root pairing that best meets the condition, or w = 1
        // when σ has lower degree (roots at infinity: a straight segment,
        // constant speed).
        let start = if c[4].abs() > 1e-9 * scale {
            let roots = quartic_roots(&c).map(|z| polish_bernstein(&wts, z));
            // One root of each conjugate pair: fold onto the upper half
            // plane (pairs then come twice) and keep two distinct ones.
            let mut upper: Vec<C64> = roots
                .iter()
                .map(|z| if z.im < 0.0 { z.conj() } else { *z })
                .collect();
            upper.sort_by(|a, b| b.im.total_cmp(&a.im));
            let z1 = upper[0];
            let z2 = *upper[1..]
                .iter()
                .max_by(|a, b| a.sub(z1).abs().total_cmp(&b.sub(z1).abs()))
                .unwrap_or(&upper[1]);
            let mut best: Option<(f64, [C64; 3])> = None;
            for (s1, s2) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
                let r1 = C64::new(z1.re, s1 * z1.im);
                let r2 = C64::new(z2.re, s2 * z2.im);
                // w(t) = (t − r1)(t − r2) = r1r2 − (r1 + r2) t + t².
                let m = [r1.mul(r2), C64::default().sub(r1.add(r2)), one];
                let mut res = 0.0f64;
                for t in [0.0, 0.5, 1.0] {
                    let w = m[0]
                        .add(m[1].mul(C64::new(t, 0.0)))
                        .add(C64::new(t * t, 0.0));
                    let dw = m[1].add(C64::new(2.0 * t, 0.0));
                    let want = target(t);
                    res = res.max((dw.div(w).im - want).abs() / (1.0 + want.abs()));
                }
                if res.is_finite() && best.is_none_or(|(r, _)| res < r) {
                    best = Some((res, m));
                }
            }
            best.map_or([one, C64::default(), C64::default()], |(_, m)| m)
        } else {
            [one, C64::default(), C64::default()]
        };
        let m = refine_phase(&curve, refine(&curve, start));
        // The condition must now hold to rounding; a pre-image that is not
        // class I leaves a residual no quadratic w can remove.
        let mut res = 0.0f64;
        for k in 0..=16 {
            let t = C64::new(k as f64 / 16.0, 0.0);
            let w = m[0].add(m[1].mul(t)).add(m[2].mul(t).mul(t));
            let dw = m[1].add(m[2].mul(t).mul(C64::new(2.0, 0.0)));
            let want = target(t.re);
            res = res.max((dw.div(w).im - want).abs() / (1.0 + want.abs()));
        }
        if !(res < 1e-9) {
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
    ///
    /// `𝒲 = a + 𝐢b` (it commutes with `𝐢`), scaled so that `𝒲(0) = 1`:
    /// ```
    /// use strandfit::rrmf::{sqrt_wrt_i, PhQuintic, Quat, RrmfQuintic};
    /// use strandfit::DVec3;
    ///
    /// let (a0, a2) = (Quat::from_array([0.3, 1.0, -0.2, 0.4]), Quat::from_array([1.0, 0.5, 0.2, -0.1]));
    /// let a1 = sqrt_wrt_i((a2 * Quat::pure(DVec3::X) * a0.conj()).v).unwrap();
    /// let r = RrmfQuintic::new(PhQuintic::new(DVec3::ZERO, [a0, a1, a2])).unwrap();
    /// assert!((r.w_at(0.0) - Quat::ONE).norm() < 1e-15);
    /// let w = r.w_at(0.6);
    /// assert!(w.v.y == 0.0 && w.v.z == 0.0);
    /// ```
    pub fn w_at(&self, t: f64) -> Quat {
        let b = bernstein2(t);
        self.w[0] * b[0] + self.w[1] * b[1] + self.w[2] * b[2]
    }

    fn w_derivative(&self, t: f64) -> Quat {
        (self.w[1] - self.w[0]) * (2.0 * (1.0 - t)) + (self.w[2] - self.w[1]) * (2.0 * t)
    }

    /// `ℬ(t) = 𝒜(t)𝒲(t)`.
    ///
    /// `ℬ = 𝒜𝒲`, so `|ℬ|² = |𝒜|²|𝒲|²`:
    /// ```
    /// use strandfit::rrmf::{sqrt_wrt_i, PhQuintic, Quat, RrmfQuintic};
    /// use strandfit::DVec3;
    ///
    /// let (a0, a2) = (Quat::from_array([0.3, 1.0, -0.2, 0.4]), Quat::from_array([1.0, 0.5, 0.2, -0.1]));
    /// let a1 = sqrt_wrt_i((a2 * Quat::pure(DVec3::X) * a0.conj()).v).unwrap();
    /// let r = RrmfQuintic::new(PhQuintic::new(DVec3::ZERO, [a0, a1, a2])).unwrap();
    /// let want = r.curve.pre_image_at(0.6).norm2() * r.w_at(0.6).norm2();
    /// assert!((r.b_at(0.6).norm2() - want).abs() < 1e-14 * want);
    /// ```
    pub fn b_at(&self, t: f64) -> Quat {
        self.curve.pre_image_at(t) * self.w_at(t)
    }

    /// The RMF `(𝐟₁, 𝐟₂, 𝐟₃)` at `t`.
    ///
    /// Orthonormal, right-handed, led by the curve's tangent:
    /// ```
    /// use strandfit::rrmf::{sqrt_wrt_i, PhQuintic, Quat, RrmfQuintic};
    /// use strandfit::DVec3;
    ///
    /// let (a0, a2) = (Quat::from_array([0.3, 1.0, -0.2, 0.4]), Quat::from_array([1.0, 0.5, 0.2, -0.1]));
    /// let a1 = sqrt_wrt_i((a2 * Quat::pure(DVec3::X) * a0.conj()).v).unwrap();
    /// let r = RrmfQuintic::new(PhQuintic::new(DVec3::ZERO, [a0, a1, a2])).unwrap();
    /// let [f1, f2, f3] = r.frame(0.6);
    /// assert!((f1 - r.curve.tangent(0.6)).length() < 1e-14);
    /// assert!(f1.dot(f2).abs() < 1e-14 && (f1.cross(f2) - f3).length() < 1e-14);
    /// ```
    pub fn frame(&self, t: f64) -> [DVec3; 3] {
        let b = self.b_at(t);
        let n = b.norm2();
        [b.sandwich(I) / n, b.sandwich(J) / n, b.sandwich(K) / n]
    }

    /// The rate at which the Euler–Rodrigues frame turns about the tangent,
    /// `2 scal(𝒜′𝐢𝒜*)/|𝒜|²` per unit parameter: what `𝒲` cancels, hence
    /// the scale of the rounding left in `𝐟₂′·𝐟₃`.
    ///
    /// It is `−𝐞₂′·𝐞₃ = 𝐞₃′·𝐞₂`, the Euler–Rodrigues frame's turning rate
    /// about the tangent counted from `𝐞₃` towards `𝐞₂` (here against a
    /// central difference):
    /// ```
    /// use strandfit::rrmf::{sqrt_wrt_i, PhQuintic, Quat, RrmfQuintic};
    /// use strandfit::DVec3;
    ///
    /// let (a0, a2) = (Quat::from_array([0.3, 1.0, -0.2, 0.4]), Quat::from_array([1.0, 0.5, 0.2, -0.1]));
    /// let a1 = sqrt_wrt_i((a2 * Quat::pure(DVec3::X) * a0.conj()).v).unwrap();
    /// let r = RrmfQuintic::new(PhQuintic::new(DVec3::ZERO, [a0, a1, a2])).unwrap();
    /// let (t, h) = (0.6, 1e-5);
    /// let e = |t| r.curve.euler_rodrigues_frame(t);
    /// let de2 = (e(t + h)[1] - e(t - h)[1]) / (2.0 * h);
    /// assert!((de2.dot(e(t)[2]) + r.erf_twist_rate(t)).abs() < 1e-8);
    /// ```
    pub fn erf_twist_rate(&self, t: f64) -> f64 {
        let a = self.curve.pre_image_at(t);
        let da = self.curve.pre_image_derivative(t);
        2.0 * (da * Quat::pure(I) * a.conj()).s / a.norm2()
    }

    /// The RMF condition's residual at `t`: `𝐟₂′·𝐟₃` (exactly zero for a
    /// rotation-minimising frame; per unit parameter, frames being unit),
    /// divided by `max(1, 2|ℬ′|/|ℬ|)` — the size of the terms the quotient
    /// rule cancels to get it (`ℬ = 𝒜𝒲`; it exceeds both `|𝐟₁′|` and the
    /// Euler–Rodrigues twist rate that `𝒲` cancels) where the frame turns
    /// fast, absolute where it turns slowly.
    ///
    /// Zero (to rounding) along a class I quintic: `𝐟₂′·𝐟₃ = 0`:
    /// ```
    /// use strandfit::rrmf::{sqrt_wrt_i, PhQuintic, Quat, RrmfQuintic};
    /// use strandfit::DVec3;
    ///
    /// let (a0, a2) = (Quat::from_array([0.3, 1.0, -0.2, 0.4]), Quat::from_array([1.0, 0.5, 0.2, -0.1]));
    /// let a1 = sqrt_wrt_i((a2 * Quat::pure(DVec3::X) * a0.conj()).v).unwrap();
    /// let r = RrmfQuintic::new(PhQuintic::new(DVec3::ZERO, [a0, a1, a2])).unwrap();
    /// assert!((0..=10).all(|k| r.rmf_residual(k as f64 / 10.0) < 1e-12));
    /// ```
    pub fn rmf_residual(&self, t: f64) -> f64 {
        let f = self.frame(t);
        let df = self.frame_derivative(t);
        let b = self.b_at(t);
        let db = self.curve.pre_image_derivative(t) * self.w_at(t)
            + self.curve.pre_image_at(t) * self.w_derivative(t);
        let scale = (2.0 * db.norm() / b.norm()).max(1.0);
        (df[1].dot(f[2]) / scale).abs()
    }

    /// `(𝐟₁, 𝐟₂, 𝐟₃)′(t)`, exactly (quotient rule on the rational form).
    ///
    /// It matches a central difference of [`frame`](Self::frame):
    /// ```
    /// use strandfit::rrmf::{sqrt_wrt_i, PhQuintic, Quat, RrmfQuintic};
    /// use strandfit::DVec3;
    ///
    /// let (a0, a2) = (Quat::from_array([0.3, 1.0, -0.2, 0.4]), Quat::from_array([1.0, 0.5, 0.2, -0.1]));
    /// let a1 = sqrt_wrt_i((a2 * Quat::pure(DVec3::X) * a0.conj()).v).unwrap();
    /// let r = RrmfQuintic::new(PhQuintic::new(DVec3::ZERO, [a0, a1, a2])).unwrap();
    /// let h = 1e-5;
    /// let (df, plus, minus) = (r.frame_derivative(0.6), r.frame(0.6 + h), r.frame(0.6 - h));
    /// assert!((0..3).all(|k| ((plus[k] - minus[k]) / (2.0 * h) - df[k]).length() < 1e-8));
    /// ```
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
            assert!(df[0].dot(f[0]).abs() < 1e-12);
            worst = worst.max(r.rmf_residual(t));
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
                prop_assert!(r.rmf_residual(t) < 1e-12, "{:e}", r.rmf_residual(t));
            }
        }
    }
}
