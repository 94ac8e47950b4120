//! Hausdorff distances between polylines and between vertex sets. How the
//! vertex-to-polyline distance relates to the continuous one, and the
//! early exit, are described on `hausdorff`.

use glam::DVec3;

use super::error::{check, MetricsError};

/// Symmetric vertex-to-polyline Hausdorff distance between the polylines `a`
/// and `b` (see
/// [Vertices and the continuous distance](hausdorff#vertices-and-the-continuous-distance)
/// for how it relates to the continuous Hausdorff distance).
///
/// Errors: [`MetricsError::Empty`] if either is empty,
/// [`MetricsError::NonFinite`] on NaN or infinite coordinates.
///
/// ```
/// use strandfit::{metrics::hausdorff, DVec3};
///
/// let a = [DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0)];
/// let b = [DVec3::new(0.0, 0.5, 0.0), DVec3::new(1.0, 0.5, 0.0), DVec3::new(2.0, 0.5, 0.0)];
/// assert_eq!(hausdorff(&a, &b).unwrap(), 0.5);
/// ```
///
/// # Vertices and the continuous distance
///
/// This is the *vertex-to-polyline* Hausdorff distance
///
/// ```text
/// H(A, B) = max( max_{a ∈ vert A} d(a, B), max_{b ∈ vert B} d(b, A) )
/// ```
///
/// where `d(p, B)` is the distance from `p` to the polyline `B` (its
/// segments, not only its vertices). The true (continuous) Hausdorff distance
/// between the polylines takes the sup over *all* points of `A` and `B`, and
/// that sup can be attained in the interior of a segment: for the "V"
/// `A = (−1,1), (0,0), (1,1)` and the "lid and diagonal"
/// `B = (−1,1), (1,1), (0,0)`, every vertex of each lies on the other, so
/// `H = 0`, while the midpoint `(0,1)` of `B`'s top edge is `1/√2` from `A`.
///
/// Why vertices suffice for densely sampled curves: `p ↦ d(p, B)` is
/// 1-Lipschitz, so a point at distance `s` along a segment of `A` of length
/// `ℓ` satisfies `d(p, B) ≤ min(d(a₀, B) + s, d(a₁, B) + ℓ − s) ≤ H + ℓ/2`.
/// Hence `H ≤ H_true ≤ H + h/2`, with `h` the longest segment of either
/// polyline. For curves sampled at spacing `h` much finer than the distances
/// being measured, `H` is the continuous distance up to `h/2` (and usually
/// far better, since the maximiser is typically near a vertex).
///
/// A polyline of one point is that point. Repeated vertices (zero-length
/// segments) are allowed.
///
/// # Cost
///
/// All the Hausdorff functions of [`metrics`](crate::metrics) are `O(mn)` with
/// an early exit: while scanning for the nearest point of `B` to a vertex `a`,
/// the scan stops as soon as some distance falls below the running maximum,
/// since `a` can then no longer raise the maximum (Taha & Hanbury 2015).
/// Squared distances are used throughout and one square root taken at the end.
pub fn hausdorff(a: &[DVec3], b: &[DVec3]) -> Result<f64, MetricsError> {
    check(a)?;
    check(b)?;
    let d2 = directed_poly2(a, b, 0.0);
    Ok(directed_poly2(b, a, d2).sqrt())
}

/// Directed vertex-to-polyline distance `max_{a ∈ vert A} d(a, B)`.
///
/// Errors as for [`hausdorff`].
///
/// A point half a unit above a segment, and the other way round:
/// ```
/// use strandfit::{metrics::hausdorff_directed, DVec3};
///
/// let a = [DVec3::new(1.0, 0.5, 0.0)];
/// let b = [DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0)];
/// assert_eq!(hausdorff_directed(&a, &b).unwrap(), 0.5);
/// assert!((hausdorff_directed(&b, &a).unwrap() - 1.25f64.sqrt()).abs() < 1e-15);
/// ```
pub fn hausdorff_directed(a: &[DVec3], b: &[DVec3]) -> Result<f64, MetricsError> {
    check(a)?;
    check(b)?;
    Ok(directed_poly2(a, b, 0.0).sqrt())
}

/// Symmetric Hausdorff distance between the vertex *sets* of `a` and `b`
/// (the order of the points is ignored). It is never smaller than
/// [`hausdorff`], since a polyline contains its vertices, and never larger
/// than the discrete Fréchet distance, since a coupling pairs every point
/// with some point of the other sequence.
///
/// Errors as for [`hausdorff`].
///
/// Vertices only: the middle vertex of `b` is `√1.25` from the nearest vertex of
/// `a`, though only `0.5` from the segment ([`hausdorff`] gives `0.5`):
/// ```
/// use strandfit::{metrics::hausdorff_vertices, DVec3};
///
/// let a = [DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0)];
/// let b = [DVec3::new(0.0, 0.5, 0.0), DVec3::new(1.0, 0.5, 0.0), DVec3::new(2.0, 0.5, 0.0)];
/// assert!((hausdorff_vertices(&a, &b).unwrap() - 1.25f64.sqrt()).abs() < 1e-15);
/// ```
pub fn hausdorff_vertices(a: &[DVec3], b: &[DVec3]) -> Result<f64, MetricsError> {
    check(a)?;
    check(b)?;
    let d2 = directed_vert2(a, b, 0.0);
    Ok(directed_vert2(b, a, d2).sqrt())
}

/// Directed vertex-set distance `max_{a ∈ A} min_{b ∈ B} |a − b|`.
///
/// Errors as for [`hausdorff`].
///
/// ```
/// use strandfit::{metrics::hausdorff_vertices_directed, DVec3};
///
/// let a = [DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0)];
/// let b = [DVec3::new(0.0, 0.5, 0.0), DVec3::new(1.0, 0.5, 0.0), DVec3::new(2.0, 0.5, 0.0)];
/// assert_eq!(hausdorff_vertices_directed(&a, &b).unwrap(), 0.5);
/// assert!((hausdorff_vertices_directed(&b, &a).unwrap() - 1.25f64.sqrt()).abs() < 1e-15);
/// ```
pub fn hausdorff_vertices_directed(a: &[DVec3], b: &[DVec3]) -> Result<f64, MetricsError> {
    check(a)?;
    check(b)?;
    Ok(directed_vert2(a, b, 0.0).sqrt())
}

/// `max(cmax, max_{a ∈ A} d(a, B)²)`, `B` a non-empty polyline.
fn directed_poly2(a: &[DVec3], b: &[DVec3], mut cmax: f64) -> f64 {
    if b.len() == 1 {
        return directed_vert2(a, b, cmax);
    }
    for &p in a {
        let mut cmin = f64::INFINITY;
        for s in b.windows(2) {
            cmin = cmin.min(point_segment2(p, s[0], s[1]));
            if cmin <= cmax {
                break; // `p` cannot raise the maximum
            }
        }
        cmax = cmax.max(cmin);
    }
    cmax
}

/// `max(cmax, max_{a ∈ A} min_{b ∈ B} |a − b|²)`, `B` non-empty.
fn directed_vert2(a: &[DVec3], b: &[DVec3], mut cmax: f64) -> f64 {
    for &p in a {
        let mut cmin = f64::INFINITY;
        for &q in b {
            cmin = cmin.min(p.distance_squared(q));
            if cmin <= cmax {
                break; // `p` cannot raise the maximum
            }
        }
        cmax = cmax.max(cmin);
    }
    cmax
}

/// Squared distance from `p` to the segment `[q0, q1]`.
///
/// The nearest point is `q0 + t(q1 − q0)` with
/// `t = clamp((p − q0)·(q1 − q0) / |q1 − q0|², 0, 1)`; a zero-length segment
/// is the point `q0`. The clamp keeps the foot on the segment even when the
/// ratio is inexact, so the result is the distance to a point of the segment
/// (within rounding), never smaller than the true distance by more than a few
/// ulps.
#[inline]
pub(crate) fn point_segment2(p: DVec3, q0: DVec3, q1: DVec3) -> f64 {
    let d = q1 - q0;
    let w = p - q0;
    let dd = d.length_squared();
    let t = if dd > 0.0 {
        (w.dot(d) / dd).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (w - t * d).length_squared()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn v(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z)
    }

    #[test]
    fn point_to_segment() {
        let seg = [v(0., 0., 0.), v(2., 0., 0.)];
        // Foot in the interior: distance 1 to the segment, √2 to the
        // nearest vertex.
        let p = [v(1., 1., 0.)];
        assert_eq!(hausdorff_directed(&p, &seg).unwrap(), 1.0);
        assert_eq!(hausdorff_vertices_directed(&p, &seg).unwrap(), 2f64.sqrt());
        // Symmetric: the segment's vertices are √2 from the point.
        assert_eq!(hausdorff(&p, &seg).unwrap(), 2f64.sqrt());
        assert_eq!(hausdorff(&seg, &p).unwrap(), 2f64.sqrt());
        // Foot clamped to the end (2, 0, 0): offset (1, 0, 4), length √17.
        let q = [v(3., 0., 4.)];
        assert_eq!(hausdorff_directed(&q, &seg).unwrap(), 17f64.sqrt());
        // Zero-length segments are points.
        let dup = [v(0., 0., 0.), v(0., 0., 0.), v(0., 3., 4.)];
        assert_eq!(hausdorff_directed(&[v(0., 0., -2.)], &dup).unwrap(), 2.0);
    }

    #[test]
    fn parallel_polylines() {
        let a = [v(0., 0., 0.), v(1., 0., 0.), v(5., 0., 0.)];
        let b = [v(-1., 0., 1.), v(3., 0., 1.), v(6., 0., 1.)];
        // b overhangs a by 1 at both ends, so its end vertices are √2 from a's;
        // everything else is 1 away.
        assert_eq!(hausdorff(&a, &b).unwrap(), 2f64.sqrt());
        let b = [v(0., 0., 1.), v(3., 0., 1.), v(5., 0., 1.)];
        assert_eq!(hausdorff(&a, &b).unwrap(), 1.0);
    }

    /// The example of `hausdorff`'s documentation: the sup is attained at an
    /// edge midpoint, not at a vertex, and is bounded by `H + h/2`.
    #[test]
    fn interior_maximiser() {
        let a = [v(-1., 1., 0.), v(0., 0., 0.), v(1., 1., 0.)];
        let b = [v(-1., 1., 0.), v(1., 1., 0.), v(0., 0., 0.)];
        let h = hausdorff(&a, &b).unwrap();
        assert_eq!(h, 0.0);
        let mid = [v(0., 1., 0.)];
        let true_lb = hausdorff_directed(&mid, &a).unwrap();
        assert!((true_lb - 0.5f64.sqrt()).abs() < 1e-15);
        assert!(true_lb <= h + 2.0 / 2.0); // longest edge of b is 2
    }

    #[test]
    fn bad_input() {
        let a = [v(0., 0., 0.)];
        assert_eq!(hausdorff(&[], &a), Err(MetricsError::Empty));
        assert_eq!(hausdorff_vertices(&a, &[]), Err(MetricsError::Empty));
        let n = [v(0., 0., f64::NAN)];
        assert_eq!(hausdorff(&a, &n), Err(MetricsError::NonFinite));
        assert_eq!(
            hausdorff_vertices_directed(&n, &a),
            Err(MetricsError::NonFinite)
        );
    }

    /// Subdivide every segment into `k` pieces (same polyline, more vertices).
    fn densify(p: &[DVec3], k: usize) -> Vec<DVec3> {
        let mut out = vec![p[0]];
        for s in p.windows(2) {
            for i in 1..=k {
                out.push(s[0].lerp(s[1], i as f64 / k as f64));
            }
        }
        out
    }

    /// Reference for the directed vertex-to-polyline distance, without the
    /// early exit.
    fn directed_brute(a: &[DVec3], b: &[DVec3]) -> f64 {
        a.iter()
            .map(|&p| {
                if b.len() == 1 {
                    p.distance(b[0])
                } else {
                    b.windows(2)
                        .map(|s| point_segment2(p, s[0], s[1]).sqrt())
                        .fold(f64::INFINITY, f64::min)
                }
            })
            .fold(0.0, f64::max)
    }

    fn pts(max: usize) -> impl Strategy<Value = Vec<DVec3>> {
        prop::collection::vec(
            (-10.0..10.0f64, -10.0..10.0f64, -10.0..10.0f64).prop_map(|(x, y, z)| v(x, y, z)),
            1..max,
        )
    }

    proptest! {
        #[test]
        fn symmetric_and_matches_brute(a in pts(15), b in pts(15)) {
            let h = hausdorff(&a, &b).unwrap();
            prop_assert_eq!(h, hausdorff(&b, &a).unwrap());
            prop_assert_eq!(h, directed_brute(&a, &b).max(directed_brute(&b, &a)));
            let hv = hausdorff_vertices(&a, &b).unwrap();
            prop_assert_eq!(hv, hausdorff_vertices(&b, &a).unwrap());
            prop_assert_eq!(hausdorff(&a, &a).unwrap(), 0.0);
        }

        /// `H ≤ H_true ≤ H + h/2`, with `H_true` estimated by densifying
        /// both polylines (densifying only adds points of the same curves).
        #[test]
        fn vertex_sup_bounds(a in pts(8), b in pts(8)) {
            let h = hausdorff(&a, &b).unwrap();
            let hd = hausdorff(&densify(&a, 64), &densify(&b, 64)).unwrap();
            let seg_max = a.windows(2).chain(b.windows(2))
                .map(|s| s[0].distance(s[1])).fold(0.0, f64::max);
            prop_assert!(h <= hd + 1e-9, "{h} > {hd}");
            prop_assert!(hd <= h + 0.5 * seg_max + 1e-9, "{hd} > {h} + {seg_max}/2");
        }
    }
}
