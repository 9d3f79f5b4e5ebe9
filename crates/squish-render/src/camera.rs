//! Perspective look-at cameras: a constructor that frames a bounding box tightly from a given
//! direction, an orbit helper (azimuth/elevation around the world's z-up axis), and the
//! projection of world points to pixels shared with the rasterizer.
//!
//! Conventions: z is up by default; azimuth 0 looks from −y toward +y (Blender's front view) and
//! grows counter-clockwise seen from above (azimuth 90° looks from +x); positive elevation puts
//! the camera above the subject, looking down.

use glam::DVec3;
use squish::mesh::Aabb3;

/// Fraction of the half field of view kept free around a framed box on its tightest side.
const FRAMING_MARGIN: f64 = 0.06;

/// A perspective camera looking from `eye` toward `target`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Position of the eye.
    pub eye: DVec3,
    /// A point the camera looks at; it projects to the image centre.
    pub target: DVec3,
    /// Approximate up direction (made orthogonal to the viewing direction internally).
    pub up: DVec3,
    /// Vertical field of view in degrees.
    pub fov_y_deg: f64,
    /// Width over height of the frustum the camera guarantees to show; an image of another
    /// aspect shows more, never less (see [`Camera::tangents`]).
    pub aspect: f64,
    /// Distance of the near clipping plane; geometry closer than this is cut away.
    pub near: f64,
}

/// An orthonormal camera frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Basis {
    pub right: DVec3,
    pub up: DVec3,
    pub forward: DVec3,
}

impl Basis {
    /// Camera-relative coordinates of `p`: (right, up, depth in front of the eye).
    #[inline]
    pub fn to_view(self, p: DVec3) -> DVec3 {
        DVec3::new(p.dot(self.right), p.dot(self.up), p.dot(self.forward))
    }
}

/// Unit `v`, or `fallback` if `v` is zero or not finite.
fn unit_or(v: DVec3, fallback: DVec3) -> DVec3 {
    let n = v.normalize_or_zero();
    if n == DVec3::ZERO { fallback } else { n }
}

/// Builds a right-handed frame looking along `forward` with `up` roughly up. When `up` is
/// (nearly) parallel to `forward`, e.g. looking straight down the z axis, another up is chosen so
/// that the frame stays well defined.
pub(crate) fn basis(forward: DVec3, up: DVec3) -> Basis {
    let forward = unit_or(forward, DVec3::Y);
    let mut up = unit_or(up, DVec3::Z);
    if forward.cross(up).length_squared() < 1e-10 {
        // Looking along the up axis: use the world axis least aligned with the view.
        up = if forward.z.abs() < 0.9 { DVec3::Z } else { DVec3::Y };
    }
    let right = forward.cross(up).normalize();
    let up = right.cross(forward);
    Basis { right, up, forward }
}

fn sane_fov(fov_deg: f64) -> f64 {
    if fov_deg.is_finite() { fov_deg.clamp(1.0, 170.0) } else { 40.0 }
}

fn sane_aspect(aspect: f64) -> f64 {
    if aspect.is_finite() && aspect > 0.0 { aspect.clamp(1e-3, 1e3) } else { 1.0 }
}

/// The view direction of an orbit camera: from a camera at (`azimuth_deg`, `elevation_deg`)
/// around the subject toward the subject (unit vector, z up).
pub fn orbit_direction(azimuth_deg: f64, elevation_deg: f64) -> DVec3 {
    let (az, el) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
    // Unit vector from the subject to the camera; the view direction is its opposite.
    let to_camera = DVec3::new(az.sin() * el.cos(), -az.cos() * el.cos(), el.sin());
    unit_or(-to_camera, DVec3::Y)
}

/// The lateral eye offset `e` for which the projected extent of points given as (lateral
/// coordinate, depth from the eye) is symmetric: max (x − e)/z = max (e − x)/z. The difference
/// of the two sides decreases strictly with `e`, so bisection finds it; `guess` is returned if the
/// points are unusable.
fn centre_offset(points: impl Iterator<Item = (f64, f64)> + Clone, guess: f64) -> f64 {
    let imbalance = |e: f64| {
        let (mut right, mut left) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
        for (x, z) in points.clone() {
            right = right.max((x - e) / z);
            left = left.max((e - x) / z);
        }
        right - left
    };
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (x, z) in points.clone() {
        if z.is_nan() || z <= 0.0 {
            return guess;
        }
        lo = lo.min(x);
        hi = hi.max(x);
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return guess;
    }
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if imbalance(mid) > 0.0 { lo = mid } else { hi = mid }
    }
    0.5 * (lo + hi)
}

impl Camera {
    /// A camera at `eye` looking at `target`, with the near plane at a thousandth of their
    /// distance.
    pub fn look_at(eye: DVec3, target: DVec3, up: DVec3, fov_y_deg: f64, aspect: f64) -> Self {
        let distance = (target - eye).length();
        let near = if distance.is_finite() && distance > 0.0 { 1e-3 * distance } else { 1e-3 };
        Self { eye, target, up, fov_y_deg: sane_fov(fov_y_deg), aspect: sane_aspect(aspect), near }
    }

    /// The closest camera looking along `view_direction` that shows all of `bbox` (with a small
    /// margin) in a `aspect` = width / height picture with vertical field of view `fov_deg`.
    ///
    /// The fit is exact for the box's eight corners, not a bounding sphere: the eye is moved
    /// sideways so that the box's projection is centred, then back until every corner is inside
    /// the horizontal and the vertical field of view. An empty or non-finite box frames the unit
    /// cube around the origin; a flat or point-like box is inflated a little.
    ///
    /// Seen from an angle, a box's corners stick out beyond the shape it holds (a sphere seen
    /// from above sits high in the frame, under the box's projected bottom corners); for
    /// previews, [`Self::framing_points`] on the vertices frames the shape itself.
    pub fn framing(bbox: &Aabb3, view_direction: DVec3, up: DVec3, fov_deg: f64, aspect: f64) -> Self {
        let (mut min, mut max) = (bbox.min, bbox.max);
        if !(min.is_finite() && max.is_finite() && min.cmple(max).all()) {
            (min, max) = (DVec3::splat(-0.5), DVec3::splat(0.5));
        }
        let center = 0.5 * (min + max);
        // Inflate degenerate boxes so that the eye ends up at a positive distance.
        let size = (max - min).max_element().max(1e-9 * center.abs().max_element()).max(1e-12);
        let half = (0.5 * (max - min)).max(DVec3::splat(1e-3 * size));
        let corners: [DVec3; 8] = std::array::from_fn(|i| {
            center
                + DVec3::new(
                    if i & 1 == 0 { -half.x } else { half.x },
                    if i & 2 == 0 { -half.y } else { half.y },
                    if i & 4 == 0 { -half.z } else { half.z },
                )
        });
        Self::fit(&corners, center, view_direction, up, fov_deg, aspect)
    }

    /// Like [`Self::framing`], but fits the points themselves (e.g. a mesh's vertices, or those of
    /// several meshes) rather than their bounding box: tighter for elongated or diagonal shapes
    /// seen from an angle. Non-finite points are ignored; with no usable point it frames the unit
    /// cube around the origin.
    pub fn framing_points(points: &[DVec3], view_direction: DVec3, up: DVec3, fov_deg: f64, aspect: f64) -> Self {
        let bbox = Aabb3::from_points(points.iter().copied().filter(|p| p.is_finite()));
        let size = if bbox.min.cmple(bbox.max).all() { bbox.extent().max_element() } else { 0.0 };
        if size.is_nan() || size <= 1e-9 * bbox.center().abs().max_element().max(1e-3) {
            // Nothing, or everything at one point: the box path inflates that sensibly.
            return Self::framing(&bbox, view_direction, up, fov_deg, aspect);
        }
        let finite: Vec<DVec3> = points.iter().copied().filter(|p| p.is_finite()).collect();
        Self::fit(&finite, bbox.center(), view_direction, up, fov_deg, aspect)
    }

    /// The closest camera looking along `view_direction` that keeps every point (not all at one
    /// place, all finite) inside the margin-reduced field of view, with the points' projection
    /// centred.
    fn fit(points: &[DVec3], center: DVec3, view_direction: DVec3, up: DVec3, fov_deg: f64, aspect: f64) -> Self {
        let fov = sane_fov(fov_deg);
        let aspect = sane_aspect(aspect);
        let frame = basis(view_direction, up);
        let tan_v = (0.5 * fov.to_radians()).tan() * (1.0 - FRAMING_MARGIN);
        let tan_h = tan_v * aspect;
        // Every point q (camera-frame coordinates relative to the centre) must satisfy
        // |q.x - e.x| <= tan_h (q.z - e.z), and the same vertically. With A = max(q.x - tan_h q.z)
        // and B = max(-q.x - tan_h q.z), the farthest-forward eye that satisfies the horizontal
        // constraints is e.x = (A - B)/2, e.z = -(A + B)/(2 tan_h); likewise vertically. The eye
        // must satisfy both, so it takes the smaller e.z (further back), which keeps the other
        // axis's constraints satisfiable.
        let local: Vec<DVec3> = points.iter().map(|&p| frame.to_view(p - center)).collect();
        let (mut a, mut b, mut c, mut d) = (f64::MIN, f64::MIN, f64::MIN, f64::MIN);
        for q in &local {
            a = a.max(q.x - tan_h * q.z);
            b = b.max(-q.x - tan_h * q.z);
            c = c.max(q.y - tan_v * q.z);
            d = d.max(-q.y - tan_v * q.z);
        }
        let ez = (-(a + b) / (2.0 * tan_h)).min(-(c + d) / (2.0 * tan_v));
        // On the looser axis the eye is further back than that axis needs, and the offset above
        // no longer centres the projection exactly: re-centre both axes for the final depth (the
        // centred offset minimizes the larger side, so it stays inside the field of view).
        let ex = centre_offset(local.iter().map(|q| (q.x, q.z - ez)), 0.5 * (a - b));
        let ey = centre_offset(local.iter().map(|q| (q.y, q.z - ez)), 0.5 * (c - d));
        let eye = center + frame.right * ex + frame.up * ey + frame.forward * ez;
        let nearest = local.iter().map(|q| q.z - ez).fold(f64::INFINITY, f64::min);
        Self {
            eye,
            target: eye - frame.forward * ez,
            up: frame.up,
            fov_y_deg: fov,
            aspect,
            // Half the distance to the nearest point: nothing framed is clipped, and depth
            // precision (1/w) does not depend on the near plane anyway.
            near: (0.5 * nearest).max(1e-6 * -ez),
        }
    }

    /// A camera that frames `bbox` from the orbit angles (degrees) around the z axis; see the
    /// module docs for the angle conventions.
    pub fn orbit(bbox: &Aabb3, azimuth_deg: f64, elevation_deg: f64, fov_deg: f64, aspect: f64) -> Self {
        Self::framing(bbox, orbit_direction(azimuth_deg, elevation_deg), DVec3::Z, fov_deg, aspect)
    }

    /// The camera's orthonormal frame.
    pub(crate) fn basis(&self) -> Basis {
        basis(self.target - self.eye, self.up)
    }

    /// Tangents of the horizontal and vertical half fields of view for an image of aspect
    /// `image_aspect` (width / height). The camera's own frustum always fits: a wider image shows
    /// more on the sides, a narrower one more above and below.
    pub fn tangents(&self, image_aspect: f64) -> (f64, f64) {
        let aspect = sane_aspect(self.aspect);
        let image_aspect = sane_aspect(image_aspect);
        let tan_v = (0.5 * sane_fov(self.fov_y_deg).to_radians()).tan();
        if image_aspect >= aspect {
            (tan_v * image_aspect, tan_v)
        } else {
            let tan_h = tan_v * aspect;
            (tan_h, tan_h / image_aspect)
        }
    }

    /// Where `p` lands in a `width` × `height` picture: (x, y) in pixels from the top-left
    /// corner (pixel centres at half-integers) and the depth in front of the eye. `None` if `p`
    /// is not in front of the near plane.
    pub fn project(&self, p: DVec3, width: u32, height: u32) -> Option<DVec3> {
        let (w, h) = (f64::from(width.max(1)), f64::from(height.max(1)));
        let (tan_h, tan_v) = self.tangents(w / h);
        let q = self.basis().to_view(p - self.eye);
        if q.z.is_nan() || q.z <= self.near {
            return None;
        }
        let x = (0.5 + 0.5 * q.x / (q.z * tan_h)) * w;
        let y = (0.5 - 0.5 * q.y / (q.z * tan_v)) * h;
        Some(DVec3::new(x, y, q.z))
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report
mod tests {
    use super::*;

    fn unit_box() -> Aabb3 {
        Aabb3 { min: DVec3::splat(-1.0), max: DVec3::splat(1.0) }
    }

    #[test]
    fn orbit_angles_follow_the_documented_convention() {
        assert!((orbit_direction(0.0, 0.0) - DVec3::Y).length() < 1e-12);
        assert!((orbit_direction(90.0, 0.0) + DVec3::X).length() < 1e-12);
        assert!((orbit_direction(0.0, 90.0) + DVec3::Z).length() < 1e-12);
    }

    #[test]
    fn framing_centres_the_box_and_keeps_corners_inside() {
        let bbox = unit_box();
        for dir in [DVec3::Y, DVec3::new(1.0, 2.0, -0.5), DVec3::Z, -DVec3::Z] {
            let cam = Camera::framing(&bbox, dir, DVec3::Z, 40.0, 1.5);
            let c = cam.project(DVec3::ZERO, 300, 200).unwrap();
            assert!(c.z > 0.0);
            let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for i in 0..8 {
                let p = DVec3::new(
                    if i & 1 == 0 { -1.0 } else { 1.0 },
                    if i & 2 == 0 { -1.0 } else { 1.0 },
                    if i & 4 == 0 { -1.0 } else { 1.0 },
                );
                let q = cam.project(p, 300, 200).unwrap();
                lo = lo.min(q);
                hi = hi.max(q);
            }
            assert!(lo.x >= 0.0 && lo.y >= 0.0 && hi.x <= 300.0 && hi.y <= 200.0, "{dir}: {lo} {hi}");
            // Tight on at least one axis, and centred on both.
            let slack = (lo.x / 300.0).min(lo.y / 200.0);
            assert!(slack < 0.05, "{dir}: {lo} {hi}");
            assert!(((lo.x + hi.x) / 2.0 - 150.0).abs() < 1e-6, "{dir}: {lo} {hi}");
            assert!(((lo.y + hi.y) / 2.0 - 100.0).abs() < 1e-6, "{dir}: {lo} {hi}");
        }
    }

    #[test]
    fn framing_survives_degenerate_input() {
        let point = Aabb3 { min: DVec3::splat(3.0), max: DVec3::splat(3.0) };
        let cam = Camera::framing(&point, DVec3::ZERO, DVec3::ZERO, f64::NAN, -1.0);
        assert!(cam.eye.is_finite() && cam.near > 0.0);
        assert!(cam.project(DVec3::splat(3.0), 10, 10).is_some());
        let cam = Camera::framing(&Aabb3::EMPTY, DVec3::Z, DVec3::Z, 40.0, 1.0);
        assert!(cam.eye.is_finite());
        assert!(cam.project(DVec3::ZERO, 10, 10).is_some());
    }

    #[test]
    fn other_image_aspects_show_at_least_the_camera_frustum() {
        let cam = Camera::framing(&unit_box(), DVec3::Y, DVec3::Z, 40.0, 1.0);
        for (w, h) in [(100, 100), (300, 100), (100, 300)] {
            for i in 0..8 {
                let p = DVec3::new(
                    if i & 1 == 0 { -1.0 } else { 1.0 },
                    if i & 2 == 0 { -1.0 } else { 1.0 },
                    if i & 4 == 0 { -1.0 } else { 1.0 },
                );
                let q = cam.project(p, w, h).unwrap();
                assert!(q.x >= 0.0 && q.x <= f64::from(w) && q.y >= 0.0 && q.y <= f64::from(h));
            }
        }
    }
}
