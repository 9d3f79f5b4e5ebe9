//! Shared fixtures of the linear-algebra tests: a seeded random generator and boundaries cut by
//! level sets (exact crossing points on edges, as the contact stage produces them).

use glam::DVec3;

use super::{EdgePoint, cut_face_weights};
use crate::mesh::{Topology, TriMesh, shapes};

/// A tiny deterministic generator (64-bit LCG, high bits out) so that tests are seeded.
pub struct Lcg(u64);

impl Lcg {
    pub fn new(seed: u64) -> Self {
        Self(seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407))
    }

    /// The generator whose internal state is `state`: its first value is the one after `state`
    /// (`new(seed)` is `from_state` of the state after `seed`).
    pub fn from_state(state: u64) -> Self {
        Self(state)
    }

    /// Uniform in [0, 1).
    pub fn next_unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [−1, 1).
    pub fn next_signed(&mut self) -> f64 {
        2.0 * self.next_unit() - 1.0
    }

    /// Uniform in `0..n` (n > 0).
    pub fn next_index(&mut self, n: usize) -> usize {
        ((self.next_unit() * n as f64) as usize).min(n - 1)
    }
}

/// The boundary `phi = 0` of the removed side `phi > 0`, the way the contact stage produces it:
/// `phi` is sampled at the vertices and the crossing on each mixed edge is the root of its linear
/// interpolant, `α = phi_i / (phi_i − phi_o)` from the inside vertex `i` (Hertzmann–Zorin style).
pub fn level_set_cut(mesh: &TriMesh, topology: &Topology, phi: impl Fn(DVec3) -> f64) -> (Vec<bool>, Vec<EdgePoint>) {
    let values: Vec<f64> = mesh.positions.iter().map(|&p| phi(p)).collect();
    let inside: Vec<bool> = values.iter().map(|&x| x > 0.0).collect();
    let mut points = Vec::new();
    for &[a, b] in topology.edges() {
        if inside[a as usize] == inside[b as usize] {
            continue;
        }
        let (i, o) = if inside[a as usize] { (a, b) } else { (b, a) };
        let (phi_i, phi_o) = (values[i as usize], values[o as usize]);
        points.push(EdgePoint { inside: i, outside: o, alpha: phi_i / (phi_i - phi_o) });
    }
    (inside, points)
}

/// Removed side: `normal · p > offset`.
pub fn plane_cut(mesh: &TriMesh, topology: &Topology, normal: DVec3, offset: f64) -> (Vec<bool>, Vec<EdgePoint>) {
    level_set_cut(mesh, topology, |p| normal.dot(p) - offset)
}

/// Removed side: the open disk (ball) of `radius` around `centre`, like a contact zone.
pub fn circle_cut(mesh: &TriMesh, topology: &Topology, centre: DVec3, radius: f64) -> (Vec<bool>, Vec<EdgePoint>) {
    level_set_cut(mesh, topology, |p| radius - (p - centre).length())
}

/// An icosphere with its cap `z > 0.35` removed: weights 0, fractional and 1 all occur.
pub fn cut_icosphere() -> (TriMesh, Vec<f64>) {
    let mesh = shapes::icosphere(1.0, 3);
    let topology = Topology::new(&mesh);
    let (inside, points) = plane_cut(&mesh, &topology, DVec3::new(0.1, 0.0, 1.0).normalize(), 0.35);
    let weights = cut_face_weights(&mesh, &topology, &inside, &points).unwrap_or_default();
    (mesh, weights)
}
