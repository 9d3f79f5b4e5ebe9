//! 2D drawing primitives on an [`Image`]: anti-aliased lines and polylines of any width, filled
//! discs and rectangle outlines. Plots are drawn with these and the bitmap font.
//!
//! Coverage is computed analytically per pixel (distance from the pixel centre to the shape,
//! with a one-pixel ramp) and blended in linear light. A polyline is accumulated into a coverage
//! mask first, taking the maximum over its segments, so that joints are not painted twice and do
//! not show darker dots with translucent colours.

use glam::DVec2;

use crate::image::Image;
use crate::shading::Rgb;

/// Distance from `p` to the segment `a`–`b`.
fn segment_distance(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 { ((p - a).dot(ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    (p - (a + ab * t)).length()
}

/// Draws a polyline through `points` (pixel coordinates, y down; (0.5, 0.5) is the centre of the
/// top-left pixel) `width` pixels wide in the linear colour `color` at opacity `alpha`. Points
/// that are not finite are skipped; one point draws a dot.
pub fn draw_polyline(image: &mut Image, points: &[(f64, f64)], width: f64, color: Rgb, alpha: f32) {
    let points: Vec<DVec2> = points.iter().map(|&(x, y)| DVec2::new(x, y)).filter(|p| p.is_finite()).collect();
    let Some(&first) = points.first() else { return };
    let half = if width.is_finite() { 0.5 * width.max(0.0) } else { 0.5 };
    let reach = half + 1.0;
    // Mask over the polyline's bounding box, clipped to the image.
    let (mut lo, mut hi) = (first, first);
    for &p in &points {
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let x0 = ((lo.x - reach).floor().max(0.0)) as i64;
    let y0 = ((lo.y - reach).floor().max(0.0)) as i64;
    let x1 = ((hi.x + reach).ceil().min(f64::from(image.width))) as i64;
    let y1 = ((hi.y + reach).ceil().min(f64::from(image.height))) as i64;
    if x0 >= x1 || y0 >= y1 {
        return;
    }
    let mw = (x1 - x0) as usize;
    let mut mask = vec![0.0f32; mw * (y1 - y0) as usize];
    let segments: Vec<(DVec2, DVec2)> =
        if points.len() == 1 { vec![(first, first)] } else { points.windows(2).map(|w| (w[0], w[1])).collect() };
    for (a, b) in segments {
        let sx0 = ((a.x.min(b.x) - reach).floor() as i64).max(x0);
        let sy0 = ((a.y.min(b.y) - reach).floor() as i64).max(y0);
        let sx1 = ((a.x.max(b.x) + reach).ceil() as i64).min(x1);
        let sy1 = ((a.y.max(b.y) + reach).ceil() as i64).min(y1);
        for y in sy0..sy1 {
            for x in sx0..sx1 {
                let d = segment_distance(DVec2::new(x as f64 + 0.5, y as f64 + 0.5), a, b);
                let coverage = (half + 0.5 - d).clamp(0.0, 1.0) as f32;
                let m = &mut mask[(y - y0) as usize * mw + (x - x0) as usize];
                *m = m.max(coverage);
            }
        }
    }
    for (k, &m) in mask.iter().enumerate() {
        if m > 0.0 {
            image.blend_pixel(x0 + (k % mw) as i64, y0 + (k / mw) as i64, color, alpha * m);
        }
    }
}

/// Draws the segment from `a` to `b` (see [`draw_polyline`] for coordinates).
pub fn draw_line(image: &mut Image, a: (f64, f64), b: (f64, f64), width: f64, color: Rgb, alpha: f32) {
    draw_polyline(image, &[a, b], width, color, alpha);
}

/// Fills the disc of the given centre and radius (anti-aliased).
pub fn fill_circle(image: &mut Image, center: (f64, f64), radius: f64, color: Rgb, alpha: f32) {
    draw_polyline(image, &[center], 2.0 * radius, color, alpha);
}

/// Outlines the rectangle with top-left corner (x, y) and size `w` × `h` with crisp 1-pixel
/// lines just inside it.
pub fn stroke_rect(image: &mut Image, x: i64, y: i64, w: u32, h: u32, color: Rgb, alpha: f32) {
    if w == 0 || h == 0 {
        return;
    }
    image.blend_rect(x, y, w, 1, color, alpha);
    image.blend_rect(x, y + i64::from(h) - 1, w, 1, color, alpha);
    if h > 2 {
        image.blend_rect(x, y + 1, 1, h - 2, color, alpha);
        image.blend_rect(x + i64::from(w) - 1, y + 1, 1, h - 2, color, alpha);
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report
mod tests {
    use super::*;

    #[test]
    fn a_horizontal_line_covers_its_width() {
        let mut image = Image::new(20, 10, [255, 255, 255, 255]);
        draw_line(&mut image, (2.0, 5.0), (18.0, 5.0), 2.0, [0.0; 3], 1.0);
        // Rows 4 and 5 (centres 4.5 and 5.5) are fully inside the 2-pixel line.
        assert_eq!(image.pixel(10, 4), Some([0, 0, 0, 255]));
        assert_eq!(image.pixel(10, 5), Some([0, 0, 0, 255]));
        assert_eq!(image.pixel(10, 2), Some([255, 255, 255, 255]));
        assert_eq!(image.pixel(10, 7), Some([255, 255, 255, 255]));
    }

    #[test]
    fn joints_are_not_painted_twice() {
        let mut once = Image::new(30, 30, [255, 255, 255, 255]);
        draw_polyline(&mut once, &[(5.0, 15.0), (15.0, 15.0), (25.0, 15.0)], 3.0, [0.0; 3], 0.5);
        let joint = once.pixel(15, 15).unwrap();
        let middle = once.pixel(10, 15).unwrap();
        assert_eq!(joint, middle);
    }

    #[test]
    fn degenerate_input_does_not_panic() {
        let mut image = Image::new(10, 10, [0; 4]);
        draw_polyline(&mut image, &[], 1.0, [1.0; 3], 1.0);
        draw_polyline(&mut image, &[(f64::NAN, 1.0), (1e300, -1e300)], f64::NAN, [1.0; 3], 1.0);
        draw_polyline(&mut image, &[(-50.0, -50.0), (-40.0, -40.0)], 1.0, [1.0; 3], 1.0);
        fill_circle(&mut image, (5.0, 5.0), 2.0, [1.0; 3], 1.0);
        assert_eq!(image.pixel(5, 5).unwrap()[3], 255);
        stroke_rect(&mut image, 0, 0, 0, 5, [1.0; 3], 1.0);
    }
}
