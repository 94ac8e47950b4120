//! Tests of the spline module against independent references (composite
//! Simpson on `|B'|` from the Bernstein derivative, finite differences of
//! the curve, closed-form lengths).

use glam::DVec3;
use proptest::prelude::*;

use super::{BezierSpline, CubicBez, SplineError};

fn v(x: f64, y: f64, z: f64) -> DVec3 {
    DVec3::new(x, y, z)
}

/// `∫ₐᵇ |B'(t)| dt` by composite Simpson on `n` (even) panels with
/// compensated summation; error `O(n⁻⁴)` for a smooth integrand, and
/// independent of the code under test (Bernstein `deriv`, no Gauss rule).
fn simpson_len(c: &CubicBez, a: f64, b: f64, n: usize) -> f64 {
    assert!(n.is_multiple_of(2));
    let h = (b - a) / n as f64;
    let f = |i: usize| c.deriv(a + h * i as f64).length();
    let (mut sum, mut comp) = (0.0f64, 0.0f64);
    let mut add = |x: f64| {
        let y = x - comp;
        let t = sum + y;
        comp = (t - sum) - y;
        sum = t;
    };
    add(f(0));
    add(f(n));
    for i in 1..n {
        add(if i % 2 == 1 { 4.0 * f(i) } else { 2.0 * f(i) });
    }
    sum * h / 3.0
}

fn quarter_circle() -> CubicBez {
    let k = 4.0 / 3.0 * (std::f64::consts::PI / 8.0).tan();
    CubicBez::new(
        v(1.0, 0.0, 0.0),
        v(1.0, k, 0.0),
        v(k, 1.0, 0.0),
        v(0.0, 1.0, 0.0),
    )
}

fn spline_of(c: &CubicBez) -> BezierSpline {
    BezierSpline::from_control_points(&[c.p0, c.p1, c.p2, c.p3]).expect("valid spline")
}

/// Angle between two vectors, accurate near 0 (unlike `acos` of the
/// normalised dot product, which cannot resolve angles below ~1e-8).
fn angle(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

/// Forward finite-difference direction of the curve leaving `(seg, t)`
/// (backward, i.e. arriving, at `t = 1`).
fn fd_dir(c: &CubicBez, t: f64, h: f64) -> DVec3 {
    if t + h <= 1.0 {
        (c.eval(t + h) - c.eval(t)).normalize()
    } else {
        (c.eval(t) - c.eval(t - h)).normalize()
    }
}

// ---------------------------------------------------------------- errors

#[test]
fn rejects_bad_counts() {
    let p = v(0.0, 0.0, 0.0);
    for n in [0usize, 1, 2, 3, 5, 6, 8, 9] {
        let pts: Vec<DVec3> = (0..n).map(|i| p + DVec3::X * i as f64).collect();
        let e = BezierSpline::from_control_points(&pts).unwrap_err();
        assert_eq!(e, SplineError::BadControlPointCount(n));
    }
    let msg = SplineError::BadControlPointCount(5).to_string();
    assert_eq!(msg, "expected 3k+1 control points (k ≥ 1), got 5");
}

#[test]
fn rejects_non_finite() {
    let mut pts: Vec<DVec3> = (0..10).map(|i| DVec3::X * i as f64).collect();
    pts[7].y = f64::NAN;
    assert_eq!(
        BezierSpline::from_control_points(&pts).unwrap_err(),
        SplineError::NonFiniteControlPoint(7)
    );
    assert_eq!(
        SplineError::NonFiniteControlPoint(7).to_string(),
        "control point 7 is not finite"
    );
    pts[7].y = 0.0;
    pts[2].z = f64::INFINITY;
    assert_eq!(
        BezierSpline::from_control_points(&pts).unwrap_err(),
        SplineError::NonFiniteControlPoint(2)
    );
}

#[test]
fn rejects_zero_length_and_overflow() {
    let pts = vec![v(1.0, 2.0, 3.0); 7];
    let e = BezierSpline::from_control_points(&pts).unwrap_err();
    assert_eq!(e, SplineError::ZeroLength);
    assert_eq!(e.to_string(), "spline has zero length");
    let pts = [
        v(-1e308, 0.0, 0.0),
        v(0.0, 0.0, 0.0),
        v(1e308, 0.0, 0.0),
        v(1e308, 1e308, 0.0),
    ];
    assert_eq!(
        BezierSpline::from_control_points(&pts).unwrap_err(),
        SplineError::NonFiniteLength
    );
}

#[test]
fn rejects_bad_accuracy_and_sample_counts() {
    let s = spline_of(&quarter_circle());
    let pts = s.control_points().to_vec();
    for a in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            BezierSpline::from_control_points_with_accuracy(&pts, a),
            Err(SplineError::BadAccuracy(_))
        ));
    }
    assert!(s.sample_equal_arclen(0).is_err());
    assert!(s.sample_points(1).is_err());
    assert!(s.sample_points(0).is_err());
    let (mut a, mut b) = (Vec::new(), Vec::new());
    assert!(s.sample_equal_arclen_into(0, &mut a, &mut b).is_err());
}

#[test]
fn out_of_range_arguments_do_not_panic() {
    let s = spline_of(&quarter_circle());
    let l = s.length();
    assert_eq!(s.param_at_arclen(f64::NAN), (0, 0.0));
    assert_eq!(s.param_at_arclen(-1.0), (0, 0.0));
    assert_eq!(s.param_at_arclen(2.0 * l), (0, 1.0));
    assert_eq!(s.arclen_at(5, 0.5), s.arclen_at(0, 0.5));
    assert_eq!(s.arclen_at(0, f64::NAN), 0.0);
    assert_eq!(s.arclen_at(0, 7.0), l);
    assert!(s.unit_tangent(99, -3.0).is_normalized());
    assert_eq!(s.eval(3, 2.0), v(0.0, 1.0, 0.0));
}

// ------------------------------------------------------------ arc length

#[test]
fn straight_line_with_uneven_handles_has_chord_length() {
    let a = v(0.3, -1.0, 2.0);
    let d = v(1.0, 2.0, -0.5);
    // Uneven parameterisation: the speed varies strongly along both
    // segments (handles bunched towards one end).
    let pts = [
        a,
        a + 0.05 * d,
        a + 0.9 * d,
        a + d,
        a + 1.01 * d,
        a + 2.9 * d,
        a + 3.0 * d,
    ];
    let s = BezierSpline::from_control_points(&pts).unwrap();
    let chord = 3.0 * d.length();
    assert!(
        (s.length() - chord).abs() <= 1e-13 * chord,
        "{} vs {chord}",
        s.length()
    );
    // and at every parameter, arc length = distance from the start
    for i in 0..=20 {
        let t = i as f64 / 20.0;
        for seg in 0..2 {
            let want = (s.eval(seg, t) - a).length();
            assert!((s.arclen_at(seg, t) - want).abs() <= 1e-13 * chord);
        }
    }
}

#[test]
fn quarter_circle_matches_simpson_reference() {
    let c = quarter_circle();
    let s = spline_of(&c);
    let reference = simpson_len(&c, 0.0, 1.0, 1_000_000);
    // The cubic is not a circle: its length differs from π/2 by ~1e-4, so
    // this comparison really tests the quadrature, not the geometry.
    assert!((reference - std::f64::consts::FRAC_PI_2).abs() > 1e-6);
    assert!(
        (s.length() - reference).abs() <= 1e-12 * reference,
        "{} vs {reference}",
        s.length()
    );
    for i in 1..10 {
        let t = i as f64 / 10.0;
        let r = simpson_len(&c, 0.0, t, 100_000);
        assert!((s.arclen_at(0, t) - r).abs() <= 1e-12 * reference, "t={t}");
    }
}

/// A cubic with an exact cusp at t = ½ (`B'(½) = 0`): `|B'|` has a kink,
/// where the Gauss rule converges only algebraically and the adaptive
/// bisection must do the work.
fn cusp() -> CubicBez {
    CubicBez::new(
        v(0.0, 0.0, 0.0),
        v(1.0, 1.0, 0.0),
        v(0.0, 1.0, 0.0),
        v(1.0, 0.0, 0.0),
    )
}

/// A cubic with a cusp at the non-dyadic `t₀ = 0.3`, so the bisection
/// never puts a panel boundary on the kink of `|B'|`.
fn cusp_at_03() -> (CubicBez, f64) {
    let t0 = 0.3;
    let (d0, d1) = (v(1.0, 1.0, 0.0), v(-1.0, 0.0, 0.2));
    // (1−t₀)² d₀ + 2t₀(1−t₀) d₁ + t₀² d₂ = 0  ⇒  B'(t₀) = 0.
    let d2 = -((1.0 - t0) * (1.0 - t0) * d0 + 2.0 * t0 * (1.0 - t0) * d1) / (t0 * t0);
    let p0 = v(0.0, 0.0, 0.0);
    let c = CubicBez::new(p0, p0 + d0, p0 + d0 + d1, p0 + d0 + d1 + d2);
    (c, t0)
}

#[test]
fn requested_accuracy_is_honoured() {
    let (cc, t0) = cusp_at_03();
    assert!(cc.deriv(t0).length() < 1e-14 * cc.leg_scale());
    for (name, c) in [("cusp", cc), ("circle", quarter_circle())] {
        // Splitting Simpson at the kink keeps each piece smooth (O(h⁴)).
        let reference = simpson_len(&c, 0.0, t0, 600_000) + simpson_len(&c, t0, 1.0, 600_000);
        let pts = [c.p0, c.p1, c.p2, c.p3];
        let mut panels = Vec::new();
        for acc in [1e-4, 1e-6, 1e-9, 1e-12] {
            let s = BezierSpline::from_control_points_with_accuracy(&pts, acc).unwrap();
            let err = (s.length() - reference).abs() / reference;
            assert!(err <= acc, "{name}: acc {acc}: relative error {err}");
            panels.push(s.num_panels());
        }
        if name == "cusp" {
            // The kink needs more panels for tighter tolerances.
            assert!(panels.windows(2).all(|w| w[0] <= w[1]), "{panels:?}");
            assert!(panels[3] > panels[0] + 10, "{panels:?}");
        }
    }
}

#[test]
fn dense_hermite_helix_has_helix_length() {
    // p(θ) = (r cos θ, r sin θ, cθ): speed √(r² + c²), exact length θ·speed.
    let (r, c, turns, n) = (2.0, 0.35, 3.0, 240usize);
    let p = |th: f64| v(r * th.cos(), r * th.sin(), c * th);
    let dp = |th: f64| v(-r * th.sin(), r * th.cos(), c);
    let theta = turns * std::f64::consts::TAU;
    let h = theta / n as f64;
    let mut pts = vec![p(0.0)];
    for i in 0..n {
        let (a, b) = (h * i as f64, h * (i + 1) as f64);
        pts.push(p(a) + h / 3.0 * dp(a));
        pts.push(p(b) - h / 3.0 * dp(b));
        pts.push(p(b));
    }
    let s = BezierSpline::from_control_points(&pts).unwrap();
    let exact = theta * (r * r + c * c).sqrt();
    let rel = (s.length() - exact).abs() / exact;
    assert!(rel < 1e-6, "relative error {rel}");
    // Equal arc length samples sit at equal helix angles (up to the
    // Hermite approximation).
    let m = 7;
    let samples = s.sample_points(m).unwrap();
    for (i, q) in samples.iter().enumerate() {
        let th = theta * i as f64 / (m - 1) as f64;
        assert!((*q - p(th)).length() < 1e-5 * exact, "sample {i}");
    }
}

// --------------------------------------------------------------- inverse

#[test]
fn inverse_on_cusp_and_quarter_circle() {
    for c in [cusp(), cusp_at_03().0, quarter_circle()] {
        let s = spline_of(&c);
        for i in 0..=200 {
            let t = i as f64 / 200.0;
            let (seg, t2) = s.param_at_arclen(s.arclen_at(0, t));
            assert_eq!(seg, 0);
            // Near the cusp t is ill-conditioned in s; compare positions.
            let tol = if c.deriv(t).length() > 1e-3 {
                1e-12
            } else {
                1e-6
            };
            assert!((t2 - t).abs() <= tol, "t={t} -> {t2}");
        }
    }
}

/// Random splines with `k ∈ [1, 5]` segments in a 20-unit box.
fn arb_spline() -> impl Strategy<Value = Vec<DVec3>> {
    (1usize..6).prop_flat_map(|k| {
        prop::collection::vec(
            (-10.0f64..10.0, -10.0f64..10.0, -10.0f64..10.0).prop_map(|(x, y, z)| v(x, y, z)),
            3 * k + 1,
        )
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn prop_param_arclen_round_trip(pts in arb_spline(), u in 0.0f64..1.0, w in 0.0f64..1.0) {
        let s = BezierSpline::from_control_points(&pts).unwrap();
        let l = s.length();
        let k = s.num_segments();
        let seg = ((u * k as f64) as usize).min(k - 1);
        let c = s.segments()[seg];
        let sa = s.arclen_at(seg, w);
        let (seg2, t2) = s.param_at_arclen(sa);
        // Same point (a join may be reported on the next segment).
        let q = s.eval(seg2, t2);
        prop_assert!((q - c.eval(w)).length() <= 1e-12 * l.max(1.0));
        // And the parameter itself, where it is well-conditioned in s
        // (dt = ds / |B'|).
        if seg2 == seg && c.deriv(w).length() >= 1e-2 * c.leg_scale() {
            prop_assert!((t2 - w).abs() <= 1e-12, "t {} -> {}", w, t2);
        }
        // The other way round: s → (seg, t) → s.
        let target = u * l;
        let (sg, t) = s.param_at_arclen(target);
        prop_assert!((s.arclen_at(sg, t) - target).abs() <= 1e-12 * l);
    }

    #[test]
    fn prop_arclen_matches_reference(pts in arb_spline(), u in 0.0f64..1.0) {
        let s = BezierSpline::from_control_points(&pts).unwrap();
        let l = s.length();
        let mut total = 0.0;
        for (i, c) in s.segments().iter().enumerate() {
            let r = simpson_len(c, 0.0, 1.0, 20_000);
            // Simpson with 2·10⁴ panels is good to ~1e-9 except at
            // cusps; the table must agree at least that well.
            prop_assert!((s.segment_length(i) - r).abs() <= 1e-8 * l, "seg {}", i);
            total += r;
            let rt = simpson_len(c, 0.0, u, 20_000);
            prop_assert!((s.arclen_at(i, u) - s.arclen_at(i, 0.0) - rt).abs() <= 1e-8 * l);
        }
        prop_assert!((l - total).abs() <= 1e-8 * l);
    }

    #[test]
    fn prop_samples_equally_spaced(pts in arb_spline(), n in 1usize..40) {
        check_samples(&BezierSpline::from_control_points(&pts).unwrap(), n);
    }
}

// -------------------------------------------------------------- sampling

/// Sample invariants: `N + 1` points, exact end points, spacing `L/N` in
/// arc length, unit tangents equal to `B'/|B'|` where `B'` is clearly
/// nonzero, and points on the curve at the located parameters.
fn check_samples(s: &BezierSpline, n: usize) {
    let l = s.length();
    let out = s.sample_equal_arclen(n).unwrap();
    assert_eq!(out.len(), n + 1);
    let cps = s.control_points();
    assert_eq!(out[0].0, cps[0]);
    assert_eq!(out[n].0, cps[cps.len() - 1]);
    for (j, &(p, tan)) in out.iter().enumerate() {
        assert!((tan.length() - 1.0).abs() < 1e-14, "tangent {j} not unit");
        let target = l * j as f64 / n as f64;
        let (seg, t) = s.param_at_arclen(target);
        assert!(
            (s.arclen_at(seg, t) - target).abs() <= 1e-10 * l,
            "sample {j}"
        );
        assert!(
            (s.eval(seg, t) - p).length() <= 1e-12 * l.max(1.0),
            "sample {j}"
        );
        let c = s.segments()[seg];
        let d = c.deriv(t);
        if d.length() > 1e-6 * c.leg_scale() {
            assert!(angle(tan, d) < 1e-12, "sample {j}: tangent {tan} vs B' {d}");
        }
    }
    // Spacing, measured with the arc-length function on the located params.
    let arcs: Vec<f64> = (0..=n)
        .map(|j| {
            let (seg, t) = s.param_at_arclen(l * j as f64 / n as f64);
            s.arclen_at(seg, t)
        })
        .collect();
    for w in arcs.windows(2) {
        assert!(((w[1] - w[0]) - l / n as f64).abs() <= 1e-10 * l);
    }
    // The buffered variants agree exactly with the allocating one.
    let (mut ps, mut ts) = (vec![DVec3::ONE; 3], Vec::new());
    s.sample_equal_arclen_into(n, &mut ps, &mut ts).unwrap();
    assert_eq!(ps.len(), n + 1);
    for j in 0..=n {
        assert_eq!((ps[j], ts[j]), out[j]);
    }
    let only = s.sample_points(n + 1).unwrap();
    assert_eq!(only, ps);
}

#[test]
fn samples_on_fixed_splines() {
    let c = quarter_circle();
    let s = spline_of(&c);
    for n in [1, 2, 3, 20, 101] {
        check_samples(&s, n);
    }
    // Uneven straight line: samples are exactly where the chord says.
    let a = v(0.0, 0.0, 0.0);
    let d = v(3.0, 4.0, 0.0);
    let s = BezierSpline::from_control_points(&[a, 0.01 * d, 0.2 * d, d]).unwrap();
    let out = s.sample_equal_arclen(10).unwrap();
    for (j, &(p, tan)) in out.iter().enumerate() {
        assert!((p - d * (j as f64 / 10.0)).length() < 1e-12, "{j}: {p}");
        assert!(angle(tan, d) < 1e-14);
    }
    check_samples(&s, 10);
}

// ------------------------------------------------------------ degenerate

const FD_H: f64 = 1e-5;
const FD_TOL: f64 = 1e-4;

#[test]
fn tangent_where_first_derivative_vanishes_at_start() {
    // P0 = P1: B'(0) = 0, the curve leaves along P2 − P0.
    let c = CubicBez::new(
        v(0.0, 0.0, 0.0),
        v(0.0, 0.0, 0.0),
        v(1.0, 1.0, 0.0),
        v(2.0, 0.0, 1.0),
    );
    assert_eq!(c.deriv(0.0), DVec3::ZERO);
    let s = spline_of(&c);
    let t0 = s.unit_tangent(0, 0.0);
    assert!(angle(t0, fd_dir(&c, 0.0, FD_H)) < FD_TOL);
    assert!(angle(t0, v(1.0, 1.0, 0.0)) < 1e-14);
    let out = s.sample_equal_arclen(4).unwrap();
    assert_eq!(out[0].1, t0);
    check_samples(&s, 4);
}

#[test]
fn tangent_where_first_derivative_vanishes_at_end() {
    // P2 = P3: B'(1) = 0 and B''(1) = 6(P1 − P3), so the curve *arrives*
    // along −B''(1) ∝ P3 − P1; a sign error (+B''(1)) would point backwards.
    let c = CubicBez::new(
        v(0.0, 0.0, 0.0),
        v(1.0, 2.0, 0.0),
        v(3.0, 0.0, 1.0),
        v(3.0, 0.0, 1.0),
    );
    assert_eq!(c.deriv(1.0), DVec3::ZERO);
    let s = spline_of(&c);
    let t1 = s.unit_tangent(0, 1.0);
    assert!(angle(t1, fd_dir(&c, 1.0, FD_H)) < FD_TOL);
    assert!(angle(t1, c.p3 - c.p1) < 1e-14);
    let out = s.sample_equal_arclen(5).unwrap();
    assert_eq!(out[5].1, t1);
    // Just before the end, B'(t) is tiny but its direction is still right.
    for t in [1.0 - 1e-15, 1.0 - 1e-12, 1.0 - 1e-9] {
        assert!(
            angle(s.unit_tangent(0, t), t1) < 1e-6,
            "t = 1 - {}",
            1.0 - t
        );
    }
    check_samples(&s, 5);
}

#[test]
fn tangent_with_three_coincident_points() {
    // P0 = P1 = P2: B'(0) = B''(0) = 0, leaves along B''' ∝ P3 − P0.
    let c = CubicBez::new(
        v(0.0, 0.0, 0.0),
        v(0.0, 0.0, 0.0),
        v(0.0, 0.0, 0.0),
        v(1.0, -2.0, 0.5),
    );
    let s = spline_of(&c);
    let t0 = s.unit_tangent(0, 0.0);
    assert!(angle(t0, fd_dir(&c, 0.0, 1e-3)) < 1e-10);
    assert!(angle(t0, c.p3) < 1e-14);
    // P1 = P2 = P3: arrives along P3 − P0 (B'(1−h) ≈ h²/2 B''').
    let c = CubicBez::new(
        v(1.0, -2.0, 0.5),
        v(0.0, 0.0, 0.0),
        v(0.0, 0.0, 0.0),
        v(0.0, 0.0, 0.0),
    );
    let s = spline_of(&c);
    let t1 = s.unit_tangent(0, 1.0);
    assert!(angle(t1, fd_dir(&c, 1.0, 1e-3)) < 1e-10);
    assert!(angle(t1, -c.p0) < 1e-14);
    check_samples(&s, 3);
}

#[test]
fn tangent_at_interior_cusp_is_one_sided() {
    let c = cusp();
    let s = spline_of(&c);
    let t = s.unit_tangent(0, 0.5);
    assert!(angle(t, fd_dir(&c, 0.5, FD_H)) < FD_TOL);
}

#[test]
fn zero_length_middle_segment() {
    let a = v(0.0, 0.0, 0.0);
    let b = v(1.0, 0.0, 0.0);
    let pts = [
        a,
        v(0.3, 0.5, 0.0),
        v(0.7, 0.5, 0.0),
        b, // join
        b,
        b,
        b,                // zero-length segment 1
        v(1.0, 0.0, 1.0), // segment 2 leaves b upwards
        v(2.0, 0.0, 1.0),
        v(2.0, 0.0, 0.0),
    ];
    let s = BezierSpline::from_control_points(&pts).unwrap();
    assert_eq!(s.segment_length(1), 0.0);
    let l0 = s.segment_length(0);
    // The join belongs to the segment that starts there with positive length.
    assert_eq!(s.param_at_arclen(l0), (2, 0.0));
    let seg2 = s.segments()[2];
    let want = fd_dir(&seg2, 0.0, FD_H);
    assert!(angle(s.unit_tangent(1, 0.5), want) < FD_TOL);
    assert!(angle(s.unit_tangent(2, 0.0), want) < FD_TOL);
    // Sampling never lands on the zero-length segment and stays monotone.
    for n in [2, 7, 30] {
        check_samples(&s, n);
    }
    // Sample exactly on the join: a sample count putting s = l0 exactly.
    let s_half = BezierSpline::from_control_points(&[
        a,
        v(0.5, 0.0, 0.0),
        v(1.0, 0.0, 0.0),
        v(1.5, 0.0, 0.0),
        v(1.5, 0.0, 0.0),
        v(1.5, 0.0, 0.0),
        v(1.5, 0.0, 0.0),
        v(1.5, 0.0, 0.5),
        v(1.5, 0.0, 1.0),
        v(1.5, 0.0, 1.5),
    ])
    .unwrap();
    let out = s_half.sample_equal_arclen(2).unwrap();
    assert!((out[1].0 - v(1.5, 0.0, 0.0)).length() < 1e-12);
    assert!(angle(out[1].1, DVec3::Z) < 1e-12, "{}", out[1].1);
}

#[test]
fn zero_length_end_segments_use_neighbour_tangents() {
    let a = v(1.0, 1.0, 1.0);
    let inner = [a, v(2.0, 1.0, 1.0), v(3.0, 2.0, 1.0), v(3.0, 3.0, 2.0)];
    let z = inner[3];
    // Zero-length first and last segments around a real one.
    let pts = [a, a, a, a, inner[1], inner[2], z, z, z, z];
    let s = BezierSpline::from_control_points(&pts).unwrap();
    let c = s.segments()[1];
    let start = fd_dir(&c, 0.0, FD_H);
    let end = fd_dir(&c, 1.0, FD_H);
    assert_eq!(s.param_at_arclen(0.0), (1, 0.0));
    assert_eq!(s.param_at_arclen(s.length()), (1, 1.0));
    assert!(angle(s.unit_tangent(0, 0.0), start) < FD_TOL);
    assert!(angle(s.unit_tangent(0, 1.0), start) < FD_TOL);
    assert!(angle(s.unit_tangent(2, 0.0), end) < FD_TOL);
    assert!(angle(s.unit_tangent(2, 1.0), end) < FD_TOL);
    let out = s.sample_equal_arclen(6).unwrap();
    assert_eq!(out[0].0, a);
    assert_eq!(out[6].0, z);
    assert!(angle(out[0].1, start) < FD_TOL);
    assert!(angle(out[6].1, end) < FD_TOL);
    check_samples(&s, 6);
}

#[test]
fn coincident_points_inside_a_spline() {
    // Interior join with P2 = P3 = P4 (both sides degenerate): the join
    // tangent is the leaving direction of the right segment (+B''(0)).
    let pts = [
        v(0.0, 0.0, 0.0),
        v(1.0, 0.0, 0.0),
        v(1.0, 1.0, 0.0),
        v(1.0, 1.0, 0.0),
        v(1.0, 1.0, 0.0),
        v(2.0, 2.0, 0.5),
        v(3.0, 2.0, 0.0),
    ];
    let s = BezierSpline::from_control_points(&pts).unwrap();
    let (seg, t) = s.param_at_arclen(s.segment_length(0));
    assert_eq!((seg, t), (1, 0.0));
    let c1 = s.segments()[1];
    assert!(angle(s.unit_tangent(1, 0.0), fd_dir(&c1, 0.0, FD_H)) < FD_TOL);
    let c0 = s.segments()[0];
    assert!(angle(s.unit_tangent(0, 1.0), fd_dir(&c0, 1.0, FD_H)) < FD_TOL);
    for n in [1, 2, 5, 16] {
        check_samples(&s, n);
    }
}
