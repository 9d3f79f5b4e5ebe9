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
    /// The world's up axis, `"y"` or `"z"`: the scene's `preview.up`, else y when an object is
    /// read from glTF (a y-up format), z otherwise (as `squish run --preview --up auto`).
    pub up: &'static str,
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
    /// Its articulations (self-contact, thesis ch. 6): `[[objects.self_contact]]` entries, then
    /// those `self_contact = "auto"` found, each named by its joints.
    pub articulations: Vec<ArticulationView>,
    /// With `self_contact = "auto"`: the parts of its skin (named by their joints).
    pub parts: Vec<String>,
    /// Keys that change nothing for this object, and why (the page greys them).
    pub inert: std::collections::BTreeMap<&'static str, String>,
    /// The URL of its base-colour texture (a glTF material's), drawn on `display`.
    pub texture: Option<String>,
    /// With a texture: the mesh split along its UV seams for drawing — per drawn vertex, the
    /// object's vertex it shows and its UV, and the triangles on the drawn vertices.
    pub display: Option<DisplayMesh>,
}

#[derive(Serialize)]
pub struct ArticulationView {
    pub name: String,
    /// Found by `self_contact = "auto"`.
    pub automatic: bool,
}

#[derive(Serialize)]
pub struct DisplayMesh {
    pub vertex: Vec<u32>,
    pub uv: Vec<f32>,
    pub triangles: Vec<u32>,
}

impl DisplayMesh {
    /// The mesh split where its corners' UVs differ (`corners`: three UVs per triangle).
    fn split(triangles: &[[u32; 3]], corners: &[[glam::DVec2; 3]]) -> Self {
        let mut index = std::collections::HashMap::new();
        let (mut vertex, mut uv, mut drawn) = (Vec::new(), Vec::new(), Vec::with_capacity(3 * triangles.len()));
        for (t, c) in triangles.iter().zip(corners) {
            for k in 0..3 {
                let key = (t[k], c[k].x.to_bits(), c[k].y.to_bits());
                let id = *index.entry(key).or_insert_with(|| {
                    vertex.push(t[k]);
                    uv.extend([c[k].x as f32, c[k].y as f32]);
                    (vertex.len() - 1) as u32
                });
                drawn.push(id);
            }
        }
        Self { vertex, uv, triangles: drawn }
    }
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
        let gltf = (0..frame.objects.len()).any(|i| session.scene.gltf_pose(i, 0.0).is_some());
        let up = match description.preview.as_ref().and_then(|p| p.up) {
            Some(squish_io::scene::UpAxisName::Y) => "y",
            Some(squish_io::scene::UpAxisName::Z) => "z",
            None if gltf => "y",
            None => "z",
        };
        let in_pairs: Vec<bool> =
            (0..frame.objects.len()).map(|i| frame.pairs.iter().any(|p| p.objects.contains(&i))).collect();
        Ok(Self {
            name,
            up,
            frames: FramesView {
                start: *session.scene.frames().start(),
                end: *session.scene.frames().end(),
                fps: description.frames.fps,
            },
            objects: frame
                .objects
                .iter()
                .enumerate()
                .map(|(i, o)| {
                    let mut inert = std::collections::BTreeMap::new();
                    let self_contact = !o.params.self_contact.is_empty() || o.params.self_contact_parts.is_some();
                    if !in_pairs[i] && self_contact {
                        inert.insert(
                            "stiffness",
                            "in no pair: the two sides of its self-contact share its stiffness; set an articulation's stiffness [parent side, child side]".to_string(),
                        );
                    }
                    let textured = session.textures.get(i).and_then(Option::as_ref).filter(|t| t.texcoord == 0);
                    let display = textured.and_then(|_| match session.scene.object_uvs(i).ok().as_deref() {
                        Some(squish::params::Uvs::PerCorner(corners)) if corners.len() == o.mesh.num_triangles() => {
                            Some(DisplayMesh::split(&o.mesh.triangles, corners))
                        }
                        _ => None,
                    });
                    ObjectView {
                        name: o.name.clone(),
                        triangles: o.mesh.triangles.iter().flatten().copied().collect(),
                        articulations: session
                            .articulations
                            .get(i)
                            .into_iter()
                            .flatten()
                            .map(|(name, automatic)| ArticulationView { name: name.clone(), automatic: *automatic })
                            .collect(),
                        parts: o.params.self_contact_parts.as_ref().map(|p| p.names.clone()).unwrap_or_default(),
                        inert,
                        texture: display.as_ref().map(|_| format!("api/texture/{i}")),
                        display,
                    }
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
    /// Every articulation's figures at this frame.
    pub articulations: Vec<ArticulationFrameView>,
    /// Per object and pair, the value of every parameter at this frame.
    pub values: ValuesView,
    pub warnings: Vec<String>,
}

#[derive(Serialize)]
pub struct ValuesView {
    pub objects: Vec<ShownValues>,
    pub pairs: Vec<ShownValues>,
    /// Per object, per articulation.
    pub articulations: Vec<Vec<ShownValues>>,
}

/// An articulation's figures at one frame (thesis ch. 6).
#[derive(Serialize)]
pub struct ArticulationFrameView {
    pub object: usize,
    pub name: String,
    pub in_contact: bool,
    pub contact_area: f64,
    /// Faces of its regions that intersect another face, before and after.
    pub faces_before: usize,
    pub faces_after: usize,
    pub time_ms: f64,
    /// Why an automatic articulation was left inactive at this frame.
    pub error: Option<String>,
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
        let mut stages = stage_milliseconds(serde_json::to_value(stats.stages).unwrap_or_default());
        // Self-contact (ch. 6, issue 27) runs before the stages and is timed apart.
        let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
        let self_contact = [
            ("self-contact: articulations", stats.articulations.iter().map(|a| ms(a.total_time)).sum::<f64>()),
            ("self-contact: parts", stats.part_pairs.iter().map(|p| ms(p.time)).sum::<f64>()),
            (
                "self-contact: untangle",
                stats.objects.iter().filter_map(|o| o.untangled.as_ref()).map(|u| ms(u.time)).sum::<f64>(),
            ),
        ];
        for (stage, time) in self_contact {
            if time > 0.0 {
                stages.insert(stage.to_string(), time);
            }
        }
        let articulations = stats
            .articulations
            .iter()
            .map(|a| ArticulationFrameView {
                object: a.object,
                name: a.name.clone(),
                in_contact: a.in_contact,
                contact_area: a.contact_area,
                faces_before: a.self_intersecting_faces_before,
                faces_after: a.self_intersecting_faces_after,
                time_ms: ms(a.total_time),
                error: a.error.clone(),
            })
            .collect();
        Self {
            version,
            frame,
            edit: stats.edit,
            total_ms: stats.total.as_secs_f64() * 1e3,
            stages,
            objects,
            pairs: computed.pairs.clone(),
            articulations,
            values: ValuesView {
                objects: objects_values,
                pairs: pairs_values,
                articulations: session.articulation_values(&computed.shot),
            },
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
