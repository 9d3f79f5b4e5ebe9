//! The automatic deformation extent φ_max (thesis §5.1, §7.1) and the object size that bounds it.
//!
//! **Rule** ([`automatic_extent`]): φ_max = max(min(K_SIZE·r, max(K_CONTACT·ρ, K_EDGE·h)), K_FLOOR·ρ)
//! with ρ = √(A/π) the radius of the region's contact (A the largest contact area of its pairs
//! at this frame), r the object's size ([`object_size`]; of the connected components the region
//! touches) and h their mean edge length. Read it as: the deformation reaches a fixed multiple of
//! the contact's own radius (an elastic body's displacement around a contact of radius a decays
//! like a²/ϱ at a distance ϱ, Boussinesq/Hertz, so how far it spreads scales with a — which holds
//! the depth and the local curvature, a² ≈ R·δ), bounded by the object's size (a small sphere
//! pressed deforms whole, up to its far side, and no further), never below a couple of edges (a
//! first touch still has a smooth dent) nor below the contact's own width (the bulge must not be
//! squeezed into a band narrower than the contact). The stiffness ratio of the pair does not enter:
//! it splits the approach between the bodies (the contact stage's k̄), while the shape of each
//! body's displacement field, and so its reach, follows the contact radius alone.
//!
//! **Calibration** against the FEM + IPC references of `data/fem/` (docs/plausibility.md,
//! docs/decisions.md "Automatic extent"): K_SIZE = 2 and K_CONTACT = 7 give the smallest
//! contact-side Hausdorff distances over 5–20% approach on a sphere pressed on a plane, on equal
//! spheres and on spheres of radius ratio 2 and 4; K_EDGE and K_FLOOR only act outside them.
//!
//! Conventions: every input is continuous in the geometry over an animation (the contact area
//! is, from its exact boundary points), so the extent is; it is invariant under rigid motions and
//! scales with a uniform scaling of the scene. An object's size is its area-weighted RMS distance
//! to its area-weighted centroid (the radius for a sphere).

use glam::DVec3;

use crate::mesh::{TriMesh, vertex_areas};

/// Bound of the automatic extent in object sizes (a pressed sphere deforms whole, no further).
pub const EXTENT_SIZE_FACTOR: f64 = 2.0;
/// The automatic extent in contact radii √(A/π), within the size bound.
pub const EXTENT_CONTACT_FACTOR: f64 = 7.0;
/// Smallest automatic extent in mean edge lengths (a first touch still has a smooth dent).
pub const EXTENT_EDGE_FACTOR: f64 = 2.0;
/// Smallest automatic extent in contact radii, whatever the size bound: the bulge must not be
/// squeezed into a band narrower than the contact, which folds the surface of deep contacts.
pub const EXTENT_CONTACT_FLOOR: f64 = 1.5;

/// The automatic extent φ_max of a region (used when `ObjectParams::extent` is `None`; the rule
/// and its calibration: module doc): `size` the size r of the components it touches
/// ([`object_size`]), `contact_area` the largest contact area A of its pairs at this frame,
/// `edge_length` the mean edge length h of those components.
///
/// Positive whenever `size` or `contact_area` is; continuous in every input.
pub fn automatic_extent(size: f64, contact_area: f64, edge_length: f64) -> f64 {
    let contact_radius = (contact_area.max(0.0) / std::f64::consts::PI).sqrt();
    let reach = (EXTENT_CONTACT_FACTOR * contact_radius).max(EXTENT_EDGE_FACTOR * edge_length.max(0.0));
    (EXTENT_SIZE_FACTOR * size).min(reach).max(EXTENT_CONTACT_FLOOR * contact_radius)
}

/// Area-weighted RMS distance of a mesh to its area-weighted centroid (see the module doc).
pub fn object_size(mesh: &TriMesh) -> f64 {
    size_from_areas(mesh, &vertex_areas(mesh))
}

/// [`object_size`] with the lumped vertex areas given; 0 for a mesh without area.
pub fn size_from_areas(mesh: &TriMesh, areas: &[f64]) -> f64 {
    let total: f64 = areas.iter().sum();
    if total.is_nan() || total <= 0.0 {
        return 0.0;
    }
    let centroid = mesh.positions.iter().zip(areas).map(|(p, a)| *p * *a).sum::<DVec3>() / total;
    let spread: f64 = mesh.positions.iter().zip(areas).map(|(p, a)| a * (*p - centroid).length_squared()).sum();
    (spread / total).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes;

    #[test]
    fn the_extent_follows_the_contact_within_the_objects_size() {
        let sphere = shapes::icosphere(50.0, 4);
        let r = object_size(&sphere);
        assert!((r - 50.0).abs() < 0.5, "{r}");
        let area = |rho: f64| std::f64::consts::PI * rho * rho;
        // A contact of radius 5 on the sphere of radius 50 (edges ≈ 4): 7 contact radii.
        assert!((automatic_extent(r, area(5.0), 4.0) - 35.0).abs() < 1e-9);
        // A wide contact: bounded by twice the size...
        assert!((automatic_extent(r, area(20.0), 4.0) - 2.0 * r).abs() < 1e-9);
        // ...but never narrower than 1.5 contact radii.
        assert!((automatic_extent(r, area(80.0), 4.0) - 120.0).abs() < 1e-9);
        // A first touch: two edges.
        assert!((automatic_extent(r, 0.0, 4.0) - 8.0).abs() < 1e-12);
        // Uniform scaling scales it.
        let scaled = automatic_extent(3.0 * r, area(15.0), 12.0);
        assert!((scaled - 3.0 * automatic_extent(r, area(5.0), 4.0)).abs() < 1e-9);
        assert_eq!(size_from_areas(&sphere, &vec![0.0; sphere.num_vertices()]), 0.0);
    }

    #[test]
    fn the_extent_is_continuous_as_a_contact_grows_from_nothing() {
        // The contact radius grows from 0 past the size bound; the extent never jumps.
        let (size, edge) = (1.0, 0.05);
        let mut previous = automatic_extent(size, 0.0, edge);
        assert!(previous > 0.0);
        let step = 1e-4;
        for k in 1..=20_000 {
            let rho = k as f64 * step;
            let extent = automatic_extent(size, std::f64::consts::PI * rho * rho, edge);
            // Lipschitz in ρ with the largest factor: 7.
            assert!((extent - previous).abs() <= EXTENT_CONTACT_FACTOR * step * (1.0 + 1e-9), "ρ = {rho}");
            assert!(extent >= previous, "the extent never shrinks as the contact grows (ρ = {rho})");
            previous = extent;
        }
    }
}
