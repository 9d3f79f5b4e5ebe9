//! The software rasterizer: meshes + camera → anti-aliased, shaded picture.
//!
//! Pipeline:
//! 1. **Setup.** Vertices are moved into the camera's frame (in `f64`, then `f32` relative to the
//!    eye, which keeps precision for meshes far from the origin) and projected. Triangles are
//!    clipped against the near plane and a guard band around the picture, then their corners are
//!    snapped to a fixed-point grid (1/256 of a sample).
//! 2. **Binning.** The supersampled picture is cut into square tiles; each triangle is listed, in
//!    scene order, in the tiles its bounding box touches.
//! 3. **Visibility.** Tiles are rasterized independently (in parallel with rayon): exact integer
//!    edge functions with a consistent tie rule (no cracks between neighbours), a depth buffer of
//!    1/w (larger is nearer; exact to interpolate in screen space, no far plane needed), and the
//!    id of the nearest triangle per sample. Ties keep the earlier triangle.
//! 4. **Shading.** Each covered sample shoots the camera ray through its centre at its triangle to
//!    get exact perspective-correct barycentric coordinates, which give the normal (smooth or
//!    flat), the colour, and for wireframes the distance to the triangle's edges in pixels.
//! 5. **Resolve.** Samples are box-filtered into pixels in linear light (premultiplied alpha) and
//!    sRGB-encoded.
//!
//! Every tile's result depends only on the input, and the tiles are gathered in a fixed order,
//! so the picture is bit-identical whatever the number of threads.

use glam::{DVec3, Vec3};
use rayon::prelude::*;
use squish::TriMesh;
use squish::mesh::vertex_normals;

use crate::RenderError;
use crate::camera::Camera;
use crate::image::{Image, MAX_IMAGE_SIDE};
use crate::shading::{Lighting, PreparedLighting, Rgb, linear_to_srgb8, srgb8};

/// How normals are chosen across a triangle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Shading {
    /// Interpolated vertex normals: smooth surfaces.
    #[default]
    Smooth,
    /// The triangle's own normal: faceted look that shows the tessellation.
    Flat,
}

/// A mesh to draw and how to draw it. Colours are linear RGB; per-face colours take precedence
/// over per-vertex colours, which take precedence over the base colour.
#[derive(Clone, Copy, Debug)]
pub struct RenderMesh<'a> {
    /// The geometry.
    pub mesh: &'a TriMesh,
    /// Colour used when no per-vertex or per-face colours are given.
    pub color: Rgb,
    /// One colour per vertex, interpolated across triangles.
    pub vertex_colors: Option<&'a [Rgb]>,
    /// One colour per triangle.
    pub face_colors: Option<&'a [Rgb]>,
    /// Smooth or flat normals.
    pub shading: Shading,
    /// Draw the triangles' edges over the surface (hidden edges stay hidden).
    pub wireframe: bool,
}

/// Default surface colour: a light neutral clay that shows shading well.
pub fn clay() -> Rgb {
    srgb8(0xc8, 0xc2, 0xb8)
}

impl<'a> RenderMesh<'a> {
    /// The mesh in the default clay colour, smooth, without wireframe.
    pub fn new(mesh: &'a TriMesh) -> Self {
        Self { mesh, color: clay(), vertex_colors: None, face_colors: None, shading: Shading::Smooth, wireframe: false }
    }

    /// Sets the base colour.
    pub fn with_color(mut self, color: Rgb) -> Self {
        self.color = color;
        self
    }

    /// Sets per-vertex colours (one per vertex of the mesh).
    pub fn with_vertex_colors(mut self, colors: &'a [Rgb]) -> Self {
        self.vertex_colors = Some(colors);
        self
    }

    /// Sets per-face colours (one per triangle of the mesh).
    pub fn with_face_colors(mut self, colors: &'a [Rgb]) -> Self {
        self.face_colors = Some(colors);
        self
    }

    /// Sets smooth or flat shading.
    pub fn with_shading(mut self, shading: Shading) -> Self {
        self.shading = shading;
        self
    }

    /// Turns the wireframe overlay on or off.
    pub fn with_wireframe(mut self, wireframe: bool) -> Self {
        self.wireframe = wireframe;
        self
    }
}

/// What is behind the meshes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Background {
    /// A vertical gradient from `top` to `bottom` (linear colours).
    Gradient {
        /// Colour of the top row.
        top: Rgb,
        /// Colour of the bottom row.
        bottom: Rgb,
    },
    /// One colour.
    Solid(Rgb),
    /// Fully transparent: alpha is the meshes' coverage, for compositing elsewhere.
    Transparent,
}

impl Default for Background {
    fn default() -> Self {
        Background::Gradient { top: srgb8(0x5b, 0x63, 0x70), bottom: srgb8(0x1e, 0x21, 0x26) }
    }
}

/// Picture size and rendering settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    /// Width in pixels (1 to [`MAX_IMAGE_SIDE`]).
    pub width: u32,
    /// Height in pixels (1 to [`MAX_IMAGE_SIDE`]).
    pub height: u32,
    /// Samples per pixel along each axis (1 to 4): 2 means 2 × 2 supersampling.
    pub supersampling: u32,
    /// What is behind the meshes.
    pub background: Background,
    /// Lights and back-face tint.
    pub lighting: Lighting,
    /// Colour of wireframe lines.
    pub wireframe_color: Rgb,
    /// Width of wireframe lines in output pixels.
    pub wireframe_width: f32,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            width: 800,
            height: 600,
            supersampling: 3,
            background: Background::default(),
            lighting: Lighting::default(),
            wireframe_color: srgb8(0x20, 0x22, 0x28),
            wireframe_width: 1.0,
        }
    }
}

impl RenderOptions {
    /// Default options for a `width` × `height` picture.
    pub fn new(width: u32, height: u32) -> Self {
        Self { width, height, ..Self::default() }
    }

    /// Width over height, the aspect to give [`Camera::framing`].
    pub fn aspect(&self) -> f64 {
        f64::from(self.width.max(1)) / f64::from(self.height.max(1))
    }
}

/// Output pixels per tile side.
const TILE: usize = 32;
/// Fixed-point subsample precision: 8 bits.
const SUBPIXEL: i64 = 256;
/// The guard band: geometry is clipped at `GUARD` times the half-width of the view, far enough
/// that clipping is rare and close enough that fixed-point coordinates stay small.
const GUARD: f64 = 2.0;
/// No triangle in this sample.
const EMPTY: u32 = u32::MAX;

/// One vertex, ready to rasterize: clip coordinates (x / tan_h, y / tan_v, w = depth) and
/// the outcode of the clip planes it is outside of.
#[derive(Clone, Copy, Debug)]
struct ClipVertex {
    clip: DVec3,
    outside: u8,
}

/// Per-triangle data the shader needs.
#[derive(Clone, Copy, Debug)]
struct TriData {
    /// Global vertex indices.
    v: [u32; 3],
    /// Colour at each corner.
    colors: [Vec3; 3],
    flat: bool,
    wire: bool,
}

/// A triangle (or a piece of a clipped one) on the sample grid.
#[derive(Clone, Copy, Debug)]
struct ScreenTri {
    /// Fixed-point sample coordinates of the corners.
    x: [i64; 3],
    y: [i64; 3],
    /// 1/w at the corners.
    inv_w: [f64; 3],
    /// Index into the triangle table.
    tri: u32,
}

/// The scene, flattened and moved into view space.
struct Scene {
    /// View-space positions relative to the eye (x right, y up, z forward).
    positions: Vec<Vec3>,
    /// View-space unit vertex normals (zero where undefined).
    normals: Vec<Vec3>,
    clip: Vec<ClipVertex>,
    tris: Vec<TriData>,
}

/// Projection constants for the supersampled grid.
#[derive(Clone, Copy, Debug)]
struct Frame {
    /// Samples across and down.
    width: usize,
    height: usize,
    tan_h: f64,
    tan_v: f64,
    near: f64,
    /// Samples per output pixel along each axis.
    ss: usize,
}

impl Frame {
    /// View-space ray direction through the sample-space point (sx, sy).
    #[inline]
    fn ray(&self, sx: f32, sy: f32) -> Vec3 {
        let x = (2.0 * sx / self.width as f32 - 1.0) * self.tan_h as f32;
        let y = (1.0 - 2.0 * sy / self.height as f32) * self.tan_v as f32;
        Vec3::new(x, y, 1.0)
    }
}

fn outcode(c: DVec3, near: f64) -> u8 {
    // Callers pass finite points only (non-finite ones are flagged outside everything).
    let mut code = 0;
    if c.z < near {
        code |= 1;
    }
    if c.x < -GUARD * c.z {
        code |= 2;
    }
    if c.x > GUARD * c.z {
        code |= 4;
    }
    if c.y < -GUARD * c.z {
        code |= 8;
    }
    if c.y > GUARD * c.z {
        code |= 16;
    }
    code
}

/// Signed distance of a clip-space point inside plane `plane` (bit index of the outcode).
#[inline]
fn plane_distance(c: DVec3, plane: usize, near: f64) -> f64 {
    match plane {
        0 => c.z - near,
        1 => c.x + GUARD * c.z,
        2 => GUARD * c.z - c.x,
        3 => c.y + GUARD * c.z,
        _ => GUARD * c.z - c.y,
    }
}

fn sanitize_color(c: Rgb) -> Vec3 {
    let v = Vec3::from_array(c);
    if v.is_finite() { v.max(Vec3::ZERO) } else { Vec3::ZERO }
}

fn check_options(options: &RenderOptions) -> Result<(), RenderError> {
    let (w, h) = (options.width, options.height);
    if w == 0 || h == 0 || w > MAX_IMAGE_SIDE || h > MAX_IMAGE_SIDE {
        return Err(RenderError::InvalidImageSize { width: w, height: h });
    }
    if !(1..=4).contains(&options.supersampling) {
        return Err(RenderError::InvalidSupersampling(options.supersampling));
    }
    Ok(())
}

impl Scene {
    fn new(meshes: &[RenderMesh], camera: &Camera, frame: &Frame) -> Result<Self, RenderError> {
        let basis = camera.basis();
        let total_vertices: usize = meshes.iter().map(|m| m.mesh.positions.len()).sum();
        let total_triangles: usize = meshes.iter().map(|m| m.mesh.triangles.len()).sum();
        if u32::try_from(total_vertices).is_err() || u32::try_from(total_triangles).is_err() {
            return Err(RenderError::SceneTooLarge { vertices: total_vertices, triangles: total_triangles });
        }
        let mut positions = Vec::with_capacity(total_vertices);
        let mut normals = Vec::with_capacity(total_vertices);
        let mut clip = Vec::with_capacity(total_vertices);
        let mut tris = Vec::with_capacity(total_triangles);
        for (index, item) in meshes.iter().enumerate() {
            let mesh = item.mesh;
            let n = mesh.positions.len();
            if let Some(colors) = item.vertex_colors
                && colors.len() != n
            {
                return Err(RenderError::ColorCount { mesh: index, kind: "vertex", expected: n, actual: colors.len() });
            }
            if let Some(colors) = item.face_colors
                && colors.len() != mesh.triangles.len()
            {
                return Err(RenderError::ColorCount {
                    mesh: index,
                    kind: "face",
                    expected: mesh.triangles.len(),
                    actual: colors.len(),
                });
            }
            // Checked before anything indexes positions with them (vertex_normals does).
            for (t, tri) in mesh.triangles.iter().enumerate() {
                if let Some(&bad) = tri.iter().find(|&&i| i as usize >= n) {
                    return Err(RenderError::IndexOutOfRange { mesh: index, triangle: t, index: bad, vertices: n });
                }
            }
            let offset = positions.len() as u32;
            let view: Vec<DVec3> = mesh.positions.par_iter().map(|&p| basis.to_view(p - camera.eye)).collect();
            positions.extend(view.iter().map(|q| q.as_vec3()));
            clip.extend(view.iter().map(|q| {
                let c = DVec3::new(q.x / frame.tan_h, q.y / frame.tan_v, q.z);
                // A non-finite vertex is outside every plane: its triangles are dropped.
                let outside = if c.is_finite() { outcode(c, frame.near) } else { 0x1f };
                ClipVertex { clip: c, outside }
            }));
            let smooth_normals = if item.shading == Shading::Smooth { vertex_normals(mesh) } else { Vec::new() };
            if smooth_normals.len() == n {
                normals.extend(smooth_normals.iter().map(|&v| basis.to_view(v).as_vec3()));
            } else {
                normals.extend(std::iter::repeat_n(Vec3::ZERO, n));
            }
            let base = sanitize_color(item.color);
            for (t, tri) in mesh.triangles.iter().enumerate() {
                let colors = if let Some(face) = item.face_colors.and_then(|c| c.get(t)) {
                    [sanitize_color(*face); 3]
                } else if let Some(vc) = item.vertex_colors {
                    tri.map(|i| vc.get(i as usize).map_or(base, |c| sanitize_color(*c)))
                } else {
                    [base; 3]
                };
                tris.push(TriData {
                    v: tri.map(|i| i + offset),
                    colors,
                    flat: item.shading == Shading::Flat,
                    wire: item.wireframe,
                });
            }
        }
        Ok(Self { positions, normals, clip, tris })
    }

    /// Snaps a clip-space point to the fixed-point sample grid.
    #[inline]
    fn snap(c: DVec3, frame: &Frame) -> (i64, i64, f64) {
        let sx = (0.5 + 0.5 * c.x / c.z) * frame.width as f64;
        let sy = (0.5 - 0.5 * c.y / c.z) * frame.height as f64;
        ((sx * SUBPIXEL as f64).round() as i64, (sy * SUBPIXEL as f64).round() as i64, 1.0 / c.z)
    }

    /// The screen triangles of triangle `t`: itself, nothing, or the fan of its clipped polygon.
    fn screen_triangles(&self, t: usize, frame: &Frame, out: &mut Vec<ScreenTri>) {
        let v = self.tris[t].v;
        let corners = v.map(|i| self.clip[i as usize]);
        let any_out = corners[0].outside | corners[1].outside | corners[2].outside;
        let all_out = corners[0].outside & corners[1].outside & corners[2].outside;
        if all_out != 0 {
            return;
        }
        if corners.iter().any(|c| !c.clip.is_finite()) {
            return;
        }
        let emit = |poly: &[DVec3], out: &mut Vec<ScreenTri>| {
            let Some((&first, rest)) = poly.split_first() else { return };
            let a = Self::snap(first, frame);
            let mut previous: Option<(i64, i64, f64)> = None;
            for &c in rest {
                let c = Self::snap(c, frame);
                if let Some(b) = previous {
                    out.push(ScreenTri {
                        x: [a.0, b.0, c.0],
                        y: [a.1, b.1, c.1],
                        inv_w: [a.2, b.2, c.2],
                        tri: t as u32,
                    });
                }
                previous = Some(c);
            }
        };
        if any_out == 0 {
            emit(&corners.map(|c| c.clip), out);
            return;
        }
        // Sutherland–Hodgman against each plane the triangle straddles. New points are always
        // computed from the inside end toward the outside end, so that the two triangles sharing
        // a clipped edge get bit-identical points and no crack opens between them.
        let mut poly: Vec<DVec3> = corners.iter().map(|c| c.clip).collect();
        for plane in 0..5 {
            if any_out & (1 << plane) == 0 {
                continue;
            }
            let mut next = Vec::with_capacity(poly.len() + 2);
            for k in 0..poly.len() {
                let a = poly[k];
                let b = poly[(k + 1) % poly.len()];
                let (da, db) = (plane_distance(a, plane, frame.near), plane_distance(b, plane, frame.near));
                let (a_in, b_in) = (da >= 0.0, db >= 0.0);
                if a_in {
                    next.push(a);
                }
                if a_in != b_in {
                    let (inside, outside, di, dout) = if a_in { (a, b, da, db) } else { (b, a, db, da) };
                    let s = di / (di - dout);
                    next.push(inside + (outside - inside) * s);
                }
            }
            poly = next;
            if poly.len() < 3 {
                return;
            }
        }
        emit(&poly, out);
    }
}

/// The first sample whose centre is at or after the fixed-point coordinate `v`: sample i has
/// its centre at (i + ½)·256.
#[inline]
fn first_sample(v: i64) -> i64 {
    -(-(v - SUBPIXEL / 2)).div_euclid(SUBPIXEL)
}

/// The last sample whose centre is at or before the fixed-point coordinate `v`.
#[inline]
fn last_sample(v: i64) -> i64 {
    (v - SUBPIXEL / 2).div_euclid(SUBPIXEL)
}

/// Fills the depth and id buffers of one tile (sample rectangle starting at (x0, y0), `w` × `h`)
/// with one screen triangle.
fn rasterize(tri: &ScreenTri, x0: usize, y0: usize, w: usize, h: usize, depth: &mut [f32], ids: &mut [u32]) {
    let (mut x, mut y, mut iw) = (tri.x, tri.y, tri.inv_w);
    let mut area = (x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0]);
    if area == 0 {
        return;
    }
    if area < 0 {
        // Both sides are drawn: put every triangle in the same winding so that "inside" is
        // "all edge functions non-negative".
        x.swap(1, 2);
        y.swap(1, 2);
        iw.swap(1, 2);
        area = -area;
    }
    let i0 = first_sample(x[0].min(x[1]).min(x[2])).max(x0 as i64);
    let i1 = last_sample(x[0].max(x[1]).max(x[2])).min((x0 + w) as i64 - 1);
    let j0 = first_sample(y[0].min(y[1]).min(y[2])).max(y0 as i64);
    let j1 = last_sample(y[0].max(y[1]).max(y[2])).min((y0 + h) as i64 - 1);
    if i0 > i1 || j0 > j1 {
        return;
    }
    // Edge k joins corner k+1 to corner k+2 and is zero on it; it is positive at corner k.
    let mut e_row = [0i64; 3];
    let mut exact = [0i64; 3];
    let mut step_x = [0i64; 3];
    let mut step_y = [0i64; 3];
    let (px, py) = (i0 * SUBPIXEL + SUBPIXEL / 2, j0 * SUBPIXEL + SUBPIXEL / 2);
    for k in 0..3 {
        let (a, b) = ((k + 1) % 3, (k + 2) % 3);
        let (dx, dy) = (x[b] - x[a], y[b] - y[a]);
        // Samples exactly on an edge belong to one of the two triangles sharing it: the one for
        // which the edge runs down (or right, if horizontal). The neighbour runs it the other way.
        let owned = dy > 0 || (dy == 0 && dx > 0);
        exact[k] = dx * (py - y[a]) - dy * (px - x[a]);
        e_row[k] = exact[k] - if owned { 0 } else { 1 };
        step_x[k] = -dy * SUBPIXEL;
        step_y[k] = dx * SUBPIXEL;
    }
    // 1/w is affine in screen space: plane through the corners, per sample step.
    let inv_area = 1.0 / area as f64;
    let dz_dx = -((y[2] - y[1]) as f64 * iw[0] + (y[0] - y[2]) as f64 * iw[1] + (y[1] - y[0]) as f64 * iw[2])
        * inv_area
        * SUBPIXEL as f64;
    let dz_dy = ((x[2] - x[1]) as f64 * iw[0] + (x[0] - x[2]) as f64 * iw[1] + (x[1] - x[0]) as f64 * iw[2])
        * inv_area
        * SUBPIXEL as f64;
    let z0 = (exact[0] as f64 * iw[0] + exact[1] as f64 * iw[1] + exact[2] as f64 * iw[2]) * inv_area;
    for j in j0..=j1 {
        let mut e = e_row;
        let row = (j as usize - y0) * w;
        let zr = z0 + dz_dy * (j - j0) as f64;
        for i in i0..=i1 {
            if (e[0] | e[1] | e[2]) >= 0 {
                let z = (zr + dz_dx * (i - i0) as f64) as f32;
                let k = row + (i as usize - x0);
                if z > depth[k] {
                    depth[k] = z;
                    ids[k] = tri.tri;
                }
            }
            e[0] += step_x[0];
            e[1] += step_x[1];
            e[2] += step_x[2];
        }
        e_row[0] += step_y[0];
        e_row[1] += step_y[1];
        e_row[2] += step_y[2];
    }
}

/// Quantities of a triangle that give barycentric coordinates of a ray hit with three dot
/// products: for a ray direction d from the eye, u = d·a_u / d·den, v = d·a_v / d·den.
#[derive(Clone, Copy, Debug)]
struct RaySetup {
    a_u: Vec3,
    a_v: Vec3,
    den: Vec3,
}

impl RaySetup {
    fn new(p: [Vec3; 3]) -> Self {
        // Möller–Trumbore with the ray origin at the eye (0): with e1 = p1 − p0, e2 = p2 − p0
        // and s = −p0, u = s·(d×e2)/e1·(d×e2) = d·(e2×s)/d·(e2×e1), v = d·(s×e1)/d·(e2×e1).
        let (e1, e2, s) = (p[1] - p[0], p[2] - p[0], -p[0]);
        Self { a_u: e2.cross(s), a_v: s.cross(e1), den: e2.cross(e1) }
    }

    /// Unclamped barycentric coordinates of the hit along `d`, or `None` if the ray is parallel.
    #[inline]
    fn barycentric(&self, d: Vec3) -> Option<Vec3> {
        let den = d.dot(self.den);
        if den == 0.0 || !den.is_finite() {
            return None;
        }
        let u = d.dot(self.a_u) / den;
        let v = d.dot(self.a_v) / den;
        Some(Vec3::new(1.0 - u - v, u, v))
    }
}

/// Everything the per-tile work reads.
struct Context<'a> {
    scene: &'a Scene,
    screen: &'a [ScreenTri],
    bins: &'a [Vec<u32>],
    frame: Frame,
    lighting: PreparedLighting,
    background: Background,
    wire_color: Vec3,
    wire_half_width: f32,
    tiles_x: usize,
}

impl Context<'_> {
    /// Background at sample row `sy` as premultiplied linear RGBA.
    fn background(&self, sy: usize) -> [f32; 4] {
        match self.background {
            Background::Gradient { top, bottom } => {
                let t = (sy as f32 + 0.5) / self.frame.height as f32;
                let c = sanitize_color(top).lerp(sanitize_color(bottom), t);
                [c.x, c.y, c.z, 1.0]
            }
            Background::Solid(c) => {
                let c = sanitize_color(c);
                [c.x, c.y, c.z, 1.0]
            }
            Background::Transparent => [0.0; 4],
        }
    }

    /// Colour of the sample at (sx, sy) covered by triangle `t`.
    fn shade(&self, t: u32, setup: &RaySetup, sx: usize, sy: usize) -> Vec3 {
        let scene = self.scene;
        let tri = &scene.tris[t as usize];
        let (cx, cy) = (sx as f32 + 0.5, sy as f32 + 0.5);
        let d = self.frame.ray(cx, cy);
        let p = tri.v.map(|i| scene.positions[i as usize]);
        let raw = setup.barycentric(d).unwrap_or(Vec3::splat(1.0 / 3.0));
        // The sample centre is inside the triangle up to rounding; clamp so that colours and
        // normals never extrapolate.
        let b = {
            let c = raw.max(Vec3::ZERO);
            let sum = c.element_sum();
            if sum > 0.0 && sum.is_finite() { c / sum } else { Vec3::splat(1.0 / 3.0) }
        };
        // The view frame (right, up, forward) is left-handed, so the outward normal of a
        // counter-clockwise triangle is e2 × e1 there, not e1 × e2.
        let geometric = (p[2] - p[0]).cross(p[1] - p[0]).normalize_or_zero();
        // The eye is at the origin: the viewer sees the front side when the normal points back
        // along the ray.
        let front = geometric.dot(d) < 0.0;
        let mut normal = geometric;
        if !tri.flat {
            let n = tri.v.map(|i| scene.normals[i as usize]);
            let smooth = (n[0] * b.x + n[1] * b.y + n[2] * b.z).normalize_or_zero();
            if smooth != Vec3::ZERO {
                normal = smooth;
            }
        }
        if !front {
            normal = -normal;
        }
        let albedo = tri.colors[0] * b.x + tri.colors[1] * b.y + tri.colors[2] * b.z;
        let to_eye = -d.normalize();
        let mut color = self.lighting.shade(normal, to_eye, albedo, front);
        if tri.wire {
            color = self.wireframe(setup, raw, cx, cy, color);
        }
        color
    }

    /// Blends the wireframe colour over `color` by how close the sample is to an edge, in output
    /// pixels. The distance to edge k is b_k / |∇b_k|, with the gradient of the barycentric
    /// coordinates across the screen taken from rays one sample to the right and below; this is
    /// exact for clipped triangles too, since it does not use the projected corners.
    fn wireframe(&self, setup: &RaySetup, b: Vec3, cx: f32, cy: f32, color: Vec3) -> Vec3 {
        let (Some(bx), Some(by)) =
            (setup.barycentric(self.frame.ray(cx + 1.0, cy)), setup.barycentric(self.frame.ray(cx, cy + 1.0)))
        else {
            return self.wire_color;
        };
        let (gx, gy) = (bx - b, by - b);
        let gradient = (gx * gx + gy * gy).powf(0.5);
        let ss = self.frame.ss as f32;
        let mut coverage = 0.0f32;
        for k in 0..3 {
            let distance_px = if gradient[k] > 0.0 { b[k].abs() / gradient[k] / ss } else { f32::INFINITY };
            // A half-pixel ramp on top of the supersampling keeps thin lines smooth.
            coverage = coverage.max((self.wire_half_width + 0.5 - distance_px).clamp(0.0, 1.0));
        }
        color.lerp(self.wire_color, coverage)
    }

    /// Renders tile `index`: premultiplied linear RGBA of its output pixels, row by row.
    fn tile(&self, index: usize) -> Vec<[f32; 4]> {
        let frame = &self.frame;
        let ss = frame.ss;
        let (tx, ty) = (index % self.tiles_x, index / self.tiles_x);
        let (x0, y0) = (tx * TILE * ss, ty * TILE * ss);
        let w = (TILE * ss).min(frame.width - x0);
        let h = (TILE * ss).min(frame.height - y0);
        let mut depth = vec![0.0f32; w * h];
        let mut ids = vec![EMPTY; w * h];
        if let Some(bin) = self.bins.get(index) {
            for &s in bin {
                rasterize(&self.screen[s as usize], x0, y0, w, h, &mut depth, &mut ids);
            }
        }
        let (ow, oh) = (w / ss, h / ss);
        let mut out = vec![[0.0f32; 4]; ow * oh];
        let mut cached: Option<(u32, RaySetup)> = None;
        for j in 0..h {
            let background = self.background(y0 + j);
            let out_row = (j / ss) * ow;
            for i in 0..w {
                let id = ids[j * w + i];
                let sample = if id == EMPTY {
                    background
                } else {
                    let setup = match cached {
                        Some((cid, setup)) if cid == id => setup,
                        _ => {
                            let tri = &self.scene.tris[id as usize];
                            let setup = RaySetup::new(tri.v.map(|v| self.scene.positions[v as usize]));
                            cached = Some((id, setup));
                            setup
                        }
                    };
                    let c = self.shade(id, &setup, x0 + i, y0 + j);
                    [c.x, c.y, c.z, 1.0]
                };
                let px = &mut out[out_row + i / ss];
                for c in 0..4 {
                    px[c] += sample[c];
                }
            }
        }
        let norm = 1.0 / (ss * ss) as f32;
        for px in &mut out {
            for c in px.iter_mut() {
                *c *= norm;
            }
        }
        out
    }
}

/// Renders the meshes seen by `camera` into a `options.width` × `options.height` picture.
///
/// The camera's frustum is shown whole whatever the picture's aspect (see
/// [`Camera::tangents`]). Triangles with non-finite corners are skipped. Errors: a picture size
/// or supersampling out of range, colour arrays whose length does not match their mesh, and
/// triangle indices out of range.
pub fn render(scene: &[RenderMesh], camera: &Camera, options: &RenderOptions) -> Result<Image, RenderError> {
    check_options(options)?;
    let ss = options.supersampling as usize;
    let (width, height) = (options.width as usize, options.height as usize);
    let (tan_h, tan_v) = camera.tangents(options.aspect());
    let near = if camera.near.is_finite() && camera.near > 0.0 { camera.near } else { 1e-6 };
    let frame = Frame { width: width * ss, height: height * ss, tan_h, tan_v, near, ss };
    let prepared = Scene::new(scene, camera, &frame)?;

    // Setup in parallel chunks, gathered in triangle order.
    let chunk = 4096;
    let pieces: Vec<Vec<ScreenTri>> = (0..prepared.tris.len().div_ceil(chunk))
        .into_par_iter()
        .map(|c| {
            let mut out = Vec::new();
            for t in c * chunk..((c + 1) * chunk).min(prepared.tris.len()) {
                prepared.screen_triangles(t, &frame, &mut out);
            }
            out
        })
        .collect();
    let screen: Vec<ScreenTri> = pieces.into_iter().flatten().collect();

    // Binning, sequential so that each bin lists triangles in scene order.
    let tile_samples = (TILE * ss) as i64;
    let tiles_x = width.div_ceil(TILE);
    let tiles_y = height.div_ceil(TILE);
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); tiles_x * tiles_y];
    for (s, tri) in screen.iter().enumerate() {
        let lo_x = first_sample(tri.x[0].min(tri.x[1]).min(tri.x[2])).max(0);
        let hi_x = last_sample(tri.x[0].max(tri.x[1]).max(tri.x[2])).min(frame.width as i64 - 1);
        let lo_y = first_sample(tri.y[0].min(tri.y[1]).min(tri.y[2])).max(0);
        let hi_y = last_sample(tri.y[0].max(tri.y[1]).max(tri.y[2])).min(frame.height as i64 - 1);
        if lo_x > hi_x || lo_y > hi_y {
            continue;
        }
        for ty in (lo_y / tile_samples)..=(hi_y / tile_samples) {
            for tx in (lo_x / tile_samples)..=(hi_x / tile_samples) {
                if let Some(bin) = bins.get_mut(ty as usize * tiles_x + tx as usize) {
                    bin.push(s as u32);
                }
            }
        }
    }

    let up = camera.basis().to_view(camera.up).as_vec3();
    let context = Context {
        scene: &prepared,
        screen: &screen,
        bins: &bins,
        frame,
        lighting: PreparedLighting::new(&options.lighting, up),
        background: options.background,
        wire_color: sanitize_color(options.wireframe_color),
        wire_half_width: if options.wireframe_width.is_finite() { 0.5 * options.wireframe_width.max(0.0) } else { 0.5 },
        tiles_x,
    };
    let tiles: Vec<Vec<[f32; 4]>> = (0..tiles_x * tiles_y).into_par_iter().map(|t| context.tile(t)).collect();

    let mut image = Image::new(options.width, options.height, [0, 0, 0, 0]);
    for (index, pixels) in tiles.iter().enumerate() {
        let (tx, ty) = (index % tiles_x, index / tiles_x);
        let ow = TILE.min(width - tx * TILE);
        for (k, px) in pixels.iter().enumerate() {
            let (x, y) = (tx * TILE + k % ow, ty * TILE + k / ow);
            let alpha = px[3];
            let rgba = if alpha > 0.0 {
                [
                    linear_to_srgb8(px[0] / alpha),
                    linear_to_srgb8(px[1] / alpha),
                    linear_to_srgb8(px[2] / alpha),
                    (alpha.min(1.0) * 255.0 + 0.5) as u8,
                ]
            } else {
                [0, 0, 0, 0]
            };
            image.set_pixel(x as u32, y as u32, rgba);
        }
    }
    Ok(image)
}
