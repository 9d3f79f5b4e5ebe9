#![allow(clippy::unwrap_used)]

use super::*;
use crate::mesh::{face_normals, shapes};
use crate::skinning::{ArticulationDirection, ArticulationParams};

/// A capsule along z (radius 0.5, from z = −3.5 to 3.5) skinned on two bones meeting at the
/// origin: the child bone bends toward +y by `angle` (radians) about the x axis. Weights blend
/// over |z| ≤ 0.6 (smoothstep).
struct BentCapsule {
    rest: TriMesh,
    topology: Topology,
    child_weight: Vec<f64>,
}

impl BentCapsule {
    fn new(segments: u32, length_rings: u32) -> Self {
        let rest = shapes::capsule(0.5, 6.0, segments, 8, length_rings);
        let topology = Topology::new(&rest);
        let child_weight = rest
            .positions
            .iter()
            .map(|p| {
                let b: f64 = std::env::var("BLEND").ok().and_then(|s| s.parse().ok()).unwrap_or(0.6);
                let x = ((p.z + b) / (2.0 * b)).clamp(0.0, 1.0);
                x * x * (3.0 - 2.0 * x)
            })
            .collect();
        Self { rest, topology, child_weight }
    }

    fn rotation(angle: f64) -> glam::DMat3 {
        glam::DMat3::from_axis_angle(DVec3::NEG_X, angle)
    }

    /// The linear-blend-skinned mesh.
    fn posed(&self, angle: f64) -> TriMesh {
        let r = Self::rotation(angle);
        let positions =
            self.rest.positions.iter().zip(&self.child_weight).map(|(p, &w)| (1.0 - w) * *p + w * (r * *p)).collect();
        TriMesh { positions, triangles: self.rest.triangles.clone() }
    }

    fn joints(angle: f64) -> [DVec3; 3] {
        [DVec3::new(0.0, 0.0, -3.0), DVec3::ZERO, Self::rotation(angle) * DVec3::new(0.0, 0.0, 3.0)]
    }

    fn articulation(&self, angle: f64) -> Articulation {
        let first = (0..self.rest.num_vertices() as u32).filter(|&v| 1.0 - self.child_weight[v as usize] >= 0.05).collect();
        let second = (0..self.rest.num_vertices() as u32).filter(|&v| self.child_weight[v as usize] >= 0.05).collect();
        Articulation {
            name: "elbow".into(),
            regions: [first, second],
            direction: ArticulationDirection::Joints(Self::joints(angle)),
            params: ArticulationParams::default(),
        }
    }
}

/// One frame: plan and apply.
fn run(
    capsule: &BentCapsule,
    setup: &mut ArticulationSetup,
    mesh: &TriMesh,
    articulation: &Articulation,
) -> (Vec<DVec3>, ArticulationPlan, AppliedArticulations) {
    let normals = crate::mesh::vertex_normals(mesh);
    let params = DeformParams::new(1.0);
    let plan = plan_articulation(mesh, &capsule.topology, &normals, setup, articulation, &params).unwrap();
    let applied = apply_articulations(mesh, std::slice::from_ref(&plan), true, 0.0, 1.0).unwrap();
    (applied.positions.clone(), plan, applied)
}

#[test]
fn bent_capsule_sweep() {
    let capsule = BentCapsule::new(40, 60);
    let mut setup = ArticulationSetup::new(&capsule.rest, &capsule.topology, &capsule.articulation(0.0), &capsule.rest).unwrap();
    let frames = 60;
    let mut previous: Option<(TriMesh, Vec<DVec3>, Vec<bool>)> = None;
    for frame in 0..=frames {
        let angle = 150f64.to_radians() * frame as f64 / frames as f64;
        let mesh = capsule.posed(angle);
        let articulation = capsule.articulation(angle);
        let (out, plan, applied) = run(&capsule, &mut setup, &mesh, &articulation);
        let result = TriMesh { positions: out.clone(), triangles: mesh.triangles.clone() };
        let before = count_self_intersections(&mesh, setup.faces()).unwrap();
        let after = count_self_intersections(&result, setup.faces()).unwrap();
        let v0 = signed_volume(&mesh);
        let dv = (signed_volume(&result) - v0) / v0;
        let flipped = face_normals(&mesh).iter().zip(face_normals(&result)).filter(|(a, b)| a.dot(*b) <= 0.0).count();
        let (step_in, step_out) = previous.as_ref().map_or((0.0, 0.0), |(m, o, _)| {
            let si = m.positions.iter().zip(&mesh.positions).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
            let so = o.iter().zip(&out).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
            (si, so)
        });
        let flips = previous.as_ref().map_or(0, |(_, _, l)| l.iter().zip(&plan.labels).filter(|(a, b)| a != b).count());
        eprintln!(
            "frame {frame:2} angle {:5.1} si {before:4} -> {after:3}  dV {dv:9.2e}  flipped {flipped:3}  step {:.4}/{:.4} = {:5.2}  cut {} flips {flips}  C {:?} D {:?} ext {:.3} h {:?} area {:.3}",
            angle.to_degrees(),
            step_out,
            step_in,
            if step_in > 0.0 { step_out / step_in } else { 0.0 },
            plan.stats.cut_edges,
            plan.stats.contact_vertices,
            plan.stats.deformable_vertices,
            plan.stats.extent,
            applied.heights,
            plan.stats.contact_area,
        );
        previous = Some((mesh, out, plan.labels));
    }
}
