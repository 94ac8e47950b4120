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
pub fn discrete_frechet(a: &[DVec3], b: &[DVec3]) -> Result<f64, MetricsError> {
    let mut row = Vec::new();
    discrete_frechet_with_buf(a, b, &mut row)
}

/// [`discrete_frechet`], using `row` as scratch space (cleared and resized to
/// `min(a.len(), b.len())`), so that a caller measuring thousands of curves
/// allocates once.
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
