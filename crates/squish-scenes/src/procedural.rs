//! Procedural scenes for the demo, the tests and the benchmarks: soft balls pressed into soft
//! ground, balls of different sizes, crossed capsules, fingers, an arm folding at its elbow. z is up; every object is closed.
//!
//! Each builder takes the penetration `depth` (how far the objects overlap along the contact
//! axis, in world units; negative for a gap) so that an animation is a sweep of depths.

use glam::{DQuat, DVec3};

use squish::mesh::{TriMesh, shapes};
use squish::params::{ObjectParams, PairParams, RegionChoice};
use squish::pipeline::{FramePair, OwnedFrame, OwnedObject};

/// A scene: a named frame, its objects and the pairs that may touch (it derefs to the
/// [`OwnedFrame`], whose [`OwnedFrame::frame`] the deformer takes).
#[derive(Clone, Debug, Default)]
pub struct ProceduralScene {
    pub name: String,
    pub contents: OwnedFrame,
}

impl std::ops::Deref for ProceduralScene {
    type Target = OwnedFrame;
    fn deref(&self) -> &OwnedFrame {
        &self.contents
    }
}

impl std::ops::DerefMut for ProceduralScene {
    fn deref_mut(&mut self) -> &mut OwnedFrame {
        &mut self.contents
    }
}

impl ProceduralScene {
    /// A scene of these objects and pairs.
    pub fn new(name: String, objects: Vec<OwnedObject>, pairs: Vec<FramePair>) -> Self {
        Self { name, contents: OwnedFrame { objects, pairs } }
    }

    fn push(&mut self, name: &str, mesh: TriMesh) -> usize {
        self.objects.push(OwnedObject { name: name.to_string(), mesh, params: ObjectParams::default() });
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

/// An arm: a capsule of radius 0.5 and length 6 along z, centred at the origin, bent at the
/// origin (its elbow) by `degrees` toward +y by linear blend skinning of two bones (weights
/// blended smoothly over |z| ≤ 1, two radii each side), with the elbow's articulation (regions
/// from the weights at 0.05, d̂ from the joints at (0, 0, −3), the origin and the hand) and its
/// rest pose; anisotropic bulge (thesis ch. 6; see [`squish::skinning::plan_articulation`]). Past about
/// 105° the inner skin passes through itself. No pair.
pub fn bent_arm(degrees: f64, segments: u32) -> ProceduralScene {
    use squish::params::{Articulation, ArticulationParams};
    let segments = segments.max(8);
    let rest = shapes::capsule(0.5, 6.0, segments, segments / 4, segments * 3 / 2);
    let weight: Vec<f64> = rest
        .positions
        .iter()
        .map(|p| {
            let x = ((p.z + 1.0) / 2.0).clamp(0.0, 1.0);
            x * x * (3.0 - 2.0 * x)
        })
        .collect();
    let rotation = DQuat::from_axis_angle(DVec3::NEG_X, degrees.to_radians());
    let mesh = TriMesh {
        positions: rest.positions.iter().zip(&weight).map(|(p, &w)| (1.0 - w) * *p + w * (rotation * *p)).collect(),
        triangles: rest.triangles.clone(),
    };
    let side = |child: bool| -> Vec<u32> {
        (0..rest.num_vertices() as u32)
            .filter(|&v| {
                let w = weight[v as usize];
                (if child { w } else { 1.0 - w }) >= 0.05
            })
            .collect()
    };
    let elbow = Articulation {
        name: "elbow".into(),
        regions: [side(false), side(true)],
        joints: Some([DVec3::new(0.0, 0.0, -3.0), DVec3::ZERO, rotation * DVec3::new(0.0, 0.0, 3.0)]),
        params: ArticulationParams::default(),
        automatic: false,
    };
    let params = ObjectParams {
        anisotropy: true,
        self_contact: vec![elbow],
        rest_positions: Some(rest.positions),
        ..ObjectParams::default()
    };
    ProceduralScene::new("bent arm".into(), vec![OwnedObject { name: "arm".into(), mesh, params }], Vec::new())
}

/// Radius of the fingers of [`fingers_on_ball`] and [`fingers_on_slab`].
pub const FINGER_RADIUS: f64 = 0.12;

/// A finger of the hand-like scenes: where it touches, in the plane (x, y); its length; its
/// penetration depth relative to `depth`; its leans (radians about y, then about x).
type Finger = ((f64, f64), f64, f64, (f64, f64));

/// The five fingers: every finger presses at its own angle, and neighbours lean apart so that
/// fingers never touch.
const FINGERS: [Finger; 5] = [
    ((-0.45, 0.1), 0.55, 1.0, (-0.45, -0.15)),
    ((-0.15, 0.22), 0.75, 1.2, (-0.15, -0.3)),
    ((0.15, 0.22), 0.85, 0.9, (0.1, -0.25)),
    ((0.45, 0.1), 0.7, 1.1, (0.4, -0.1)),
    ((-0.2, -0.45), 0.5, 0.8, (-0.2, 0.5)),
];

/// A hand-like mesh: five capsule fingers of radius [`FINGER_RADIUS`] and different lengths joined
/// into one mesh with [`TriMesh::append`] (each finger a connected component, finger `k` holding
/// the faces of the `k`-th block), each with its tip sphere centred at `tips[k]` and its axis
/// leaning as listed in `FINGERS`.
fn fingers(tips: &[DVec3; 5], segments: u32) -> TriMesh {
    let mut hand = TriMesh::default();
    for (tip, &(_, length, _, (lean_y, lean_x))) in tips.iter().zip(&FINGERS) {
        let mut finger = shapes::capsule(FINGER_RADIUS, length, segments, segments / 4, (segments / 4).max(2));
        let axis = (DQuat::from_rotation_x(lean_x) * DQuat::from_rotation_y(lean_y)) * DVec3::Z;
        let rotation = DQuat::from_rotation_arc(DVec3::Z, axis);
        // The capsule's lower hemisphere is centred at z = −length/2 on its axis.
        let offset = *tip + axis * (0.5 * length);
        finger.map_positions(|p| rotation * p + offset);
        hand.append(&finger);
    }
    hand
}

/// Five fingers of one hand mesh pressing a soft unit ball at the origin (icosphere with
/// `subdivisions`), each at its own angle, finger `k`'s tip sphere overlapping the ball by
/// `depth × factor_k` (factors 1, 1.2, 0.9, 1.1, 0.8). The hand's working regions are its
/// components (one per finger, §7.1.2, Fig. 7.6); the ball is one region. Pair: (hand, ball).
pub fn fingers_on_ball(depth: f64, subdivisions: u32, segments: u32) -> ProceduralScene {
    let mut scene = ProceduralScene { name: "fingers on a ball".into(), ..Default::default() };
    let tips = FINGERS.map(|((x, y), _, factor, _)| {
        let on_ball = DVec3::new(x, y, (1.0 - x * x - y * y).sqrt());
        on_ball * (1.0 + FINGER_RADIUS - depth * factor)
    });
    let h = scene.push("hand", fingers(&tips, segments));
    scene.objects[h].params.region = RegionChoice::Components;
    let b = scene.push("ball", shapes::icosphere(1.0, subdivisions));
    scene.pair(h, b);
    scene
}

/// The fingers of [`fingers_on_ball`] pressing a soft closed slab (2 × 2 × 0.4, top face at
/// z = 0, `cells` cells along each axis) straight down at their own angles, finger `k` sinking
/// `depth × factor_k` into it. The slab's working regions are automatic (`Distance(0)`: bands as
/// wide as its extent requires). Pair: (hand, slab).
pub fn fingers_on_slab(depth: f64, cells: u32, segments: u32) -> ProceduralScene {
    let mut scene = ProceduralScene { name: "fingers on a slab".into(), ..Default::default() };
    let tips = FINGERS.map(|((x, y), _, factor, _)| DVec3::new(x, y, FINGER_RADIUS - depth * factor));
    let h = scene.push("hand", fingers(&tips, segments));
    scene.objects[h].params.region = RegionChoice::Components;
    let mut slab = shapes::cuboid(DVec3::new(2.0, 2.0, 0.4), cells);
    slab.map_positions(|p| p - DVec3::new(0.0, 0.0, 0.2));
    let s = scene.push("slab", slab);
    scene.objects[s].params.region = RegionChoice::Distance;
    scene.pair(h, s);
    scene
}

/// The fingers of [`fingers_on_slab`] and the slab as ONE mesh (the slab first, then the five
/// fingers): fingers pressing the palm of their own hand (Fig. 7.5). Its working regions are its
/// components; the pair is the object with itself, so its distinct regions are paired.
pub fn fingers_on_own_palm(depth: f64, cells: u32, segments: u32) -> ProceduralScene {
    let two = fingers_on_slab(depth, cells, segments);
    let mut hand = two.objects[1].mesh.clone();
    hand.append(&two.objects[0].mesh);
    let mut scene = ProceduralScene { name: "fingers on their own palm".into(), ..Default::default() };
    let h = scene.push("hand", hand);
    scene.objects[h].params.region = RegionChoice::Components;
    scene.pair(h, h);
    scene
}
