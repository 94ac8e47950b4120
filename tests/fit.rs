//! The whole floating tangents fit on splines with known answers.

use std::f64::consts::TAU;

use glam::DVec3;
use strandfit::helix::Relaxation;
use strandfit::metrics::discrete_frechet;
use strandfit::spline::BezierSpline;
use strandfit::{fit_spline, fit_splines, FitError, FitOptions};

fn hermite(pos: impl Fn(f64) -> DVec3, u0: f64, u1: f64, segments: usize) -> BezierSpline {
    strandfit::synthetic::hermite_spline(pos, u0, u1, segments).unwrap()
}

#[test]
fn a_densely_approximated_helix_is_recovered() {
    // Right-handed helix of radius a and pitch 2πc: κ = a/(a²+c²), τ = c/(a²+c²).
    for (a, c, hand) in [(2.0, 0.5, 1.0), (1.0, 1.5, -1.0), (3.0, 0.05, 1.0)] {
        let pos = |u: f64| DVec3::new(a * u.cos(), hand * a * u.sin(), c * u);
        let spline = hermite(pos, 0.0, 3.0 * TAU, 300);
        let m2 = a * a + c * c;
        let (kappa, tau) = (a / m2, hand * c / m2);
        for n in [6usize, 20, 45] {
            let chain = fit_spline(&spline, &FitOptions::new(n)).unwrap();
            assert_eq!(chain.len(), n);
            for e in chain.elements() {
                assert!(
                    (e.curvature - kappa).abs() <= 1e-3 * kappa,
                    "κ {} vs {kappa}",
                    e.curvature
                );
                assert!(
                    (e.torsion - tau).abs() <= 1e-3 * kappa.hypot(tau),
                    "τ {} vs {tau}",
                    e.torsion
                );
                assert!((e.axis().dot(DVec3::Z).abs() - 1.0).abs() < 1e-3);
            }
            assert!((chain.length() - spline.length()).abs() <= 1e-3 * spline.length());
        }
    }
}

#[test]
fn fit_then_evaluate_hits_the_spline_and_improves_with_n() {
    let pos = |u: f64| DVec3::new(u.cos() * (1.0 + 0.3 * u), u.sin(), 0.2 * u * u);
    let spline = hermite(pos, 0.0, 8.0, 40);
    let dense = spline.sample_points(2001).unwrap();
    let mut last = f64::INFINITY;
    for n in [5usize, 10, 20, 40, 80] {
        let chain = fit_spline(&spline, &FitOptions::new(n)).unwrap();
        let d = discrete_frechet(&dense, &chain.sample(2001)).unwrap();
        assert!(d < last, "N={n}: Fréchet {d} did not improve on {last}");
        last = d;
        let (gap, angle) = chain.continuity_defects();
        assert!(
            gap < 1e-12 * spline.length() && angle < 1e-10,
            "N={n}: gap {gap}, angle {angle}"
        );
    }
    // Second-order convergence of the approximation (Fréchet ∝ 1/N²).
    assert!(last < 2e-3 * spline.length(), "Fréchet at N=80: {last}");
}

#[test]
fn circles_and_straight_lines() {
    let r = 4.0;
    let circle = hermite(
        |u: f64| DVec3::new(r * u.cos(), r * u.sin(), 0.0),
        0.0,
        0.9 * TAU,
        200,
    );
    let chain = fit_spline(&circle, &FitOptions::new(12)).unwrap();
    for e in chain.elements() {
        // The Hermite cubics match the circle's tangents to ≈1e-6 (h⁴ error
        // with h = 0.028 rad); the fit is exact for its input, so κ is off by
        // that much, and the planar input gives τ = 0 exactly.
        assert!(
            (e.curvature - 1.0 / r).abs() < 1e-5 / r,
            "κ {} vs {}",
            e.curvature,
            1.0 / r
        );
        assert_eq!(e.torsion, 0.0);
    }
    let line = BezierSpline::from_control_points(&[
        DVec3::ZERO,
        DVec3::new(0.5, 1.0, 1.5),
        DVec3::new(1.0, 2.0, 3.0),
        DVec3::new(3.0, 6.0, 9.0),
    ])
    .unwrap();
    let chain = fit_spline(&line, &FitOptions::new(7)).unwrap();
    for e in chain.elements() {
        assert_eq!(e.curvature, 0.0);
        assert!((e.tangent - DVec3::new(1.0, 2.0, 3.0).normalize()).length() < 1e-14);
    }
    assert!((chain.length() - 14f64.sqrt() * 3.0).abs() < 1e-12);
    // A straight stretch between curved parts (equal tangents at several
    // break points) still gives a G1 chain.
    let mut cps = vec![
        DVec3::new(-3.0, -3.0, 0.0),
        DVec3::new(-3.0, -1.0, 0.0),
        DVec3::new(-2.0, 0.0, 0.0),
        DVec3::ZERO,
        DVec3::new(2.0, 0.0, 0.0),
        DVec3::new(4.0, 0.0, 0.0),
        DVec3::new(6.0, 0.0, 0.0),
    ];
    cps.extend([
        DVec3::new(8.0, 0.0, 0.0),
        DVec3::new(9.0, 1.0, 1.0),
        DVec3::new(9.0, 3.0, 2.0),
    ]);
    let mixed = BezierSpline::from_control_points(&cps).unwrap();
    let chain = fit_spline(&mixed, &FitOptions::new(16)).unwrap();
    assert!(chain.elements().iter().any(|e| e.curvature == 0.0));
    let (gap, angle) = chain.continuity_defects();
    assert!(gap < 1e-12 && angle < 1e-10);
}

#[test]
fn dense_and_tridiagonal_fits_agree() {
    let pos = |u: f64| DVec3::new(u.cos(), (2.0 * u).sin(), 0.3 * u);
    let spline = hermite(pos, 0.0, 6.0, 30);
    for n in [3usize, 17, 60] {
        let tri = fit_spline(&spline, &FitOptions::new(n)).unwrap();
        let dense = fit_spline(
            &spline,
            &FitOptions {
                relaxation: Relaxation::DenseLu,
                ..FitOptions::new(n)
            },
        )
        .unwrap();
        for (a, b) in tri.elements().iter().zip(dense.elements()) {
            assert!((a.start - b.start).length() < 1e-9 * spline.length());
            assert!((a.curvature - b.curvature).abs() < 1e-7 * a.curvature.max(1.0));
        }
    }
}

#[test]
fn batch_matches_single_and_reports_errors_per_curve() {
    let good = hermite(|u: f64| DVec3::new(u, u.sin(), u.cos()), 0.0, 5.0, 10);
    let splines = vec![good.clone(), good.clone()];
    let results = fit_splines(&splines, &FitOptions::new(9));
    let single = fit_spline(&good, &FitOptions::new(9)).unwrap();
    for r in results {
        assert_eq!(r.unwrap(), single);
    }
    assert_eq!(
        fit_spline(&good, &FitOptions::new(0)),
        Err(FitError::NoElements)
    );
}

#[test]
fn scale_and_rotation_invariance_of_the_fit() {
    let pos = |u: f64| DVec3::new(u.cos(), u.sin() * 0.5, 0.4 * u);
    let spline = hermite(pos, 0.0, 7.0, 20);
    let base = fit_spline(&spline, &FitOptions::new(15)).unwrap();
    let q = glam::DQuat::from_axis_angle(DVec3::new(1.0, -2.0, 0.5).normalize(), 1.1);
    let s = 7.5;
    let moved: Vec<DVec3> = spline
        .control_points()
        .iter()
        .map(|&p| q * p * s + DVec3::new(3.0, 2.0, 1.0))
        .collect();
    let moved = fit_spline(
        &BezierSpline::from_control_points(&moved).unwrap(),
        &FitOptions::new(15),
    )
    .unwrap();
    for (a, b) in base.elements().iter().zip(moved.elements()) {
        assert!((a.curvature - b.curvature * s).abs() < 1e-9);
        assert!((a.torsion - b.torsion * s).abs() < 1e-9);
        assert!((a.length * s - b.length).abs() < 1e-9 * s);
    }
}
