//! Discrete Fréchet distance.

use glam::DVec3;

use super::error::{check, MetricsError};

/// Discrete Fréchet distance between the point sequences `a` and `b`
/// (Eiter & Mannila 1994).
///
/// This is the minimum, over monotone couplings of the indices (both
/// sequences traversed from first to last point, each step advancing one or
/// both), of the largest distance between coupled points. It is computed
/// exactly by the dynamic programme
///
/// ```text
/// c(i, j) = max(|aᵢ − bⱼ|, min(c(i−1, j), c(i−1, j−1), c(i, j−1)))
/// ```
///
/// in `O(mn)` time. Only one row of `c` is live at a time, and the distance
/// is symmetric, so the row runs over the shorter sequence: `O(min(m, n))`
/// memory, one allocation. Use [`discrete_frechet_with_buf`] to reuse that
/// row across many calls.
///
/// Accuracy: the programme only takes maxima and minima of squared
/// distances, and `√` is monotone, so it is run on squared distances and one
/// square root is taken at the end. The result is therefore the correctly
/// rounded root of one of the `mn` squared distances (each computed with a
/// few ulps of relative error); nothing accumulates.
///
/// Errors: [`MetricsError::Empty`] if either sequence is empty,
/// [`MetricsError::NonFinite`] if any coordinate is NaN or infinite.
///
/// Order matters, where the Hausdorff distance ignores it: a segment and
/// the same segment reversed are 0 apart in Hausdorff, their length in
/// Fréchet.
///
/// ```
/// use strandfit::metrics::{discrete_frechet, hausdorff, MetricsError};
/// use strandfit::DVec3;
///
/// let a = [DVec3::ZERO, DVec3::X, 2.0 * DVec3::X];
/// let back = [2.0 * DVec3::X, DVec3::X, DVec3::ZERO];
/// assert_eq!(discrete_frechet(&a, &a).unwrap(), 0.0);
/// assert_eq!(discrete_frechet(&a, &back).unwrap(), 2.0);
/// assert_eq!(hausdorff(&a, &back).unwrap(), 0.0);
/// assert_eq!(discrete_frechet(&a, &[]), Err(MetricsError::Empty));
/// ```
pub fn discrete_frechet(a: &[DVec3], b: &[DVec3]) -> Result<f64, MetricsError> {
    let mut row = Vec::new();
    discrete_frechet_with_buf(a, b, &mut row)
}

/// [`discrete_frechet`], using `row` as scratch space (cleared and resized to
/// `min(a.len(), b.len())`), so that a caller measuring thousands of curves
/// allocates once.
///
/// The middle vertex of `a` must be coupled with an end of `b`, one unit away
/// (the continuous distance of these two segments is 0):
/// ```
/// use strandfit::{metrics::discrete_frechet_with_buf, DVec3};
///
/// let a = [DVec3::ZERO, DVec3::X, 2.0 * DVec3::X];
/// let b = [DVec3::ZERO, 2.0 * DVec3::X];
/// let mut row = Vec::new();
/// assert_eq!(discrete_frechet_with_buf(&a, &b, &mut row).unwrap(), 1.0);
/// assert_eq!(discrete_frechet_with_buf(&b, &a, &mut row).unwrap(), 1.0); // symmetric
/// ```
pub fn discrete_frechet_with_buf(
    a: &[DVec3],
    b: &[DVec3],
    row: &mut Vec<f64>,
) -> Result<f64, MetricsError> {
    check(a)?;
    check(b)?;
    // Symmetric: iterate over the longer sequence, keep the row over the
    // shorter one.
    let (long, short) = if a.len() >= b.len() { (a, b) } else { (b, a) };
    row.clear();
    row.reserve(short.len());

    // First row, i = 0: only moves along `short` are possible, so
    // c(0, j) = max_{k ≤ j} |a₀ − b_k|².
    let p = long[0];
    let mut acc = 0.0f64;
    for &q in short {
        acc = acc.max(p.distance_squared(q));
        row.push(acc);
    }

    // Rows i ≥ 1, updated in place. Before the update `row[j]` holds
    // c(i−1, j) ("up"); `diag` carries c(i−1, j−1) and `left` c(i, j−1).
    let (row0, rest) = row.split_first_mut().expect("short is non-empty");
    let (&q0, short_rest) = short.split_first().expect("short is non-empty");
    for &p in &long[1..] {
        let mut diag = *row0;
        *row0 = row0.max(p.distance_squared(q0));
        let mut left = *row0;
        // Zipped iterators: no bounds checks in the O(mn) loop.
        for (c, &q) in rest.iter_mut().zip(short_rest) {
            let up = *c;
            let v = diag.min(up).min(left).max(p.distance_squared(q));
            diag = up;
            *c = v;
            left = v;
        }
    }
    Ok(row[short.len() - 1].sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn v(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z)
    }

    /// Reference: the full `m × n` table, straight from the recurrence.
    fn frechet_full(a: &[DVec3], b: &[DVec3]) -> f64 {
        let (m, n) = (a.len(), b.len());
        let mut c = vec![vec![0.0f64; n]; m];
        for i in 0..m {
            for j in 0..n {
                let d = a[i].distance(b[j]);
                c[i][j] = match (i, j) {
                    (0, 0) => d,
                    (0, _) => c[0][j - 1].max(d),
                    (_, 0) => c[i - 1][0].max(d),
                    _ => c[i - 1][j].min(c[i - 1][j - 1]).min(c[i][j - 1]).max(d),
                };
            }
        }
        c[m - 1][n - 1]
    }

    #[test]
    fn parallel_segments() {
        let a = [v(0., 0., 0.), v(1., 0., 0.)];
        let b = [v(0., 1., 0.), v(1., 1., 0.)];
        assert_eq!(discrete_frechet(&a, &b).unwrap(), 1.0);
    }

    #[test]
    fn reverse() {
        // Endpoints are coupled, so d ≥ |a₀ − b₀| = 2; coupling i ↔ i
        // achieves max(2, 0, 2) = 2.
        let a = [v(0., 0., 0.), v(1., 0., 0.), v(2., 0., 0.)];
        let b: Vec<_> = a.iter().rev().copied().collect();
        assert_eq!(discrete_frechet(&a, &b).unwrap(), 2.0);
    }

    #[test]
    fn exceeds_hausdorff() {
        // Same vertex set {0, 1, 2} on the x axis, so the vertex Hausdorff
        // distance is 0, but b = 0, 2, 1, 2 backtracks. When b is at its
        // second point (2), a is at 0 (distance 2), 1 (distance 1) or 2; if at
        // 2 it must stay there while b returns to 1 (distance 1). So d ≥ 1,
        // and a = 0,1,1,2 ↔ b = 0,2,1,2 (plus a₁↔b₁) attains 1.
        let a = [v(0., 0., 0.), v(1., 0., 0.), v(2., 0., 0.)];
        let b = [v(0., 0., 0.), v(2., 0., 0.), v(1., 0., 0.), v(2., 0., 0.)];
        assert_eq!(discrete_frechet(&a, &b).unwrap(), 1.0);
        assert_eq!(crate::metrics::hausdorff_vertices(&a, &b).unwrap(), 0.0);
    }

    #[test]
    fn single_points() {
        let a = [v(1., 2., 3.)];
        let b = [v(1., 2., 7.), v(1., 2., 3.)];
        // a₀ is coupled with every point of b.
        assert_eq!(discrete_frechet(&a, &b).unwrap(), 4.0);
        assert_eq!(discrete_frechet(&b, &a).unwrap(), 4.0);
        assert_eq!(discrete_frechet(&a, &a).unwrap(), 0.0);
    }

    #[test]
    fn bad_input() {
        let a = [v(0., 0., 0.)];
        assert_eq!(discrete_frechet(&[], &a), Err(MetricsError::Empty));
        assert_eq!(discrete_frechet(&a, &[]), Err(MetricsError::Empty));
        let n = [v(f64::NAN, 0., 0.)];
        assert_eq!(discrete_frechet(&a, &n), Err(MetricsError::NonFinite));
        let i = [v(0., f64::INFINITY, 0.)];
        assert_eq!(discrete_frechet(&i, &a), Err(MetricsError::NonFinite));
    }

    #[test]
    fn buffer_reuse() {
        let a = [v(0., 0., 0.), v(1., 0., 0.), v(2., 1., 0.)];
        let b = [v(0., 1., 0.), v(3., 1., 0.)];
        let mut row = vec![99.0; 10];
        let d1 = discrete_frechet_with_buf(&a, &b, &mut row).unwrap();
        let d2 = discrete_frechet_with_buf(&b, &a, &mut row).unwrap();
        assert_eq!(d1, frechet_full(&a, &b));
        assert_eq!(d1, d2);
    }

    fn pts(max: usize) -> impl Strategy<Value = Vec<DVec3>> {
        prop::collection::vec(
            (-10.0..10.0f64, -10.0..10.0f64, -10.0..10.0f64).prop_map(|(x, y, z)| v(x, y, z)),
            1..max,
        )
    }

    proptest! {
        #[test]
        fn matches_full_table(a in pts(25), b in pts(25)) {
            let d = discrete_frechet(&a, &b).unwrap();
            let r = frechet_full(&a, &b);
            // Same comparisons on squared vs plain distances: equal up to
            // the rounding of one sqrt.
            prop_assert!((d - r).abs() <= 4.0 * f64::EPSILON * r, "{d} vs {r}");
        }

        #[test]
        fn metric_sanity(a in pts(20), b in pts(20), t in (-5.0..5.0f64, -5.0..5.0f64, -5.0..5.0f64)) {
            let d = discrete_frechet(&a, &b).unwrap();
            prop_assert_eq!(d, discrete_frechet(&b, &a).unwrap());
            prop_assert_eq!(discrete_frechet(&a, &a).unwrap(), 0.0);
            // Endpoints are always coupled.
            let lb = a[0].distance(b[0]).max(a[a.len() - 1].distance(b[b.len() - 1]));
            prop_assert!(d >= lb);
            // Translating both changes each distance by rounding only.
            let t = v(t.0, t.1, t.2);
            let at: Vec<_> = a.iter().map(|p| *p + t).collect();
            let bt: Vec<_> = b.iter().map(|p| *p + t).collect();
            let dt = discrete_frechet(&at, &bt).unwrap();
            prop_assert!((d - dt).abs() <= 1e-12 * (1.0 + d), "{d} vs {dt}");
        }

        /// Fréchet ≥ vertex Hausdorff ≥ vertex-to-polyline Hausdorff: a
        /// coupling pairs every vertex with some vertex of the other
        /// sequence, and a polyline contains its vertices.
        #[test]
        fn bounds_hausdorff(a in pts(20), b in pts(20)) {
            let f = discrete_frechet(&a, &b).unwrap();
            let hv = crate::metrics::hausdorff_vertices(&a, &b).unwrap();
            let hp = crate::metrics::hausdorff(&a, &b).unwrap();
            prop_assert!(f >= hv, "{f} < {hv}");
            prop_assert!(hv >= hp - 1e-12 * (1.0 + hv), "{hv} < {hp}");
        }
    }
}
