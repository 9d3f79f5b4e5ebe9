//! Colour spaces and the lighting model.
//!
//! All shading and blending happens in linear RGB (`[f32; 3]`, the [`Rgb`] alias); only the
//! final 8-bit image is sRGB-encoded. The lighting model is a key light, a fill light and a
//! hemispherical ambient term (sky above, ground below the camera's up direction), with a
//! Blinn-Phong highlight from the key light. Light directions are given relative to the camera
//! so that every view of a mesh is lit the same way, which is what a preview wants: the shape
//! should read clearly whatever the orbit angle.
//!
//! Back faces (the side of a triangle opposite its counter-clockwise normal) are lit as if their
//! normal were flipped, but with a tinted, darker albedo: an inside-out region or a surface that
//! penetrates another one then shows up at a glance.

use glam::Vec3;

/// A linear-light RGB colour, each channel nominally in `[0, 1]`.
pub type Rgb = [f32; 3];

/// Converts one sRGB-encoded channel in `[0, 1]` to linear light.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// Converts one linear-light channel to sRGB encoding, clamping to `[0, 1]` first.
pub fn linear_to_srgb(c: f32) -> f32 {
    // NaN compares false everywhere: map it to black rather than let it reach the encoder.
    let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
    if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 }
}

/// Converts one linear-light channel to an sRGB byte (rounded, clamped).
pub fn linear_to_srgb8(c: f32) -> u8 {
    (linear_to_srgb(c) * 255.0 + 0.5) as u8
}

/// The linear colour of an 8-bit sRGB triple, e.g. `srgb8(0x44, 0x88, 0xcc)` for `#4488cc`.
pub fn srgb8(r: u8, g: u8, b: u8) -> Rgb {
    [srgb_to_linear(f32::from(r) / 255.0), srgb_to_linear(f32::from(g) / 255.0), srgb_to_linear(f32::from(b) / 255.0)]
}

/// A directional light. `direction` points from the surface toward the light, in camera space:
/// x to the right of the image, y up the image, z toward the viewer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    /// Direction toward the light in camera space (need not be normalized).
    pub direction: [f32; 3],
    /// Linear colour times intensity.
    pub color: Rgb,
}

/// Lights and material constants shared by every mesh of a render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lighting {
    /// Main light, upper left of the camera; also makes the specular highlight.
    pub key: Light,
    /// Softer light from the right that keeps the shadow side readable.
    pub fill: Light,
    /// Ambient light received by a surface facing the camera's up direction.
    pub sky: Rgb,
    /// Ambient light received by a surface facing down.
    pub ground: Rgb,
    /// Strength of the Blinn-Phong highlight (0 disables it).
    pub specular: f32,
    /// Blinn-Phong exponent: larger is a smaller, sharper highlight.
    pub shininess: f32,
    /// Colour that back faces are pulled toward.
    pub back_tint: Rgb,
    /// How far back faces are pulled toward [`Self::back_tint`], in `[0, 1]`.
    pub back_tint_amount: f32,
    /// Brightness factor applied to back faces after tinting, in `[0, 1]`.
    pub back_brightness: f32,
}

impl Default for Lighting {
    fn default() -> Self {
        Self {
            key: Light { direction: [-0.55, 0.75, 0.65], color: [0.80, 0.78, 0.74] },
            fill: Light { direction: [0.85, -0.15, 0.45], color: [0.22, 0.25, 0.30] },
            sky: [0.30, 0.32, 0.36],
            ground: [0.12, 0.11, 0.10],
            specular: 0.28,
            shininess: 48.0,
            back_tint: [0.80, 0.05, 0.40],
            back_tint_amount: 0.7,
            back_brightness: 0.75,
        }
    }
}

/// Lighting prepared for a render: light directions in the rasterizer's view space (x right,
/// y up, z forward into the picture) and unit length.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PreparedLighting {
    key_dir: Vec3,
    key_color: Vec3,
    fill_dir: Vec3,
    fill_color: Vec3,
    sky: Vec3,
    ground: Vec3,
    /// The camera's up direction in view space, for the hemispherical ambient term.
    up: Vec3,
    specular: f32,
    shininess: f32,
    back_tint: Vec3,
    back_tint_amount: f32,
    back_brightness: f32,
}

/// Camera space (z toward the viewer) to view space (z forward): flip z, normalize, and fall
/// back to "from the viewer" for a zero or non-finite direction.
fn to_view_direction(d: [f32; 3]) -> Vec3 {
    let v = Vec3::new(d[0], d[1], -d[2]).normalize_or_zero();
    if v == Vec3::ZERO { Vec3::new(0.0, 0.0, -1.0) } else { v }
}

fn finite_color(c: Rgb) -> Vec3 {
    let v = Vec3::from_array(c);
    if v.is_finite() { v.max(Vec3::ZERO) } else { Vec3::ZERO }
}

impl PreparedLighting {
    /// `up` is the camera's up direction expressed in view space.
    pub(crate) fn new(lighting: &Lighting, up: Vec3) -> Self {
        let finite01 = |x: f32| if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 };
        Self {
            key_dir: to_view_direction(lighting.key.direction),
            key_color: finite_color(lighting.key.color),
            fill_dir: to_view_direction(lighting.fill.direction),
            fill_color: finite_color(lighting.fill.color),
            sky: finite_color(lighting.sky),
            ground: finite_color(lighting.ground),
            up: up.normalize_or_zero(),
            specular: if lighting.specular.is_finite() { lighting.specular.max(0.0) } else { 0.0 },
            shininess: if lighting.shininess.is_finite() { lighting.shininess.clamp(1.0, 4096.0) } else { 32.0 },
            back_tint: finite_color(lighting.back_tint),
            back_tint_amount: finite01(lighting.back_tint_amount),
            back_brightness: finite01(lighting.back_brightness),
        }
    }

    /// Colour of a surface point.
    ///
    /// `normal` is the unit shading normal already turned toward the viewer's side of the
    /// triangle, `to_eye` the unit vector from the point to the eye, `albedo` the surface colour
    /// and `front` whether the viewer sees the triangle's front side.
    #[inline]
    pub(crate) fn shade(&self, normal: Vec3, to_eye: Vec3, albedo: Vec3, front: bool) -> Vec3 {
        let albedo =
            if front { albedo } else { albedo.lerp(self.back_tint, self.back_tint_amount) * self.back_brightness };
        let hemisphere = 0.5 + 0.5 * normal.dot(self.up);
        let ambient = self.ground.lerp(self.sky, hemisphere);
        let key = normal.dot(self.key_dir).max(0.0);
        let fill = normal.dot(self.fill_dir).max(0.0);
        let diffuse = ambient + self.key_color * key + self.fill_color * fill;
        let mut color = albedo * diffuse;
        if self.specular > 0.0 && key > 0.0 {
            let half = (self.key_dir + to_eye).normalize_or_zero();
            let highlight = normal.dot(half).max(0.0).powf(self.shininess);
            // A dimmer highlight on back faces keeps them from looking glossy-new.
            let strength = if front { self.specular } else { 0.3 * self.specular };
            color += self.key_color * (strength * highlight);
        }
        color
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trips_every_byte() {
        for b in 0..=255u8 {
            let lin = srgb_to_linear(f32::from(b) / 255.0);
            assert_eq!(linear_to_srgb8(lin), b);
        }
        assert_eq!(linear_to_srgb8(f32::NAN), 0);
        assert_eq!(linear_to_srgb8(-3.0), 0);
        assert_eq!(linear_to_srgb8(7.0), 255);
    }

    #[test]
    fn back_faces_are_darker_and_tinted() {
        let light = PreparedLighting::new(&Lighting::default(), Vec3::Y);
        let n = Vec3::new(0.0, 0.0, -1.0);
        let grey = Vec3::splat(0.6);
        let front = light.shade(n, n, grey, true);
        let back = light.shade(n, n, grey, false);
        assert!(back.element_sum() < 0.8 * front.element_sum(), "{front} {back}");
        // The default tint is magenta: red and blue above green.
        assert!(back.x > 1.5 * back.y && back.z > 1.5 * back.y, "{back}");
    }
}
