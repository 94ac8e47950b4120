//! A helical element: the helix that leaves `start` along a unit `tangent`,
//! ends at `end`, and climbs at a given pitch angle `ψ` about its axis
//! (not yet part of the container format: the codec's elements are the
//! `ψ = 0` members, the circular arcs of [`super::predict::Arc`]).
//!
//! Why: on smooth curls a chain of circular arcs can only follow a helix
//! for a short stretch (a circle leaves a helix of curvature `κ` and
//! torsion `τ` by about `κτℓ³/6` over a length `ℓ`), so a hair strand at
//! 0.5 mm takes about 15 arcs, most of the file's bytes. An element with
//! its own pitch costs one number more; a greedy covering of the shared
//! hair (`benches/helix_reach.py`, elements ending on input vertices, 20
//! strands of each kind, within 0.6 / 0.9 of T = 0.5 mm) needs 0.60 / 0.67
//! as many of them as arcs on the gently drooping strands, 0.61 / 0.70 on
//! the wavy ones and 0.76 / 0.55 on the curly ones (the fornix at 0.5 mm:
//! 0.81–0.84).
//!
//! **Geometry.** In the helix's frame (`t₀`, the principal normal `n₀` and
//! the binormal `b₀ = t₀ × n₀` at the start), with `c = cos ψ`,
//! `s = sin ψ` and `ρ` the radius of the Darboux rotation (`κ = c/ρ`,
//! `τ = s/ρ`), the point after turning `θ` about the axis (arc length `ρθ`)
//! is
//!
//! ```text
//! p(θ) − p₀ = ρ [ N(θ) t₀ + c A(θ) n₀ + c s B(θ) b₀ ],
//! N = c² sin θ + s² θ,   A = 1 − cos θ = 2 sin²(θ/2),   B = θ − sin θ,
//! ```
//!
//! and its tangent `t(θ) = (1 − c²A) t₀ + c sin θ n₀ + c s A b₀`. Given the
//! chord `d = end − start`, the angle `γ` between `t₀` and `d` fixes the turn
//! `Θ`: `γ = G(Θ) = atan2(c √(A² + s²B²), N)`, which rises from 0 (as
//! `Θ/2` for a circle) up to a turn beyond `4` rad for every `ψ`; the
//! element is kept to `Θ ≤ π` (`ψ ≠ 0`; a circle, `ψ = 0`, to the arcs'
//! 0.95 of a full turn) and `Θ` is found by Newton's method inside a
//! bisection bracket. Then `ρ = |d| / √(N² + c²(A² + s²B²))`, and `n₀` is
//! the chord's direction across `t₀` turned back by `β = atan2(sB, A)`.
//! Everything is `+ − × ÷ √`, `sin`, `cos` and `atan2` in a fixed order,
//! so an encoder and a decoder that run this code agree.
//!
//! (An example: `a_quarter_turn_of_a_known_helix` in the tests.)

use glam::DVec3;

use super::predict::{any_perpendicular, ArcError, MAX_HALF_TURN};

/// One helical element ([module docs](self)).
#[derive(Clone, Copy, Debug)]
pub struct HelicalArc {
    start: DVec3,
    end: DVec3,
    /// `t₀`, `n₀`, `b₀`.
    frame: [DVec3; 3],
    /// `cos ψ`, `sin ψ`.
    cos_psi: f64,
    sin_psi: f64,
    /// `ρ`: `1/√(κ² + τ²)` (infinite for a straight element).
    rho: f64,
    /// `Θ`, the turn about the axis (0 for a straight element).
    turn: f64,
    /// For a straight element, its length.
    straight: f64,
}

/// `θ − sin θ`, without the cancellation of the difference for small `θ`.
fn theta_minus_sin(t: f64) -> f64 {
    if t.abs() < 1.0 {
        // The series to θ²¹ (the next term is below 1e-19 of the sum).
        let t2 = t * t;
        let mut r = 1.0;
        for d in [420.0, 342.0, 272.0, 210.0, 156.0, 110.0, 72.0, 42.0, 20.0] {
            r = 1.0 - t2 / d * r;
        }
        t * t2 / 6.0 * r
    } else {
        t - t.sin()
    }
}

/// `(N, √(A² + s²B²), A, B)` at turn `t` for `(c, s) = (cos ψ, sin ψ)`.
fn parts(t: f64, c: f64, s: f64) -> (f64, f64, f64, f64) {
    let h = (0.5 * t).sin();
    let a = 2.0 * h * h;
    let b = theta_minus_sin(t);
    let n = c * c * t.sin() + s * s * t;
    (n, (a * a + s * s * b * b).sqrt(), a, b)
}

/// `G(θ) = atan2(c√(A² + s²B²), N)`, the angle between the start tangent and
/// the chord after a turn `θ`, and its derivative.
fn chord_angle(t: f64, c: f64, s: f64) -> (f64, f64) {
    let (n, q, a, b) = parts(t, c, s);
    let (x, y) = (n, c * q);
    let dx = c * c * t.cos() + s * s;
    // d√Q/dθ = (A A' + s² B B')/√Q with A' = sin θ, B' = A.
    let dq = if q > 0.0 {
        (a * t.sin() + s * s * b * a) / q
    } else {
        0.0
    };
    let dy = c * dq;
    let r2 = x * x + y * y;
    let g = y.atan2(x);
    let dg = if r2 > 0.0 {
        (x * dy - y * dx) / r2
    } else {
        0.5
    };
    (g, dg)
}

impl HelicalArc {
    /// The largest turn about the axis of a pitched element: `G` rises
    /// monotonically to beyond 4 rad for every `ψ` (checked in the tests).
    pub const MAX_TURN: f64 = std::f64::consts::PI;

    /// The helix from `start` along the unit `tangent` to `end` at pitch
    /// angle `psi` (`|ψ| < π/2`; positive: right-handed about the axis).
    ///
    /// Errors: not finite ([`ArcError::NonFinite`], also `|ψ| ≥ π/2`),
    /// `end == start` ([`ArcError::ZeroChord`]), or a chord that no turn
    /// within the limit reaches ([`ArcError::Backwards`]).
    pub fn new(start: DVec3, tangent: DVec3, end: DVec3, psi: f64) -> Result<Self, ArcError> {
        let d = end - start;
        let chord = d.length();
        if !(chord.is_finite() && tangent.is_finite() && psi.is_finite())
            || psi.abs() >= std::f64::consts::FRAC_PI_2
        {
            return Err(ArcError::NonFinite);
        }
        if chord == 0.0 {
            return Err(ArcError::ZeroChord);
        }
        let (s, c) = psi.sin_cos();
        let along = d.dot(tangent);
        let across = d - tangent * along;
        let m = across.length();
        let gamma = m.atan2(along);
        if gamma < 1e-12 {
            return Ok(HelicalArc {
                start,
                end,
                frame: [tangent, any_perpendicular(tangent), DVec3::ZERO],
                cos_psi: c,
                sin_psi: s,
                rho: f64::INFINITY,
                turn: 0.0,
                straight: chord,
            });
        }
        let limit = if psi == 0.0 {
            2.0 * MAX_HALF_TURN
        } else {
            Self::MAX_TURN
        };
        if gamma > chord_angle(limit, c, s).0 {
            return Err(ArcError::Backwards);
        }
        let turn = solve_turn(gamma, c, s, limit);
        let (n, q, a, b) = parts(turn, c, s);
        let rho = chord / (n * n + c * c * q * q).sqrt();
        // The chord's direction across the tangent is n₀ turned by β
        // towards b₀: turn it back.
        let u = across / m;
        let w = tangent.cross(u);
        let beta = (s * b).atan2(a);
        let (sb, cb) = beta.sin_cos();
        let n0 = u * cb - w * sb;
        let b0 = tangent.cross(n0);
        Ok(HelicalArc {
            start,
            end,
            frame: [tangent, n0, b0],
            cos_psi: c,
            sin_psi: s,
            rho,
            turn,
            straight: 0.0,
        })
    }

    /// Curvature `κ = cos ψ / ρ`.
    pub fn curvature(&self) -> f64 {
        if self.turn == 0.0 {
            0.0
        } else {
            self.cos_psi / self.rho
        }
    }

    /// Torsion `τ = sin ψ / ρ`.
    pub fn torsion(&self) -> f64 {
        if self.turn == 0.0 {
            0.0
        } else {
            self.sin_psi / self.rho
        }
    }

    /// Arc length `ρΘ`.
    pub fn length(&self) -> f64 {
        if self.turn == 0.0 {
            self.straight
        } else {
            self.rho * self.turn
        }
    }

    /// Turn `Θ` about the helix's axis.
    pub fn turn(&self) -> f64 {
        self.turn
    }

    /// Point at arc length `σ` from the start.
    pub fn point_at(&self, sigma: f64) -> DVec3 {
        let [t0, n0, b0] = self.frame;
        if self.turn == 0.0 {
            return self.start + t0 * sigma;
        }
        let (c, s) = (self.cos_psi, self.sin_psi);
        let th = sigma / self.rho;
        let (n, _, a, b) = parts(th, c, s);
        self.start + (t0 * n + n0 * (c * a) + b0 * (c * s * b)) * self.rho
    }

    /// Unit tangent at arc length `σ`.
    pub fn tangent_at(&self, sigma: f64) -> DVec3 {
        let [t0, n0, b0] = self.frame;
        if self.turn == 0.0 {
            return t0;
        }
        let (c, s) = (self.cos_psi, self.sin_psi);
        let th = sigma / self.rho;
        let h = (0.5 * th).sin();
        let a = 2.0 * h * h;
        (t0 * (1.0 - c * c * a) + n0 * (c * th.sin()) + b0 * (c * s * a)).normalize()
    }

    /// Unit principal normal at arc length `σ` (any perpendicular of the
    /// tangent for a straight element).
    pub fn normal_at(&self, sigma: f64) -> DVec3 {
        let [t0, n0, b0] = self.frame;
        if self.turn == 0.0 {
            return n0;
        }
        let (c, s) = (self.cos_psi, self.sin_psi);
        let (st, ct) = (sigma / self.rho).sin_cos();
        (t0 * (-c * st) + n0 * ct + b0 * (s * st)).normalize()
    }

    /// The end's tangent.
    pub fn end_tangent(&self) -> DVec3 {
        self.tangent_at(self.length())
    }

    /// Number of equal pieces whose chords are within `sagitta` of the
    /// curve to leading order (`κℓ²/8`, as for arcs).
    pub fn pieces(&self, sagitta: f64) -> usize {
        let need = self.length() * (self.curvature() / (8.0 * sagitta)).sqrt();
        if need.is_finite() && need > 1.0 {
            need.ceil().min(1e7) as usize
        } else {
            1
        }
    }

    /// Appends `pieces(sagitta)` equal steps' points, without the start
    /// and ending exactly at `end`.
    pub fn sample_into(&self, sagitta: f64, out: &mut Vec<DVec3>) {
        let n = self.pieces(sagitta);
        let step = self.length() / n as f64;
        out.reserve(n);
        for k in 1..n {
            out.push(self.point_at(step * k as f64));
        }
        out.push(self.end);
    }
}

/// The turn `Θ ∈ (0, limit]` with `G(Θ) = γ` (`0 < γ ≤ G(limit)`, `G`
/// increasing there): Newton's method from the circle's `2γ`, kept inside
/// a bracket that each step narrows (bisection where Newton leaves it).
fn solve_turn(gamma: f64, c: f64, s: f64, limit: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, limit);
    let mut t = (2.0 * gamma).min(limit);
    for _ in 0..100 {
        let (g, dg) = chord_angle(t, c, s);
        let f = g - gamma;
        if f == 0.0 {
            return t;
        }
        if f > 0.0 {
            hi = t;
        } else {
            lo = t;
        }
        let newton = t - f / dg;
        let next = if dg > 0.0 && newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        if (next - t).abs() <= 1e-15 * t || hi - lo <= 1e-15 * hi {
            return next;
        }
        t = next;
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::predict::Arc;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A random unit vector.
    fn unit(rng: &mut ChaCha8Rng) -> DVec3 {
        loop {
            let v = DVec3::new(
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
            );
            if v.length_squared() > 0.01 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }

    #[test]
    fn a_quarter_turn_of_a_known_helix() {
        // (cos t, sin t, 0.5 t): pitch angle atan(0.5), curvature
        // 1/(1 + 0.25), torsion 0.5/(1 + 0.25), speed √1.25.
        let p = |t: f64| DVec3::new(t.cos(), t.sin(), 0.5 * t);
        let tangent = DVec3::new(0.0, 1.0, 0.5).normalize();
        let h = HelicalArc::new(p(0.0), tangent, p(1.0), 0.5f64.atan()).unwrap();
        assert!((h.curvature() - 0.8).abs() < 1e-12);
        assert!((h.torsion() - 0.4).abs() < 1e-12);
        assert!((h.length() - 1.25f64.sqrt()).abs() < 1e-12);
        assert!((h.point_at(0.5 * h.length()) - p(0.5)).length() < 1e-12);
        // Left-handed: the mirror image, pitch angle −atan(0.5).
        let m = |t: f64| DVec3::new(t.cos(), t.sin(), -0.5 * t);
        let tangent = DVec3::new(0.0, 1.0, -0.5).normalize();
        let h = HelicalArc::new(m(0.0), tangent, m(1.0), -(0.5f64.atan())).unwrap();
        assert!((h.torsion() + 0.4).abs() < 1e-12);
        assert!((h.point_at(0.5 * h.length()) - m(0.5)).length() < 1e-12);
    }

    #[test]
    fn the_chord_angle_rises_past_four_radians_for_every_pitch() {
        // The domain `Θ ≤ π` (and a circle's 0.95 of a turn) lies where
        // `G` increases, so the turn of a chord is unique.
        for i in 0..=300 {
            let psi = -1.56 + 3.12 * i as f64 / 300.0;
            let (s, c) = f64::sin_cos(psi);
            let mut before = 0.0;
            for k in 1..=4000 {
                let t = 4.0 * k as f64 / 4000.0;
                let (g, dg) = chord_angle(t, c, s);
                assert!(
                    g > before && dg > 0.0,
                    "psi {psi} turn {t}: G {g} after {before}, G' {dg}"
                );
                before = g;
            }
        }
        // A circle's `G(Θ) = Θ/2` to the arcs' limit.
        for k in 1..=1000 {
            let t = 2.0 * MAX_HALF_TURN * k as f64 / 1000.0;
            assert!((chord_angle(t, 1.0, 0.0).0 - 0.5 * t).abs() < 1e-12);
        }
    }

    #[test]
    fn no_pitch_is_the_circular_arc() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for _ in 0..2000 {
            let start = DVec3::new(
                rng.gen_range(-10.0..10.0),
                rng.gen_range(-10.0..10.0),
                rng.gen_range(-10.0..10.0),
            );
            let tangent = unit(&mut rng);
            let end = start + unit(&mut rng) * rng.gen_range(0.01..5.0);
            let (Ok(arc), h) = (
                Arc::new(start, tangent, end),
                HelicalArc::new(start, tangent, end, 0.0),
            ) else {
                continue;
            };
            let h = h.expect("every arc is a helix of no pitch");
            let scale = 1.0 + arc.length;
            assert!(
                (h.length() - arc.length).abs() < 1e-10 * scale,
                "{} {}",
                h.length(),
                arc.length
            );
            assert!((h.curvature() - arc.curvature).abs() < 1e-9 * (1.0 + arc.curvature));
            assert_eq!(h.torsion(), 0.0);
            assert!((h.end_tangent() - arc.end_tangent()).length() < 1e-9);
            for k in 0..=8 {
                let sigma = arc.length * k as f64 / 8.0;
                assert!((h.point_at(sigma) - arc.point_at(sigma)).length() < 1e-9 * scale);
            }
            assert_eq!(h.pieces(0.01), arc.pieces(0.01));
        }
    }

    #[test]
    fn a_helix_is_recovered_from_its_start_tangent_end_and_pitch() {
        // Random helices (pitch angle, radius of the Darboux rotation, turn
        // up to the limit, frame, start): the element through the same
        // start, tangent and end has the same curvature, torsion, length,
        // points and end tangent.
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for case in 0..3000 {
            let psi: f64 = rng.gen_range(-1.5..1.5);
            let rho: f64 = 10f64.powf(rng.gen_range(-2.0..3.0));
            let turn: f64 = if case % 10 == 0 {
                10f64.powf(rng.gen_range(-7.0..-2.0))
            } else {
                rng.gen_range(0.01..HelicalArc::MAX_TURN)
            };
            let t0 = unit(&mut rng);
            let n0 = any_perpendicular(t0);
            let spin: f64 = rng.gen_range(0.0..6.3);
            let n0 = n0 * spin.cos() + t0.cross(n0) * spin.sin();
            let truth = HelicalArc {
                start: DVec3::new(rng.gen_range(-5.0..5.0), 1.0, -2.0),
                end: DVec3::ZERO,
                frame: [t0, n0, t0.cross(n0)],
                cos_psi: psi.cos(),
                sin_psi: psi.sin(),
                rho,
                turn,
                straight: 0.0,
            };
            let length = rho * turn;
            let end = truth.point_at(length);
            let h = HelicalArc::new(truth.start, t0, end, psi).unwrap_or_else(|e| {
                panic!("case {case}: {e:?} (psi {psi}, rho {rho}, turn {turn})")
            });
            let rel = |a: f64, b: f64| (a - b).abs() / b.abs().max(1e-300);
            // (The coordinates are rounded at their magnitude.)
            let rounding = 1e-14 * (truth.start.length() + length);
            assert!(
                (h.length() - length).abs() < 1e-8 * length + rounding,
                "case {case}: length {} of {length}",
                h.length()
            );
            // A nearly straight (or tiny) element's bend is near the end
            // point's rounding (its offset across the tangent is about
            // ρΘ²/2): its curvature is not in the data, its points are.
            if rho * turn * turn / 2.0 > 1e-5 * (truth.start.length() + length) {
                assert!(
                    rel(h.curvature(), psi.cos() / rho) < 1e-8,
                    "case {case}: psi {psi} rho {rho} turn {turn}: {} of {}",
                    h.curvature(),
                    psi.cos() / rho
                );
                assert!(
                    (h.torsion() - psi.sin() / rho).abs() < 1e-8 / rho,
                    "case {case}"
                );
                assert!(
                    (h.end_tangent() - truth.tangent_at(length)).length() < 1e-7,
                    "case {case}"
                );
            }
            for k in 1..=4 {
                let sigma = length * k as f64 / 4.0;
                let err = (h.point_at(sigma) - truth.point_at(sigma)).length();
                assert!(
                    err < 1e-8 * length + rounding,
                    "case {case}: point {k} off by {err}"
                );
            }
            // The samples end exactly at the end and are equally spaced in
            // arc length (equal chords on a helix).
            let mut out = Vec::new();
            h.sample_into(1e-3 * rho, &mut out);
            assert_eq!(*out.last().unwrap(), end);
            if out.len() > 2 {
                let chords: Vec<f64> = std::iter::once(truth.start)
                    .chain(out.iter().copied())
                    .collect::<Vec<_>>()
                    .windows(2)
                    .map(|w| (w[1] - w[0]).length())
                    .collect();
                let (lo, hi) = chords
                    .iter()
                    .fold((f64::MAX, 0.0f64), |(l, u), &c| (l.min(c), u.max(c)));
                assert!(hi - lo < 1e-7 * hi, "case {case}: chords {lo}..{hi}");
            }
        }
    }

    #[test]
    fn curvature_and_torsion_are_the_curves_own() {
        // Frenet–Serret by finite differences of the points: κ = |p''|,
        // τ = (p' × p'') · p''' / κ².
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for _ in 0..200 {
            let start = DVec3::ZERO;
            let tangent = unit(&mut rng);
            let end = start + unit(&mut rng) * rng.gen_range(0.5..3.0);
            let psi = rng.gen_range(-1.2..1.2);
            let Ok(h) = HelicalArc::new(start, tangent, end, psi) else {
                continue;
            };
            if h.turn() < 0.05 {
                continue;
            }
            let s0 = 0.5 * h.length();
            let e = 1e-3 * h.length().min(1.0 / h.curvature().max(1e-9));
            let p = |k: f64| h.point_at(s0 + k * e);
            let d1 = (p(1.0) - p(-1.0)) / (2.0 * e);
            let d2 = (p(1.0) - 2.0 * p(0.0) + p(-1.0)) / (e * e);
            let d3 = (p(2.0) - 2.0 * p(1.0) + 2.0 * p(-1.0) - p(-2.0)) / (2.0 * e * e * e);
            let kappa = d1.cross(d2).length();
            let tau = d1.cross(d2).dot(d3) / (kappa * kappa);
            let scale = 1.0 / h.rho;
            assert!(
                (kappa - h.curvature()).abs() < 1e-4 * scale,
                "{kappa} {}",
                h.curvature()
            );
            assert!(
                (tau - h.torsion()).abs() < 1e-3 * scale,
                "{tau} {}",
                h.torsion()
            );
            assert!((d1.normalize() - h.tangent_at(s0)).length() < 1e-6);
            assert!((d2.normalize() - h.normal_at(s0)).length() < 1e-4);
        }
    }

    #[test]
    fn bad_elements_are_refused() {
        let (o, x) = (DVec3::ZERO, DVec3::X);
        assert_eq!(
            HelicalArc::new(o, x, o, 0.3).unwrap_err(),
            ArcError::ZeroChord
        );
        assert_eq!(
            HelicalArc::new(o, x, DVec3::NAN, 0.3).unwrap_err(),
            ArcError::NonFinite
        );
        assert_eq!(
            HelicalArc::new(o, x, DVec3::Y, 1.6).unwrap_err(),
            ArcError::NonFinite
        );
        // Straight back: no turn reaches it.
        assert_eq!(
            HelicalArc::new(o, x, -x, 0.3).unwrap_err(),
            ArcError::Backwards
        );
        // Straight ahead: a straight element, whatever the pitch.
        let h = HelicalArc::new(o, x, 2.0 * x, 0.7).unwrap();
        assert_eq!((h.curvature(), h.length()), (0.0, 2.0));
        assert_eq!(h.point_at(1.0), x);
    }
}
