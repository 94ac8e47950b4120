//! Tangents and curvatures of a polyline (Section 5; the method is described
//! on `tangents_and_curvatures`), resampling, smoothing and noise.

use glam::DVec2;

/// Tangent and signed curvature at every vertex, window half-width `q ≥ 1`
/// (clamped to the polyline). Needs at least 3 vertices and no zero-length
/// edges (checked by the callers).
///
/// By local quadratic fitting (Section 5, after Lewiner, Gomes, Lopes &
/// Craizer 2005): around vertex `vᵢ`, fit `Cᵢ(t) = vᵢ + vᵢ′t + ½vᵢ″t²` by
/// least squares to the neighbours
/// `v_{i+j}`, `|j| ≤ q`, with `t` the signed arc length along the polyline
/// from `vᵢ` (so uneven sampling is accounted for), then
/// `κ = (x′y″ − y′x″)/|v′|³` (signed) and `T̂ = v′/|v′|`. At the ends the
/// window is one-sided. [`resample`] (the paper's) or [`densify`] evens
/// out the sampling first, as Section 6 assumes.
///
/// ```
/// use glam::DVec2;
/// use strandfit::sketch::tangents_and_curvatures;
/// // A circle of radius 2, counter-clockwise: κ = +1/2, to 1 %.
/// let pts: Vec<DVec2> = (0..50).map(|i| 2.0 * DVec2::from_angle(0.05 * i as f64)).collect();
/// let found = tangents_and_curvatures(&pts, 3);
/// for (i, (tangent, kappa)) in found.into_iter().enumerate() {
///     assert!((kappa - 0.5).abs() < 0.005, "{i}: {kappa}");
///     assert!((tangent.length() - 1.0).abs() < 1e-12);
/// }
/// ```
pub fn tangents_and_curvatures(points: &[DVec2], q: usize) -> Vec<(DVec2, f64)> {
    let n = points.len();
    let q = q.max(1).min(n.saturating_sub(1) / 2).max(1);
    let mut s = vec![0.0; n];
    for i in 1..n {
        s[i] = s[i - 1] + (points[i] - points[i - 1]).length();
    }
    (0..n)
        .map(|i| {
            // A window of 2q + 1 vertices, shifted inside at the ends.
            let lo = i.saturating_sub(q).min(n.saturating_sub(2 * q + 1));
            let hi = (lo + 2 * q).min(n - 1);
            // Least squares for p_j − p_i = d t + ½dd t² + ⅙ddd t³. The
            // cubic term matters wherever the window is not symmetric in
            // arc length (one-sided at the ends, or uneven sampling): there
            // a quadratic's curvature is biased to first order in the
            // window length (12 % on a circle over 0.6 rad at an end, 2 %
            // in the interior with ±30 % spacing); with it, second order.
            let k = if hi - lo >= 3 { 3 } else { 2 };
            let mut m = [[0.0f64; 3]; 3];
            let mut r = [DVec2::ZERO; 3];
            for j in lo..=hi {
                if j == i {
                    continue;
                }
                let t = s[j] - s[i];
                let f = [t, 0.5 * t * t, t * t * t / 6.0];
                let dp = points[j] - points[i];
                for a in 0..k {
                    r[a] += f[a] * dp;
                    for b in 0..k {
                        m[a][b] += f[a] * f[b];
                    }
                }
            }
            let (d, dd) = solve_normal(m, r, k);
            let speed = d.length();
            let tangent = d / speed;
            let kappa = d.perp_dot(dd) / (speed * speed * speed);
            (tangent, kappa)
        })
        .collect()
}

/// `(d, dd)` from the `k × k` normal equations (Cramer's rule; `k` = 2
/// or 3), by coordinate.
fn solve_normal(m: [[f64; 3]; 3], r: [DVec2; 3], k: usize) -> (DVec2, DVec2) {
    if k == 2 {
        let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
        return (
            (r[0] * m[1][1] - r[1] * m[0][1]) / det,
            (r[1] * m[0][0] - r[0] * m[1][0]) / det,
        );
    }
    let det3 = |a: [[f64; 3]; 3]| {
        a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
    };
    let det = det3(m);
    let solve = |col: usize| {
        let pick = |c: usize| {
            let mut a = m;
            for row in 0..3 {
                a[row][col] = if c == 0 { r[row].x } else { r[row].y };
            }
            det3(a) / det
        };
        DVec2::new(pick(0), pick(1))
    };
    (solve(0), solve(1))
}

/// Savitzky–Golay weights of the 9-point quadratic (and cubic) smoothing
/// filter, `c₀ = Σ wⱼ p_{i+j}` for `j = −4 … 4`, over 231.
const SG9: [f64; 9] = [-21.0, 14.0, 39.0, 54.0, 59.0, 54.0, 39.0, 14.0, -21.0];

/// The 9-point Savitzky–Golay estimate of vertex `i` (`4 ≤ i < n − 4`).
fn sg9(points: &[DVec2], i: usize) -> DVec2 {
    (0..9).map(|j| SG9[j] * points[i + j - 4]).sum::<DVec2>() / 231.0
}

/// The polyline smoothed by the 9-point Savitzky–Golay filter (`SG9`),
/// its first and last four vertices kept: for judging the drawing's
/// sampling where noise moves each vertex by a sizeable part of an edge.
///
/// ```
/// use glam::DVec2;
/// use strandfit::sketch::smoothed;
///
/// // A cubic is left as it is (to rounding); the ends are kept exactly.
/// let cubic: Vec<DVec2> = (0..20).map(|i| 0.1 * i as f64).map(|x| DVec2::new(x, x * x * x - x)).collect();
/// let s = smoothed(&cubic);
/// assert_eq!(s.len(), 20);
/// assert_eq!(s[..4], cubic[..4]);
/// assert!(s.iter().zip(&cubic).all(|(a, b)| (*a - *b).length() < 1e-12));
/// // A zigzag about a line is pulled towards it.
/// let zigzag: Vec<DVec2> = (0..20).map(|i| DVec2::new(i as f64, if i % 2 == 0 { 0.1 } else { -0.1 })).collect();
/// assert!(smoothed(&zigzag)[4..16].iter().all(|p| p.y.abs() < 0.02));
/// ```
pub fn smoothed(points: &[DVec2]) -> Vec<DVec2> {
    let n = points.len();
    (0..n)
        .map(|i| {
            if i >= 4 && i + 4 < n {
                sg9(points, i)
            } else {
                points[i]
            }
        })
        .collect()
}

/// How alike the drawing's neighbouring residuals about the 9-point
/// Savitzky–Golay filter (`SG9`) are: the fraction of consecutive pairs
/// `rᵢ, rᵢ₊₁` with `rᵢ·rᵢ₊₁ > 0`. Independent noise gives about 0.4 (the
/// filter makes neighbouring residuals correlate at −0.35); a clean
/// drawing, whose residuals are the filter's bias on the curve's bends,
/// nearly 1 (they turn only where the bending changes). A fraction, not a
/// correlation, so that a corner's few large residuals do not decide it.
/// So the noise [`estimate_noise`] finds can be told apart from a coarse
/// drawing's curvature. 0.5 for fewer than ten vertices.
///
/// ```
/// use glam::DVec2;
/// use strandfit::sketch::residual_agreement;
///
/// // A coarse clean circle: residuals are bias, alike along the drawing.
/// let circle: Vec<DVec2> = (0..40).map(|k| DVec2::from_angle(k as f64 * 0.3)).collect();
/// assert!(residual_agreement(&circle) > 0.9);
/// // The same with noise: residuals alike in about 0.4 of the pairs.
/// use rand::{Rng, SeedableRng};
/// let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
/// let noisy: Vec<DVec2> = circle.iter().map(|p| *p + 0.05 * DVec2::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0))).collect();
/// assert!(residual_agreement(&noisy) < 0.6);
/// ```
pub fn residual_agreement(points: &[DVec2]) -> f64 {
    let n = points.len();
    if n < SG9.len() + 1 {
        return 0.5;
    }
    let r: Vec<DVec2> = (4..n - 4).map(|i| points[i] - sg9(points, i)).collect();
    let alike = r.windows(2).filter(|w| w[0].dot(w[1]) > 0.0).count();
    alike as f64 / (r.len() - 1) as f64
}

/// Half-widths (in vertices) of the local quadratic fits [`denoise`] tries
/// at each vertex, in order; each about 1.4 times the last.
const DENOISE_WIDTHS: [usize; 9] = [2, 3, 4, 6, 8, 11, 16, 22, 32];

/// Half-width of [`denoise`]'s confidence intervals, in standard deviations
/// of each fit's estimate (the ICI rule's Γ).
const ICI_GAMMA: f64 = 1.4;

/// The value at vertex `i` of the least-squares quadratic in `s` through
/// vertices `lo..=hi`, and its hat value (the variance of that value over
/// the variance of one vertex, for independent noise).
fn local_quadratic(points: &[DVec2], s: &[f64], i: usize, lo: usize, hi: usize) -> (DVec2, f64) {
    let scale = (s[hi] - s[lo]).max(f64::MIN_POSITIVE);
    let mut m = [[0.0f64; 3]; 3];
    let mut r = [DVec2::ZERO; 3];
    for j in lo..=hi {
        let u = (s[j] - s[i]) / scale;
        let basis = [1.0, u, u * u];
        for a in 0..3 {
            for b in 0..3 {
                m[a][b] += basis[a] * basis[b];
            }
            r[a] += basis[a] * points[j];
        }
    }
    // The first row of M⁻¹ (M is symmetric): cofactors over the determinant.
    let c0 = m[1][1] * m[2][2] - m[1][2] * m[2][1];
    let c1 = m[1][2] * m[2][0] - m[1][0] * m[2][2];
    let c2 = m[1][0] * m[2][1] - m[1][1] * m[2][0];
    let det = m[0][0] * c0 + m[0][1] * c1 + m[0][2] * c2;
    if !(det.abs() > 1e-300) {
        return (points[i], 1.0);
    }
    let value = (c0 * r[0] + c1 * r[1] + c2 * r[2]) / det;
    (value, c0 / det)
}

/// The drawing with independent noise of standard deviation `sigma` (per
/// coordinate) smoothed away where the curve allows it. At each vertex,
/// three local quadratic fits (in the arc length of the drawing lightly
/// smoothed): over a window centred on the vertex, one ending at it and
/// one starting at it, each grown through `DENOISE_WIDTHS` (clipped at the
/// drawing's ends) while its confidence disc (radius `Γσ√h`, `Γ = 1.4`, `h`
/// the fit's hat value) still meets those of the narrower ones and of the
/// vertex itself: Lepski's rule, as in the intersection of confidence
/// intervals of Goldenshluger and Nemirovski (1997) and Katkovnik's
/// directional LPA–ICI. The three values are averaged with weights
/// `1/h`. On a smooth stretch the windows grow until the curve's own
/// bending shows, where a fit's bias would reach its noise; at a corner
/// the windows that straddle it stop short, and the one on the corner's
/// near side carries the estimate, so corners stay sharp. Measured on the
/// benchmark's drawings at 0.01–0.3 % noise: the denoised vertices lie
/// 0.25–0.65 σ (root mean square) from the true curve, against 1.25 σ
/// drawn. With `sigma = 0` the drawing comes back as it is.
///
/// ```
/// use glam::DVec2;
/// use strandfit::sketch::denoise;
///
/// // A circle of radius 1, 400 vertices, each moved by ±0.01 in x and y.
/// let circle: Vec<DVec2> = (0..400).map(|k| DVec2::from_angle(k as f64 * 0.012)).collect();
/// let jitter = |k: usize| if (k * 7919) % 5 < 2 { 0.01 } else { -0.01 };
/// let noisy: Vec<DVec2> = circle.iter().enumerate().map(|(k, p)| *p + DVec2::new(jitter(k), jitter(k + 1))).collect();
/// let d = denoise(&noisy, 0.01);
/// let worst = |p: &[DVec2]| p.iter().map(|q| (q.length() - 1.0).abs()).fold(0.0, f64::max);
/// assert!(worst(&d) < 0.4 * worst(&noisy));
/// // No noise: nothing moves.
/// assert_eq!(denoise(&circle, 0.0), circle);
/// ```
pub fn denoise(points: &[DVec2], sigma: f64) -> Vec<DVec2> {
    let n = points.len();
    if n < 2 * DENOISE_WIDTHS[0] + 1 || !(sigma > 0.0) {
        return points.to_vec();
    }
    let guide = smoothed(points);
    let mut s = vec![0.0; n];
    for i in 1..n {
        s[i] = s[i - 1] + (guide[i] - guide[i - 1]).length();
    }
    // One window per side of the vertex and one centred on it, each grown
    // by the ICI rule; the three estimates fused by inverse variance. At a
    // corner the window on each side grows up to it and no further, and
    // the one that does not straddle it carries the estimate.
    let grown = |i: usize, window: &dyn Fn(usize) -> (usize, usize)| -> (DVec2, f64) {
        // Accepted estimates with their standard deviations over σ: the
        // vertex itself first. Discs, not boxes, so that the choice does
        // not depend on how the drawing is turned.
        let mut accepted: Vec<(DVec2, f64)> = vec![(points[i], 1.0)];
        let mut best = (points[i], 1.0);
        for &m in &DENOISE_WIDTHS {
            if 4 * m > n {
                break;
            }
            let (a, b) = window(m);
            if b - a < 2 * DENOISE_WIDTHS[0] {
                continue;
            }
            let (value, hat) = local_quadratic(points, &s, i, a, b);
            let spread = hat.sqrt();
            let meets = accepted
                .iter()
                .all(|&(v, d)| (value - v).length() <= ICI_GAMMA * sigma * (d + spread));
            if !meets {
                break;
            }
            accepted.push((value, spread));
            best = (value, hat);
        }
        best
    };
    (0..n)
        .map(|i| {
            let estimates = [
                grown(i, &|m| (i.saturating_sub(m), (i + m).min(n - 1))),
                grown(i, &|m| (i.saturating_sub(2 * m), i)),
                grown(i, &|m| (i, (i + 2 * m).min(n - 1))),
            ];
            let weight: f64 = estimates.iter().map(|e| 1.0 / e.1).sum();
            estimates.iter().map(|e| e.0 / e.1).sum::<DVec2>() / weight
        })
        .collect()
}

/// Noise of a drawing: the standard deviation `σ` of independent noise on
/// each coordinate of each vertex, estimated from how far every vertex
/// lies from the local cubic fitted by least squares to it and its four
/// neighbours on each side (the Savitzky–Golay filter `SG9`), in the
/// vertex index (a drawing sampled at a slowly varying rate is a smooth
/// curve in it too).
///
/// With noise alone the residual `rᵢ = pᵢ − Σ wⱼ p_{i+j}` has variance
/// `σ²(1 − w₀)` per coordinate (`w₀ = 59/231`), so `|rᵢ|²/(σ²(1 − w₀))` is
/// χ² with two degrees of freedom, of median `2 ln 2`: `σ̂² = median |rᵢ|²
/// / ((1 − w₀) 2 ln 2)`. The median ignores the few vertices near corners
/// (where the cubic does not fit). On a smooth curve without noise the
/// residual is the cubic's error, `O(κ³ h⁴)` for edges of length `h`: on a
/// 500-vertex drawing of unit length, under `10⁻⁶`.
///
/// Fewer than 9 vertices: 0 (no estimate).
///
/// ```
/// use glam::DVec2;
/// use strandfit::sketch::estimate_noise;
/// // A circle of 400 vertices, every vertex moved by ±0.001 in x and y.
/// let pts: Vec<DVec2> = (0..400)
///     .map(|i| {
///         let a = i as f64 * 0.01;
///         let s = if (i * 7919) % 3 == 0 { 1.0 } else { -1.0 };
///         DVec2::new(a.cos(), a.sin()) + 0.001 * DVec2::new(s, -s)
///     })
///     .collect();
/// let sigma = estimate_noise(&pts);
/// assert!(sigma > 0.0005 && sigma < 0.002, "{sigma}");
/// ```
pub fn estimate_noise(points: &[DVec2]) -> f64 {
    let n = points.len();
    if n < SG9.len() {
        return 0.0;
    }
    let w0 = SG9[4] / 231.0;
    let mut r2: Vec<f64> = (4..n - 4)
        .map(|i| (points[i] - sg9(points, i)).length_squared())
        .collect();
    let mid = r2.len() / 2;
    let (_, median, _) = r2.select_nth_unstable_by(mid, f64::total_cmp);
    (*median / ((1.0 - w0) * 2.0 * std::f64::consts::LN_2)).sqrt()
}

/// The polyline resampled at `m ≥ 2` points equally spaced in arc length
/// (ends kept).
///
/// ```
/// use glam::DVec2;
/// use strandfit::sketch::resample;
/// let l = [DVec2::ZERO, DVec2::new(1.0, 0.0), DVec2::new(1.0, 3.0)];
/// let r = resample(&l, 5); // length 4: a point every unit
/// assert_eq!(r[1], DVec2::new(1.0, 0.0));
/// assert_eq!(r[4], DVec2::new(1.0, 3.0));
/// ```
pub fn resample(points: &[DVec2], m: usize) -> Vec<DVec2> {
    let m = m.max(2);
    let n = points.len();
    let mut s = vec![0.0; n];
    for i in 1..n {
        s[i] = s[i - 1] + (points[i] - points[i - 1]).length();
    }
    let total = s[n - 1];
    let mut out = Vec::with_capacity(m);
    let mut seg = 0;
    for k in 0..m {
        let target = total * k as f64 / (m - 1) as f64;
        while seg + 2 < n && s[seg + 1] < target {
            seg += 1;
        }
        let len = s[seg + 1] - s[seg];
        let f = if len > 0.0 {
            ((target - s[seg]) / len).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.push(points[seg].lerp(points[seg + 1], f));
    }
    out[m - 1] = points[n - 1];
    out
}

/// Turning angle of the polyline at vertex `i` (0 at the ends).
fn turning(points: &[DVec2], i: usize) -> f64 {
    if i == 0 || i + 1 >= points.len() {
        return 0.0;
    }
    (points[i] - points[i - 1])
        .angle_to(points[i + 1] - points[i])
        .abs()
}

/// A vertex turning by more than `CORNER_TURN` and `CORNER_RATIO` times
/// the median turning of the vertices around it (a corner; on a smooth
/// stroke the turning varies slowly).
///
/// ```
/// use glam::DVec2;
/// use strandfit::sketch::is_corner;
///
/// // An L: the vertex at the bend is a corner, the others are not.
/// let mut l: Vec<DVec2> = (0..10).map(|i| DVec2::new(i as f64, 0.0)).collect();
/// l.extend((1..10).map(|i| DVec2::new(9.0, i as f64)));
/// assert_eq!((0..l.len()).filter(|&i| is_corner(&l, i)).collect::<Vec<_>>(), [9]);
/// // A circle turns by 0.2 rad at every vertex, but evenly: no corner.
/// let circle: Vec<DVec2> = (0..30).map(|i| DVec2::from_angle(0.2 * i as f64)).collect();
/// assert!((0..30).all(|i| !is_corner(&circle, i)));
/// ```
pub fn is_corner(points: &[DVec2], i: usize) -> bool {
    let t = turning(points, i);
    if t <= CORNER_TURN {
        return false;
    }
    let lo = i.saturating_sub(CORNER_SPAN);
    let hi = (i + CORNER_SPAN).min(points.len() - 1);
    let mut around: Vec<f64> = (lo..=hi)
        .filter(|&j| j + 1 < i || j > i + 1)
        .map(|j| turning(points, j))
        .collect();
    if around.is_empty() {
        return false;
    }
    around.sort_by(f64::total_cmp);
    t > CORNER_RATIO * around[around.len() / 2]
}

const CORNER_TURN: f64 = 0.1;
const CORNER_RATIO: f64 = 4.0;
const CORNER_SPAN: usize = 8;

/// The polyline with every edge longer than `target` split into
/// `⌈len/target⌉` pieces of equal parameter along a cubic Hermite spline
/// through the vertices with Bessel tangents (the chordal Catmull–Rom
/// spline), split at corners ([`is_corner`]); every input vertex is kept,
/// so the spacing is evened out without moving a vertex of the drawing
/// (a corner between two samples is not cut, as uniform resampling cuts
/// it). Where the vertices lie on a smooth curve with edges of length `h`,
/// the new points lie within `O(h³)` of it rather than the chords' `O(h²)`
/// (15× closer on a coarse, uneven test drawing).
///
/// ```
/// use glam::DVec2;
/// use strandfit::sketch::densify;
///
/// // A half circle of 8 vertices, densified to edges of about 0.1.
/// let coarse: Vec<DVec2> = (0..8).map(|i| DVec2::from_angle(std::f64::consts::PI * i as f64 / 7.0)).collect();
/// let fine = densify(&coarse, 0.1);
/// assert!(fine.len() > 30);
/// assert!(fine.windows(2).all(|w| (w[1] - w[0]).length() <= 0.1));
/// // Every vertex is kept, in order.
/// let kept: Vec<DVec2> = fine.iter().copied().filter(|p| coarse.contains(p)).collect();
/// assert_eq!(kept, coarse);
/// // The new points are within 0.002 of the circle; the chords' midpoints 0.025.
/// assert!(fine.iter().all(|p| (p.length() - 1.0).abs() < 0.002));
/// // Too few vertices, or no target: as it was.
/// assert_eq!(densify(&coarse[..2], 0.1), coarse[..2]);
/// ```
pub fn densify(points: &[DVec2], target: f64) -> Vec<DVec2> {
    let n = points.len();
    if n < 3 || !(target > 0.0) {
        return points.to_vec();
    }
    let corner: Vec<bool> = (0..n).map(|i| is_corner(points, i)).collect();
    let mut out = Vec::with_capacity(2 * n);
    out.push(points[0]);
    for j in 0..n - 1 {
        let len = (points[j + 1] - points[j]).length();
        let k = ((len / target).ceil() as usize).max(1);
        if k > 1 {
            let tangents = segment_tangents(points, &corner, j);
            for q in 1..k {
                out.push(hermite(
                    points[j],
                    points[j + 1],
                    tangents,
                    q as f64 / k as f64,
                ));
            }
        }
        out.push(points[j + 1]);
    }
    out
}

/// `p₁ + m₁u + (3(p₂ − p₁) − 2m₁ − m₂)u² + (2(p₁ − p₂) + m₁ + m₂)u³`.
fn hermite(p1: DVec2, p2: DVec2, (m1, m2): (DVec2, DVec2), u: f64) -> DVec2 {
    let d = p2 - p1;
    p1 + u * (m1 + u * (3.0 * d - 2.0 * m1 - m2 + u * (-2.0 * d + m1 + m2)))
}

/// Hermite tangents of segment `[i, i + 1]`: at each end, the derivative
/// of the parabola through that vertex and its two neighbours, in chord
/// length (Bessel's tangent, as the chordal Catmull–Rom spline has it;
/// `O(h²)` accurate however uneven the edges), times the segment's chord.
/// At the polyline's ends and at corners, where a neighbour is missing,
/// the derivative of the cubic through the four vertices on the segment's
/// side instead (a one-sided parabola is much less accurate), so a corner
/// stays sharp.
fn segment_tangents(points: &[DVec2], corner: &[bool], i: usize) -> (DVec2, DVec2) {
    let n = points.len();
    let (p1, p2) = (points[i], points[i + 1]);
    // Up to two vertices on either side without crossing a corner.
    let run = |from: usize, step: isize| {
        let mut out = Vec::with_capacity(2);
        let mut j = from as isize;
        for _ in 0..2 {
            if corner[j as usize] {
                break;
            }
            j += step;
            if j < 0 || j >= n as isize {
                break;
            }
            out.push(points[j as usize]);
        }
        out
    };
    let (back, ahead) = (run(i, -1), run(i + 1, 1));
    let d1 = match back.first() {
        Some(&p0) => parabola_derivative([p0, p1, p2], 1),
        None => end_derivative(&[&[p1, p2][..], &ahead].concat()),
    };
    let d2 = match ahead.first() {
        Some(&p3) => parabola_derivative([p1, p2, p3], 1),
        None => -end_derivative(&[&[p2, p1][..], &back].concat()),
    };
    let h = (p2 - p1).length();
    (h * d1, h * d2)
}

/// Derivative at vertex `at` of the parabola through `q` parameterised by
/// chord length: with knots `0, h₀, h₀ + h₁`, `Q′(s) = [q₀q₁] + (2s − h₀)
/// [q₀q₁q₂]` (divided differences).
fn parabola_derivative(q: [DVec2; 3], at: usize) -> DVec2 {
    let (h0, h1) = ((q[1] - q[0]).length(), (q[2] - q[1]).length());
    let d01 = (q[1] - q[0]) / h0;
    let d12 = (q[2] - q[1]) / h1;
    let d012 = (d12 - d01) / (h0 + h1);
    let s = [0.0, h0, h0 + h1][at];
    d01 + (2.0 * s - h0) * d012
}

/// Derivative at `q[0]` of the polynomial through the 2–4 points `q`,
/// parameterised by chord length (Newton's form: `Q′(0) = c₁ − c₂s₁ +
/// c₃s₁s₂`).
fn end_derivative(q: &[DVec2]) -> DVec2 {
    let mut knots = vec![0.0];
    for w in q.windows(2) {
        knots.push(knots[knots.len() - 1] + (w[1] - w[0]).length());
    }
    let mut table = q.to_vec();
    let mut coef = Vec::with_capacity(q.len());
    for level in 1..q.len() {
        for j in 0..q.len() - level {
            table[j] = (table[j + 1] - table[j]) / (knots[j + level] - knots[j]);
        }
        coef.push(table[0]);
    }
    let mut d = DVec2::ZERO;
    let mut product = 1.0;
    for (k, c) in coef.iter().enumerate() {
        d += product * *c;
        product *= -knots[k + 1];
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::sketch::testing::with_noise;

    /// Distance from `p` to the polyline `line`.
    fn to_polyline(p: DVec2, line: &[DVec2]) -> f64 {
        line.windows(2)
            .map(|w| {
                let d = w[1] - w[0];
                let t = ((p - w[0]).dot(d) / d.length_squared()).clamp(0.0, 1.0);
                (p - w[0] - t * d).length()
            })
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn denoising_keeps_corners_and_removes_most_of_the_noise() {
        // Two arcs of radius 1 meeting at a 0.6 rad corner (vertex 100 of
        // 201), spacing 0.01, noise 0.005 (half an edge).
        let mut clean = vec![DVec2::ZERO];
        let mut dir = 0.0f64;
        for k in 0..200 {
            dir += if k == 100 { 0.6 } else { 0.01 };
            let last = *clean.last().unwrap();
            clean.push(last + 0.01 * DVec2::from_angle(dir));
        }
        let sigma = 0.005;
        for seed in 0..3 {
            let drawn = with_noise(&clean, sigma, seed);
            let d = denoise(&drawn, sigma);
            let off: Vec<f64> = d.iter().map(|&p| to_polyline(p, &clean)).collect();
            let rms = (off.iter().map(|o| o * o).sum::<f64>() / off.len() as f64).sqrt();
            // Drawn: σ along the normal. Denoised: about σ/3.
            assert!(rms < 0.45 * sigma, "seed {seed}: {}", rms / sigma);
            // At the corner too: the nine vertices about it stay within 2σ
            // of the true corner's arms (a window straddling the corner
            // would cut it by up to 0.6 · 0.16 / 4 ≈ 5σ).
            for k in 96..=104 {
                assert!(
                    off[k] < 2.0 * sigma,
                    "seed {seed}, vertex {k}: {}",
                    off[k] / sigma
                );
            }
            // The drawing turned and moved is denoised the same, turned
            // and moved.
            let turn = DVec2::from_angle(1.1);
            let moved: Vec<DVec2> = drawn
                .iter()
                .map(|&p| turn.rotate(p) + DVec2::new(3.0, -2.0))
                .collect();
            for (a, b) in denoise(&moved, sigma).iter().zip(&d) {
                assert!((*a - turn.rotate(*b) - DVec2::new(3.0, -2.0)).length() < 1e-12);
            }
        }
    }

    #[test]
    fn circle_with_uneven_sampling() {
        // Radius 2, counterclockwise: κ = +1/2, tangent ⟂ radius.
        let mut angles: Vec<f64> = (0..60).map(|k| k as f64 * 0.1).collect();
        for (k, a) in angles.iter_mut().enumerate() {
            *a += 0.03 * ((k * 7) % 5) as f64; // uneven
        }
        let pts: Vec<DVec2> = angles
            .iter()
            .map(|a| 2.0 * DVec2::new(a.cos(), a.sin()))
            .collect();
        let est = tangents_and_curvatures(&pts, 3);
        for (i, (t, k)) in est.iter().enumerate() {
            let a = angles[i];
            let want = DVec2::new(-a.sin(), a.cos());
            // The one-sided windows (3 end vertices each side) extrapolate,
            // so they are less accurate than the interior ones.
            let end = !(3..57).contains(&i);
            let (kt, tt) = if end { (0.03, 0.01) } else { (0.015, 2e-3) };
            assert!((k - 0.5).abs() < kt, "{i}: {k}");
            assert!((*t - want).length() < tt, "{i}");
        }
        // The error falls with the window's turning, (κ·span)²: a finer
        // sampling (0.02 rad steps) gives the curvature to 3e-4 relative.
        let pts: Vec<DVec2> = (0..200)
            .map(|k| 2.0 * DVec2::new((0.02 * k as f64).cos(), (0.02 * k as f64).sin()))
            .collect();
        for (i, (_, k)) in tangents_and_curvatures(&pts, 3).iter().enumerate() {
            let tol = if (3..197).contains(&i) { 3e-4 } else { 2e-3 };
            assert!((k - 0.5).abs() < tol, "{i}: {k}");
        }
    }

    /// Distance from `v` to the projected helix `h` (from a guess `t0`).
    fn off_curve(h: &crate::sketch::PlacedHelix, v: DVec2, t0: f64) -> f64 {
        let t = h.closest_parameter(v, t0);
        (h.point(t) - v).length()
    }

    #[test]
    fn densified_points_stay_on_an_unevenly_sampled_curve() {
        // Two turns of a projected helix (radius 1, tilted), 54 vertices
        // with steps alternating 0.35 and 0.1 rad, long edges split in
        // three: points on the chords sag by up to 1.5e-2, those on the
        // spline 15× less, and every vertex is kept.
        let h = crate::sketch::PlacedHelix::from_params(&[0.3, 0.0, 0.0, 1.0, 0.2, 0.7], false);
        let mut ts = vec![0.0];
        while *ts.last().unwrap() < 12.0 {
            let step = if ts.len() % 2 == 0 { 0.1 } else { 0.35 };
            ts.push(ts.last().unwrap() + step);
        }
        let pts: Vec<DVec2> = ts.iter().map(|&t| h.point(t)).collect();
        let t_end = *ts.last().unwrap();
        let dense: Vec<(f64, DVec2)> = (0..=12_000)
            .map(|k| t_end * k as f64 / 12_000.0)
            .map(|t| (t, h.point(t)))
            .collect();
        let worst = |r: &[DVec2]| {
            // Each point from the nearest of a dense sampling of the curve.
            r.iter()
                .map(|&v| {
                    let (t0, _) = dense
                        .iter()
                        .min_by(|a, b| (a.1 - v).length().total_cmp(&(b.1 - v).length()))
                        .unwrap();
                    off_curve(&h, v, *t0)
                })
                .fold(0.0, f64::max)
        };
        let edges: Vec<f64> = pts.windows(2).map(|w| (w[1] - w[0]).length()).collect();
        let target = edges.iter().cloned().fold(0.0, f64::max) / 3.0;
        let spline = densify(&pts, target);
        // The same splits on the chords.
        let chords: Vec<DVec2> = pts
            .windows(2)
            .flat_map(|w| {
                let k = ((w[1] - w[0]).length() / target).ceil() as usize;
                (0..k).map(move |q| w[0].lerp(w[1], q as f64 / k as f64))
            })
            .collect();
        assert_eq!(chords.len() + 1, spline.len());
        let (dc, ds) = (worst(&chords), worst(&spline));
        assert!(dc > 5e-3, "{dc}");
        // Measured: 1.5e-2 and 9.5e-4 (the worst at the ends, where the
        // tangent is one-sided).
        assert!(ds < dc / 10.0, "chords {dc}, spline {ds}");
        // Every vertex kept, in order; no piece much longer than target.
        let mut it = spline.iter();
        assert!(pts.iter().all(|p| it.any(|q| q == p)));
        assert!(spline
            .windows(2)
            .all(|w| (w[1] - w[0]).length() < 1.1 * target));
        // Nothing to split: unchanged.
        assert_eq!(densify(&pts, 1.0), pts);
    }

    #[test]
    fn densifying_keeps_corners_sharp() {
        // An arc, a 0.6 rad corner, another arc, each edge split in five:
        // the new points stay on one arc or the other (no bulge at the
        // corner, which a spline through it would make: ~4e-3).
        let mut pts = vec![DVec2::ZERO];
        let mut dir = 0.0f64;
        for k in 0..40 {
            let turn = if k == 20 { 0.6 } else { 0.05 };
            dir += turn;
            let last = *pts.last().unwrap();
            pts.push(last + 0.05 * DVec2::from_angle(dir));
        }
        let r = densify(&pts, 0.0101);
        assert_eq!(r.len(), 5 * 40 + 1);
        // Each arc is a circle of radius 0.05 / (2 sin 0.025) through its
        // vertices; distance of a point to the nearer circle.
        let radius = 0.05 / (2.0 * 0.025f64.sin());
        let centre = |a: usize, b: usize| {
            // Circumcentre of three vertices of the arc.
            let (p, q, s) = (pts[a], pts[(a + b) / 2], pts[b]);
            let d = 2.0 * (p.x * (q.y - s.y) + q.x * (s.y - p.y) + s.x * (p.y - q.y));
            let f = |v: DVec2| v.length_squared();
            DVec2::new(
                (f(p) * (q.y - s.y) + f(q) * (s.y - p.y) + f(s) * (p.y - q.y)) / d,
                (f(p) * (s.x - q.x) + f(q) * (p.x - s.x) + f(s) * (q.x - p.x)) / d,
            )
        };
        let c1 = centre(0, 20);
        let c2 = centre(21, 40);
        let worst = r
            .iter()
            .map(|&v| {
                ((v - c1).length() - radius)
                    .abs()
                    .min(((v - c2).length() - radius).abs())
            })
            .fold(0.0, f64::max);
        assert!(worst < 1e-4, "{worst}");
    }

    #[test]
    fn resampling_is_uniform_and_keeps_the_ends() {
        let pts = [DVec2::ZERO, DVec2::new(1.0, 0.0), DVec2::new(1.0, 3.0)];
        let r = resample(&pts, 9);
        assert_eq!(r.len(), 9);
        assert_eq!(r[0], pts[0]);
        assert_eq!(r[8], pts[2]);
        for w in r.windows(2) {
            assert!(((w[1] - w[0]).length() - 0.5).abs() < 1e-12);
        }
    }
}
