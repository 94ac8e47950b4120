//! The paper's complexity ∫√(κ² + τ²) ds (Eq. 12) on curves with known values.

use std::f64::consts::TAU;

use glam::DVec3;
use strandfit::metrics::complexity_cubics;
use strandfit::spline::{BezierSpline, CubicBez};
use strandfit::{fit_spline, FitOptions};
fn hermite(pos: impl Fn(f64) -> DVec3, u0: f64, u1: f64, segments: usize) -> BezierSpline {
    strandfit::synthetic::hermite_spline(pos, u0, u1, segments).unwrap()
}

#[test]
fn straight_cubic_has_zero_complexity() {
    let c = CubicBez::new(
        DVec3::ZERO,
        DVec3::new(0.1, 0.2, 0.3),
        DVec3::new(1.0, 2.0, 3.0),
        DVec3::new(2.0, 4.0, 6.0),
    );
    assert!(complexity_cubics(&[c], 1e-10).abs() < 1e-9);
}

#[test]
fn circle_arc_and_helix_match_the_closed_form() {
    // Circle arc of angle θ: κ = 1/r, τ = 0, length rθ ⇒ complexity θ.
    let theta = 2.5;
    let circle = hermite(
        |u: f64| DVec3::new(3.0 * u.cos(), 3.0 * u.sin(), 0.0),
        0.0,
        theta,
        64,
    );
    let c = complexity_cubics(circle.segments(), 1e-10);
    assert!((c - theta).abs() < 1e-4 * theta, "{c} vs {theta}");
    // Helix (a cos u, a sin u, c u): √(κ² + τ²) = 1/√(a² + c²), length u√(a² + c²) ⇒ u.
    let u1 = 2.0 * TAU;
    let helix = hermite(
        |u: f64| DVec3::new(2.0 * u.cos(), 2.0 * u.sin(), 0.7 * u),
        0.0,
        u1,
        200,
    );
    let c = complexity_cubics(helix.segments(), 1e-10);
    assert!((c - u1).abs() < 1e-4 * u1, "{c} vs {u1}");
    // The fitted chain's complexity Σφ* agrees with the spline's.
    let chain = fit_spline(&helix, &FitOptions::new(30)).unwrap();
    assert!((chain.complexity() - u1).abs() < 1e-3 * u1);
}

#[test]
fn complexity_is_scale_and_rotation_invariant() {
    let s = hermite(
        |u: f64| DVec3::new(u.cos(), (1.3 * u).sin(), 0.2 * u * u),
        0.0,
        5.0,
        20,
    );
    let base = complexity_cubics(s.segments(), 1e-10);
    let q = glam::DQuat::from_axis_angle(DVec3::new(0.3, -1.0, 2.0).normalize(), 0.8);
    for scale in [1e-3, 0.5, 40.0] {
        let pts: Vec<DVec3> = s
            .control_points()
            .iter()
            .map(|&p| q * p * scale + DVec3::ONE)
            .collect();
        let moved = BezierSpline::from_control_points(&pts).unwrap();
        let c = complexity_cubics(moved.segments(), 1e-10);
        assert!(
            (c - base).abs() < 1e-8 * base,
            "scale {scale}: {c} vs {base}"
        );
    }
}
