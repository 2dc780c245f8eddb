//! The standard normal distribution's tails, for the noise model's hot-pixel statistics and
//! the gap workflow's outlier thresholds.

/// Upper tail of the standard normal distribution, `Q(x) = erfc(x / sqrt 2) / 2`, with erfc from
/// its Chebyshev fit (Numerical Recipes in C, 2nd ed., section 6.2, `erfcc`: fractional error
/// below 1.2e-7 everywhere, so the far tail keeps its relative accuracy).
#[must_use]
pub fn normal_tail(x: f64) -> f64 {
    let z = (x / std::f64::consts::SQRT_2).abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98 + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let erfc = t * (-z * z + poly).exp();
    0.5 * if x >= 0.0 { erfc } else { 2.0 - erfc }
}

/// Inverse of [`normal_tail`]: the `z` with `Q(z) = p` (bisection; `0 < p < 1/2`).
#[must_use]
pub fn normal_tail_inverse(p: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 40.0f64);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if normal_tail(mid) > p { lo = mid } else { hi = mid }
    }
    0.5 * (lo + hi)
}
