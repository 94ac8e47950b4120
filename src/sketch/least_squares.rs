//! A small Levenberg–Marquardt search for the two-vertex fits of Section
//! 6.2 (described on `least_squares`).

use super::nelder_mead::Minimum;

/// Stopping rules of [`least_squares`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeastSquaresOptions {
    /// Evaluations of the residuals after which the search stops (a
    /// Jacobian by forward differences costs `N`).
    pub max_evals: usize,
    /// Relative decrease of `‖r‖²` in an accepted step to stop at.
    pub ftol: f64,
    /// Step length (∞-norm), relative to the parameters' size, to stop at.
    pub xtol: f64,
}

impl Default for LeastSquaresOptions {
    fn default() -> Self {
        LeastSquaresOptions {
            max_evals: 200,
            ftol: 1e-12,
            xtol: 1e-10,
        }
    }
}

/// Minimise `‖r(x)‖²` from `x0` by Levenberg–Marquardt: each step solves
/// `(JᵀJ + λ·diag(JᵀJ)) δ = −Jᵀr` (Marquardt's scaling, the diagonal
/// floored so that a parameter the residuals ignore stays put), with `J`
/// by forward differences; a step that lowers `‖r‖²` is taken and `λ`
/// divided by 3, one that does not multiplies `λ` by 4 and is solved again
/// from the same `J`. Non-finite residuals count as `+∞`. Returns the best
/// point, `‖r‖²` there and the evaluations spent.
///
/// Stops once an accepted step lowers `‖r‖²` by less than `ftol` of it or
/// moves `x` by less than `xtol·(‖x‖∞ + xtol)`, once `‖r‖²` is zero, or
/// once `max_evals` evaluations are spent (checked before each Jacobian and
/// each trial).
///
/// ```
/// use strandfit::sketch::{least_squares, LeastSquaresOptions};
/// // Rosenbrock as residuals: ‖r‖² = (1 − x)² + 100 (y − x²)².
/// let r = |x: &[f64; 2]| [1.0 - x[0], 10.0 * (x[1] - x[0] * x[0])];
/// let m = least_squares(r, [-1.2, 1.0], &LeastSquaresOptions::default());
/// assert!((m.x[0] - 1.0).abs() < 1e-6 && (m.x[1] - 1.0).abs() < 1e-6, "{:?}", m.x);
/// assert!(m.value < 1e-12 && m.evals < 200);
/// ```
pub fn least_squares<const N: usize, const M: usize>(
    mut f: impl FnMut(&[f64; N]) -> [f64; M],
    x0: [f64; N],
    opts: &LeastSquaresOptions,
) -> Minimum<N> {
    let mut eval = |x: &[f64; N]| {
        let r = f(x);
        let s: f64 = r.iter().map(|v| v * v).sum();
        (r, if s.is_finite() { s } else { f64::INFINITY })
    };
    let (mut r, mut value) = eval(&x0);
    let mut x = x0;
    let mut evals = 1;
    let mut lambda = 1e-3;
    'outer: while value > 0.0 && value.is_finite() && evals + N <= opts.max_evals {
        // Forward differences, each step scaled to its parameter.
        let mut jac = [[0.0; N]; M];
        for k in 0..N {
            let h = 1e-8 * x[k].abs().max(1e-4);
            let mut xh = x;
            xh[k] += h;
            let (rh, _) = eval(&xh);
            for i in 0..M {
                jac[i][k] = (rh[i] - r[i]) / h;
            }
        }
        evals += N;
        let mut a = [[0.0; N]; N];
        let mut g = [0.0; N];
        for i in 0..M {
            for k in 0..N {
                g[k] += jac[i][k] * r[i];
                for l in 0..N {
                    a[k][l] += jac[i][k] * jac[i][l];
                }
            }
        }
        let floor = (0..N).map(|k| a[k][k]).fold(0.0, f64::max) * 1e-12 + 1e-300;
        loop {
            if evals >= opts.max_evals {
                break 'outer;
            }
            let mut damped = a;
            for k in 0..N {
                damped[k][k] += lambda * a[k][k].max(floor);
            }
            let Some(delta) = cholesky_solve(damped, g.map(|v| -v)) else {
                lambda *= 4.0;
                if lambda > 1e16 {
                    break 'outer;
                }
                continue;
            };
            let trial: [f64; N] = std::array::from_fn(|k| x[k] + delta[k]);
            let (rt, vt) = eval(&trial);
            evals += 1;
            if vt < value {
                let size = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let step = delta.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let decrease = value - vt;
                (x, r, value) = (trial, rt, vt);
                lambda = (lambda / 3.0).max(1e-12);
                if decrease <= opts.ftol * value || step <= opts.xtol * (size + opts.xtol) {
                    break 'outer;
                }
                break;
            }
            lambda *= 4.0;
            if lambda > 1e16 {
                break 'outer;
            }
        }
    }
    Minimum { x, value, evals }
}

/// `A x = b` for a symmetric positive definite `A` (Cholesky), or `None`
/// where a pivot is not positive.
fn cholesky_solve<const N: usize>(mut a: [[f64; N]; N], mut b: [f64; N]) -> Option<[f64; N]> {
    for j in 0..N {
        let mut d = a[j][j];
        for k in 0..j {
            d -= a[j][k] * a[j][k];
        }
        if !(d > 0.0) {
            return None;
        }
        let d = d.sqrt();
        a[j][j] = d;
        for i in j + 1..N {
            let mut s = a[i][j];
            for k in 0..j {
                s -= a[i][k] * a[j][k];
            }
            a[i][j] = s / d;
        }
    }
    for i in 0..N {
        for k in 0..i {
            b[i] -= a[i][k] * b[k];
        }
        b[i] /= a[i][i];
    }
    for i in (0..N).rev() {
        for k in i + 1..N {
            b[i] -= a[k][i] * b[k];
        }
        b[i] /= a[i][i];
    }
    Some(b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn cholesky_solves_random_positive_definite_systems() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for _ in 0..200 {
            let m: [[f64; 3]; 5] =
                std::array::from_fn(|_| std::array::from_fn(|_| rng.gen_range(-1.0..1.0)));
            let mut a = [[0.0; 3]; 3];
            for row in &m {
                for k in 0..3 {
                    for l in 0..3 {
                        a[k][l] += row[k] * row[l];
                    }
                }
            }
            let x: [f64; 3] = std::array::from_fn(|_| rng.gen_range(-1.0..1.0));
            let b: [f64; 3] = std::array::from_fn(|k| (0..3).map(|l| a[k][l] * x[l]).sum());
            let y = cholesky_solve(a, b).unwrap();
            for k in 0..3 {
                assert!(
                    (y[k] - x[k]).abs() < 1e-8 * (1.0 + x[k].abs()),
                    "{y:?} {x:?}"
                );
            }
        }
        assert!(cholesky_solve([[1.0, 2.0], [2.0, 1.0]], [1.0, 1.0]).is_none());
    }

    #[test]
    fn finds_the_zero_of_consistent_systems_and_the_minimum_of_others() {
        // Three nonlinear equations in three unknowns with the root (1, 2, 3),
        // from random starts near it; then a fourth, inconsistent residual:
        // the minimum of ‖r‖² found must be stationary (no smaller value in
        // small steps around it).
        let root = [1.0, 2.0, 3.0];
        let r3 = |x: &[f64; 3]| {
            [
                x[0] * x[1] - 2.0,
                x[1].sin() + x[2] - 2f64.sin() - 3.0,
                x[0] * x[0] + 0.1 * x[2] * x[2] - 1.9,
            ]
        };
        let r4 = |x: &[f64; 3]| {
            let [a, b, c] = r3(x);
            [a, b, c, x[0] + x[1] + x[2] - 5.0]
        };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let opts = LeastSquaresOptions::default();
        for _ in 0..50 {
            let x0: [f64; 3] = std::array::from_fn(|k| root[k] + rng.gen_range(-0.3..0.3));
            let m = least_squares(r3, x0, &opts);
            assert!(m.value < 1e-20, "{m:?}");
            for k in 0..3 {
                assert!((m.x[k] - root[k]).abs() < 1e-8, "{m:?}");
            }
            let m = least_squares(r4, x0, &opts);
            let value = |x: &[f64; 3]| r4(x).iter().map(|v| v * v).sum::<f64>();
            assert!((value(&m.x) - m.value).abs() <= 1e-15 * m.value, "{m:?}");
            assert!(m.value > 0.1, "inconsistent: {m:?}");
            for k in 0..3 {
                for h in [-1e-4, 1e-4] {
                    let mut y = m.x;
                    y[k] += h;
                    assert!(
                        value(&y) >= m.value - 1e-12,
                        "{m:?} not a minimum along {k}"
                    );
                }
            }
        }
    }

    #[test]
    fn keeps_to_its_budget_and_treats_non_finite_residuals_as_infinite() {
        let opts = LeastSquaresOptions {
            max_evals: 12,
            ..Default::default()
        };
        let rosen = |x: &[f64; 2]| [1.0 - x[0], 10.0 * (x[1] - x[0] * x[0])];
        let m = least_squares(rosen, [-1.2, 1.0], &opts);
        assert!(m.evals <= 12, "{m:?}");
        // A residual that is NaN beyond x = 2 is never stepped into.
        let walled = |x: &[f64; 1]| [if x[0] > 2.0 { f64::NAN } else { x[0] - 3.0 }];
        let m = least_squares(walled, [0.0], &LeastSquaresOptions::default());
        assert!(m.x[0] <= 2.0 && m.value.is_finite(), "{m:?}");
        assert!(m.x[0] > 1.5, "{m:?}");
    }
}
