//! The automatic deformation extent φ_max (thesis §5.1, §7.1; Fig. 5.5, 7.23) and the object size
//! it scales with.
//!
//! An object's size is its area-weighted RMS distance to its area-weighted centroid (the radius
//! for a sphere): invariant under rigid motions and continuous with the geometry, so an extent
//! derived from it is continuous over an animation.

use glam::DVec3;

use crate::mesh::{TriMesh, vertex_areas};

/// The automatic extent φ_max of an object (used when `ObjectParams::extent` is `None`):
/// `max(min(1.2·r, 3·r_partner), 1.5·ρ)`, where r is the object's size ([`object_size`]),
/// r_partner the smallest size among the objects it is paired with, and ρ = √(A/π) the radius of
/// the largest contact area A of its pairs at this frame.
///
/// The terms follow the thesis' choices (§7.1, Fig. 5.5, 7.23): φ_max = 60 for a sphere of
/// diameter 100 (1.2·r) and 150 for the plane it presses (3·r of the sphere: a large object's
/// deformation is limited by the size of what presses it). The contact term keeps the bulge from
/// being squeezed into a band narrower than the contact, which folds the surface for deep
/// contacts. Every term is continuous over an animation, so the automatic extent is too.
///
/// With working regions, each region gets its own extent: r is the size of the connected
/// components of its object that it touches (the object's size for a one-piece object; a finger's
/// size when the fingers are separate components), r_partner the smallest such size among the
/// regions it is paired with, A the largest contact area of its region pairs.
pub fn automatic_extent(size: f64, partner_size: f64, contact_area: f64) -> f64 {
    (1.2 * size).min(3.0 * partner_size).max(1.5 * (contact_area.max(0.0) / std::f64::consts::PI).sqrt())
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
    fn the_size_of_a_sphere_is_its_radius_and_the_extent_follows_the_thesis() {
        let sphere = shapes::icosphere(50.0, 4);
        let r = object_size(&sphere);
        assert!((r - 50.0).abs() < 0.5, "{r}");
        // φ_max = 60 for the sphere of diameter 100, 150 for the plane it presses (its partner).
        assert!((automatic_extent(r, f64::INFINITY, 0.0) - 1.2 * r).abs() < 1e-12);
        assert!((automatic_extent(f64::INFINITY, r, 0.0) - 3.0 * r).abs() < 1e-12);
        // A contact wider than the size term widens the extent.
        let area = std::f64::consts::PI * 100.0 * 100.0;
        assert!((automatic_extent(r, r, area) - 150.0).abs() < 1e-9);
        assert_eq!(size_from_areas(&sphere, &vec![0.0; sphere.num_vertices()]), 0.0);
    }
}
