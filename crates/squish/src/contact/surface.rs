//! The potential contact surface 𝒮 (thesis §4.3) at the samples of the mapping regions.
//!
//! **Positions.** With the relative stiffnesses k̄_a = k_a / (k_a + k_b), k̄_b = 1 − k̄_a (a rigid
//! object: k̄ = 1 for it, 0 for the other), a point p of a matched to p″ on b moves by the
//! displacement δ = p″ − p to p′ = p + k̄_b·δ, and a point of b to p′ = p + k̄_a·δ: 𝒮 is b's
//! surface when b is rigid, a's when a is rigid (the algorithm box's p + (1 − k̄)δ).
//!
//! **Normals — decision.** The extracted thesis formula for the implicit function F swaps k̄_1 and
//! k̄_2 and its ζ has a sign error; we re-derive it. Along d̂, 𝒮 = {k̄_a P_a(x) + k̄_b P_b(x)},
//! with P_l(x) the projection of x along d̂ onto mesh l. Writing mesh l locally as a height
//! h_l over the plane ⟂ d̂ with normal n_l, ∇h_l = −(I − d̂d̂ᵀ) n_l / (n_l·d̂), so the gradient of
//! F(x) = k̄_a h_a + k̄_b h_b − x·d̂ is parallel to
//! g = (I − d̂d̂ᵀ)(k̄_a n_a/(n_a·d̂) + k̄_b n_b/(n_b·d̂)) + d̂. Multiplying by |n_a·d̂||n_b·d̂| ≥ 0
//! removes the divisions:
//!
//! ζ = (I − d̂d̂ᵀ)(k̄_a |n_b·d̂| sgn(n_a·d̂) n_a + k̄_b |n_a·d̂| sgn(n_b·d̂) n_b) + |n_a·d̂||n_b·d̂| d̂,
//!
//! where for a point of a, n_a is its own (interpolated) normal and n_b = n″ at its match, and
//! for a point of b the other way round. Checks: k̄_a = 1 gives ζ ∥ n_a (𝒮 is a); a flat contact
//! (n_a = −d̂, n_b = d̂) gives ζ ∥ d̂. Orientation: n′ = −ζ/|ζ| for points of a (outward of a,
//! n′·d̂ ≤ 0), n′ = +ζ/|ζ| for points of b; if |ζ| ≈ 0, n′ = ∓d̂. At sgn(0) the sign of a
//! front-facing normal is taken (n_a·d̂ ≤ 0, n_b·d̂ ≥ 0), so ζ does not flip at grazing normals;
//! zero means |n·d̂| ≤ 10⁻¹² ([`GRAZING`]): the boundary points of a projected region lie on a
//! silhouette, where n·d̂ = 0 comes out of the arithmetic as ±10⁻¹⁷, and a sign taken from that
//! round-off flipped n′ — and the point's penetration c — from one frame to the next of a
//! skinned walk whose input moved by 2·10⁻⁸ (docs/self-contact.md, "A silhouette's sign").
//!
//! Written per side with `toward` = +d̂ for a and −d̂ for b, the same expression with
//! (own, other) in place of (a, b) and `toward` in place of d̂ gives n′ = −ζ/|ζ| on both sides.
//!
//! **Penetration.** The contact criterion's per-point value is c = −δᵀn′: positive where the
//! point is inside the other object, negative where there is a gap, and the same at a point of a
//! and at its match on b (δ and n′ both flip).

use glam::DVec3;

use super::mapping::{Match, SideMapping};
use super::{ContactSide, Sample};

/// A sample of a mapping region with its match and its point on 𝒮.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SurfaceSample {
    /// Position p on its own mesh.
    pub position: DVec3,
    /// Own unit normal n (interpolated and normalized at boundary points).
    pub normal: DVec3,
    /// The match p″ on the other mesh.
    pub matched: DVec3,
    /// Unit normal of the other mesh at the match, n″.
    pub match_normal: DVec3,
    /// Point on 𝒮, p′ = p + k̄_other·δ.
    pub target: DVec3,
    /// Unit normal of 𝒮 there, oriented outward from this sample's mesh (n′).
    pub surface_normal: DVec3,
    /// Penetration along 𝒮's normal, c = −δᵀn′ (positive inside the other object).
    pub depth: f64,
}

impl SurfaceSample {
    /// δ = p″ − p.
    pub fn displacement(&self) -> DVec3 {
        self.matched - self.position
    }
}

/// |n·d̂| at or below which a unit normal counts as grazing (n·d̂ = 0) for the signs of ζ:
/// many times the round-off of a dot product of unit vectors, far below any slope a mesh has.
const GRAZING: f64 = 1e-12;

/// The unit normal n′ of 𝒮 at a point of one side (module docs): `own` and `other` are the two
/// meshes' normals there, `toward` is +d̂ for a point of a and −d̂ for a point of b, `k_own` and
/// `k_other` the relative stiffnesses. Outward from the point's own mesh.
pub fn surface_normal(own: DVec3, other: DVec3, toward: DVec3, k_own: f64, k_other: f64) -> DVec3 {
    let (g_own, g_other) = (own.dot(toward), other.dot(toward));
    // Front-facing sides of the signs at zero (own faces −toward, other faces +toward), zero
    // taken within the round-off of a dot product of unit vectors: a boundary point on a
    // silhouette has n·d̂ = 0 by construction, computed as ±1e-17.
    let s_own = if g_own > GRAZING { 1.0 } else { -1.0 };
    let s_other = if g_other < -GRAZING { -1.0 } else { 1.0 };
    let tangential = k_own * g_other.abs() * s_own * own + k_other * g_own.abs() * s_other * other;
    let zeta = tangential - toward * tangential.dot(toward) + toward * (g_own.abs() * g_other.abs());
    match (-zeta).try_normalize() {
        // |ζ| ≈ 0 within round-off of its terms: the contact direction itself.
        Some(n) if zeta.length_squared() > 1e-30 * (1.0 + tangential.length_squared()) => n,
        _ => -toward,
    }
}

/// The sample of 𝒮 for a point `p` with own normal `n` matched to `m`.
pub fn surface_sample(p: DVec3, n: DVec3, m: &Match, toward: DVec3, k_own: f64, k_other: f64) -> SurfaceSample {
    let delta = m.point - p;
    let surface_normal = surface_normal(n, m.normal, toward, k_own, k_other);
    SurfaceSample {
        position: p,
        normal: n,
        matched: m.point,
        match_normal: m.normal,
        target: p + k_other * delta,
        surface_normal,
        depth: -delta.dot(surface_normal),
    }
}

/// 𝒮 at the samples of one side's mapping region.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SideSurface {
    /// One per vertex of [`SideMapping::vertices`].
    pub vertex_samples: Vec<SurfaceSample>,
    /// One per boundary point of [`SideMapping::region`].
    pub point_samples: Vec<SurfaceSample>,
}

impl SideSurface {
    /// The sample of a point of ℳ (`None` for a vertex outside ℳ).
    pub fn sample(&self, mapping: &SideMapping, sample: Sample) -> Option<&SurfaceSample> {
        match sample {
            Sample::Vertex(v) => match mapping.vertex_slot.get(v as usize) {
                Some(&s) if s != super::mapping::NO_SLOT => self.vertex_samples.get(s as usize),
                _ => None,
            },
            Sample::Point(p) => self.point_samples.get(p as usize),
        }
    }
}

/// Own unit normal of `side` at a sample of `region` (interpolated and normalized).
pub fn own_normal(side: &ContactSide, region: &super::EdgeRegion, sample: Sample) -> DVec3 {
    region.interpolate(side.normals, sample).normalize_or_zero()
}

/// 𝒮 at every sample of `mapping` (side with direction `toward` and relative stiffnesses).
pub fn side_surface(side: &ContactSide, mapping: &SideMapping, toward: DVec3, k_own: f64, k_other: f64) -> SideSurface {
    let region = &mapping.region;
    let vertex_samples = mapping
        .vertices
        .iter()
        .zip(&mapping.vertex_matches)
        .map(|(&v, m)| {
            let s = Sample::Vertex(v);
            surface_sample(side.mesh.positions[v as usize], own_normal(side, region, s), m, toward, k_own, k_other)
        })
        .collect();
    let point_samples = mapping
        .point_matches
        .iter()
        .enumerate()
        .map(|(k, m)| {
            let s = Sample::Point(k as u32);
            surface_sample(
                region.point_position(side.mesh, k as u32),
                own_normal(side, region, s),
                m,
                toward,
                k_own,
                k_other,
            )
        })
        .collect();
    SideSurface { vertex_samples, point_samples }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z).normalize()
    }

    /// A rigid tilted plane as b (k̄_b = 1): 𝒮 is the plane, so n′ is its normal on b's side and
    /// the opposite on a's side, whatever a's normal.
    #[test]
    fn a_rigid_tilted_plane_gives_its_normal() {
        let d = DVec3::Z;
        let plane = unit(0.3, -0.2, 1.0);
        for own in [unit(0.1, 0.4, -1.0), unit(-0.5, 0.0, -0.6), unit(0.0, 0.0, -1.0)] {
            // A point of a (elastic, k̄_a = 0) matched on the plane.
            let n_a = surface_normal(own, plane, d, 0.0, 1.0);
            assert!((n_a + plane).length() < 1e-12, "{n_a}");
            // A point of the plane (b) matched on a.
            let n_b = surface_normal(plane, own, -d, 1.0, 0.0);
            assert!((n_b - plane).length() < 1e-12, "{n_b}");
        }
        // Displacements: a point of a moves all the way to the plane, a point of b stays.
        let m = Match { point: DVec3::new(0.0, 0.0, 0.1), normal: plane, ..Default::default() };
        let s = surface_sample(DVec3::new(0.0, 0.0, -0.2), unit(0.0, 0.0, -1.0), &m, d, 0.0, 1.0);
        assert!((s.target - m.point).length() < 1e-15);
        // Penetration 0.3 along z, measured along the plane's normal.
        assert!((s.depth - 0.3 * plane.z).abs() < 1e-12, "{}", s.depth);
    }

    /// Flat contact: n′ = ∓d̂; and symmetric normals about the plane ⟂ d̂ with equal stiffness
    /// give n′ = ∓d̂ too (𝒮 is the mid-plane), with n′ on a's side = −(n′ on b's side).
    #[test]
    fn flat_and_symmetric_contacts_give_the_contact_direction() {
        let d = unit(0.2, 0.1, 1.0);
        assert!((surface_normal(-d, d, d, 0.5, 0.5) + d).length() < 1e-12);
        assert!((surface_normal(d, -d, -d, 0.5, 0.5) - d).length() < 1e-12);
        let d = DVec3::Z;
        let n_a = unit(0.4, -0.3, -1.0);
        let n_b = DVec3::new(n_a.x, n_a.y, -n_a.z); // mirror of n_a through the plane z = 0
        let on_a = surface_normal(n_a, n_b, d, 0.5, 0.5);
        let on_b = surface_normal(n_b, n_a, -d, 0.5, 0.5);
        assert!((on_a + d).length() < 1e-12, "{on_a}");
        assert!((on_a + on_b).length() < 1e-12, "{on_a} {on_b}");
        // Stiffness 1 on a: 𝒮 is a, n′ = n_a on a's side.
        assert!((surface_normal(n_a, n_b, d, 1.0, 0.0) - n_a).length() < 1e-12);
    }

    /// n′ on a's side and on b's side at the same point of 𝒮 are opposite for any stiffness (the
    /// formula is the same gradient seen from both sides).
    #[test]
    fn both_sides_see_opposite_normals_of_the_same_surface() {
        let d = unit(-0.1, 0.2, 1.0);
        let n_a = unit(0.3, 0.5, -1.0);
        let n_b = unit(-0.6, 0.1, 0.8);
        for k in [0.0, 0.2, 0.5, 0.9, 1.0] {
            let on_a = surface_normal(n_a, n_b, d, k, 1.0 - k);
            let on_b = surface_normal(n_b, n_a, -d, 1.0 - k, k);
            assert!((on_a + on_b).length() < 1e-12, "k = {k}: {on_a} {on_b}");
            assert!(on_a.dot(d) <= 0.0);
        }
    }

    /// A grazing normal (a boundary point on a silhouette: n·d̂ = 0, computed as ±10⁻¹⁷) takes
    /// the front-facing sign whichever side of zero its round-off fell, so n′ and the penetration
    /// do not flip; a normal that truly faces away still flips them.
    #[test]
    fn a_grazing_normal_takes_the_front_facing_sign_whatever_its_round_off() {
        let d = DVec3::Z;
        let other = unit(0.2, -0.4, 0.55);
        let m = Match { point: DVec3::new(0.03, 0.01, 0.001), normal: other, ..Default::default() };
        let sample = |z: f64| surface_sample(DVec3::ZERO, DVec3::new(1.0, 0.0, z), &m, d, 0.5, 0.5);
        let (above, below, zero) = (sample(2.8e-17), sample(-4.2e-17), sample(0.0));
        for s in [above, below] {
            assert!((s.surface_normal - zero.surface_normal).length() < 1e-12, "{s:?}");
            assert!((s.depth - zero.depth).abs() < 1e-12, "{} {}", s.depth, zero.depth);
        }
        assert!(zero.depth.abs() > 1e-3, "{}", zero.depth);
        // Facing away by a slope of 10⁻⁶: the other sign, the penetration of the other sign.
        let away = sample(1e-6);
        assert!(away.depth * zero.depth < 0.0, "{} {}", away.depth, zero.depth);
    }
}
