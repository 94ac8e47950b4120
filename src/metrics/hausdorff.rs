//! Hausdorff distances between polylines and between vertex sets.
//!
//! [`hausdorff`] is the *vertex-to-polyline* Hausdorff distance
//!
//! ```text
//! H(A, B) = max( max_{a ∈ vert A} d(a, B), max_{b ∈ vert B} d(b, A) )
//! ```
//!
//! where `d(p, B)` is the distance from `p` to the polyline `B` (its
//! segments, not only its vertices). The true (continuous) Hausdorff distance
//! between the polylines takes the sup over *all* points of `A` and `B`, and
//! that sup can be attained in the interior of a segment: for the "V"
//! `A = (−1,1), (0,0), (1,1)` and the closed triangle
//! `B = (−1,1), (1,1), (0,0)`, every vertex of each lies on the other, so
//! `H = 0`, while the midpoint `(0,1)` of `B`'s top edge is `1/√2` from `A`.
//!
//! Why vertices suffice for densely sampled curves: `p ↦ d(p, B)` is
//! 1-Lipschitz, so a point at distance `s` along a segment of `A` of length
//! `ℓ` satisfies `d(p, B) ≤ min(d(a₀, B) + s, d(a₁, B) + ℓ − s) ≤ H + ℓ/2`.
//! Hence `H ≤ H_true ≤ H + h/2`, with `h` the longest segment of either
//! polyline. For curves sampled at spacing `h` much finer than the distances
//! being measured, `H` is the continuous distance up to `h/2` (and usually
//! far better, since the maximiser is typically near a vertex).
//!
//! A polyline of one point is that point. Repeated vertices (zero-length
//! segments) are allowed.
//!
//! All functions are `O(mn)` with an early exit: while scanning for the
//! nearest point of `B` to a vertex `a`, the scan stops as soon as some
//! distance falls below the running maximum, since `a` can then no longer
//! raise the maximum (Taha & Hanbury 2015). Squared distances are used
//! throughout and one square root taken at the end.

use glam::DVec3;

use super::error::{check, MetricsError};

/// Symmetric vertex-to-polyline Hausdorff distance between the polylines `a`
/// and `b` (see the module documentation for how it relates to the continuous
/// Hausdorff distance).
///
/// Errors: [`MetricsError::Empty`] if either is empty,
/// [`MetricsError::NonFinite`] on NaN or infinite coordinates.
pub fn hausdorff(a: &[DVec3], b: &[DVec3]) -> Result<f64, MetricsError> {
    check(a)?;
    check(b)?;
    let d2 = directed_poly2(a, b, 0.0);
    Ok(directed_poly2(b, a, d2).sqrt())
}

/// Directed vertex-to-polyline distance `max_{a ∈ vert A} d(a, B)`.
///
/// Errors as for [`hausdorff`].
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
pub fn hausdorff_vertices(a: &[DVec3], b: &[DVec3]) -> Result<f64, MetricsError> {
    check(a)?;
    check(b)?;
    let d2 = directed_vert2(a, b, 0.0);
    Ok(directed_vert2(b, a, d2).sqrt())
}

/// Directed vertex-set distance `max_{a ∈ A} min_{b ∈ B} |a − b|`.
///
/// Errors as for [`hausdorff`].
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
