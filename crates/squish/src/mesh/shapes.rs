//! Procedural shapes for demos, tests and benchmarks, each with a resolution parameter:
//! icosphere, UV sphere, capsule, subdivided grid (open plane), box. All are centred at the
//! origin, counter-clockwise seen from outside, and closed and manifold except the grid.
//!
//! The capsule's axis and the grid's normal are +z, so that "up" is +z as in Blender; rotate with
//! [`TriMesh::map_positions`] for other conventions.

use std::collections::HashMap;
use std::f64::consts::PI;

use glam::DVec3;

use super::TriMesh;

/// Icosphere of the given radius: an icosahedron subdivided `subdivisions` times (each level
/// splits every triangle in four) with vertices pushed onto the sphere.
/// Vertices: 10·4^s + 2; triangles: 20·4^s.
pub fn icosphere(radius: f64, subdivisions: u32) -> TriMesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut positions: Vec<DVec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<DVec3>| -> u32 {
            let key = (a.min(b), a.max(b));
            *midpoints.entry(key).or_insert_with(|| {
                let m = (positions[a as usize] + positions[b as usize]).normalize();
                positions.push(m);
                (positions.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let ab = midpoint(a, b, &mut positions);
            let bc = midpoint(b, c, &mut positions);
            let ca = midpoint(c, a, &mut positions);
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    for p in &mut positions {
        *p *= radius;
    }
    TriMesh { positions, triangles }
}

/// UV sphere with `segments` around the z axis (≥ 3) and `rings` from pole to pole (≥ 2).
/// Vertices: segments·(rings − 1) + 2.
pub fn uv_sphere(radius: f64, segments: u32, rings: u32) -> TriMesh {
    let segments = segments.max(3);
    let rings = rings.max(2);
    let profile: Vec<(f64, f64)> = (1..rings)
        .map(|i| {
            let theta = PI * i as f64 / rings as f64;
            (radius * theta.sin(), radius * theta.cos())
        })
        .collect();
    revolve(&profile, radius, -radius, segments)
}

/// Capsule along z: a cylinder of the given `radius` and `length` (between the hemispheres'
/// centres) closed by two hemispheres. `segments` around the axis, `rings` per hemisphere and
/// `length_rings` rows along the cylinder.
pub fn capsule(radius: f64, length: f64, segments: u32, rings: u32, length_rings: u32) -> TriMesh {
    let segments = segments.max(3);
    let rings = rings.max(1);
    let length_rings = length_rings.max(1);
    let half = 0.5 * length;
    let mut profile = Vec::new();
    for i in 1..=rings {
        let theta = 0.5 * PI * i as f64 / rings as f64;
        profile.push((radius * theta.sin(), half + radius * theta.cos()));
    }
    for i in 1..length_rings {
        profile.push((radius, half - length * i as f64 / length_rings as f64));
    }
    for i in 0..rings {
        let theta = 0.5 * PI + 0.5 * PI * i as f64 / rings as f64;
        profile.push((radius * theta.sin(), -half + radius * theta.cos()));
    }
    revolve(&profile, half + radius, -half - radius, segments)
}

/// A surface of revolution around z: `profile` lists (radius, z) rings from top to bottom,
/// closed by a top pole at `z_top` and a bottom pole at `z_bottom`.
fn revolve(profile: &[(f64, f64)], z_top: f64, z_bottom: f64, segments: u32) -> TriMesh {
    let mut positions = vec![DVec3::new(0.0, 0.0, z_top)];
    for &(r, z) in profile {
        for j in 0..segments {
            let phi = 2.0 * PI * j as f64 / segments as f64;
            positions.push(DVec3::new(r * phi.cos(), r * phi.sin(), z));
        }
    }
    positions.push(DVec3::new(0.0, 0.0, z_bottom));
    let bottom = (positions.len() - 1) as u32;
    let ring = |i: usize, j: u32| 1 + (i as u32) * segments + j % segments;
    let mut triangles = Vec::new();
    for j in 0..segments {
        triangles.push([0, ring(0, j), ring(0, j + 1)]);
    }
    for i in 0..profile.len() - 1 {
        for j in 0..segments {
            let (a, b, c, d) = (ring(i, j), ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1));
            triangles.push([a, c, d]);
            triangles.push([a, d, b]);
        }
    }
    let last = profile.len() - 1;
    for j in 0..segments {
        triangles.push([bottom, ring(last, j + 1), ring(last, j)]);
    }
    TriMesh { positions, triangles }
}

/// An open rectangular grid in the xy plane (normal +z), `width` along x and `depth` along y,
/// with `nx` × `ny` cells split into two triangles each along alternating diagonals (so that the
/// grid has no preferred diagonal direction). Vertices: (nx + 1)(ny + 1).
pub fn grid(width: f64, depth: f64, nx: u32, ny: u32) -> TriMesh {
    let (nx, ny) = (nx.max(1), ny.max(1));
    let mut positions = Vec::with_capacity(((nx + 1) * (ny + 1)) as usize);
    for j in 0..=ny {
        for i in 0..=nx {
            positions.push(DVec3::new(width * (i as f64 / nx as f64 - 0.5), depth * (j as f64 / ny as f64 - 0.5), 0.0));
        }
    }
    let id = |i: u32, j: u32| j * (nx + 1) + i;
    let mut triangles = Vec::with_capacity((2 * nx * ny) as usize);
    for j in 0..ny {
        for i in 0..nx {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            if (i + j) % 2 == 0 {
                triangles.push([a, b, c]);
                triangles.push([a, c, d]);
            } else {
                triangles.push([a, b, d]);
                triangles.push([b, c, d]);
            }
        }
    }
    TriMesh { positions, triangles }
}

/// A closed axis-aligned box of the given size centred at the origin, each face a grid of
/// `n` × `n` cells (along each axis the number of cells is `n`).
pub fn cuboid(size: DVec3, n: u32) -> TriMesh {
    let n = n.max(1);
    let mut mesh = TriMesh::default();
    let mut index: HashMap<[i64; 3], u32> = HashMap::new();
    // Each face: an origin corner and two axes spanning it, ordered so that u × v points outward.
    let faces: [(DVec3, DVec3, DVec3); 6] = [
        (DVec3::new(1.0, -1.0, -1.0), DVec3::Y, DVec3::Z),
        (DVec3::new(-1.0, -1.0, -1.0), DVec3::Z, DVec3::Y),
        (DVec3::new(-1.0, 1.0, -1.0), DVec3::Z, DVec3::X),
        (DVec3::new(-1.0, -1.0, -1.0), DVec3::X, DVec3::Z),
        (DVec3::new(-1.0, -1.0, 1.0), DVec3::X, DVec3::Y),
        (DVec3::new(-1.0, -1.0, -1.0), DVec3::Y, DVec3::X),
    ];
    for (origin, u, v) in faces {
        let mut ids = vec![0u32; ((n + 1) * (n + 1)) as usize];
        for j in 0..=n {
            for i in 0..=n {
                // Integer lattice coordinates in [−n, n] so that shared edge vertices weld exactly.
                let lattice = origin * n as f64 + (u * i as f64 + v * j as f64) * 2.0;
                let key = [lattice.x as i64, lattice.y as i64, lattice.z as i64];
                let id = *index.entry(key).or_insert_with(|| {
                    mesh.positions.push(0.5 * size * lattice / n as f64);
                    (mesh.positions.len() - 1) as u32
                });
                ids[(j * (n + 1) + i) as usize] = id;
            }
        }
        let at = |i: u32, j: u32| ids[(j * (n + 1) + i) as usize];
        for j in 0..n {
            for i in 0..n {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                if (i + j) % 2 == 0 {
                    mesh.triangles.push([a, b, c]);
                    mesh.triangles.push([a, c, d]);
                } else {
                    mesh.triangles.push([a, b, d]);
                    mesh.triangles.push([b, c, d]);
                }
            }
        }
    }
    mesh
}

/// A closed cube of edge `size` with `n` × `n` cells per face.
pub fn cube(size: f64, n: u32) -> TriMesh {
    cuboid(DVec3::splat(size), n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{Topology, signed_volume};

    fn assert_closed_manifold(mesh: &TriMesh) {
        mesh.check_for_deformation().expect("valid mesh");
        let topo = Topology::new(mesh);
        assert!(topo.is_closed());
        assert_eq!(topo.euler_characteristic(), 2);
        assert!(signed_volume(mesh) > 0.0, "outward orientation");
    }

    #[test]
    fn closed_shapes_are_closed_manifold_spheres() {
        assert_closed_manifold(&icosphere(1.0, 0));
        assert_closed_manifold(&icosphere(1.0, 3));
        assert_closed_manifold(&uv_sphere(1.0, 16, 9));
        assert_closed_manifold(&capsule(0.5, 2.0, 16, 4, 6));
        assert_closed_manifold(&cube(1.0, 1));
        assert_closed_manifold(&cuboid(DVec3::new(2.0, 1.0, 0.5), 5));
    }

    #[test]
    fn shape_sizes_follow_their_parameters() {
        assert_eq!(icosphere(1.0, 2).num_vertices(), 162);
        assert_eq!(uv_sphere(1.0, 16, 8).num_vertices(), 16 * 7 + 2);
        assert_eq!(grid(1.0, 1.0, 10, 5).num_vertices(), 66);
        assert_eq!(cube(1.0, 4).num_vertices(), 6 * 16 + 2);
        let cube_volume = signed_volume(&cuboid(DVec3::new(2.0, 3.0, 4.0), 3));
        assert!((cube_volume - 24.0).abs() < 1e-12);
        // A capsule's volume approaches πr²L + 4/3 πr³ from below.
        let (r, l) = (0.5, 2.0);
        let exact = PI * r * r * l + 4.0 / 3.0 * PI * r.powi(3);
        let v = signed_volume(&capsule(r, l, 64, 16, 8));
        assert!(v < exact && v > 0.99 * exact, "{v} vs {exact}");
    }

    #[test]
    fn grid_is_an_open_disk_facing_up() {
        let mesh = grid(2.0, 1.0, 8, 4);
        mesh.check_for_deformation().expect("valid grid");
        let topo = Topology::new(&mesh);
        assert_eq!(topo.boundary_loops(&mesh).len(), 1);
        assert_eq!(topo.euler_characteristic(), 1);
        for n in crate::mesh::face_normals(&mesh) {
            assert!((n - DVec3::Z).length() < 1e-12);
        }
    }
}
