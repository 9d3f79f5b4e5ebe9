//! # squish-render — preview pictures and quality plots with no GPU and no system libraries
//!
//! The `squish` command line renders its results to PNG with this crate:
//! - [`render`]: a tile-parallel software rasterizer (z-buffer, supersampling, two-sided
//!   Blinn-Phong lighting with tinted back faces, smooth or flat shading, per-vertex or per-face
//!   colours, wireframe overlay), deterministic to the bit whatever the thread count;
//! - [`Camera`]: perspective cameras, with [`Camera::framing`] to fit a bounding box and
//!   [`Camera::orbit`] to look from azimuth/elevation angles (z up);
//! - [`Image`], [`encode_png`], [`hstack`], [`vstack`], [`grid`] and a built-in bitmap font
//!   ([`draw_text`], [`label`]) to compose and caption pictures;
//! - colour maps for debug views ([`Label`], [`sequential`], [`scalar_colors`]);
//! - line plots as standalone SVG ([`svg_line_plot`]) or as pictures ([`plot_image`]), drawn
//!   with anti-aliased 2D primitives ([`draw_polyline`] …).
//!
//! Colours passed in are linear RGB ([`Rgb`]); use [`srgb8`] to write them as the usual
//! 8-bit hex values.
//!
//! ```
//! use squish::mesh::{bounding_box, shapes};
//! use squish_render::*;
//!
//! let sphere = shapes::icosphere(1.0, 3);
//! let u: Vec<f64> = sphere.positions.iter().map(|p| 0.5 + 0.5 * p.z).collect();
//! let colors = scalar_colors(&u, Some((0.0, 1.0)));
//! let options = RenderOptions::new(320, 240);
//! let camera = Camera::orbit(&bounding_box(&sphere), 30.0, 20.0, 40.0, options.aspect());
//! let mut image = render(&[RenderMesh::new(&sphere).with_vertex_colors(&colors)], &camera, &options)?;
//! label(&mut image, "frame 12");
//! let png: Vec<u8> = encode_png(&image)?; // write it atomically where it belongs
//! assert!(png.starts_with(b"\x89PNG"));
//! # Ok::<(), RenderError>(())
//! ```

mod camera;
mod canvas;
mod colormap;
mod font;
mod image;
mod plot;
mod raster;
mod shading;

pub use camera::{Camera, orbit_direction};
pub use canvas::{draw_line, draw_polyline, fill_circle, stroke_rect};
pub use colormap::{Label, MISSING_COLOR, categorical, label_colors, scalar_colors, sequential};
pub use font::{
    ADVANCE, GLYPH_HEIGHT, GLYPH_WIDTH, LINE_HEIGHT, draw_text, draw_text_vertical, glyph, label, text_size,
};
pub use image::{Image, MAX_IMAGE_SIDE, encode_png, grid, hstack, rgba8, vstack};
pub use plot::{Plot, Series, plot_image, svg_line_plot};
pub use raster::{Background, RenderMesh, RenderOptions, Shading, clay, render};
pub use shading::{Light, Lighting, Rgb, linear_to_srgb, linear_to_srgb8, srgb_to_linear, srgb8};

/// Why a picture could not be made.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("invalid image size {width}×{height}: each side must be between 1 and {max} pixels", max = MAX_IMAGE_SIDE)]
    InvalidImageSize { width: u32, height: u32 },
    #[error("supersampling {0} is out of range: use 1 (none) to 4 (4×4 samples per pixel)")]
    InvalidSupersampling(u32),
    #[error("an image of {width}×{height} needs {expected} RGBA bytes but the buffer has {actual}")]
    BufferSize { width: u32, height: u32, expected: usize, actual: usize },
    #[error("mesh {mesh} has {actual} {kind} colours but needs one per {kind}, {expected} in all")]
    ColorCount { mesh: usize, kind: &'static str, expected: usize, actual: usize },
    #[error("triangle {triangle} of mesh {mesh} refers to vertex {index}, but the mesh has only {vertices} vertices")]
    IndexOutOfRange { mesh: usize, triangle: usize, index: u32, vertices: usize },
    #[error("the scene is too large to render ({vertices} vertices, {triangles} triangles; at most 2^32 of each)")]
    SceneTooLarge { vertices: usize, triangles: usize },
    #[error("PNG encoding failed: {0}")]
    Png(#[from] png::EncodingError),
}
