//! What the page is sent: the scene once (objects' triangles, pairs, frames, the parameter
//! schema) and, for every computed frame, the input and output positions, the overlays of the
//! deformation (contact zone, deformable region, radial parameter u, bulge map), each object's
//! profile curve (§5.4.1, evaluated by the core's own B-spline) and the readouts.

use serde::Serialize;
use squish::TriMesh;
use squish::deform::{Profile, Wrinkles};
use squish::params::SchemaEntry;

use super::session::{Computed, Session, ShownValues};

/// The scene as the page builds its view and controls from.
#[derive(Serialize)]
pub struct SceneView {
    pub name: String,
    pub frames: FramesView,
    pub objects: Vec<ObjectView>,
    pub pairs: Vec<PairView>,
    /// Every parameter of the deformer (`squish params --json`'s rows).
    pub schema: Vec<SchemaEntry>,
}

#[derive(Serialize)]
pub struct FramesView {
    pub start: i64,
    pub end: i64,
    pub fps: f64,
}

#[derive(Serialize)]
pub struct ObjectView {
    pub name: String,
    /// Flat vertex indices, three per triangle.
    pub triangles: Vec<u32>,
}

#[derive(Serialize)]
pub struct PairView {
    pub objects: [usize; 2],
    pub names: [String; 2],
}

impl SceneView {
    pub fn of(session: &Session) -> Result<Self, String> {
        let description = session.scene.description();
        let frame = session.frame(&session.edits)?;
        let name = session.scene.path().file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        Ok(Self {
            name,
            frames: FramesView {
                start: *session.scene.frames().start(),
                end: *session.scene.frames().end(),
                fps: description.frames.fps,
            },
            objects: frame
                .objects
                .iter()
                .map(|o| ObjectView {
                    name: o.name.clone(),
                    triangles: o.mesh.triangles.iter().flatten().copied().collect(),
                })
                .collect(),
            pairs: description
                .pairs
                .iter()
                .map(|p| {
                    let index = |n: &str| description.objects.iter().position(|o| o.name == n).unwrap_or(0);
                    PairView { objects: [index(&p.objects[0]), index(&p.objects[1])], names: p.objects.clone() }
                })
                .collect(),
            schema: squish::params::schema_entries(),
        })
    }
}

/// One computed frame for the page.
#[derive(Serialize)]
pub struct FrameView {
    /// The edits' version this frame computed (the page drops older ones).
    pub version: u64,
    pub frame: i64,
    /// True if it was a fast edit of the previous frame (§5.4–5.5 only).
    pub edit: bool,
    pub total_ms: f64,
    /// Per stage, milliseconds.
    pub stages: std::collections::BTreeMap<String, f64>,
    pub objects: Vec<ObjectFrameView>,
    pub pairs: Vec<squish_shot::frame_quality::PairQuality>,
    /// Per object and pair, the value of every parameter at this frame.
    pub values: ValuesView,
    pub warnings: Vec<String>,
}

#[derive(Serialize)]
pub struct ValuesView {
    pub objects: Vec<ShownValues>,
    pub pairs: Vec<ShownValues>,
}

#[derive(Serialize)]
pub struct ObjectFrameView {
    pub name: String,
    /// Flat x, y, z of the input and of the output.
    pub input: Vec<f64>,
    pub output: Vec<f64>,
    pub quality: squish_shot::frame_quality::ObjectQuality,
    /// Overlays, per vertex (absent when the object was not deformed): u in [0, 1] inside the
    /// deformable region and −1 elsewhere; contact and deformable as 0/1; η.
    pub overlays: Option<Overlays>,
    /// η per vertex as painted or read from the scene (absent: uniform 1).
    pub painted: Option<Vec<f64>>,
    /// Per vertex, 1 on a face that intersects another face of the frame (of this object or
    /// another; the exact test of `squish info`), on the input and on the output.
    pub intersecting: Intersecting,
    pub profile: ProfileView,
}

#[derive(Serialize)]
pub struct Overlays {
    pub u: Vec<f64>,
    pub contact: Vec<u8>,
    pub deformable: Vec<u8>,
    pub bulge_map: Vec<f64>,
}

#[derive(Serialize)]
pub struct Intersecting {
    pub input: Vec<u8>,
    pub output: Vec<u8>,
}

/// Per object, 1 for the vertices of faces that intersect any other face of `meshes` (the
/// objects taken as one mesh, so that overlaps between objects and within one both count).
/// A mesh the test cannot read (a non-finite coordinate) shows no overlap rather than failing
/// the frame's view.
fn intersecting_vertices(meshes: &[&TriMesh]) -> Vec<Vec<u8>> {
    let mut faces: Vec<Vec<u32>> = vec![Vec::new(); meshes.len()];
    let mut all = TriMesh::default();
    let mut owner = Vec::new();
    for (i, mesh) in meshes.iter().enumerate() {
        let offset = all.positions.len() as u32;
        all.positions.extend_from_slice(&mesh.positions);
        all.triangles.extend(mesh.triangles.iter().map(|t| t.map(|v| v + offset)));
        owner.extend((0..mesh.num_triangles() as u32).map(|f| (i, f)));
    }
    if let Ok(found) = squish::spatial::self_intersections(&all) {
        for &f in &found.faces {
            let (i, own) = owner[f as usize];
            faces[i].push(own);
        }
    }
    meshes
        .iter()
        .zip(&faces)
        .map(|(mesh, faces)| squish_shot::shot::face_vertex_flags(mesh, faces).into_iter().map(u8::from).collect())
        .collect()
}

/// The profile curve of §5.4.1 for a unit amplitude and zero slope at the contact, with the
/// object's abscissas, bulge factor and wrinkles: what the editor draws and drags.
#[derive(Serialize)]
pub struct ProfileView {
    /// The control points' abscissas and ordinates (v0 … v5).
    pub x: [f64; 6],
    pub y: [f64; 6],
    /// (u, 𝓗(u)) samples, wrinkles included.
    pub curve: Vec<[f64; 2]>,
}

/// Samples of the drawn profile.
const PROFILE_SAMPLES: usize = 96;

/// The bulge ordinate drawn for `bulge = 1` (relative to the unit amplitude): the editor shows
/// shape, the solved height depends on the volume.
const DRAWN_BULGE_ORDINATE: f64 = 0.35;

impl ProfileView {
    fn of(params: &squish::ObjectParams) -> Self {
        let [x2, x3, x4] = params.profile();
        let shape = squish::deform::ProfileShape { x2, x3, x4 };
        let profile = Profile::new(&shape, 1.0, 0.0, DRAWN_BULGE_ORDINATE * params.bulge);
        let wrinkles = Wrinkles { amplitude: params.wrinkle_amplitude, frequency: params.wrinkle_frequency };
        let curve = (0..=PROFILE_SAMPLES)
            .map(|k| {
                let u = k as f64 / PROFILE_SAMPLES as f64;
                [u, profile.height(u) + wrinkles.at(u)]
            })
            .collect();
        Self { x: profile.x, y: profile.y, curve }
    }
}

impl FrameView {
    pub fn of(session: &Session, computed: &Computed, version: u64, frame: i64) -> Self {
        let result = &computed.result;
        let flat = |ps: &[glam::DVec3]| ps.iter().flat_map(|p| p.to_array()).collect::<Vec<f64>>();
        let inputs: Vec<&TriMesh> = computed.shot.objects.iter().map(|o| &o.mesh).collect();
        let outputs: Vec<TriMesh> = inputs
            .iter()
            .zip(&result.positions)
            .map(|(m, p)| TriMesh { positions: p.clone(), triangles: m.triangles.clone() })
            .collect();
        let mut intersecting_inputs = intersecting_vertices(&inputs).into_iter();
        let mut intersecting_outputs = intersecting_vertices(&outputs.iter().collect::<Vec<_>>()).into_iter();
        let objects = computed
            .shot
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| {
                let overlays = result.deformations.get(i).and_then(Option::as_ref).map(|d| Overlays {
                    u: d.u
                        .iter()
                        .map(|&u| if u.is_finite() && d.deformable.len() == d.u.len() { u } else { -1.0 })
                        .collect(),
                    contact: d.contact.iter().map(|&c| u8::from(c)).collect(),
                    deformable: d.deformable.iter().map(|&c| u8::from(c)).collect(),
                    bulge_map: d.bulge_map.clone(),
                });
                ObjectFrameView {
                    name: o.name.clone(),
                    input: flat(&o.mesh.positions),
                    output: flat(&result.positions[i]),
                    quality: computed.objects[i].clone(),
                    overlays,
                    painted: o.params.bulge_map.clone(),
                    intersecting: Intersecting {
                        input: intersecting_inputs.next().unwrap_or_default(),
                        output: intersecting_outputs.next().unwrap_or_default(),
                    },
                    profile: ProfileView::of(&o.params),
                }
            })
            .collect();
        let (objects_values, pairs_values) = session.values(&computed.shot);
        let stats = &result.stats;
        let stages = stage_milliseconds(serde_json::to_value(stats.stages).unwrap_or_default());
        Self {
            version,
            frame,
            edit: stats.edit,
            total_ms: stats.total.as_secs_f64() * 1e3,
            stages,
            objects,
            pairs: computed.pairs.clone(),
            values: ValuesView { objects: objects_values, pairs: pairs_values },
            warnings: stats.warnings.iter().map(|w| w.message.clone()).collect(),
        }
    }
}

/// The stage times (durations as `{secs, nanos}`) in milliseconds.
fn stage_milliseconds(stages: serde_json::Value) -> std::collections::BTreeMap<String, f64> {
    let serde_json::Value::Object(map) = stages else { return Default::default() };
    map.into_iter()
        .filter_map(|(stage, t)| {
            let secs = t.get("secs")?.as_f64()?;
            let nanos = t.get("nanos")?.as_f64()?;
            Some((stage, secs * 1e3 + nanos * 1e-6))
        })
        .collect()
}
