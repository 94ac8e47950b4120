//! Ghosh short-helix interpolation: recover random helices from their end
//! data, the paper's invariants, and every degenerate branch.

use std::f64::consts::{PI, TAU};

use glam::DVec3;
use proptest::prelude::*;
use strandfit::helix::{interpolate, HelixElement, HelixError, DEFAULT_COHELICAL_TOL};

fn unit(v: [f64; 3]) -> Option<DVec3> {
    let v = DVec3::from(v);
    (v.length() > 0.1).then(|| v.normalize())
}

/// A helix element from a start frame, κ, τ and turning angle φ*.
fn helix(p0: DVec3, t0: DVec3, n_hint: DVec3, kappa: f64, tau: f64, phi: f64) -> HelixElement {
    let n0 = (n_hint - n_hint.dot(t0) * t0).normalize();
    let omega = kappa.hypot(tau);
    HelixElement {
        start: p0,
        tangent: t0,
        normal: n0,
        curvature: kappa,
        torsion: tau,
        length: phi / omega,
    }
}

/// Interpolate the end data of `e` and compare all parameters.
///
/// `rel` is the tolerance for well-conditioned data. Short elements are
/// intrinsically ill-conditioned: with relative data noise `η` (rounding of
/// positions relative to the chord, and of tangents), curvature is determined
/// to `~η/θ` and torsion (a third-order effect) to `~η/θ²` relative to `ω`,
/// `θ` the angle between the end tangents.
/// Those bounds are added, so the test states the conditioning, not a fudge.
fn check_recovers(e: &HelixElement, rel: f64) -> Result<(), TestCaseError> {
    let p1 = e.end_point();
    let t1 = e.end_frame().tangent;
    let got = interpolate(e.start, e.tangent, p1, t1, DEFAULT_COHELICAL_TOL)
        .map_err(|err| TestCaseError::fail(format!("{err} for {e:?}")))?;
    let g = got.element;
    let w = e.omega();
    let chord = (p1 - e.start).length();
    let eta = f64::EPSILON * (4.0 + (e.start.length() + p1.length()) / chord);
    let phi = e.phi();
    // Turning angle of the tangent, θ ≤ φ* (much smaller for steep helices).
    let theta = e.tangent.cross(t1).length().atan2(e.tangent.dot(t1));
    let rel_k = rel + 10.0 * eta / theta;
    let rel_t = rel + 10.0 * eta / (theta * theta);
    prop_assert!(
        (g.curvature - e.curvature).abs() <= rel_k * w,
        "κ {} vs {}",
        g.curvature,
        e.curvature
    );
    prop_assert!(
        (g.torsion - e.torsion).abs() <= rel_t * w,
        "τ {} vs {}",
        g.torsion,
        e.torsion
    );
    prop_assert!(
        (g.length - e.length).abs() <= rel_k * e.length,
        "L {} vs {}",
        g.length,
        e.length
    );
    prop_assert!(
        (got.phi - phi).abs() <= rel_k * TAU,
        "φ* {} vs {}",
        got.phi,
        phi
    );
    prop_assert!(
        (got.axis - e.axis()).length() <= rel_t * 10.0,
        "axis {} vs {}",
        got.axis,
        e.axis()
    );
    // Whatever the conditioning of the parameters, the fitted helix hits the
    // end data.
    prop_assert!((g.end_point() - p1).length() <= (rel + 4.0 * eta) * chord.max(e.length));
    prop_assert!((g.end_frame().tangent - t1).length() <= rel);
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// Random axis, κ, τ, start frame and φ* ∈ [0.05, 2π − 0.05], start
    /// point within ten radii of curvature of the origin: all parameters
    /// recovered to 1e-9 relative (the conditioning terms of
    /// `check_recovers` are below 1e-10 here).
    #[test]
    fn random_helices_are_recovered(
        t in prop::array::uniform3(-1.0f64..1.0),
        n in prop::array::uniform3(-1.0f64..1.0),
        p in prop::array::uniform3(-10.0f64..10.0),
        log_kappa in -3.0f64..2.0,
        tau_ratio in -20.0f64..20.0,
        phi in 0.05f64..(TAU - 0.05),
    ) {
        let (Some(t0), Some(nh)) = (unit(t), unit(n)) else { return Ok(()) };
        prop_assume!(t0.cross(nh).length() > 0.1);
        let kappa = 10f64.powf(log_kappa);
        let omega = kappa.hypot(kappa * tau_ratio);
        let e = helix(DVec3::from(p) / omega, t0, nh, kappa, kappa * tau_ratio, phi);
        check_recovers(&e, 1e-9)?;
    }

    /// The whole range φ* ∈ (0, 2π) and far-away start points: parameters
    /// within the conditioning bounds, end data always hit to 1e-9.
    #[test]
    fn random_helices_any_turning_angle_and_offset(
        t in prop::array::uniform3(-1.0f64..1.0),
        n in prop::array::uniform3(-1.0f64..1.0),
        p in prop::array::uniform3(-100.0f64..100.0),
        log_kappa in -3.0f64..2.0,
        tau_ratio in -20.0f64..20.0,
        phi in 1e-3f64..(TAU - 1e-3),
    ) {
        let (Some(t0), Some(nh)) = (unit(t), unit(n)) else { return Ok(()) };
        prop_assume!(t0.cross(nh).length() > 0.1);
        let kappa = 10f64.powf(log_kappa);
        let e = helix(DVec3::from(p), t0, nh, kappa, kappa * tau_ratio, phi);
        check_recovers(&e, 1e-9)?;
    }

    /// Nearly planar helices put φ* within a hair of an end of I₀, where H
    /// has its poles.
    #[test]
    fn near_planar_helices_near_the_poles(
        t in prop::array::uniform3(-1.0f64..1.0),
        n in prop::array::uniform3(-1.0f64..1.0),
        log_tau in -14.0f64..-4.0,
        sign in prop::bool::ANY,
        phi in 1e-2f64..(TAU - 1e-2),
    ) {
        let (Some(t0), Some(nh)) = (unit(t), unit(n)) else { return Ok(()) };
        prop_assume!(t0.cross(nh).length() > 0.1);
        let tau = if sign { 1.0 } else { -1.0 } * 10f64.powf(log_tau);
        let e = helix(DVec3::ZERO, t0, nh, 1.0, tau, phi);
        check_recovers(&e, 1e-9)?;
    }

    /// Small turning angles (short, nearly straight elements).
    #[test]
    fn small_turning_angles(
        log_phi in -7.0f64..-2.0,
        tau_ratio in -5.0f64..5.0,
    ) {
        let e = helix(DVec3::new(1.0, 2.0, 3.0), DVec3::new(0.3, 0.4, 0.5).normalize(), DVec3::Z, 2.0, 2.0 * tau_ratio, 10f64.powf(log_phi));
        check_recovers(&e, 1e-9)?;
    }

    /// Invariance: rotating, translating and scaling the data rotates,
    /// translates and scales the helix (κ, τ scale by 1/s; φ* is unchanged);
    /// a mirror image flips the sign of the torsion.
    #[test]
    fn rigid_motion_scale_and_mirror(
        axis in prop::array::uniform3(-1.0f64..1.0),
        angle in 0.0f64..TAU,
        scale in 0.01f64..100.0,
        shift in prop::array::uniform3(-50.0f64..50.0),
        tau_ratio in -3.0f64..3.0,
        phi in 0.1f64..6.0,
    ) {
        let Some(ax) = unit(axis) else { return Ok(()) };
        let e = helix(DVec3::ZERO, DVec3::X, DVec3::Y, 0.8, 0.8 * tau_ratio, phi);
        let (p1, t1) = (e.end_point(), e.end_frame().tangent);
        let base = interpolate(e.start, e.tangent, p1, t1, 1e-6).unwrap();
        let q = glam::DQuat::from_axis_angle(ax, angle);
        let map = |v: DVec3| q * v * scale + DVec3::from(shift);
        let moved = interpolate(map(e.start), q * e.tangent, map(p1), q * t1, 1e-6).unwrap();
        // The moved data's coordinates are rounded at their magnitude, up
        // to |shift|, against a helix of size ~scale: the recovered
        // parameters carry that ratio's share of rounding (a helix of
        // 0.008 moved 50 away: 8e-9 off in τ·s, where 1e-9 held before).
        let tol = 1e-9 * (1.0 + DVec3::from(shift).length() / scale / 100.0);
        prop_assert!((moved.phi - base.phi).abs() < tol);
        prop_assert!((moved.element.curvature * scale - base.element.curvature).abs() < tol);
        prop_assert!((moved.element.torsion * scale - base.element.torsion).abs() < tol);
        prop_assert!((moved.axis - q * base.axis).length() < tol);
        // Mirror through the xy-plane.
        let m = |v: DVec3| DVec3::new(v.x, v.y, -v.z);
        let mirrored = interpolate(m(e.start), m(e.tangent), m(p1), m(t1), 1e-6).unwrap();
        prop_assert!((mirrored.element.torsion + base.element.torsion).abs() < 1e-9);
        prop_assert!((mirrored.element.curvature - base.element.curvature).abs() < 1e-9);
    }

    /// Reversal symmetry: the helix from (p₁, −t₁) to (p₀, −t₀) is the same
    /// curve run backwards — same κ, same τ (torsion does not depend on the
    /// direction of travel), same length and φ*.
    #[test]
    fn reversal_gives_the_same_helix(
        t in prop::array::uniform3(-1.0f64..1.0),
        n in prop::array::uniform3(-1.0f64..1.0),
        tau_ratio in -5.0f64..5.0,
        phi in 0.01f64..6.2,
    ) {
        let (Some(t0), Some(nh)) = (unit(t), unit(n)) else { return Ok(()) };
        prop_assume!(t0.cross(nh).length() > 0.1);
        let e = helix(DVec3::ZERO, t0, nh, 1.3, 1.3 * tau_ratio, phi);
        let (p1, t1) = (e.end_point(), e.end_frame().tangent);
        let fwd = interpolate(e.start, t0, p1, t1, 1e-6).unwrap();
        let back = interpolate(p1, -t1, e.start, -t0, 1e-6).unwrap();
        prop_assert!((fwd.element.curvature - back.element.curvature).abs() < 1e-9);
        prop_assert!((fwd.element.torsion - back.element.torsion).abs() < 1e-9);
        prop_assert!((fwd.element.length - back.element.length).abs() < 1e-9 * fwd.element.length);
        // Midpoints coincide.
        let mid_f = fwd.element.point(0.5 * fwd.element.length);
        let mid_b = back.element.point(0.5 * back.element.length);
        prop_assert!((mid_f - mid_b).length() < 1e-9 * fwd.element.length);
    }
}

#[test]
fn circle_arcs_all_turning_angles() {
    // Planar case ⟨p1−p0, t1×t0⟩ = 0: φ* at an end of I₀ (ERRATA 2: the
    // arccos branch when ⟨p1−p0, t1+t0⟩ > 0).
    let r = 2.5;
    for k in 1..64 {
        let phi = TAU * k as f64 / 64.0;
        let p0 = DVec3::new(r, 0.0, 0.0);
        let p1 = DVec3::new(r * phi.cos(), r * phi.sin(), 0.0);
        let t0 = DVec3::Y;
        let t1 = DVec3::new(-phi.sin(), phi.cos(), 0.0);
        let h = interpolate(p0, t0, p1, t1, 1e-9).unwrap();
        assert!((h.phi - phi).abs() < 1e-12, "φ={phi}: got {}", h.phi);
        assert!((h.element.curvature - 1.0 / r).abs() < 1e-12);
        assert_eq!(h.element.torsion, 0.0);
        assert!((h.element.length - r * phi).abs() < 1e-11);
        assert!((h.axis - DVec3::Z).length() < 1e-12);
        let theta = t0.dot(t1).clamp(-1.0, 1.0).acos();
        let at_end = (h.phi - theta).abs().min((h.phi - (TAU - theta)).abs());
        assert!(at_end < 1e-12, "planar φ* is an end of I₀");
    }
    // Quarter circle: ⟨p1−p0, t1+t0⟩ > 0 and φ* = π/2 (ERRATA 2).
    let h = interpolate(DVec3::X, DVec3::Y, DVec3::Y, -DVec3::X, 1e-9).unwrap();
    assert!((h.phi - PI / 2.0).abs() < 1e-14);
}

#[test]
fn straight_segments() {
    let t = DVec3::new(1.0, 2.0, 2.0);
    let h = interpolate(DVec3::ONE, t, DVec3::ONE + 3.0 * t, t * 7.0, 1e-9).unwrap();
    assert_eq!(h.element.curvature, 0.0);
    assert_eq!(h.element.torsion, 0.0);
    assert!((h.element.length - 9.0).abs() < 1e-14);
    assert!((h.element.end_point() - (DVec3::ONE + 3.0 * t)).length() < 1e-13);
    // Chord pointing backwards, or off the tangent: no short helix.
    let back = interpolate(DVec3::ZERO, DVec3::X, -DVec3::X, DVec3::X, 1e-9);
    assert!(matches!(
        back,
        Err(HelixError::ParallelTangentsOffChord { .. })
    ));
    let off = interpolate(
        DVec3::ZERO,
        DVec3::X,
        DVec3::new(1.0, 0.1, 0.0),
        DVec3::X,
        1e-9,
    );
    match off {
        Err(HelixError::ParallelTangentsOffChord { deviation }) => {
            assert!((deviation - 0.1f64.atan()).abs() < 1e-12)
        }
        other => panic!("expected an error, got {other:?}"),
    }
}

#[test]
fn half_circle_for_opposite_tangents() {
    let d = 3.0;
    let h = interpolate(
        DVec3::ZERO,
        DVec3::X,
        DVec3::new(0.0, d, 0.0),
        -DVec3::X,
        1e-9,
    )
    .unwrap();
    assert!((h.phi - PI).abs() < 1e-15);
    assert!((h.element.curvature - 2.0 / d).abs() < 1e-15);
    assert_eq!(h.element.torsion, 0.0);
    assert!((h.element.length - PI * d / 2.0).abs() < 1e-14);
    assert!((h.element.end_point() - DVec3::new(0.0, d, 0.0)).length() < 1e-14);
    assert!((h.element.end_frame().tangent + DVec3::X).length() < 1e-15);
    // Nearly opposite tangents converge to it continuously.
    let eps = 1e-9;
    let t1 = DVec3::new(-1.0, 0.0, eps).normalize();
    let near = interpolate(DVec3::ZERO, DVec3::X, DVec3::new(0.0, d, 0.0), t1, 1e-6).unwrap();
    assert!((near.phi - PI).abs() < 1e-6);
    assert!((near.element.end_point() - DVec3::new(0.0, d, 0.0)).length() < 1e-12);
    // Opposite tangents with a chord not ⊥ t0 are not co-helical.
    let bad = interpolate(
        DVec3::ZERO,
        DVec3::X,
        DVec3::new(0.5, d, 0.0),
        -DVec3::X,
        1e-9,
    );
    assert!(matches!(bad, Err(HelixError::NotCoHelical { .. })));
}

#[test]
fn bad_inputs_are_errors_with_reasons() {
    let same = interpolate(DVec3::ONE, DVec3::X, DVec3::ONE, DVec3::Y, 1e-6);
    assert_eq!(same, Err(HelixError::CoincidentPoints));
    assert_eq!(
        interpolate(DVec3::ZERO, DVec3::ZERO, DVec3::X, DVec3::X, 1e-6),
        Err(HelixError::ZeroTangent)
    );
    assert_eq!(
        interpolate(
            DVec3::new(f64::NAN, 0.0, 0.0),
            DVec3::X,
            DVec3::X,
            DVec3::X,
            1e-6
        ),
        Err(HelixError::NonFinite)
    );
    // Not co-helical: chord along t1 − t0. The error says by how much.
    let t0 = DVec3::X;
    let t1 = DVec3::Y;
    let err = interpolate(
        DVec3::ZERO,
        t0,
        DVec3::ZERO + (t1 - t0) + DVec3::Z,
        t1,
        1e-6,
    )
    .unwrap_err();
    match err {
        HelixError::NotCoHelical {
            residual,
            tolerance,
        } => {
            let expect = (t1 - t0).length() / ((t1 - t0) + DVec3::Z).length();
            assert!((residual - expect).abs() < 1e-12);
            assert_eq!(tolerance, 1e-6);
            assert!(err.to_string().contains("not co-helical"));
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn uniqueness_the_root_is_the_only_sign_change() {
    // H is increasing on I₀ (paper, Section 5.2.1): the interpolant does not
    // depend on which of two different bracketings we would have started from.
    // We check the consequence: data generated by helices with φ* on either
    // side of π are recovered, and φ* moves monotonically with χ.
    let t0 = DVec3::X;
    let t1 = DVec3::new(0.2, 0.9, 0.3).normalize();
    let e1 = (t1 + t0).normalize();
    let e2 = t1.cross(t0).normalize();
    let mut last = 0.0;
    for k in 0..200 {
        // Sweep the chord direction in the plane ⊥ e3, from +e1 to −e1
        // through +e2 (χ decreases, so φ* increases).
        let a = PI * (k as f64 + 0.5) / 200.0;
        let d = a.cos() * e1 + a.sin() * e2;
        let h = interpolate(DVec3::ZERO, t0, d, t1, 1e-9).unwrap();
        assert!(h.phi > last, "φ* must increase as χ decreases");
        last = h.phi;
        assert!((h.element.end_point() - d).length() < 1e-12);
        assert!((h.element.end_frame().tangent - t1).length() < 1e-12);
    }
}

/// The reference (Brent) and the GPU kernel's `f64` twin (bisection) solve the
/// same equation from the same half-angle data, so on short arcs — where κ is
/// determined by the data only to `~ε/θ` — they must still agree to a few ε:
/// neither may form `sin(β − x)` from the rounded `β = π − θ` (which costs
/// `ε/θ` relative; 4e-10 at θ = 1e-6).
#[test]
fn reference_and_twin_agree_on_short_arcs() {
    use strandfit::helix::HermitePair;
    use strandfit::kernels::ghosh_bisect::interpolate_twin;
    let mut pairs = Vec::new();
    let mut k = 0u64;
    for i in 0..400 {
        // Deterministic spread: θ from 1e-7 to 1e-2, τ/κ from −3 to 3.
        k = k
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let u = (k >> 11) as f64 / (1u64 << 53) as f64;
        let phi = 10f64.powf(-7.0 + 5.0 * (i as f64 / 400.0));
        let tau = -3.0 + 6.0 * u;
        let t0 = DVec3::new(0.3, -0.5, 0.8).normalize();
        let e = helix(
            DVec3::new(1.0, 2.0, -3.0),
            t0,
            DVec3::new(1.0, u, 0.2),
            1.0,
            tau,
            phi,
        );
        pairs.push(HermitePair {
            p0: e.start,
            t0: e.tangent,
            p1: e.end_point(),
            t1: e.end_frame().tangent,
        });
    }
    let twin = interpolate_twin::<f64>(&pairs, DEFAULT_COHELICAL_TOL);
    let mut worst = 0.0f64;
    for (p, t) in pairs.iter().zip(&twin) {
        let r = p.interpolate(DEFAULT_COHELICAL_TOL).unwrap().element;
        let t = t.as_ref().unwrap().element;
        let w = r.omega();
        worst = worst
            .max((r.curvature - t.curvature).abs() / (w * f64::EPSILON))
            .max((r.torsion - t.torsion).abs() / (w * f64::EPSILON));
    }
    eprintln!("short arcs: reference vs twin, worst |Δκ|, |Δτ| = {worst:.1} ε·ω");
    assert!(worst <= 64.0, "{worst} ε·ω");
}
