//! A tiny line chart drawn by hand on an RGB buffer (axes, grid, polylines, a legend in the
//! font8x8 glyphs the plan picture uses): enough for a training curve without a plotting
//! library and its font stack. Output is a pure function of the data, so PNG bytes repeat.

use image::{Rgb, RgbImage};

/// One polyline.
#[derive(Clone, Debug)]
pub struct Series {
    pub label: String,
    pub color: [u8; 3],
    /// `(x, y)` points, drawn in order; non-finite points are skipped.
    pub points: Vec<(f64, f64)>,
}

const MARGIN_LEFT: i32 = 64;
const MARGIN_RIGHT: i32 = 16;
const MARGIN_TOP: i32 = 28;
const MARGIN_BOTTOM: i32 = 36;
const AXIS: Rgb<u8> = Rgb([40, 40, 40]);
const GRID: Rgb<u8> = Rgb([225, 225, 225]);

fn put(img: &mut RgbImage, x: i32, y: i32, c: Rgb<u8>) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, c);
    }
}

/// A line `thick` pixels wide (Bresenham, with a square brush).
fn line(img: &mut RgbImage, (x0, y0): (i32, i32), (x1, y1): (i32, i32), c: Rgb<u8>, thick: i32) {
    let (dx, dy) = ((x1 - x0).abs(), -(y1 - y0).abs());
    let (sx, sy) = (if x0 < x1 { 1 } else { -1 }, if y0 < y1 { 1 } else { -1 });
    let (mut x, mut y, mut err) = (x0, y0, dx + dy);
    loop {
        for oy in 0..thick {
            for ox in 0..thick {
                put(img, x + ox - thick / 2, y + oy - thick / 2, c);
            }
        }
        if x == x1 && y == y1 {
            break;
        }
        let e2 = 2 * err;
        if e2 >= dy {
            err += dy;
            x += sx;
        }
        if e2 <= dx {
            err += dx;
            y += sy;
        }
    }
}

/// `text` with its top-left corner at (x, y).
fn text(img: &mut RgbImage, x: i32, y: i32, s: &str, c: Rgb<u8>) {
    use font8x8::UnicodeFonts as _;
    for (i, ch) in s.chars().enumerate() {
        let Some(glyph) = font8x8::BASIC_FONTS.get(ch) else { continue };
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..8 {
                if bits & (1 << col) != 0 {
                    put(img, x + i as i32 * 8 + col, y + row as i32, c);
                }
            }
        }
    }
}

/// A tick label: few digits, no trailing noise.
fn tick_label(v: f64) -> String {
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".to_string() } else { s.to_string() }
}

/// Draws `series` on a `width` x `height` white canvas with a title, axes from the data's
/// bounds (y padded by 5 %), four grid lines per axis and a legend.
#[must_use]
pub fn line_chart(title: &str, series: &[Series], width: u32, height: u32) -> RgbImage {
    let mut img = RgbImage::from_pixel(width, height, Rgb([255, 255, 255]));
    let finite = || series.iter().flat_map(|s| &s.points).filter(|(x, y)| x.is_finite() && y.is_finite());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for &(x, y) in finite() {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    if !x0.is_finite() {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    // Whole-number x data (generations, evaluations): widen the axis to a multiple of the four
    // grid steps so every tick label is a whole number.
    if finite().all(|(x, _)| x.fract() == 0.0) {
        x1 = x0 + ((x1 - x0) / 4.0).ceil() * 4.0;
    }
    let pad = if y1 > y0 { 0.05 * (y1 - y0) } else { 0.5 };
    (y0, y1) = (y0 - pad, y1 + pad);
    let (left, right) = (MARGIN_LEFT, width as i32 - MARGIN_RIGHT);
    let (top, bottom) = (MARGIN_TOP, height as i32 - MARGIN_BOTTOM);
    let px = |x: f64| left + ((x - x0) / (x1 - x0) * f64::from(right - left)).round() as i32;
    let py = |y: f64| bottom - ((y - y0) / (y1 - y0) * f64::from(bottom - top)).round() as i32;

    for k in 0..=4 {
        let t = f64::from(k) / 4.0;
        let (gx, gy) = (px(x0 + t * (x1 - x0)), py(y0 + t * (y1 - y0)));
        line(&mut img, (gx, top), (gx, bottom), GRID, 1);
        line(&mut img, (left, gy), (right, gy), GRID, 1);
        let xl = tick_label(x0 + t * (x1 - x0));
        text(&mut img, gx - 4 * xl.len() as i32, bottom + 6, &xl, AXIS);
        let yl = tick_label(y0 + t * (y1 - y0));
        text(&mut img, left - 6 - 8 * yl.len() as i32, gy - 4, &yl, AXIS);
    }
    line(&mut img, (left, bottom), (right, bottom), AXIS, 1);
    line(&mut img, (left, top), (left, bottom), AXIS, 1);
    text(&mut img, left, 8, title, AXIS);

    for s in series {
        let c = Rgb(s.color);
        let pts: Vec<(i32, i32)> =
            s.points.iter().filter(|(x, y)| x.is_finite() && y.is_finite()).map(|&(x, y)| (px(x), py(y))).collect();
        for w in pts.windows(2) {
            line(&mut img, w[0], w[1], c, 2);
        }
        if let [p] = pts.as_slice() {
            line(&mut img, *p, *p, c, 4);
        }
    }
    // Legend, bottom right inside the plot, one row per series.
    for (i, s) in series.iter().enumerate() {
        let y = bottom - 14 * (series.len() - i) as i32;
        let x = right - 8 * s.label.len() as i32 - 30;
        line(&mut img, (x, y + 4), (x + 18, y + 4), Rgb(s.color), 3);
        text(&mut img, x + 24, y, &s.label, AXIS);
    }
    img
}

/// PNG bytes of `img` (deterministic for the same pixels).
#[must_use]
pub fn to_png(img: &RgbImage) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    // Encoding an in-memory RGB buffer into a Vec cannot fail.
    let _ = img.write_to(&mut out, image::ImageFormat::Png);
    out.into_inner()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polylines_are_drawn_in_their_colour_and_repeat() {
        let s = vec![
            Series { label: "best".into(), color: [200, 0, 0], points: vec![(0.0, 0.0), (1.0, 1.0), (2.0, 1.5)] },
            Series { label: "mean".into(), color: [0, 0, 200], points: vec![(0.0, 0.0), (2.0, 0.5)] },
        ];
        let img = line_chart("curve", &s, 320, 200);
        let count = |c: [u8; 3]| img.pixels().filter(|p| p.0 == c).count();
        assert!(count([200, 0, 0]) > 100 && count([0, 0, 200]) > 100);
        // The polylines start at the left edge of the plot area (x = 0 of the data).
        let leftmost = img.enumerate_pixels().filter(|(_, _, p)| p.0 == [200, 0, 0]).map(|(x, _, _)| x).min();
        assert!(
            leftmost.is_some_and(|x| (MARGIN_LEFT as u32 - 1..=MARGIN_LEFT as u32 + 1).contains(&x)),
            "{leftmost:?}"
        );
        assert_eq!(to_png(&img), to_png(&line_chart("curve", &s, 320, 200)));
        // An empty chart still draws.
        let _ = line_chart("empty", &[], 100, 80);
    }
}
