//! `spline_sample.wgsl` on the GPU against its CPU twin and the `f64`
//! reference (`BezierSpline::sample_equal_arclen`), over 100,000+ samples of
//! a ragged batch — splines of 1 to 30 segments, 1 to 4,000 elements each —
//! with smooth, straight, far-away, zero-length-segment, very uneven,
//! end-degenerate, near-cusp and cusp splines.

mod common;
use common::{E32, E64};

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use strandfit::gpu::{GpuContext, GpuError, Precision, Timings};
use strandfit::kernels::spline_sample::{
    sample, sample_counts, sample_counts_twin, ChunkLimits, SplineSamples,
};
use strandfit::spline::BezierSpline;
use strandfit::synthetic::hermite_spline;
use strandfit::twin::spline_sample::{FINE, QUAD_FLOOR, QUAD_TOL};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Family {
    /// Hermite cubics of a wandering helix, ~100 from the origin.
    Hair,
    /// Random control points in a box (occasional near-cusps).
    Random,
    /// Collinear control points, monotone along the line.
    Straight,
    /// Random with some segments collapsed to a point (also first/last).
    ZeroSeg,
    /// Segments of length ~1e-6 between segments of length ~1.
    Uneven,
    /// Segments with `P₀ = P₁` and/or `P₂ = P₃` (`B'` vanishes at an end).
    EndDegenerate,
    /// A cusp perturbed out of plane by 1e-2 … 1e-6.
    NearCusp,
    /// Exact cusps, and collinear points that reverse direction.
    Cusp,
}
const FAMILIES: [Family; 8] = [
    Family::Hair,
    Family::Random,
    Family::Straight,
    Family::ZeroSeg,
    Family::Uneven,
    Family::EndDegenerate,
    Family::NearCusp,
    Family::Cusp,
];

fn v(x: f64, y: f64, z: f64) -> DVec3 {
    DVec3::new(x, y, z)
}

fn rand_v(rng: &mut ChaCha8Rng, r: f64) -> DVec3 {
    v(
        rng.gen_range(-r..r),
        rng.gen_range(-r..r),
        rng.gen_range(-r..r),
    )
}

/// The inner control points and end of a gently curved segment of size
/// `r` from `last` (inner points near the thirds of the chord).
fn gentle(rng: &mut ChaCha8Rng, last: DVec3, r: f64) -> [DVec3; 3] {
    let d = rand_v(rng, 1.0).normalize() * r;
    [
        last + d / 3.0 + rand_v(rng, 0.15 * r),
        last + 2.0 * d / 3.0 + rand_v(rng, 0.15 * r),
        last + d,
    ]
}

/// Reference tables at their tightest (16ε of L), so the reference is exact
/// to well below the kernel's `f64` tolerance.
fn tight(cps: &[DVec3]) -> Option<BezierSpline> {
    BezierSpline::from_control_points_with_accuracy(cps, 1e-300).ok()
}

fn spline(rng: &mut ChaCha8Rng, fam: Family) -> Option<BezierSpline> {
    let k = rng.gen_range(1..=30usize);
    match fam {
        Family::Hair => {
            let (a, b, c) = (
                rng.gen_range(0.5..3.0),
                rng.gen_range(0.1..2.0),
                rng.gen_range(0.0..6.3),
            );
            let o = rand_v(rng, 100.0);
            let h = hermite_spline(
                |u: f64| {
                    let r = 1.0 + 0.3 * (0.7 * u + c).sin();
                    o + v(r * (a * u).cos(), r * (a * u).sin(), b * u)
                },
                0.0,
                rng.gen_range(1.0..8.0),
                k,
            )
            .ok()?;
            tight(h.control_points())
        }
        Family::Random => {
            let o = rand_v(rng, 10.0);
            let cps: Vec<DVec3> = (0..3 * k + 1).map(|_| o + rand_v(rng, 1.0)).collect();
            tight(&cps)
        }
        Family::Straight => {
            let d = rand_v(rng, 1.0).normalize();
            let o = rand_v(rng, 50.0);
            let mut ts: Vec<f64> = (0..3 * k + 1).map(|_| rng.gen_range(0.0..5.0)).collect();
            ts.sort_by(f64::total_cmp);
            if rng.gen_bool(0.5) {
                // evenly spaced: constant speed
                ts = (0..3 * k + 1).map(|i| i as f64 * 0.3).collect();
            }
            tight(&ts.iter().map(|&t| o + t * d).collect::<Vec<_>>())
        }
        Family::ZeroSeg => {
            let mut cps = vec![rand_v(rng, 1.0)];
            for i in 0..k.max(3) {
                let last = *cps.last().unwrap();
                if i == 0 || i == k.max(3) - 1 || rng.gen_bool(0.3) {
                    cps.extend([last; 3]);
                } else {
                    cps.extend(gentle(rng, last, 1.0));
                }
            }
            tight(&cps)
        }
        Family::Uneven => {
            let mut cps = vec![rand_v(rng, 1.0)];
            for i in 0..k {
                let last = *cps.last().unwrap();
                let r = if i % 2 == 1 { 1e-6 } else { 1.0 };
                cps.extend(gentle(rng, last, r));
            }
            tight(&cps)
        }
        Family::EndDegenerate => {
            let mut cps = vec![rand_v(rng, 1.0)];
            for _ in 0..k {
                let last = *cps.last().unwrap();
                let [mut p1, mut p2, end] = gentle(rng, last, 1.0);
                if rng.gen_bool(0.5) {
                    p1 = last;
                }
                if rng.gen_bool(0.5) {
                    p2 = end;
                }
                cps.extend([p1, p2, end]);
            }
            tight(&cps)
        }
        Family::NearCusp | Family::Cusp => {
            // B(t) = o + s·((t − c)², (t − c)³, δ t³) in a random frame: a
            // cusp at t = c (inside a panel: c is not a multiple of 1/32)
            // for δ = 0, a near-cusp (|B'| ≥ ~δ) otherwise.
            let delta = if fam == Family::Cusp {
                0.0
            } else {
                10f64.powi(-rng.gen_range(2..=6))
            };
            let o = rand_v(rng, 5.0);
            let s = rng.gen_range(0.5..2.0);
            if fam == Family::Cusp && rng.gen_bool(0.3) {
                // collinear reversal: B' = 0 at t = 1/2 ± √5/10
                let d = rand_v(rng, 1.0).normalize();
                return tight(&[o, o + 2.0 * s * d, o - s * d, o + s * d]);
            }
            let c = rng.gen_range(0.1..0.9);
            let ex = rand_v(rng, 1.0).normalize();
            let ey = ex.any_orthonormal_vector();
            let ez = ex.cross(ey);
            let m = |p: DVec3| o + s * (p.x * ex + p.y * ey + p.z * ez);
            let a0 = v(c * c, -c * c * c, 0.0);
            let a1 = v(-2.0 * c, 3.0 * c * c, 0.0);
            let a2 = v(1.0, -3.0 * c, 0.0);
            let a3 = v(0.0, 1.0, delta);
            let mut cps: Vec<DVec3> = [
                a0,
                a0 + a1 / 3.0,
                a0 + 2.0 * a1 / 3.0 + a2 / 3.0,
                a0 + a1 + a2 + a3,
            ]
            .into_iter()
            .map(m)
            .collect();
            // a smooth tail after the cusp segment
            for _ in 1..k.min(4) {
                let last = *cps.last().unwrap();
                cps.extend((0..3).map(|_| last + rand_v(rng, 1.0)));
            }
            tight(&cps)
        }
    }
}

const N_CHOICES: [usize; 8] = [1, 2, 3, 10, 57, 200, 1000, 4000];
const TARGET_SAMPLES: usize = 110_000;

struct Batch {
    splines: Vec<BezierSpline>,
    fams: Vec<Family>,
    counts: Vec<usize>,
}

fn batch() -> Batch {
    let mut rng = ChaCha8Rng::seed_from_u64(0x5a17);
    let (mut splines, mut fams, mut counts) = (Vec::new(), Vec::new(), Vec::new());
    let mut total = 0;
    let mut i = 0;
    while total < TARGET_SAMPLES || i < 4 * FAMILIES.len() {
        let fam = FAMILIES[i % FAMILIES.len()];
        i += 1;
        let Some(s) = spline(&mut rng, fam) else {
            continue;
        };
        let n = N_CHOICES[rng.gen_range(0..N_CHOICES.len())];
        total += n + 1;
        splines.push(s);
        fams.push(fam);
        counts.push(n);
    }
    Batch {
        splines,
        fams,
        counts,
    }
}

// Error argument (units: ε of the kernel's precision; L the spline's
// length, k its segment count). A sample's position along the curve is off
// by the error of the arc length at which it is placed:
// - quadrature: each segment's table passed the check
//   |GL(coarse) − GL(halves)| ≤ max(QUAD_TOL ε·len/COARSE, QUAD_FLOOR ε·panel)
//   per coarse panel; the halves are at least as accurate as the coarse
//   panel they replace (2¹⁶ × more for smooth |B'|, ≥ 4× at a kink), so a
//   segment's table is within (QUAD_TOL + QUAD_FLOOR) ε of its length;
// - summation: FINE sequential sums inside a segment and k across segments,
//   each ≤ ε of the running total: ≤ (FINE + k) ε L;
// - s_j = L·(j·(1/N)) and local = s − cum: a few ε L;
// - Newton stops at a step below 32ε in t (or where its predicted error
//   a²|B''|/(2|B'|) is below that): ≤ 32ε·|B'| in s;
// - evaluation of B(t) − P₀ in coordinates ≤ 3·leg/S: a few ε of the
//   largest leg (the host adds P₀ in f64: ≤ 4 ε₆₄ |P|).
// So |Δs| ≤ (QUAD_TOL + QUAD_FLOOR + FINE + k + 8) ε L + 32 ε|B'| and
// |Δp| ≤ |Δs| + 8 ε·leg + 4 ε₆₄|P|.
// The tangent turns by κ·|Δs| along the curve, and the rounding of the
// control points (≤ ε of the segment's coordinates, ≤ 3 legs) moves
// B'/|B'| by ≤ 64 ε·leg/|B'|: |Δt| ≤ 16 ε + 64 ε·leg/|B'| + κ|Δs|. The
// reference forms B' from absolute coordinates, adding 64 ε₆₄|P|/|B'|.
// The reference is not exact either: its table is built at 16 ε₆₄ L and
// its Newton stops within 1e-14 in t (≈ 45 ε₆₄·|B'| in s); both are added
// to |Δs| in the comparison with it. (Measured on a single segment against
// a 4096-panel compensated quadrature: the reference's samples were off by
// 46 ε₆₄ L, the f64 kernel's by 21 ε₆₄ L.)
//
// GPU vs twin: the same operations in the same order; lavapipe does not
// contract a·b + c into FMA, so they are expected bit-identical (measured:
// see the README table). A contracting driver changes roundings only, so
// the same budget without the quadrature term bounds the difference; a
// spline flagged on one side and not the other (a borderline quadrature
// check) is compared against the reference budget instead.
fn pos_budget(k: usize, quad: bool) -> f64 {
    let q = if quad { QUAD_TOL + QUAD_FLOOR } else { 0.0 };
    q + (FINE + k) as f64 + 8.0
}

#[derive(Clone, Copy, Debug, Default)]
struct Worst {
    /// |Δp| / (ε L).
    point: f64,
    /// |Δt| / ε.
    tangent: f64,
    /// Largest error / allowed.
    ratio: f64,
    samples: usize,
    splines: usize,
    fallbacks: usize,
}

/// Reference data per sample: (segment leg scale, |B'|, κ) at the
/// reference's parameter for s_j.
fn local_terms(s: &BezierSpline, n: usize, j: usize) -> (f64, f64, f64) {
    let (seg, t) = s.param_at_arclen(s.length() * j as f64 / n as f64);
    let c = &s.segments()[seg];
    let d1 = c.deriv(t);
    let d2 = c.deriv2(t);
    let sp = d1.length();
    let kappa = d1.cross(d2).length() / (sp * sp * sp);
    (c.leg_scale(), sp, kappa)
}

fn check(
    label: &str,
    eps: f64,
    quad: bool,
    b: &Batch,
    got: &[SplineSamples],
    want: &[SplineSamples],
    exact_fallbacks: bool,
) {
    let report = std::env::var("PARITY_REPORT").is_ok();
    let mut worst: Vec<(Family, Worst)> = FAMILIES.iter().map(|&f| (f, Worst::default())).collect();
    let mut mismatched_flags = 0;
    for (i, s) in b.splines.iter().enumerate() {
        let (g, w) = (&got[i], &want[i]);
        let n = b.counts[i];
        assert_eq!(g.points.len(), n + 1, "{label}: spline {i} count");
        assert_eq!(w.points.len(), n + 1, "{label}: spline {i} count");
        let slot = &mut worst.iter_mut().find(|x| x.0 == b.fams[i]).unwrap().1;
        slot.splines += 1;
        slot.fallbacks += g.fallback as usize;
        if exact_fallbacks && g.fallback {
            assert_eq!(g, w, "{label}: spline {i}: a fallback is the reference");
            continue;
        }
        // A flag that differs between GPU and twin: judge by the reference.
        let quad = quad || g.fallback != w.fallback;
        mismatched_flags += (g.fallback != w.fallback) as usize;
        let cps = s.control_points();
        assert_eq!(g.points[0], cps[0], "{label}: spline {i} first point");
        assert_eq!(
            g.points[n],
            cps[cps.len() - 1],
            "{label}: spline {i} last point"
        );
        let len = s.length();
        let budget = pos_budget(s.num_segments(), quad);
        for j in 0..=n {
            let (leg, speed, kappa) = local_terms(s, n, j);
            let ep = (g.points[j] - w.points[j]).length();
            let et = (g.tangents[j] - w.tangents[j]).length();
            // Newton's stop (t within 32ε, so s within 32ε·|B'|), and for
            // the reference its own errors: table 16 ε₆₄ L, Newton stop
            // 1e-14 in t.
            let reference = if quad {
                16.0 * E64 * len + 1e-14 * speed
            } else {
                0.0
            };
            let ds = budget * eps * len + 32.0 * eps * speed + reference;
            let p_tol = ds + 8.0 * eps * leg + 4.0 * E64 * w.points[j].length();
            // + the reference's own rounding: it forms B' from absolute
            // coordinates, ε₆₄|P|/|B'| per difference.
            let mag = w.points[j].length();
            let t_tol = (16.0 * eps + 64.0 * (eps * leg + E64 * mag) / speed + kappa * ds).min(2.0);
            let r = (ep / p_tol).max(et / t_tol);
            slot.samples += 1;
            slot.point = slot.point.max(ep / (eps * len));
            slot.tangent = slot.tangent.max(et / eps);
            if r > slot.ratio && report {
                eprintln!(
                    "{label} {:?} new worst ratio {r:.3e}: spline {i} (k = {}, L = {len:.3e}) j = {j}/{n}: \
                     |Δp| = {ep:.3e} (tol {p_tol:.3e}), |Δt| = {et:.3e} (tol {t_tol:.3e}), |B'| = {speed:.3e}, κ = {kappa:.3e}",
                    b.fams[i],
                    s.num_segments()
                );
            }
            slot.ratio = slot.ratio.max(r);
            assert!(
                r <= 1.0 || report,
                "{label}: spline {i} ({:?}) sample {j}/{n}: |Δp| {ep:e} > {p_tol:e} or |Δt| {et:e} > {t_tol:e}\n got {} {}\n want {} {}",
                b.fams[i],
                g.points[j],
                g.tangents[j],
                w.points[j],
                w.tangents[j]
            );
        }
    }
    for (f, w) in &worst {
        eprintln!(
            "{label} {f:?}: {} splines, {} samples, {} fallbacks; worst |Δp|/(εL) {:.3}, |Δt|/ε {:.3}, ratio {:.3e}",
            w.splines, w.samples, w.fallbacks, w.point, w.tangent, w.ratio
        );
    }
    if !exact_fallbacks {
        eprintln!("{label}: {mismatched_flags} splines flagged on one side only");
    }
    assert!(
        worst.iter().all(|(_, w)| w.ratio <= 1.0),
        "{label}: beyond tolerance"
    );
}

fn reference(b: &Batch) -> Vec<SplineSamples> {
    b.splines
        .iter()
        .zip(&b.counts)
        .map(|(s, &n)| {
            let (points, tangents) = s.sample_equal_arclen(n).unwrap().into_iter().unzip();
            SplineSamples {
                points,
                tangents,
                fallback: true,
            }
        })
        .collect()
}

fn parity(ctx: &GpuContext, precision: Precision) {
    let t0 = std::time::Instant::now();
    let b = batch();
    let total: usize = b.counts.iter().map(|n| n + 1).sum();
    let want = reference(&b);
    let (twin, eps) = match precision {
        Precision::F32 => (
            sample_counts_twin::<f32>(&b.splines, &b.counts).unwrap(),
            E32,
        ),
        Precision::F64 => (
            sample_counts_twin::<f64>(&b.splines, &b.counts).unwrap(),
            E64,
        ),
    };
    let k = ctx.exec(precision).unwrap();
    let mut t = Timings::default();
    let gpu = sample_counts(&k, &b.splines, &b.counts, ChunkLimits::default(), &mut t).unwrap();
    let name = precision.name();
    eprintln!(
        "{name}: {} splines, {total} samples; GPU {:?} ({} chunks); setup + twin + reference {:?}",
        b.splines.len(),
        t.total(),
        t.chunks,
        t0.elapsed()
    );
    assert!(total >= 100_000);
    // Bit-identity is what lavapipe gives; report it either way.
    let identical = gpu.iter().zip(&twin).filter(|(g, w)| g == w).count();
    eprintln!(
        "{name} gpu vs twin: {identical}/{} splines bit-identical",
        gpu.len()
    );
    check(
        &format!("{name} gpu vs twin"),
        eps,
        false,
        &b,
        &gpu,
        &twin,
        false,
    );
    check(
        &format!("{name} gpu vs reference"),
        eps,
        true,
        &b,
        &gpu,
        &want,
        true,
    );
    // Families that must stay on the GPU, and cusps that must not.
    for (i, g) in gpu.iter().enumerate() {
        match b.fams[i] {
            Family::Hair | Family::Straight | Family::Uneven | Family::EndDegenerate => {
                assert!(
                    !g.fallback,
                    "{name}: spline {i} ({:?}) fell back",
                    b.fams[i]
                )
            }
            _ => {}
        }
    }
    // Cusps inside a panel are flagged, except where the kink's quadrature
    // error happens to be small (then the reference comparison above holds
    // them to the same tolerance as everything else).
    let cusps: Vec<bool> = (0..gpu.len())
        .filter(|&i| b.fams[i] == Family::Cusp)
        .map(|i| gpu[i].fallback)
        .collect();
    let flagged = cusps.iter().filter(|&&f| f).count();
    assert!(
        4 * flagged >= 3 * cusps.len(),
        "{name}: {flagged}/{} cusps flagged",
        cusps.len()
    );
    // Chunking and splitting do not change results: tiny chunks (a spline
    // of 4,001 samples spans several) give the same answer.
    let small = ctx.exec(precision).unwrap();
    let limits = ChunkLimits {
        samples: 1500,
        segments: 40,
    };
    let mut t2 = Timings::default();
    let chunked = sample_counts(&small, &b.splines, &b.counts, limits, &mut t2).unwrap();
    eprintln!("{name}: small chunks: {} chunks", t2.chunks);
    assert!(t2.chunks > 50);
    assert!(chunked == gpu, "{name}: chunking changed results");
}

#[test]
fn spline_sample_parity_f64() {
    let Some(ctx) = common::gpu_f64_or_skip("spline_sample_parity_f64") else {
        return;
    };
    parity(&ctx, Precision::F64);
}

#[test]
fn spline_sample_parity_f32() {
    let Some(ctx) = common::gpu_or_skip("spline_sample_parity_f32") else {
        return;
    };
    parity(&ctx, Precision::F32);
}

/// Contract edge cases: `N = 0` and a count per spline are input errors,
/// an empty batch is empty, `N = 1` is the two end points, and the uniform
/// entry point equals the ragged one.
#[test]
fn spline_sample_edge_cases() {
    let Some(ctx) = common::gpu_or_skip("spline_sample_edge_cases") else {
        return;
    };
    let k = ctx.exec(Precision::F32).unwrap();
    let mut t = Timings::default();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let splines: Vec<BezierSpline> = (0..5)
        .filter_map(|_| spline(&mut rng, Family::Hair))
        .collect();
    assert!(matches!(
        sample(&k, &splines, 0, &mut t),
        Err(GpuError::InvalidInput(_))
    ));
    assert!(matches!(
        sample_counts(&k, &splines, &[3], ChunkLimits::default(), &mut t),
        Err(GpuError::InvalidInput(_))
    ));
    assert!(sample(&k, &[], 5, &mut t).unwrap().is_empty());
    let one = sample(&k, &splines, 1, &mut t).unwrap();
    for (s, o) in splines.iter().zip(&one) {
        let cps = s.control_points();
        assert_eq!(o.points, vec![cps[0], cps[cps.len() - 1]]);
    }
    let uniform = sample(&k, &splines, 33, &mut t).unwrap();
    let ragged = sample_counts(
        &k,
        &splines,
        &vec![33; splines.len()],
        ChunkLimits::default(),
        &mut t,
    )
    .unwrap();
    assert_eq!(uniform, ragged);
    // Far from the origin (1e6): segments travel relative to their start, so
    // f32 keeps its relative precision along the curve (|Δp| a few ε₃₂ L,
    // not ε₃₂·1e6) and the host adds the start in f64.
    let far = hermite_spline(
        |u| v(1e6 + u.cos(), -1e6 + u.sin(), 1e6 + 0.1 * u),
        0.0,
        6.0,
        12,
    )
    .unwrap();
    let got = sample(&k, std::slice::from_ref(&far), 500, &mut t).unwrap();
    assert!(!got[0].fallback);
    let want = far.sample_equal_arclen(500).unwrap();
    for (j, (p, tan)) in want.iter().enumerate() {
        let ep = (got[0].points[j] - *p).length();
        assert!(ep < 8.0 * E32 * far.length() + 1e-9, "far {j}: {ep:e}");
        assert!((got[0].tangents[j] - *tan).length() < 64.0 * E32, "far {j}");
    }
    // A spline too large for one chunk's segment table goes to the
    // reference (exactly), the rest stay on the GPU.
    let small = ctx.exec(Precision::F32).unwrap();
    let limits = ChunkLimits {
        samples: 1000,
        segments: 5,
    };
    let big = hermite_spline(|u| v(u.cos(), u.sin(), 0.1 * u), 0.0, 6.0, 9).unwrap();
    let fits = hermite_spline(|u| v(u, u.sin(), 0.0), 0.0, 3.0, 3).unwrap();
    let res = sample_counts(&small, &[big.clone(), fits], &[20, 20], limits, &mut t).unwrap();
    assert!(res[0].fallback && !res[1].fallback);
    let (points, tangents): (Vec<_>, Vec<_>) =
        big.sample_equal_arclen(20).unwrap().into_iter().unzip();
    assert_eq!(
        (res[0].points.clone(), res[0].tangents.clone()),
        (points, tangents)
    );
}
