//! Procedural scenes for the demo, the tests and the benchmarks: soft balls pressed into soft
//! ground, balls of different sizes, crossed capsules. z is up; every object is closed.
//!
//! Each builder takes the penetration `depth` (how far the objects overlap along the contact
//! axis, in world units; negative for a gap) so that an animation is a sweep of depths.

use glam::{DQuat, DVec3};

use super::{Frame, FrameObject, FramePair, ObjectParams};
use crate::contact::PairParams;
use crate::mesh::{TriMesh, shapes};

/// An object of a procedural scene.
#[derive(Clone, Debug)]
pub struct SceneObject {
    pub name: String,
    pub mesh: TriMesh,
    pub params: ObjectParams,
}

/// A scene: objects and the pairs that may touch.
#[derive(Clone, Debug, Default)]
pub struct ProceduralScene {
    pub name: String,
    pub objects: Vec<SceneObject>,
    pub pairs: Vec<FramePair>,
}

impl ProceduralScene {
    /// The scene as a frame for the [`super::Deformer`].
    pub fn frame(&self) -> Frame<'_> {
        Frame {
            objects: self
                .objects
                .iter()
                .map(|o| FrameObject { name: &o.name, mesh: &o.mesh, params: &o.params })
                .collect(),
            pairs: self.pairs.clone(),
        }
    }

    /// The object called `name`.
    pub fn object_mut(&mut self, name: &str) -> Option<&mut SceneObject> {
        self.objects.iter_mut().find(|o| o.name == name)
    }

    fn push(&mut self, name: &str, mesh: TriMesh) -> usize {
        self.objects.push(SceneObject { name: name.to_string(), mesh, params: ObjectParams::default() });
        self.objects.len() - 1
    }

    fn pair(&mut self, a: usize, b: usize) {
        self.pairs.push(FramePair { objects: [a, b], params: PairParams::default() });
    }
}

fn translated(mut mesh: TriMesh, offset: DVec3) -> TriMesh {
    mesh.map_positions(|p| p + offset);
    mesh
}

/// A soft unit ball (icosphere with `subdivisions`) pressed by `depth` into a soft closed slab
/// (4 × 4 × 0.5, top face at z = 0, `cells` cells along x and y). Pair: (ball, ground), so the
/// mapping direction points up.
pub fn ball_on_ground(depth: f64, subdivisions: u32, cells: u32) -> ProceduralScene {
    let mut scene = ProceduralScene { name: "ball on ground".into(), ..Default::default() };
    let ball = translated(shapes::icosphere(1.0, subdivisions), DVec3::new(0.0, 0.0, 1.0 - depth));
    let ground = cells_slab(cells);
    let b = scene.push("ball", ball);
    let g = scene.push("ground", ground);
    scene.pair(b, g);
    scene
}

/// The ground of [`ball_on_ground`]: a 4 × 4 × 0.5 slab with its top at z = 0.
fn cells_slab(cells: u32) -> TriMesh {
    // `cuboid` uses `cells` cells along every axis, so the thin sides get elongated cells; they
    // are far from the contact.
    let mut slab = shapes::cuboid(DVec3::new(4.0, 4.0, 0.5), cells);
    slab.map_positions(|p| p - DVec3::new(0.0, 0.0, 0.25));
    slab
}

/// Two soft balls of different sizes: a unit ball at the origin and a ball of radius 0.6 above it,
/// overlapping by `depth`. Pair: (small, big).
pub fn two_balls(depth: f64, subdivisions: u32) -> ProceduralScene {
    let mut scene = ProceduralScene { name: "two balls".into(), ..Default::default() };
    let big = shapes::icosphere(1.0, subdivisions);
    let small = translated(shapes::icosphere(0.6, subdivisions), DVec3::new(0.0, 0.0, 1.6 - depth));
    let s = scene.push("small", small);
    let b = scene.push("big", big);
    scene.pair(s, b);
    scene
}

/// Two identical unit balls mirrored through the plane z = 0, overlapping by `depth`: the second
/// is the exact mirror image of the first (vertex i ↔ vertex i), for symmetry tests.
pub fn mirrored_balls(depth: f64, subdivisions: u32) -> ProceduralScene {
    let mut scene = ProceduralScene { name: "mirrored balls".into(), ..Default::default() };
    let top = translated(shapes::icosphere(1.0, subdivisions), DVec3::new(0.0, 0.0, 1.0 - 0.5 * depth));
    let mut bottom = top.clone();
    bottom.map_positions(|p| DVec3::new(p.x, p.y, -p.z));
    for t in &mut bottom.triangles {
        t.swap(1, 2);
    }
    let a = scene.push("top", top);
    let b = scene.push("bottom", bottom);
    scene.pair(a, b);
    scene
}

/// Two capsules of radius 0.5 and length 2 crossed at right angles, one along x below, one along
/// y above, overlapping by `depth`. Pair: (upper, lower).
pub fn crossed_capsules(depth: f64, segments: u32) -> ProceduralScene {
    let mut scene = ProceduralScene { name: "crossed capsules".into(), ..Default::default() };
    let capsule = || shapes::capsule(0.5, 2.0, segments, segments / 4, segments / 2);
    let mut lower = capsule();
    let along_x = DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2);
    lower.map_positions(|p| along_x * p);
    let mut upper = capsule();
    let along_y = DQuat::from_rotation_x(std::f64::consts::FRAC_PI_2);
    upper.map_positions(|p| along_y * p + DVec3::new(0.0, 0.0, 1.0 - depth));
    let u = scene.push("upper", upper);
    let l = scene.push("lower", lower);
    scene.pair(u, l);
    scene
}
