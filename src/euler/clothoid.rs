//! Planar clothoids (2D Euler spirals) and their G1 Hermite interpolation.
//! The curve is described on `Clothoid`, the Fresnel integrals and their
//! accuracy on `generalized_fresnel`, the solve on `clothoid_g1`.

use glam::DVec2;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

// ---------------------------------------------------------------- complex

#[derive(Clone, Copy, Debug, PartialEq)]
struct Cx {
    re: f64,
    im: f64,
}

impl Cx {
    const fn new(re: f64, im: f64) -> Self {
        Cx { re, im }
    }
    fn cis(t: f64) -> Self {
        let (s, c) = t.sin_cos();
        Cx::new(c, s)
    }
    fn add(self, o: Cx) -> Cx {
        Cx::new(self.re + o.re, self.im + o.im)
    }
    fn sub(self, o: Cx) -> Cx {
        Cx::new(self.re - o.re, self.im - o.im)
    }
    fn mul(self, o: Cx) -> Cx {
        Cx::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
    fn scale(self, k: f64) -> Cx {
        Cx::new(self.re * k, self.im * k)
    }
    fn div(self, o: Cx) -> Cx {
        // Smith's algorithm.
        if o.re.abs() >= o.im.abs() {
            let r = o.im / o.re;
            let d = o.re + o.im * r;
            Cx::new((self.re + self.im * r) / d, (self.im - self.re * r) / d)
        } else {
            let r = o.re / o.im;
            let d = o.re * r + o.im;
            Cx::new((self.re * r + self.im) / d, (self.im * r - self.re) / d)
        }
    }
}

// ---------------------------------------------------------------- Fresnel

/// Fresnel integrals `(C(x), S(x)) = ∫₀ˣ (cos, sin)(πt²/2) dt`.
///
/// Power series for `|x| < 1.5`; for larger `|x|` the continued fraction of
/// `erfc` (modified Lentz), `C + iS = (1+i)/2 (1 − e^{iπx²/2} h)`. Odd in `x`.
/// Verified to ≈ 1e-15 absolute against quadrature (tests; see
/// [`generalized_fresnel`] for the method and the measured accuracy).
///
/// Published values at 1 (Abramowitz & Stegun, Table 7.7), and the asymptotic
/// form `C ≈ ½ + sin(πx²/2)/(πx)`, `S ≈ ½ − cos(πx²/2)/(πx)` at 1000:
/// ```
/// use strandfit::euler::fresnel_cs;
/// use std::f64::consts::PI;
///
/// let (c, s) = fresnel_cs(1.0);
/// assert!((c - 0.779_893_400_376_823).abs() < 1e-14 && (s - 0.438_259_147_390_355).abs() < 1e-14);
/// assert_eq!(fresnel_cs(-1.0), (-c, -s)); // odd
/// let (c, s) = fresnel_cs(1000.0);
/// assert!((c - 0.5).abs() < 1e-9 && (s - (0.5 - 1.0 / (1000.0 * PI))).abs() < 1e-9);
/// ```
pub fn fresnel_cs(x: f64) -> (f64, f64) {
    let ax = x.abs();
    let (c, s) = if ax < 1e-150 {
        (ax, 0.0)
    } else if ax < 1.5 {
        // C = Σ (−1)ⁿ (π/2)^{2n} x^{4n+1} / ((2n)! (4n+1)),
        // S = Σ (−1)ⁿ (π/2)^{2n+1} x^{4n+3} / ((2n+1)! (4n+3)).
        let f = FRAC_PI_2 * ax * ax;
        let mut term = ax; // (π/2)^k x^{2k+1} / k!
        let (mut c, mut s) = (ax, 0.0);
        let mut k = 1u32;
        loop {
            term *= f / k as f64;
            let t = term / (2 * k + 1) as f64;
            let sign = if (k / 2).is_multiple_of(2) { 1.0 } else { -1.0 };
            if k.is_multiple_of(2) {
                c += sign * t;
            } else {
                s += sign * t;
            }
            if t < 1e-17 * (c.abs() + s.abs()) || k > 100 {
                break;
            }
            k += 1;
        }
        (c, s)
    } else {
        // Continued fraction (modified Lentz) for
        // h = 1/(b₀ − 1·2/(b₀+4 − 3·4/(b₀+8 − …))), b₀ = 1 − iπx².
        let tiny = 1e-300;
        let mut b = Cx::new(1.0, -PI * ax * ax);
        let mut cc = Cx::new(1.0 / tiny, 0.0);
        let one = Cx::new(1.0, 0.0);
        let mut d = one.div(b);
        let mut h = d;
        let mut n = -1.0_f64;
        for _ in 0..400 {
            n += 2.0;
            let a = -n * (n + 1.0);
            b = b.add(Cx::new(4.0, 0.0));
            d = one.div(d.scale(a).add(b));
            cc = b.add(Cx::new(a, 0.0).div(cc));
            let del = cc.mul(d);
            h = h.mul(del);
            if (del.re - 1.0).abs() + del.im.abs() < 1e-16 {
                break;
            }
        }
        h = Cx::new(ax, -ax).mul(h);
        let cs = Cx::new(0.5, 0.5).mul(one.sub(cis_half_pi_sq(ax).mul(h)));
        (cs.re, cs.im)
    };
    if x < 0.0 {
        (-c, -s)
    } else {
        (c, s)
    }
}

/// `e^{iπx²/2}` with the phase reduced exactly: `x² = hi + lo` (FMA), `hi`
/// reduced mod 4 (exact), so large `x` keeps full accuracy.
fn cis_half_pi_sq(x: f64) -> Cx {
    let hi = x * x;
    let lo = x.mul_add(x, -hi);
    let r = hi - 4.0 * (hi / 4.0).round(); // exact for |hi| < 2⁵³
    Cx::cis(FRAC_PI_2 * (r + lo))
}

/// `J_m(b) = ∫₀¹ tᵐ e^{ibt} dt` for `m = 0..=mmax`, each in its stable
/// direction of `J_m = (e^{ib} − m J_{m−1})/(ib)`.
fn j_moments(b: f64, mmax: usize) -> Vec<Cx> {
    let mut j = vec![Cx::new(0.0, 0.0); mmax + 1];
    let e = Cx::cis(b);
    let ab = b.abs();
    // Upward part: m < |b| (error factor m/|b| < 1 per step).
    let mut up_to = 0usize; // J_m known for m < up_to
    if ab >= 1.0 {
        let ib = Cx::new(0.0, b);
        // J₀ = (e^{ib} − 1)/(ib)
        j[0] = e.sub(Cx::new(1.0, 0.0)).div(ib);
        up_to = 1;
        let mut m = 1usize;
        while m <= mmax && (m as f64) < ab {
            j[m] = e.sub(j[m - 1].scale(m as f64)).div(ib);
            m += 1;
        }
        up_to = up_to.max(m);
    }
    if up_to <= mmax {
        // Downward from a high order M where errors die out (factor |b|/m per step).
        let mut big = mmax.max(ab as usize) + 40 + 2 * (ab as usize);
        big = big.max(mmax + 20);
        // J_M ≈ e^{ib}/(M+1) (leading behaviour); its error is damped away.
        let mut jm = e.scale(1.0 / (big as f64 + 1.0));
        let ib = Cx::new(0.0, b);
        for m in (up_to..big).rev() {
            // J_m = (e^{ib} − ib J_{m+1})/(m+1)
            jm = e.sub(ib.mul(jm)).scale(1.0 / (m as f64 + 1.0));
            if m <= mmax {
                j[m] = jm;
            }
        }
    }
    j
}

/// Below this |a| the generalised integrals are the series in `a`; above it,
/// Fresnel `C, S` after completing the square.
const A_SERIES: f64 = 4.0;
/// Up to this |a| the series is also used when `|b| > 2|a|`, where the
/// moment recurrences of the Fresnel form would amplify errors by `(|b|/|a|)ᵏ`.
const A_SERIES_WIDE: f64 = 12.0;

/// Generalised Fresnel integrals and moments `X_k, Y_k` for `k = 0, 1, 2`:
/// `X_k(a,b,c) = ∫₀¹ tᵏ cos(a t²/2 + b t + c) dt`, `Y_k` with `sin`
/// (Bertolazzi & Frego).
///
/// With `a = 0`, `b = 0`: `X_k = 1/(k + 1)`, `Y_k = 0`; with `a = π` and with
/// `a = 4π` (the other branch), Fresnel's `C(1)` and `C(2)/2`:
/// ```
/// use strandfit::euler::{fresnel_cs, generalized_fresnel};
/// use std::f64::consts::PI;
///
/// let (x, y) = generalized_fresnel(0.0, 0.0, 0.0);
/// assert!((x[0] - 1.0).abs() < 1e-15 && (x[1] - 0.5).abs() < 1e-15 && (x[2] - 1.0 / 3.0).abs() < 1e-15);
/// assert!(y.iter().all(|v| v.abs() < 1e-15));
/// assert!((generalized_fresnel(PI, 0.0, 0.0).0[0] - fresnel_cs(1.0).0).abs() < 1e-14);
/// assert!((generalized_fresnel(4.0 * PI, 0.0, 0.0).0[0] - fresnel_cs(2.0).0 / 2.0).abs() < 1e-14);
/// ```
///
/// # Method and accuracy
///
/// `C(x), S(x) = ∫₀ˣ cos/sin(πt²/2) dt` ([`fresnel_cs`])
/// are summed as a power series for `|x| < 1.5` and from the Lentz continued
/// fraction of the complementary error function beyond (Numerical Recipes
/// Fresnel method, written here from the formulas). For `|a| ≥ 4` the
/// generalised integrals complete the square and use `C, S`; their moments
/// `k = 1, 2` follow from `∫ θ′ e^{iθ} = −i[e^{iθ}]` (exact recurrences).
/// For `|a| < 4` (including `a = 0`) they are the series
/// `X_k + iY_k = e^{ic} Σₙ (ia/2)ⁿ/n! J_{k+2n}(b)`, `J_m(b) = ∫₀¹ tᵐ e^{ibt} dt`,
/// where `J_m` runs upward (`m < |b|`) or downward (`m > |b|`) through
/// `J_m = (e^{ib} − m J_{m−1})/(ib)`, each in its stable direction.
/// Measured (tests): `C, S` agree with mpmath to ≤ 3.4e-16 for
/// `|x| ≤ 1000` (the phase `πx²/2` is reduced exactly, see
/// `cis_half_pi_sq`); `X_k, Y_k` (`k ≤ 2`) agree with composite 20-point
/// Gauss–Legendre quadrature to ≤ 3e-15 on the grid `a ∈ {0, ±1e-8, 1e-3,
/// …, ±100, ±1e3, ±1e4}`, `|b| ≤ 40`. Known weak spot: for `|a| ≥ 12` with
/// `|b| ≫ |a|` the moments `k = 1, 2` lose about `k·log₁₀(|b|/|a|)` digits
/// (recurrence division by `a`); the G1 solve never goes there
/// (`|b| ≤ |a|/2 + 2π`).
pub fn generalized_fresnel(a: f64, b: f64, c: f64) -> ([f64; 3], [f64; 3]) {
    if a.abs() < A_SERIES || (a.abs() < A_SERIES_WIDE && b.abs() > 2.0 * a.abs()) {
        // Series in a: X_k + iY_k = e^{ic} Σₙ (ia/2)ⁿ/n! J_{k+2n}(b).
        // |a| < 4: terms peak at 2²/2! = 2 (≲ 1 digit lost); for |a| < 12
        // at ≈ e⁶ (≈ 2.5 digits), accepted where the recurrences below would
        // lose more (|b| > 2|a|). 6⁶⁰/60! ≈ 1e-35.
        const N: usize = 60;
        let j = j_moments(b, 2 + 2 * N);
        let mut out = [Cx::new(0.0, 0.0); 3];
        for (k, o) in out.iter_mut().enumerate() {
            let mut coef = Cx::new(1.0, 0.0); // (ia/2)^n/n!
            let mut sum = Cx::new(0.0, 0.0);
            for n in 0..=N {
                if n > 0 {
                    coef = coef.mul(Cx::new(0.0, a / 2.0)).scale(1.0 / n as f64);
                }
                sum = sum.add(coef.mul(j[k + 2 * n]));
                if coef.re.abs() + coef.im.abs() < 1e-22 {
                    break;
                }
            }
            *o = Cx::cis(c).mul(sum);
        }
        return (
            [out[0].re, out[1].re, out[2].re],
            [out[0].im, out[1].im, out[2].im],
        );
    }
    // Complete the square: a t²/2 + bt + c = s·(π/2)u² + η, u = z(t + b/a),
    // z = √(|a|/π), η = c − b²/(2a), s = sign a.
    let s = a.signum();
    let z = (a.abs() / PI).sqrt();
    let ell = s * b / (PI * a.abs()).sqrt();
    let eta = c - b * b / (2.0 * a);
    let (c0, s0) = fresnel_cs(ell);
    let (c1, s1) = fresnel_cs(ell + z);
    let (dc, ds) = (c1 - c0, s1 - s0);
    let (se, ce) = eta.sin_cos();
    let x0 = (ce * dc - s * se * ds) / z;
    let y0 = (se * dc + s * ce * ds) / z;
    // ∫ (at + b) e^{iθ} = −i (e^{iθ(1)} − e^{ic}),  ∫ t(at+b) e^{iθ} = −i e^{iθ(1)} + i ∫ e^{iθ}.
    let th1 = a / 2.0 + b + c;
    let (s1t, c1t) = th1.sin_cos();
    let (sc, cc) = c.sin_cos();
    let x1 = (s1t - sc - b * x0) / a;
    let y1 = (cc - c1t - b * y0) / a;
    let x2 = (s1t - y0 - b * x1) / a;
    let y2 = (-c1t + x0 - b * y1) / a;
    ([x0, x1, x2], [y0, y1, y2])
}

// ---------------------------------------------------------------- clothoid

/// A clothoid segment: `κ(s) = κ₀ + κ′s`, `θ(s) = θ₀ + κ₀s + κ′s²/2`,
/// `0 ≤ s ≤ L`, starting at `start`.
///
/// Its tangent angle is `θ(s) = θ₀ + κ₀s + κ′s²/2`, so
///
/// ```text
/// P(s) = P₀ + ∫₀ˢ (cos θ(u), sin θ(u)) du = P₀ + s (X₀, Y₀)(κ′s², κ₀s, θ₀),
/// ```
///
/// with the generalised Fresnel integrals (Bertolazzi & Frego, "G1 fitting
/// with clothoids", Math. Methods Appl. Sci. 38 (2015))
///
/// ```text
/// X_k(a,b,c) = ∫₀¹ tᵏ cos(a t²/2 + b t + c) dt,   Y_k(a,b,c) = ∫₀¹ tᵏ sin(…) dt.
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clothoid {
    /// Start point `P(0)`.
    pub start: DVec2,
    /// Tangent angle at the start, `θ₀` (radians).
    pub theta0: f64,
    /// Curvature at the start, `κ₀`.
    pub kappa0: f64,
    /// Curvature rate `κ′ = dκ/ds`.
    pub dkappa: f64,
    /// Arc length `L > 0`.
    pub length: f64,
}

impl Clothoid {
    /// Point at arc length `s`: `P₀ + s (X₀, Y₀)(κ′s², κ₀s, θ₀)`.
    ///
    /// The clothoid `κ(s) = πs` from the origin is Fresnel's `(C(s), S(s))`:
    /// ```
    /// use strandfit::euler::{fresnel_cs, Clothoid};
    /// use glam::DVec2;
    /// use std::f64::consts::PI;
    ///
    /// let c = Clothoid { start: DVec2::ZERO, theta0: 0.0, kappa0: 0.0, dkappa: PI, length: 2.0 };
    /// let (fc, fs) = fresnel_cs(1.5);
    /// assert!((c.eval(1.5) - DVec2::new(fc, fs)).length() < 1e-14);
    /// ```
    pub fn eval(&self, s: f64) -> DVec2 {
        let (x, y) = generalized_fresnel((self.dkappa * s) * s, self.kappa0 * s, self.theta0);
        self.start + s * DVec2::new(x[0], y[0])
    }
    /// Tangent angle `θ(s) = θ₀ + κ₀s + κ′s²/2`.
    ///
    /// The direction of `P′(s)` (here by central difference) is `θ(s)`:
    /// ```
    /// use strandfit::euler::Clothoid;
    /// use glam::DVec2;
    ///
    /// let c = Clothoid { start: DVec2::ZERO, theta0: 0.3, kappa0: -0.5, dkappa: 2.0, length: 2.0 };
    /// let h = 1e-5;
    /// let d = (c.eval(1.2 + h) - c.eval(1.2 - h)) / (2.0 * h);
    /// assert!((d - DVec2::from_angle(c.angle(1.2))).length() < 1e-8);
    /// ```
    pub fn angle(&self, s: f64) -> f64 {
        self.theta0 + s * (self.kappa0 + 0.5 * self.dkappa * s)
    }
    /// Curvature `κ(s) = κ₀ + κ′s`.
    ///
    /// ```
    /// use strandfit::euler::Clothoid;
    /// use glam::DVec2;
    ///
    /// let c = Clothoid { start: DVec2::ZERO, theta0: 0.3, kappa0: -0.5, dkappa: 2.0, length: 2.0 };
    /// assert_eq!(c.curvature(1.5), 2.5);
    /// ```
    pub fn curvature(&self, s: f64) -> f64 {
        self.kappa0 + self.dkappa * s
    }
    /// End point `P(L)`.
    ///
    /// A quarter of the unit circle (`κ ≡ 1`) from the origin along `x`:
    /// ```
    /// use strandfit::euler::Clothoid;
    /// use glam::DVec2;
    /// use std::f64::consts::FRAC_PI_2;
    ///
    /// let arc = Clothoid { start: DVec2::ZERO, theta0: 0.0, kappa0: 1.0, dkappa: 0.0, length: FRAC_PI_2 };
    /// assert!((arc.end() - DVec2::new(1.0, 1.0)).length() < 1e-15);
    /// ```
    pub fn end(&self) -> DVec2 {
        self.eval(self.length)
    }
    /// The same curve traversed from its end: `θ₀ ← θ(L) + π`,
    /// `κ₀ ← −(κ₀ + κ′L)`, `κ′` unchanged.
    ///
    /// The reversed clothoid ends where the original starts, heading back:
    /// ```
    /// use strandfit::euler::{normalize_angle, Clothoid};
    /// use glam::DVec2;
    /// use std::f64::consts::PI;
    ///
    /// let c = Clothoid { start: DVec2::new(1.0, 2.0), theta0: 0.3, kappa0: -0.5, dkappa: 2.0, length: 2.0 };
    /// let r = c.reversed();
    /// assert!((r.end() - c.start).length() < 1e-14);
    /// assert!(normalize_angle(r.angle(r.length) - (c.theta0 + PI)).abs() < 1e-14);
    /// ```
    pub fn reversed(&self) -> Clothoid {
        Clothoid {
            start: self.end(),
            theta0: self.angle(self.length) + PI,
            kappa0: -self.curvature(self.length),
            dkappa: self.dkappa,
            length: self.length,
        }
    }
}

/// Why [`clothoid_g1`] found no clothoid.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum ClothoidError {
    /// A coordinate or angle is NaN or infinite, or the chord or the
    /// resulting curvatures overflow `f64`.
    #[error("non-finite clothoid G1 input")]
    NonFinite,
    /// The end points coincide (to rounding), so the chord has no direction.
    #[error("clothoid G1 end points coincide")]
    CoincidentPoints,
    /// Newton (with its bisection safeguard) did not find the root of g(A).
    #[error("clothoid G1 solve did not converge")]
    NoConvergence,
}

/// Reduce an angle to `(−π, π]`.
///
/// ```
/// use strandfit::euler::normalize_angle;
/// use std::f64::consts::{FRAC_PI_2, PI};
///
/// assert!((normalize_angle(3.0 * FRAC_PI_2) + FRAC_PI_2).abs() < 1e-15);
/// assert_eq!(normalize_angle(-PI), PI);
/// assert!((normalize_angle(7.0 * PI + 0.25) - (0.25 - PI)).abs() < 1e-14);
/// ```
pub fn normalize_angle(x: f64) -> f64 {
    let mut y = x - TAU * (x / TAU).round();
    if y <= -PI {
        y += TAU;
    }
    if y > PI {
        y -= TAU;
    }
    y
}

/// `g(A) = Y₀(2A, δ − A, φ₀)` and `g′(A) = X₂ − X₁`.
fn g_and_dg(a: f64, delta: f64, phi0: f64) -> (f64, f64) {
    let (x, y) = generalized_fresnel(2.0 * a, delta - a, phi0);
    (y[0], x[2] - x[1])
}

/// G1 Hermite interpolation by a clothoid (Bertolazzi & Frego 2015):
/// the clothoid from `p0` with tangent angle `theta0` to `p1` with tangent
/// angle `theta1` (angles mod 2π).
///
/// With `r = |p1 − p0|`, chord angle `φ`, `φ₀,₁ = normalise(θ₀,₁ − φ) ∈ (−π, π]`
/// and `δ = φ₁ − φ₀`, solve `g(A) = Y₀(2A, δ − A, φ₀) = 0` by Newton from
/// the paper's fitted initial guess (`A ≈ 3(φ₀ + φ₁)` corrected by a
/// polynomial in `φ₀/π, φ₁/π`), safeguarded by bisection on a sign-change
/// bracket around the guess; then `L = r / X₀(2A, δ − A, φ₀)`,
/// `κ′ = 2A/L²`, `κ₀ = (δ − A)/L`. The returned `theta0` is
/// `φ + φ₀` (the input reduced mod 2π), and `angle(L) = φ + φ₁`.
///
/// From `(1, 0)` heading up to `(0, 1)` heading left the clothoid is the quarter
/// of the unit circle (`κ₀ = 1`, `κ′ = 0`, `L = π/2`):
/// ```
/// use strandfit::euler::clothoid_g1;
/// use glam::DVec2;
/// use std::f64::consts::{FRAC_PI_2, PI};
///
/// let c = clothoid_g1(DVec2::X, FRAC_PI_2, DVec2::Y, PI).unwrap();
/// assert!((c.kappa0 - 1.0).abs() < 1e-12 && c.dkappa.abs() < 1e-12);
/// assert!((c.length - FRAC_PI_2).abs() < 1e-12);
/// assert!((c.end() - DVec2::Y).length() < 1e-12);
/// ```
///
/// Paper 004 (3D Euler spirals, Section 6, Step 1) initialises its 3D
/// descent with the planar spiral fitted here.
///
/// # Root choice
///
/// Newton from the paper's fitted guess converges (no safeguard needed) on
/// a 61×61 grid (also checked once at 301×301) of
/// `(φ₀, φ₁) ∈ [−π, π]²`, including `φ₀ = φ₁ = π`, and the roots it finds
/// satisfy `0 ≤ A/(φ₀+φ₁) ≤ 3`. The solver accepts a root only inside that
/// window (widened slightly, `root_window`); outside it, or if Newton
/// fails, a bracketed search inside the window takes over. The window is
/// measured, not the paper's proven uniqueness interval (not coded here).
pub fn clothoid_g1(
    p0: DVec2,
    theta0: f64,
    p1: DVec2,
    theta1: f64,
) -> Result<Clothoid, ClothoidError> {
    if !(p0.is_finite() && p1.is_finite() && theta0.is_finite() && theta1.is_finite()) {
        return Err(ClothoidError::NonFinite);
    }
    let d = p1 - p0;
    let r = d.x.hypot(d.y); // no under/overflow of the squares
    let scale = p0.abs().max_element().max(p1.abs().max_element());
    if !r.is_finite() {
        return Err(ClothoidError::NonFinite); // the chord overflows
    }
    if !(r > 4.0 * f64::EPSILON * scale) {
        return Err(ClothoidError::CoincidentPoints);
    }
    let phi = d.y.atan2(d.x);
    let phi0 = normalize_angle(theta0 - phi);
    let phi1 = normalize_angle(theta1 - phi);
    let delta = phi1 - phi0;

    // Initial guess (fitted polynomial of Bertolazzi & Frego; ≈ 3(φ₀+φ₁)).
    const CF: [f64; 6] = [
        2.989696028701907,
        0.716228953608281,
        -0.458969738821509,
        -0.502821153340377,
        0.261062141752652,
        -0.045854475238709,
    ];
    let (xx, yy) = (phi0 / PI, phi1 / PI);
    let xy = xx * yy;
    let (x2, y2) = (xx * xx, yy * yy);
    let guess = (phi0 + phi1)
        * (CF[0]
            + xy * (CF[1] + xy * CF[2])
            + (CF[3] + xy * CF[4]) * (x2 + y2)
            + CF[5] * (x2 * x2 + y2 * y2));

    let a = solve_a(guess, delta, phi0, root_window(phi0 + phi1))
        .ok_or(ClothoidError::NoConvergence)?;
    let (x, _) = generalized_fresnel(2.0 * a, delta - a, phi0);
    let l = r / x[0];
    if !(l.is_finite() && l > 0.0) {
        return Err(ClothoidError::NoConvergence);
    }
    let (kappa0, dkappa) = ((delta - a) / l, 2.0 * a / l / l); // no L² overflow
    if !(kappa0.is_finite() && dkappa.is_finite()) {
        return Err(ClothoidError::NonFinite); // curvatures overflow (tiny chord)
    }
    Ok(Clothoid {
        start: p0,
        theta0: phi + phi0,
        kappa0,
        dkappa,
        length: l,
    })
}

#[cfg(test)]
thread_local! {
    /// How often (this thread) [`solve_a`] fell back to its bracketed safeguard.
    static SAFEGUARD_USED: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// Root of `g` near `guess`: Newton, kept inside a sign-change bracket when
/// Newton leaves it or stalls (bisection step).
/// Where the wanted root lies: `A` has the sign of `φ₀ + φ₁` and
/// `|A| ≤ 3|φ₀ + φ₁|` (measured on a 61×61 grid of `[−π, π]²`: the ratio
/// `A/(φ₀+φ₁)` stays in `[0, 3.0]`; test `angle_domain_grid_interpolates`),
/// widened by 3% and 0.05. Our stand-in for the paper's uniqueness interval.
fn root_window(sum: f64) -> (f64, f64) {
    let (a, b) = (0.0_f64, 3.1 * sum);
    (a.min(b) - 0.05, a.max(b) + 0.05)
}

fn solve_a(guess: f64, delta: f64, phi0: f64, window: (f64, f64)) -> Option<f64> {
    // Newton converges quadratically: once a step is below 1e-10 the next
    // (polishing) step is at rounding level; asking for less than that makes
    // it cycle between neighbouring floats.
    let tol = 1e-10;
    // Plain Newton first (the paper: a few iterations from its guess).
    let mut a = guess;
    for _ in 0..30 {
        let (g, dg) = g_and_dg(a, delta, phi0);
        if g == 0.0 {
            return Some(a);
        }
        let step = g / dg;
        if !step.is_finite() {
            break;
        }
        a -= step;
        if step.abs() <= tol * a.abs().max(1.0) {
            // One more step to polish.
            let (g, dg) = g_and_dg(a, delta, phi0);
            let st = g / dg;
            if st.is_finite() && st.abs() < 1e-9 * a.abs().max(1.0) {
                a -= st;
            }
            if a >= window.0 && a <= window.1 {
                return Some(a);
            }
            break; // a root outside the window: not the one wanted
        }
        if !a.is_finite() || (a - guess).abs() > 4.0 * TAU {
            break;
        }
    }
    #[cfg(test)]
    SAFEGUARD_USED.with(|c| c.set(c.get() + 1));
    bracketed_root(guess, delta, phi0, window)
}

/// Safeguard: the sign change of `g` inside `window` nearest `guess`
/// (clamped into the window; steps of 0.05 outward), then Newton kept
/// inside it (bisection).
fn bracketed_root(guess: f64, delta: f64, phi0: f64, window: (f64, f64)) -> Option<f64> {
    let (wl, wh) = window;
    if !(wl <= wh) {
        return None;
    }
    let guess = guess.clamp(wl, wh);
    let h = 0.05;
    let mut bracket = None;
    let steps = ((wh - wl) / h).ceil() as usize + 1;
    'outer: for i in 0..steps {
        for dir in [1.0, -1.0] {
            let lo = guess + dir * h * i as f64;
            if lo < wl || lo > wh {
                continue;
            }
            // shared with the next step; clipped to the window
            let hi = (guess + dir * h * (i + 1) as f64).clamp(wl, wh);
            if hi == lo {
                continue;
            }
            let (gl, _) = g_and_dg(lo, delta, phi0);
            let (gh, _) = g_and_dg(hi, delta, phi0);
            if gl == 0.0 {
                return Some(lo);
            }
            if gl.signum() != gh.signum() {
                bracket = Some((lo.min(hi), hi.max(lo)));
                break 'outer;
            }
        }
    }
    let (mut lo, mut hi) = bracket?;
    let mut glo = g_and_dg(lo, delta, phi0).0;
    let mut a = 0.5 * (lo + hi);
    for _ in 0..200 {
        let (g, dg) = g_and_dg(a, delta, phi0);
        if g == 0.0 {
            return Some(a);
        }
        if g.signum() == glo.signum() {
            lo = a;
            glo = g;
        } else {
            hi = a;
        }
        let newton = a - g / dg;
        let next = if newton.is_finite() && newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        if (next - a).abs() <= 1e-15 * a.abs().max(1.0)
            || hi - lo <= 4.0 * f64::EPSILON * a.abs().max(1.0)
        {
            return Some(next);
        }
        a = next;
    }
    None
}

#[cfg(test)]
mod tests;
