//! Small weighted linear least-squares fits by the normal equations, for the few-parameter
//! fits of calibration and the effect searches (two to five unknowns, so a dense solve with
//! partial pivoting is all they need).

/// A fitted linear model.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// One coefficient per basis function.
    pub coefficients: Vec<f64>,
    /// Weighted sum of squared residuals at the solution.
    pub chi2: f64,
}

/// Fits `value ~ sum_j c_j basis_j` over `rows` of `(basis, value, weight)`, minimising
/// `sum weight (value - fitted)^2`; `None` when the system is singular or any row's basis is
/// not `terms` long.
#[must_use]
pub fn fit<'a>(rows: impl IntoIterator<Item = (&'a [f64], f64, f64)> + Clone, terms: usize) -> Option<Fit> {
    let mut a = vec![vec![0.0; terms + 1]; terms];
    for (basis, value, weight) in rows.clone() {
        if basis.len() != terms {
            return None;
        }
        for r in 0..terms {
            for c in 0..terms {
                a[r][c] += weight * basis[r] * basis[c];
            }
            a[r][terms] += weight * basis[r] * value;
        }
    }
    let coefficients = solve(a)?;
    let chi2 = rows
        .into_iter()
        .map(|(basis, value, weight)| {
            let fitted: f64 = basis.iter().zip(&coefficients).map(|(b, c)| b * c).sum();
            weight * (value - fitted) * (value - fitted)
        })
        .sum();
    Some(Fit { coefficients, chi2 })
}

/// Gaussian elimination with partial pivoting of an augmented `N x (N + 1)` system.
#[must_use]
pub fn solve(mut a: Vec<Vec<f64>>) -> Option<Vec<f64>> {
    let n = a.len();
    if a.iter().any(|row| row.len() != n + 1) {
        return None;
    }
    for col in 0..n {
        let pivot = (col..n).max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs()))?;
        if a[pivot][col].abs() < 1e-300 {
            return None;
        }
        a.swap(col, pivot);
        let pivot_row = a[col].clone();
        for row in a.iter_mut().skip(col + 1) {
            let f = row[col] / pivot_row[col];
            for (v, p) in row.iter_mut().zip(pivot_row.iter()).skip(col) {
                *v -= f * p;
            }
        }
    }
    let mut x = vec![0.0; n];
    for row in (0..n).rev() {
        let s: f64 = (row + 1..n).map(|c| a[row][c] * x[c]).sum();
        x[row] = (a[row][n] - s) / a[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_polynomial_and_its_residual() {
        let xs: Vec<f64> = (0..20).map(|i| f64::from(i) / 19.0).collect();
        let basis: Vec<[f64; 3]> = xs.iter().map(|&x| [x, x * x, x * x * x]).collect();
        let exact: Vec<f64> = xs.iter().map(|&x| 2.0 * x - 0.5 * x * x + 0.25 * x * x * x).collect();
        let rows = basis.iter().zip(&exact).map(|(b, &v)| (&b[..], v, 1.0));
        let f = fit(rows, 3).unwrap();
        for (c, want) in f.coefficients.iter().zip([2.0, -0.5, 0.25]) {
            assert!((c - want).abs() < 1e-9, "{c} vs {want}");
        }
        assert!(f.chi2 < 1e-18);
        // A line through the cubic leaves a residual, weighted.
        let rows = basis.iter().zip(&exact).map(|(b, &v)| (&b[..1], v, 4.0));
        assert!(fit(rows, 1).unwrap().chi2 > 1e-4);
        assert!(solve(vec![vec![1.0, 2.0, 3.0], vec![2.0, 4.0, 6.0]]).is_none(), "singular");
    }
}
