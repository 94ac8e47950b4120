//! Piecewise helices: continuity of fitted chains, evaluation, and the
//! compact parameter form (which must rebuild the relaxed points).

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use strandfit::helix::{interpolate, relax, PiecewiseHelix, Relaxation};

fn random_unit(rng: &mut impl Rng) -> DVec3 {
    loop {
        let v = DVec3::new(
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
        );
        if v.length() > 0.1 && v.length() < 1.0 {
            return v.normalize();
        }
    }
}

/// A chain from random, slowly turning data; `straight_run` makes three
/// consecutive tangents equal (straight elements between them).
fn random_chain(rng: &mut impl Rng, n: usize, straight_run: bool) -> (PiecewiseHelix, Vec<DVec3>) {
    let mut p = vec![DVec3::new(5.0, -2.0, 1.0)];
    let mut t = vec![random_unit(rng)];
    for i in 0..n {
        let nt = if straight_run && (3..5).contains(&i) {
            t[i]
        } else {
            (t[i] + 0.4 * random_unit(rng)).normalize()
        };
        let step = rng.gen_range(0.5..1.5);
        let chord = if straight_run && (3..5).contains(&i) {
            t[i]
        } else {
            (t[i] + nt).normalize()
        };
        p.push(p[i] + step * chord + 0.02 * random_unit(rng));
        t.push(nt);
    }
    let relaxed = relax(&p, &t, Relaxation::Tridiagonal);
    let elements = (0..n)
        .map(|i| {
            interpolate(relaxed[i], t[i], relaxed[i + 1], t[i + 1], 1e-6)
                .unwrap()
                .element
        })
        .collect();
    (PiecewiseHelix::new(elements), relaxed)
}

#[test]
fn fitted_chains_are_g1() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for n in [1, 2, 5, 20, 100] {
        let (chain, relaxed) = random_chain(&mut rng, n, n >= 20);
        let (gap, angle) = chain.continuity_defects();
        let scale = chain.length();
        assert!(gap < 1e-12 * scale, "gap {gap}");
        assert!(angle < 1e-11, "tangent jump {angle}");
        assert!(
            (chain.elements().last().unwrap().end_point() - relaxed[n]).length() < 1e-12 * scale
        );
    }
}

#[test]
fn params_rebuild_the_relaxed_points() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    for n in [1, 3, 10, 50, 300] {
        for straight in [false, true] {
            if straight && n < 10 {
                continue;
            }
            let (chain, relaxed) = random_chain(&mut rng, n, straight);
            let params = chain.to_params().unwrap();
            assert_eq!(params.elements.len(), n);
            let rebuilt = PiecewiseHelix::from_params(&params);
            let scale = relaxed
                .iter()
                .map(|q| (*q - relaxed[0]).length())
                .fold(0.0, f64::max);
            for (i, e) in rebuilt.elements().iter().enumerate() {
                let err = (e.start - relaxed[i]).length();
                assert!(err <= 1e-9 * scale, "n={n} point {i}: {err}");
            }
            let end = rebuilt.elements().last().unwrap().end_point();
            assert!((end - relaxed[n]).length() <= 1e-9 * scale);
            // The rebuilt chain is exactly continuous and agrees everywhere.
            let (gap, _) = rebuilt.continuity_defects();
            assert_eq!(gap, 0.0);
            for k in 0..=50 {
                let s = chain.length() * k as f64 / 50.0;
                let d = (chain.point(s).unwrap() - rebuilt.point(s).unwrap()).length();
                assert!(d <= 1e-9 * scale);
            }
        }
    }
}

#[test]
fn evaluation_by_arc_length() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let (chain, _) = random_chain(&mut rng, 8, false);
    let total: f64 = chain.elements().iter().map(|e| e.length).sum();
    assert!((chain.length() - total).abs() < 1e-12);
    assert_eq!(chain.point(-1.0), Some(chain.elements()[0].start));
    let pts = chain.sample(200);
    assert_eq!(pts.len(), 200);
    assert_eq!(pts[0], chain.elements()[0].start);
    assert!((pts[199] - chain.elements()[7].end_point()).length() < 1e-14);
    // Consecutive samples are (nearly) equally spaced along the curve: the
    // chord never exceeds the arc step.
    let step = chain.length() / 199.0;
    for w in pts.windows(2) {
        assert!((w[1] - w[0]).length() <= step * (1.0 + 1e-12));
    }
    // Frames are orthonormal and tangents are unit.
    for k in 0..=40 {
        let f = chain.frame(chain.length() * k as f64 / 40.0).unwrap();
        assert!((f.tangent.length() - 1.0).abs() < 1e-13);
        assert!(f.tangent.dot(f.normal).abs() < 1e-13);
    }
    // Complexity of a chain is Σ ωL = Σ φ*.
    let c: f64 = chain
        .elements()
        .iter()
        .map(|e| e.curvature.hypot(e.torsion) * e.length)
        .sum();
    assert!((chain.complexity() - c).abs() < 1e-12);
    assert!(PiecewiseHelix::new(vec![]).point(0.0).is_none());
}
