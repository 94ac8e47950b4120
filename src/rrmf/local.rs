//! G1 Hermite interpolation by an RRMF quintic of class I with a one-sided
//! frame condition (Section 4); the method is described on
//! `interpolate_local`.

use glam::{DMat3, DQuat, DVec3};
use std::f64::consts::{FRAC_PI_3, PI};

use super::quat::{bisector, neg_cross, Quat, I};
use super::quintic::PhQuintic;
use super::rmf::{RmfError, RrmfQuintic};

/// Tolerance of the checks on the input (frame orthonormality, condition
/// (4.1), parallel tangents), relative.
pub const INPUT_TOL: f64 = 1e-9;

/// Why the local problem has no solution.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LocalError {
    #[error("an input is not finite")]
    /// An input is not finite.
    NotFinite,
    #[error("the end points coincide")]
    /// The end points coincide.
    Coincident,
    #[error("the initial frame is not orthonormal and right-handed (error {0:.2e})")]
    /// The initial frame is not orthonormal and right-handed (by this error).
    BadFrame(f64),
    #[error("the end tangent is zero")]
    /// The end tangent is zero.
    ZeroTangent,
    #[error("condition (4.1) fails: u_i.du = {left:.6}, du.u_f = {right:.6}")]
    /// Condition (4.1) fails.
    NotSymmetric {
        /// `𝐮ᵢ·𝚫𝐩` (unit chord).
        left: f64,
        /// `𝚫𝐩·𝐮_f`.
        right: f64,
    },
    #[error("the end tangents are parallel or opposite (gamma = {0:.3e} rad); the method needs u_i x u_f != 0")]
    /// The end tangents are parallel or opposite (angle `γ`); the method needs `𝐮ᵢ × 𝐮_f ≠ 0`.
    ParallelTangents(f64),
    #[error("no RRMF5-I interpolant: gamma = {gamma:.4} <= 2pi/5 and the sufficient condition (4.30) fails")]
    /// No RRMF5-I interpolant: `γ ≤ 2π/5` and the sufficient condition (4.30) fails.
    NoSolution {
        /// The angle `γ` between the end tangents.
        gamma: f64,
    },
    #[error("rational RMF: {0}")]
    /// No rational RMF for the interpolant.
    Rmf(#[from] RmfError),
}

/// The solution of one local problem.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalSolution {
    /// The interpolant with its rational RMF.
    pub curve: RrmfQuintic,
    /// `μ` of (4.4) and (4.17).
    pub mu: f64,
    /// `θ₁` (4.13) and `φ₂ = θ₂` in the canonical frame.
    pub theta1: f64,
    /// `φ₂ = θ₂` in the canonical frame.
    pub phi2: f64,
    /// `γ`, the angle between `𝐮ᵢ` and `𝐮_f`.
    pub gamma: f64,
    /// `g(φ₂)` of Section 4.3 (angular length of the spherical control
    /// polygon) for the chosen root.
    pub g: f64,
    /// For `γ < 2π/5`, the other root `φ₂` and its `g` (not chosen: its
    /// `g` is larger).
    pub other_root: Option<(f64, f64)>,
}

/// Pieces of the construction in the canonical frame for one `φ₂`.
struct Config {
    u2: Quat,
    u1: Quat,
    theta1: f64,
    /// `√|𝒰₀⋆𝒰₂|`.
    root_q2: f64,
    /// `𝐈_γ(φ₂)`.
    displacement: DVec3,
}

/// `𝒰₀ = 𝐢`; `û₂ = 𝐛(𝐮_f, 𝐢)` (a pure unit quaternion).
fn configure(u_hat2: Quat, s0: DVec3, s4: DVec3, phi2: f64) -> Option<Config> {
    let u0 = Quat::pure(I);
    let u2 = u_hat2 * Quat::exp(I, phi2);
    let q2 = u0.star(u2);
    let q2_len = q2.length();
    let s2 = q2 / q2_len;
    let u_hat1 = Quat::pure(bisector(I, s2)?);
    // (4.14)
    let x1 = (u0 * Quat::pure(I) * u_hat1.conj() - u_hat1 * Quat::pure(I) * u2.conj()).s;
    let y1 = -(u0 * u_hat1.conj() + u_hat1 * u2.conj()).s;
    let t0 = x1.atan2(y1);
    let sum = u0 + u2;
    let sum_len = sum.norm();
    // (4.11): 𝐬₀₂ = (𝐬₀ + 𝐬₄ + 2 𝒰₀⋆𝒰₂)/|𝒰₀ + 𝒰₂|².
    let s02 = (s0 + s4 + 2.0 * q2) / (sum_len * sum_len);
    let want = bisector(s02, s2);
    // (4.13) and (4.15): of θ₁ and θ₁ + π, the one whose 𝐬_m (4.10) is
    // 𝐛(𝐬₀₂, 𝐬₂) (they give opposite 𝐬_m).
    let mut best = None;
    for theta1 in [t0, t0 + PI] {
        let u1 = u_hat1 * Quat::exp(I, theta1);
        let sm = (sum * Quat::pure(I) * u1.conj()).v / sum_len;
        let score = want.map_or(0.0, |w| sm.dot(w));
        if best.as_ref().is_none_or(|(s, _, _)| score > *s) {
            best = Some((score, theta1, u1));
        }
    }
    let (_, theta1, u1) = best?;
    let root_q2 = q2_len.sqrt();
    // (4.18)–(4.19): 𝐪₁ + 𝐪₂ + 𝐪₃.
    let displacement = (s0 + s4) + q2 + root_q2 * sum.star(u1);
    Some(Config {
        u2,
        u1,
        theta1,
        root_q2,
        displacement,
    })
}

/// `g(φ₂) = Σ arccos(𝐬ᵢ·𝐬ᵢ₊₁)` of the spherical control points (Section 4.3).
fn g_functional(cfg: &Config) -> f64 {
    let pre = [Quat::pure(I), cfg.u1 * cfg.root_q2, cfg.u2];
    let c = PhQuintic::new(DVec3::ZERO, pre);
    let s = c.hodograph_control_points().map(|h| h.normalize());
    (0..4)
        .map(|i| s[i].dot(s[i + 1]).clamp(-1.0, 1.0).acos())
        .sum()
}

/// The unit PH displacement `𝐒_γ(φ₂) = 𝐈_γ/|𝐈_γ|` (4.26) for end tangents
/// `u_i`, `u_f` (unit), in world coordinates: what the spline's tangent
/// selection (5.4) tests through condition (4.30) at `φ₂ = 2π/3`. `None`
/// for parallel tangents or a vanishing `𝐈_γ`.
///
/// At the solved `φ₂` of [`interpolate_local`] it is the chord direction `𝚫𝐮`
/// (here the data of its example):
/// ```
/// use strandfit::rrmf::{interpolate_local, unit_displacement};
/// use strandfit::DVec3;
///
/// let (p_f, u_f) = (DVec3::new(1.0, 1.0, 0.0), DVec3::new(0.5, 0.5, -0.5f64.sqrt()));
/// let sol = interpolate_local(DVec3::ZERO, [DVec3::X, DVec3::Y, DVec3::Z], p_f, u_f).unwrap();
/// let s = unit_displacement(DVec3::X, u_f, sol.phi2).unwrap();
/// assert!((s - p_f.normalize()).length() < 1e-9);
/// ```
pub fn unit_displacement(u_i: DVec3, u_f: DVec3, phi2: f64) -> Option<DVec3> {
    // Any rotation taking u_i to 𝐢 will do: the construction is covariant
    // under rotations about 𝐢 (Remark 3.6).
    let rot = DQuat::from_rotation_arc(u_i, I);
    let s4 = rot * u_f;
    let b = bisector(I, s4)?;
    neg_cross(I, s4)?;
    let cfg = configure(Quat::pure(b), I, s4, phi2)?;
    let d = cfg.displacement.try_normalize()?;
    Some(rot.inverse() * d)
}

/// G1 Hermite interpolation by an RRMF quintic of class I with a one-sided
/// frame condition (Section 4): from `𝐩ᵢ` with frame `(𝐮ᵢ, 𝐯ᵢ, 𝐰ᵢ)` to `𝐩_f`
/// with tangent direction `𝐮_f`, given the symmetry condition (4.1)
/// `𝐮ᵢ·𝚫𝐮 = 𝚫𝐮·𝐮_f` (see [Method](interpolate_local#method)).
///
/// From the origin with frame `(x, y, z)` to `(1, 1, 0)` with tangent `x`
/// turned by `π/2` about the chord (so that `𝐮ᵢ·𝚫𝐮 = 𝚫𝐮·𝐮_f`, (4.1)): the
/// quintic meets the data, and its frame starts as given and is rotation
/// minimising:
/// ```
/// use strandfit::rrmf::interpolate_local;
/// use strandfit::DVec3;
///
/// let frame = [DVec3::X, DVec3::Y, DVec3::Z];
/// let (p_f, u_f) = (DVec3::new(1.0, 1.0, 0.0), DVec3::new(0.5, 0.5, -0.5f64.sqrt()));
/// let c = interpolate_local(DVec3::ZERO, frame, p_f, u_f).unwrap().curve;
/// assert!((c.curve.position(1.0) - p_f).length() < 1e-12 && (c.curve.tangent(1.0) - u_f).length() < 1e-12);
/// assert!((0..3).all(|k| (c.frame(0.0)[k] - frame[k]).length() < 1e-12));
/// assert!(c.rmf_residual(0.5) < 1e-12);
/// ```
///
/// # Method
///
/// **Canonical frame.** The paper's `𝐢` is any unit vector; its Section 4.2
/// takes `𝐢 = 𝐮ᵢ`, `𝐣 = −𝐯ᵢ`, `𝐤 = −𝐰ᵢ`, where (4.6) gives `α₀ = 0` and
/// `𝒰₀ = 𝐢`. We solve there and rotate the pre-image back (`𝒜 ↦ 𝒬𝒜` turns
/// the hodograph `𝒜𝐢𝒜*` and the frame `𝒜𝒲𝐞𝒲*𝒜*` by `𝒬`): the choices
/// of the method — (4.15) for `θ₁`, `𝐒_γ(φ₂) = 𝚫𝐮` for `φ₂`, the `g`
/// functional — are geometric, so the result is the same in every frame,
/// and the assumptions `𝐢 ≠ −𝐮ᵢ`, `𝐢 ≠ −𝐮_f` of (4.5) hold by construction.
/// In this frame `φ₂ = θ₂` (Eq. 4.22).
///
/// **Steps.** `𝒰₂(θ₂) = 𝐛(𝐮_f, 𝐢) e^{θ₂𝐢}` (4.5); `𝐬₂ = 𝒰₀⋆𝒰₂/|𝒰₀⋆𝒰₂|`
/// (4.8); `𝒰₁ = 𝐛(𝐢, 𝐬₂) e^{θ₁𝐢}` with `θ₁ = atan2(x₁, y₁)` or `+π` (4.13,
/// 4.14), the one with `𝐬_m = 𝐛(𝐬₀₂, 𝐬₂)` (4.15); the scaled displacement
/// `𝐈_γ = 𝐪₁ + 𝐪₂ + 𝐪₃` (4.18); `φ₂` by bisection on
/// `f(φ₂) = (𝐒_γ(φ₂) − 𝚫𝐮)·𝐛` (4.31) in the regime of `γ` (Section 4.3:
/// `[0, π]` for `γ > 2π/5`; `[0, 2π/3]` for `γ = 2π/5`; both `[0, 2π/3]` and
/// `[2π/3, π]` for `γ < 2π/5`, keeping the root with the smaller `g`), on
/// the side given by the sign of `𝚫𝐮·𝐧`; then `μ = √(5|𝚫𝐩|/|𝐈_γ|)` (4.17)
/// and `𝒜₀ = μ𝒰₀`, `𝒜₁ = μ√|𝒰₀⋆𝒰₂| 𝒰₁`, `𝒜₂ = μ𝒰₂`.
pub fn interpolate_local(
    p_i: DVec3,
    frame: [DVec3; 3],
    p_f: DVec3,
    u_f: DVec3,
) -> Result<LocalSolution, LocalError> {
    let [u_i, v_i, w_i] = frame;
    let finite = p_i.is_finite() && p_f.is_finite() && u_f.is_finite();
    if !(finite && frame.iter().all(|v| v.is_finite())) {
        return Err(LocalError::NotFinite);
    }
    let dp = p_f - p_i;
    let dist = dp.length();
    if dist == 0.0 {
        return Err(LocalError::Coincident);
    }
    let frame_err = [
        (u_i.length() - 1.0).abs(),
        (v_i.length() - 1.0).abs(),
        u_i.dot(v_i).abs(),
        (u_i.cross(v_i) - w_i).length(),
    ]
    .into_iter()
    .fold(0.0f64, f64::max);
    if frame_err > INPUT_TOL {
        return Err(LocalError::BadFrame(frame_err));
    }
    let u_f = u_f.try_normalize().ok_or(LocalError::ZeroTangent)?;
    let du = dp / dist;
    let (left, right) = (u_i.dot(du), du.dot(u_f));
    if (left - right).abs() > INPUT_TOL {
        return Err(LocalError::NotSymmetric { left, right });
    }
    let gamma = u_i.dot(u_f).clamp(-1.0, 1.0).acos();
    if u_i.cross(u_f).length() <= INPUT_TOL {
        return Err(LocalError::ParallelTangents(gamma));
    }
    // World ← canonical: columns 𝐮ᵢ, −𝐯ᵢ, −𝐰ᵢ.
    let rot = DQuat::from_mat3(&DMat3::from_cols(u_i, -v_i, -w_i)).normalize();
    let to_local = rot.inverse();
    let s0 = I;
    let s4 = to_local * u_f;
    let du_l = to_local * du;
    let b = bisector(s0, s4).ok_or(LocalError::ParallelTangents(gamma))?;
    let n = neg_cross(s0, s4).ok_or(LocalError::ParallelTangents(gamma))?;
    let u_hat2 = Quat::pure(b);
    // Work on the side Δu·n ≥ 0 (Proposition 4.2 and the symmetry
    // S(2π − φ)·n = −S(φ)·n), then mirror φ₂.
    let side = if du_l.dot(n) < 0.0 { -1.0 } else { 1.0 };
    let cfg_at = |phi: f64| configure(u_hat2, s0, s4, side * phi);
    // f(φ₂) of (4.31), (𝐒_γ − 𝚫𝐮)·𝐛, compares the two unit vectors of the
    // circle 𝒞(𝐬₀, 𝐬₄) by their 𝐛 components; on the working side both
    // have 𝐧 components ≥ 0 (Proposition 4.2), so the same sign and the same
    // roots come from their angles from 𝐛, which stay well conditioned
    // where 𝐒_γ is near ±𝐛 (the 𝐛 component is flat there, and the root
    // would carry only half the digits).
    let angle = |v: DVec3| v.dot(n).abs().atan2(v.dot(b));
    let target = angle(du_l);
    let f = |phi: f64| -> Option<f64> {
        let c = cfg_at(phi)?;
        Some(target - angle(c.displacement))
    };
    // Section 4.3's bisection, accelerated: the Illinois variant of regula
    // falsi keeps the sign-changing bracket (so it finds the same root) but
    // needs about 10 evaluations instead of 53; every fourth step is a plain
    // halving, so the bracket shrinks at least as fast as bisection's.
    let bisect = |lo: f64, hi: f64| -> Option<f64> {
        let (mut a, mut b) = (lo, hi);
        let (mut fa, mut fb) = (f(a)?, f(b)?);
        if fa == 0.0 {
            return Some(a);
        }
        if fb == 0.0 {
            return Some(b);
        }
        if fa.signum() == fb.signum() {
            return None;
        }
        let mut kept = 0i32; // which end was kept last time: −1 a, +1 b
        for step in 0..200 {
            if (b - a).abs() <= 4.0 * f64::EPSILON * a.abs().max(b.abs()).max(1.0) {
                break;
            }
            let mut c = if step % 4 == 3 {
                0.5 * (a + b)
            } else {
                (a * fb - b * fa) / (fb - fa)
            };
            if !(c > a.min(b) && c < a.max(b)) {
                c = 0.5 * (a + b);
            }
            let fc = f(c)?;
            if fc == 0.0 {
                return Some(c);
            }
            if fc.signum() == fb.signum() {
                // b moves; a is kept: halve its weight if kept twice.
                b = c;
                fb = fc;
                if kept == -1 {
                    fa *= 0.5;
                }
                kept = -1;
            } else {
                a = c;
                fa = fc;
                if kept == 1 {
                    fb *= 0.5;
                }
                kept = 1;
            }
        }
        Some(if fa.abs() < fb.abs() { a } else { b })
    };
    let two_pi_5 = 0.4 * PI;
    let mut other_root = None;
    let phi = if (du_l - b).length() <= INPUT_TOL {
        // 𝐒_γ(0) = 𝐛 (Proposition 4.1).
        Some(0.0)
    } else if gamma > two_pi_5 + INPUT_TOL {
        bisect(0.0, PI)
    } else {
        // (4.30): f(2π/3) < 0 is needed; with it, [0, 2π/3] (γ = 2π/5) or
        // both [0, 2π/3] and [2π/3, π] (γ < 2π/5), the better by g.
        match f(2.0 * FRAC_PI_3) {
            Some(v) if v < 0.0 => {
                let first = bisect(0.0, 2.0 * FRAC_PI_3);
                let second = if gamma < two_pi_5 - INPUT_TOL {
                    bisect(2.0 * FRAC_PI_3, PI)
                } else {
                    None
                };
                match (first, second) {
                    (Some(a), Some(c)) => {
                        let ga = cfg_at(a).map_or(f64::INFINITY, |k| g_functional(&k));
                        let gc = cfg_at(c).map_or(f64::INFINITY, |k| g_functional(&k));
                        if gc < ga {
                            other_root = Some((side * a, ga));
                            Some(c)
                        } else {
                            other_root = Some((side * c, gc));
                            Some(a)
                        }
                    }
                    (a, c) => a.or(c),
                }
            }
            _ => return Err(LocalError::NoSolution { gamma }),
        }
    };
    let phi = phi.ok_or(LocalError::NoSolution { gamma })?;
    let cfg = cfg_at(phi).ok_or(LocalError::NoSolution { gamma })?;
    let i_len = cfg.displacement.length();
    let mu = (5.0 * dist / i_len).sqrt();
    let q = Quat::new(rot.w, DVec3::new(rot.x, rot.y, rot.z));
    let pre = [
        q * Quat::pure(I) * mu,
        q * cfg.u1 * (mu * cfg.root_q2),
        q * cfg.u2 * mu,
    ];
    let curve = RrmfQuintic::new(PhQuintic::new(p_i, pre))?;
    Ok(LocalSolution {
        curve,
        mu,
        theta1: cfg.theta1,
        phi2: side * phi,
        gamma,
        g: g_functional(&cfg),
        other_root,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Data satisfying (4.1): 𝐮_f is 𝐮ᵢ turned about 𝚫𝐮 by `turn`.
    fn data(p_i: DVec3, frame: [DVec3; 3], dp: DVec3, turn: f64) -> (DVec3, DVec3) {
        let du = dp.normalize();
        let u_f = DQuat::from_axis_angle(du, turn) * frame[0];
        (p_i + dp, u_f)
    }

    fn frame_from(u: DVec3, hint: DVec3) -> [DVec3; 3] {
        let u = u.normalize();
        let v = (hint - hint.dot(u) * u).normalize();
        [u, v, u.cross(v)]
    }

    /// The curve's size: rounding in the control points is relative to it.
    /// Near `γ = 2π/5, φ₂ = π`, where `𝐈_γ` vanishes (Proposition 4.3),
    /// the curve can be 10⁴ chords long; its end is then exact to `ε` of
    /// that, not of the chord.
    fn size(c: &PhQuintic) -> f64 {
        let r = c.control_points();
        r.iter().map(|p| (*p - r[0]).length()).fold(0.0, f64::max)
    }

    fn check(sol: &LocalSolution, p_i: DVec3, frame: [DVec3; 3], p_f: DVec3, u_f: DVec3) {
        let c = &sol.curve;
        let scale = size(&c.curve);
        assert!((c.curve.position(0.0) - p_i).length() <= 1e-12 * scale);
        assert!(
            (c.curve.position(1.0) - p_f).length() <= 1e-12 * scale,
            "{:e}",
            (c.curve.position(1.0) - p_f).length()
        );
        assert!((c.curve.tangent(1.0) - u_f.normalize()).length() < 1e-12);
        let f0 = c.frame(0.0);
        for k in 0..3 {
            assert!(
                (f0[k] - frame[k]).length() < 1e-12,
                "{k}: {:?} vs {:?}",
                f0[k],
                frame[k]
            );
        }
        assert!(c.curve.class_one_residual() < 1e-12);
        // (4.4): r′(0) = μ²𝐮ᵢ and r′(1) = μ²𝐮_f.
        let mu2 = sol.mu * sol.mu;
        assert!((c.curve.hodograph(0.0) - mu2 * frame[0]).length() < 1e-12 * mu2);
        assert!((c.curve.hodograph(1.0) - mu2 * u_f.normalize()).length() < 1e-12 * mu2);
        for i in 0..=20 {
            let t = i as f64 / 20.0;
            assert!(
                c.rmf_residual(t) < 1e-12,
                "{:e} at {t}, length/chord {}, gamma {}, phi2 {}",
                c.rmf_residual(t),
                c.curve.length() / (p_f - p_i).length(),
                sol.gamma,
                sol.phi2
            );
        }
    }

    #[test]
    fn regimes_of_gamma() {
        let p_i = DVec3::new(1.0, 2.0, 3.0);
        let frame = frame_from(DVec3::new(1.0, 0.2, -0.1), DVec3::Z);
        let (mut below, mut at, mut above, mut two_roots) = (0, 0, 0, 0);
        let cases = [0.2f64, 0.35 * PI, 0.4 * PI, 0.6 * PI, 0.9 * PI];
        for (tau, gamma, sign) in [0.3f64, 0.45, 0.64, 0.7, 0.8, 1.2]
            .iter()
            .flat_map(|&t| cases.iter().flat_map(move |&g| [(t, g, 1.0), (t, g, -1.0)]))
        {
            let dp = 2.5 * (tau.cos() * frame[0] + tau.sin() * frame[1]);
            // γ from the turn β about 𝚫𝐮: cos γ = cos²τ + sin²τ cos β.
            let c = (gamma.cos() - tau.cos().powi(2)) / tau.sin().powi(2);
            if !(-1.0..=1.0).contains(&c) {
                continue; // beyond γ_max of (5.2): no turn reaches it
            }
            let turn = c.acos();
            let (p_f, u_f) = data(p_i, frame, dp, sign * turn);
            let Ok(sol) = interpolate_local(p_i, frame, p_f, u_f) else {
                // Only γ ≤ 2π/5 may fail, when (4.30) does not hold.
                assert!(gamma <= 0.4 * PI + 1e-9, "{gamma}");
                continue;
            };
            assert!((sol.gamma - gamma).abs() < 1e-9, "{} {gamma}", sol.gamma);
            check(&sol, p_i, frame, p_f, u_f);
            if (gamma - 0.4 * PI).abs() < 1e-12 {
                at += 1;
                // [0, 2π/3] only (Section 4.3).
                assert!(sol.phi2.abs() <= 2.0 * FRAC_PI_3 + 1e-12);
            } else if gamma < 0.4 * PI {
                below += 1;
                // Two roots, one in each bracket; the kept one has the
                // smaller g, and the other interpolates too.
                if let Some((phi, g)) = sol.other_root {
                    two_roots += 1;
                    assert!(sol.g <= g, "{} > {g}", sol.g);
                    assert!(
                        (phi.abs() - 2.0 * FRAC_PI_3).signum()
                            != (sol.phi2.abs() - 2.0 * FRAC_PI_3).signum()
                    );
                }
            } else {
                above += 1;
                assert!(sol.other_root.is_none());
            }
        }
        assert!(
            below >= 1 && at >= 1 && above >= 1 && two_roots >= 1,
            "{below} {at} {above} {two_roots}"
        );
    }

    #[test]
    fn bad_input() {
        let frame = frame_from(DVec3::X, DVec3::Y);
        let p = DVec3::ZERO;
        assert_eq!(
            interpolate_local(p, frame, p, DVec3::Y),
            Err(LocalError::Coincident)
        );
        // (4.1) violated.
        assert!(matches!(
            interpolate_local(p, frame, DVec3::new(1.0, 1.0, 0.0), DVec3::Z),
            Err(LocalError::NotSymmetric { .. })
        ));
        // Not a frame.
        let bad = [DVec3::X, DVec3::X, DVec3::Z];
        assert!(matches!(
            interpolate_local(p, bad, DVec3::ONE, DVec3::Y),
            Err(LocalError::BadFrame(_))
        ));
        assert_eq!(
            interpolate_local(p, frame, DVec3::new(f64::NAN, 0.0, 0.0), DVec3::Y),
            Err(LocalError::NotFinite)
        );
        // Same tangent (u_f = u_i; (4.1) holds trivially).
        assert!(matches!(
            interpolate_local(p, frame, DVec3::new(1.0, 1.0, 0.0), DVec3::X),
            Err(LocalError::ParallelTangents(_))
        ));
    }

    proptest! {
        #[test]
        fn round_trip_and_rotation_invariance(
            dp in prop::array::uniform3(-3.0f64..3.0),
            u in prop::array::uniform3(-1.0f64..1.0),
            hint in prop::array::uniform3(-1.0f64..1.0),
            turn in 0.2f64..3.0,
            sign in prop::bool::ANY,
            axis in prop::array::uniform3(-1.0f64..1.0),
            angle in -3.0f64..3.0,
        ) {
            let (dp, u, hint, axis) = (DVec3::from(dp), DVec3::from(u), DVec3::from(hint), DVec3::from(axis));
            prop_assume!(dp.length() > 0.1 && u.length() > 0.1 && axis.length() > 0.1);
            prop_assume!(u.normalize().cross(hint).length() > 0.1);
            let frame = frame_from(u, hint);
            let turn = if sign { turn } else { -turn };
            let p_i = DVec3::new(0.5, -1.0, 2.0);
            let (p_f, u_f) = data(p_i, frame, dp, turn);
            // Keep away from parallel tangents (tiny γ).
            prop_assume!(frame[0].angle_between(u_f) > 0.05);
            let sol = interpolate_local(p_i, frame, p_f, u_f);
            if let Ok(sol) = sol {
                check(&sol, p_i, frame, p_f, u_f);
                // Rotating the data rotates the solution.
                let r = DQuat::from_axis_angle(axis.normalize(), angle);
                let rf = frame.map(|v| r * v);
                let other = interpolate_local(r * p_i, rf, r * p_f, r * u_f).unwrap();
                for i in 0..=8 {
                    let t = i as f64 / 8.0;
                    let a = r * sol.curve.curve.position(t);
                    let b = other.curve.curve.position(t);
                    prop_assert!((a - b).length() < 1e-9 * size(&sol.curve.curve), "{a} {b}");
                    let fa = sol.curve.frame(t).map(|v| r * v);
                    let fb = other.curve.frame(t);
                    prop_assert!((fa[1] - fb[1]).length() < 1e-9);
                }
            } else {
                // Only where the paper allows it: γ ≤ 2π/5 without (4.30).
                let e = sol.unwrap_err();
                prop_assert!(matches!(e, LocalError::NoSolution { .. }), "{e}");
                prop_assert!(frame[0].angle_between(u_f) <= 0.4 * PI + 1e-9);
            }
        }
    }
}
