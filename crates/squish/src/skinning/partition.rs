//! The shared region ℛ of two overlapping working regions, its partition-of-unity weights β
//! (thesis §6.1.1), and the crease cut that splits ℛ at every frame (§6.1.3).
//!
//! **β (§6.1.1).** ℛ = 𝒲₁ ∩ 𝒲₂. β is harmonic on ℛ (cotangent Laplacian of the *rest pose*, so
//! it never changes over an animation) with β = 1 at the vertices of ℛ on 𝒲₂'s border only (next
//! to 𝒲₁ \ ℛ, where 𝒲₂ stops) and β = 0 at those on 𝒲₁'s border only; vertices on both borders
//! get the natural (Neumann) condition. β weighs 𝒲₁'s result in the blend `p′ = βp′₁ + (1 − β)p′₂`
//! (§6, Eq. at the start of the chapter), so it is extended by 1 over 𝒲₁ \ ℛ and by 0 over 𝒲₂ \ ℛ:
//! the blend is continuous across ℛ's borders. The seeds are imposed exactly and the harmonic
//! values clamped to [0, 1] (the soft constraints of App. B leave them O(1/λ) off).
//!
//! **Crease cut (§6.1.3, Eq. 6.1).** A graph cut over ℛ's vertices and edges labels every vertex of
//! ℛ 𝒲̄₁ or 𝒲̄₂, minimizing `Σ_i D_i(w_i) + Σ_ij K_ij δ(w_i ≠ w_j)` with
//! - the boundary term `K_ij = 0.1 + min_{x ∈ e_ij} |n(x)·d̂|`, n interpolated linearly along the
//!   edge: 0.1 where a silhouette (as seen from d̂) crosses the edge, the smaller end value
//!   otherwise, so the cut runs along the silhouette of the fold;
//! - the regional term from β. *Decision:* the extracted text reads `D_i(𝒲̄₁) = β_i`, which would
//!   send the vertices that blend entirely into 𝒲₁'s result (β = 1) to 𝒲̄₂; the labeling cost must
//!   be low where the vertex belongs to the label, so `D_i(𝒲̄₁) = 1 − β_i`, `D_i(𝒲̄₂) = β_i`
//!   (the cut prefers the iso-line β = ½, as §6.1.3 says). It is multiplied by
//!   `cut_regional_weight` (1 in Eq. 6.1).
//! - *Decision:* the seeds of β are hard constraints (infinite terminal links), so that 𝒲̄₁ always
//!   contains 𝒲₁ \ ℛ's neighbours in ℛ and the two truncated regions never interleave.
//!
//! The minimum cut is found by max-flow ([`super::min_cut`], Dinic's) on integer capacities (the energies
//! quantized to 2⁻²⁰, exact arithmetic, so the result does not depend on round-off); the labels are
//! the source side of the residual graph (the smallest minimum cut), deterministic.

use glam::DVec3;

use super::ArticulationError;
use super::min_cut::Network;
use crate::linalg::{EdgeConstraint, solve_harmonic};
use crate::mesh::{SubMesh, Topology, TriMesh};

/// Which side a vertex of ℛ is tied to by the partition of unity.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Seed {
    /// Free: β is harmonic there.
    Free,
    /// On 𝒲₂'s border only (next to 𝒲₁ \ ℛ): β = 1, always in 𝒲̄₁.
    First,
    /// On 𝒲₁'s border only: β = 0, always in 𝒲̄₂.
    Second,
}

/// ℛ with its weights and the graph of the crease cut, built once on the rest pose.
#[derive(Clone, Debug)]
pub struct SharedRegion {
    /// ℛ's vertices (object ids, increasing).
    pub vertices: Vec<u32>,
    /// Per object vertex: in 𝒲₁, in 𝒲₂.
    pub membership: Vec<[bool; 2]>,
    /// Per object vertex: β (1 on 𝒲₁ \ ℛ, 0 on 𝒲₂ \ ℛ, harmonic on ℛ, NaN outside 𝒲₁ ∪ 𝒲₂).
    pub beta: Vec<f64>,
    /// Per vertex of ℛ (same order as `vertices`): its seed.
    pub seeds: Vec<Seed>,
    /// ℛ's edges as pairs of indices into `vertices`.
    pub edges: Vec<[u32; 2]>,
}

impl SharedRegion {
    /// Builds ℛ, the seeds and β from the two regions' vertex lists on the rest pose `rest`
    /// (`topology` is the object's).
    pub fn new(rest: &TriMesh, topology: &Topology, regions: &[Vec<u32>; 2]) -> Result<Self, ArticulationError> {
        let n = rest.num_vertices();
        let mut membership = vec![[false; 2]; n];
        for (l, list) in regions.iter().enumerate() {
            for &v in list {
                let slot = membership.get_mut(v as usize).ok_or(ArticulationError::VertexOutOfRange {
                    region: l + 1,
                    vertex: v,
                    count: n,
                })?;
                slot[l] = true;
            }
        }
        let vertices: Vec<u32> = (0..n as u32).filter(|&v| membership[v as usize] == [true, true]).collect();
        if vertices.is_empty() {
            return Err(ArticulationError::EmptyRegion {
                what: "the shared region (the two working regions do not overlap)",
                fix: "make the regions overlap around the articulation",
            });
        }
        let mut local = vec![u32::MAX; n];
        for (k, &v) in vertices.iter().enumerate() {
            local[v as usize] = k as u32;
        }
        // Seeds: border of 𝒲₂ only (a neighbour outside 𝒲₂, none outside 𝒲₁) → 1, and vice versa.
        let seeds: Vec<Seed> = vertices
            .iter()
            .map(|&v| {
                let (mut outside_first, mut outside_second) = (false, false);
                for w in topology.vertex_neighbors(v) {
                    let [in1, in2] = membership[w as usize];
                    outside_first |= !in1;
                    outside_second |= !in2;
                }
                match (outside_first, outside_second) {
                    (false, true) => Seed::First,
                    (true, false) => Seed::Second,
                    _ => Seed::Free,
                }
            })
            .collect();
        if !seeds.contains(&Seed::First) || !seeds.contains(&Seed::Second) {
            return Err(ArticulationError::EmptyRegion {
                what: "one side of the shared region's border",
                fix: "the shared region must separate the two regions: each needs vertices of its own next to it",
            });
        }
        let edges: Vec<[u32; 2]> = topology
            .edges()
            .iter()
            .filter_map(|&[a, b]| {
                let (la, lb) = (local[a as usize], local[b as usize]);
                (la != u32::MAX && lb != u32::MAX).then_some([la, lb])
            })
            .collect();

        // β: harmonic on ℛ's faces of the rest pose, seeds as constraints.
        let in_shared: Vec<bool> = (0..n).map(|v| local[v] != u32::MAX).collect();
        let sub = SubMesh::from_vertex_mask(rest, &in_shared);
        let mut beta = vec![f64::NAN; n];
        for (v, m) in membership.iter().enumerate() {
            match m {
                [true, false] => beta[v] = 1.0,
                [false, true] => beta[v] = 0.0,
                _ => {}
            }
        }
        let seed_value = |s: Seed| match s {
            Seed::First => Some(1.0),
            Seed::Second => Some(0.0),
            Seed::Free => None,
        };
        if sub.num_vertices() > 0 {
            let sub_topology = Topology::new(&sub.mesh);
            let constraints: Vec<EdgeConstraint> = sub
                .parent_vertex
                .iter()
                .enumerate()
                .filter_map(|(i, &v)| {
                    seed_value(seeds[local[v as usize] as usize]).map(|b| EdgeConstraint::vertex(i as u32, b))
                })
                .collect();
            let values = solve_harmonic(&sub.mesh, &sub_topology, None, &constraints, 0.5)
                .map_err(|e| ArticulationError::Numerical { stage: "partition of unity β", message: e.to_string() })?;
            for (&v, &b) in sub.parent_vertex.iter().zip(&values) {
                beta[v as usize] = b.clamp(0.0, 1.0);
            }
        }
        for (k, &v) in vertices.iter().enumerate() {
            // Exact seeds; a vertex of ℛ in no face of ℛ takes ½ unless seeded.
            beta[v as usize] =
                seed_value(seeds[k]).unwrap_or(if beta[v as usize].is_nan() { 0.5 } else { beta[v as usize] });
        }
        Ok(Self { vertices, membership, beta, seeds, edges })
    }

    /// Labels ℛ for this frame (see the module doc): `true` = 𝒲̄₁, per vertex of ℛ (same order as
    /// [`Self::vertices`]). `normals` are the object's unit vertex normals at this frame, `d` the
    /// unit mapping direction, `regional_weight` the factor of the β term.
    pub fn crease_cut(&self, normals: &[DVec3], d: DVec3, regional_weight: f64) -> Vec<bool> {
        let m = self.vertices.len();
        // Integer capacities: energies in units of 2⁻²⁰.
        let quantize = |x: f64| (x.max(0.0) * (1u64 << 20) as f64).round() as u64;
        let dots: Vec<f64> = self.vertices.iter().map(|&v| normals[v as usize].dot(d)).collect();
        let boundary: Vec<u64> = self
            .edges
            .iter()
            .map(|&[i, j]| {
                let (a, b) = (dots[i as usize], dots[j as usize]);
                let smallest = if a * b <= 0.0 || a.is_nan() || b.is_nan() { 0.0 } else { a.abs().min(b.abs()) };
                quantize(0.1 + smallest)
            })
            .collect();
        let regional: Vec<[u64; 2]> = self
            .vertices
            .iter()
            .map(|&v| {
                let beta = self.beta[v as usize];
                [quantize(regional_weight * (1.0 - beta)), quantize(regional_weight * beta)]
            })
            .collect();
        let finite: u64 = boundary.iter().map(|&k| 2 * k).chain(regional.iter().map(|r| r[0] + r[1])).sum();
        let infinite = finite.saturating_add(1);

        let (source, sink) = (m, m + 1);
        let mut network = Network::new(m + 2);
        for (&[i, j], &k) in self.edges.iter().zip(&boundary) {
            network.add_pair(i as usize, j as usize, k, k);
        }
        for (k, seed) in self.seeds.iter().enumerate() {
            // Source side = 𝒲̄₁. Cutting source→i labels i 𝒲̄₂ and pays D_i(𝒲̄₂); cutting i→sink
            // labels it 𝒲̄₁ and pays D_i(𝒲̄₁).
            let [cost_first, cost_second] = regional[k];
            let (to_source, to_sink) = match seed {
                Seed::First => (infinite, 0),
                Seed::Second => (0, infinite),
                Seed::Free => (cost_second, cost_first),
            };
            if to_source > 0 {
                network.add_pair(source, k, to_source, 0);
            }
            if to_sink > 0 {
                network.add_pair(k, sink, to_sink, 0);
            }
        }
        let mut side = network.source_side(source, sink);
        side.truncate(m);
        side
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::mesh::shapes;

    /// A capsule along z split at z = 0 with an overlap |z| ≤ half_width.
    fn capsule_regions(half_width: f64) -> (TriMesh, Topology, [Vec<u32>; 2]) {
        let mesh = shapes::capsule(1.0, 4.0, 32, 8, 40);
        let topology = Topology::new(&mesh);
        let first = (0..mesh.num_vertices() as u32).filter(|&v| mesh.positions[v as usize].z <= half_width).collect();
        let second = (0..mesh.num_vertices() as u32).filter(|&v| mesh.positions[v as usize].z >= -half_width).collect();
        (mesh, topology, [first, second])
    }

    #[test]
    fn beta_is_a_partition_of_unity_across_the_shared_region() {
        let (mesh, topology, regions) = capsule_regions(0.6);
        let shared = SharedRegion::new(&mesh, &topology, &regions).unwrap();
        assert!(shared.vertices.iter().all(|&v| mesh.positions[v as usize].z.abs() <= 0.6));
        for (v, p) in mesh.positions.iter().enumerate() {
            let b = shared.beta[v];
            assert!((0.0..=1.0).contains(&b), "β = {b} at {p}");
            if p.z > 0.6 {
                assert_eq!(b, 0.0);
            }
            if p.z < -0.6 {
                assert_eq!(b, 1.0);
            }
        }
        // On a cylinder, harmonic β is linear in z: 1 at the bottom of ℛ, 0 at its top.
        let zs: Vec<f64> = shared.vertices.iter().map(|&v| mesh.positions[v as usize].z).collect();
        let (lo, hi) = zs.iter().fold((f64::MAX, f64::MIN), |(a, b), &z| (a.min(z), b.max(z)));
        for (&v, &z) in shared.vertices.iter().zip(&zs) {
            let linear = (hi - z) / (hi - lo);
            assert!((shared.beta[v as usize] - linear).abs() < 0.02, "z = {z}: β = {}", shared.beta[v as usize]);
        }
        // Monotone along z: β decreases from 𝒲₁'s side to 𝒲₂'s.
        for &[i, j] in &shared.edges {
            let (vi, vj) = (shared.vertices[i as usize] as usize, shared.vertices[j as usize] as usize);
            let (zi, zj) = (mesh.positions[vi].z, mesh.positions[vj].z);
            if (zi - zj).abs() > 1e-9 {
                assert!((shared.beta[vi] - shared.beta[vj]) * (zi - zj) <= 1e-9);
            }
        }
    }

    #[test]
    fn regions_that_do_not_overlap_or_separate_are_errors() {
        let (mesh, topology, _) = capsule_regions(0.6);
        let all: Vec<u32> = (0..mesh.num_vertices() as u32).collect();
        let low: Vec<u32> = all.iter().copied().filter(|&v| mesh.positions[v as usize].z < -0.1).collect();
        let high: Vec<u32> = all.iter().copied().filter(|&v| mesh.positions[v as usize].z > 0.1).collect();
        assert!(matches!(
            SharedRegion::new(&mesh, &topology, &[low.clone(), high]),
            Err(ArticulationError::EmptyRegion { .. })
        ));
        // 𝒲₂ inside 𝒲₁: ℛ = 𝒲₂ has no border with 𝒲₂ \ ℛ.
        assert!(SharedRegion::new(&mesh, &topology, &[all, low]).is_err());
        let out = SharedRegion::new(&mesh, &topology, &[vec![0, 1_000_000], vec![0]]);
        assert!(matches!(out, Err(ArticulationError::VertexOutOfRange { region: 1, .. })));
    }

    #[test]
    fn the_cut_follows_the_silhouette_seen_from_the_direction() {
        let (mesh, topology, regions) = capsule_regions(1.2);
        let shared = SharedRegion::new(&mesh, &topology, &regions).unwrap();
        // A fake normal field whose silhouette seen from d̂ = x is the tilted line z = 0.5·y
        // crossing ℛ, turning from −x to +x within ~0.1 of it as the skin of a fold does: the cut
        // must follow it rather than the iso-line β = ½ (z = 0).
        let normals: Vec<DVec3> = mesh
            .positions
            .iter()
            .map(|p| {
                let s = ((p.z - 0.5 * p.y) / 0.1).tanh();
                DVec3::new(-s, 0.0, (1.0 - s * s).max(0.0).sqrt()).normalize()
            })
            .collect();
        let labels = shared.crease_cut(&normals, DVec3::X, 1.0);
        let mut wrong = 0;
        for (k, &v) in shared.vertices.iter().enumerate() {
            let p = mesh.positions[v as usize];
            let side = p.z - 0.5 * p.y;
            if side.abs() > 0.2 && labels[k] != (side < 0.0) {
                wrong += 1;
            }
        }
        assert_eq!(wrong, 0, "vertices away from the silhouette on the wrong side");
        // Seeds are respected whatever the energy.
        for (k, seed) in shared.seeds.iter().enumerate() {
            match seed {
                Seed::First => assert!(labels[k]),
                Seed::Second => assert!(!labels[k]),
                Seed::Free => {}
            }
        }
        // Without a silhouette (normals orthogonal to d̂ nowhere), the β term puts the cut at β = ½.
        let flat = vec![DVec3::X; mesh.num_vertices()];
        let labels = shared.crease_cut(&flat, DVec3::X, 1.0);
        for (k, &v) in shared.vertices.iter().enumerate() {
            let b = shared.beta[v as usize];
            if (b - 0.5).abs() > 0.1 {
                assert_eq!(labels[k], b > 0.5, "β = {b}");
            }
        }
    }
}
