//! Deterministic synthetic inputs for benchmarks, examples and tests.

use glam::DVec3;

use crate::euler::FrenetProblem;
use crate::pair::HermitePair;
use crate::spline::{BezierSpline, SplineError};

/// Cubic Hermite spline through `segments + 1` samples of `pos` on
/// `[u0, u1]`, with derivatives from central differences of `pos` (step 1e-6):
/// a smooth `G1` spline that approximates `pos` to `O(h⁴)`.
pub fn hermite_spline(
    pos: impl Fn(f64) -> DVec3,
    u0: f64,
    u1: f64,
    segments: usize,
) -> Result<BezierSpline, SplineError> {
    let vel = |u: f64| (pos(u + 1e-6) - pos(u - 1e-6)) / 2e-6;
    let h = (u1 - u0) / segments.max(1) as f64;
    let mut cps = vec![pos(u0)];
    for k in 0..segments {
        let (a, b) = (u0 + k as f64 * h, u0 + (k + 1) as f64 * h);
        cps.push(pos(a) + vel(a) * h / 3.0);
        cps.push(pos(b) - vel(b) * h / 3.0);
        cps.push(pos(b));
    }
    BezierSpline::from_control_points(&cps)
}

/// Curve `c` of the synthetic family: a wandering helix (radius and pitch
/// varying slowly), about the shape of a hair strand.
fn wandering_helix(c: usize) -> impl Fn(f64) -> DVec3 {
    let phase = c as f64 * 0.618_033_988_75;
    move |u: f64| {
        let r = 1.0 + 0.3 * (0.7 * u + phase).sin();
        DVec3::new(
            r * (2.0 * u + phase).cos(),
            r * (2.0 * u + phase).sin(),
            0.8 * u + 0.2 * (1.3 * u).sin(),
        )
    }
}

/// Deterministic smooth test splines: Hermite cubics of a wandering helix
/// (curvature and torsion varying slowly), about the shape of a hair strand.
pub fn synthetic_splines(count: usize, segments: usize) -> Vec<BezierSpline> {
    (0..count)
        .filter_map(|c| {
            let pos = wandering_helix(c);
            hermite_spline(pos, 0.0, 6.0, segments).ok()
        })
        .collect()
}

/// Deterministic point–tangent pairs `(P₁, T₁, P₂, T₂)` for completion
/// benchmarks: the ends of arcs of the wandering helices above, each arc
/// turning by 0.2 to 1.2 rad — gaps like those between fibre fragments.
pub fn synthetic_hermite_pairs(count: usize) -> Vec<HermitePair> {
    (0..count)
        .map(|c| {
            let pos = wandering_helix(c);
            let tangent = |u: f64| ((pos(u + 1e-6) - pos(u - 1e-6)) / 2e-6).normalize();
            let u0 = (c as f64 * 0.414_213_562_37).fract() * 6.0;
            let u1 = u0 + 0.1 + 0.5 * (c as f64 * 0.732_050_807_57).fract();
            HermitePair::new(pos(u0), tangent(u0), pos(u1), tangent(u1))
        })
        .collect()
}

/// A local motion problem of paper 001, Section 4: start point, start frame
/// `(u, v, w)`, displacement to the end point and end tangent.
pub type LocalMotion = (DVec3, [DVec3; 3], DVec3, DVec3);

/// Deterministic local motion problems satisfying (4.1): the end tangent is
/// the start tangent turned about the chord by 0.3–2.8 rad.
pub fn synthetic_local_motions(count: usize) -> Vec<LocalMotion> {
    (0..count)
        .map(|k| {
            let a = k as f64 * 0.618_033_988_75;
            let u = DVec3::new(a.cos(), a.sin(), 0.3 * (2.0 * a).sin()).normalize();
            let frame = crate::rrmf::default_frame(u).unwrap_or([DVec3::X, DVec3::Y, DVec3::Z]);
            let dp = DVec3::new(
                1.0 + (1.7 * a).sin(),
                (1.3 * a).cos(),
                0.5 * (0.7 * a).sin(),
            );
            let turn = 0.3 + 2.5 * (a * 0.414).fract();
            let u_f = glam::DQuat::from_axis_angle(dp.normalize(), turn) * u;
            (DVec3::ZERO, frame, dp, u_f)
        })
        .collect()
}

/// `count` point streams of `len` points along wandering helices, spaced
/// like the samples of a hair strand or a probe path.
pub fn synthetic_streams(count: usize, len: usize) -> Vec<Vec<DVec3>> {
    (0..count)
        .map(|c| {
            let ph = c as f64 * 0.618_033_988_75;
            (0..len)
                .map(|k| {
                    let u = k as f64 * 0.45;
                    let r = 1.0 + 0.3 * (0.7 * u + ph).sin();
                    DVec3::new(r * (2.0 * u + ph).cos(), r * (2.0 * u + ph).sin(), 0.8 * u)
                })
                .collect()
        })
        .collect()
}

/// SplitMix64: a small deterministic generator for the synthetic inputs
/// and the kernels' parity batches (the library does not depend on `rand`).
#[derive(Clone, Debug)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    pub fn new(seed: u64) -> Self {
        SplitMix64(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[a, b)`.
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        let u = (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
        a + (b - a) * u
    }

    /// Uniform on the unit sphere (rejection from the shell
    /// `0.2 < |v| < 1`, so that normalising is well conditioned).
    pub fn unit_vector(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let l = v.length();
            if l > 0.2 && l < 1.0 {
                return v / l;
            }
        }
    }
}

/// Total turning of the tangent, `∫₀ᴸ |κ| ds`, of a spiral (`κ` linear, so
/// in closed form, split at the inflection if `κ` changes sign).
pub fn spiral_turning(p: &FrenetProblem) -> f64 {
    let (k0, k1) = (p.kappa0, p.curvature(p.length));
    if k0 * k1 >= 0.0 {
        0.5 * (k0.abs() + k1.abs()) * p.length
    } else {
        (k0 * k0 + k1 * k1) / (2.0 * p.gamma.abs())
    }
}

/// Deterministic random 3D Euler spirals whose tangent turns by at most one
/// revolution (`∫|κ| ds ≤ 2π`), for completion tests and benchmarks:
///
/// * start `x₀` uniform in `[−5, 5]³`, tangent `T₀` uniform on the sphere,
///   normal `N₀` perpendicular to it at a uniform angle;
/// * in the dimensionless rates of the whole length, uniform:
///   `κ₀L ∈ [0, 2π)`, `γL² ∈ [−2π, 2π)` (curvature at the start and its
///   change over the curve), `τ₀L ∈ [−π, π)`, `δL² ∈ [−π, π)` (twist);
///   then `L ∈ [0.5, 3)` (`κ₀ ≥ 0` loses nothing: `N₀` takes every
///   direction);
/// * a draw whose turning ([`spiral_turning`]) exceeds `2π` is rejected and
///   drawn again (12% are). The turning of those kept is spread over the
///   whole revolution (median 2.7 rad, 10% above 5.3). `κ` may change sign
///   (an inflection, 29% of the spirals): such pairs are kept, they occur
///   in real gaps.
pub fn random_spirals(count: usize, seed: u64) -> Vec<FrenetProblem> {
    use std::f64::consts::{PI, TAU};
    let mut rng = SplitMix64(seed);
    let mut out = Vec::with_capacity(count);
    while out.len() < count {
        let start = DVec3::new(
            rng.range(-5.0, 5.0),
            rng.range(-5.0, 5.0),
            rng.range(-5.0, 5.0),
        );
        let t = rng.unit_vector();
        let phi = rng.range(0.0, TAU);
        let e1 = t.any_orthonormal_vector();
        let n = phi.cos() * e1 + phi.sin() * t.cross(e1);
        // Dimensionless rates (turning and twist over the whole length),
        // then the length.
        let (k0, g) = (rng.range(0.0, TAU), rng.range(-TAU, TAU));
        let (t0, d) = (rng.range(-PI, PI), rng.range(-PI, PI));
        let l = rng.range(0.5, 3.0);
        let p = FrenetProblem::new(start, t, n, k0 / l, g / (l * l), t0 / l, d / (l * l), l);
        if spiral_turning(&p) <= TAU {
            out.push(p);
        }
    }
    out
}

/// The completion problems of spirals: `(x₀, T₀, x(L), T(L))`, the end by
/// 1024 integration steps (on all cores). The pair is the input to solve;
/// how close it is to the generating spiral's exact end (about `1e-12`
/// relative) does not matter.
pub fn spiral_end_pairs(spirals: &[FrenetProblem]) -> Vec<HermitePair> {
    use rayon::prelude::*;
    spirals
        .par_iter()
        .map(|p| {
            let e = p.integrate_unchecked(1024);
            HermitePair::new(p.start, p.frame[0], e.point, e.frame[0])
        })
        .collect()
}

/// A drawing of `n` vertices for the sketch benchmarks: the projection of
/// a helix of radius 30 whose axis is tilted 60° out of the page, 2.5
/// turns, followed by a wider, flatter curl of 1.5 turns (two helices),
/// sampled evenly in the helix parameter (so the edges are uneven).
pub fn synthetic_sketch(n: usize) -> Vec<glam::DVec2> {
    let n = n.max(4);
    let first = n * 5 / 8;
    let mut out = Vec::with_capacity(n);
    let tilt = 60f64.to_radians();
    let coil = |u: f64, r: f64, p: f64, tilt: f64| {
        glam::DVec2::new(r * u.cos(), r * u.sin() * tilt.cos() - p * u * tilt.sin())
    };
    for k in 0..first {
        let u = 2.5 * std::f64::consts::TAU * k as f64 / (first - 1) as f64;
        out.push(coil(u, 30.0, 9.0, tilt));
    }
    let join = *out.last().unwrap_or(&glam::DVec2::ZERO);
    let second = n - first;
    let start = coil(0.0, 45.0, 20.0, 1.2);
    for k in 1..=second {
        let u = 1.5 * std::f64::consts::TAU * k as f64 / second as f64;
        out.push(join + coil(u, 45.0, 20.0, 1.2) - start);
    }
    out
}

/// A harder drawing of `n` vertices for the sketch benchmarks: `k` curls
/// (projections of helices of different radii, pitches and tilts, 1.25
/// turns each), each starting where the last ended with its direction
/// turned by 0.6 rad (a corner), evenly sampled in the helix parameter.
pub fn synthetic_sketch_curls(n: usize, k: usize) -> Vec<glam::DVec2> {
    use glam::DVec2;
    let k = k.max(1);
    let per = (n.max(4 * k) / k).max(4);
    let radii = [30.0, 18.0, 25.0, 12.0];
    let pitches = [6.0, 4.0, 9.0, 2.5];
    let tilts: [f64; 4] = [1.0, 0.5, 1.2, 0.8];
    let mut out: Vec<DVec2> = Vec::with_capacity(per * k);
    for i in 0..k {
        let (r, p, tilt) = (radii[i % 4], pitches[i % 4], tilts[i % 4]);
        let coil = |u: f64| DVec2::new(r * u.cos(), r * u.sin() * tilt.cos() - p * u * tilt.sin());
        let turn = 1.25 * std::f64::consts::TAU;
        let count = if i + 1 == k {
            n.max(per * k) - per * (k - 1)
        } else {
            per
        };
        let part: Vec<DVec2> = (0..=count)
            .map(|j| coil(turn * j as f64 / count as f64))
            .collect();
        if out.len() < 2 {
            out.extend(&part[..count]);
            continue;
        }
        // Place the curl at the end of the drawing, turned 0.6 rad.
        let m = out.len();
        let end_dir = (out[m - 1] - out[m - 2]).to_angle();
        let start_dir = (part[1] - part[0]).to_angle();
        let rot = DVec2::from_angle(end_dir + 0.6 - start_dir);
        let join = out[m - 1];
        out.extend(
            part[1..]
                .iter()
                .take(count)
                .map(|&q| join + rot.rotate(q - part[0])),
        );
    }
    out.truncate(n.max(4));
    out
}
