//! Frenet–Serret integration of a 3D Euler spiral, in `f64` (the reference).
//! The scheme and its error are described on `FrenetProblem`. Here: the
//! two-word quaternion update is `TwoQuat::rotate`, Neumaier's sum
//! `CompSum`, and `march` the loop that every integration drives.

use glam::{DQuat, DVec3};
use thiserror::Error;

/// Largest `|FᵀF − I|` entry (and `|T × N − B|`) accepted in a start frame.
pub const FRAME_TOL: f64 = 1e-9;

/// Why a [`FrenetProblem`] cannot be integrated.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum FrenetError {
    #[error("non-finite start point, frame, parameter or scaled rate")]
    /// A start value is not finite.
    NonFinite,
    #[error("negative length {0}")]
    /// The length is negative.
    NegativeLength(f64),
    #[error(
        "start frame is not orthonormal: max |FᵀF − I| = {deviation:.3e} exceeds {FRAME_TOL:e}"
    )]
    /// The start frame is not orthonormal.
    FrameNotOrthonormal {
        /// `max |FᵀF − I|`.
        deviation: f64,
    },
    #[error("start frame is left-handed: B = −T × N")]
    /// The start frame is left-handed (`B = −T × N`).
    LeftHanded,
    #[error("the step count must be at least 1")]
    /// The step count is zero.
    ZeroSteps,
}

/// A 3D Euler spiral given by its start (Definition 4.1 of paper 004).
///
/// # Integration
///
/// Definition 4.1 of paper 004: from `x(0) = x₀` and the frame
/// `F = [T N B]` (columns, orthonormal, right-handed),
///
/// ```text
/// x′ = T,   T′ = κN,   N′ = −κT + τB,   B′ = −τN,   κ = κ₀ + γs,  τ = τ₀ + δs.
/// ```
///
/// In matrix form `F′ = F Ŵ`, where `Ŵ` is the cross-product matrix of the
/// Darboux vector in body coordinates `W = (τ, 0, κ)` (so `F Ŵ e₁ = κN`
/// and so on). The frame is a path in SO(3), and [`integrate`](Self::integrate)
/// integrates it there:
///
/// **Scaling.** With `u = s/L ∈ [0, 1]` the rates become dimensionless,
/// `ω(u) = (t₀ + d u, 0, k₀ + g u)` with `k₀ = κ₀L`, `g = γL²`, `t₀ = τ₀L`,
/// `d = δL²` ([`FrenetProblem::rates`]), and the offset `(x − x₀)/L` is
/// `O(1)`. The GPU kernel works in exactly these variables (its `f32` values
/// stay `O(1)`); the host multiplies by `L` in `f64`.
///
/// **Frame: fourth-order Magnus steps.** Over an interval `[u, u + ℓ]` the
/// frame obeys `F(u + ℓ) = F(u) exp(Ω̂)`. Since `ω` is linear, write
/// `ω = a + b(u − u_m)` about the interval's midpoint `u_m`; the first two
/// Magnus terms (for the right action `F′ = F Ŵ` the commutator enters with
/// a `+`) are, in closed form,
///
/// ```text
/// Ω = ∫ω du + ½ ∫∫_{u₂<u₁} ω(u₂) × ω(u₁) = ℓ a + ℓ³/12 a × b
///   = ( ℓ(t₀ + d u_m),  ℓ³ c / 12,  ℓ(k₀ + g u_m) ),     c = k₀d − t₀g,
/// ```
///
/// (`a × b` has only an `N` component, and `c` is the same everywhere).
/// This is what the two-Gauss-point Magnus method of Iserles and Nørsett
/// evaluates for linear `ω`; the dropped terms are `O(ℓ⁵)`, so the rotation
/// is locally fifth and globally **fourth order**. `exp` is taken as a unit
/// quaternion `r = (cos φ/2, sinc(φ/2) Ω/2)`, `φ = |Ω|` (Rodrigues); the
/// frame is read off the accumulated quaternion normalised, so it is
/// orthonormal to a few `ε` whatever the step count (the paper's explicit
/// Euler drifts off SO(3) linearly in `h`, `ERRATA.md` §004). The
/// accumulated quaternion is updated as `q + q(r − 1)` in two words, so
/// that rounding does not drift linearly in the step count either. Each
/// step of `h = 1/N` is taken as two such rotations of `ℓ = h/2`, so the frame is
/// also known at the step's midpoint.
///
/// **Position: Simpson on the tangent.** `(x_{k+1} − x_k)/L =
/// h/6 (T_k + 4 T_{k+½} + T_{k+1})` with the tangents of the marched frames
/// (errors `O(h⁴)` globally, and the rule integrates cubics exactly), so the
/// position is globally `O(h⁴)` too. The increments are summed with
/// Neumaier's compensated sum, so the sum adds `O(ε)` rather than `O(Nε)`.
/// Cost per step: two `exp`s (one `sincos` each) and two quaternion
/// products.
///
/// **Error.** Truncation: `≈ C (Θ/N)⁴` relative, with `Θ = ∫|ω| du` the total
/// turning; the tests measure order 4 (halving `h` divides the error by 16).
/// Rounding: `O(εφ)` per rotation in the accumulated quaternion (two-word
/// update), so `O(εΘ)` in all, plus `O(ε)` per step, independent from step
/// to step, in the tangents read off it (`≈ √N ε` in the position).
///
/// **Symmetry.** The scheme is self-adjoint: stepping the reversed spiral
/// ([`FrenetProblem::reversed`], Prop. 5.2) undoes each rotation exactly in
/// exact arithmetic (the reversed interval's `Ω` is `−D Ω D` with
/// `D = diag(−1, 1, −1)`, the frame flip `(T, N, B) → (−T, N, −B)`: the
/// reversed rates have the same mean on the interval and `c̃ = −c`), and
/// Simpson's nodes are the same frames, so a round trip returns to the start
/// up to rounding, at any step count.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrenetProblem {
    /// `x₀`.
    pub start: DVec3,
    /// `[T₀, N₀, B₀]`, orthonormal and right-handed (`B₀ = T₀ × N₀`).
    pub frame: [DVec3; 3],
    /// `κ₀`: curvature at the start (signed: a negative value flips `N`).
    pub kappa0: f64,
    /// `γ = dκ/ds`.
    pub gamma: f64,
    /// `τ₀`: torsion at the start.
    pub tau0: f64,
    /// `δ = dτ/ds`.
    pub delta: f64,
    /// `L ≥ 0`.
    pub length: f64,
}

/// Point and frame `[T, N, B]` at one arc length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrenetEnd {
    /// `x(s)`.
    pub point: DVec3,
    /// `[T, N, B](s)`.
    pub frame: [DVec3; 3],
}

impl FrenetProblem {
    /// The problem with frame `[T, N, T × N]`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        start: DVec3,
        tangent: DVec3,
        normal: DVec3,
        kappa0: f64,
        gamma: f64,
        tau0: f64,
        delta: f64,
        length: f64,
    ) -> Self {
        FrenetProblem {
            start,
            frame: [tangent, normal, tangent.cross(normal)],
            kappa0,
            gamma,
            tau0,
            delta,
            length,
        }
    }

    /// `κ(s) = κ₀ + γs`.
    ///
    /// ```
    /// use strandfit::{DVec3, FrenetProblem};
    ///
    /// let p = FrenetProblem::new(DVec3::ZERO, DVec3::X, DVec3::Y, 1.0, 0.5, 0.2, -0.1, 4.0);
    /// assert_eq!(p.curvature(2.0), 2.0);
    /// ```
    pub fn curvature(&self, s: f64) -> f64 {
        self.kappa0 + self.gamma * s
    }

    /// `τ(s) = τ₀ + δs`.
    ///
    /// ```
    /// use strandfit::{DVec3, FrenetProblem};
    ///
    /// let p = FrenetProblem::new(DVec3::ZERO, DVec3::X, DVec3::Y, 1.0, 0.5, 0.2, -0.1, 4.0);
    /// assert!((p.torsion(2.0) - 0.0).abs() < 1e-15);
    /// ```
    pub fn torsion(&self, s: f64) -> f64 {
        self.tau0 + self.delta * s
    }

    /// The dimensionless rates `[κ₀L, γL², τ₀L, δL²]` of the scaled problem
    /// (`u = s/L`): what the integrator (and the GPU kernel) works with.
    ///
    /// ```
    /// use strandfit::{DVec3, FrenetProblem};
    ///
    /// let p = FrenetProblem::new(DVec3::ZERO, DVec3::X, DVec3::Y, 1.0, 0.5, 0.25, -0.125, 2.0);
    /// assert_eq!(p.rates(), [2.0, 2.0, 0.5, -0.5]);
    /// ```
    pub fn rates(&self) -> [f64; 4] {
        let l = self.length;
        [
            self.kappa0 * l,
            self.gamma * l * l,
            self.tau0 * l,
            self.delta * l * l,
        ]
    }

    /// Upper bound on the rotation angle of any of `steps` steps (the sum
    /// of its two Magnus angles):
    /// `h(max|t₀ + d u| + max|k₀ + g u|) + h³|c|/12` (the maxima at the ends,
    /// `ω` being linear). The GPU kernel refuses steps beyond
    /// [`crate::twin::frenet_integrate::STEP_ANGLE_MAX`].
    ///
    /// For a circle (`κ = 1`, `L = π`) every step turns by exactly `π/steps`:
    /// ```
    /// use strandfit::{DVec3, FrenetProblem};
    /// use std::f64::consts::PI;
    ///
    /// let half = FrenetProblem::new(DVec3::ZERO, DVec3::X, DVec3::Y, 1.0, 0.0, 0.0, 0.0, PI);
    /// assert!((half.max_step_angle(8) - PI / 8.0).abs() < 1e-15);
    /// ```
    pub fn max_step_angle(&self, steps: usize) -> f64 {
        step_angle_bound(self.rates(), steps)
    }

    /// Finite values, `L ≥ 0`, an orthonormal right-handed frame.
    ///
    /// ```
    /// use strandfit::euler::FrenetError;
    /// use strandfit::{DVec3, FrenetProblem};
    ///
    /// let p = FrenetProblem::new(DVec3::ZERO, DVec3::X, DVec3::Y, 1.0, 0.0, 0.0, 0.0, 1.0);
    /// assert_eq!(p.validate(), Ok(()));
    /// let left = FrenetProblem { frame: [DVec3::X, DVec3::Y, -DVec3::Z], ..p };
    /// assert_eq!(left.validate(), Err(FrenetError::LeftHanded));
    /// assert_eq!(FrenetProblem { length: -1.0, ..p }.validate(), Err(FrenetError::NegativeLength(-1.0)));
    /// ```
    pub fn validate(&self) -> Result<(), FrenetError> {
        let [t, n, b] = self.frame;
        let finite = self.start.is_finite()
            && self.frame.iter().all(|v| v.is_finite())
            && [self.kappa0, self.gamma, self.tau0, self.delta, self.length]
                .iter()
                .all(|x| x.is_finite())
            && self.rates().iter().all(|x| x.is_finite());
        if !finite {
            return Err(FrenetError::NonFinite);
        }
        if self.length < 0.0 {
            return Err(FrenetError::NegativeLength(self.length));
        }
        let mut deviation = 0.0f64;
        for (i, a) in self.frame.iter().enumerate() {
            for (j, c) in self.frame.iter().enumerate() {
                let want = if i == j { 1.0 } else { 0.0 };
                deviation = deviation.max((a.dot(*c) - want).abs());
            }
        }
        if deviation > FRAME_TOL {
            return Err(FrenetError::FrameNotOrthonormal { deviation });
        }
        if t.cross(n).dot(b) < 0.0 {
            return Err(FrenetError::LeftHanded);
        }
        Ok(())
    }

    /// Point and frame at `s = L` after `steps` steps of the fourth-order
    /// scheme ([integration](FrenetProblem#integration)): error
    /// `≈ C (Θ/steps)⁴` plus rounding.
    ///
    /// ```
    /// use strandfit::{DVec3, FrenetProblem};
    ///
    /// // κ = 1, τ = 0 for L = π: half of the unit circle.
    /// let half = FrenetProblem::new(DVec3::ZERO, DVec3::X, DVec3::Y, 1.0, 0.0, 0.0, 0.0, std::f64::consts::PI);
    /// let end = half.integrate(256).unwrap();
    /// assert!((end.point - DVec3::new(0.0, 2.0, 0.0)).length() < 1e-9);
    /// assert!((end.frame[0] + DVec3::X).length() < 1e-9);
    /// ```
    pub fn integrate(&self, steps: usize) -> Result<FrenetEnd, FrenetError> {
        self.validate()?;
        if steps == 0 {
            return Err(FrenetError::ZeroSteps);
        }
        Ok(self.integrate_unchecked(steps))
    }

    /// [`integrate`](Self::integrate) without validation (`steps = 0` is
    /// taken as 1). Invalid input gives meaningless (possibly non-finite)
    /// output, never a panic.
    ///
    /// Constant `κ = 0.8`, `τ = 0.4` is the helix of radius 1 and pitch `2π·0.5`
    /// about `z`; one turn (`L = 2π√1.25`) climbs `π`:
    /// ```
    /// use strandfit::{DVec3, FrenetProblem};
    /// use std::f64::consts::PI;
    ///
    /// let helix = FrenetProblem::new(DVec3::X, DVec3::new(0.0, 1.0, 0.5).normalize(), -DVec3::X,
    ///     0.8, 0.0, 0.4, 0.0, 2.0 * PI * 1.25f64.sqrt());
    /// let end = helix.integrate_unchecked(512);
    /// assert!((end.point - DVec3::new(1.0, 0.0, PI)).length() < 1e-9);
    /// ```
    pub fn integrate_unchecked(&self, steps: usize) -> FrenetEnd {
        let steps = steps.max(1);
        let mut end = self.state(DVec3::ZERO, DQuat::IDENTITY);
        march(self.rates(), steps, steps, &mut |p, q| {
            end = self.state(p, q)
        });
        end
    }

    /// [`integrate_unchecked`](Self::integrate_unchecked) (the same scheme,
    /// so the same end up to rounding, `≈ 1e-14`) with the derivatives of the end point and end tangent
    /// with respect to `(κ₀, γ, τ₀, δ, L)`, from one march.
    ///
    /// A change `δW(s)` of the Darboux vector `(τ, 0, κ)` (body
    /// coordinates) on `[s, s + ds]` turns the rest of the curve about
    /// `x(s)` by the world vector `F(s) δW ds`, so
    ///
    /// ```text
    /// δT(L) = δθ × T(L),   δθ = ∫₀ᴸ F δW ds,   δx(L) = ∫₀ᴸ F δW × (x(L) − x(s)) ds,
    /// ```
    ///
    /// with `F δW = B, sB, T, sT` for `κ₀, γ, τ₀, δ`; and `∂x(L)/∂L = T(L)`,
    /// `∂T(L)/∂L = κ(L) N(L)`. The integrals are Simpson sums on the march's
    /// nodes: the derivatives of the exact curve to `O(h⁴)`, not the exact
    /// derivatives of the discrete end (which differ by as much) — what a
    /// Gauss–Newton step needs, at about 1.4 marches instead of the ten of
    /// central differences.
    ///
    /// `∂x(L)/∂L = T(L)`, and `∂x(L)/∂κ₀` matches a central difference:
    /// ```
    /// use strandfit::{DVec3, FrenetProblem};
    ///
    /// let p = FrenetProblem::new(DVec3::ZERO, DVec3::X, DVec3::Y, 0.7, 0.3, 0.2, -0.1, 2.0);
    /// let (end, d_point, _d_tangent) = p.integrate_with_derivatives_unchecked(256);
    /// assert!((d_point[4] - end.frame[0]).length() < 1e-15);
    /// let h = 1e-5;
    /// let plus = FrenetProblem { kappa0: 0.7 + h, ..p }.integrate_unchecked(256).point;
    /// let minus = FrenetProblem { kappa0: 0.7 - h, ..p }.integrate_unchecked(256).point;
    /// assert!(((plus - minus) / (2.0 * h) - d_point[0]).length() < 1e-7);
    /// ```
    pub fn integrate_with_derivatives_unchecked(
        &self,
        steps: usize,
    ) -> (FrenetEnd, [DVec3; 5], [DVec3; 5]) {
        let steps = steps.max(1);
        let (p1, q1, m) = march_with_moments(self.rates(), steps);
        let end = self.state(p1, q1);
        let l = self.length;
        let (l2, l3) = (l * l, l * l * l);
        let (t1, n1) = (q1 * DVec3::X, q1 * DVec3::Y);
        let dtheta = [l * m.b, l2 * m.ub, l * p1, l2 * m.ut];
        let dx = [
            l2 * (m.b.cross(p1) - m.b_x_p),
            l3 * (m.ub.cross(p1) - m.ub_x_p),
            -l2 * m.t_x_p,
            l3 * (m.ut.cross(p1) - m.ut_x_p),
        ];
        let [f0, f1, f2] = self.frame;
        let world = |v: DVec3| f0 * v.x + f1 * v.y + f2 * v.z;
        let mut d_point = [DVec3::ZERO; 5];
        let mut d_tangent = [DVec3::ZERO; 5];
        for i in 0..4 {
            d_point[i] = world(dx[i]);
            d_tangent[i] = world(dtheta[i].cross(t1));
        }
        d_point[4] = world(t1);
        d_tangent[4] = world(self.curvature(l) * n1);
        (end, d_point, d_tangent)
    }

    /// Point and frame at `s = L` by the paper's integrator (Section 6):
    /// explicit Euler on the Frenet–Serret system with `steps` uniform
    /// steps of `h = L/steps`, no re-orthonormalisation:
    ///
    /// ```text
    /// x += h T,  T += h κ N,  N += h(−κ T + τ B),  B −= h τ N
    /// ```
    ///
    /// (all right-hand sides at the step's start). Kept as the paper's
    /// baseline: it is first order, and the frame drifts off orthonormal by
    /// `O(h Θ)` (ERRATA 004.1: with 100 samples the end point is off by
    /// about 0.075 on a curve of length 2.76). [`integrate`](Self::integrate)
    /// is the default. Errors as for `integrate`.
    ///
    /// First order: on half of the unit circle, twice the steps halve the error
    /// (and the frame is no longer orthonormal):
    /// ```
    /// use strandfit::{DVec3, FrenetProblem};
    /// use std::f64::consts::PI;
    ///
    /// let half = FrenetProblem::new(DVec3::ZERO, DVec3::X, DVec3::Y, 1.0, 0.0, 0.0, 0.0, PI);
    /// let err = |n| (half.integrate_explicit_euler(n).unwrap().point - DVec3::new(0.0, 2.0, 0.0)).length();
    /// let ratio = err(200) / err(100);
    /// assert!((ratio - 0.5).abs() < 0.02, "{ratio}");
    /// assert!((half.integrate_explicit_euler(100).unwrap().frame[0].length() - 1.0).abs() > 1e-3);
    /// ```
    pub fn integrate_explicit_euler(&self, steps: usize) -> Result<FrenetEnd, FrenetError> {
        self.validate()?;
        if steps == 0 {
            return Err(FrenetError::ZeroSteps);
        }
        let h = self.length / steps as f64;
        let (mut x, [mut t, mut n, mut b]) = (self.start, self.frame);
        for k in 0..steps {
            let s = k as f64 * h;
            let (kappa, tau) = (self.curvature(s), self.torsion(s));
            let (dt, dn, db) = (kappa * n, -kappa * t + tau * b, -tau * n);
            x += h * t;
            t += h * dt;
            n += h * dn;
            b += h * db;
        }
        Ok(FrenetEnd {
            point: x,
            frame: [t, n, b],
        })
    }

    /// `m` samples at `s = L j/(m − 1)`, `j = 0..m` (both ends included;
    /// `m = 1` is the start, `m = 0` nothing), with `steps_per_interval`
    /// steps between consecutive samples: one march of
    /// `(m − 1)·steps_per_interval` steps, whose last sample is
    /// [`integrate`](Self::integrate)`((m − 1)·steps_per_interval)`.
    ///
    /// Five samples of half the unit circle, `π/4` apart:
    /// ```
    /// use strandfit::{DVec3, FrenetProblem};
    /// use std::f64::consts::{FRAC_PI_4, PI};
    ///
    /// let half = FrenetProblem::new(DVec3::ZERO, DVec3::X, DVec3::Y, 1.0, 0.0, 0.0, 0.0, PI);
    /// let s = half.sample(5, 64).unwrap();
    /// for (j, e) in s.iter().enumerate() {
    ///     let a = j as f64 * FRAC_PI_4;
    ///     assert!((e.point - DVec3::new(a.sin(), 1.0 - a.cos(), 0.0)).length() < 1e-10);
    /// }
    /// ```
    pub fn sample(
        &self,
        m: usize,
        steps_per_interval: usize,
    ) -> Result<Vec<FrenetEnd>, FrenetError> {
        self.validate()?;
        if steps_per_interval == 0 {
            return Err(FrenetError::ZeroSteps);
        }
        Ok(self.sample_unchecked(m, steps_per_interval))
    }

    /// [`sample`](Self::sample) without validation (`steps_per_interval = 0`
    /// is taken as 1).
    ///
    /// The last sample is the end of one march of `(m − 1)·steps_per_interval` steps:
    /// ```
    /// use strandfit::{DVec3, FrenetProblem};
    ///
    /// let p = FrenetProblem::new(DVec3::ZERO, DVec3::X, DVec3::Y, 0.7, 0.3, 0.2, -0.1, 2.0);
    /// let s = p.sample_unchecked(4, 10);
    /// assert_eq!(s.len(), 4);
    /// assert!((s[3].point - p.integrate_unchecked(30).point).length() < 1e-14);
    /// assert_eq!(p.sample_unchecked(1, 10)[0].point, DVec3::ZERO);
    /// ```
    pub fn sample_unchecked(&self, m: usize, steps_per_interval: usize) -> Vec<FrenetEnd> {
        let every = steps_per_interval.max(1);
        match m {
            0 => Vec::new(),
            1 => vec![self.state(DVec3::ZERO, DQuat::IDENTITY)],
            _ => {
                let mut out = Vec::with_capacity(m);
                out.push(self.state(DVec3::ZERO, DQuat::IDENTITY));
                march(self.rates(), (m - 1) * every, every, &mut |p, q| {
                    out.push(self.state(p, q))
                });
                out
            }
        }
    }

    /// The same spiral traversed backwards from `end` (Prop. 5.2 of paper
    /// 004): start `x(L)`, frame `(−T, N, −B)(L)`, `κ₀ + γL`, `−γ`, `τ₀ + δL`,
    /// `−δ`. Derivation: `y(σ) = x(L − σ)` has `y′ = −T`; with `T̃ = −T`,
    /// `Ñ = N`, `B̃ = T̃ × Ñ = −B` the Frenet equations hold with
    /// `κ̃(σ) = κ(L − σ)` and `τ̃(σ) = τ(L − σ)` (torsion is a property of the
    /// curve, not of its direction). Its end is `x₀` with frame
    /// `(−T₀, N₀, −B₀)`.
    ///
    /// The scheme is self-adjoint: integrating the reversed spiral from the end
    /// returns to the start, with frame `(−T₀, N₀, −B₀)`, even with few steps:
    /// ```
    /// use strandfit::{DVec3, FrenetProblem};
    ///
    /// let p = FrenetProblem::new(DVec3::ZERO, DVec3::X, DVec3::Y, 0.7, 0.3, 0.2, -0.1, 2.0);
    /// let end = p.integrate(8).unwrap();
    /// let back = p.reversed(&end).integrate(8).unwrap();
    /// assert!(back.point.length() < 1e-13);
    /// assert!((back.frame[0] + DVec3::X).length() < 1e-13 && (back.frame[1] - DVec3::Y).length() < 1e-13);
    /// ```
    pub fn reversed(&self, end: &FrenetEnd) -> FrenetProblem {
        let [t, n, b] = end.frame;
        FrenetProblem {
            start: end.point,
            frame: [-t, n, -b],
            kappa0: self.curvature(self.length),
            gamma: -self.gamma,
            tau0: self.torsion(self.length),
            delta: -self.delta,
            length: self.length,
        }
    }

    /// World point and frame from the scaled body offset `p` and rotation `q`.
    fn state(&self, p: DVec3, q: DQuat) -> FrenetEnd {
        let [t0, n0, b0] = self.frame;
        let world = |v: DVec3| t0 * v.x + n0 * v.y + b0 * v.z;
        FrenetEnd {
            point: self.start + self.length * world(p),
            frame: [
                world(q * DVec3::X),
                world(q * DVec3::Y),
                world(q * DVec3::Z),
            ],
        }
    }
}

/// See [`FrenetProblem::max_step_angle`].
pub(crate) fn step_angle_bound(rates: [f64; 4], steps: usize) -> f64 {
    let [k0, g, t0, d] = rates;
    let h = 1.0 / steps.max(1) as f64;
    let c = k0 * d - t0 * g;
    h * (t0.abs().max((t0 + d).abs()) + k0.abs().max((k0 + g).abs())) + h * h * h / 12.0 * c.abs()
}

/// Neumaier's compensated sum of vectors.
#[derive(Default)]
struct CompSum {
    sum: DVec3,
    comp: DVec3,
}

impl CompSum {
    fn add(&mut self, x: DVec3) {
        let mut s = self.sum.to_array();
        let mut c = self.comp.to_array();
        for ((s, c), x) in s.iter_mut().zip(&mut c).zip(x.to_array()) {
            let t = *s + x;
            *c += if s.abs() >= x.abs() {
                (*s - t) + x
            } else {
                (x - t) + *s
            };
            *s = t;
        }
        self.sum = DVec3::from_array(s);
        self.comp = DVec3::from_array(c);
    }

    fn value(&self) -> DVec3 {
        self.sum + self.comp
    }
}

/// The Magnus vector of the scaled problem over `[u_m − len/2, u_m + len/2]`.
#[inline]
fn magnus(rates: [f64; 4], u_m: f64, len: f64) -> DVec3 {
    let [k0, g, t0, d] = rates;
    let c = k0 * d - t0 * g;
    DVec3::new(
        len * (t0 + d * u_m),
        len * len * len / 12.0 * c,
        len * (k0 + g * u_m),
    )
}

/// `r − 1` for the rotation `r = exp(Ω̂)` as a quaternion:
/// `(sin(φ/2)/φ · Ω, cos(φ/2) − 1)`, `φ = |Ω|`, the real part as
/// `−sin²/(1 + cos)` (no cancellation) while `cos φ/2 > 0`.
fn rotation_m1(v: DVec3) -> DQuat {
    let phi = v.length();
    let (s, c) = (0.5 * phi).sin_cos();
    let a = if phi < 1e-4 {
        0.5 * (1.0 - phi * phi / 24.0)
    } else {
        s / phi
    };
    let w = if c > 0.0 {
        -(s * s) / (1.0 + c)
    } else {
        c - 1.0
    };
    DQuat::from_xyzw(a * v.x, a * v.y, a * v.z, w)
}

/// The accumulated rotation `hi + lo` in two words per component; `hi` is
/// the rounded value.
#[derive(Clone, Copy)]
struct TwoQuat {
    hi: DQuat,
    lo: DQuat,
}

impl TwoQuat {
    /// `q ← q r` as `q + q (r − 1)`, the `O(φ)` increment added exactly
    /// (TwoSum, renormalised). Composing `q r` and renormalising instead
    /// rounds `q` by `O(ε)` per rotation, and with small steps those
    /// roundings are correlated, so the frame drifts linearly in `N`; this
    /// way the drift is `O(εφ)` per rotation. `q` is not renormalised (an
    /// exact rotation keeps `|q|`); [`Self::unit`] normalises a copy.
    fn rotate(self, rm1: DQuat) -> TwoQuat {
        let d = (self.hi * rm1).to_array();
        let (mut hi, mut lo) = (self.hi.to_array(), self.lo.to_array());
        for i in 0..4 {
            let (s, x) = (hi[i], d[i]);
            let t = s + x;
            let e = if s.abs() >= x.abs() {
                (s - t) + x
            } else {
                (x - t) + s
            };
            let c = lo[i] + e;
            hi[i] = t + c;
            lo[i] = (t - hi[i]) + c;
        }
        TwoQuat {
            hi: DQuat::from_array(hi),
            lo: DQuat::from_array(lo),
        }
    }

    fn unit(&self) -> DQuat {
        self.hi.normalize()
    }
}

/// March `steps` steps of `h = 1/steps` and call `visit(offset/L, rotation)`
/// (body coordinates of the start frame) after every `every`-th step.
fn march(rates: [f64; 4], steps: usize, every: usize, visit: &mut dyn FnMut(DVec3, DQuat)) {
    let h = 1.0 / steps as f64;
    let mut q = TwoQuat {
        hi: DQuat::IDENTITY,
        lo: DQuat::from_xyzw(0.0, 0.0, 0.0, 0.0),
    };
    let mut t = DVec3::X;
    let mut p = CompSum::default();
    for k in 0..steps {
        let kf = k as f64;
        let mid = q.rotate(rotation_m1(magnus(rates, (kf + 0.25) * h, 0.5 * h)));
        let next = mid.rotate(rotation_m1(magnus(rates, (kf + 0.75) * h, 0.5 * h)));
        let t_mid = mid.unit() * DVec3::X;
        let t_next = next.unit() * DVec3::X;
        p.add(h / 6.0 * (t + 4.0 * t_mid + t_next));
        q = next;
        t = t_next;
        if (k + 1) % every == 0 {
            visit(p.value(), q.unit());
        }
    }
}

/// Simpson moments of the march in [`march_with_moments`], in body
/// coordinates of the start frame (`u = s/L`, `p = (x − x₀)/L`):
/// `∫B`, `∫uB`, `∫uT`, `∫B×p`, `∫uB×p`, `∫T×p`, `∫uT×p` over `[0, 1]`.
struct Moments {
    b: DVec3,
    ub: DVec3,
    ut: DVec3,
    b_x_p: DVec3,
    ub_x_p: DVec3,
    t_x_p: DVec3,
    ut_x_p: DVec3,
}

/// `r − 1` for `r = exp(Ω̂)` as in [`rotation_m1`], by Taylor series
/// while `φ = |Ω| ≤ 1/4` (`sinc` and `cos − 1` of `φ/2` to `x⁸`; the
/// dropped terms are below `ε/4` relative), no square root or `sincos`.
#[inline]
fn rotation_m1_series(v: DVec3) -> DQuat {
    let x2 = 0.25 * v.length_squared();
    if x2 > 1.0 / 64.0 {
        return rotation_m1(v);
    }
    // ½ sinc(x) and cos x − 1, x = φ/2.
    let a = 0.5 * (1.0 - x2 / 6.0 * (1.0 - x2 / 20.0 * (1.0 - x2 / 42.0 * (1.0 - x2 / 72.0))));
    let w =
        -0.5 * x2 * (1.0 - x2 / 12.0 * (1.0 - x2 / 30.0 * (1.0 - x2 / 56.0 * (1.0 - x2 / 90.0))));
    DQuat::from_xyzw(a * v.x, a * v.y, a * v.z, w)
}

/// The columns `T`, `B` of the rotation of a (not necessarily unit)
/// quaternion, divided by `|q|²`.
#[inline]
fn columns_t_b(q: DQuat) -> (DVec3, DVec3) {
    let (x, y, z, w) = (q.x, q.y, q.z, q.w);
    let inv = 1.0 / (x * x + y * y + z * z + w * w);
    let (ww, xx, yy, zz) = (w * w, x * x, y * y, z * z);
    (
        inv * DVec3::new(
            ww + xx - yy - zz,
            2.0 * (x * y + w * z),
            2.0 * (x * z - w * y),
        ),
        inv * DVec3::new(
            2.0 * (x * z + w * y),
            2.0 * (y * z - w * x),
            ww - xx - yy + zz,
        ),
    )
}

/// The march of [`march`] (the same scheme: two Magnus rotations per step,
/// Simpson on the tangents) to the end, organised for speed rather than for
/// the last bits, with the [`Moments`] by Simpson's rule on the same nodes
/// (step ends and midpoints). Against [`march`]: the rotation `r − 1` by
/// series for small angles ([`rotation_m1_series`]), the accumulated
/// quaternion in one word and not renormalised (the frame columns are
/// divided by `|q|²`), the position sum not compensated — rounding
/// `O(Nε)` instead of `O(ε)` per component, `≈ 1e-14` at the few hundred
/// steps a solve uses, far below the truncation error. The offset at a
/// midpoint, which the march does not produce, is the cubic Hermite
/// interpolant of its step (`O(h⁴)`, like the rule).
///
/// Returns the end offset `p(1)`, the end rotation (unit) and the moments.
fn march_with_moments(rates: [f64; 4], steps: usize) -> (DVec3, DQuat, Moments) {
    let h = 1.0 / steps as f64;
    let mut q = DQuat::IDENTITY;
    let mut t = DVec3::X;
    let mut p = DVec3::ZERO;
    // Simpson weights ×6/h: 1 at u = 0 (where B = Z, p = 0, u = 0: only
    // ∫B gets a term), 4 at midpoints, 2 at inner step ends, 1 at u = 1
    // (added with 2 in the loop, one taken back after it).
    let mut m = Moments {
        b: DVec3::Z,
        ub: DVec3::ZERO,
        ut: DVec3::ZERO,
        b_x_p: DVec3::ZERO,
        ub_x_p: DVec3::ZERO,
        t_x_p: DVec3::ZERO,
        ut_x_p: DVec3::ZERO,
    };
    let add = |m: &mut Moments, w: f64, u: f64, t: DVec3, b: DVec3, p: DVec3| {
        let (bp, tp, wu) = (b.cross(p), t.cross(p), w * u);
        m.b += w * b;
        m.ub += wu * b;
        m.ut += wu * t;
        m.b_x_p += w * bp;
        m.ub_x_p += wu * bp;
        m.t_x_p += w * tp;
        m.ut_x_p += wu * tp;
    };
    let mut b_last = DVec3::Z;
    for k in 0..steps {
        let kf = k as f64;
        let mid = q + q * rotation_m1_series(magnus(rates, (kf + 0.25) * h, 0.5 * h));
        let next = mid + mid * rotation_m1_series(magnus(rates, (kf + 0.75) * h, 0.5 * h));
        let (t_mid, b_mid) = columns_t_b(mid);
        let (t_next, b_next) = columns_t_b(next);
        let p_next = p + h / 6.0 * (t + 4.0 * t_mid + t_next);
        let p_mid = 0.5 * (p + p_next) + h / 8.0 * (t - t_next);
        add(&mut m, 4.0, (kf + 0.5) * h, t_mid, b_mid, p_mid);
        add(&mut m, 2.0, (kf + 1.0) * h, t_next, b_next, p_next);
        q = next;
        t = t_next;
        p = p_next;
        b_last = b_next;
    }
    add(&mut m, -1.0, 1.0, t, b_last, p);
    let w = h / 6.0;
    for v in [
        &mut m.b,
        &mut m.ub,
        &mut m.ut,
        &mut m.b_x_p,
        &mut m.ub_x_p,
        &mut m.t_x_p,
        &mut m.ut_x_p,
    ] {
        *v *= w;
    }
    (p, q.normalize(), m)
}

#[cfg(test)]
mod tests {
    /// The paper's explicit Euler against the fourth-order default, both
    /// against a converged reference (the default at 2¹⁴ steps): Euler is
    /// first order (error halves with the step), drifts off unit length,
    /// and at the paper's 100 samples is orders of magnitude worse.
    #[test]
    fn explicit_euler_is_first_order_and_the_default_is_fourth() {
        let p = FrenetProblem::new(
            DVec3::new(0.3, -0.2, 0.1),
            DVec3::X,
            DVec3::Y,
            1.2,
            -0.4,
            0.5,
            0.3,
            2.76,
        );
        let reference = p.integrate(1 << 14).unwrap();
        let err = |e: &FrenetEnd| e.point.distance(reference.point);
        let e100 = err(&p.integrate_explicit_euler(99).unwrap());
        let (e1, e2) = (
            err(&p.integrate_explicit_euler(400).unwrap()),
            err(&p.integrate_explicit_euler(800).unwrap()),
        );
        let order = (e1 / e2).log2();
        assert!((order - 1.0).abs() < 0.1, "Euler order {order}");
        let (m1, m2) = (
            err(&p.integrate(16).unwrap()),
            err(&p.integrate(32).unwrap()),
        );
        let morder = (m1 / m2).log2();
        assert!(morder > 3.5, "default order {morder}");
        let m100 = err(&p.integrate(99).unwrap());
        assert!(
            e100 > 1e-3 && m100 < 1e-7,
            "Euler {e100}, default {m100} at 100 samples"
        );
        // No re-normalisation: |T| grows (each step adds h²κ²|N|² to |T|²).
        let t = p.integrate_explicit_euler(99).unwrap().frame[0].length();
        assert!(t > 1.0 + 1e-3, "|T(L)| = {t}");
        eprintln!("explicit Euler at 100 samples: end point off by {e100:.3e} (default {m100:.1e}), |T| = {t:.5}");
    }

    use super::*;
    use crate::helix::HelixElement;
    use proptest::prelude::*;

    fn frame_from(t: DVec3, n: DVec3) -> [DVec3; 3] {
        let t = t.normalize();
        let n = (n - n.dot(t) * t).normalize();
        [t, n, t.cross(n)]
    }

    fn problem(k0: f64, g: f64, t0: f64, d: f64, l: f64) -> FrenetProblem {
        FrenetProblem {
            start: DVec3::new(3.0, -1.5, 2.25),
            frame: frame_from(DVec3::new(1.0, 2.0, -0.5), DVec3::new(0.3, -0.2, 1.0)),
            kappa0: k0,
            gamma: g,
            tau0: t0,
            delta: d,
            length: l,
        }
    }

    fn frame_dist(a: &[DVec3; 3], b: &[DVec3; 3]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (*x - *y).length())
            .fold(0.0, f64::max)
    }

    fn orthonormality(f: &[DVec3; 3]) -> f64 {
        let mut dev = 0.0f64;
        for i in 0..3 {
            for j in 0..3 {
                let want = if i == j { 1.0 } else { 0.0 };
                dev = dev.max((f[i].dot(f[j]) - want).abs());
            }
        }
        dev.max((f[0].cross(f[1]) - f[2]).length())
    }

    /// `(point error / L, frame error)` against a much finer run.
    fn err_vs(p: &FrenetProblem, steps: usize, truth: &FrenetEnd) -> (f64, f64) {
        let e = p.integrate(steps).unwrap();
        (
            (e.point - truth.point).length() / p.length,
            frame_dist(&e.frame, &truth.frame),
        )
    }

    #[test]
    fn constant_rates_reproduce_the_helix() {
        for (k, tau, l) in [
            (0.8, 0.3, 7.0),
            (2.0, -1.5, 3.0),
            (0.0, 4.0, 2.0),
            (1.0, 0.0, 6.0),
        ] {
            let p = problem(k, 0.0, tau, 0.0, l);
            let e = HelixElement {
                start: p.start,
                tangent: p.frame[0],
                normal: p.frame[1],
                curvature: k,
                torsion: tau,
                length: l,
            };
            let want = e.end_frame();
            let want = [want.tangent, want.normal, want.binormal];
            let mut prev = f64::INFINITY;
            for steps in [16, 32, 64, 128] {
                let got = p.integrate(steps).unwrap();
                // Constant ω: every Magnus step is the exact rotation, so the
                // frame is exact up to rounding at any step count...
                let fe = frame_dist(&got.frame, &want);
                assert!(fe < 1e-14, "{k} {tau}: frame {fe:e}");
                // ...and the position carries Simpson's O(h⁴) error.
                let pe = (got.point - e.end_point()).length() / l;
                assert!(
                    pe < 2e-4 * (16.0 / steps as f64).powi(4) + 1e-15,
                    "{k} {tau} {steps}: {pe:e}"
                );
                if prev > 1e-12 {
                    assert!(
                        pe < prev / 12.0 || pe < 1e-14,
                        "{k} {tau} {steps}: {pe:e} vs {prev:e}"
                    );
                }
                prev = pe;
            }
            let got = p.integrate(2048).unwrap();
            assert!((got.point - e.end_point()).length() < 1e-12 * (1.0 + p.start.length()));
            // Rounding does not drift with the step count (two-word
            // rotation update): 50,000 steps still give the exact frame.
            let got = p.integrate(50_000).unwrap();
            let fe = frame_dist(&got.frame, &want);
            eprintln!("{k} {tau}: frame error after 50,000 steps {fe:e}");
            assert!(fe < 1e-14, "{k} {tau}: frame after 50,000 steps {fe:e}");
        }
    }

    /// `(∫₀ᴸ cos θ, ∫₀ᴸ sin θ)`, `θ = κ₀s + γs²/2`, by composite 5-point
    /// Gauss–Legendre on 4000 panels (error far below 1e-14 here).
    fn clothoid(k0: f64, g: f64, l: f64) -> (f64, f64) {
        const X: [f64; 5] = [
            0.0,
            0.538_469_310_105_683_1,
            -0.538_469_310_105_683_1,
            0.906_179_845_938_664,
            -0.906_179_845_938_664,
        ];
        const W: [f64; 5] = [
            0.568_888_888_888_888_9,
            0.478_628_670_499_366_47,
            0.478_628_670_499_366_47,
            0.236_926_885_056_189_08,
            0.236_926_885_056_189_08,
        ];
        let panels = 4000;
        let w = l / panels as f64;
        let (mut c, mut s) = (0.0, 0.0);
        for i in 0..panels {
            let mid = (i as f64 + 0.5) * w;
            for (x, wt) in X.iter().zip(W) {
                let u = mid + 0.5 * w * x;
                let th = k0 * u + 0.5 * g * u * u;
                c += 0.5 * w * wt * th.cos();
                s += 0.5 * w * wt * th.sin();
            }
        }
        (c, s)
    }

    #[test]
    fn planar_spiral_matches_the_clothoid() {
        for (k0, g, l) in [(0.5, 1.2, 3.0), (2.0, -1.5, 2.5), (0.0, 3.0, 2.0)] {
            let p = problem(k0, g, 0.0, 0.0, l);
            let [t0, n0, b0] = p.frame;
            let (x, y) = clothoid(k0, g, l);
            let want = p.start + x * t0 + y * n0;
            let th = k0 * l + 0.5 * g * l * l;
            let got = p.integrate(3000).unwrap();
            // Stays in the plane (T₀, N₀) and B = B₀ exactly, up to rounding.
            assert!((got.point - p.start).dot(b0).abs() < 1e-14 * l, "planar");
            assert!((got.frame[2] - b0).length() < 1e-14);
            // Frame: the rotation angle is the midpoint rule on a linear κ,
            // i.e. exact.
            let t_want = th.cos() * t0 + th.sin() * n0;
            assert!((got.frame[0] - t_want).length() < 1e-14, "{k0} {g}");
            // Simpson's error ≈ (θ/N)⁴/2880 ≈ 5e-15 here.
            let pe = (got.point - want).length() / l;
            assert!(pe < 1e-13, "{k0} {g}: {pe:e}");
            // Convergence of the position, order 4.
            let e1 = (p.integrate(20).unwrap().point - want).length();
            let e2 = (p.integrate(40).unwrap().point - want).length();
            let order = (e1 / e2).log2();
            assert!((3.7..4.4).contains(&order), "{k0} {g}: order {order}");
        }
    }

    #[test]
    fn convergence_is_fourth_order() {
        // All four rates non-zero, κ crossing zero, about 1.5 turns.
        let p = problem(3.0, -2.5, 1.0, 1.5, 2.0);
        let truth = p.integrate(8192).unwrap();
        let errs: Vec<(f64, f64)> = [16, 32, 64, 128]
            .iter()
            .map(|&n| err_vs(&p, n, &truth))
            .collect();
        for w in errs.windows(2) {
            let op = (w[0].0 / w[1].0).log2();
            let of = (w[0].1 / w[1].1).log2();
            assert!((3.8..4.3).contains(&op), "point order {op}: {errs:?}");
            assert!((3.8..4.3).contains(&of), "frame order {of}: {errs:?}");
        }
        // And the error is small in absolute terms at modest step counts.
        assert!(errs[2].0 < 1e-6 && errs[2].1 < 1e-6, "{errs:?}");
    }

    #[test]
    fn frame_stays_orthonormal() {
        let p = problem(1.3, 0.7, -2.0, 0.4, 30.0);
        for steps in [1, 7, 1000, 20_000] {
            let e = p.integrate(steps).unwrap();
            let d = orthonormality(&e.frame);
            assert!(d < 2e-15, "{steps}: {d:e}");
        }
    }

    #[test]
    fn reversal_returns_to_the_start() {
        let p = problem(2.0, -1.7, 0.6, 1.1, 3.0);
        // Coarse on purpose: the truncation error is ~1e-6 here, but the
        // scheme is self-adjoint, so the round trip is exact up to rounding.
        let steps = 24;
        let fwd = p.integrate(steps).unwrap();
        let back = p.reversed(&fwd).integrate(steps).unwrap();
        let [t0, n0, b0] = p.frame;
        assert!(
            (back.point - p.start).length() < 1e-14 * 4.0,
            "{:e}",
            (back.point - p.start).length()
        );
        assert!(frame_dist(&back.frame, &[-t0, n0, -b0]) < 1e-14);
        // Not trivially: the truncation error is far larger.
        let fine = p.integrate(2048).unwrap();
        assert!((fine.point - fwd.point).length() > 1e-9);
    }

    #[test]
    fn scaling_scales_the_offset() {
        let p = problem(1.2, 0.9, -0.7, 0.5, 2.5);
        let e = p.integrate(64).unwrap();
        for c in [4.0, 3.7, 1e-3, 250.0] {
            let q = FrenetProblem {
                start: DVec3::ZERO,
                kappa0: p.kappa0 / c,
                gamma: p.gamma / (c * c),
                tau0: p.tau0 / c,
                delta: p.delta / (c * c),
                length: c * p.length,
                ..p
            };
            let f = q.integrate(64).unwrap();
            let off = f.point / c - (e.point - p.start);
            assert!(off.length() < 1e-14 * p.length, "{c}: {:e}", off.length());
            assert!(frame_dist(&f.frame, &e.frame) < 1e-14, "{c}");
            if c == 4.0 {
                // powers of two scale exactly
                assert_eq!(f.frame, e.frame);
            }
        }
    }

    /// The one-march derivatives against central differences of a fine
    /// integration, and the end itself `integrate`'s up to rounding.
    #[test]
    fn derivatives_match_central_differences() {
        for base in [
            problem(0.8, 0.3, 0.4, -0.2, 2.5),
            problem(1.5, -1.1, -0.9, 0.6, 3.0),
            problem(0.0, 0.0, 0.0, 0.0, 1.0),
            problem(2.0, 0.0, 3.0, 0.0, 2.0),
        ] {
            let (end, dx, dt) = base.integrate_with_derivatives_unchecked(128);
            let reference = base.integrate_unchecked(128);
            assert!((end.point - reference.point).length() < 1e-13 * base.length.max(1.0));
            assert!(frame_dist(&end.frame, &reference.frame) < 1e-13);
            let fine = 1024;
            for k in 0..5 {
                let h = 1e-5;
                let shifted = |sign: f64| {
                    let mut q = base;
                    match k {
                        0 => q.kappa0 += sign * h,
                        1 => q.gamma += sign * h,
                        2 => q.tau0 += sign * h,
                        3 => q.delta += sign * h,
                        _ => q.length += sign * h,
                    }
                    q.integrate_unchecked(fine)
                };
                let (a, b) = (shifted(1.0), shifted(-1.0));
                let fx = (a.point - b.point) / (2.0 * h);
                let ft = (a.frame[0] - b.frame[0]) / (2.0 * h);
                let scale = 1.0 + fx.length();
                assert!(
                    (fx - dx[k]).length() < 1e-7 * scale,
                    "{base:?} k = {k}: {fx} vs {}",
                    dx[k]
                );
                assert!(
                    (ft - dt[k]).length() < 1e-7 * (1.0 + ft.length()),
                    "{base:?} k = {k}: {ft} vs {}",
                    dt[k]
                );
            }
        }
    }

    #[test]
    fn straight_line_and_zero_length() {
        let p = problem(0.0, 0.0, 0.7, -0.3, 5.0);
        let e = p.integrate(10).unwrap();
        assert!((e.point - (p.start + 5.0 * p.frame[0])).length() < 1e-14);
        assert!((e.frame[0] - p.frame[0]).length() < 1e-15);
        let z = problem(1.0, 2.0, 3.0, 4.0, 0.0).integrate(5).unwrap();
        assert_eq!(z.point, DVec3::new(3.0, -1.5, 2.25));
    }

    #[test]
    fn samples_match_integrate() {
        let p = problem(1.0, -0.6, 0.8, 0.2, 4.0);
        let s = p.sample(9, 6).unwrap();
        assert_eq!(s.len(), 9);
        assert_eq!(s[0].point, p.start);
        assert_eq!(s[0].frame, p.frame);
        assert_eq!(s[8], p.integrate(48).unwrap());
        // Sample j is the end of the spiral cut at L·j/8 (extensibility,
        // Prop. 5.3) with the same step length.
        let cut = FrenetProblem {
            length: p.length * 3.0 / 8.0,
            ..p
        };
        let e = cut.integrate(18).unwrap();
        assert!((e.point - s[3].point).length() < 1e-14);
        assert!(p.sample(0, 3).unwrap().is_empty());
        assert_eq!(p.sample(1, 3).unwrap(), vec![s[0]]);
    }

    #[test]
    fn validation() {
        let ok = problem(1.0, 0.0, 0.0, 0.0, 1.0);
        assert!(ok.validate().is_ok());
        let nan = FrenetProblem {
            kappa0: f64::NAN,
            ..ok
        };
        assert_eq!(nan.integrate(4), Err(FrenetError::NonFinite));
        let overflow = FrenetProblem {
            gamma: 1e300,
            length: 1e10,
            ..ok
        };
        assert_eq!(overflow.validate(), Err(FrenetError::NonFinite));
        let neg = FrenetProblem { length: -1.0, ..ok };
        assert_eq!(neg.integrate(4), Err(FrenetError::NegativeLength(-1.0)));
        let mut skew = ok;
        skew.frame[1] += 1e-6 * skew.frame[0];
        assert!(matches!(
            skew.validate(),
            Err(FrenetError::FrameNotOrthonormal { .. })
        ));
        let mut left = ok;
        left.frame[2] = -left.frame[2];
        assert_eq!(left.validate(), Err(FrenetError::LeftHanded));
        assert_eq!(ok.integrate(0), Err(FrenetError::ZeroSteps));
        assert_eq!(ok.sample(3, 0), Err(FrenetError::ZeroSteps));
        // Unchecked: no panic on garbage.
        let _ = nan.integrate_unchecked(0);
    }

    fn arb_problem() -> impl Strategy<Value = FrenetProblem> {
        (
            (-3.0..3.0f64, -3.0..3.0f64, -3.0..3.0f64),
            (-3.0..3.0f64, -3.0..3.0f64, -3.0..3.0f64),
            (-4.0..4.0f64, -4.0..4.0f64, -4.0..4.0f64, -4.0..4.0f64),
            (0.05..3.0f64, -10.0..10.0f64),
        )
            .prop_filter("frame", |((a, b, c), (d, e, f), _, _)| {
                let t = DVec3::new(*a, *b, *c);
                let n = DVec3::new(*d, *e, *f);
                t.length() > 0.1 && t.cross(n).length() > 0.1 * n.length().max(0.1)
            })
            .prop_map(
                |((a, b, c), (d, e, f), (k0, g, t0, dd), (l, x))| FrenetProblem {
                    start: DVec3::new(x, -x, 0.5 * x),
                    frame: frame_from(DVec3::new(a, b, c), DVec3::new(d, e, f)),
                    kappa0: k0,
                    gamma: g,
                    tau0: t0,
                    delta: dd,
                    length: l,
                },
            )
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn random_problems(p in arb_problem()) {
            let steps = 64;
            let e = p.integrate(steps).unwrap();
            let scale = 1.0 + p.start.length() + p.length;
            // On SO(3), a chord no longer than the arc.
            // The integration adds at most a few ε to the start frame's own
            // defect (a random frame built by Gram–Schmidt from nearly
            // parallel vectors can start 6e-15 off; found by this test).
            let (out, inp) = (orthonormality(&e.frame), orthonormality(&p.frame));
            prop_assert!(out < 4e-15 + inp, "out {out:e}, start frame {inp:e}");
            prop_assert!((e.point - p.start).length() <= p.length * (1.0 + 1e-14));
            // Self-adjoint: the reversed spiral comes back.
            let back = p.reversed(&e).integrate(steps).unwrap();
            let [t0, n0, b0] = p.frame;
            prop_assert!((back.point - p.start).length() < 1e-13 * scale);
            prop_assert!(frame_dist(&back.frame, &[-t0, n0, -b0]) < 1e-13);
            // Converged to the truncation error predicted by the order:
            // the 4× finer run moves the end by ≈ the coarse error itself.
            let fine = p.integrate(4 * steps).unwrap();
            let theta = {
                let [k0, g, t0, d] = p.rates();
                (k0.abs() + 0.5 * g.abs()).hypot(t0.abs() + 0.5 * d.abs())
            };
            let bound = 1e-2 * (theta.max(1.0) / steps as f64).powi(4) * theta.max(1.0).powi(2);
            prop_assert!(
                (fine.point - e.point).length() / p.length < bound + 1e-14,
                "{:e} vs {bound:e}", (fine.point - e.point).length() / p.length
            );
        }
    }
}
