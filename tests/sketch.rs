//! Sketch to 3D (paper 003): exact projections of known helices are lifted
//! back to them; piecewise projections are segmented at their junctions;
//! invariance to similarity transforms of the drawing; noise; bad input.

use std::f64::consts::{PI, TAU};

use glam::{DQuat, DVec2, DVec3};
use strandfit::sketch::{lift_sketch, refit_g1, Resampling, SketchError, SketchOptions};

/// A 3D helix about `axis` (unit), radius `r`, pitch `p` per radian,
/// through `centre`, turned about its axis by `phase`.
struct Helix3 {
    frame: DQuat,
    r: f64,
    p: f64,
    centre: DVec3,
}

impl Helix3 {
    fn point(&self, u: f64) -> DVec3 {
        self.centre + self.frame * DVec3::new(self.r * u.cos(), self.r * u.sin(), self.p * u)
    }
}

/// `m` points of the projection of `h` on `z = 0` for `u ∈ [u0, u1]`,
/// equally spaced in 2D arc length (so the input is used as is), with the
/// 3D points they come from.
fn projection(h: &Helix3, u0: f64, u1: f64, m: usize) -> (Vec<DVec2>, Vec<DVec3>) {
    let fine = 20_000;
    let us: Vec<f64> = (0..=fine)
        .map(|k| u0 + (u1 - u0) * k as f64 / fine as f64)
        .collect();
    let mut s = vec![0.0];
    for w in us.windows(2) {
        let d = (h.point(w[1]) - h.point(w[0])).truncate().length();
        s.push(s.last().unwrap() + d);
    }
    let total = *s.last().unwrap();
    let mut out2 = Vec::new();
    let mut out3 = Vec::new();
    let mut k = 0;
    for j in 0..m {
        let target = total * j as f64 / (m - 1) as f64;
        while k + 1 < fine && s[k + 1] < target {
            k += 1;
        }
        // Bisection on u in [us[k], us[k+1]] for the exact arc length.
        let (mut lo, mut hi) = (us[k], us[k + 1]);
        let base = s[k];
        let arc = |u: f64| {
            // Simpson on the projected speed from us[k] to u.
            let n = 16;
            let hstep = (u - us[k]) / n as f64;
            let speed = |v: f64| {
                let e = 1e-6;
                ((h.point(v + e) - h.point(v - e)).truncate() / (2.0 * e)).length()
            };
            let mut acc = speed(us[k]) + speed(u);
            for i in 1..n {
                acc += speed(us[k] + i as f64 * hstep) * if i % 2 == 1 { 4.0 } else { 2.0 };
            }
            base + acc * hstep / 3.0
        };
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if arc(mid) < target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let u = 0.5 * (lo + hi);
        let p = h.point(u);
        out2.push(p.truncate());
        out3.push(p);
    }
    (out2, out3)
}

/// Deterministic pseudo-random numbers in [0, 1).
fn rng(seed: &mut u64) -> f64 {
    *seed = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*seed >> 11) as f64 / (1u64 << 53) as f64
}

/// The smallest over the largest projected speed on `[u0, u1]`: near 0 the
/// drawing has a (near-)cusp, where it turns back on itself.
fn speed_ratio(h: &Helix3, u0: f64, u1: f64) -> f64 {
    let speed = |u: f64| ((h.point(u + 1e-6) - h.point(u - 1e-6)).truncate() / 2e-6).length();
    let s: Vec<f64> = (0..=400)
        .map(|k| speed(u0 + (u1 - u0) * k as f64 / 400.0))
        .collect();
    s.iter().cloned().fold(f64::INFINITY, f64::min) / s.iter().cloned().fold(0.0, f64::max)
}

fn random_helix(seed: &mut u64) -> Helix3 {
    let tilt = 0.2 + 1.2 * rng(seed);
    let frame = DQuat::from_rotation_z(TAU * rng(seed))
        * DQuat::from_rotation_x(tilt)
        * DQuat::from_rotation_z(TAU * rng(seed));
    Helix3 {
        frame,
        r: 1.0,
        p: 0.15 + 0.5 * rng(seed),
        centre: DVec3::new(rng(seed), rng(seed), rng(seed)),
    }
}

/// `max − min` of a sequence.
fn spread(v: impl Iterator<Item = f64> + Clone) -> f64 {
    v.clone().fold(f64::MIN, f64::max) - v.fold(f64::MAX, f64::min)
}

#[test]
fn exact_projections_are_lifted_to_their_helix() {
    // Random axis tilts (the paper's c over (−π/2, π/2)), pitches and
    // lengths of 0.6 to 1.3 turns, drawings without near-cusps (see the
    // README: where the drawing turns back sharply the covering splits it).
    let mut seed = 11u64;
    let mut tried = 0;
    let mut cases = 0;
    while cases < 16 {
        tried += 1;
        let h = random_helix(&mut seed);
        let u1 = 4.0 + 4.0 * rng(&mut seed);
        if speed_ratio(&h, 0.0, u1) < 0.3 {
            continue;
        }
        cases += 1;
        let (sketch, truth) = projection(&h, 0.0, u1, 150);
        let r = lift_sketch(&sketch, &SketchOptions::default()).unwrap();
        assert!(!r.resampled);
        assert_eq!(
            r.helices.len(),
            1,
            "case {cases}: p {} c {} {:?}",
            h.p,
            (h.frame * DVec3::Z).z.asin(),
            r.helices
        );
        assert!(
            r.max_error < 1e-6 * r.length,
            "case {cases}: {:e}",
            r.max_error / r.length
        );
        assert!(r.junctions.is_empty());
        // The lift is the helix or its mirror, up to a shift in z: z − z_true
        // or z + z_true is constant.
        let same = spread(r.points_3d.iter().zip(&truth).map(|(a, b)| a.z - b.z));
        let mirror = spread(r.points_3d.iter().zip(&truth).map(|(a, b)| a.z + b.z));
        assert!(
            same.min(mirror) < 1e-6 * r.length,
            "case {cases}: {same:e} {mirror:e}"
        );
        // And the fitted helix has the true radius and pitch.
        let f = r.helices[0].helix;
        assert!((f.a.abs() - h.r).abs() < 1e-6, "{f:?}");
        assert!((f.b.abs() - h.p).abs() < 1e-6, "{f:?}");
    }
    assert!(tried < 40, "{tried}");
}

/// Projections of `k` helices joined end to end, each next one placed so
/// that its projection starts where the last ended, turning by 0.6 rad. Returns the sketch and the junction vertices.
fn piecewise(k: usize, seed: &mut u64, per: usize) -> (Vec<DVec2>, Vec<usize>) {
    let mut sketch: Vec<DVec2> = Vec::new();
    let mut junctions = Vec::new();
    while junctions.len() < k {
        let mut h = random_helix(seed);
        let u1 = 3.0 + 2.0 * rng(seed);
        if speed_ratio(&h, 0.0, u1) < 0.3 {
            continue;
        }
        // Different radii so that neighbours are different helices.
        h.r = [1.0, 0.45, 0.7, 0.3][junctions.len() % 4];
        h.p *= h.r;
        if sketch.len() >= 2 {
            // A corner of 0.6 rad in the drawing at the join, so that the
            // junction is a feature of the drawing and not only of the
            // curvature (where two helices meet smoothly, either fits the
            // vertices near the join within E_max).
            let n = sketch.len();
            let end_dir = (sketch[n - 1] - sketch[n - 2]).to_angle();
            let start_dir = (h.point(1e-6) - h.point(0.0)).truncate().to_angle();
            h.frame = DQuat::from_rotation_z(end_dir + 0.6 - start_dir) * h.frame;
            let start = h.point(0.0).truncate();
            h.centre += (sketch[n - 1] - start).extend(0.0);
        }
        let (part, _) = projection(&h, 0.0, u1, per);
        if sketch.is_empty() {
            sketch.extend(part);
        } else {
            sketch.extend(part.into_iter().skip(1));
        }
        junctions.push(sketch.len() - 1);
    }
    junctions.pop(); // the last end is not a junction
    (sketch, junctions)
}

#[test]
fn piecewise_projections_are_split_at_their_junctions() {
    // 2–4 helices, 60 vertices each, a 0.6 rad corner at each join; seeds
    // 5 and 13 (18 drawings, 36 junctions). Every junction is at its
    // corner vertex exactly, none spurious: a drawing used as it is keeps
    // its vertices, and one whose edges differ by more than 3× (the
    // helices differ in size) is densified, which keeps them too (the
    // junction is then the densified polyline's copy of the corner
    // vertex). With the paper's uniform resampling the corner falls
    // between two samples, and the junction must be the sample next to it
    // (within one step). Measured on 16 seeds (144 drawings, 288
    // junctions): every junction exact, 1 spurious; uniform: every
    // junction within 0.9 steps, 3 spurious.
    for resampling in [Resampling::Densify, Resampling::Uniform] {
        let (mut exact, mut near) = (0, 0);
        for start in [5u64, 13] {
            let mut seed = start;
            for k in 2..=4 {
                for _ in 0..3 {
                    let (sketch, truth) = piecewise(k, &mut seed, 60);
                    // α_T = 0: the fine fit keeps every vertex within E_max.
                    let o = SketchOptions {
                        alpha_t: 0.0,
                        resampling,
                        ..Default::default()
                    };
                    let r = lift_sketch(&sketch, &o).unwrap();
                    assert!(
                        r.max_error <= 1e-3 * r.length,
                        "{resampling:?} seed {start} k {k}: {} noise {} denoised {} n {}",
                        r.max_error / r.length,
                        r.noise / r.length,
                        r.denoised,
                        r.helices.len()
                    );
                    let found: Vec<usize> = r.junctions.iter().map(|j| j.vertex).collect();
                    assert_eq!(
                        found.len(),
                        truth.len(),
                        "{resampling:?} seed {start}: {found:?} vs {truth:?}"
                    );
                    if !r.resampled {
                        assert_eq!(found, truth, "seed {start}");
                        exact += truth.len();
                        continue;
                    }
                    let step = r.length / (r.points_2d.len() - 1) as f64;
                    for (&f, &t) in found.iter().zip(&truth) {
                        let d = (r.points_2d[f] - sketch[t]).length();
                        if resampling == Resampling::Densify {
                            assert_eq!(r.points_2d[f], sketch[t], "seed {start}");
                            exact += 1;
                        } else {
                            assert!(d <= step, "seed {start}: {} steps", d / step);
                            near += 1;
                        }
                    }
                }
            }
        }
        eprintln!("{resampling:?}: {exact} junctions exact, {near} within a step of the corner");
        match resampling {
            Resampling::Densify => assert_eq!(exact, 36),
            Resampling::Uniform => assert!(exact >= 18, "{exact}/36"),
        }
    }
}

#[test]
fn the_g1_refit_closes_the_junction_gaps_and_reports_its_projection() {
    // Two- and three-helix drawings: the lift leaves tangent gaps at its
    // junctions; the floating-tangents re-fit within T = E_max·L has none
    // (rounding), meets T, and its projection is within its 3D distance of
    // the drawing (projection shortens distances) — the number reported.
    let mut seed = 21u64;
    for k in [2, 3] {
        let (sketch, _) = piecewise(k, &mut seed, 60);
        let r = lift_sketch(&sketch, &SketchOptions::default()).unwrap();
        let kink = r
            .junctions
            .iter()
            .map(|j| j.tangent_angle)
            .fold(0.0, f64::max);
        assert!(kink > 1e-3, "{kink}");
        let t = 1e-3 * r.length;
        let g = refit_g1(&r, t).unwrap();
        assert!(
            g.within_tolerance && g.distance_3d <= t,
            "{} vs {t}",
            g.distance_3d
        );
        let (gap, angle) = g.continuity;
        assert!(gap < 1e-9 * r.length && angle < 1e-7, "{gap} {angle}");
        assert!(
            g.projection_distance <= g.distance_3d * (1.0 + 1e-6) + t / 64.0,
            "{} vs {}",
            g.projection_distance,
            g.distance_3d
        );
        // It did move: the drawing is not G1 at the corners.
        assert!(g.projection_distance > 0.0);
        eprintln!(
            "k={k}: lift kink {:.1}°, G1 chain of {} elements, 3D {:.2e} L, projection {:.2e} L",
            kink.to_degrees(),
            g.chain.len(),
            g.distance_3d / r.length,
            g.projection_distance / r.length
        );
    }
}

#[test]
fn similar_drawings_give_similar_helices() {
    // The paper's claim: rotation, translation and uniform scale of the
    // drawing give the same piecewise helix (up to that similarity and
    // the mirror). Checked on a two-helix drawing.
    let mut seed = 21u64;
    let (sketch, _) = piecewise(2, &mut seed, 60);
    let base = lift_sketch(&sketch, &SketchOptions::default()).unwrap();
    for (angle, scale, shift) in [
        (0.7, 1.0, DVec2::ZERO),
        (2.5, 3.0, DVec2::new(10.0, -4.0)),
        (-1.2, 0.02, DVec2::new(0.3, 0.1)),
    ] {
        let rot = DVec2::from_angle(angle);
        let moved: Vec<DVec2> = sketch
            .iter()
            .map(|&p| rot.rotate(p) * scale + shift)
            .collect();
        let r = lift_sketch(&moved, &SketchOptions::default()).unwrap();
        assert_eq!(r.helices.len(), base.helices.len());
        for (a, b) in r.helices.iter().zip(&base.helices) {
            assert_eq!((a.first, a.last), (b.first, b.last));
            assert!(
                (a.helix.a.abs() - scale * b.helix.a.abs()).abs() < 1e-6 * scale,
                "{a:?} {b:?}"
            );
            assert!((a.helix.b.abs() - scale * b.helix.b.abs()).abs() < 1e-6 * scale);
        }
        assert!((r.max_error - scale * base.max_error).abs() < 1e-7 * scale * base.length);
        for (a, b) in r.junctions.iter().zip(&base.junctions) {
            assert!((a.tangent_angle - b.tangent_angle).abs() < 1e-6);
        }
        // The 3D shapes agree: z up to sign and shift, scaled.
        let same = spread(
            r.points_3d
                .iter()
                .zip(&base.points_3d)
                .map(|(a, b)| a.z - scale * b.z),
        );
        let mirror = spread(
            r.points_3d
                .iter()
                .zip(&base.points_3d)
                .map(|(a, b)| a.z + scale * b.z),
        );
        assert!(
            same.min(mirror) < 1e-6 * scale * base.length,
            "{same} {mirror}"
        );
    }
}

#[test]
fn noisy_drawings_give_a_bounded_projection_error() {
    // A hand-drawn-like stroke: an exact projection with noise of 0.1 % of
    // the length on every vertex. The result covers the whole drawing and
    // stays within a few noise amplitudes of it.
    let mut seed = 3u64;
    for _ in 0..4 {
        let (mut sketch, _) = piecewise(2, &mut seed, 100);
        let length: f64 = sketch.windows(2).map(|w| (w[1] - w[0]).length()).sum();
        let noise = 1e-3 * length;
        for p in sketch.iter_mut() {
            *p += noise * DVec2::new(rng(&mut seed) - 0.5, rng(&mut seed) - 0.5) * 2.0;
        }
        let r = lift_sketch(
            &sketch,
            &SketchOptions {
                emax: Some(3e-3),
                ..Default::default()
            },
        )
        .unwrap();
        assert!(r.helices.len() <= 12, "{}", r.helices.len());
        assert!(
            r.max_error < 5.0 * noise,
            "{} vs noise {noise}",
            r.max_error
        );
        assert!(
            r.rms_error < 2.0 * noise,
            "{} vs noise {noise}",
            r.rms_error
        );
        assert_eq!(r.helices[0].first, 0);
        assert_eq!(r.helices.last().unwrap().last, r.points_2d.len() - 1);
        assert!(r.points_3d.iter().all(|p| p.is_finite()));
    }
}

#[test]
fn bad_sketches_are_refused_with_a_reason() {
    let o = SketchOptions::default();
    let p = |v: &[[f64; 2]]| v.iter().map(|a| DVec2::from(*a)).collect::<Vec<_>>();
    assert_eq!(lift_sketch(&[], &o).unwrap_err(), SketchError::TooFew(0));
    assert_eq!(
        lift_sketch(&p(&[[0.0, 0.0], [1.0, 0.0]]), &o).unwrap_err(),
        SketchError::TooFew(2)
    );
    assert_eq!(
        lift_sketch(&p(&[[0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [1.0, 0.0]]), &o).unwrap_err(),
        SketchError::TooFew(2)
    );
    assert_eq!(
        lift_sketch(&p(&[[0.0, 0.0], [f64::NAN, 0.0], [1.0, 0.0]]), &o).unwrap_err(),
        SketchError::NonFinite(1)
    );
    let e = lift_sketch(
        &p(&[[0.0, 0.0], [1.0, 0.0], [2.0, 1.0]]),
        &SketchOptions {
            emax: Some(0.0),
            ..o
        },
    );
    assert!(matches!(e, Err(SketchError::Options(_))));
    let e = lift_sketch(
        &p(&[[0.0, 0.0], [1.0, 0.0], [2.0, 1.0]]),
        &SketchOptions { alpha_t: 1.0, ..o },
    );
    assert!(matches!(e, Err(SketchError::Options(_))));
    assert!(SketchError::TooFew(2)
        .to_string()
        .contains("at least 3 distinct points"));
    // A straight stroke and a three-point stroke still work (degenerate helices).
    let r = lift_sketch(
        &p(&[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0], [4.0, 0.0]]),
        &o,
    )
    .unwrap();
    assert!(
        r.max_error < 1e-9 && r.points_3d.iter().all(|q| q.is_finite()),
        "{r:?}"
    );
    let r = lift_sketch(&p(&[[0.0, 0.0], [1.0, 0.0], [2.0, 1.0]]), &o).unwrap();
    assert!(r.points_3d.iter().all(|q| q.is_finite()));
}

/// Gaussian noise of `sigma` on each coordinate of each vertex (Box–Muller
/// on ChaCha8, the generator of `benches/sketch_noise.rs`, so the seeds
/// there are the drawings here).
fn with_noise(d: &[DVec2], sigma: f64, seed: u64) -> Vec<DVec2> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut gauss = move || {
        let u: f64 = rng.gen_range(f64::MIN_POSITIVE..1.0);
        let v: f64 = rng.gen();
        (-2.0 * u.ln()).sqrt() * (TAU * v).cos()
    };
    d.iter()
        .map(|&p| {
            let (x, y) = (gauss(), gauss());
            p + sigma * DVec2::new(x, y)
        })
        .collect()
}

fn polyline_length(d: &[DVec2]) -> f64 {
    d.windows(2).map(|w| (w[1] - w[0]).length()).sum()
}

fn depth(r: &strandfit::sketch::SketchLift) -> f64 {
    spread(r.points_3d.iter().map(|p| p.z))
}

/// The benchmark's lifts of the `curls` drawing (500 vertices) with
/// `noise` (of its length) at each of `seeds`: per seed, the helices
/// found, the depth over the exact drawing's and the worst drawn vertex's
/// distance over σ.
fn noisy_curls(curls: usize, noise: f64, seeds: &[u64]) -> Vec<(u64, usize, f64, f64)> {
    use rayon::prelude::*;
    use strandfit::synthetic::synthetic_sketch_curls;
    let d = synthetic_sketch_curls(500, curls);
    let exact = depth(&lift_sketch(&d, &SketchOptions::default()).unwrap());
    let sigma = noise * polyline_length(&d);
    seeds
        .par_iter()
        .map(|&seed| {
            let r = lift_sketch(&with_noise(&d, sigma, seed), &SketchOptions::default()).unwrap();
            (
                seed,
                r.helices.len(),
                depth(&r) / exact,
                r.drawn_error / sigma,
            )
        })
        .collect()
}

#[test]
fn the_noise_of_a_drawing_is_estimated() {
    use strandfit::sketch::estimate_noise;
    use strandfit::synthetic::synthetic_sketch_curls;
    for k in 1..=4 {
        let d = synthetic_sketch_curls(500, k);
        let l = polyline_length(&d);
        let exact = estimate_noise(&d);
        assert!(exact < 1e-5 * l, "{k} curls: {} of the length", exact / l);
        for (i, f) in [1e-4, 1e-3, 3e-3].into_iter().enumerate() {
            let sigma = f * l;
            let found = estimate_noise(&with_noise(&d, sigma, i as u64));
            assert!(
                (found / sigma - 1.0).abs() < 0.15,
                "{k} curls, σ = {f} L: found {}",
                found / sigma
            );
        }
    }
}

/// The benchmark's five drawings (`benches/sketch_noise.rs`, 500
/// vertices) with the number of helices each is drawn from: two coils and
/// one to four curls.
fn benchmark_drawings() -> Vec<(usize, Vec<DVec2>)> {
    use strandfit::synthetic::{synthetic_sketch, synthetic_sketch_curls};
    vec![
        (2, synthetic_sketch(500)),
        (1, synthetic_sketch_curls(500, 1)),
        (2, synthetic_sketch_curls(500, 2)),
        (3, synthetic_sketch_curls(500, 3)),
        (4, synthetic_sketch_curls(500, 4)),
    ]
}

#[test]
fn noisy_drawings_are_lifted_to_few_plausible_helices() {
    // Issue 22: at 0.1 % noise (half a pixel on a 500-pixel stroke) the
    // paper's E_max equals the noise, and the stroke came back as 34–50
    // helices with depths to 10⁵ times the exact drawing's. Now the
    // drawing is denoised, E_max follows the noise found (5σ̂), helices
    // seen end-on are refused, each helix is grown from two seeds, the
    // walk takes the nearest foot ahead at a near-cusp, and neighbours
    // that one helix explains as well (by the drawn vertices' residuals)
    // are merged. Measured by benches/sketch_noise.rs on 8 seeds of these
    // five drawings (40 at each noise level, before → after): at 0.1 % the
    // count exact on 25 → 35, the depth within 2× on 31 → 39, the largest
    // depth 99× → 2.3× the exact's; at 0.3 %: 24 → 33, 23 → 29, 444× →
    // 13×. The misses are near-cusps (helices tilted 1.2 rad) blurred by
    // the noise.
    use rayon::prelude::*;
    let drawings = benchmark_drawings();
    let o = SketchOptions::default();
    let exact_depth: Vec<f64> = drawings
        .iter()
        .map(|(_, d)| depth(&lift_sketch(d, &o).unwrap()))
        .collect();
    let seeds = 3;
    let runs: Vec<(usize, usize, f64, f64)> = (0..drawings.len() * seeds)
        .into_par_iter()
        .map(|n| {
            let (i, seed) = (n / seeds, (n % seeds) as u64);
            let (helices, d) = &drawings[i];
            let sigma = 1e-3 * polyline_length(d);
            let r = lift_sketch(&with_noise(d, sigma, seed), &o).unwrap();
            assert!(r.denoised);
            // The threshold follows the noise found, 5σ̂.
            assert!(
                (r.emax / (5.0 * r.noise) - 1.0).abs() < 1e-12,
                "{} {}",
                r.emax,
                r.noise
            );
            assert!((r.noise / sigma - 1.0).abs() < 0.1, "{}", r.noise / sigma);
            for h in &r.helices {
                assert!(h.helix.a.abs() < 10.0 * r.length, "{h:?}");
            }
            // The fit ran on the denoised vertices, closer to it than the
            // drawn ones.
            assert!(
                r.max_error <= r.drawn_error,
                "{} {}",
                r.max_error,
                r.drawn_error
            );
            let ratio = depth(&r) / exact_depth[i];
            (*helices, r.helices.len(), ratio, r.drawn_error / sigma)
        })
        .collect();
    let exact_count = runs.iter().filter(|r| r.0 == r.1).count();
    let near_depth = runs.iter().filter(|r| (0.5..=2.0).contains(&r.2)).count();
    // Measured: 13 and 15 of these 15; 15 and 15 since a short piece
    // beside a long one is tried as the same helix (`merge_short`).
    assert!(
        exact_count >= 14,
        "{exact_count}/15 with the right count: {runs:?}"
    );
    assert!(
        near_depth >= 14,
        "{near_depth}/15 with depth within 2×: {runs:?}"
    );
    for (want, got, ratio, drawn) in &runs {
        // Never wild: at most one helix too many, the depth within 10×
        // the exact's, every drawn vertex within a few σ of the fit.
        assert!(*got <= want + 2, "{runs:?}");
        assert!((0.1..=10.0).contains(ratio), "{runs:?}");
        assert!(*drawn < 8.0, "{runs:?}");
    }
    // 0.3 %: a few depths off, never a wild lift. Measured on these 15:
    // the count right on 15, the depth within 2× on 13 (the four curls,
    // seeds 1 and 2, at 2.9× and 2.0×), every drawn vertex within 6σ; on
    // 192 lifts of the four curls (benches/sketch_noise.rs) the depth
    // within 2× on 165, never beyond 5.3×, and within 7.1σ.
    let heavy: Vec<(usize, usize, f64, f64)> = (0..drawings.len() * seeds)
        .into_par_iter()
        .map(|n| {
            let (i, seed) = (n / seeds, (n % seeds) as u64);
            let (helices, d) = &drawings[i];
            let sigma = 3e-3 * polyline_length(d);
            let r = lift_sketch(&with_noise(d, sigma, seed), &o).unwrap();
            for h in &r.helices {
                assert!(h.helix.a.abs() < 10.0 * r.length, "{h:?}");
            }
            let ratio = depth(&r) / exact_depth[i];
            (*helices, r.helices.len(), ratio, r.drawn_error / sigma)
        })
        .collect();
    let exact_count = heavy.iter().filter(|r| r.0 == r.1).count();
    let near_depth = heavy.iter().filter(|r| (0.5..=2.0).contains(&r.2)).count();
    assert!(
        exact_count >= 14,
        "{exact_count}/15 right at 0.3 %: {heavy:?}"
    );
    assert!(
        near_depth >= 13,
        "{near_depth}/15 within 2× at 0.3 %: {heavy:?}"
    );
    for (want, got, ratio, drawn) in &heavy {
        assert!(*got <= want + 1, "{heavy:?}");
        assert!((0.25..=6.0).contains(ratio), "{heavy:?}");
        assert!(*drawn < 8.0, "{heavy:?}");
    }
}

#[test]
fn lifted_angles_are_reported_within_a_turn() {
    // A circle arc drawn with a little noise: the helix seen along its
    // axis, where the fit's tilt wandered as far as 29.8 rad (the same
    // helix as 29.8 − 10π, but not what a reader of the output expects),
    // and a straight stroke (−5.2 rad). Every tilt and rotation comes back
    // in (−π, π]. (Before: 5 of the 7 noisy lifts here out of it, four of
    // them arcs.)
    let arc: Vec<DVec2> = (0..500)
        .map(|k| 100.0 * DVec2::from_angle(0.01 * k as f64))
        .collect();
    let line: Vec<DVec2> = (0..500).map(|k| DVec2::new(k as f64, 0.0)).collect();
    let o = SketchOptions::default();
    let mut lifts = 0;
    for (d, seed, sigma) in [
        (&arc, 0, 0.0),
        (&arc, 1, 0.002),
        (&arc, 3, 0.005),
        (&arc, 5, 0.02),
        (&arc, 11, 0.002),
        (&arc, 2, 0.5),
        (&line, 0, 0.0),
        (&line, 10, 0.1),
        (&line, 3, 0.5),
    ] {
        {
            let r = lift_sketch(&with_noise(d, sigma, seed), &o).unwrap();
            for h in &r.helices {
                assert!(h.helix.c > -PI && h.helix.c <= PI, "σ {sigma}: {h:?}");
                assert!(h.theta > -PI && h.theta <= PI, "σ {sigma}: {h:?}");
            }
            lifts += 1;
        }
    }
    assert_eq!(lifts, 9);
}

#[test]
fn a_straight_stroke_is_lifted_flat() {
    // Any tilt of a line projects to a straight stroke: the drawing does
    // not show a depth, and the lift takes none (`flattened`). Before, the
    // fit's steps wandered along that valley: these five came back 0.03
    // (no noise), 0.76, 0.87, 0.48 and 0.08 times the stroke's length
    // deep; now under 1e-4 (the bound 1e-3).
    let line: Vec<DVec2> = (0..500).map(|k| DVec2::new(k as f64, 0.0)).collect();
    let o = SketchOptions::default();
    let mut depths = Vec::new();
    for (seed, sigma) in [(0, 0.0), (1, 0.005), (2, 0.05), (3, 0.2), (4, 0.5)] {
        let r = lift_sketch(&with_noise(&line, sigma, seed), &o).unwrap();
        assert_eq!(r.helices.len(), 1, "σ {sigma}");
        depths.push(depth(&r) / r.length);
        // Drawn as closely as before the flattening: within a few σ.
        assert!(
            r.drawn_error <= 8.0 * sigma + 1e-9 * r.length,
            "σ {sigma}: {}",
            r.drawn_error
        );
    }
    assert!(depths.iter().all(|&d| d < 1e-3), "{depths:?}");
}

#[test]
fn lightly_noisy_drawings_keep_their_helices_and_depth() {
    // Issue 22: from no noise to 0.03 % of the length, each drawing comes
    // back as the helices drawn, at the exact drawing's depth, every drawn
    // vertex within a few σ of the lift (or within a tenth of E_max, which
    // stays at its floor of 0.1 % of the length up to 0.02 % of noise).
    // Measured (benches/sketch_noise.rs, 16 seeds at each level, 400
    // lifts at 0–0.03 %, docs/reference.md): the count right on 398 (three
    // curls at 0.03 %, 14 of 16), the depth within 0.95–1.05× but on one
    // lift (2.6×, three curls at 0.03 %, seed 1), drawn vertices within
    // 7.6σ. These are seed 0: 0.95–1.03×, within 4.3σ.
    use rayon::prelude::*;
    let drawings = benchmark_drawings();
    let o = SketchOptions::default();
    let exact: Vec<(usize, f64)> = drawings
        .par_iter()
        .map(|(_, d)| {
            let r = lift_sketch(d, &o).unwrap();
            (r.helices.len(), depth(&r))
        })
        .collect();
    for ((want, _), (got, _)) in drawings.iter().zip(&exact) {
        assert_eq!(want, got, "the exact drawings");
    }
    let noises = [1e-5, 1e-4, 3e-4];
    let runs: Vec<(usize, f64, usize, f64, f64)> = (0..drawings.len() * noises.len())
        .into_par_iter()
        .map(|n| {
            let (i, noise) = (n / noises.len(), noises[n % noises.len()]);
            let (helices, d) = &drawings[i];
            let sigma = noise * polyline_length(d);
            let r = lift_sketch(&with_noise(d, sigma, 0), &o).unwrap();
            let drawn = r.drawn_error / sigma.max(r.emax / 80.0);
            (
                *helices,
                noise,
                r.helices.len(),
                depth(&r) / exact[i].1,
                drawn,
            )
        })
        .collect();
    for (want, noise, got, ratio, drawn) in &runs {
        assert_eq!(want, got, "{noise}: {runs:?}");
        assert!((0.8..=1.25).contains(ratio), "{noise}: {runs:?}");
        assert!(*drawn < 8.0, "{noise}: {runs:?}");
    }
}

#[test]
fn a_curl_cut_at_its_blurred_near_cusp_is_one_helix() {
    // The third curl of this drawing is tilted so that its projection
    // nearly turns back a quarter turn before its end; at 0.1 % noise the
    // walk's feet past that near-cusp fell on the branch it came by, and
    // the last 22–24 vertices came back as a helix of their own (seeds 0
    // and 4 of benches/sketch_noise.rs: 4 helices). The union, refitted
    // with each foot at the curve's nearest point, is one helix by the
    // drawn vertices' residuals.
    use strandfit::synthetic::synthetic_sketch_curls;
    let d = synthetic_sketch_curls(500, 3);
    let exact = depth(&lift_sketch(&d, &SketchOptions::default()).unwrap());
    let sigma = 1e-3 * polyline_length(&d);
    for seed in [0, 4] {
        let r = lift_sketch(&with_noise(&d, sigma, seed), &SketchOptions::default()).unwrap();
        let ratio = depth(&r) / exact;
        assert_eq!(r.helices.len(), 3, "seed {seed}: depth {ratio:.2}");
        assert!((0.5..=2.0).contains(&ratio), "seed {seed}: {ratio}");
        assert!(
            r.drawn_error < 5.0 * sigma,
            "seed {seed}: {}",
            r.drawn_error / sigma
        );
    }
}

#[test]
fn a_curl_taken_by_a_flat_arc_is_found_from_a_confident_seed() {
    // Issue 22: at 0.1 % noise the covering of this drawing grew, from the
    // seed of largest curvature, a flat arc across the third curl (or a
    // helix across the corner before it) that stayed within E_max, and the
    // curl came back as two helices, one 2–3× too deep (seeds 3, 7, 9 and
    // 10 of benches/sketch_noise.rs). A piece is now taken for the helix
    // drawn only where its vertices' RMS distance is within the noise left
    // (CONFIDENT_RMS); until one is, more seeds are tried.
    let runs = noisy_curls(3, 1e-3, &[3, 7, 9, 10]);
    for (seed, count, ratio, drawn) in &runs {
        assert_eq!(*count, 3, "seed {seed}: {runs:?}");
        assert!((0.5..=2.0).contains(ratio), "seed {seed}: {runs:?}");
        // Every drawn vertex within a few σ (measured: 3.1–5.9).
        assert!(*drawn < 8.0, "seed {seed}: {runs:?}");
    }
}

#[test]
fn four_curls_at_a_thousandth_of_noise_come_back_as_four_helices_of_their_depth() {
    // Issue 22's four-helix drawing at 0.1 % noise, the benchmark's first
    // eight seeds. Measured 2026-11-29: 8 of 8 with four helices and the
    // depth within 2× of the exact drawing's; before slivers were absorbed
    // ahead of the junction slides, seed 5 came back 3.7× too deep (a
    // slide grew the sliver at the third corner into a piece across it).
    // At least 7 of 8: the lift's outcome on about one noisy drawing in
    // twenty is decided by last-bit rounding (see the test above).
    use rayon::prelude::*;
    use strandfit::synthetic::synthetic_sketch_curls;
    let d = synthetic_sketch_curls(500, 4);
    let exact = depth(&lift_sketch(&d, &SketchOptions::default()).unwrap());
    let sigma = 1e-3 * polyline_length(&d);
    let runs: Vec<(u64, usize, f64)> = (0u64..8)
        .into_par_iter()
        .map(|seed| {
            let r = lift_sketch(&with_noise(&d, sigma, seed), &SketchOptions::default()).unwrap();
            (seed, r.helices.len(), depth(&r) / exact)
        })
        .collect();
    let right = runs
        .iter()
        .filter(|(_, n, ratio)| *n == 4 && (0.5..=2.0).contains(ratio))
        .count();
    assert!(right >= 7, "{right}/8 right: {runs:?}");
}

#[test]
fn a_deeper_helix_across_a_curl_is_refitted_from_the_seeds_fits() {
    // Issue 22: at 0.1 % noise the covering took, across a curl seen
    // nearly edge-on, a helix deeper than drawn that stays within E_max
    // (0.15–0.19 E_max RMS): four curls, seeds 12, 16 and 32 of
    // benches/sketch_noise.rs, came back with four helices but 2.1–2.8×
    // the exact depth; three curls, seed 46, with four helices 2.2× too
    // deep. A piece over CONFIDENT_RMS is now refitted over its vertices
    // from the fits the covering made from seeds inside it, and the
    // closest kept.
    for (curls, seeds) in [(4, &[12u64, 16, 32][..]), (3, &[46][..])] {
        let runs = noisy_curls(curls, 1e-3, seeds);
        for (seed, count, ratio, drawn) in &runs {
            assert_eq!(*count, curls, "{curls} curls, seed {seed}: {runs:?}");
            assert!(
                (0.5..=2.0).contains(ratio),
                "{curls} curls, seed {seed}: {runs:?}"
            );
            // Every drawn vertex within a few σ.
            assert!(*drawn < 8.0, "{curls} curls, seed {seed}: {runs:?}");
        }
    }
}

#[test]
fn the_fine_fit_does_not_deepen_a_piece_into_another_helix() {
    // Issue 22: at 0.3 % noise the covering of the three-curl drawing had
    // the second curl right (depth slope 0.3), and the fine fit's tangent
    // term pulled it to a helix of slope 2.4–2.8 that meets its
    // neighbours' tangents: seeds 5, 9, 11, 18 and 40 of
    // benches/sketch_noise.rs came back 2.0–3.7× too deep. A piece the
    // fine fit makes over DEEPENED times steeper keeps its covering fit.
    // No lift is deeper than 2× (what this guards); the depth within 2×
    // both ways and the helix count, which rounding in the covering's
    // searches can tip at this noise, on all but one (seed 18 came back
    // as four helices once the searches' sines were computed inline; seed
    // 9 at 0.49× the exact depth once the two-vertex fits were made by
    // least squares, 0.69× or 1.01× with other caps on their evaluations).
    let runs = noisy_curls(3, 3e-3, &[5, 9, 11, 18, 40]);
    for (seed, _, ratio, drawn) in &runs {
        assert!(*ratio <= 2.0, "seed {seed}: {runs:?}");
        assert!(*drawn < 8.0, "seed {seed}: {runs:?}");
    }
    let within = runs
        .iter()
        .filter(|(_, _, ratio, _)| (0.5..=2.0).contains(ratio))
        .count();
    assert!(within >= 4, "{runs:?}");
    let counted = runs.iter().filter(|(_, count, _, _)| *count == 3).count();
    assert!(counted >= 4, "{runs:?}");
}

/// A stroke as a hand and a screen draw it: `d` scaled to `pixels` of
/// length, wobbled along its length (three slow sines, at most about
/// `wobble` pixels off) and rounded to whole pixels.
fn hand_drawn(d: &[DVec2], pixels: f64, wobble: f64) -> Vec<DVec2> {
    let scale = pixels / polyline_length(d);
    let n = d.len();
    d.iter()
        .enumerate()
        .map(|(k, &p)| {
            let s = k as f64 / (n - 1) as f64;
            let w = |f: f64, phase: f64| (TAU * f * s + phase).sin();
            let off = DVec2::new(
                0.5 * w(1.3, 0.4) + 0.3 * w(2.9, 2.0) + 0.2 * w(4.1, 1.1),
                0.5 * w(1.7, 1.3) + 0.3 * w(3.3, 0.2) + 0.2 * w(5.3, 2.6),
            );
            (p * scale + wobble * off).round()
        })
        .collect()
}

#[test]
fn hand_drawn_strokes_are_lifted_to_their_helices() {
    // Issue 22: a slow wobble of a pixel or two and pixel rounding, on
    // strokes of 600 pixels drawn from one to four helices.
    use strandfit::synthetic::{synthetic_sketch, synthetic_sketch_curls};
    let o = SketchOptions::default();
    for (want, d) in [
        (1, synthetic_sketch_curls(500, 1)),
        (2, synthetic_sketch_curls(500, 2)),
        (2, synthetic_sketch(500)),
        (3, synthetic_sketch_curls(500, 3)),
        (4, synthetic_sketch_curls(500, 4)),
    ] {
        let exact = depth(&lift_sketch(&d, &o).unwrap()) / polyline_length(&d);
        for wobble in [1.0, 2.0] {
            let drawn = hand_drawn(&d, 600.0, wobble);
            let r = lift_sketch(&drawn, &o).unwrap();
            let ratio = depth(&r) / r.length / exact;
            let what = format!(
                "{want} helices, wobble {wobble} px: {} helices, depth {ratio:.2}× the exact's, noise {:.2} px, E_max {:.2} px, drawn error {:.2} px",
                r.helices.len(),
                r.noise,
                r.emax,
                r.drawn_error
            );
            eprintln!("{what}");
            // Measured (2026-11-30): the count exact on 7 of 10 (one too
            // many on the others), the depth within 0.71–1.33× the exact
            // drawing's, every pixel within 1.7 px of the fit; the noise
            // found is about the rounding's (uniform over a pixel:
            // 0.29 px), 0.31–0.34 px.
            assert!(r.denoised, "{what}");
            assert!((want..=want + 1).contains(&r.helices.len()), "{what}");
            assert!((0.67..=1.5).contains(&ratio), "{what}");
            assert!(r.drawn_error < 1.5 * wobble + 0.75, "{what}");
            assert!((0.2..0.5).contains(&r.noise), "{what}");
        }
    }
}

#[test]
fn an_emax_given_overrides_the_noise() {
    use strandfit::synthetic::synthetic_sketch_curls;
    let d = synthetic_sketch_curls(300, 1);
    let sigma = 1e-3 * polyline_length(&d);
    let noisy = with_noise(&d, sigma, 0);
    let auto = lift_sketch(&noisy, &SketchOptions::default()).unwrap();
    assert!(auto.emax > 4.0 * sigma, "{} vs σ {sigma}", auto.emax);
    let given = SketchOptions {
        emax: Some(2e-2),
        ..Default::default()
    };
    let r = lift_sketch(&noisy, &given).unwrap();
    assert_eq!(r.emax, 2e-2 * r.length);
    assert!(r.noise > 0.0);
    // An exact drawing keeps the paper's 0.1 %.
    let r = lift_sketch(&d, &SketchOptions::default()).unwrap();
    assert_eq!(r.emax, 1e-3 * r.length);
}

#[test]
fn noisy_coils_are_never_lifted_far_deeper_than_drawn() {
    // Issue 22, "never wild ones": at 0.3 % noise the second coil of this
    // drawing was fitted by helices seen nearly end-on, whose depth the
    // noise leaves undetermined, every vertex within E_max: seeds 11, 15,
    // 16, 20, 29, 37 and 47 of benches/sketch_noise.rs came back 10–25
    // times the exact drawing's depth, one piece 8 times deeper than its
    // drawn length. A plausible helix is now at most 3 times deeper than
    // its drawn length, and no step of the covering makes a plausible
    // piece implausible. Measured 2026-11-29: 1.1–7.5 times the exact
    // depth, no helix over 3.6 times deeper than its drawn length, every
    // drawn vertex within 7.3 σ.
    use rayon::prelude::*;
    use strandfit::synthetic::synthetic_sketch;
    let d = synthetic_sketch(500);
    let o = SketchOptions::default();
    let exact = depth(&lift_sketch(&d, &o).unwrap());
    let sigma = 3e-3 * polyline_length(&d);
    let runs: Vec<(u64, usize, f64, f64, f64)> = [11u64, 15, 16, 20, 29, 37, 47]
        .into_par_iter()
        .map(|seed| {
            let r = lift_sketch(&with_noise(&d, sigma, seed), &o).unwrap();
            // Each helix's depth over the length it draws, sampled finely.
            let steepest = r
                .helices
                .iter()
                .map(|h| {
                    let m = 400;
                    let ts: Vec<f64> = (0..=m)
                        .map(|k| h.t_start + (h.t_end - h.t_start) * k as f64 / m as f64)
                        .collect();
                    let drawn: Vec<DVec2> = ts.iter().map(|&t| h.point_2d(t)).collect();
                    spread(ts.iter().map(|&t| h.point_3d(t).z)) / polyline_length(&drawn)
                })
                .fold(0.0, f64::max);
            (
                seed,
                r.helices.len(),
                depth(&r) / exact,
                steepest,
                r.drawn_error / sigma,
            )
        })
        .collect();
    for (seed, count, ratio, steepest, drawn) in &runs {
        assert!(*count <= 4, "seed {seed}: {runs:?}");
        assert!(*ratio < 8.0, "seed {seed}: {runs:?}");
        // (The covering bounds the slope measured at the vertices' feet,
        // 3; sampled finely the curve measured up to 3.6.)
        assert!(*steepest < 4.0, "seed {seed}: {runs:?}");
        assert!(*drawn < 8.0, "seed {seed}: {runs:?}");
    }
}

/// The drawing of `lift_sketch`'s example: the projections of two helices,
/// the second starting where the first ends with a corner of 0.6 rad, each
/// sampled evenly along its length; 43 vertices, the corner at vertex 24.
/// Coarse: the first helix's curvature is greatest at its first vertex.
fn coarse_two_helices() -> Vec<DVec2> {
    use strandfit::sketch::{resample, PlacedHelix};
    let a = PlacedHelix::from_params(&[0.0, 0.0, 0.0, 1.0, 0.3, 0.8], false);
    let turn = a.derivative(3.0).to_angle() + 0.6 - std::f64::consts::FRAC_PI_2;
    let end = a.point(3.0);
    let b = PlacedHelix::from_params(&[turn, end.x, end.y, 0.7, 0.1, 1.0], true);
    let dense = |h: &PlacedHelix| -> Vec<DVec2> {
        (0..=1000)
            .map(|k| h.point(3.0 * k as f64 / 1000.0))
            .collect()
    };
    let (da, db) = (dense(&a), dense(&b));
    let nb = (25.0 * polyline_length(&db) / polyline_length(&da)).round() as usize;
    let mut d = resample(&da, 25);
    d.extend(resample(&db, nb + 1).into_iter().skip(1));
    assert_eq!(d.len(), 43);
    d
}

/// `d` turned by `angle` about the origin.
fn turned(d: &[DVec2], angle: f64) -> Vec<DVec2> {
    let r = DVec2::from_angle(angle);
    d.iter().map(|&p| r.rotate(p)).collect()
}

#[test]
fn an_exact_drawing_turned_is_lifted_the_same() {
    // Turning a drawing changes nothing but rounding, yet this one's first
    // helix came back split in two at 14 of these 60 angles (2026-11-30):
    // the growth from the seed stopped on a helix that fits its stretch
    // within 0.3 E_max and is not the one drawn (restarts from the radius
    // scaled did not leave it), the rest of the stretch was covered by
    // another such helix, and the merge of the two got stuck as well. A
    // clean drawing's stuck growth is now restarted from the pitch scaled
    // too (`PITCH_HOP_ABOVE` in src/sketch/cover.rs): all 60 the same.
    use rayon::prelude::*;
    let d = coarse_two_helices();
    let spans: Vec<(usize, Vec<(usize, usize)>)> = (0..60)
        .into_par_iter()
        .map(|k| {
            let r = lift_sketch(&turned(&d, 0.1 * k as f64), &SketchOptions::default()).unwrap();
            (k, r.helices.iter().map(|h| (h.first, h.last)).collect())
        })
        .collect();
    let wrong: Vec<_> = spans
        .iter()
        .filter(|(_, s)| s != &[(0, 24), (24, 42)])
        .collect();
    assert!(wrong.is_empty(), "{wrong:?}");
}

#[test]
fn coarse_coils_turned_are_mostly_lifted_to_two_helices() {
    // The two-coil drawing of benches/sketch_noise.rs, exact but drawn with
    // 60 vertices instead of 500, at 24 angles. Measured 2026-11-30: two
    // helices at 5 of the angles with restarts from the radius alone, at
    // 19 with the pitch's too; the rest come back as three, the second
    // coil split between two helices that each fit within E_max and are
    // neither the one drawn (at 120 vertices: 0 and 11 of 24). Such pieces
    // are now refitted (the test below: 24 of 24 at 120 vertices), but at
    // 60 the same 19 of 24: below 1 % of E_max in RMS a piece is not
    // refitted, and the split pieces here fit closer than that.
    use rayon::prelude::*;
    use strandfit::synthetic::synthetic_sketch;
    let d = synthetic_sketch(60);
    let counts: Vec<usize> = (0..24)
        .into_par_iter()
        .map(|k| {
            let r = lift_sketch(&turned(&d, 0.26 * k as f64), &SketchOptions::default()).unwrap();
            r.helices.len()
        })
        .collect();
    let two = counts.iter().filter(|&&c| c == 2).count();
    assert!(two >= 16, "{counts:?}");
    assert!(counts.iter().all(|&c| c <= 3), "{counts:?}");
}

#[test]
fn coarse_drawings_turned_are_refitted_to_the_drawn_helices() {
    // Exact drawings sampled coarsely, turned: the two coils at 120
    // vertices came back as three helices at 15 of 24 angles, three curls
    // at 80 vertices as four or more at 21 of 24 (2026-11-30), each
    // covering a stretch within E_max without being the drawn helix. On a
    // clean drawing a piece over CLEAN_REFIT_RMS is now fitted again from
    // fresh seeds inside it, and the passes run again: 24 and 21 of 24
    // right. Here every other of those angles, with a floor one under
    // what was measured on them (12 and 9 of 12; before, 7 and 3).
    use rayon::prelude::*;
    use strandfit::synthetic::{synthetic_sketch, synthetic_sketch_curls};
    let cases = [
        (2usize, synthetic_sketch(120), 11),
        (3, synthetic_sketch_curls(80, 3), 8),
    ];
    for (want, d, floor) in &cases {
        let counts: Vec<usize> = (0..12)
            .into_par_iter()
            .map(|k| {
                let r =
                    lift_sketch(&turned(d, 0.52 * k as f64), &SketchOptions::default()).unwrap();
                r.helices.len()
            })
            .collect();
        let right = counts.iter().filter(|&&c| c == *want).count();
        assert!(
            right >= *floor,
            "{want} helices drawn: {right} right, {counts:?}"
        );
    }
}
