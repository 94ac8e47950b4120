//! Point relaxation (paper 000, Section 4); the problem and its two solvers
//! are described on `relax`.

use faer::linalg::solvers::Solve;
use faer::Mat;
use glam::DVec3;

use super::ghosh::PARALLEL_EPS;

/// Which solver [`relax`] uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Relaxation {
    /// `O(N)` symmetric tridiagonal solve in the Lagrange multipliers.
    #[default]
    Tridiagonal,
    /// The paper's `2N + 3` normal equations by dense LU (`O(N³)`).
    DenseLu,
}

/// Relax `points` (N + 1 of them) against `tangents` (unit, same count).
///
/// Tangents `x` then `y` ask for a chord ⊥ `y − x`; each point moves half the
/// way, along `y − x`:
/// ```
/// use strandfit::helix::{relax, Relaxation};
/// use strandfit::DVec3;
///
/// let p = relax(&[DVec3::ZERO, DVec3::X], &[DVec3::X, DVec3::Y], Relaxation::Tridiagonal);
/// assert!((p[0] - DVec3::new(0.25, -0.25, 0.0)).length() < 1e-15);
/// assert!((p[1] - DVec3::new(0.75, 0.25, 0.0)).length() < 1e-15);
/// ```
///
/// # Method
///
/// Point relaxation (paper 000, Section 4) moves the break points as little
/// as possible so that every consecutive pair becomes co-helical,
///
/// ```text
/// min Σᵢ ‖p'ᵢ − pᵢ‖²   subject to   ⟨p'ᵢ₊₁ − p'ᵢ, dᵢ⟩ = 0,  dᵢ = tᵢ₊₁ − tᵢ,
/// ```
///
/// for `i = 0..N−1` (N + 1 points). Two solvers give the same unique minimiser:
///
/// * [`relax_tridiagonal`] (default, `O(N)`): the Lagrange conditions give
///   `p'ᵢ = pᵢ − ½(λᵢ₋₁ êᵢ₋₁ − λᵢ êᵢ)`; substituting into the constraints gives
///   the symmetric tridiagonal system
///   `λᵢ − ½⟨êᵢ, êᵢ₋₁⟩λᵢ₋₁ − ½⟨êᵢ, êᵢ₊₁⟩λᵢ₊₁ = ⟨pᵢ₊₁ − pᵢ, êᵢ⟩`.
///   We use the unit directions `êᵢ = dᵢ/|dᵢ|` (the constraints are unchanged);
///   the matrix then has unit diagonal and off-diagonals of size ≤ ½, so it is
///   diagonally dominant and symmetric positive definite, and the Thomas
///   algorithm is stable without pivoting.
/// * [`relax_dense`] (the paper's reference): `p'ᵢ₊₁ = p'ᵢ + Dᵢaᵢ` with `Dᵢ` an
///   orthonormal basis of the plane ⊥ `dᵢ` (Eq. (3)); the unconstrained least
///   squares in `(p'₀, a₀ … aₙ₋₁)` has the `2N + 3` normal equations (5),
///   solved by dense LU with partial pivoting (faer).
///
/// A constraint whose `dᵢ` vanishes (`|dᵢ| ≤` [`PARALLEL_EPS`], parallel
/// tangents) says nothing by itself. Dropping it would leave the chord free,
/// and for parallel tangents the only short helix is the straight segment
/// along them (Ghosh's theorem excludes `t₁ = t₀`; the limit is a full turn).
/// So we replace it by that condition, chord ∥ `t`: two constraints (chord ⊥
/// `u`, `v`) in the multiplier form, and `Dᵢ = [t̂]` (one unknown) in the dense
/// form. Both solvers still solve the same problem.
pub fn relax(points: &[DVec3], tangents: &[DVec3], method: Relaxation) -> Vec<DVec3> {
    match method {
        Relaxation::Tridiagonal => {
            let mut out = Vec::new();
            let mut scratch = RelaxScratch::default();
            relax_tridiagonal(points, tangents, &mut out, &mut scratch);
            out
        }
        Relaxation::DenseLu => relax_dense(points, tangents),
    }
}

/// Reusable buffers for [`relax_tridiagonal`] (no allocation in hot loops).
#[derive(Default, Debug)]
pub struct RelaxScratch {
    segs: Vec<Seg>,
    schur: Vec<Block>,
}

/// The constraint directions of one segment: `ê` for a proper constraint, or
/// an orthonormal pair `(u, v)` ⊥ `t` when the tangents are parallel (the
/// chord must then run along the tangent: the straight short helix).
#[derive(Clone, Copy, Debug, Default)]
struct Seg {
    dirs: [DVec3; 2],
    m: usize,
    /// Right-hand side, then the eliminated `y`, then the multipliers `λ`.
    y: [f64; 2],
    /// Off-diagonal block to the next segment, `−½ Eᵢᵀ Eᵢ₊₁`.
    b: Block,
}

/// A small dense block, `m × m'` with `m, m' ≤ 2`.
type Block = [[f64; 2]; 2];

/// Constraint directions of segment `i`: see [`Seg`].
#[inline]
fn segment_dirs(t0: DVec3, t1: DVec3) -> ([DVec3; 2], usize) {
    let d = t1 - t0;
    let len = d.length();
    if len > PARALLEL_EPS {
        ([d / len, DVec3::ZERO], 1)
    } else {
        let (u, v) = (t0 + t1).normalize().any_orthonormal_pair();
        ([u, v], 2)
    }
}

/// `O(N)` relaxation (the multiplier form of [`relax`]'s Method); writes
/// the relaxed points into `out`.
///
/// With parallel tangents the vanished constraint is replaced by the
/// straight-segment condition (chord ⊥ two directions ⊥ `t`), making the
/// system block tridiagonal with 1×1 or 2×2 blocks; the block Thomas
/// algorithm solves it in `O(N)` (the blocks are SPD Schur complements).
///
/// # Panics
/// If `points` and `tangents` differ in length (a programming error).
///
/// It satisfies every constraint `⟨p'ᵢ₊₁ − p'ᵢ, tᵢ₊₁ − tᵢ⟩ = 0`, and agrees with [`relax_dense`]:
/// ```
/// use strandfit::helix::{relax_dense, relax_tridiagonal, RelaxScratch};
/// use strandfit::DVec3;
///
/// let p = [DVec3::ZERO, DVec3::new(1.0, 0.2, 0.1), DVec3::new(1.5, 1.0, 0.4), DVec3::new(1.0, 2.0, 0.5)];
/// let t = [DVec3::X, DVec3::new(1.0, 1.0, 0.0).normalize(), DVec3::Y, DVec3::new(-1.0, 1.0, 0.2).normalize()];
/// let (mut out, mut scratch) = (Vec::new(), RelaxScratch::default());
/// relax_tridiagonal(&p, &t, &mut out, &mut scratch);
/// for i in 0..3 {
///     assert!((out[i + 1] - out[i]).dot(t[i + 1] - t[i]).abs() < 1e-14);
/// }
/// assert!(out.iter().zip(relax_dense(&p, &t)).all(|(a, b)| a.distance(b) < 1e-12));
/// ```
pub fn relax_tridiagonal(
    points: &[DVec3],
    tangents: &[DVec3],
    out: &mut Vec<DVec3>,
    scratch: &mut RelaxScratch,
) {
    assert_eq!(points.len(), tangents.len(), "one tangent per point");
    out.clear();
    out.extend_from_slice(points);
    let n = points.len().saturating_sub(1); // number of segments
    if n == 0 {
        return;
    }
    let RelaxScratch { segs, schur } = scratch;
    segs.clear();
    for i in 0..n {
        let (dirs, m) = segment_dirs(tangents[i], tangents[i + 1]);
        let chord = points[i + 1] - points[i];
        let mut y = [0.0; 2];
        for k in 0..m {
            y[k] = chord.dot(dirs[k]);
        }
        segs.push(Seg {
            dirs,
            m,
            y,
            b: [[0.0; 2]; 2],
        });
    }
    for i in 0..n.saturating_sub(1) {
        let (a, b) = (segs[i], segs[i + 1]);
        for r in 0..a.m {
            for c in 0..b.m {
                segs[i].b[r][c] = -0.5 * a.dirs[r].dot(b.dirs[c]);
            }
        }
    }
    // Forward elimination: Sᵢ = I − Bᵢ₋₁ᵀ Sᵢ₋₁⁻¹ Bᵢ₋₁, yᵢ −= Bᵢ₋₁ᵀ Sᵢ₋₁⁻¹ yᵢ₋₁.
    schur.clear();
    for i in 0..n {
        let m = segs[i].m;
        let mut s = identity(m);
        if i > 0 {
            let prev = segs[i - 1];
            let inv = inverse(&schur[i - 1], prev.m);
            // W = S⁻¹ B (prev.m × m)
            let w = mul(&inv, prev.m, prev.m, &prev.b, m);
            let winv_y = mat_vec(&inv, prev.m, prev.m, &prev.y);
            for r in 0..m {
                for c in 0..m {
                    for k in 0..prev.m {
                        s[r][c] -= prev.b[k][r] * w[k][c];
                    }
                }
                for k in 0..prev.m {
                    segs[i].y[r] -= prev.b[k][r] * winv_y[k];
                }
            }
        }
        schur.push(s);
    }
    // Back substitution: λᵢ = Sᵢ⁻¹ (yᵢ − Bᵢ λᵢ₊₁), stored in y.
    for i in (0..n).rev() {
        let m = segs[i].m;
        let mut rhs = segs[i].y;
        if i + 1 < n {
            let next = segs[i + 1];
            for r in 0..m {
                for c in 0..next.m {
                    rhs[r] -= segs[i].b[r][c] * next.y[c];
                }
            }
        }
        let inv = inverse(&schur[i], m);
        segs[i].y = mat_vec(&inv, m, m, &rhs);
    }
    // p'ᵢ = pᵢ − ½(Eᵢ₋₁λᵢ₋₁ − Eᵢλᵢ)
    for i in 0..=n {
        let mut corr = DVec3::ZERO;
        if i > 0 {
            let s = &segs[i - 1];
            for k in 0..s.m {
                corr += s.y[k] * s.dirs[k];
            }
        }
        if i < n {
            let s = &segs[i];
            for k in 0..s.m {
                corr -= s.y[k] * s.dirs[k];
            }
        }
        out[i] -= 0.5 * corr;
    }
}

#[inline]
fn identity(m: usize) -> Block {
    let mut b = [[0.0; 2]; 2];
    for (k, row) in b.iter_mut().enumerate().take(m) {
        row[k] = 1.0;
    }
    b
}

/// Inverse of an SPD block of size 1 or 2.
#[inline]
fn inverse(a: &Block, m: usize) -> Block {
    if m == 1 {
        [[1.0 / a[0][0], 0.0], [0.0, 0.0]]
    } else {
        let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
        [
            [a[1][1] / det, -a[0][1] / det],
            [-a[1][0] / det, a[0][0] / det],
        ]
    }
}

#[inline]
fn mul(a: &Block, r: usize, k: usize, b: &Block, c: usize) -> Block {
    let mut out = [[0.0; 2]; 2];
    for i in 0..r {
        for j in 0..c {
            for l in 0..k {
                out[i][j] += a[i][l] * b[l][j];
            }
        }
    }
    out
}

#[inline]
fn mat_vec(a: &Block, r: usize, c: usize, v: &[f64; 2]) -> [f64; 2] {
    let mut out = [0.0; 2];
    for i in 0..r {
        for j in 0..c {
            out[i] += a[i][j] * v[j];
        }
    }
    out
}

/// The paper's dense normal equations (5), solved by LU with partial pivoting
/// (see [`relax`]'s Method).
///
/// Points are centred on their centroid first (translation does not change
/// the minimiser, and it keeps the right-hand side small).
///
/// # Panics
/// If `points` and `tangents` differ in length (a programming error).
///
/// Tangents `x` then `y` ask for a chord ⊥ `y − x`; each point moves half the
/// way, along `y − x`:
/// ```
/// use strandfit::helix::relax_dense;
/// use strandfit::DVec3;
///
/// let p = relax_dense(&[DVec3::ZERO, DVec3::X], &[DVec3::X, DVec3::Y]);
/// assert!((p[0] - DVec3::new(0.25, -0.25, 0.0)).length() < 1e-15);
/// assert!((p[1] - DVec3::new(0.75, 0.25, 0.0)).length() < 1e-15);
/// ```
pub fn relax_dense(points: &[DVec3], tangents: &[DVec3]) -> Vec<DVec3> {
    assert_eq!(points.len(), tangents.len(), "one tangent per point");
    let n = points.len().saturating_sub(1);
    if n == 0 {
        return points.to_vec();
    }
    let centroid = points.iter().copied().sum::<DVec3>() / points.len() as f64;
    let p: Vec<DVec3> = points.iter().map(|&q| q - centroid).collect();

    // Basis columns of each Dⱼ and their offsets in the unknown vector.
    let mut bases: Vec<Vec<DVec3>> = Vec::with_capacity(n);
    for j in 0..n {
        let d = tangents[j + 1] - tangents[j];
        let len = d.length();
        if len > PARALLEL_EPS {
            let (v0, v1) = (d / len).any_orthonormal_pair();
            bases.push(vec![v0, v1]);
        } else {
            // Parallel tangents: the chord must run along them (1 unknown).
            bases.push(vec![(tangents[j] + tangents[j + 1]).normalize()]);
        }
    }
    let mut offset = Vec::with_capacity(n);
    let mut size = 3;
    for b in &bases {
        offset.push(size);
        size += b.len();
    }

    // Suffix sums S_j = Σ_{i>j} p_i for the right-hand side.
    let mut suffix = vec![DVec3::ZERO; n + 1];
    for j in (0..n).rev() {
        suffix[j] = suffix[j + 1] + p[j + 1];
    }
    let total: DVec3 = p.iter().copied().sum();

    let mut a = Mat::<f64>::zeros(size, size);
    let mut rhs = Mat::<f64>::zeros(size, 1);
    let np1 = (n + 1) as f64;
    for r in 0..3 {
        a[(r, r)] = np1;
        rhs[(r, 0)] = total[r];
    }
    for j in 0..n {
        let wj = (n - j) as f64; // number of points i > j
        for (cj, v) in bases[j].iter().enumerate() {
            let col = offset[j] + cj;
            // p'₀ block × Dⱼ block: (N − j) Dⱼ
            for r in 0..3 {
                a[(r, col)] = wj * v[r];
                a[(col, r)] = wj * v[r];
            }
            rhs[(col, 0)] = v.dot(suffix[j]);
            // Dⱼᵀ D_k blocks: (N − max(j, k)) ⟨v, u⟩
            for k in j..n {
                let wk = (n - k) as f64;
                for (ck, u) in bases[k].iter().enumerate() {
                    let col2 = offset[k] + ck;
                    let val = wk * v.dot(*u);
                    a[(col, col2)] = val;
                    a[(col2, col)] = val;
                }
            }
        }
    }
    let lu = a.partial_piv_lu();
    let x = lu.solve(&rhs);

    let mut out = Vec::with_capacity(n + 1);
    let mut cur = DVec3::new(x[(0, 0)], x[(1, 0)], x[(2, 0)]);
    out.push(cur + centroid);
    for j in 0..n {
        for (cj, v) in bases[j].iter().enumerate() {
            cur += x[(offset[j] + cj, 0)] * *v;
        }
        out.push(cur + centroid);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

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

    /// Random smooth-ish polyline with slowly turning tangents.
    fn random_data(rng: &mut impl Rng, n: usize) -> (Vec<DVec3>, Vec<DVec3>) {
        let mut p = vec![DVec3::new(10.0, -3.0, 7.0)];
        let mut t = vec![random_unit(rng)];
        for i in 0..n {
            let step = rng.gen_range(0.5..1.5);
            let noise = 0.3 * random_unit(rng);
            let nt = (t[i] + noise).normalize();
            p.push(p[i] + step * (t[i] + nt).normalize() + 0.05 * random_unit(rng));
            t.push(nt);
        }
        (p, t)
    }

    fn max_constraint_residual(p: &[DVec3], t: &[DVec3]) -> f64 {
        (0..p.len() - 1)
            .map(|i| {
                let d = t[i + 1] - t[i];
                let chord = p[i + 1] - p[i];
                if d.length() <= PARALLEL_EPS {
                    chord.cross(t[i]).length() / chord.length()
                } else {
                    chord.dot(d).abs() / (chord.length() * d.length())
                }
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn both_solvers_agree_and_satisfy_constraints() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for &n in &[1usize, 2, 3, 10, 57, 200] {
            for _ in 0..5 {
                let (p, t) = random_data(&mut rng, n);
                let a = relax(&p, &t, Relaxation::DenseLu);
                let b = relax(&p, &t, Relaxation::Tridiagonal);
                let scale = p.iter().map(|q| (*q - p[0]).length()).fold(0.0, f64::max);
                let diff = a
                    .iter()
                    .zip(&b)
                    .map(|(x, y)| (*x - *y).length())
                    .fold(0.0, f64::max);
                assert!(diff <= 1e-9 * scale, "n={n}: solvers differ by {diff}");
                assert!(max_constraint_residual(&a, &t) < 1e-10, "dense residual");
                assert!(
                    max_constraint_residual(&b, &t) < 1e-10,
                    "tridiagonal residual"
                );
            }
        }
    }

    #[test]
    fn relaxation_is_the_minimiser() {
        // Any feasible perturbation (a move along the constraint manifold)
        // increases the objective: compare with random feasible points
        // obtained by relaxing perturbed data (feasible for the same tangents).
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let (p, t) = random_data(&mut rng, 12);
        let best = relax(&p, &t, Relaxation::Tridiagonal);
        let cost = |q: &[DVec3]| {
            q.iter()
                .zip(&p)
                .map(|(a, b)| (*a - *b).length_squared())
                .sum::<f64>()
        };
        let c0 = cost(&best);
        for _ in 0..50 {
            let pert: Vec<DVec3> = p.iter().map(|q| *q + 0.2 * random_unit(&mut rng)).collect();
            let feasible = relax(&pert, &t, Relaxation::Tridiagonal);
            assert!(max_constraint_residual(&feasible, &t) < 1e-10);
            assert!(cost(&feasible) >= c0 - 1e-12);
        }
    }

    #[test]
    fn already_cohelical_points_do_not_move_and_translation_commutes() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let (p, t) = random_data(&mut rng, 20);
        let once = relax(&p, &t, Relaxation::Tridiagonal);
        let twice = relax(&once, &t, Relaxation::Tridiagonal);
        for (a, b) in once.iter().zip(&twice) {
            assert!((*a - *b).length() < 1e-12);
        }
        let shift = DVec3::new(1e3, -2e3, 5e2);
        let moved: Vec<DVec3> = p.iter().map(|q| *q + shift).collect();
        let r = relax(&moved, &t, Relaxation::DenseLu);
        for (a, b) in once.iter().zip(&r) {
            assert!((*a + shift - *b).length() < 1e-9);
        }
    }

    #[test]
    fn parallel_tangents_force_straight_chords() {
        // Straight run in the middle: t2 = t3 = t4 exactly.
        let t = vec![
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0).normalize(),
            DVec3::Y,
            DVec3::Y,
            DVec3::Y,
            DVec3::new(0.0, 1.0, 1.0).normalize(),
        ];
        let p = vec![
            DVec3::ZERO,
            DVec3::new(1.0, 0.4, 0.1),
            DVec3::new(1.5, 1.3, 0.0),
            DVec3::new(1.6, 2.3, -0.1),
            DVec3::new(1.5, 3.3, 0.2),
            DVec3::new(1.5, 4.0, 0.9),
        ];
        let a = relax(&p, &t, Relaxation::DenseLu);
        let b = relax(&p, &t, Relaxation::Tridiagonal);
        for (x, y) in a.iter().zip(&b) {
            assert!((*x - *y).length() < 1e-12);
        }
        assert!(max_constraint_residual(&b, &t) < 1e-12);
        // All tangents equal: the points are projected onto a common line
        // along the tangent, through their centroid (least squares).
        let t_same = vec![DVec3::Z; 5];
        let p_any: Vec<DVec3> = (0..5)
            .map(|i| DVec3::new(i as f64, (i * i) as f64, i as f64))
            .collect();
        let tri = relax(&p_any, &t_same, Relaxation::Tridiagonal);
        let dense = relax(&p_any, &t_same, Relaxation::DenseLu);
        let c = p_any.iter().copied().sum::<DVec3>() / 5.0;
        for ((x, y), p) in dense.iter().zip(&tri).zip(&p_any) {
            assert!((*x - *y).length() < 1e-12);
            assert!((x.x - c.x).abs() < 1e-12 && (x.y - c.y).abs() < 1e-12);
            assert!((x.z - p.z).abs() < 1e-12);
        }
    }

    #[test]
    fn random_data_with_parallel_runs_agree() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for n in [4usize, 9, 40, 150] {
            let (p, mut t) = random_data(&mut rng, n);
            // Make a few runs of equal tangents, including at the ends.
            for i in [0usize, 1, n / 2, n / 2 + 1, n - 1] {
                t[i + 1] = t[i];
            }
            let a = relax(&p, &t, Relaxation::DenseLu);
            let b = relax(&p, &t, Relaxation::Tridiagonal);
            let scale = p.iter().map(|q| (*q - p[0]).length()).fold(0.0, f64::max);
            let diff = a
                .iter()
                .zip(&b)
                .map(|(x, y)| (*x - *y).length())
                .fold(0.0, f64::max);
            assert!(diff <= 1e-9 * scale, "n={n}: {diff}");
            assert!(max_constraint_residual(&a, &t) < 1e-10);
            assert!(max_constraint_residual(&b, &t) < 1e-10);
        }
    }

    #[test]
    fn degenerate_sizes() {
        assert!(relax(&[], &[], Relaxation::Tridiagonal).is_empty());
        assert!(relax(&[], &[], Relaxation::DenseLu).is_empty());
        let one = [DVec3::ONE];
        assert_eq!(relax(&one, &[DVec3::X], Relaxation::DenseLu), one.to_vec());
    }
}
