//! Animated benchmark scenes at the sizes of the thesis' performance tables (ch. 7 §5, tables
//! 7.1–7.3), for `squish bench` and the criterion benchmarks.
//!
//! Each [`BenchScene`] is a rest pose (objects, pairs, parameters) plus rigid translations of
//! some objects over the animation parameter `t ∈ [0, 1]` ([`BenchScene::pose`]): the contact
//! moves and deepens from frame to frame while the connectivity stays, as in an animation, so a
//! reused [`squish::pipeline::Deformer`] keeps its caches. Meshes are procedural except two that come from
//! files (the bunny and the hand): the library reads no files, so those builders take the mesh.
//!
//! The sizes follow table 7.3 (working regions 𝒲) and, through fixed extents φ_max, roughly the
//! deformable regions 𝒟 of tables 7.1–7.2. Where the thesis cut a working region out of a larger
//! mesh, our object is that size and is processed whole (the bunny's lower part is cut out as a
//! mesh), so the rows compare equal work; `press-100k-automatic` shows the automatic working
//! region instead. [`BenchSize::Quick`] shrinks every scene (≈ ¼ of the
//! vertices) for smoke tests.
//!
//! A scene may instead be given frame by frame ([`BenchScene::from_poses`]): a skinned
//! character's animation, posed by the caller from a file (CesiumMan's walk with
//! `self_contact = "auto"` in `squish bench`); [`BenchScene::pose`] then gives the pose nearest
//! to `t`.

use glam::{DQuat, DVec3};

use squish::mesh::{SubMesh, TriMesh, shapes};
use squish::params::{ObjectParams, PairParams, RegionChoice};
use std::time::{Duration, Instant};

use squish::pipeline::{Deformer, FramePair, FrameResult};
use squish::stage::{PerStage, Stage};

use crate::procedural::ProceduralScene;
use squish::OwnedObject;

/// Full thesis-size scenes, or smaller ones for a quick smoke run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BenchSize {
    Full,
    Quick,
}

impl BenchSize {
    /// `full` at full size, `quick` otherwise.
    fn pick<T>(self, full: T, quick: T) -> T {
        match self {
            Self::Full => full,
            Self::Quick => quick,
        }
    }
}

/// The thesis row a scene is compared with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThesisRow {
    /// Table of the thesis ("7.1": method A, "7.2": method B).
    pub table: &'static str,
    /// The row's name in that table.
    pub scene: &'static str,
    /// |𝒲| of the two sides (table 7.3), in our pair order (first object(s), second object).
    pub working: [usize; 2],
    /// |𝒟| of the two sides (tables 7.1–7.2; 0 for a rigid side), in our pair order.
    pub deformable: [usize; 2],
    /// Average time per frame of the C++ prototype (one core of an i7-4790K), ms.
    pub ms: f64,
    /// The row's breakdown, % of `ms`, column by column ([`ThesisRow::columns`]: i., m., c., p.,
    /// di., g., de.). The table's own rounding: a row sums to 99–101.
    pub stages: [f64; 7],
    /// % of `ms` spent in factorizations (table 7.2's s., part of p., di. and g.; table 7.1
    /// has no such column).
    pub factorizations: Option<f64>,
}

impl ThesisRow {
    /// The stages of the columns of [`Self::stages`], in order: the [spans](Stage::spans) that
    /// the thesis' tables time.
    pub fn columns() -> impl Iterator<Item = Stage> {
        Stage::spans().filter(|s| s.in_thesis_tables())
    }

    /// The thesis' time of each stage in ms: its columns and, for table 7.2, the factorizations;
    /// `None` for a stage the table has no column for.
    pub fn stage_ms(&self) -> PerStage<Option<f64>> {
        let mut ms = PerStage::default();
        for (stage, percent) in Self::columns().zip(self.stages) {
            ms[stage] = Some(self.ms * percent / 100.0);
        }
        ms[Stage::Factorization] = self.factorizations.map(|percent| self.ms * percent / 100.0);
        ms
    }
}

/// The thesis rows (tables 7.1–7.3) of the scenes below.
pub const FINGERS_BALL: ThesisRow = ThesisRow {
    table: "7.2",
    scene: "fingers - ball",
    working: [1064, 1561],
    deformable: [194, 1479],
    ms: 5.6,
    stages: [11.0, 9.0, 1.0, 26.0, 4.0, 30.0, 18.0],
    factorizations: Some(33.0),
};
pub const FINGERS_PALM: ThesisRow = ThesisRow {
    table: "7.2",
    scene: "fingers - palm",
    working: [2664, 2184],
    deformable: [616, 1202],
    ms: 9.0,
    stages: [23.0, 9.0, 1.0, 23.0, 3.0, 21.0, 20.0],
    factorizations: Some(26.0),
};
pub const PLANE_SPHERE: ThesisRow = ThesisRow {
    table: "7.1",
    scene: "plane - sphere",
    working: [639, 1521],
    deformable: [568, 0],
    ms: 9.93,
    stages: [17.9, 3.4, 17.5, 20.3, 16.8, 9.4, 14.8],
    factorizations: None,
};
pub const SMALL_BIG_SPHERES: ThesisRow = ThesisRow {
    table: "7.1",
    scene: "s. sphere - b. sphere",
    working: [635, 10183],
    deformable: [0, 9995],
    ms: 233.1,
    stages: [4.1, 0.6, 21.0, 26.5, 25.4, 13.7, 8.7],
    factorizations: None,
};
pub const BUNNY_JELLY: ThesisRow = ThesisRow {
    table: "7.2",
    scene: "bunny - jelly",
    working: [14408, 5002],
    deformable: [4182, 4259],
    ms: 101.8,
    stages: [12.0, 9.0, 2.0, 43.0, 1.0, 18.0, 16.0],
    factorizations: Some(41.0),
};
pub const WALK: ThesisRow = ThesisRow {
    table: "7.2",
    scene: "walk",
    working: [740, 11717],
    deformable: [0, 11682],
    ms: 76.8,
    stages: [5.0, 4.0, 0.0, 30.0, 1.0, 49.0, 11.0],
    factorizations: Some(61.0),
};
pub const HAT_EGG: ThesisRow = ThesisRow {
    table: "7.2",
    scene: "hat - egg",
    working: [12092, 10242],
    deformable: [10137, 0],
    ms: 173.4,
    stages: [41.0, 12.0, 2.0, 30.0, 1.0, 10.0, 5.0],
    factorizations: Some(33.0),
};
pub const HAND_PILLOW: ThesisRow = ThesisRow {
    table: "7.1",
    scene: "hand - pillow",
    working: [2285, 26234],
    deformable: [0, 18612],
    ms: 728.5,
    stages: [5.2, 0.8, 32.0, 31.2, 19.4, 5.0, 6.3],
    factorizations: None,
};

/// A rigid translation of one object over the animation: `from` at t = 0, `to` at t = 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    pub object: usize,
    pub from: DVec3,
    pub to: DVec3,
}

/// An animated benchmark scene (see the module doc).
#[derive(Clone, Debug)]
pub struct BenchScene {
    /// Short identifier, e.g. `"fingers-ball"`.
    pub name: &'static str,
    /// The thesis row it stands for (`None`: no counterpart, e.g. the stress case).
    pub thesis: Option<ThesisRow>,
    /// The rest pose (objects at their rest positions, before any [`Motion`]).
    pub rest: ProceduralScene,
    /// Moving objects.
    pub motions: Vec<Motion>,
    /// Poses given frame by frame, evenly over `t ∈ [0, 1]` (same objects and triangles in
    /// each); when not empty they replace `rest` + `motions`.
    pub poses: Vec<ProceduralScene>,
}

impl BenchScene {
    /// The scene at animation time `t` (clamped to [0, 1]): moving objects translated, others as
    /// at rest. Triangles are unchanged, so deformer caches carry over between poses.
    pub fn pose(&self, t: f64) -> ProceduralScene {
        let t = t.clamp(0.0, 1.0);
        if let Some(last) = self.poses.len().checked_sub(1) {
            return self.poses[(t * last as f64).round() as usize].clone();
        }
        let mut scene = self.rest.clone();
        for motion in &self.motions {
            if let Some(object) = scene.objects.get_mut(motion.object) {
                let offset = motion.from.lerp(motion.to, t);
                object.mesh.map_positions(|p| p + offset);
            }
        }
        scene
    }

    /// A scene given by its poses, evenly over the animation (the first is also its rest);
    /// `None` without poses.
    pub fn from_poses(name: &'static str, poses: Vec<ProceduralScene>) -> Option<BenchScene> {
        let rest = poses.first()?.clone();
        Some(BenchScene { name, thesis: None, rest, motions: Vec::new(), poses })
    }

    /// The time of frame `frame` of an animation of `frames` frames (0 to 1 inclusive).
    pub fn frame_time(frame: usize, frames: usize) -> f64 {
        if frames <= 1 { 1.0 } else { frame as f64 / (frames - 1) as f64 }
    }

    /// The run of the scene's animation that `squish bench` times (and the work guard counts): a
    /// fresh deformer without the quality pass, a warm-up frame at t = 0 (`warmed` sees the
    /// deformer after it, and its time), then `frames` frames at [`Self::frame_time`], each result
    /// handed to `each` with its index and the deformer. The first error stops the run.
    pub fn animate(
        &self,
        frames: usize,
        warmed: impl FnOnce(&Deformer, Duration),
        mut each: impl FnMut(usize, FrameResult, &Deformer),
    ) -> Result<(), String> {
        let mut deformer = Deformer::new().without_quality();
        let start = Instant::now();
        deformer.deform(&self.pose(0.0).frame()).map_err(|e| format!("warm-up frame: {e}"))?;
        warmed(&deformer, start.elapsed());
        for k in 0..frames {
            let pose = self.pose(Self::frame_time(k, frames));
            let result = deformer.deform(&pose.frame()).map_err(|e| format!("frame {k}: {e}"))?;
            each(k, result, &deformer);
        }
        Ok(())
    }

    /// Vertices of every object (the working regions 𝒲, which are whole objects).
    pub fn vertices(&self) -> Vec<usize> {
        self.rest.objects.iter().map(|o| o.mesh.num_vertices()).collect()
    }

    /// The objects on each side of the pairs: those that come first in a pair, then the others
    /// (e.g. [fingers, ball]), the order of [`ThesisRow::working`].
    pub fn sides(&self) -> [Vec<usize>; 2] {
        let count = self.rest.objects.len();
        let first: Vec<usize> = (0..count).filter(|&i| self.rest.pairs.iter().any(|p| p.objects[0] == i)).collect();
        let second = (0..count).filter(|i| !first.contains(i)).collect();
        [first, second]
    }

    /// The non-rigid object with the most vertices: the largest system factorized per frame.
    pub fn largest_deformable(&self) -> Option<&OwnedObject> {
        self.rest.objects.iter().filter(|o| !o.params.rigid).max_by_key(|o| o.mesh.num_vertices())
    }
}

/// Builder state shared by the scene functions.
struct Builder {
    scene: ProceduralScene,
    motions: Vec<Motion>,
}

impl Builder {
    fn new(name: &str) -> Self {
        Self { scene: ProceduralScene { name: name.to_string(), ..Default::default() }, motions: Vec::new() }
    }

    fn object(&mut self, name: &str, mesh: TriMesh, params: ObjectParams) -> usize {
        self.scene.objects.push(OwnedObject { name: name.to_string(), mesh, params });
        self.scene.objects.len() - 1
    }

    fn pair(&mut self, a: usize, b: usize) {
        self.scene.pairs.push(FramePair { objects: [a, b], params: PairParams::default() });
    }

    fn moves(&mut self, object: usize, from: DVec3, to: DVec3) {
        self.motions.push(Motion { object, from, to });
    }

    fn finish(self, name: &'static str, thesis: Option<ThesisRow>) -> BenchScene {
        BenchScene { name, thesis, rest: self.scene, motions: self.motions, poses: Vec::new() }
    }
}

fn transformed(mut mesh: TriMesh, rotation: DQuat, scale: DVec3, offset: DVec3) -> TriMesh {
    mesh.map_positions(|p| rotation * (p * scale) + offset);
    mesh
}

/// Capsule "fingertips" of radius `radius` and cylinder length `length`, pointing down (−z) at a
/// tilt of `tilt` radians about x, their tips at `tips`. Vertices each: segments·(2·rings +
/// length_rings − 1) + 2.
fn fingertips(
    b: &mut Builder,
    tips: &[DVec3],
    radius: f64,
    length: f64,
    resolution: (u32, u32, u32),
    tilt: f64,
) -> Vec<usize> {
    let (segments, rings, length_rings) = resolution;
    let rotation = DQuat::from_rotation_x(tilt);
    tips.iter()
        .enumerate()
        .map(|(i, &tip)| {
            // The capsule's lower tip is at z = −(length/2 + radius); put it on `tip`.
            let capsule = shapes::capsule(radius, length, segments, rings, length_rings);
            let axis_tip = rotation * DVec3::new(0.0, 0.0, -(0.5 * length + radius));
            let mesh = transformed(capsule, rotation, DVec3::ONE, tip - axis_tip);
            b.object(&format!("finger {}", i + 1), mesh, ObjectParams::default())
        })
        .collect()
}

/// Table 7.2 "fingers – ball" (method B, 5.6 ms; 𝒲 1064 + 1561, 𝒟 194 + 1479): four soft
/// capsule fingertips (≈ 1.0k vertices together) pressing a soft UV ball (≈ 1.56k vertices), one
/// pair per finger.
pub fn fingers_ball(size: BenchSize) -> BenchScene {
    let mut b = Builder::new("fingers – ball");
    let (segments, rings) = size.pick((40, 40), (20, 20));
    let ball = b.object("ball", shapes::uv_sphere(1.0, segments, rings), ObjectParams::default().with_extent(2.8));
    let xs = [-0.45, -0.15, 0.15, 0.45];
    // Tips on the ball's surface (z = √(1 − x²)) before the motion presses them in.
    let tips: Vec<DVec3> = xs.iter().map(|&x: &f64| DVec3::new(x, 0.0, (1.0 - x * x).sqrt())).collect();
    let resolution = size.pick((16, 6, 5), (10, 3, 3));
    let fingers = fingertips(&mut b, &tips, 0.13, 0.5, resolution, 0.0);
    for (i, &f) in fingers.iter().enumerate() {
        b.scene.objects[f].params = ObjectParams::default().with_stiffness(2.0).with_extent(0.12);
        b.pair(f, ball);
        // Unequal depths: the fingers do not press in unison.
        let depth = 0.06 + 0.02 * i as f64;
        b.moves(f, DVec3::new(0.0, 0.0, -0.5 * depth), DVec3::new(0.0, 0.0, -depth));
    }
    b.finish("fingers-ball", Some(FINGERS_BALL))
}

/// Table 7.2 "fingers – palm" (method B, 9 ms; 𝒲 2664 + 2184, 𝒟 616 + 1202): four tilted soft
/// fingertips (≈ 2.6k vertices) pressing a soft flattened ellipsoid palm (≈ 2.2k vertices).
pub fn fingers_palm(size: BenchSize) -> BenchScene {
    let mut b = Builder::new("fingers – palm");
    let (segments, rings) = size.pick((48, 46), (24, 23));
    let palm_scale = DVec3::new(1.2, 0.9, 0.35);
    let palm = transformed(shapes::uv_sphere(1.0, segments, rings), DQuat::IDENTITY, palm_scale, DVec3::ZERO);
    let palm = b.object("palm", palm, ObjectParams::default().with_extent(1.0));
    let xs = [-0.5, -0.17, 0.17, 0.5];
    let tips: Vec<DVec3> = xs
        .iter()
        .map(|&x: &f64| {
            let r = (x / palm_scale.x).powi(2);
            DVec3::new(x, 0.0, palm_scale.z * (1.0 - r).sqrt())
        })
        .collect();
    let resolution = size.pick((24, 10, 8), (12, 5, 4));
    let fingers = fingertips(&mut b, &tips, 0.15, 0.9, resolution, 0.5);
    for (i, &f) in fingers.iter().enumerate() {
        b.scene.objects[f].params = ObjectParams::default().with_extent(0.3);
        b.pair(f, palm);
        let depth = 0.07 + 0.015 * i as f64;
        b.moves(f, DVec3::new(0.0, 0.0, -0.4 * depth), DVec3::new(0.0, 0.0, -depth));
    }
    b.finish("fingers-palm", Some(FINGERS_PALM))
}

/// Table 7.1 "plane – sphere" (method A, 9.93 ms; 𝒲 1521 + 639, 𝒟 568): a soft icosphere (642
/// vertices) pressed onto a rigid open plane (39 × 39 vertices).
pub fn sphere_plane(size: BenchSize) -> BenchScene {
    let mut b = Builder::new("sphere – plane");
    let subdivisions = size.pick(3, 2);
    let cells = size.pick(38, 19);
    let sphere = b.object("sphere", shapes::icosphere(1.0, subdivisions), ObjectParams::default().with_extent(2.0));
    let plane = b.object("plane", shapes::grid(4.0, 4.0, cells, cells), ObjectParams::rigid());
    b.pair(sphere, plane);
    b.moves(sphere, DVec3::new(0.0, 0.0, 1.0 - 0.15), DVec3::new(0.0, 0.0, 1.0 - 0.35));
    b.finish("sphere-plane", Some(PLANE_SPHERE))
}

/// Table 7.1 "s. sphere – b. sphere" (method A, 233.1 ms; 𝒲 635 + 10183, 𝒟 9995): a rigid
/// small icosphere (642 vertices) pressing a soft big icosphere (10242 vertices).
pub fn small_big_spheres(size: BenchSize) -> BenchScene {
    let mut b = Builder::new("small sphere – big sphere");
    let (small_subdivisions, big_subdivisions) = size.pick((3, 5), (2, 4));
    let small = b.object("small sphere", shapes::icosphere(0.35, small_subdivisions), ObjectParams::rigid());
    let big =
        b.object("big sphere", shapes::icosphere(1.0, big_subdivisions), ObjectParams::default().with_extent(2.6));
    b.pair(small, big);
    b.moves(small, DVec3::new(0.25, 0.0, 1.35 - 0.08), DVec3::new(-0.15, 0.0, 1.35 - 0.25));
    b.finish("small-big-spheres", Some(SMALL_BIG_SPHERES))
}

/// The working region of table 7.3's bunny: the `count` lowest vertices of `bunny` (z up), as an
/// open mesh of the faces they hold, whose volume is preserved as part of the closed bunny.
fn lowest_region(bunny: &TriMesh, count: usize) -> TriMesh {
    let mut heights: Vec<f64> = bunny.positions.iter().map(|p| p.z).collect();
    heights.sort_by(f64::total_cmp);
    let Some(&level) = heights.get(count.saturating_sub(1)) else { return bunny.clone() };
    let mask: Vec<bool> = bunny.positions.iter().map(|p| p.z <= level).collect();
    SubMesh::from_vertex_mask(bunny, &mask).mesh
}

/// The bunny of `bunny_29834.obj` (y up as stored, ≈ 1.5 wide) turned z up.
fn bunny_z_up(bunny: TriMesh) -> TriMesh {
    transformed(bunny, DQuat::from_rotation_x(std::f64::consts::FRAC_PI_2), DVec3::ONE, DVec3::ZERO)
}

/// A bunny (z up) sinking its flat base into a soft subdivided cube.
fn bunny_on_jelly(bunny: TriMesh, bunny_params: ObjectParams, size: BenchSize) -> Builder {
    let mut b = Builder::new("bunny – jelly");
    let base = bunny.positions.iter().map(|p| p.z).fold(f64::INFINITY, f64::min);
    let cells = size.pick(29, 14);
    let jelly = transformed(shapes::cube(1.8, cells), DQuat::IDENTITY, DVec3::ONE, DVec3::new(0.0, 0.0, -0.9));
    let bunny = b.object("bunny", bunny, bunny_params.with_extent(0.25));
    let jelly = b.object("jelly", jelly, ObjectParams::default().with_stiffness(0.5).with_extent(3.0));
    b.pair(bunny, jelly);
    b.moves(bunny, DVec3::new(0.0, 0.0, -base - 0.03), DVec3::new(0.05, 0.0, -base - 0.12));
    b
}

/// Table 7.2 "bunny – jelly" (method B, 101.8 ms; 𝒲 14408 + 5002, 𝒟 4182 + 4259): a soft
/// bunny sitting on a soft subdivided cube (5048 vertices). `bunny` is the shared
/// `bunny_29834.obj`; as in the thesis, its working region is its lower part (the 14408 lowest
/// vertices, ≈ half of it: an open mesh whose volume is preserved as part of the closed bunny).
/// See [`bunny_whole_jelly`] for the whole bunny.
pub fn bunny_jelly(bunny: TriMesh, size: BenchSize) -> BenchScene {
    let bunny = bunny_z_up(bunny);
    let count = size.pick(14408, bunny.num_vertices() / 2);
    let region = lowest_region(&bunny, count);
    let params = ObjectParams { preserve_volume: Some(true), ..ObjectParams::default() };
    bunny_on_jelly(region, params, size).finish("bunny-jelly", Some(BUNNY_JELLY))
}

/// [`bunny_jelly`] with the whole bunny as its working region (29834 vertices, twice the
/// thesis' 𝒲), compared with the same thesis row.
pub fn bunny_whole_jelly(bunny: TriMesh, size: BenchSize) -> BenchScene {
    bunny_on_jelly(bunny_z_up(bunny), ObjectParams::default(), size).finish("bunny-whole-jelly", Some(BUNNY_JELLY))
}

/// Table 7.2 "walk" (method B, 76.8 ms; 𝒲 740 + 11717, 𝒟 0 + 11682): two rigid foot-like boxes
/// (≈ 770 vertices together) stepping on a soft open plane (108 × 108 cells, 11881 vertices):
/// one foot presses down while the other lifts.
pub fn feet_plane(size: BenchSize) -> BenchScene {
    let mut b = Builder::new("feet – plane");
    let cells = size.pick(108, 54);
    let plane = b.object("plane", shapes::grid(6.0, 6.0, cells, cells), ObjectParams::default().with_extent(4.0));
    let foot_cells = size.pick(8, 4);
    let foot = |x: f64| {
        transformed(
            shapes::cuboid(DVec3::new(0.5, 1.2, 0.4), foot_cells),
            DQuat::IDENTITY,
            DVec3::ONE,
            DVec3::new(x, 0.0, 0.2),
        )
    };
    let left = b.object("left foot", foot(-0.6), ObjectParams::rigid());
    let right = b.object("right foot", foot(0.6), ObjectParams::rigid());
    b.pair(left, plane);
    b.pair(right, plane);
    b.moves(left, DVec3::new(0.0, 0.0, -0.2), DVec3::new(0.0, 0.1, -0.05));
    b.moves(right, DVec3::new(0.0, 0.0, -0.05), DVec3::new(0.0, 0.1, -0.2));
    b.finish("feet-plane", Some(WALK))
}

/// A closed shell of revolution around z — a hat: the outer hemisphere of radius `outer`, a rim
/// down to the inner hemisphere of radius `inner`, whose apex is the bottom pole. Built by
/// moving the vertices of a UV sphere (so the connectivity is the sphere's): polar angle θ ∈
/// [0, π] goes over the outer surface for θ < 0.45π, the rim up to 0.55π, the inner surface after.
fn hat(outer: f64, inner: f64, segments: u32, rings: u32) -> TriMesh {
    use std::f64::consts::{FRAC_PI_2, PI};
    let mut mesh = shapes::uv_sphere(1.0, segments, rings);
    mesh.map_positions(|p| {
        let theta = p.z.clamp(-1.0, 1.0).acos();
        let around = DVec3::new(p.x, p.y, 0.0).normalize_or_zero();
        let s = theta / PI;
        let (angle, radius) = if s <= 0.45 {
            (s / 0.45 * FRAC_PI_2, outer)
        } else if s <= 0.55 {
            (FRAC_PI_2, outer + (inner - outer) * (s - 0.45) / 0.1)
        } else {
            ((1.0 - s) / 0.45 * FRAC_PI_2, inner)
        };
        radius * (around * angle.sin() + DVec3::Z * angle.cos())
    });
    mesh
}

/// Table 7.2 "hat – egg" (method B, 173.4 ms; 𝒲 12092 + 10242, 𝒟 10137 + 0): a soft hat (a
/// closed hemispherical shell, ≈ 12.1k vertices) pulled down on a rigid egg (a stretched
/// icosphere, 10242 vertices).
pub fn hat_egg(size: BenchSize) -> BenchScene {
    let mut b = Builder::new("hat – egg");
    let (segments, rings) = size.pick((110, 111), (55, 56));
    let hat = b.object("hat", hat(1.1, 0.9, segments, rings), ObjectParams::default().with_extent(2.8));
    let egg_mesh =
        transformed(shapes::icosphere(1.0, size.pick(5, 4)), DQuat::IDENTITY, DVec3::new(0.8, 0.8, 1.0), DVec3::ZERO);
    let egg = b.object("egg", egg_mesh, ObjectParams::rigid());
    b.pair(hat, egg);
    // The egg's top (z = 1) goes 0.04 to 0.12 into the shell's inside (radius 0.9, thickness 0.2).
    b.moves(hat, DVec3::new(0.0, 0.0, 0.06), DVec3::new(0.02, 0.0, -0.02));
    b.finish("hat-egg", Some(HAT_EGG))
}

/// Table 7.1 "hand – pillow" (method A, 728.5 ms; 𝒲 2285 + 26234, 𝒟 18612): the shared
/// `hand_7993.obj` (rigid, lying in the xy plane, ≈ 1 long) pressed into a soft pillow (a
/// flattened UV ellipsoid of ≈ 26k vertices).
pub fn hand_pillow(hand: TriMesh, size: BenchSize) -> BenchScene {
    let mut b = Builder::new("hand – pillow");
    let (segments, rings) = size.pick((162, 162), (81, 81));
    let pillow =
        transformed(shapes::uv_sphere(1.0, segments, rings), DQuat::IDENTITY, DVec3::new(1.0, 0.8, 0.3), DVec3::ZERO);
    let lowest = hand.positions.iter().map(|p| p.z).fold(f64::INFINITY, f64::min);
    let centre = hand.positions.iter().fold(DVec3::ZERO, |s, p| s + *p) / hand.positions.len().max(1) as f64;
    let hand = transformed(hand, DQuat::IDENTITY, DVec3::ONE, DVec3::new(-centre.x, -centre.y, -lowest));
    let pillow = b.object("pillow", pillow, ObjectParams::default().with_extent(1.3));
    let hand = b.object("hand", hand, ObjectParams::rigid());
    b.pair(hand, pillow);
    b.moves(hand, DVec3::new(0.0, 0.0, 0.3 - 0.06), DVec3::new(0.0, 0.05, 0.3 - 0.12));
    b.finish("hand-pillow", Some(HAND_PILLOW))
}

/// Stress case, no thesis counterpart: two soft UV spheres of ≈ 50k vertices each (≈ 25k in
/// quick mode) pressed together at their equators: one pair of ≈ 100k vertices.
pub fn stress_100k(size: BenchSize) -> BenchScene {
    let mut b = Builder::new("stress 100k");
    let (segments, rings) = size.pick((224, 224), (112, 112));
    let a = b.object("left", shapes::uv_sphere(1.0, segments, rings), ObjectParams::default().with_extent(0.8));
    let c = b.object("right", shapes::uv_sphere(1.0, segments, rings), ObjectParams::default().with_extent(0.8));
    b.pair(a, c);
    b.moves(a, DVec3::new(-1.0 + 0.05, 0.0, 0.0), DVec3::new(-1.0 + 0.15, 0.0, 0.0));
    b.moves(c, DVec3::new(1.0 - 0.05, 0.0, 0.0), DVec3::new(1.0 - 0.15, 0.0, 0.0));
    b.finish("stress-100k", None)
}

/// No thesis counterpart: a soft ball (radius 0.25, ≈ 5k vertices) pressing a soft sphere ten
/// times larger of ≈ 100k vertices (≈ 25k in quick mode), a small contact on a large mesh; both
/// processed whole.
pub fn press_100k(size: BenchSize) -> BenchScene {
    press_on_a_big_sphere(size, RegionChoice::Whole).finish("press-100k", None)
}

/// [`press_100k`] with automatic working regions (`region = "distance"`): each object is
/// processed on a band around its contact, with the same result up to round-off (the
/// parametrization domain lies inside the band). The ratio of the two rows is the automatic
/// region's speed-up (about 1 since the whole object's linear systems leave out the rows
/// outside the parametrization domain).
pub fn press_100k_automatic(size: BenchSize) -> BenchScene {
    press_on_a_big_sphere(size, RegionChoice::Distance).finish("press-100k-automatic", None)
}

fn press_on_a_big_sphere(size: BenchSize, region: RegionChoice) -> Builder {
    let mut b = Builder::new("press 100k");
    let (segments, rings) = size.pick((316, 316), (158, 158));
    let (ball_segments, ball_rings) = size.pick((72, 72), (36, 36));
    let params = ObjectParams::default().with_region(region);
    let big = b.object("sphere", shapes::uv_sphere(2.5, segments, rings), params.clone());
    let ball = b.object("ball", shapes::uv_sphere(0.25, ball_segments, ball_rings), params.with_stiffness(0.5));
    b.pair(ball, big);
    // Pressed 0.04 → 0.12 deep, off the UV sphere's pole, sliding a little.
    let direction = DVec3::new(0.3, 0.2, 1.0).normalize();
    b.moves(ball, direction * (2.75 - 0.04), direction * (2.75 - 0.12) + DVec3::new(0.0, 0.03, 0.0));
    b
}

/// The procedural scenes (every scene but the two that need a mesh file), in table order.
pub fn procedural_scenes(size: BenchSize) -> Vec<BenchScene> {
    vec![
        fingers_ball(size),
        fingers_palm(size),
        sphere_plane(size),
        small_big_spheres(size),
        feet_plane(size),
        hat_egg(size),
        stress_100k(size),
        press_100k(size),
        press_100k_automatic(size),
    ]
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use squish::pipeline::Deformer;

    /// A scene given by its poses plays them evenly over t: pose k of n at t = k / (n − 1), the
    /// nearest one in between.
    #[test]
    fn a_scene_given_by_poses_plays_the_nearest_one() {
        let poses: Vec<ProceduralScene> = (0..5)
            .map(|k| {
                let mut mesh = shapes::icosphere(1.0, 1);
                mesh.map_positions(|p| p + DVec3::X * f64::from(k));
                let object = OwnedObject { name: "ball".into(), mesh, params: ObjectParams::default() };
                ProceduralScene::new(format!("pose {k}"), vec![object], Vec::new())
            })
            .collect();
        assert!(BenchScene::from_poses("none", Vec::new()).is_none());
        let scene = BenchScene::from_poses("walk", poses).unwrap();
        assert_eq!(scene.rest.name, "pose 0");
        for (t, k) in [(0.0, 0), (0.25, 1), (0.3, 1), (0.4, 2), (1.0, 4), (7.0, 4), (-1.0, 0)] {
            assert_eq!(scene.pose(t).name, format!("pose {k}"), "t = {t}");
        }
        assert_eq!(BenchScene::frame_time(2, 5), 0.5);
    }

    #[test]
    fn poses_move_only_the_moving_objects_and_keep_the_connectivity() {
        let scene = fingers_ball(BenchSize::Quick);
        let (a, b) = (scene.pose(0.0), scene.pose(1.0));
        for (i, (oa, ob)) in a.objects.iter().zip(&b.objects).enumerate() {
            assert_eq!(oa.mesh.triangles, ob.mesh.triangles);
            let moving = scene.motions.iter().any(|m| m.object == i);
            assert_eq!(oa.mesh.positions != ob.mesh.positions, moving, "object {i}");
        }
        assert_eq!(scene.rest.pairs.len(), 4);
    }

    #[test]
    fn the_thesis_breakdowns_are_the_tables_rows() {
        let rows =
            [FINGERS_BALL, FINGERS_PALM, PLANE_SPHERE, SMALL_BIG_SPHERES, BUNNY_JELLY, WALK, HAT_EGG, HAND_PILLOW];
        for row in rows {
            // The tables' rounding: rows sum to 99–101 %.
            let sum: f64 = row.stages.iter().sum();
            assert!((99.0..=101.05).contains(&sum), "{}: {sum}", row.scene);
            let ms: f64 = ThesisRow::columns().filter_map(|s| row.stage_ms()[s]).sum();
            assert!((ms - row.ms * sum / 100.0).abs() < 1e-9, "{}", row.scene);
            // Table 7.2 (method B) has the factorization column, table 7.1 does not.
            assert_eq!(row.factorizations.is_some(), row.table == "7.2", "{}", row.scene);
            assert!(row.factorizations.is_none_or(|s| s > 0.0 && s < 100.0));
        }
        // Spot checks against the tables: hand – pillow's c., fingers – ball's g.
        assert_eq!(HAND_PILLOW.stages[2], 32.0);
        assert_eq!(ThesisRow::columns().count(), HAND_PILLOW.stages.len());
        assert!(FINGERS_BALL.stage_ms()[Stage::Guide].is_some_and(|ms| (ms - 1.68).abs() < 1e-12));
        assert_eq!(PLANE_SPHERE.stage_ms()[Stage::Factorization], None);
    }

    #[test]
    fn full_sizes_match_the_thesis_tables() {
        let vertices = |scene: BenchScene| scene.vertices();
        assert_eq!(vertices(small_big_spheres(BenchSize::Full)), [642, 10242]);
        assert_eq!(vertices(sphere_plane(BenchSize::Full))[0], 642);
        let feet = vertices(feet_plane(BenchSize::Full));
        assert_eq!(feet[0], 109 * 109);
        let stress: usize = vertices(stress_100k(BenchSize::Full)).iter().sum();
        assert!((95_000..105_000).contains(&stress), "{stress}");
        let hat: usize = vertices(hat_egg(BenchSize::Full))[0];
        assert!((11_500..12_500).contains(&hat), "{hat}");
    }

    #[test]
    fn the_bunny_working_region_is_a_valid_open_region_of_the_thesis_size() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/meshes/bunny_29834.obj");
        let Ok(bunny) = squish_io::read_obj(std::path::Path::new(path)) else {
            eprintln!("skipped: ../shared/data/meshes/bunny_29834.obj is absent");
            return;
        };
        let scene = bunny_jelly(bunny.clone(), BenchSize::Full);
        let region = &scene.rest.objects[0].mesh;
        let topology = region.check_for_deformation().unwrap();
        assert!(!topology.is_closed());
        assert!((14_000..=14_408).contains(&region.num_vertices()), "{}", region.num_vertices());
        let whole = bunny_whole_jelly(bunny, BenchSize::Full);
        assert_eq!(whole.rest.objects[0].mesh.num_vertices(), 29834);
    }

    #[test]
    fn the_automatic_press_gives_the_whole_press_up_to_round_off() {
        let (whole, automatic) = (press_100k(BenchSize::Quick), press_100k_automatic(BenchSize::Quick));
        let (mut a, mut b) = (Deformer::new(), Deformer::new());
        for t in [0.0, 0.5, 1.0] {
            let (pose_a, pose_b) = (whole.pose(t), automatic.pose(t));
            let (ra, rb) = (a.deform(&pose_a.frame()).unwrap(), b.deform(&pose_b.frame()).unwrap());
            let (mut worst, mut moved) = (0.0f64, 0.0f64);
            for (o, object) in pose_a.objects.iter().enumerate() {
                for ((p, q), input) in ra.positions[o].iter().zip(&rb.positions[o]).zip(&object.mesh.positions) {
                    worst = worst.max((*p - *q).length());
                    moved = moved.max((*p - *input).length());
                }
            }
            let regions: Vec<_> = rb.stats.regions.iter().map(|r| (r.object, r.vertices, r.domain_vertices)).collect();
            println!(
                "t = {t}: largest difference {worst:.2e} of a largest displacement {moved:.3e}; regions {regions:?}"
            );
            // The big sphere is cut (the ball's band may cover the whole ball).
            assert!(rb.stats.regions.iter().all(|r| !r.domain_reaches_cut && !r.extent_clamped));
            assert!(rb.stats.regions.iter().any(|r| r.object == 0 && !r.whole));
            assert!(moved > 0.01 && worst <= 1e-12 * moved, "t = {t}: {worst:.2e} of {moved:.2e}");
        }
    }

    #[test]
    fn the_hat_is_a_closed_manifold_shell() {
        let mesh = hat(1.1, 0.9, 24, 25);
        let topology = mesh.check_for_deformation().unwrap();
        assert!(topology.is_closed());
        // Outward orientation: a shell's volume is positive and ≈ ⅔π(1.1³ − 0.9³).
        let volume = squish::mesh::signed_volume(&mesh);
        let expected = 2.0 / 3.0 * std::f64::consts::PI * (1.1f64.powi(3) - 0.9f64.powi(3));
        assert!((volume - expected).abs() < 0.1 * expected, "{volume} vs {expected}");
    }
}
