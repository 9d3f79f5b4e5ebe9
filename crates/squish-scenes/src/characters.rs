//! Rigged characters for whole-character self-contact (`self_contact = "auto"`, issue 36): a
//! procedural humanoid in three extreme poses, and CesiumMan subdivided to ≥ 15k vertices, each
//! posed frame by frame by linear blend skinning. [`crate::shots`] measures a deformer on them.
//!
//! **The humanoid** ([`humanoid`]) is one closed, manifold, outward-oriented triangle mesh: the
//! zero set of a smooth union of 20 tapered capsules (pelvis, abdomen, chest, shoulders, neck,
//! head, upper arms, forearms, hands, thighs, shins, feet), meshed by naive surface nets on a
//! grid of cell `cell` and projected onto the zero set. z is up, the character faces +y, its
//! left side is −x; it stands 1.78 tall in an A-pose (arms 40° from the body), so the rest pose
//! has no self-intersection. Its skeleton has 17 joints ([`JOINTS`]); every vertex is skinned to
//! at most four joints by the distance to their capsules, normalized.
//!
//! **Its poses** ([`Pose`]) go from the rest pose at frame 0 to the extreme pose at the last
//! frame, each joint's rotation eased in by smoothstep in time: a deep squat with the elbows
//! fully bent, a crouch with the torso bent onto the thighs, the arms crossed over the chest.
//! The pelvis is moved so that the ankles stay where they are. Plain skinning of these poses
//! pushes the skin through itself more and more (thighs into calves, forearms into upper arms,
//! belly into thighs, arms into the chest and into each other).
//!
//! **CesiumMan subdivided** ([`cesium_man_subdivided`]): the glTF sample's mesh welded as
//! `squish run` welds it, every triangle split 1-to-9 (two new vertices on each edge, one at
//! each face's centroid), the new vertices' positions and weights interpolated linearly from
//! the edge's or face's corners and the weights cut to their four largest, renormalized
//! ([`subdivide_skinned`]); 21 026 vertices. Its walk is the file's animation.

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use glam::{DMat4, DQuat, DVec3};
use squish::mesh::TriMesh;
use squish::params::{Articulation, ArticulationParams, ObjectParams, SkinParts};
use squish::pipeline::OwnedObject;
use squish::skinning::{Skin, SkinWeights, joint_matrices, linear_blend_skinning};
use squish_io::scene::{JointPoints, automatic_self_contact};

/// A skinned mesh and its skeleton, posed by world transforms of its skeleton's nodes.
#[derive(Clone, Debug)]
pub struct RiggedCharacter {
    pub name: String,
    /// The bind pose.
    pub rest: TriMesh,
    pub weights: SkinWeights,
    /// Skin joints (node ids) and inverse bind matrices.
    pub skin: Skin,
    /// Per skin joint, its parent skin joint.
    pub parents: Vec<Option<usize>>,
    /// Per skin joint, its name.
    pub joint_names: Vec<String>,
    /// World transforms of the skeleton's nodes in the bind pose.
    pub rest_world: Vec<DMat4>,
}

/// What `self_contact = "auto"` finds on a character: its parts and the articulations of its
/// skeleton with the nodes giving their directions (as a scene file's `auto` finds them).
#[derive(Clone, Debug)]
pub struct AutoSelfContact {
    pub parts: SkinParts,
    pub articulations: Vec<(String, [Vec<u32>; 2], JointPoints)>,
}

impl RiggedCharacter {
    /// The mesh posed by plain linear blend skinning for these node world transforms.
    pub fn posed(&self, world: &[DMat4]) -> Result<TriMesh, String> {
        let matrices = joint_matrices(&self.skin, world).map_err(|e| e.to_string())?;
        let positions =
            linear_blend_skinning(&self.rest.positions, &self.weights, &matrices).map_err(|e| e.to_string())?;
        Ok(TriMesh { positions, triangles: self.rest.triangles.clone() })
    }

    /// `self_contact = "auto"` on this character ([`automatic_self_contact`], the analysis of a
    /// scene file's glTF skin, of `squish.Skin` and of the Blender add-on).
    pub fn auto_self_contact(&self) -> AutoSelfContact {
        let joints = &self.skin.joints;
        let points = |pair: [usize; 2]| JointPoints::of(&self.parents, pair, |j| joints[j], &self.rest_world);
        let found = automatic_self_contact(&self.rest, &self.weights, &self.parents, &self.joint_names, |pair| {
            points(pair).is_some()
        });
        let articulations =
            found.articulations.into_iter().filter_map(|a| Some((a.name, a.regions, points(a.joints)?))).collect();
        AutoSelfContact { parts: found.parts, articulations }
    }

    /// The object at the pose `world`: plain skinning, with `self_contact = "auto"` set up from
    /// `auto` when given (articulations posed by `world`, the parts, the bind pose).
    pub fn object(&self, world: &[DMat4], auto: Option<&AutoSelfContact>) -> Result<OwnedObject, String> {
        let mesh = self.posed(world)?;
        let mut params = ObjectParams::default();
        if let Some(auto) = auto {
            for (name, regions, points) in &auto.articulations {
                let joints = points.points(world).ok_or_else(|| format!("{name}: a node transform is missing"))?;
                params.self_contact.push(Articulation {
                    name: name.clone(),
                    regions: regions.clone(),
                    joints: Some(joints),
                    params: ArticulationParams::default(),
                    automatic: true,
                });
            }
            params.self_contact_parts = Some(auto.parts.clone());
            params.rest_positions = Some(self.rest.positions.clone());
        }
        Ok(OwnedObject { name: self.name.clone(), mesh, params })
    }
}

/// A character's animation: node world transforms at any (fractional) frame `0 ..= frames − 1`.
#[derive(Clone)]
pub struct CharacterShot {
    /// Short identifier, e.g. `"humanoid-squat"`.
    pub name: &'static str,
    pub character: Arc<RiggedCharacter>,
    pub frames: usize,
    pose: Arc<dyn Fn(f64) -> Vec<DMat4> + Send + Sync>,
}

impl std::fmt::Debug for CharacterShot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CharacterShot").field("name", &self.name).field("frames", &self.frames).finish_non_exhaustive()
    }
}

impl CharacterShot {
    pub fn new(
        name: &'static str,
        character: Arc<RiggedCharacter>,
        frames: usize,
        pose: impl Fn(f64) -> Vec<DMat4> + Send + Sync + 'static,
    ) -> Self {
        Self { name, character, frames, pose: Arc::new(pose) }
    }

    /// Node world transforms at frame `frame` (fractional frames in between: the animation is
    /// continuous in time).
    pub fn world(&self, frame: f64) -> Vec<DMat4> {
        (self.pose)(frame)
    }

    /// Plain skinning at `frame`.
    pub fn input(&self, frame: f64) -> Result<TriMesh, String> {
        self.character.posed(&self.world(frame))
    }

    /// The shot as a bench scene: every frame with `self_contact = "auto"`.
    pub fn bench_scene(&self) -> Result<crate::bench::BenchScene, String> {
        let auto = self.character.auto_self_contact();
        let poses = (0..self.frames)
            .map(|k| {
                let object = self.character.object(&self.world(k as f64), Some(&auto))?;
                Ok(crate::procedural::ProceduralScene::new(self.name.to_string(), vec![object], Vec::new()))
            })
            .collect::<Result<Vec<_>, String>>()?;
        crate::bench::BenchScene::from_poses(self.name, poses).ok_or_else(|| "no frame".to_string())
    }
}

// ---------------------------------------------------------------------------------------------
// The procedural humanoid

/// The humanoid's joints: name, parent, position in the rest pose (z up, facing +y, left = −x).
pub const JOINTS: [(&str, Option<usize>, [f64; 3]); 17] = [
    ("hips", None, [0.0, 0.0, 0.95]),
    ("spine", Some(0), [0.0, 0.0, 1.08]),
    ("chest", Some(1), [0.0, 0.0, 1.28]),
    ("neck", Some(2), [0.0, 0.0, 1.46]),
    ("head", Some(3), [0.0, 0.0, 1.58]),
    ("upper_arm.L", Some(2), [-0.19, 0.0, 1.42]),
    ("forearm.L", Some(5), [-0.19 - 0.27 * SIN40, 0.0, 1.42 - 0.27 * COS40]),
    ("hand.L", Some(6), [-0.19 - 0.52 * SIN40, 0.0, 1.42 - 0.52 * COS40]),
    ("upper_arm.R", Some(2), [0.19, 0.0, 1.42]),
    ("forearm.R", Some(8), [0.19 + 0.27 * SIN40, 0.0, 1.42 - 0.27 * COS40]),
    ("hand.R", Some(9), [0.19 + 0.52 * SIN40, 0.0, 1.42 - 0.52 * COS40]),
    ("thigh.L", Some(0), [-0.11, 0.0, 0.92]),
    ("shin.L", Some(11), [-0.11, 0.0, 0.5]),
    ("foot.L", Some(12), [-0.11, 0.0, 0.09]),
    ("thigh.R", Some(0), [0.11, 0.0, 0.92]),
    ("shin.R", Some(14), [0.11, 0.0, 0.5]),
    ("foot.R", Some(15), [0.11, 0.0, 0.09]),
];

const SIN40: f64 = 0.642_787_609_686_539_3;
const COS40: f64 = 0.766_044_443_118_978;

/// The default grid cell of [`humanoid`]: 4 314 vertices.
pub const HUMANOID_CELL: f64 = 0.024;

/// A tapered capsule of the humanoid, owned by a joint; `flat` scales its cross-section along y
/// (the torso's depth).
#[derive(Clone, Copy, Debug)]
struct Capsule {
    joint: usize,
    a: DVec3,
    b: DVec3,
    ra: f64,
    rb: f64,
    flat: f64,
}

impl Capsule {
    /// An approximate signed distance (exact for an untapered, unflattened capsule).
    fn distance(&self, p: DVec3) -> f64 {
        let mut q = p - self.a;
        q.y /= self.flat;
        let mut ab = self.b - self.a;
        ab.y /= self.flat;
        let t = (q.dot(ab) / ab.length_squared().max(1e-300)).clamp(0.0, 1.0);
        ((q - ab * t).length() - (self.ra + (self.rb - self.ra) * t)) * self.flat.min(1.0)
    }
}

fn joint_position(j: usize) -> DVec3 {
    DVec3::from_array(JOINTS[j].2)
}

/// The humanoid's capsules in the rest pose.
fn capsules() -> Vec<Capsule> {
    let v = DVec3::new;
    let c = |joint, a, b, ra, rb| Capsule { joint, a, b, ra, rb, flat: 1.0 };
    let mut list = vec![
        Capsule { joint: 0, a: v(-0.09, 0.0, 0.95), b: v(0.09, 0.0, 0.95), ra: 0.13, rb: 0.13, flat: 0.8 },
        Capsule { joint: 1, a: v(0.0, 0.0, 0.98), b: v(0.0, 0.0, 1.22), ra: 0.125, rb: 0.13, flat: 0.75 },
        Capsule { joint: 2, a: v(0.0, 0.0, 1.22), b: v(0.0, 0.0, 1.36), ra: 0.15, rb: 0.14, flat: 0.72 },
        c(2, v(-0.15, 0.0, 1.42), v(0.15, 0.0, 1.42), 0.065, 0.065),
        c(3, v(0.0, 0.0, 1.44), v(0.0, 0.0, 1.6), 0.05, 0.05),
        c(4, v(0.0, 0.01, 1.66), v(0.0, 0.01, 1.72), 0.095, 0.09),
    ];
    for (side, first) in [(-1.0, 5), (1.0, 8)] {
        let arm = DVec3::new(side * SIN40, 0.0, -COS40);
        let (shoulder, elbow, wrist) = (joint_position(first), joint_position(first + 1), joint_position(first + 2));
        list.push(c(first, shoulder, elbow, 0.05, 0.043));
        list.push(c(first + 1, elbow, wrist, 0.042, 0.033));
        list.push(c(first + 2, wrist, wrist + arm * 0.11, 0.033, 0.03));
    }
    for (side, first) in [(-1.0, 11), (1.0, 14)] {
        let (hip, knee, ankle) = (joint_position(first), joint_position(first + 1), joint_position(first + 2));
        list.push(c(first, hip, knee, 0.08, 0.056));
        list.push(c(first + 1, knee, ankle, 0.053, 0.038));
        let heel = ankle + v(0.0, -0.01, -0.025);
        list.push(c(first + 2, heel, v(side * 0.115, 0.16, 0.04), 0.04, 0.03));
    }
    list
}

/// Polynomial smooth minimum of width `k`.
fn smooth_min(a: f64, b: f64, k: f64) -> f64 {
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.min(b) - h * h * k * 0.25
}

/// The humanoid's implicit function: negative inside.
fn body(capsules: &[Capsule], p: DVec3) -> f64 {
    capsules.iter().fold(f64::INFINITY, |f, c| {
        let d = c.distance(p);
        if f.is_finite() { smooth_min(f, d, 0.04) } else { d }
    })
}

/// Naive surface nets of `f` (negative inside) on the grid of cell `cell` over `[lo, hi]`: one
/// vertex per cell the surface crosses (the mean of its edges' crossings, then projected onto
/// the zero set by Newton steps), one quad (two triangles, split along the shorter diagonal)
/// per grid edge crossing the surface, oriented outward. Manifold where the grid resolves the
/// surface (no cell crossed by two sheets).
fn surface_nets(f: &dyn Fn(DVec3) -> f64, lo: DVec3, hi: DVec3, cell: f64) -> TriMesh {
    let n = ((hi - lo) / cell).ceil().as_uvec3() + glam::UVec3::ONE;
    let (nx, ny, nz) = (n.x as usize, n.y as usize, n.z as usize);
    let index = |i: usize, j: usize, k: usize| (k * ny + j) * nx + i;
    let point = |i: usize, j: usize, k: usize| lo + DVec3::new(i as f64, j as f64, k as f64) * cell;
    let mut values = vec![0.0; nx * ny * nz];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let v = f(point(i, j, k));
                // No grid value exactly on the surface: every sign is strict.
                values[index(i, j, k)] = if v == 0.0 { 1e-12 } else { v };
            }
        }
    }
    let inside = |i: usize, j: usize, k: usize| values[index(i, j, k)] < 0.0;
    // Cell vertices.
    let mut cell_vertex = vec![u32::MAX; nx * ny * nz];
    let mut positions = Vec::new();
    const CORNERS: [[usize; 3]; 8] =
        [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1], [1, 1, 1]];
    const EDGES: [[usize; 2]; 12] =
        [[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6], [5, 7], [0, 4], [1, 5], [2, 6], [3, 7]];
    for k in 0..nz - 1 {
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                let corner = |c: usize| {
                    let [a, b, d] = CORNERS[c];
                    (point(i + a, j + b, k + d), values[index(i + a, j + b, k + d)])
                };
                let mut sum = DVec3::ZERO;
                let mut count = 0;
                for [a, b] in EDGES {
                    let ((pa, va), (pb, vb)) = (corner(a), corner(b));
                    if (va < 0.0) != (vb < 0.0) {
                        sum += pa + (pb - pa) * (va / (va - vb));
                        count += 1;
                    }
                }
                if count > 0 {
                    cell_vertex[index(i, j, k)] = positions.len() as u32;
                    positions.push(sum / f64::from(count));
                }
            }
        }
    }
    // Projection onto the zero set (central-difference gradients), at most half a cell.
    let step = 1e-4 * cell;
    for p in &mut positions {
        let start = *p;
        for _ in 0..3 {
            let g = DVec3::new(
                f(*p + DVec3::X * step) - f(*p - DVec3::X * step),
                f(*p + DVec3::Y * step) - f(*p - DVec3::Y * step),
                f(*p + DVec3::Z * step) - f(*p - DVec3::Z * step),
            ) / (2.0 * step);
            let value = f(*p);
            if g.length_squared() > 1e-12 {
                *p -= g * (value / g.length_squared());
            }
        }
        let offset = *p - start;
        if offset.length() > 0.5 * cell {
            *p = start + offset.normalize() * 0.5 * cell;
        }
    }
    // Quads around the grid edges crossing the surface.
    let mut triangles = Vec::new();
    let mut quad = |q: [u32; 4], outward_positive: bool| {
        let [a, b, c, d] = if outward_positive { q } else { [q[0], q[3], q[2], q[1]] };
        let (pa, pb, pc, pd) =
            (positions[a as usize], positions[b as usize], positions[c as usize], positions[d as usize]);
        // The diagonal whose worse triangle is the better one (area over longest edge²),
        // the shorter one when both are fine.
        let quality = |p: DVec3, q: DVec3, r: DVec3| {
            let longest = (q - p).length_squared().max((r - q).length_squared()).max((p - r).length_squared());
            (q - p).cross(r - p).length() / longest.max(f64::MIN_POSITIVE)
        };
        let along_ac = quality(pa, pb, pc).min(quality(pa, pc, pd));
        let along_bd = quality(pa, pb, pd).min(quality(pb, pc, pd));
        let shorter_ac = (pa - pc).length_squared() <= (pb - pd).length_squared();
        let ac = if along_ac.min(along_bd) > 0.1 { shorter_ac } else { along_ac >= along_bd };
        if ac {
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        } else {
            triangles.push([a, b, d]);
            triangles.push([b, c, d]);
        }
    };
    for k in 1..nz - 1 {
        for j in 1..ny - 1 {
            for i in 1..nx - 1 {
                let here = inside(i, j, k);
                // Edge along x to (i+1, j, k): cells around it in (y, z), counter-clockwise about +x.
                if i + 1 < nx && here != inside(i + 1, j, k) {
                    let q = [
                        cell_vertex[index(i, j - 1, k - 1)],
                        cell_vertex[index(i, j, k - 1)],
                        cell_vertex[index(i, j, k)],
                        cell_vertex[index(i, j - 1, k)],
                    ];
                    quad(q, here);
                }
                // Along y: cells in (z, x), counter-clockwise about +y.
                if j + 1 < ny && here != inside(i, j + 1, k) {
                    let q = [
                        cell_vertex[index(i - 1, j, k - 1)],
                        cell_vertex[index(i - 1, j, k)],
                        cell_vertex[index(i, j, k)],
                        cell_vertex[index(i, j, k - 1)],
                    ];
                    quad(q, here);
                }
                // Along z: cells in (x, y), counter-clockwise about +z.
                if k + 1 < nz && here != inside(i, j, k + 1) {
                    let q = [
                        cell_vertex[index(i - 1, j - 1, k)],
                        cell_vertex[index(i, j - 1, k)],
                        cell_vertex[index(i, j, k)],
                        cell_vertex[index(i - 1, j, k)],
                    ];
                    quad(q, here);
                }
            }
        }
    }
    TriMesh { positions, triangles }
}

/// A closed manifold mesh of one piece without degenerate triangles or self-intersections.
fn is_clean(mesh: &TriMesh) -> bool {
    let Ok(topology) = mesh.check_for_deformation() else { return false };
    topology.is_closed()
        && topology.vertex_components().1 == 1
        && squish::spatial::self_intersecting_faces(mesh, 0..mesh.num_triangles() as u32, |_, _| true)
            .is_ok_and(|faces| faces.is_empty())
}

/// Skin weights from the distances to the joints' capsules: joint j's weight is
/// `(1 − (d_j − d_min) / 0.04)²` where positive, the four largest kept, normalized.
fn humanoid_weights(capsules: &[Capsule], positions: &[DVec3]) -> SkinWeights {
    const FALLOFF: f64 = 0.04;
    let mut joints = Vec::with_capacity(positions.len());
    let mut weights = Vec::with_capacity(positions.len());
    for &p in positions {
        let mut d = [f64::INFINITY; JOINTS.len()];
        for c in capsules {
            d[c.joint] = d[c.joint].min(c.distance(p));
        }
        let least = d.iter().copied().fold(f64::INFINITY, f64::min);
        let mut w: Vec<(f64, u32)> = d
            .iter()
            .enumerate()
            .map(|(j, &dj)| ((1.0 - (dj - least) / FALLOFF).max(0.0).powi(2), j as u32))
            .filter(|&(w, _)| w > 0.0)
            .collect();
        w.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        w.truncate(4);
        let mut row_j = [0u32; 4];
        let mut row_w = [0.0; 4];
        for (k, (wk, jk)) in w.into_iter().enumerate() {
            row_j[k] = jk;
            row_w[k] = wk;
        }
        joints.push(row_j);
        weights.push(row_w);
    }
    // Rows are finite and non-negative with a positive sum (the nearest joint weighs 1).
    SkinWeights::new(joints, weights).unwrap_or_default()
}

/// The procedural humanoid (see the module doc) meshed on a grid of cell `cell` (world units;
/// [`HUMANOID_CELL`] by default, 4 314 vertices; vertices grow as 1/cell²).
pub fn humanoid(cell: f64) -> RiggedCharacter {
    let list = capsules();
    let f = |p: DVec3| body(&list, p);
    // Surface nets is manifold where no cell is crossed by two sheets: the grid is shifted
    // (deterministically) until the mesh is a valid closed manifold without self-intersections.
    let mut rest = TriMesh::default();
    for attempt in 0..24 {
        let shift = (DVec3::new(0.131, 0.293, 0.417) * f64::from(attempt)).fract_gl() * cell;
        let lo = DVec3::new(-0.75, -0.3, -0.05) - DVec3::splat(cell) + shift;
        let hi = DVec3::new(0.75, 0.3, 1.85);
        rest = surface_nets(&f, lo, hi, cell);
        if is_clean(&rest) {
            break;
        }
    }
    let weights = humanoid_weights(&list, &rest.positions);
    let rest_world: Vec<DMat4> = (0..JOINTS.len()).map(|j| DMat4::from_translation(joint_position(j))).collect();
    let inverse_bind = rest_world.iter().map(DMat4::inverse).collect();
    RiggedCharacter {
        name: "humanoid".into(),
        rest,
        weights,
        skin: Skin { joints: (0..JOINTS.len()).collect(), inverse_bind },
        parents: JOINTS.iter().map(|j| j.1).collect(),
        joint_names: JOINTS.iter().map(|j| j.0.to_string()).collect(),
        rest_world,
    }
}

/// The humanoid's extreme poses (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pose {
    /// A deep squat, the elbows fully bent: thighs against calves, forearms against upper arms.
    Squat,
    /// A crouch, the torso bent forward onto the thighs.
    Crouch,
    /// The arms crossed over the chest.
    ArmsCrossed,
}

impl Pose {
    pub const ALL: [Pose; 3] = [Pose::Squat, Pose::Crouch, Pose::ArmsCrossed];

    /// `"squat"`, `"crouch"`, `"arms-crossed"`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Squat => "squat",
            Self::Crouch => "crouch",
            Self::ArmsCrossed => "arms-crossed",
        }
    }

    /// The world direction of each joint's bone at the end of the animation (`None`: the bone
    /// keeps its rest direction relative to its parent), left side given, right side mirrored.
    fn targets(self) -> [Option<DVec3>; 17] {
        let v = |x: f64, y: f64, z: f64| Some(DVec3::new(x, y, z).normalize());
        let mut t: [Option<DVec3>; 17] = [None; 17];
        let foot_flat = v(0.0, 0.98, -0.17);
        let (spine, chest, neck, upper, fore, thigh, shin, foot);
        match self {
            Self::Squat => {
                spine = v(0.0, 0.45, 0.89);
                chest = v(0.0, 0.35, 0.94);
                neck = v(0.0, 0.15, 0.99);
                upper = v(-0.3, 0.45, -0.84);
                // Elbow bent 158°: the forearm 22° from the upper arm, on its front.
                fore = upper.map(|u| {
                    let n = (DVec3::Y - u * u.y).normalize();
                    (-u * 22f64.to_radians().cos() + n * 22f64.to_radians().sin()).normalize()
                });
                thigh = v(-0.25, 0.95, 0.12);
                shin = v(-0.05, -0.82, -0.57);
                foot = foot_flat;
            }
            Self::Crouch => {
                spine = v(0.0, 0.85, -0.3);
                chest = v(0.0, 0.6, -0.8);
                neck = v(0.0, 0.9, 0.1);
                upper = v(-0.35, 0.3, -0.89);
                fore = v(-0.15, 0.75, -0.64);
                thigh = v(-0.12, 0.9, -0.25);
                shin = v(0.0, -0.7, -0.72);
                foot = foot_flat;
            }
            Self::ArmsCrossed => {
                spine = None;
                chest = None;
                neck = None;
                upper = v(-0.15, 0.35, -0.92);
                fore = v(0.9, 0.28, 0.33);
                thigh = None;
                shin = None;
                foot = None;
            }
        }
        t[1] = spine;
        t[2] = chest;
        t[3] = neck;
        t[5] = upper;
        t[6] = fore;
        t[11] = thigh;
        t[12] = shin;
        t[13] = foot;
        let mirror = |d: Option<DVec3>| d.map(|d| DVec3::new(-d.x, d.y, d.z));
        t[8] = mirror(upper);
        // Crossed arms: the right forearm passes below and behind the left one.
        t[9] = if self == Self::ArmsCrossed { v(-0.9, 0.12, 0.42) } else { mirror(fore) };
        t[14] = mirror(thigh);
        t[15] = mirror(shin);
        t[16] = mirror(foot);
        t
    }

    /// Each joint's local rotation at the end of the animation: the shortest arc taking its
    /// bone's rest direction to its target, in its parent's posed frame.
    fn end_rotations(self) -> [DQuat; 17] {
        let targets = self.targets();
        let mut local = [DQuat::IDENTITY; 17];
        let mut world = [DQuat::IDENTITY; 17];
        for j in 0..JOINTS.len() {
            let parent = JOINTS[j].1.map_or(DQuat::IDENTITY, |p| world[p]);
            if let Some(target) = targets[j] {
                let rest = bone_direction(j);
                local[j] = DQuat::from_rotation_arc(rest, parent.inverse() * target);
            }
            world[j] = parent * local[j];
        }
        local
    }
}

/// The rest direction of joint j's bone: towards its first child, or the hand's and foot's own.
fn bone_direction(j: usize) -> DVec3 {
    match j {
        7 => DVec3::new(-SIN40, 0.0, -COS40),
        10 => DVec3::new(SIN40, 0.0, -COS40),
        13 | 16 => DVec3::new(0.0, 0.98, -0.17).normalize(),
        4 => DVec3::Z,
        _ => {
            let child = (0..JOINTS.len()).find(|&c| JOINTS[c].1 == Some(j)).unwrap_or(j);
            (joint_position(child) - joint_position(j)).normalize_or(DVec3::Z)
        }
    }
}

/// Joint world transforms for these local rotations, the pelvis at `root` offset from rest.
fn forward_kinematics(local: &[DQuat; 17], root: DVec3) -> Vec<DMat4> {
    let mut world: Vec<DMat4> = Vec::with_capacity(JOINTS.len());
    for (j, &(_, parent, p)) in JOINTS.iter().enumerate() {
        let m = match parent {
            None => DMat4::from_rotation_translation(local[j], DVec3::from_array(p) + root),
            Some(q) => world[q] * DMat4::from_rotation_translation(local[j], DVec3::from_array(p) - joint_position(q)),
        };
        world.push(m);
    }
    world
}

/// The humanoid's world transforms at `s ∈ [0, 1]` of the way from the rest pose to `pose`
/// (each rotation slerped from the identity), the pelvis moved so that the ankles' midpoint
/// stays at rest.
pub fn humanoid_pose(pose: Pose, s: f64) -> Vec<DMat4> {
    let end = pose.end_rotations();
    let local: [DQuat; 17] = std::array::from_fn(|j| DQuat::IDENTITY.slerp(end[j], s));
    let world = forward_kinematics(&local, DVec3::ZERO);
    let ankles = |w: &[DMat4]| (w[13].w_axis.truncate() + w[16].w_axis.truncate()) * 0.5;
    let rest = (joint_position(13) + joint_position(16)) * 0.5;
    forward_kinematics(&local, rest - ankles(&world))
}

/// Smoothstep easing.
pub fn smoothstep(t: f64) -> f64 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The humanoid going from rest into `pose` over `frames` frames (smoothstep in time), as a
/// shot named `humanoid-<pose>`.
pub fn humanoid_shot(character: Arc<RiggedCharacter>, pose: Pose, frames: usize) -> CharacterShot {
    let name = match pose {
        Pose::Squat => "humanoid-squat",
        Pose::Crouch => "humanoid-crouch",
        Pose::ArmsCrossed => "humanoid-arms-crossed",
    };
    let last = frames.saturating_sub(1).max(1) as f64;
    CharacterShot::new(name, character, frames, move |frame| humanoid_pose(pose, smoothstep(frame / last)))
}

/// The three shots of the default humanoid, `frames` frames each.
pub fn humanoid_shots(cell: f64, frames: usize) -> Vec<CharacterShot> {
    let character = Arc::new(humanoid(cell));
    Pose::ALL.iter().map(|&pose| humanoid_shot(character.clone(), pose, frames)).collect()
}

// ---------------------------------------------------------------------------------------------
// Subdivision

/// Where a vertex of a subdivided mesh comes from: up to three corners of the original mesh
/// and their barycentric weights (summing to 1).
pub type Origin = [(u32, f64); 3];

/// Every triangle split 1-to-9: two new vertices on each edge (at ⅓ and ⅔, shared by the
/// edge's two faces), one at each face's centroid; positions and skin weights interpolated
/// linearly, the weights cut to their four largest and renormalized. Returns the mesh, its
/// weights and each vertex's origin (original vertices first, in order). A closed manifold
/// mesh stays closed and manifold, with the same orientation.
pub fn subdivide_skinned(mesh: &TriMesh, weights: &SkinWeights) -> (TriMesh, SkinWeights, Vec<Origin>) {
    let mut origins: Vec<Origin> = (0..mesh.num_vertices() as u32).map(|v| [(v, 1.0), (v, 0.0), (v, 0.0)]).collect();
    let mut edge_points: HashMap<(u32, u32), [u32; 2]> = HashMap::new();
    // The points at ⅓ and ⅔ from a to b.
    let mut on_edge = |a: u32, b: u32, origins: &mut Vec<Origin>| -> [u32; 2] {
        let (lo, hi) = (a.min(b), a.max(b));
        let points = *edge_points.entry((lo, hi)).or_insert_with(|| {
            let first = origins.len() as u32;
            origins.push([(lo, 2.0 / 3.0), (hi, 1.0 / 3.0), (hi, 0.0)]);
            origins.push([(lo, 1.0 / 3.0), (hi, 2.0 / 3.0), (hi, 0.0)]);
            [first, first + 1]
        });
        if a == lo { points } else { [points[1], points[0]] }
    };
    let mut triangles = Vec::with_capacity(9 * mesh.num_triangles());
    for &[a, b, c] in &mesh.triangles {
        let [ab1, ab2] = on_edge(a, b, &mut origins);
        let [bc1, bc2] = on_edge(b, c, &mut origins);
        let [ca1, ca2] = on_edge(c, a, &mut origins);
        let m = origins.len() as u32;
        origins.push([(a, 1.0 / 3.0), (b, 1.0 / 3.0), (c, 1.0 / 3.0)]);
        triangles.extend_from_slice(&[
            [a, ab1, ca2],
            [ab1, ab2, m],
            [ab1, m, ca2],
            [ab2, b, bc1],
            [ab2, bc1, m],
            [m, bc1, bc2],
            [ca2, m, ca1],
            [ca1, m, bc2],
            [ca1, bc2, c],
        ]);
    }
    let positions =
        origins.iter().map(|o| o.iter().fold(DVec3::ZERO, |s, &(v, l)| s + mesh.positions[v as usize] * l)).collect();
    let (js, ws) = (weights.joints(), weights.weights());
    let mut joints = Vec::with_capacity(origins.len());
    let mut rows = Vec::with_capacity(origins.len());
    for o in &origins {
        let mut sum: Vec<(u32, f64)> = Vec::with_capacity(12);
        for &(v, l) in o {
            if l == 0.0 {
                continue;
            }
            for (&j, &w) in js[v as usize].iter().zip(&ws[v as usize]) {
                if w == 0.0 {
                    continue;
                }
                match sum.iter_mut().find(|(k, _)| *k == j) {
                    Some(entry) => entry.1 += l * w,
                    None => sum.push((j, l * w)),
                }
            }
        }
        sum.sort_by(|x, y| y.1.total_cmp(&x.1).then(x.0.cmp(&y.0)));
        sum.truncate(4);
        let mut row_j = [0u32; 4];
        let mut row_w = [0.0; 4];
        for (k, (j, w)) in sum.into_iter().enumerate() {
            row_j[k] = j;
            row_w[k] = w;
        }
        joints.push(row_j);
        rows.push(row_w);
    }
    // Rows come from valid weights: finite, non-negative.
    let weights = SkinWeights::new(joints, rows).unwrap_or_default();
    (TriMesh { positions, triangles }, weights, origins)
}

/// A glTF file's skinned character: the first skinned mesh instance, welded as `squish run`
/// welds a glTF mesh (`weld = true`, exact), with its first animation.
pub fn gltf_character(path: &Path) -> Result<(RiggedCharacter, Arc<squish_io::GltfScene>), String> {
    let options = squish_io::GltfReadOptions::default().with_weld(squish_io::WeldMode::Exact);
    let scene = squish_io::read_gltf(path, &options).map_err(|e| e.to_string())?;
    let instance = scene
        .instances()
        .into_iter()
        .find(|i| i.skin.is_some())
        .ok_or_else(|| format!("{}: no skinned mesh", path.display()))?;
    let mesh = &scene.meshes[instance.mesh];
    let skin = &scene.skins[instance.skin.unwrap_or_default()].skin;
    let weights = mesh.skin_weights.clone().ok_or_else(|| format!("{}: no skin weights", path.display()))?;
    let joints = &skin.joints;
    let joint_names = joints.iter().map(|&n| scene.nodes.get(n).map_or_else(String::new, |n| n.name.clone())).collect();
    let parents = joints
        .iter()
        .map(|&n| scene.nodes.get(n).and_then(|node| node.parent).and_then(|p| joints.iter().position(|&j| j == p)))
        .collect();
    let name = path.file_stem().map_or_else(|| "character".into(), |s| s.to_string_lossy().into_owned());
    let character = RiggedCharacter {
        name,
        rest: TriMesh { positions: mesh.positions.clone(), triangles: mesh.triangles.clone() },
        weights,
        skin: skin.clone(),
        parents,
        joint_names,
        rest_world: scene.skeleton.rest_world_transforms(),
    };
    Ok((character, Arc::new(scene)))
}

/// CesiumMan (`rigged/CesiumMan.glb` of the shared data) subdivided 1-to-9 with interpolated
/// weights ([`subdivide_skinned`]): 21 026 vertices.
pub fn cesium_man_subdivided(path: &Path) -> Result<(RiggedCharacter, Arc<squish_io::GltfScene>), String> {
    let (original, scene) = gltf_character(path)?;
    let (rest, weights, _) = subdivide_skinned(&original.rest, &original.weights);
    Ok((RiggedCharacter { name: "cesium_man_15k".into(), rest, weights, ..original }, scene))
}

/// A glTF character's walk: its first animation sampled at `fps` over `frames` frames from
/// time 0 (looped over the clip's duration), fractional frames in between.
pub fn gltf_shot(
    name: &'static str,
    character: Arc<RiggedCharacter>,
    scene: Arc<squish_io::GltfScene>,
    frames: usize,
    fps: f64,
) -> CharacterShot {
    let duration = scene.animations.first().map_or(0.0, |a| a.duration());
    let animation = (!scene.animations.is_empty()).then_some(0);
    CharacterShot::new(name, character, frames, move |frame| {
        let mut time = frame / fps;
        if duration > 0.0 {
            time = time.rem_euclid(duration);
        }
        scene.world_transforms(animation, time).unwrap_or_else(|_| scene.skeleton.rest_world_transforms())
    })
}

/// The shared data's CesiumMan walk, 48 frames at 24 fps, on the original mesh
/// (`"cesium-man-walk"`) or subdivided (`"cesium-man-15k-walk"`).
pub fn cesium_man_walk(path: &Path, subdivided: bool) -> Result<CharacterShot, String> {
    let (character, scene) = if subdivided { cesium_man_subdivided(path)? } else { gltf_character(path)? };
    let name = if subdivided { "cesium-man-15k-walk" } else { "cesium-man-walk" };
    Ok(gltf_shot(name, Arc::new(character), scene, 48, 24.0))
}
