//! The Nelder–Mead simplex search of Section 6.2 (described on `minimize`).

/// Stopping rules of [`minimize`].
///
/// ```
/// use strandfit::sketch::{minimize, NelderMeadOptions};
///
/// let rosenbrock = |x: &[f64; 2]| (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2);
/// // A budget of 30 evaluations stops the search early: the last step may
/// // overrun it by at most N + 1 = 3.
/// let opts = NelderMeadOptions { max_evals: 30, ..Default::default() };
/// let m = minimize(rosenbrock, [-1.2, 1.0], [0.1, 0.1], &opts);
/// assert!(m.evals >= 30 && m.evals <= 33, "{}", m.evals);
/// let full = minimize(rosenbrock, [-1.2, 1.0], [0.1, 0.1], &NelderMeadOptions::default());
/// assert!(full.value < m.value);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NelderMeadOptions {
    /// Evaluations of the function after which the search stops (checked
    /// before each step, which may spend up to `N + 1` more).
    pub max_evals: usize,
    /// Relative spread of the simplex's values to stop at.
    pub ftol: f64,
    /// Largest vertex distance (∞-norm) from the best to stop at.
    pub xtol: f64,
}

impl Default for NelderMeadOptions {
    fn default() -> Self {
        NelderMeadOptions {
            max_evals: 600,
            ftol: 1e-14,
            xtol: 1e-10,
        }
    }
}

/// The best vertex found, its value and the evaluations spent.
///
/// ```
/// use strandfit::sketch::{minimize, NelderMeadOptions};
///
/// // The value is the function's at the vertex returned; every call counted.
/// let mut calls = 0;
/// let f = |x: &[f64; 3]| (x[0] - 3.0).powi(2) + 10.0 * (x[1] + 1.0).powi(2) + x[2] * x[2];
/// let m = minimize(|x: &[f64; 3]| { calls += 1; f(x) }, [0.0; 3], [0.5; 3], &NelderMeadOptions::default());
/// assert_eq!(m.evals, calls);
/// assert_eq!(m.value, f(&m.x));
/// assert!((m.x[0] - 3.0).abs() < 1e-4 && (m.x[1] + 1.0).abs() < 1e-4);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Minimum<const N: usize> {
    /// The best vertex.
    pub x: [f64; N],
    /// The function's value there.
    pub value: f64,
    /// Evaluations spent.
    pub evals: usize,
}

/// Minimise `f` from `x0`, the initial simplex `x0` and `x0 + step_i e_i`.
/// A `NaN` value counts as `+∞` (so a bad region is left, not trusted).
///
/// The Nelder–Mead simplex search as Lagarias, Reeds, Wright & Wright
/// (1998) state it — the method the paper uses for its small fits (Section
/// 6.2, reference \[14\]): reflection ρ = 1, expansion χ = 2, contraction
/// γ = ½ (outside and inside), shrink σ = ½, with their tie-breaking
/// (a new vertex goes after the old ones of equal value).
///
/// Stops when the simplex is small in both senses —
/// `max |f_i − f_0| ≤ ftol·(|f_0| + tiny)` and `max ‖x_i − x_0‖_∞ ≤ xtol` —
/// or once `max_evals` evaluations are spent (checked before each step:
/// the step under way may spend up to `N + 1` more).
///
/// ```
/// use strandfit::sketch::{minimize, NelderMeadOptions};
/// let rosenbrock = |x: &[f64; 2]| (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2);
/// let m = minimize(rosenbrock, [-1.2, 1.0], [0.1, 0.1], &NelderMeadOptions::default());
/// assert!((m.x[0] - 1.0).abs() < 1e-4 && (m.x[1] - 1.0).abs() < 1e-4, "{:?}", m.x);
/// ```
pub fn minimize<const N: usize>(
    mut f: impl FnMut(&[f64; N]) -> f64,
    x0: [f64; N],
    step: [f64; N],
    opts: &NelderMeadOptions,
) -> Minimum<N> {
    let mut eval = |x: &[f64; N]| {
        let v = f(x);
        if v.is_nan() {
            f64::INFINITY
        } else {
            v
        }
    };
    let mut simplex: Vec<([f64; N], f64)> = Vec::with_capacity(N + 1);
    simplex.push((x0, eval(&x0)));
    for i in 0..N {
        let mut x = x0;
        x[i] += step[i];
        simplex.push((x, eval(&x)));
    }
    let mut evals = N + 1;
    let combine = |a: &[f64; N], b: &[f64; N], t: f64| -> [f64; N] {
        // a + t (b − a)
        std::array::from_fn(|k| a[k] + t * (b[k] - a[k]))
    };
    loop {
        // Stable sort: equal values keep their order (Lagarias' rule).
        simplex.sort_by(|p, q| p.1.total_cmp(&q.1));
        let best = simplex[0].1;
        let fspread = simplex
            .iter()
            .map(|p| (p.1 - best).abs())
            .fold(0.0, f64::max);
        let xspread = simplex
            .iter()
            .flat_map(|p| p.0.iter().zip(&simplex[0].0).map(|(a, b)| (a - b).abs()))
            .fold(0.0, f64::max);
        let converged = fspread <= opts.ftol * (best.abs() + 1e-300) && xspread <= opts.xtol;
        if converged || evals >= opts.max_evals || !best.is_finite() && xspread == 0.0 {
            break;
        }
        let centroid: [f64; N] =
            std::array::from_fn(|k| simplex[..N].iter().map(|p| p.0[k]).sum::<f64>() / N as f64);
        let (worst_x, worst_f) = simplex[N];
        let second_worst = simplex[N - 1].1;
        let xr = combine(&centroid, &worst_x, -1.0);
        let fr = eval(&xr);
        evals += 1;
        if fr < best {
            let xe = combine(&centroid, &worst_x, -2.0);
            let fe = eval(&xe);
            evals += 1;
            simplex[N] = if fe < fr { (xe, fe) } else { (xr, fr) };
            continue;
        }
        if fr < second_worst {
            simplex[N] = (xr, fr);
            continue;
        }
        // Contraction: outside if the reflected point beats the worst.
        let (xc, fc, accept) = if fr < worst_f {
            let xc = combine(&centroid, &worst_x, -0.5);
            let fc = eval(&xc);
            (xc, fc, fc <= fr)
        } else {
            let xc = combine(&centroid, &worst_x, 0.5);
            let fc = eval(&xc);
            (xc, fc, fc < worst_f)
        };
        evals += 1;
        if accept {
            simplex[N] = (xc, fc);
            continue;
        }
        // Shrink towards the best vertex.
        let x_best = simplex[0].0;
        for p in simplex.iter_mut().skip(1) {
            p.0 = combine(&x_best, &p.0, 0.5);
            p.1 = eval(&p.0);
        }
        evals += N;
    }
    simplex.sort_by(|p, q| p.1.total_cmp(&q.1));
    Minimum {
        x: simplex[0].0,
        value: simplex[0].1,
        evals,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_rosenbrock_minimum() {
        let r = minimize(
            |x: &[f64; 2]| 100.0 * (x[1] - x[0] * x[0]).powi(2) + (1.0 - x[0]).powi(2),
            [-1.2, 1.0],
            [0.1, 0.1],
            &NelderMeadOptions {
                max_evals: 2000,
                ..Default::default()
            },
        );
        assert!(
            (r.x[0] - 1.0).abs() < 1e-6 && (r.x[1] - 1.0).abs() < 1e-6,
            "{r:?}"
        );
        assert!(r.value < 1e-12);
    }

    #[test]
    fn finds_a_shifted_quadratic_in_three_dimensions_and_respects_the_budget() {
        let f = |x: &[f64; 3]| {
            (x[0] - 3.0).powi(2) + 10.0 * (x[1] + 1.0).powi(2) + (x[2] - 0.5).powi(4)
        };
        let r = minimize(f, [0.0; 3], [0.5; 3], &NelderMeadOptions::default());
        assert!(
            (r.x[0] - 3.0).abs() < 1e-5 && (r.x[1] + 1.0).abs() < 1e-5,
            "{r:?}"
        );
        assert!((r.x[2] - 0.5).abs() < 1e-2);
        let few = minimize(
            f,
            [0.0; 3],
            [0.5; 3],
            &NelderMeadOptions {
                max_evals: 20,
                ..Default::default()
            },
        );
        assert!(few.evals <= 20 + 3, "{}", few.evals);
        assert!(few.value > r.value);
    }

    #[test]
    fn nan_regions_are_avoided() {
        // NaN for x < 0: the minimum at x = 0.25 is still found from x = 1.
        let r = minimize(
            |x: &[f64; 1]| {
                if x[0] < 0.0 {
                    f64::NAN
                } else {
                    (x[0] - 0.25).powi(2)
                }
            },
            [1.0],
            [0.8],
            &NelderMeadOptions::default(),
        );
        assert!((r.x[0] - 0.25).abs() < 1e-6, "{r:?}");
    }
}
