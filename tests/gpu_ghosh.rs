//! `ghosh_bisect.wgsl` on the GPU against its CPU twin and the `f64`
//! reference (`helix::interpolate`), over 100,000+ random segments
//! with every degenerate and near-degenerate branch.

mod common;
use common::unit_vector;
use common::{E32, E64};

use std::f64::consts::{PI, TAU};

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use strandfit::gpu::{Precision, Timings};
use strandfit::helix::{HelixElement, HelixError, HermitePair, ShortHelix, DEFAULT_COHELICAL_TOL};
use strandfit::kernels::ghosh_bisect::{interpolate, interpolate_twin};

fn element(rng: &mut ChaCha8Rng, kappa: f64, tau: f64, phi: f64) -> HelixElement {
    let t0 = unit_vector(rng);
    let n = unit_vector(rng);
    let n0 = (n - n.dot(t0) * t0).normalize();
    let scale = 10f64.powf(rng.gen_range(-2.0..2.0));
    let start = DVec3::new(
        rng.gen_range(-100.0..100.0),
        rng.gen_range(-100.0..100.0),
        rng.gen_range(-100.0..100.0),
    );
    let omega = kappa.hypot(tau);
    HelixElement {
        start,
        tangent: t0,
        normal: n0,
        curvature: kappa / scale,
        torsion: tau / scale,
        length: phi / omega * scale,
    }
}

fn pair_of(e: &HelixElement, rng: &mut ChaCha8Rng) -> HermitePair {
    // tangents need not be unit
    let (a, b) = (rng.gen_range(0.5..2.0), rng.gen_range(0.5..2.0));
    HermitePair {
        p0: e.start,
        t0: a * e.tangent,
        p1: e.end_point(),
        t1: b * e.end_frame().tangent,
    }
}

/// Which family a case belongs to (for the report and the tolerances).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Family {
    Generic,
    Planar,
    NearPlanar,
    Steep,
    ShortArc,
    NearHalfTurn,
    Straight,
    HalfCircle,
    Invalid,
}

fn case(rng: &mut ChaCha8Rng, i: usize) -> (Family, HermitePair) {
    let sgn = if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
    match i % 16 {
        0..=5 => {
            let k = rng.gen_range(0.05..2.0);
            let t = sgn * rng.gen_range(0.0..2.0);
            let phi = rng.gen_range(0.01..TAU - 0.01);
            (Family::Generic, pair_of(&element(rng, k, t, phi), rng))
        }
        6 => {
            let phi = rng.gen_range(0.01..TAU - 0.01);
            (Family::Planar, pair_of(&element(rng, 1.0, 0.0, phi), rng))
        }
        7 => {
            let phi = rng.gen_range(0.01..TAU - 0.01);
            let t = sgn * 10f64.powf(rng.gen_range(-9.0..-4.0));
            (Family::NearPlanar, pair_of(&element(rng, 1.0, t, phi), rng))
        }
        8 => {
            // τ ≫ κ: tangents turn little while the helix turns a lot.
            let phi = rng.gen_range(0.5..TAU - 0.5);
            let k = 10f64.powf(rng.gen_range(-3.0..-1.0));
            (Family::Steep, pair_of(&element(rng, k, sgn, phi), rng))
        }
        9 => {
            let phi = 10f64.powf(rng.gen_range(-5.0..-2.0));
            let t = sgn * rng.gen_range(0.0..2.0);
            (Family::ShortArc, pair_of(&element(rng, 1.0, t, phi), rng))
        }
        10 => {
            let phi = PI + sgn * 10f64.powf(rng.gen_range(-8.0..-3.0));
            let t = rng.gen_range(-1e-3..1e-3);
            (
                Family::NearHalfTurn,
                pair_of(&element(rng, 1.0, t, phi), rng),
            )
        }
        11 => {
            let t0 = unit_vector(rng);
            let p0 = DVec3::new(rng.gen_range(-50.0..50.0), 0.0, 1.0);
            let p1 = p0 + rng.gen_range(0.01..10.0) * t0;
            (
                Family::Straight,
                HermitePair {
                    p0,
                    t0,
                    p1,
                    t1: 2.0 * t0,
                },
            )
        }
        12 => {
            let t0 = unit_vector(rng);
            let n = unit_vector(rng);
            let d = (n - n.dot(t0) * t0).normalize() * rng.gen_range(0.01..10.0);
            let p0 = DVec3::new(1.0, rng.gen_range(-50.0..50.0), 0.0);
            (
                Family::HalfCircle,
                HermitePair {
                    p0,
                    t0,
                    p1: p0 + d,
                    t1: -t0,
                },
            )
        }
        13 => {
            let e = element(rng, 1.0, 0.5, 2.0);
            let mut p = pair_of(&e, rng);
            match rng.gen_range(0..5) {
                0 => p.p1 = p.p0,
                1 => p.t0 = DVec3::ZERO,
                2 => p.t1.y = f64::NAN,
                3 => p.p1 += 0.01 * (p.t1.normalize() - p.t0.normalize()), // off co-helical
                _ => p.p0.x = f64::INFINITY,
            }
            (Family::Invalid, p)
        }
        _ => {
            let k = rng.gen_range(0.05..2.0);
            let t = sgn * rng.gen_range(0.0..2.0);
            let phi = rng.gen_range(0.01..TAU - 0.01);
            (Family::Generic, pair_of(&element(rng, k, t, phi), rng))
        }
    }
}

/// How well `h` interpolates the pair: end point error relative to the
/// element's size (its length, or the chord if longer), end tangent error.
fn hits(h: &ShortHelix, p: &HermitePair, scale: f64) -> (f64, f64) {
    let e = &h.element;
    (
        (e.end_point() - p.p1).length() / scale,
        (e.end_frame().tangent - p.t1.normalize()).length(),
    )
}

/// Tolerances of one comparison, in units of the kernel's `ε`; see
/// `check` for how they scale with the conditioning of each case.
#[derive(Clone, Copy, Debug)]
struct Tol {
    eps: f64,
    point: f64,
    tangent: f64,
    params: f64,
}

#[derive(Default, Debug, Clone, Copy)]
struct Worst {
    point: f64,
    tangent: f64,
    kappa: f64,
    tau: f64,
    /// Largest error / allowed over all checks (must stay ≤ 1).
    ratio: f64,
}

/// Compare `got` with `want` case by case and assert the tolerances.
///
/// Why the tolerances scale as they do (η: relative noise of the data the
/// kernel sees, `ε` of its precision for `d` and the unit tangents, plus the
/// `f64` rounding of the test's own end points, `ε₆₄(|p₀| + |p₁|)/size`):
/// - end point: `C_p·η` of the element's size — the helix through rounded
///   data misses the exact end by the data's own noise;
/// - end tangent: `C_t·ε`;
/// - curvature, relative to `ω`: `C·η/θ`; torsion, a third-order effect of
///   the data: `C·η/θ²` (θ the angle between the end tangents) — the same
///   conditioning the reference's own tests state (`tests/ghosh.rs`).
fn check(
    label: &str,
    tol: Tol,
    cases: &[(Family, HermitePair)],
    got: &[Result<ShortHelix, HelixError>],
    want: &[Result<ShortHelix, HelixError>],
) -> Vec<(Family, Worst)> {
    let mut worst: Vec<(Family, Worst)> = Vec::new();
    for (i, ((fam, pair), (g, w))) in cases.iter().zip(got.iter().zip(want)).enumerate() {
        if !worst.iter().any(|(f, _)| f == fam) {
            worst.push((*fam, Worst::default()));
        }
        let slot = &mut worst.iter_mut().find(|(f, _)| f == fam).unwrap().1;
        match (g, w) {
            (Ok(g), Ok(w)) => {
                let chord = (pair.p1 - pair.p0).length();
                let size = chord.max(w.element.length);
                let eta =
                    tol.eps + 4.0 * f64::EPSILON * (pair.p0.length() + pair.p1.length()) / size;
                let (ep, et) = hits(g, pair, size);
                let om = w.element.omega().max(1e-300);
                let t0 = pair.t0.normalize();
                let t1 = pair.t1.normalize();
                let theta = t0.cross(t1).length().atan2(t0.dot(t1)).max(1e-300);
                let dk = (g.element.curvature - w.element.curvature).abs() / om;
                let dt = (g.element.torsion - w.element.torsion).abs() / om;
                slot.point = slot.point.max(ep);
                slot.tangent = slot.tangent.max(et);
                slot.kappa = slot.kappa.max(dk);
                slot.tau = slot.tau.max(dt);
                let ratios = [
                    ep / (tol.point * eta),
                    et / (tol.tangent * tol.eps),
                    dk / (tol.params * eta * (1.0 + 1.0 / theta)),
                    dt / (tol.params * eta * (1.0 + 1.0 / (theta * theta))),
                ];
                let r = ratios.iter().cloned().fold(0.0, f64::max);
                if r > slot.ratio
                    && std::env::var("PARITY_REPORT").is_ok()
                    && label.contains("reference")
                {
                    eprintln!("{label} {fam:?} new worst {ratios:?}\n  got {g:?}\n  want {w:?}\n  data {pair:?}");
                }
                slot.ratio = slot.ratio.max(r);
                assert!(
                    r <= 1.0 || std::env::var("PARITY_REPORT").is_ok(),
                    "{label}: case {i} ({fam:?}) beyond tolerance {tol:?}: ratios {ratios:?}\n got {g:?}\n want {w:?}\n data {pair:?}"
                );
            }
            (Err(a), Err(b)) => assert_eq!(a, b, "{label}: case {i} ({fam:?}) errors differ"),
            _ => panic!("{label}: case {i} ({fam:?}): {g:?} vs {w:?} for {pair:?}"),
        }
    }
    for (f, w) in &worst {
        eprintln!("{label} {f:?}: {w:?}");
    }
    worst
}

const N: usize = 100_000;

// Kernel vs its twin: the same operations; drivers may still contract
// a·b + c into fma or reorder, so allow a few ulps (lavapipe: bit-identical).
const TWIN_F64: Tol = Tol {
    eps: E64,
    point: 64.0,
    tangent: 64.0,
    params: 64.0,
};
const TWIN_F32: Tol = Tol {
    eps: E32,
    point: 64.0,
    tangent: 64.0,
    params: 64.0,
};
// Kernel vs the f64 reference: bisection vs Brent, polynomial vs libm
// transcendentals, and (f32) the rounding of d and the tangents.
const REF_F64: Tol = Tol {
    eps: E64,
    point: 100.0,
    tangent: 100.0,
    params: 100.0,
};
const REF_F32: Tol = Tol {
    eps: E32,
    point: 100.0,
    tangent: 100.0,
    params: 100.0,
};

fn cases() -> Vec<(Family, HermitePair)> {
    let mut rng = ChaCha8Rng::seed_from_u64(0x6805);
    (0..N).map(|i| case(&mut rng, i)).collect()
}

#[test]
fn ghosh_bisect_parity_f64() {
    let Some(ctx) = common::gpu_f64_or_skip("ghosh_bisect_parity_f64") else {
        return;
    };
    let cases = cases();
    let pairs: Vec<HermitePair> = cases.iter().map(|c| c.1).collect();
    let tol = DEFAULT_COHELICAL_TOL;
    let reference: Vec<_> = pairs.iter().map(|p| p.interpolate(tol)).collect();
    let twin = interpolate_twin::<f64>(&pairs, tol);
    let k = ctx.exec(Precision::F64).unwrap();
    let mut t = Timings::default();
    let gpu = interpolate(&k, &pairs, tol, &mut t).unwrap();
    check("f64 gpu vs twin", TWIN_F64, &cases, &gpu, &twin);
    check("f64 gpu vs reference", REF_F64, &cases, &gpu, &reference);
}

#[test]
fn ghosh_bisect_parity_f32() {
    let Some(ctx) = common::gpu_or_skip("ghosh_bisect_parity_f32") else {
        return;
    };
    let cases = cases();
    let pairs: Vec<HermitePair> = cases.iter().map(|c| c.1).collect();
    let tol = DEFAULT_COHELICAL_TOL;
    let reference: Vec<_> = pairs.iter().map(|p| p.interpolate(tol)).collect();
    let twin = interpolate_twin::<f32>(&pairs, tol);
    let k = ctx.exec(Precision::F32).unwrap();
    let mut t = Timings::default();
    let gpu = interpolate(&k, &pairs, tol, &mut t).unwrap();
    check("f32 gpu vs twin", TWIN_F32, &cases, &gpu, &twin);
    check("f32 gpu vs reference", REF_F32, &cases, &gpu, &reference);
}
