//! Continuous Fréchet distance between polylines (Alt & Godau 1995): the
//! definition and the value on `frechet_polyline`, the decision on
//! `frechet_within`.

use glam::DVec3;

use super::error::{check, MetricsError};

/// Closed interval of a segment parameter in `[0, 1]`.
type Interval = Option<(f64, f64)>;

/// The parameters `t ∈ [0, 1]` with `|a + t(b − a) − p| ≤ eps`: where a
/// segment meets a closed ball, one interval or none.
fn free_interval(p: DVec3, a: DVec3, b: DVec3, eps2: f64) -> Interval {
    let d = b - a;
    let w = a - p;
    let dd = d.length_squared();
    if dd == 0.0 {
        return (w.length_squared() <= eps2).then_some((0.0, 1.0));
    }
    // |w + t d|² ≤ ε²: centred on the foot of the perpendicular t* with
    // half-width √(ε² − h²)/|d|, h the distance to the line. Computing h
    // from the vector w + t* d (not from the quadratic's discriminant,
    // which cancels catastrophically when p is on the line) keeps the
    // interval right down to ε ≈ ulp(|p|).
    let ts = -d.dot(w) / dd;
    let h2 = (w + ts * d).length_squared();
    if h2 > eps2 {
        return None;
    }
    let half = ((eps2 - h2) / dd).sqrt();
    let (t0, t1) = (ts - half, ts + half);
    let (lo, hi) = (t0.max(0.0), t1.min(1.0));
    (lo <= hi).then_some((lo, hi))
}

/// `Interval ∩ [from, 1]`.
fn from(iv: Interval, lo: f64) -> Interval {
    iv.and_then(|(a, b)| (a.max(lo) <= b).then_some((a.max(lo), b)))
}

/// `F(P, Q) ≤ eps`, for the continuous Fréchet distance `F` (defined on
/// [`frechet_polyline`])? Polylines of one point are points. Errors: empty or
/// non-finite input.
///
/// A tent of height `0.3` over a segment: `F = 0.3`:
/// ```
/// use strandfit::{metrics::frechet_within, DVec3};
///
/// let p = [DVec3::ZERO, DVec3::X];
/// let q = [DVec3::ZERO, DVec3::new(0.5, 0.3, 0.0), DVec3::X];
/// assert!(frechet_within(&p, &q, 0.3 + 1e-12).unwrap());
/// assert!(!frechet_within(&p, &q, 0.3 - 1e-9).unwrap());
/// ```
///
/// # Method
///
/// Alt and Godau's free-space diagram. On
/// the grid of cells (segment `i` of `P`) × (segment `j` of `Q`), the free
/// space `{(s, t) : |P(s) − Q(t)| ≤ ε}` is convex in each cell, so it is
/// described by its intervals on the cell edges (a segment meets a ball in
/// one interval). `F ≤ ε` iff the top-right corner is reachable from the
/// bottom-left one by a path monotone in both parameters; reachable edge
/// intervals propagate cell by cell. `O(mn)` time, `O(n)` memory.
pub fn frechet_within(p: &[DVec3], q: &[DVec3], eps: f64) -> Result<bool, MetricsError> {
    check(p)?;
    check(q)?;
    Ok(within(p, q, eps, &mut Vec::new(), &mut Vec::new()))
}

fn within(
    p: &[DVec3],
    q: &[DVec3],
    eps: f64,
    left: &mut Vec<Interval>,
    right: &mut Vec<Interval>,
) -> bool {
    if !(eps >= 0.0) {
        return false;
    }
    let eps2 = eps * eps;
    let (m, n) = (p.len() - 1, q.len() - 1);
    if p[0].distance_squared(q[0]) > eps2 || p[m].distance_squared(q[n]) > eps2 {
        return false;
    }
    // A point against a polyline: every point of the polyline must be
    // within ε, and distance to a point is convex along segments.
    if m == 0 {
        return q.iter().all(|x| x.distance_squared(p[0]) <= eps2);
    }
    if n == 0 {
        return p.iter().all(|x| x.distance_squared(q[0]) <= eps2);
    }
    // left[j]: reachable part of the left edge of cell (i, j), i.e. of
    // {P(i)} × segment j of Q. Column i = 0 is the left boundary, reachable
    // only straight up from (0, 0) while the free space is unbroken.
    left.clear();
    let mut open = true;
    for j in 0..n {
        let iv = if open {
            free_interval(p[0], q[j], q[j + 1], eps2)
        } else {
            None
        };
        let iv = iv.filter(|&(a, _)| a == 0.0);
        open = matches!(iv, Some((_, b)) if b == 1.0);
        left.push(iv);
    }
    // `bottom_open`: the bottom boundary t = 0 is reachable up to segment i.
    let mut bottom_open = true;
    for i in 0..m {
        right.clear();
        // Bottom edge of cell (i, 0): {segment i of P} × {Q(0)}.
        let mut bottom = if bottom_open {
            free_interval(q[0], p[i], p[i + 1], eps2).filter(|&(a, _)| a == 0.0)
        } else {
            None
        };
        bottom_open = matches!(bottom, Some((_, b)) if b == 1.0);
        for j in 0..n {
            let l = left[j];
            let r_free = free_interval(p[i + 1], q[j], q[j + 1], eps2);
            let t_free = free_interval(q[j + 1], p[i], p[i + 1], eps2);
            // Right edge: from the bottom anything free; from the left only
            // at or above the lowest reachable point.
            let r = match (bottom, l) {
                (Some(_), _) => r_free,
                (None, Some((a, _))) => from(r_free, a),
                (None, None) => None,
            };
            let top = match (l, bottom) {
                (Some(_), _) => t_free,
                (None, Some((a, _))) => from(t_free, a),
                (None, None) => None,
            };
            right.push(r);
            bottom = top;
        }
        // `bottom` is now the top edge of cell (i, n − 1): the top boundary.
        if i == m - 1 {
            let top_reaches = matches!(bottom, Some((_, b)) if b == 1.0);
            let right_reaches = matches!(right[n - 1], Some((_, b)) if b == 1.0);
            return top_reaches || right_reaches;
        }
        std::mem::swap(left, right);
    }
    unreachable!("m ≥ 1 returns inside the loop")
}

/// Continuous Fréchet distance between polylines, to within `rel_tol`
/// relative (plus `1e-300` absolute): the returned value `F̃` satisfies
/// `F ≤ F̃ ≤ F(1 + rel_tol)`. Errors: empty or non-finite input.
///
/// A path along `x` that runs ahead to `1.5`, back to `0.5`, then on to `2`:
/// the Hausdorff distance is 0, but the coupling has to wait out half the
/// backtrack, `F = 0.5`:
/// ```
/// use strandfit::{metrics::frechet_polyline, DVec3};
///
/// let p = [DVec3::ZERO, 2.0 * DVec3::X];
/// let q = [DVec3::ZERO, 1.5 * DVec3::X, 0.5 * DVec3::X, 2.0 * DVec3::X];
/// let f = frechet_polyline(&p, &q, 1e-9).unwrap();
/// assert!(f >= 0.5 && f <= 0.5 * (1.0 + 1e-9));
/// ```
///
/// # Definition
///
/// The discrete Fréchet distance of [`discrete_frechet`](super::discrete_frechet)
/// couples vertices only, so two samplings of the same curve at spacing `h`
/// are up to `h/2` apart: useless for checking a fit to a tolerance below the
/// sampling step of the data (tractography is stored every ≈ 0.5–1 mm and
/// compressed to 0.1–0.5 mm). The continuous distance couples every point of
/// one polyline with a point of the other:
///
/// ```text
/// F(P, Q) = inf over monotone reparametrisations α, β of max_t |P(α(t)) − Q(β(t))|.
/// ```
///
/// # Method
///
/// Bisection on `ε` between the lower bound `max(|P₀ − Q₀|, |P_m − Q_n|)` and
/// the upper bound given by the discrete distance of the vertices, to a
/// relative accuracy the caller chooses.
pub fn frechet_polyline(p: &[DVec3], q: &[DVec3], rel_tol: f64) -> Result<f64, MetricsError> {
    let (mut l, mut r) = (Vec::new(), Vec::new());
    smallest_passing(p, q, rel_tol, |eps| within(p, q, eps, &mut l, &mut r))
}

/// The smallest `ε` for which the monotone test `passes` holds, by
/// bisection to `rel_tol` (an upper bound `≤ (1 + rel_tol)·exact`) between
/// the end points' distance (a lower bound of both distances here) and the
/// discrete Fréchet distance of the vertices (an upper bound of both: it
/// couples every vertex in order).
fn smallest_passing(
    p: &[DVec3],
    q: &[DVec3],
    rel_tol: f64,
    mut passes: impl FnMut(f64) -> bool,
) -> Result<f64, MetricsError> {
    check(p)?;
    check(q)?;
    let mut lo = p[0]
        .distance(q[0])
        .max(p[p.len() - 1].distance(q[q.len() - 1]));
    let mut hi = super::discrete_frechet(p, q)?;
    if passes(lo) {
        return Ok(lo);
    }
    let rel_tol = rel_tol.max(4.0 * f64::EPSILON);
    while hi - lo > rel_tol * hi && hi > 1e-300 {
        let mid = 0.5 * (lo + hi);
        if passes(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Ok(hi)
}

/// Do the points `p` lie within `eps` of the polyline `q` *in order*:
/// are there positions `0 = t₀ ≤ t₁ ≤ … ≤ t_m = end` along `q` with
/// `|pᵢ − q(tᵢ)| ≤ eps`? This is the Fréchet distance with `p` taken as
/// its vertices only (discrete) and `q` as a curve (continuous): what a
/// fit of sampled data can be held to. The continuous distance between the
/// polylines also charges the input's own chords (a smooth curve through
/// samples spaced `h` on a bend of radius `R` is `h²/8R` from their
/// chords), a floor no fit can get under; this one does not, and it still
/// forbids going back, skipping a stretch or ending elsewhere.
///
/// Greedy (each point at the earliest admissible position after the
/// previous one) is exact for this decision: an earlier position never
/// removes options for the points after it. `O(m + n)` segment tests plus
/// one scan per point of the segments it skips.
///
/// Points visited out of order along a segment need `eps ≥ 0.5`, in order any
/// `eps ≥ 0`:
/// ```
/// use strandfit::{metrics::ordered_within, DVec3};
///
/// let q = [DVec3::ZERO, 2.0 * DVec3::X];
/// let back = [DVec3::ZERO, 1.5 * DVec3::X, 0.5 * DVec3::X, 2.0 * DVec3::X];
/// assert!(!ordered_within(&back, &q, 0.49).unwrap());
/// assert!(ordered_within(&back, &q, 0.5).unwrap());
/// let forth = [DVec3::ZERO, 0.5 * DVec3::X, 1.5 * DVec3::X, 2.0 * DVec3::X];
/// assert!(ordered_within(&forth, &q, 0.0).unwrap());
/// ```
pub fn ordered_within(p: &[DVec3], q: &[DVec3], eps: f64) -> Result<bool, MetricsError> {
    check(p)?;
    check(q)?;
    Ok(ordered(p, q, eps))
}

fn ordered(p: &[DVec3], q: &[DVec3], eps: f64) -> bool {
    if !(eps >= 0.0) {
        return false;
    }
    let eps2 = eps * eps;
    let last = p.len() - 1;
    if p[0].distance_squared(q[0]) > eps2 || p[last].distance_squared(q[q.len() - 1]) > eps2 {
        return false;
    }
    if q.len() == 1 {
        return p.iter().all(|x| x.distance_squared(q[0]) <= eps2);
    }
    if last == 0 {
        return true; // one point, matched to both ends
    }
    // Current position: segment j, parameter u in it.
    let (mut j, mut u) = (0usize, 0.0f64);
    for x in &p[1..last] {
        loop {
            if let Some((a, b)) = free_interval(*x, q[j], q[j + 1], eps2) {
                if b >= u {
                    u = a.max(u);
                    break;
                }
            }
            j += 1;
            u = 0.0;
            if j + 1 >= q.len() {
                return false;
            }
        }
    }
    // The last point goes to the end, which is never before the position.
    true
}

/// The smallest `eps` for which [`ordered_within`] holds, to `rel_tol`
/// (returns an upper bound `≤ (1 + rel_tol)·exact`).
///
/// Positions `t₁ ≤ t₂` along `q` within `eps` of `1.5` and of `0.5` need
/// `1.5 − eps ≤ 0.5 + eps`, so the distance is `0.5`:
/// ```
/// use strandfit::{metrics::ordered_distance, DVec3};
///
/// let q = [DVec3::ZERO, 2.0 * DVec3::X];
/// let p = [DVec3::ZERO, 1.5 * DVec3::X, 0.5 * DVec3::X, 2.0 * DVec3::X];
/// let d = ordered_distance(&p, &q, 1e-9).unwrap();
/// assert!(d >= 0.5 && d <= 0.5 * (1.0 + 1e-9));
/// ```
pub fn ordered_distance(p: &[DVec3], q: &[DVec3], rel_tol: f64) -> Result<f64, MetricsError> {
    smallest_passing(p, q, rel_tol, |eps| ordered(p, q, eps))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn v(x: f64, y: f64) -> DVec3 {
        DVec3::new(x, y, 0.0)
    }

    #[test]
    fn tent_over_a_segment() {
        let p = [v(0.0, 0.0), v(1.0, 0.0)];
        let q = [v(0.0, 0.0), v(0.5, 0.3), v(1.0, 0.0)];
        let f = frechet_polyline(&p, &q, 1e-12).unwrap();
        assert!((f - 0.3).abs() < 1e-11, "{f}");
        assert!(frechet_within(&p, &q, 0.3 + 1e-12).unwrap());
        assert!(!frechet_within(&p, &q, 0.3 - 1e-9).unwrap());
        // The discrete distance of the vertices is the diagonal to (0.5, 0.3).
        let d = crate::metrics::discrete_frechet(&p, &q).unwrap();
        assert!(d > 0.5);
    }

    #[test]
    fn backtracking_costs_what_hausdorff_misses() {
        // Q runs ahead to 1.5, back to 0.5, then on to 2: the same set as P
        // (Hausdorff 0), but P cannot go back, so the best is to wait at 1.
        let p = [v(0.0, 0.0), v(2.0, 0.0)];
        let q = [v(0.0, 0.0), v(1.5, 0.0), v(0.5, 0.0), v(2.0, 0.0)];
        assert_eq!(crate::metrics::hausdorff(&p, &q).unwrap(), 0.0);
        let f = frechet_polyline(&p, &q, 1e-12).unwrap();
        assert!((f - 0.5).abs() < 1e-11, "{f}");
    }

    #[test]
    fn resampling_is_free() {
        // The same curve with other vertices: distance 0, where the discrete
        // distance is half the spacing.
        let p: Vec<DVec3> = (0..=10).map(|k| v(k as f64, 0.0)).collect();
        let q: Vec<DVec3> = (0..=7).map(|k| v(10.0 * k as f64 / 7.0, 0.0)).collect();
        assert!(frechet_within(&p, &q, 1e-12).unwrap());
        assert!(crate::metrics::discrete_frechet(&p, &q).unwrap() > 0.2);
    }

    #[test]
    fn points_and_errors() {
        let p = [v(0.0, 0.0)];
        let q = [v(1.0, 0.0), v(0.0, 2.0)];
        assert!((frechet_polyline(&p, &q, 1e-12).unwrap() - 2.0).abs() < 1e-11);
        assert_eq!(frechet_polyline(&[], &q, 1e-9), Err(MetricsError::Empty));
        assert_eq!(
            frechet_within(&[v(f64::NAN, 0.0)], &q, 1.0),
            Err(MetricsError::NonFinite)
        );
        assert!(!frechet_within(&q, &q, f64::NAN).unwrap());
    }

    #[test]
    fn ordered_distance_ignores_chords_but_not_order() {
        // Samples of a circle against a fine polygon of the same circle:
        // the vertices lie on it (distance ~0), while the continuous
        // distance pays the coarse chords' sagitta.
        let circle = |n: usize| -> Vec<DVec3> {
            (0..=n)
                .map(|k| {
                    let a = std::f64::consts::PI * k as f64 / n as f64;
                    v(a.cos(), a.sin())
                })
                .collect()
        };
        let (coarse, fine) = (circle(6), circle(6000));
        let d = ordered_distance(&coarse, &fine, 1e-9).unwrap();
        assert!(d < 1e-6, "{d}");
        let f = frechet_polyline(&coarse, &fine, 1e-9).unwrap();
        let sagitta = 1.0 - (std::f64::consts::PI / 12.0).cos();
        assert!((f - sagitta).abs() < 1e-3, "{f} vs {sagitta}");
        // Order: the same points reversed in the middle are far.
        let mut shuffled = coarse.clone();
        shuffled.swap(2, 4);
        assert!(ordered_distance(&shuffled, &fine, 1e-9).unwrap() > 0.5);
        // A point that the curve does not pass is charged.
        let mut off = coarse.clone();
        off[3] += v(0.0, 0.25);
        assert!((ordered_distance(&off, &fine, 1e-9).unwrap() - 0.25).abs() < 1e-6);
    }

    fn densify(p: &[DVec3], k: usize) -> Vec<DVec3> {
        let mut out = vec![p[0]];
        for w in p.windows(2) {
            for j in 1..=k {
                out.push(w[0].lerp(w[1], j as f64 / k as f64));
            }
        }
        out
    }

    fn polyline() -> impl Strategy<Value = Vec<DVec3>> {
        prop::collection::vec((-3.0..3.0f64, -3.0..3.0f64, -3.0..3.0f64), 1..7)
            .prop_map(|v| v.into_iter().map(|(x, y, z)| DVec3::new(x, y, z)).collect())
    }

    proptest! {
        /// Bounds: Hausdorff (vertex-to-polyline) ≤ F ≤ discrete; F is
        /// symmetric; and the discrete distance of finely densified copies
        /// converges to F from above (each point is within h/2 of the
        /// continuous coupling's partner, h the densified spacing).
        #[test]
        fn bounds_symmetry_and_convergence(p in polyline(), q in polyline()) {
            let f = frechet_polyline(&p, &q, 1e-10).unwrap();
            let g = frechet_polyline(&q, &p, 1e-10).unwrap();
            prop_assert!((f - g).abs() <= 1e-9 * (1.0 + f), "{f} vs {g}");
            let h = crate::metrics::hausdorff(&p, &q).unwrap();
            let d = crate::metrics::discrete_frechet(&p, &q).unwrap();
            prop_assert!(h <= f * (1.0 + 1e-9) + 1e-12 && f <= d * (1.0 + 1e-9) + 1e-12, "{h} {f} {d}");
            let k = 64;
            let (pd, qd) = (densify(&p, k), densify(&q, k));
            let dd = crate::metrics::discrete_frechet(&pd, &qd).unwrap();
            let spacing = pd.windows(2).chain(qd.windows(2)).map(|w| w[0].distance(w[1])).fold(0.0, f64::max);
            prop_assert!(dd >= f * (1.0 - 1e-9) - 1e-12 && dd <= f + spacing, "densified {dd} vs {f} (h = {spacing})");
            // The ordered vertex distance lies between the directed
            // vertex-to-polyline distance and the continuous one.
            let o = ordered_distance(&p, &q, 1e-10).unwrap();
            let hd = crate::metrics::hausdorff_directed(&p, &q).unwrap();
            prop_assert!(hd <= o * (1.0 + 1e-9) + 1e-12 && o <= f * (1.0 + 1e-9) + 1e-12, "{hd} {o} {f}");
        }
    }
}
