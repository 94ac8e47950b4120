use super::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton on Pₙ).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 0.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        out.push((x, 2.0 / ((1.0 - x * x) * dp * dp)));
    }
    out
}

/// ∫₀¹ tᵏ (cos, sin)(a t²/2 + b t + c) dt by composite 20-point Gauss–Legendre.
fn quad(k: i32, a: f64, b: f64, c: f64) -> (f64, f64) {
    let gl = gauss_legendre(20);
    let panels = 40 + (a.abs() + b.abs()) as usize;
    let h = 1.0 / panels as f64;
    let (mut sx, mut sy) = (0.0, 0.0);
    for p in 0..panels {
        let m = (p as f64 + 0.5) * h;
        for &(x, w) in &gl {
            let t = m + 0.5 * h * x;
            let th = 0.5 * a * t * t + b * t + c;
            let tk = t.powi(k);
            sx += w * 0.5 * h * tk * th.cos();
            sy += w * 0.5 * h * tk * th.sin();
        }
    }
    (sx, sy)
}

/// (x, C(x), S(x)) from mpmath (`fresnelc`, `fresnels`, 30 digits).
const FRESNEL_REF: [(f64, f64, f64); 16] = [
    (1e-09, 1.0000000000000000623e-9, 5.2359877559829897091e-28),
    (0.1, 0.099997532627085073601, 0.00052358954761221068668),
    (0.5, 0.49234422587144639288, 0.064732432859999277611),
    (1.0, 0.77989340037682282947, 0.43825914739035476608),
    (1.49, 0.45458652017763682046, 0.70111322499827987102),
    (1.5, 0.44526117603982153506, 0.69750496008209301308),
    (1.51, 0.43611616803601728632, 0.69346142191597614687),
    (2.0, 0.4882534060753407545, 0.3434156783636982422),
    (3.0, 0.60572078929768562956, 0.4963129989673750361),
    (4.5, 0.52602591505353874137, 0.43427297504870358947),
    (5.0, 0.5636311887040122311, 0.49919138191711688675),
    (7.3, 0.53926801565846248225, 0.51894732785814429068),
    (10.0, 0.49989869420551572361, 0.4681699785848822404),
    (30.0, 0.49999624737060988691, 0.48938967444219379679),
    (100.0, 0.49999989867881789756, 0.49681690114783755327),
    (1000.0, 0.49999999989867881636, 0.49968169011381630608),
];

#[test]
fn fresnel_cs_matches_reference_values() {
    let mut worst: f64 = 0.0;
    for &(x, rc, rs) in &FRESNEL_REF {
        for sign in [1.0, -1.0] {
            let (c, s) = fresnel_cs(sign * x);
            let e = (c - sign * rc).abs().max((s - sign * rs).abs());
            worst = worst.max(e);
            assert!(e < 2e-15, "x = {}: C {c} vs {rc}, S {s} vs {rs}", sign * x);
        }
    }
    // Quadrature cross-check at moderate x (x C(x) form, to test the harness too).
    for &x in &[0.7, 1.2, 2.2, 4.0] {
        let (qc, qs) = quad(0, PI * x * x, 0.0, 0.0);
        let (c, s) = fresnel_cs(x);
        assert!((c - x * qc).abs() < 1e-14 && (s - x * qs).abs() < 1e-14);
    }
    assert_eq!(fresnel_cs(0.0), (0.0, 0.0));
    eprintln!("fresnel_cs worst abs error vs mpmath: {worst:e}");
}

#[test]
fn generalized_fresnel_matches_quadrature() {
    let avals = [
        0.0, 1e-8, -1e-8, 1e-3, 0.3, -0.99, 1.0, -1.5, 3.0, 3.999_999, 4.0, -4.0, 10.0, -37.0,
        100.0, -100.0, 1e3, 1e4, -1e4,
    ];
    let bvals = [0.0, 1e-7, 0.7, -2.5, 5.0, -13.0, 40.0];
    let cvals = [0.0, 1.0, -2.9];
    let mut worst: f64 = 0.0;
    for &a in &avals {
        for &b in &bvals {
            for &c in &cvals {
                let (x, y) = generalized_fresnel(a, b, c);
                for k in 0..3 {
                    let (qx, qy) = quad(k as i32, a, b, c);
                    let e = (x[k] - qx).abs().max((y[k] - qy).abs());
                    worst = worst.max(e);
                    assert!(
                        e < 1e-13,
                        "a={a} b={b} c={c} k={k}: ({}, {}) vs ({qx}, {qy}), err {e:e}",
                        x[k],
                        y[k]
                    );
                }
            }
        }
    }
    eprintln!("generalized_fresnel worst abs error vs quadrature: {worst:e}");
}

#[test]
fn generalized_fresnel_continuous_across_branch() {
    // |a| = A_SERIES switches from the series to the Fresnel form.
    for &b in &[0.0, 0.3, -4.0, 25.0] {
        for &a in &[A_SERIES, -A_SERIES] {
            let (x0, y0) = generalized_fresnel(a * (1.0 - 1e-14), b, 0.4);
            let (x1, y1) = generalized_fresnel(a, b, 0.4);
            for k in 0..3 {
                let e = (x0[k] - x1[k]).abs().max((y0[k] - y1[k]).abs());
                assert!(e < 5e-14, "b={b} a={a} k={k}: {e:e}");
            }
        }
    }
}

fn ang_diff(a: f64, b: f64) -> f64 {
    normalize_angle(a - b).abs()
}

fn assert_same_curve(a: &Clothoid, b: &Clothoid, tol: f64) {
    let scale = a.length;
    for i in 0..=16 {
        let s = a.length * i as f64 / 16.0;
        let sb = b.length * i as f64 / 16.0;
        let d = (a.eval(s) - b.eval(sb)).length();
        assert!(
            d <= tol * scale,
            "points differ at {i}/16 by {d:e}: {a:?} vs {b:?}"
        );
    }
}

#[test]
fn round_trip_random_clothoids() {
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let (mut tried, mut kept) = (0, 0);
    let mut worst: f64 = 0.0;
    while kept < 400 {
        tried += 1;
        let len = 10f64.powf(rng.gen_range(-2.0..2.0));
        // dimensionless κ₀L and κ′L²
        let k0l: f64 = rng.gen_range(-4.0..4.0);
        let dkl2: f64 = rng.gen_range(-8.0..8.0);
        let truth = Clothoid {
            start: DVec2::new(rng.gen_range(-50.0..50.0), rng.gen_range(-50.0..50.0)),
            theta0: rng.gen_range(-PI..PI),
            kappa0: k0l / len,
            dkappa: dkl2 / (len * len),
            length: len,
        };
        // Keep curves whose tangent stays within (−π, π) of the chord
        // direction all along (no loops): the solution class of the paper.
        let p1 = truth.end();
        let phi = (p1 - truth.start).to_angle();
        let mut ok = true;
        for i in 0..=200 {
            let s = len * i as f64 / 200.0;
            let rel = truth.angle(s) - phi;
            let rel0 = normalize_angle(truth.theta0 - phi);
            let off = rel - (truth.theta0 - phi) + rel0;
            if off.abs() >= PI * 0.98 {
                ok = false;
            }
        }
        if !ok {
            continue;
        }
        kept += 1;
        let th1 = truth.angle(len);
        let fit = clothoid_g1(truth.start, truth.theta0, p1, th1).expect("solve");
        let rel = |x: f64, y: f64, s: f64| (x - y).abs() / s;
        let e = [
            rel(fit.length, len, len),
            rel(fit.kappa0 * len, truth.kappa0 * len, 1.0 + k0l.abs()),
            rel(
                fit.dkappa * len * len,
                truth.dkappa * len * len,
                1.0 + dkl2.abs(),
            ),
            ang_diff(fit.theta0, truth.theta0),
        ];
        for (i, &ei) in e.iter().enumerate() {
            worst = worst.max(ei);
            assert!(
                ei < 1e-10,
                "param {i} err {ei:e}: truth {truth:?} fit {fit:?}"
            );
        }
        assert_same_curve(&truth, &fit, 1e-10);
        assert!((fit.end() - p1).length() < 1e-11 * len.max(p1.length()));
        assert!(ang_diff(fit.angle(fit.length), th1) < 1e-11);
    }
    eprintln!("round trip: kept {kept} of {tried}, worst relative parameter error {worst:e}");
}

#[test]
fn collinear_is_straight() {
    let p0 = DVec2::new(1.0, 2.0);
    let p1 = DVec2::new(4.0, 6.0);
    let phi = (p1 - p0).to_angle();
    let c = clothoid_g1(p0, phi, p1, phi).unwrap();
    assert_eq!(c.kappa0, 0.0);
    assert_eq!(c.dkappa, 0.0);
    assert!((c.length - 5.0).abs() < 1e-14);
    assert!((c.eval(2.5) - DVec2::new(2.5, 4.0)).length() < 1e-14);
}

#[test]
fn circle_data_gives_circle() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut worst: f64 = 0.0;
    for _ in 0..200 {
        let r: f64 = 10f64.powf(rng.gen_range(-1.0..1.0));
        let centre = DVec2::new(rng.gen_range(-5.0..5.0), rng.gen_range(-5.0..5.0));
        let a0: f64 = rng.gen_range(-PI..PI);
        let sweep: f64 = rng.gen_range(0.05..1.9 * PI) * if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
        let a1 = a0 + sweep;
        let p0 = centre + r * DVec2::from_angle(a0);
        let p1 = centre + r * DVec2::from_angle(a1);
        let turn = sweep.signum() * FRAC_PI_2;
        let c = clothoid_g1(p0, a0 + turn, p1, a1 + turn).unwrap();
        let l = r * sweep.abs();
        let e = [
            c.dkappa.abs() * l * l,
            (c.kappa0 * r - sweep.signum()).abs(),
            (c.length - l).abs() / l,
        ];
        for (i, &ei) in e.iter().enumerate() {
            worst = worst.max(ei);
            assert!(
                ei < 1e-10,
                "quantity {i}: {ei:e}, r {r}, sweep {sweep}: {c:?}"
            );
        }
        let mid = c.eval(0.5 * c.length);
        assert!(((mid - centre).length() - r).abs() < 1e-10 * r);
    }
    eprintln!("circle: worst κ′L², |κ₀R − 1|, ΔL/L = {worst:e}");
}

#[test]
fn reversal_symmetry() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for _ in 0..200 {
        let p0 = DVec2::new(rng.gen_range(-3.0..3.0), rng.gen_range(-3.0..3.0));
        let p1 = DVec2::new(rng.gen_range(-3.0..3.0), rng.gen_range(-3.0..3.0));
        let (t0, t1) = (rng.gen_range(-PI..PI), rng.gen_range(-PI..PI));
        let f = clothoid_g1(p0, t0, p1, t1).unwrap();
        let b = clothoid_g1(p1, t1 + PI, p0, t0 + PI).unwrap();
        let fl = f.length;
        assert!((b.length - fl).abs() < 1e-10 * fl);
        assert!(
            (b.kappa0 + f.kappa0 + f.dkappa * fl).abs() * fl < 1e-9,
            "{f:?} {b:?}"
        );
        assert!((b.dkappa - f.dkappa).abs() * fl * fl < 1e-9);
        assert!(ang_diff(b.theta0, f.angle(fl) + PI) < 1e-10);
        assert_same_curve(&f.reversed(), &b, 1e-10);
    }
}

#[test]
fn similarity_invariance() {
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    for _ in 0..200 {
        let p0 = DVec2::new(rng.gen_range(-3.0..3.0), rng.gen_range(-3.0..3.0));
        let p1 = DVec2::new(rng.gen_range(-3.0..3.0), rng.gen_range(-3.0..3.0));
        let (t0, t1) = (rng.gen_range(-PI..PI), rng.gen_range(-PI..PI));
        let rot: f64 = rng.gen_range(-PI..PI);
        let k: f64 = 10f64.powf(rng.gen_range(-3.0..3.0));
        let sh = DVec2::new(rng.gen_range(-100.0..100.0), rng.gen_range(-100.0..100.0));
        let map = |p: DVec2| sh + k * DVec2::from_angle(rot).rotate(p);
        let f = clothoid_g1(p0, t0, p1, t1).unwrap();
        let g = clothoid_g1(map(p0), t0 + rot, map(p1), t1 + rot).unwrap();
        let fl = f.length;
        assert!((g.length - k * fl).abs() < 1e-10 * k * fl);
        assert!((g.kappa0 * k - f.kappa0).abs() * fl < 1e-9);
        assert!((g.dkappa * k * k - f.dkappa).abs() * fl * fl < 1e-9);
        assert!(ang_diff(g.theta0, f.theta0 + rot) < 1e-10);
        for i in 0..=8 {
            let s = fl * i as f64 / 8.0;
            let d = (g.eval(k * s) - map(f.eval(s))).length();
            assert!(d < 1e-9 * k * fl.max(1.0) + 1e-12 * sh.length(), "{d:e}");
        }
    }
}

#[test]
fn bad_input_is_an_error() {
    let p = DVec2::new(1.0, 1.0);
    assert_eq!(
        clothoid_g1(p, 0.0, p, 1.0),
        Err(ClothoidError::CoincidentPoints)
    );
    let q = DVec2::new(2.0, 1.0);
    assert_eq!(
        clothoid_g1(p, f64::NAN, q, 1.0),
        Err(ClothoidError::NonFinite)
    );
    assert_eq!(
        clothoid_g1(p, 0.0, q, f64::INFINITY),
        Err(ClothoidError::NonFinite)
    );
    assert_eq!(
        clothoid_g1(DVec2::new(f64::NAN, 0.0), 0.0, q, 0.0),
        Err(ClothoidError::NonFinite)
    );
    assert_eq!(
        clothoid_g1(
            DVec2::new(-1e308, 1e308),
            0.0,
            DVec2::new(1e308, -1e308),
            0.0
        ),
        Err(ClothoidError::NonFinite)
    );
    assert_eq!(
        clothoid_g1(p, 0.0, p + DVec2::new(1e-17, 0.0), 0.0),
        Err(ClothoidError::CoincidentPoints)
    );
    // Extreme but valid angles: both tangents pointing back along the chord.
    for &(a, b) in &[(PI, PI), (PI, -PI), (PI, 0.0), (-3.0, 3.0), (3.1, 3.1)] {
        let r = clothoid_g1(DVec2::ZERO, a, DVec2::X, b);
        if let Ok(c) = r {
            assert!((c.end() - DVec2::X).length() < 1e-10, "{a} {b}: {c:?}");
        }
    }
}

/// The whole angle domain: every (φ₀, φ₁) on a grid of (−π, π]² (ends
/// included) is solved, and the clothoid meets both end conditions.
#[test]
fn angle_domain_grid_interpolates() {
    let n = 60;
    let mut worst: f64 = 0.0;
    let mut failed = Vec::new();
    let mut max_a: f64 = 0.0;
    for i in 0..=n {
        for j in 0..=n {
            let p0 = -PI + TAU * i as f64 / n as f64;
            let p1 = -PI + TAU * j as f64 / n as f64;
            let before = SAFEGUARD_USED.with(|c| c.get());
            let res = clothoid_g1(DVec2::ZERO, p0, DVec2::X, p1);
            if SAFEGUARD_USED.with(|c| c.get()) > before {
                eprintln!(
                    "safeguard at φ = ({p0:.4}, {p1:.4}) -> {:?}",
                    res.map(|c| 0.5 * c.dkappa * c.length * c.length)
                );
            }
            match res {
                Ok(c) => {
                    let e = (c.end() - DVec2::X)
                        .length()
                        .max(ang_diff(c.angle(c.length), p1));
                    worst = worst.max(e);
                    assert!(e < 1e-12, "φ = ({p0}, {p1}): residual {e:e}, {c:?}");
                    // no extra loops: total |turning| below 4π
                    let a = 0.5 * c.dkappa * c.length * c.length;
                    assert!(a.abs() < 4.0 * TAU, "φ = ({p0}, {p1}): A = {a}");
                    // A has the sign of φ₀ + φ₁ (A = 0: circle arc or segment).
                    let (n0, n1) = (normalize_angle(p0), normalize_angle(p1));
                    assert!(a * (n0 + n1) >= -1e-12, "φ = ({p0}, {p1}): A = {a}");
                    assert!(
                        a.abs() <= 3.0 * (n0 + n1).abs() + 1e-9,
                        "φ = ({p0}, {p1}): A = {a}"
                    );
                    if (n0 + n1).abs() > 1e-9 {
                        max_a = max_a.max(a.abs() / (n0 + n1).abs());
                    }
                }
                Err(e) => failed.push((p0, p1, e)),
            }
        }
    }
    let safeguard = SAFEGUARD_USED.with(|c| c.get());
    eprintln!(
        "grid: worst residual {worst:e}; failures {failed:?}; safeguard used {safeguard} times; max A/(φ₀+φ₁) {max_a}"
    );
    assert_eq!(
        safeguard, 0,
        "Newton from the fitted guess should converge on the whole domain"
    );
    // Only the degenerate corner φ₀ = φ₁ = π (both tangents back along the chord; ±π map to π) may fail.
    assert!(
        failed
            .iter()
            .all(|&(a, b, _)| normalize_angle(a) == PI && normalize_angle(b) == PI),
        "{failed:?}"
    );
}

/// The bracketed safeguard finds the same root as Newton from nearby guesses.
#[test]
fn safeguard_finds_the_newton_root() {
    for &(p0, p1) in &[
        (0.3, 0.9),
        (-2.5, 1.4),
        (3.0, 3.0),
        (-1.0, 1.0),
        (2.9, -0.2),
    ] {
        let delta: f64 = p1 - p0;
        let guess = 3.0 * (p0 + p1);
        let w = root_window(normalize_angle(p0) + normalize_angle(p1));
        let newton = solve_a(guess, delta, p0, w).unwrap();
        for off in [-0.4, 0.0, 0.33, 100.0] {
            let b = bracketed_root(newton + off, delta, p0, w).unwrap();
            assert!(
                (b - newton).abs() < 1e-12 * newton.abs().max(1.0),
                "φ = ({p0}, {p1}), off {off}: {b} vs {newton}"
            );
        }
    }
}

/// Extreme but finite inputs never panic; successes meet the end conditions.
#[test]
fn extreme_inputs_do_not_panic() {
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    for _ in 0..2000 {
        let e0: f64 = rng.gen_range(-300.0..300.0);
        let e1: f64 = rng.gen_range(-300.0..300.0);
        let p0 = DVec2::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0)) * 10f64.powf(e0);
        let p1 = DVec2::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0)) * 10f64.powf(e1);
        let t0 = rng.gen_range(-1e6..1e6);
        let t1 = rng.gen_range(-1e6..1e6);
        if let Ok(c) = clothoid_g1(p0, t0, p1, t1) {
            assert!(c.length > 0.0 && c.length.is_finite());
            let r = (p1 - p0).length();
            let end = c.end();
            if end.is_finite() {
                assert!(
                    (end - p1).length() <= 1e-11 * r + 1e-15 * p0.length().max(p1.length()),
                    "{c:?} {p1}"
                );
            }
        }
    }
    let p = DVec2::ZERO;
    assert_eq!(
        clothoid_g1(p, 1.0, DVec2::new(1e-310, 0.0), -1.0),
        Err(ClothoidError::NonFinite)
    );
}
