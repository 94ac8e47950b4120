//! The scaling function `ρ` of an ATPH curve in Bernstein form: `Bernstein`.

/// Bernstein coefficients `ρ₀ … ρₙ`, `n ≤ 3`.
///
/// The scaling function `ρ` of an ATPH curve as a polynomial of degree
/// `n ≤ 3` in Bernstein form on `[0, 1]`, `ρ(t) = Σ ρ_j B_jⁿ(t)` (Eqs. 2.7,
/// 2.9). Its sign decides regularity (Proposition 1): `‖r′‖ = |ρ|`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bernstein {
    coef: [f64; 4],
    degree: usize,
}

/// `B_jⁿ(t) = Σ_k MONOMIAL[n][j][k] tᵏ`.
const MONOMIAL: [[[f64; 4]; 4]; 4] = [
    [[1.0, 0.0, 0.0, 0.0], [0.0; 4], [0.0; 4], [0.0; 4]],
    [
        [1.0, -1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0; 4],
        [0.0; 4],
    ],
    [
        [1.0, -2.0, 1.0, 0.0],
        [0.0, 2.0, -2.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0; 4],
    ],
    [
        [1.0, -3.0, 3.0, -1.0],
        [0.0, 3.0, -6.0, 3.0],
        [0.0, 0.0, 3.0, -3.0],
        [0.0, 0.0, 0.0, 1.0],
    ],
];

/// How `ρ` behaves on `[0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sign {
    /// `ρ > 0`: a regular curve running along the interpolated tangents.
    Positive,
    /// `ρ < 0`: regular, but running against them (Section 3.2).
    Negative,
    /// `ρ` vanishes somewhere on `[0, 1]`: the curve has a singular point.
    Vanishes,
}

impl Bernstein {
    /// From coefficients `ρ₀ … ρₙ`; `1 ≤ len ≤ 4`.
    pub fn new(coefficients: &[f64]) -> Self {
        assert!(
            (1..=4).contains(&coefficients.len()),
            "degree 0 to 3 supported"
        );
        let mut coef = [0.0; 4];
        coef[..coefficients.len()].copy_from_slice(coefficients);
        Bernstein {
            coef,
            degree: coefficients.len() - 1,
        }
    }

    /// The degree `n` (2 or 3).
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// The Bernstein coefficients `ρ₀ … ρₙ`.
    pub fn coefficients(&self) -> &[f64] {
        &self.coef[..=self.degree]
    }

    /// Monomial coefficients `c_k` of `ρ(t) = Σ c_k tᵏ`.
    ///
    /// `(1−t)² + 2·2t(1−t) + 3t² = 1 + 2t`:
    /// ```
    /// use strandfit::atph::Bernstein;
    ///
    /// assert_eq!(Bernstein::new(&[1.0, 2.0, 3.0]).monomial(), [1.0, 2.0, 0.0, 0.0]);
    /// ```
    pub fn monomial(&self) -> [f64; 4] {
        let mut c = [0.0; 4];
        for j in 0..=self.degree {
            for k in 0..4 {
                c[k] += self.coef[j] * MONOMIAL[self.degree][j][k];
            }
        }
        c
    }

    /// `B_jⁿ` in monomial form (the columns of systems 3.1 and 4.1).
    ///
    /// `B₁³(t) = 3t(1 − t)² = 3t − 6t² + 3t³`:
    /// ```
    /// use strandfit::atph::Bernstein;
    ///
    /// assert_eq!(Bernstein::basis_monomial(3, 1), [0.0, 3.0, -6.0, 3.0]);
    /// ```
    pub fn basis_monomial(degree: usize, j: usize) -> [f64; 4] {
        MONOMIAL[degree][j]
    }

    /// `ρ(t)` by de Casteljau (stable for the Bernstein form).
    ///
    /// It agrees with the monomial form `1 + 2t` of Bernstein `1, 2, 3`:
    /// ```
    /// use strandfit::atph::Bernstein;
    ///
    /// let b = Bernstein::new(&[1.0, 2.0, 3.0]);
    /// assert!((b.eval(0.3) - 1.6).abs() < 1e-15);
    /// ```
    pub fn eval(&self, t: f64) -> f64 {
        let mut b = self.coef;
        for r in 1..=self.degree {
            for j in 0..=self.degree - r {
                b[j] = (1.0 - t) * b[j] + t * b[j + 1];
            }
        }
        b[0]
    }

    /// `ρ′(t)`.
    ///
    /// ```
    /// use strandfit::atph::Bernstein;
    ///
    /// // (1 − 2t)², Bernstein 1, −1, 1: derivative 8t − 4.
    /// assert!((Bernstein::new(&[1.0, -1.0, 1.0]).derivative(0.75) - 2.0).abs() < 1e-15);
    /// ```
    pub fn derivative(&self, t: f64) -> f64 {
        let n = self.degree;
        if n == 0 {
            return 0.0;
        }
        let mut d = [0.0; 4];
        for j in 0..n {
            d[j] = n as f64 * (self.coef[j + 1] - self.coef[j]);
        }
        Bernstein::new(&d[..n]).eval(t)
    }

    /// `∫₀¹ ρ = Σ ρ_j / (n + 1)` (each `B_jⁿ` integrates to `1/(n+1)`).
    ///
    /// ```
    /// use strandfit::atph::Bernstein;
    ///
    /// // 1 + 2t − 3t² + t³ (Bernstein 1, 5/3, 4/3, 1) integrates to 1 + 1 − 1 + 1/4.
    /// assert!((Bernstein::new(&[1.0, 5.0 / 3.0, 4.0 / 3.0, 1.0]).integral() - 1.25).abs() < 1e-15);
    /// ```
    pub fn integral(&self) -> f64 {
        self.coefficients().iter().sum::<f64>() / (self.degree + 1) as f64
    }

    /// `∫₀^ξ ρ`.
    ///
    /// `∫₀^½ (1 + 2t) dt = ¾`:
    /// ```
    /// use strandfit::atph::Bernstein;
    ///
    /// assert!((Bernstein::new(&[1.0, 2.0, 3.0]).integral_to(0.5) - 0.75).abs() < 1e-15);
    /// ```
    pub fn integral_to(&self, xi: f64) -> f64 {
        let c = self.monomial();
        let mut s = 0.0;
        let mut x = xi;
        for (k, ck) in c.iter().enumerate() {
            s += ck * x / (k + 1) as f64;
            x *= xi;
        }
        s
    }

    /// The paper's sufficient test (Sections 3.2 and 4): all coefficients of
    /// one strict sign bound `ρ` away from zero (`min ρ_j ≤ ρ ≤ max ρ_j`).
    ///
    /// Sufficient only: `1, −0.2, 1` is positive on `[0, 1]` but not certified:
    /// ```
    /// use strandfit::atph::{Bernstein, Sign};
    ///
    /// assert_eq!(Bernstein::new(&[1.0, 2.0, 3.0]).certified_sign(), Some(Sign::Positive));
    /// assert_eq!(Bernstein::new(&[-1.0, -0.1]).certified_sign(), Some(Sign::Negative));
    /// assert_eq!(Bernstein::new(&[1.0, -0.2, 1.0]).certified_sign(), None);
    /// ```
    pub fn certified_sign(&self) -> Option<Sign> {
        let c = self.coefficients();
        if c.iter().all(|&v| v > 0.0) {
            Some(Sign::Positive)
        } else if c.iter().all(|&v| v < 0.0) {
            Some(Sign::Negative)
        } else {
            None
        }
    }

    /// The exact sign behaviour on `[0, 1]`: the paper's test first, then
    /// de Casteljau subdivision where it is inconclusive. A piece whose
    /// coefficients share a strict sign has no root; a piece whose end
    /// values differ in sign (or vanish) has one; other pieces are halved.
    /// A root of even multiplicity (a touching zero) is found when the
    /// pieces shrink to `2⁻⁴⁰` without settling, and reported as `Vanishes`
    /// (the speed reaches zero to rounding).
    ///
    /// `1, −0.2, 1` is `1 − 2.4t + 2.4t²`, positive (minimum `0.4` at `½`);
    /// `1, −1, 1` is `(1 − 2t)²`, which touches zero:
    /// ```
    /// use strandfit::atph::{Bernstein, Sign};
    ///
    /// assert_eq!(Bernstein::new(&[1.0, -0.2, 1.0]).sign(), Sign::Positive);
    /// assert_eq!(Bernstein::new(&[1.0, -1.0, 1.0]).sign(), Sign::Vanishes);
    /// assert_eq!(Bernstein::new(&[-1.0, 1.5, -1.0]).sign(), Sign::Vanishes); // −1 + 5t − 5t²
    /// ```
    pub fn sign(&self) -> Sign {
        if let Some(s) = self.certified_sign() {
            return s;
        }
        let c = self.coefficients();
        if !c.iter().all(|v| v.is_finite()) {
            return Sign::Vanishes;
        }
        let first = c[0];
        if first == 0.0 {
            return Sign::Vanishes;
        }
        if piece_has_root(self.coef, self.degree, 0) {
            Sign::Vanishes
        } else if first > 0.0 {
            Sign::Positive
        } else {
            Sign::Negative
        }
    }

    /// The sign changes of `ρ` in `(0, 1)`, ascending, by bisection to
    /// rounding inside a grid of `16(n+1)` cells (for the arc length
    /// `∫|ρ|`); touching roots are omitted (they do not change the sign, so
    /// `∫|ρ|` is the same).
    ///
    /// `(t − ¼)(t − ¾) = t² − t + 3/16` is Bernstein `3/16, −5/16, 3/16`:
    /// ```
    /// use strandfit::atph::Bernstein;
    ///
    /// let r = Bernstein::new(&[3.0 / 16.0, -5.0 / 16.0, 3.0 / 16.0]).roots();
    /// assert_eq!(r.len(), 2);
    /// assert!((r[0] - 0.25).abs() < 1e-15 && (r[1] - 0.75).abs() < 1e-15);
    /// ```
    pub fn roots(&self) -> Vec<f64> {
        let mut roots = Vec::new();
        let n = 256usize.min(16 * (self.degree + 1));
        let mut prev = self.eval(0.0);
        for i in 1..=n {
            let t = i as f64 / n as f64;
            let v = self.eval(t);
            if prev * v < 0.0 {
                let (mut lo, mut hi) = ((i - 1) as f64 / n as f64, t);
                let mut flo = prev;
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    let fm = self.eval(mid);
                    if fm * flo <= 0.0 {
                        hi = mid;
                    } else {
                        lo = mid;
                        flo = fm;
                    }
                }
                roots.push(0.5 * (lo + hi));
            } else if v == 0.0 && i < n {
                roots.push(t);
            }
            prev = v;
        }
        // Two sign changes inside one grid cell (a near-double root) are
        // missed; |ρ| then differs from ±ρ only between them, by at most the
        // cell width times the tiny |ρ| there (second order in the gap).
        roots
    }
}

fn piece_has_root(c: [f64; 4], n: usize, depth: u32) -> bool {
    let all_pos = c[..=n].iter().all(|&v| v > 0.0);
    let all_neg = c[..=n].iter().all(|&v| v < 0.0);
    if all_pos || all_neg {
        return false;
    }
    if c[0] * c[n] <= 0.0 || depth >= 40 {
        return true;
    }
    let (l, r) = split_half(c, n);
    piece_has_root(l, n, depth + 1) || piece_has_root(r, n, depth + 1)
}

/// de Casteljau at `t = ½`: the two halves' coefficients.
fn split_half(c: [f64; 4], n: usize) -> ([f64; 4], [f64; 4]) {
    let mut l = [0.0; 4];
    let mut r = [0.0; 4];
    let mut b = c;
    l[0] = b[0];
    r[n] = b[n];
    for k in 1..=n {
        for j in 0..=n - k {
            b[j] = 0.5 * (b[j] + b[j + 1]);
        }
        l[k] = b[0];
        r[n - k] = b[n - k];
    }
    (l, r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn forms_agree() {
        let p = Bernstein::new(&[0.3, -1.2, 2.0, 0.7]);
        let c = p.monomial();
        for i in 0..=20 {
            let t = i as f64 / 20.0;
            let mono = c[0] + t * (c[1] + t * (c[2] + t * c[3]));
            assert!((p.eval(t) - mono).abs() < 1e-14);
        }
        // ∫ and derivative against finite differences / the monomials.
        assert!((p.integral() - (c[0] + c[1] / 2.0 + c[2] / 3.0 + c[3] / 4.0)).abs() < 1e-15);
        assert!((p.integral_to(1.0) - p.integral()).abs() < 1e-15);
        let h = 1e-6;
        let fd = (p.eval(0.4 + h) - p.eval(0.4 - h)) / (2.0 * h);
        assert!((p.derivative(0.4) - fd).abs() < 1e-8);
    }

    #[test]
    fn the_papers_test_is_sufficient_not_necessary() {
        // All positive: certified.
        assert_eq!(
            Bernstein::new(&[1.0, 0.2, 3.0]).certified_sign(),
            Some(Sign::Positive)
        );
        // Mixed signs, yet ρ(t) = 1 − 2·0.1·2t(1−t)… > 0: the exact test says so.
        let p = Bernstein::new(&[1.0, -0.1, 1.0]);
        assert_eq!(p.certified_sign(), None);
        assert_eq!(p.sign(), Sign::Positive);
        // A real root.
        assert_eq!(Bernstein::new(&[1.0, -2.0, 1.0]).sign(), Sign::Vanishes);
        // A touching (double) root: (2t − 1)² = [1, −1, 1].
        assert_eq!(Bernstein::new(&[1.0, -1.0, 1.0]).sign(), Sign::Vanishes);
        assert_eq!(
            Bernstein::new(&[-2.0, -0.5, -1.0, -3.0]).sign(),
            Sign::Negative
        );
        assert_eq!(Bernstein::new(&[0.0, 1.0]).sign(), Sign::Vanishes);
    }

    proptest! {
        #[test]
        fn sign_agrees_with_dense_sampling(c in proptest::collection::vec(-2.0f64..2.0, 1..=4)) {
            let p = Bernstein::new(&c);
            let samples: Vec<f64> = (0..=4000).map(|i| p.eval(i as f64 / 4000.0)).collect();
            let min = samples.iter().cloned().fold(f64::INFINITY, f64::min);
            let max = samples.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            match p.sign() {
                Sign::Positive => prop_assert!(min > 0.0),
                Sign::Negative => prop_assert!(max < 0.0),
                // A sign change, or a minimum of |ρ| tiny against its size.
                Sign::Vanishes => prop_assert!(
                    min <= 0.0 && max >= 0.0
                        || samples.iter().map(|v| v.abs()).fold(f64::INFINITY, f64::min)
                            < 1e-6 * max.abs().max(min.abs())
                ),
            }
            if let Some(s) = p.certified_sign() {
                prop_assert_eq!(s, p.sign());
            }
            // Roots: ρ vanishes there, and ∫|ρ| from them matches quadrature.
            for r in p.roots() {
                prop_assert!(p.eval(r).abs() < 1e-9);
            }
        }
    }
}
