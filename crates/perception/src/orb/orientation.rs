//! Keypoint orientation by the intensity centroid (Rosin), as OpenCV's ORB (`ICAngles`).

use super::pyramid::Level;

/// Half-widths of the rows v = 0..=15 of the radius-15 circular patch (OpenCV's `umax` for
/// patch size 31, made symmetric in x and y).
pub const UMAX_31: [i32; 16] = [15, 15, 15, 15, 14, 14, 14, 13, 13, 12, 11, 10, 9, 8, 6, 3];

// OpenCV's fastAtan2 polynomial coefficients (core/mathfuncs_core), already in degrees. The
// literals are OpenCV's own digits; rounding them to f32 is what OpenCV does too.
const RAD2DEG: f32 = (180.0 / std::f64::consts::PI) as f32;
#[allow(clippy::excessive_precision)]
const ATAN_P1: f32 = 0.999_787_841_279_480_7_f32 * RAD2DEG;
#[allow(clippy::excessive_precision)]
const ATAN_P3: f32 = -0.325_808_397_464_097_5_f32 * RAD2DEG;
#[allow(clippy::excessive_precision)]
const ATAN_P5: f32 = 0.155_578_651_846_328_1_f32 * RAD2DEG;
#[allow(clippy::excessive_precision)]
const ATAN_P7: f32 = -0.044_326_555_547_921_28_f32 * RAD2DEG;

/// OpenCV's `fastAtan2(y, x)`: degrees in [0, 360), about 0.3 degree accurate, in f32 with
/// OpenCV's operation order so that the descriptor rotation matches bit for bit.
#[must_use]
pub fn fast_atan2_deg(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let eps = f64::EPSILON as f32;
    let mut a = if ax >= ay {
        let c = ay / (ax + eps);
        let c2 = c * c;
        (((ATAN_P7 * c2 + ATAN_P5) * c2 + ATAN_P3) * c2 + ATAN_P1) * c
    } else {
        let c = ax / (ay + eps);
        let c2 = c * c;
        90.0 - (((ATAN_P7 * c2 + ATAN_P5) * c2 + ATAN_P3) * c2 + ATAN_P1) * c
    };
    if x < 0.0 {
        a = 180.0 - a;
    }
    if y < 0.0 {
        a = 360.0 - a;
    }
    a
}

/// Orientation (degrees) of the level pixel (x, y): the angle of the patch's intensity centroid,
/// m10 = sum u I, m01 = sum v I over the circular patch of radius 15 (v grows downwards).
#[must_use]
pub fn ic_angle(level: &Level, x: usize, y: usize) -> f32 {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2 (checked just above).
        return unsafe { ic_angle_avx2(level, x, y) };
    }
    ic_angle_impl(level, x, y)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn ic_angle_avx2(level: &Level, x: usize, y: usize) -> f32 {
    ic_angle_impl(level, x, y)
}

#[inline(always)]
fn ic_angle_impl(level: &Level, x: usize, y: usize) -> f32 {
    let d = &level.data;
    let s = level.stride;
    let c = level.index(x as isize, y as isize);
    let mut m10 = 0i32;
    let mut m01 = 0i32;
    for u in -15i32..=15 {
        m10 += u * i32::from(d[(c as isize + u as isize) as usize]);
    }
    for v in 1..=15usize {
        let w = UMAX_31[v] as isize;
        let below = &d[c + v * s - w as usize..=c + v * s + w as usize];
        let above = &d[c - v * s - w as usize..=c - v * s + w as usize];
        let mut v_sum = 0i32;
        for (i, (&p, &m)) in below.iter().zip(above).enumerate() {
            let u = i as i32 - w as i32;
            let (p, m) = (i32::from(p), i32::from(m));
            v_sum += p - m;
            m10 += u * (p + m);
        }
        m01 += v as i32 * v_sum;
    }
    fast_atan2_deg(m01 as f32, m10 as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_atan2_is_close_to_atan2_on_all_quadrants() {
        for i in 0..720 {
            let t = (i as f64 + 0.25) * 0.5_f64.to_radians();
            let (y, x) = (t.sin() as f32 * 100.0, t.cos() as f32 * 100.0);
            let got = f64::from(fast_atan2_deg(y, x));
            let want = t.to_degrees().rem_euclid(360.0);
            let diff = (got - want + 180.0).rem_euclid(360.0) - 180.0;
            assert!(diff.abs() < 0.02, "{want} vs {got}");
        }
    }
}
