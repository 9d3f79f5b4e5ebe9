//! 8-bit sRGB images with straight alpha: pixel access, blending in linear light, rectangles,
//! composition into rows, columns and grids, and PNG encoding.
//!
//! The encoder returns bytes rather than writing a file so that the caller can write it
//! atomically (temporary file + rename) and decide where it goes.

use crate::RenderError;
use crate::shading::{Rgb, linear_to_srgb8, srgb_to_linear};

/// Largest width or height accepted for an image, so that sizes can never overflow and a typo
/// in a command line does not try to allocate terabytes.
pub const MAX_IMAGE_SIDE: u32 = 16_384;

/// An RGBA picture, 8 bits per channel, sRGB-encoded colour with straight (not premultiplied)
/// alpha, rows from top to bottom.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height * 4` bytes: R, G, B, A for each pixel, row by row.
    pub rgba: Vec<u8>,
}

/// The sRGB → linear table for all 256 byte values; blending converts through it.
fn srgb_table() -> &'static [f32; 256] {
    static TABLE: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0)))
}

/// The linear value of one sRGB byte.
#[inline]
pub(crate) fn byte_to_linear(b: u8) -> f32 {
    srgb_table()[usize::from(b)]
}

/// An opaque sRGB byte colour from a linear one.
pub fn rgba8(color: Rgb) -> [u8; 4] {
    [linear_to_srgb8(color[0]), linear_to_srgb8(color[1]), linear_to_srgb8(color[2]), 255]
}

impl Image {
    /// A `width` × `height` image filled with `fill` (sRGB bytes + alpha). Sizes above
    /// [`MAX_IMAGE_SIDE`] are clamped to it.
    pub fn new(width: u32, height: u32, fill: [u8; 4]) -> Self {
        let (width, height) = (width.min(MAX_IMAGE_SIDE), height.min(MAX_IMAGE_SIDE));
        let n = width as usize * height as usize;
        let mut rgba = Vec::with_capacity(4 * n);
        for _ in 0..n {
            rgba.extend_from_slice(&fill);
        }
        Self { width, height, rgba }
    }

    /// Wraps existing RGBA bytes, checking that there are exactly `width * height * 4` of them.
    pub fn from_rgba(width: u32, height: u32, rgba: Vec<u8>) -> Result<Self, RenderError> {
        let expected = 4 * width as usize * height as usize;
        if width > MAX_IMAGE_SIDE || height > MAX_IMAGE_SIDE {
            return Err(RenderError::InvalidImageSize { width, height });
        }
        if rgba.len() != expected {
            return Err(RenderError::BufferSize { width, height, expected, actual: rgba.len() });
        }
        Ok(Self { width, height, rgba })
    }

    #[inline]
    fn offset(&self, x: i64, y: i64) -> Option<usize> {
        if x < 0 || y < 0 || x >= i64::from(self.width) || y >= i64::from(self.height) {
            return None;
        }
        Some(4 * (y as usize * self.width as usize + x as usize))
    }

    /// The pixel at (x, y), or `None` outside the image.
    pub fn pixel(&self, x: u32, y: u32) -> Option<[u8; 4]> {
        let o = self.offset(i64::from(x), i64::from(y))?;
        let p = self.rgba.get(o..o + 4)?;
        Some([p[0], p[1], p[2], p[3]])
    }

    /// Sets the pixel at (x, y); does nothing outside the image.
    pub fn set_pixel(&mut self, x: u32, y: u32, rgba: [u8; 4]) {
        if let Some(o) = self.offset(i64::from(x), i64::from(y))
            && let Some(p) = self.rgba.get_mut(o..o + 4)
        {
            p.copy_from_slice(&rgba);
        }
    }

    /// Paints the linear colour `color` over the pixel at (x, y) with opacity `alpha` in
    /// `[0, 1]`, blending in linear light ("over" compositing). Outside the image it does nothing.
    pub fn blend_pixel(&mut self, x: i64, y: i64, color: Rgb, alpha: f32) {
        let alpha = if alpha.is_nan() { 0.0 } else { alpha.clamp(0.0, 1.0) };
        if alpha <= 0.0 {
            return;
        }
        let Some(o) = self.offset(x, y) else { return };
        let Some(p) = self.rgba.get_mut(o..o + 4) else { return };
        let dst_a = f32::from(p[3]) / 255.0;
        let out_a = alpha + dst_a * (1.0 - alpha);
        if out_a <= 0.0 {
            return;
        }
        for c in 0..3 {
            let dst = byte_to_linear(p[c]);
            let mixed = (color[c] * alpha + dst * dst_a * (1.0 - alpha)) / out_a;
            p[c] = linear_to_srgb8(mixed);
        }
        p[3] = (out_a * 255.0 + 0.5) as u8;
    }

    /// Fills the rectangle with top-left corner (x, y) and size `w` × `h` (clipped to the image)
    /// with `rgba`, replacing what was there.
    pub fn fill_rect(&mut self, x: i64, y: i64, w: u32, h: u32, rgba: [u8; 4]) {
        let x0 = x.max(0);
        let y0 = y.max(0);
        let x1 = (x + i64::from(w)).min(i64::from(self.width));
        let y1 = (y + i64::from(h)).min(i64::from(self.height));
        for yy in y0..y1 {
            for xx in x0..x1 {
                if let Some(o) = self.offset(xx, yy)
                    && let Some(p) = self.rgba.get_mut(o..o + 4)
                {
                    p.copy_from_slice(&rgba);
                }
            }
        }
    }

    /// Blends the linear colour `color` with opacity `alpha` over a rectangle (clipped).
    pub fn blend_rect(&mut self, x: i64, y: i64, w: u32, h: u32, color: Rgb, alpha: f32) {
        let x1 = (x + i64::from(w)).min(i64::from(self.width));
        let y1 = (y + i64::from(h)).min(i64::from(self.height));
        for yy in y.max(0)..y1 {
            for xx in x.max(0)..x1 {
                self.blend_pixel(xx, yy, color, alpha);
            }
        }
    }

    /// Copies `src` into this image with its top-left corner at (x, y), replacing pixels
    /// (clipped to the image).
    pub fn blit(&mut self, src: &Image, x: i64, y: i64) {
        for sy in 0..src.height {
            let ty = y + i64::from(sy);
            for sx in 0..src.width {
                let tx = x + i64::from(sx);
                if let (Some(to), Some(p)) = (self.offset(tx, ty), src.pixel(sx, sy))
                    && let Some(dst) = self.rgba.get_mut(to..to + 4)
                {
                    dst.copy_from_slice(&p);
                }
            }
        }
    }
}

/// Places `images` side by side, left to right, `gap` pixels apart, each centred vertically,
/// on a `background` canvas. No image gives a 0 × 0 image.
pub fn hstack(images: &[&Image], gap: u32, background: [u8; 4]) -> Image {
    let width =
        images.iter().map(|i| u64::from(i.width)).sum::<u64>() + u64::from(gap) * images.len().saturating_sub(1) as u64;
    let height = images.iter().map(|i| i.height).max().unwrap_or(0);
    let mut out = Image::new(width.min(u64::from(MAX_IMAGE_SIDE)) as u32, height, background);
    let mut x = 0i64;
    for image in images {
        out.blit(image, x, i64::from((height - image.height) / 2));
        x += i64::from(image.width) + i64::from(gap);
    }
    out
}

/// Stacks `images` top to bottom, `gap` pixels apart, each centred horizontally, on a
/// `background` canvas. No image gives a 0 × 0 image.
pub fn vstack(images: &[&Image], gap: u32, background: [u8; 4]) -> Image {
    let height = images.iter().map(|i| u64::from(i.height)).sum::<u64>()
        + u64::from(gap) * images.len().saturating_sub(1) as u64;
    let width = images.iter().map(|i| i.width).max().unwrap_or(0);
    let mut out = Image::new(width, height.min(u64::from(MAX_IMAGE_SIDE)) as u32, background);
    let mut y = 0i64;
    for image in images {
        out.blit(image, i64::from((width - image.width) / 2), y);
        y += i64::from(image.height) + i64::from(gap);
    }
    out
}

/// Arranges `images` in rows of `columns` (at least 1), each cell as large as the largest image,
/// images centred in their cells, `gap` pixels between cells.
pub fn grid(images: &[&Image], columns: usize, gap: u32, background: [u8; 4]) -> Image {
    let columns = columns.max(1);
    let cell_w = images.iter().map(|i| i.width).max().unwrap_or(0);
    let cell_h = images.iter().map(|i| i.height).max().unwrap_or(0);
    let rows = images.len().div_ceil(columns);
    let cols = columns.min(images.len());
    let side = |cells: usize, cell: u32| {
        (cells as u64 * u64::from(cell) + u64::from(gap) * cells.saturating_sub(1) as u64)
            .min(u64::from(MAX_IMAGE_SIDE)) as u32
    };
    let mut out = Image::new(side(cols, cell_w), side(rows, cell_h), background);
    for (k, image) in images.iter().enumerate() {
        let (col, row) = ((k % columns) as i64, (k / columns) as i64);
        let x = col * (i64::from(cell_w) + i64::from(gap)) + i64::from((cell_w - image.width) / 2);
        let y = row * (i64::from(cell_h) + i64::from(gap)) + i64::from((cell_h - image.height) / 2);
        out.blit(image, x, y);
    }
    out
}

/// Encodes the image as an 8-bit RGBA PNG tagged as sRGB and returns the file's bytes.
pub fn encode_png(image: &Image) -> Result<Vec<u8>, RenderError> {
    let expected = 4 * image.width as usize * image.height as usize;
    if image.rgba.len() != expected {
        return Err(RenderError::BufferSize {
            width: image.width,
            height: image.height,
            expected,
            actual: image.rgba.len(),
        });
    }
    if image.width == 0 || image.height == 0 {
        return Err(RenderError::InvalidImageSize { width: image.width, height: image.height });
    }
    let mut bytes = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut bytes, image.width, image.height);
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = encoder.write_header()?;
        writer.write_image_data(&image.rgba)?;
        writer.finish()?;
    }
    Ok(bytes)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report
mod tests {
    use super::*;

    #[test]
    fn blending_is_done_in_linear_light() {
        let mut image = Image::new(1, 1, [0, 0, 0, 255]);
        image.blend_pixel(0, 0, [1.0, 1.0, 1.0], 0.5);
        // Half white over black is linear 0.5, i.e. sRGB 188, not 128.
        assert_eq!(image.pixel(0, 0), Some([188, 188, 188, 255]));
        let mut clear = Image::new(1, 1, [0, 0, 0, 0]);
        clear.blend_pixel(0, 0, [1.0, 0.0, 0.0], 0.5);
        assert_eq!(clear.pixel(0, 0), Some([255, 0, 0, 128]));
        // Out of range coordinates and NaN alpha are ignored.
        image.blend_pixel(-1, 5, [1.0; 3], 1.0);
        image.blend_pixel(0, 0, [0.0; 3], f32::NAN);
        assert_eq!(image.pixel(0, 0), Some([188, 188, 188, 255]));
    }

    #[test]
    fn stacks_and_grids_have_the_expected_sizes() {
        let a = Image::new(10, 4, [255, 0, 0, 255]);
        let b = Image::new(6, 8, [0, 255, 0, 255]);
        let bg = [0, 0, 0, 255];
        let h = hstack(&[&a, &b], 2, bg);
        assert_eq!((h.width, h.height), (18, 8));
        assert_eq!(h.pixel(0, 2), Some([255, 0, 0, 255]));
        assert_eq!(h.pixel(0, 0), Some(bg));
        assert_eq!(h.pixel(11, 0), Some(bg));
        assert_eq!(h.pixel(12, 0), Some([0, 255, 0, 255]));
        let v = vstack(&[&a, &b], 1, bg);
        assert_eq!((v.width, v.height), (10, 13));
        assert_eq!(v.pixel(2, 5), Some([0, 255, 0, 255]));
        let g = grid(&[&a, &b, &a], 2, 0, bg);
        assert_eq!((g.width, g.height), (20, 16));
        assert_eq!(hstack(&[], 3, bg).rgba.len(), 0);
    }

    #[test]
    fn inconsistent_buffers_are_errors() {
        assert!(Image::from_rgba(2, 2, vec![0; 15]).is_err());
        let bad = Image { width: 3, height: 1, rgba: vec![0; 4] };
        assert!(matches!(encode_png(&bad), Err(RenderError::BufferSize { .. })));
        assert!(encode_png(&Image::new(0, 0, [0; 4])).is_err());
    }
}
