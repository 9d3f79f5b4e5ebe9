//! Physical references: quasi-static FEM + IPC simulations of elastic spheres in contact
//! (`data/fem/`, made by `data/fem/ipc_sphere_contact.py`: compressible neo-Hookean tetrahedra,
//! E = 10⁵, ν = 0.45, IPC barrier contact), as deformer inputs and as the shapes the deformer's
//! outputs are measured against (docs/plausibility.md).
//!
//! Conventions of the references: the contact axis is z; sphere A (radius R_A) lies above the
//! contact and is pressed down, B (a sphere of radius R_B fixed at its bottom, or the rigid plane
//! z = 0) below it. A reference keeps each body's whole rest surface, its *contact side* (the rest
//! vertices within a polar angle of the contact axis, see [`FemBody::cap`]) and, per step, the
//! simulated positions of those vertices.
//!
//! **The input of a step** is the rigid approach the simulation reached: the rest spheres with A's
//! centre lowered by the centres' approach (`center_approach − center_drop_B`, the drop of B's
//! centre on its fixed base taken off), intersecting ([`FemReference::input`]). Everything is
//! measured in B's centre frame: the simulated positions are moved up by B's centre drop.
//!
//! **Measures** ([`FemReference::compare`]), on each deformable body's contact side — the rest
//! vertices within the polar angle `min(π/2, 3·R_min/R)` of the contact axis (a hemisphere for the
//! smaller sphere, a cap of arc 3·R_min on a larger one):
//! - the symmetric Hausdorff distance between the deformed contact side and the simulated one:
//!   the larger of the farthest deformed vertex from the simulated surface and the farthest
//!   simulated vertex from the deformed surface (point–triangle distances);
//! - the contact radius: the largest distance from the axis of a vertex of A in the contact zone
//!   (the simulation's: of a vertex within 2·10⁻³ R_A of the obstacle — the same vertex rule);
//! - the bulge height: the largest outward displacement along the rest normal, from the rigid
//!   input, over the contact side;
//! - the spread: the largest arc distance from the contact axis (on the rest sphere) of a vertex
//!   whose displacement from the rigid input is at least 10% of the body's largest.

use glam::DVec3;

use squish::mesh::{TriMesh, shapes, vertex_normals};
use squish::params::ObjectParams;
use squish::pipeline::FramePair;
use squish::spatial::TriangleBvh;

use crate::procedural::ProceduralScene;
use squish::OwnedObject;

/// The displacement, as a fraction of a body's largest, down to which a vertex counts in its spread.
pub const SPREAD_FRACTION: f64 = 0.1;

/// What B is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FemScene {
    /// A sphere pressed on the rigid plane z = 0.
    Plane,
    /// Sphere A pressed on sphere B.
    Spheres,
}

/// One elastic body of a reference.
#[derive(Clone, Debug)]
pub struct FemBody {
    /// Its whole rest surface (the deformer's input before the approach).
    pub rest: TriMesh,
    pub radius: f64,
    /// Its rest centre.
    pub centre: DVec3,
    /// The unit direction from its centre to the contact.
    pub toward: DVec3,
    /// The rest vertex ids whose simulated positions are kept (increasing): the contact side and
    /// a margin of 0.15 rad.
    pub cap: Vec<u32>,
    /// The rest faces whose three vertices are in the cap, in cap ids.
    pub cap_faces: Vec<[u32; 3]>,
}

impl FemBody {
    /// A body from its rest surface, radius, centre, direction to the contact and cap ids.
    pub fn new(rest: TriMesh, radius: f64, centre: DVec3, toward: DVec3, cap: Vec<u32>) -> Result<Self, String> {
        let n = rest.num_vertices();
        let mut slot = vec![u32::MAX; n];
        for (k, &v) in cap.iter().enumerate() {
            let Some(s) = slot.get_mut(v as usize) else {
                return Err(format!("cap vertex {v} is not a vertex of the rest surface ({n} vertices)"));
            };
            *s = k as u32;
        }
        let cap_faces = rest
            .triangles
            .iter()
            .filter_map(|t| {
                let ids = t.map(|v| slot[v as usize]);
                ids.iter().all(|&s| s != u32::MAX).then_some(ids)
            })
            .collect();
        Ok(Self { rest, radius, centre, toward, cap, cap_faces })
    }

    /// The polar angle from the contact axis of a rest point.
    fn polar_angle(&self, p: DVec3) -> f64 {
        let r = p - self.centre;
        (r.dot(self.toward) / r.length()).clamp(-1.0, 1.0).acos()
    }
}

/// One step of a reference: the simulation's figures and positions.
#[derive(Clone, Debug)]
pub struct FemStep {
    /// Step number (1-based, as in the file names).
    pub step: usize,
    /// Displacement of A's top cap (the platen).
    pub delta: f64,
    /// Drop of A's centre from its rest position.
    pub center_approach: f64,
    /// Drop of B's centre (0 for the plane).
    pub center_drop_b: f64,
    /// Contact force on the platen.
    pub force: f64,
    /// The simulation's contact radius (largest distance from the axis of a vertex of A within
    /// 2·10⁻³ R_A of the obstacle).
    pub contact_radius: f64,
    /// Per body, the simulated positions of its cap vertices (in cap order), in the simulation's
    /// frame.
    pub caps: Vec<Vec<DVec3>>,
}

impl FemStep {
    /// The approach of the two centres: what the deformer's input is given.
    pub fn approach(&self) -> f64 {
        self.center_approach - self.center_drop_b
    }
}

/// A reference: its scene, bodies and steps.
#[derive(Clone, Debug)]
pub struct FemReference {
    pub name: String,
    pub scene: FemScene,
    /// A, then B for [`FemScene::Spheres`].
    pub bodies: Vec<FemBody>,
    pub steps: Vec<FemStep>,
}

/// The figures of one step: the deformer's against the simulation's.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepComparison {
    /// The centres' approach over R_min.
    pub relative_approach: f64,
    /// Per deformable body (A, then B for spheres): the symmetric Hausdorff distance on its
    /// contact side over R_min.
    pub hausdorff: Vec<f64>,
    /// The contact radius of the deformer (from A's zone) and of the simulation.
    pub contact_radius: [f64; 2],
    /// Per body: the bulge height of the deformer and of the simulation.
    pub bulge: Vec<[f64; 2]>,
    /// Per body: the spread of the deformer and of the simulation.
    pub spread: Vec<[f64; 2]>,
}

impl StepComparison {
    /// The largest Hausdorff distance over the bodies (over R_min).
    pub fn worst_hausdorff(&self) -> f64 {
        self.hausdorff.iter().copied().fold(0.0, f64::max)
    }

    /// Deformer's contact radius over the simulation's, minus 1.
    pub fn contact_radius_error(&self) -> f64 {
        self.contact_radius[0] / self.contact_radius[1] - 1.0
    }
}

/// Parses `key = value` lines.
fn value<'a>(text: &'a str, key: &str) -> Result<&'a str, String> {
    text.lines()
        .filter_map(|l| l.split_once('='))
        .find(|(k, _)| k.trim() == key)
        .map(|(_, v)| v.trim())
        .ok_or_else(|| format!("reference.txt has no `{key}`"))
}

fn number(text: &str, key: &str) -> Result<f64, String> {
    let v = value(text, key)?;
    v.parse().map_err(|_| format!("`{key} = {v}` is not a number"))
}

fn vector(text: &str, key: &str) -> Result<DVec3, String> {
    let v = value(text, key)?;
    let xs: Vec<f64> =
        v.split_whitespace().map(str::parse).collect::<Result<_, _>>().map_err(|_| format!("`{key} = {v}`"))?;
    match xs[..] {
        [x, y, z] => Ok(DVec3::new(x, y, z)),
        _ => Err(format!("`{key} = {v}` is not three numbers")),
    }
}

/// The rows of `summary.csv` as maps from column to value.
fn summary_rows(csv: &str) -> Result<Vec<Vec<(String, f64)>>, String> {
    let mut lines = csv.lines().filter(|l| !l.trim().is_empty());
    let header: Vec<String> =
        lines.next().ok_or("summary.csv is empty")?.split(',').map(|s| s.trim().to_string()).collect();
    lines
        .map(|line| {
            let values: Vec<f64> = line
                .split(',')
                .map(|s| s.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|e| format!("summary.csv: `{line}`: {e}"))?;
            Ok(header.iter().cloned().zip(values).collect())
        })
        .collect()
}

fn column(row: &[(String, f64)], name: &str) -> Option<f64> {
    row.iter().find(|(k, _)| k == name).map(|(_, v)| *v)
}

impl FemReference {
    /// A reference from its files' contents: `reference.txt`, `summary.csv`, the rest surfaces,
    /// the cap ids (whitespace-separated) and, per step in the order of `summary.csv`, per body,
    /// the simulated cap positions.
    pub fn parse(
        name: &str,
        reference: &str,
        summary: &str,
        rest: Vec<TriMesh>,
        caps: &[&str],
        steps: Vec<Vec<Vec<DVec3>>>,
    ) -> Result<Self, String> {
        let scene = match value(reference, "scene")? {
            "plane" => FemScene::Plane,
            "spheres" => FemScene::Spheres,
            other => return Err(format!("unknown scene `{other}`")),
        };
        let names = match scene {
            FemScene::Plane => &["A"][..],
            FemScene::Spheres => &["A", "B"][..],
        };
        if rest.len() != names.len() || caps.len() != names.len() {
            return Err(format!("{name}: {} bodies expected", names.len()));
        }
        let mut bodies = Vec::new();
        for ((body, mesh), cap) in names.iter().zip(rest).zip(caps) {
            let radius = number(reference, &format!("radius_{body}"))?;
            let centre = vector(reference, &format!("centre_{body}"))?;
            let toward = if *body == "A" { -DVec3::Z } else { DVec3::Z };
            let ids: Vec<u32> = cap
                .split_whitespace()
                .map(str::parse)
                .collect::<Result<_, _>>()
                .map_err(|e| format!("cap ids: {e}"))?;
            bodies.push(FemBody::new(mesh, radius, centre, toward, ids)?);
        }
        let rows = summary_rows(summary)?;
        if rows.len() != steps.len() {
            return Err(format!("{name}: summary.csv has {} steps, {} step files were given", rows.len(), steps.len()));
        }
        let mut out = Vec::new();
        for (row, caps) in rows.iter().zip(steps) {
            let get = |c: &str| column(row, c).ok_or_else(|| format!("summary.csv has no column `{c}`"));
            if caps.len() != bodies.len() || caps.iter().zip(&bodies).any(|(c, b)| c.len() != b.cap.len()) {
                return Err(format!("{name}: a step's cap positions do not match the caps"));
            }
            out.push(FemStep {
                step: get("step")? as usize,
                delta: get("delta")?,
                center_approach: get("center_approach")?,
                center_drop_b: column(row, "center_drop_B").unwrap_or(0.0),
                force: get("force")?,
                contact_radius: get("contact_radius")?,
                caps,
            });
        }
        Ok(Self { name: name.to_string(), scene, bodies, steps: out })
    }

    /// The smaller radius of the elastic bodies.
    pub fn min_radius(&self) -> f64 {
        self.bodies.iter().map(|b| b.radius).fold(f64::INFINITY, f64::min)
    }

    /// The deformer's input at `step` (an index into [`Self::steps`]): A lowered by the centres'
    /// approach onto B at rest, or onto a rigid plane grid at z = 0 (of 4·R_A across, edges about
    /// A's), each object with `params(body)` (the plane is rigid whatever it says).
    pub fn input(&self, step: usize, params: impl Fn(usize) -> ObjectParams) -> ProceduralScene {
        let approach = self.steps[step].approach();
        let a = &self.bodies[0];
        let mut sphere = a.rest.clone();
        sphere.map_positions(|p| p - DVec3::Z * approach);
        let mut objects = vec![OwnedObject { name: "A".into(), mesh: sphere, params: params(0) }];
        match self.scene {
            FemScene::Plane => {
                let edge = squish::mesh::mean_edge_length(&a.rest, &squish::Topology::new(&a.rest));
                let cells = (4.0 * a.radius / edge).ceil().clamp(2.0, 400.0) as u32;
                let plane = shapes::grid(4.0 * a.radius, 4.0 * a.radius, cells, cells);
                objects.push(OwnedObject { name: "plane".into(), mesh: plane, params: ObjectParams::rigid() });
            }
            FemScene::Spheres => {
                objects.push(OwnedObject { name: "B".into(), mesh: self.bodies[1].rest.clone(), params: params(1) });
            }
        }
        let pairs = vec![FramePair { objects: [0, 1], params: Default::default() }];
        ProceduralScene::new(self.name.clone(), objects, pairs)
    }

    /// The deformer's figures at `step` against the simulation's (see the module doc):
    /// `positions` are the deformed positions of the input's objects, `contact_a` the contact
    /// zone flags of A's vertices.
    pub fn compare(&self, step: usize, positions: &[Vec<DVec3>], contact_a: &[bool]) -> StepComparison {
        let s = &self.steps[step];
        let r_min = self.min_radius();
        let lift = DVec3::Z * s.center_drop_b;
        let approach = s.approach();
        let mut out = StepComparison { relative_approach: approach / r_min, ..Default::default() };
        for (k, body) in self.bodies.iter().enumerate() {
            let rigid_offset = if k == 0 { -DVec3::Z * approach } else { DVec3::ZERO };
            let output = &positions[k];
            let simulated: Vec<DVec3> = s.caps[k].iter().map(|p| *p + lift).collect();
            let limit = (0.5 * std::f64::consts::PI).min(3.0 * r_min / body.radius);
            let compared: Vec<usize> = (0..body.cap.len())
                .filter(|&c| body.polar_angle(body.rest.positions[body.cap[c] as usize]) <= limit)
                .collect();
            let simulated_mesh = TriMesh { positions: simulated.clone(), triangles: body.cap_faces.clone() };
            let output_mesh = TriMesh { positions: output.clone(), triangles: body.rest.triangles.clone() };
            let (Ok(simulated_tree), Ok(output_tree)) =
                (TriangleBvh::new(&simulated_mesh), TriangleBvh::new(&output_mesh))
            else {
                out.hausdorff.push(f64::INFINITY);
                continue;
            };
            let distance = |tree: &TriangleBvh, p: DVec3| tree.closest_point(p).map_or(f64::INFINITY, |c| c.distance);
            let mut hausdorff = 0.0f64;
            for &c in &compared {
                let v = body.cap[c] as usize;
                hausdorff =
                    hausdorff.max(distance(&simulated_tree, output[v])).max(distance(&output_tree, simulated[c]));
            }
            out.hausdorff.push(hausdorff / r_min);
            let normals = vertex_normals(&body.rest);
            let rigid: Vec<DVec3> = body.cap.iter().map(|&v| body.rest.positions[v as usize] + rigid_offset).collect();
            let deformed: Vec<DVec3> = body.cap.iter().map(|&v| output[v as usize]).collect();
            let (mut bulge, mut spread) = ([0.0; 2], [0.0; 2]);
            for (which, moved) in [&deformed, &simulated].into_iter().enumerate() {
                let displacement = |c: usize| moved[c] - rigid[c];
                let largest = compared.iter().map(|&c| displacement(c).length()).fold(0.0, f64::max);
                for &c in &compared {
                    let v = body.cap[c] as usize;
                    bulge[which] = f64::max(bulge[which], displacement(c).dot(normals[v]));
                    if largest > 0.0 && displacement(c).length() >= SPREAD_FRACTION * largest {
                        spread[which] = f64::max(spread[which], body.polar_angle(body.rest.positions[v]) * body.radius);
                    }
                }
            }
            out.bulge.push(bulge);
            out.spread.push(spread);
        }
        let a = &self.bodies[0];
        let radius = (0..a.rest.num_vertices())
            .filter(|&v| contact_a.get(v).copied().unwrap_or(false))
            .map(|v| {
                let p = positions[0][v];
                (p.x * p.x + p.y * p.y).sqrt()
            })
            .fold(0.0, f64::max);
        out.contact_radius = [radius, s.contact_radius];
        out
    }
}
