//! The articulations of an object (`[[objects.self_contact]]`, thesis ch. 6), resolved once when
//! the scene loads: the two regions of each articulation (from the skin weights of two
//! consecutive joints, or from two masks), the joint nodes whose world positions give the
//! direction at each frame, and the object's bind pose (on which the partition weights β are
//! computed).
//!
//! **Joints and direction.** With `joints = ["A", "B"]` (B a child of A in the skin), region 1 is
//! A's influence and region 2 the influence of B and every joint below it
//! ([`squish::skinning::regions_from_skin_weights`]). The direction at a frame comes from three
//! world positions: q₀ = A (start of the parent bone), q₁ = B (the articulation) and q₂ = the end
//! of the child bone, which is B's first child joint in the skin (in the file's order) or, when
//! B has none, the point that continues the parent bone beyond B in the rest pose
//! (B + (B − A) at rest) and then moves rigidly with B (as a vertex skinned to B alone would).

use std::sync::Arc;

use glam::{DMat4, DVec3};
use squish::mesh::{Topology, TriMesh};
use squish::params::{Articulation, ArticulationParams, SkinParts, did_you_mean};
use squish::skinning::{ArticulationSetup, SkinWeights, parts_from_skin, regions_from_skin_weights};

use super::source::SourceAssets;
use super::tracks::ParamTracks;
use super::types::{ObjectSpec, SelfContactSpec, VertexData};
use crate::IoError;

/// Where an articulation's three direction points come from (indices of world transforms: glTF
/// node ids for a scene, skin joint ids for other callers of [`automatic_self_contact`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum JointPoints {
    /// Node ids of the parent joint, the joint and the end of the child bone.
    Nodes([usize; 3]),
    /// Node ids of the parent joint and the joint; the third point is `end_local` in the
    /// joint's frame (B + (B − A) in the rest pose, carried by B).
    Extended { nodes: [usize; 2], end_local: DVec3 },
}

impl JointPoints {
    /// The direction points of the articulation `[parent, child]` (skin joint ids, `parents` the
    /// skin's hierarchy): the child's first child joint, or the parent bone continued beyond the
    /// child at rest and carried by it (see the module doc). `id` maps a skin joint to the index
    /// of its transforms, `rest` holds the rest world transforms by that index.
    pub fn of(
        parents: &[Option<usize>],
        [parent, child]: [usize; 2],
        id: impl Fn(usize) -> usize,
        rest: &[DMat4],
    ) -> Option<Self> {
        match (0..parents.len()).find(|&c| parents[c] == Some(child)) {
            Some(end) => Some(Self::Nodes([id(parent), id(child), id(end)])),
            None => {
                let (a, b) = (id(parent), id(child));
                let (rest_a, rest_b) = (rest.get(a)?, rest.get(b)?);
                let (pa, pb) = (rest_a.w_axis.truncate(), rest_b.w_axis.truncate());
                Some(Self::Extended { nodes: [a, b], end_local: rest_b.inverse().transform_point3(pb + (pb - pa)) })
            }
        }
    }

    /// The three points in the skeleton's world space for these world transforms.
    pub fn points(self, world: &[DMat4]) -> Option<[DVec3; 3]> {
        let at = |n: usize| world.get(n).map(|m| m.w_axis.truncate());
        match self {
            Self::Nodes([a, b, c]) => Some([at(a)?, at(b)?, at(c)?]),
            Self::Extended { nodes: [a, b], end_local } => {
                let end = world.get(b)?.transform_point3(end_local);
                Some([at(a)?, at(b)?, end])
            }
        }
    }
}

/// An articulation as loaded.
#[derive(Debug)]
pub(crate) struct ArticulationAssets {
    /// Region 1 (parent side) and region 2 (child side), sorted object vertex ids.
    pub(crate) regions: Arc<[Vec<u32>; 2]>,
    /// With `joints = [A, B]`: the joints giving the direction (used at the frames where
    /// `direction = "joints"`).
    pub(crate) joints: Option<JointPoints>,
    /// Its parameters over the shot.
    pub(crate) params: ParamTracks<ArticulationParams>,
    /// Found by `self_contact = "auto"` (see [`Articulation::automatic`]).
    pub(crate) automatic: bool,
}

/// The self-contact assets of an object: its articulations, its parts with `self_contact =
/// "auto"`, and its bind pose when the mesh is a glTF node (`None` otherwise: the frame's own
/// mesh serves as the rest pose).
pub(crate) struct ObjectArticulations {
    pub(crate) articulations: Vec<ArticulationAssets>,
    /// Names of the articulations, in order (the entries' or the automatic ones').
    pub(crate) names: Vec<String>,
    pub(crate) parts: Option<Arc<SkinParts>>,
    pub(crate) rest_positions: Option<Arc<[DVec3]>>,
}

/// With `self_contact = "auto"`: a part keeps its own faces when it has at least this fraction
/// of the mesh's faces (and [`MIN_PART_FACES`]); smaller ones join their parent joint's part.
pub const MIN_PART_FRACTION: f64 = 0.01;
/// The least number of faces of a part of its own.
pub const MIN_PART_FACES: usize = 16;

/// Loads the articulations of `object`. `located(entry, key, message)` places a message at a key
/// of an entry in the scene file; `load_mask` reads a per-vertex mask in the object's numbering.
pub(crate) fn load_articulations(
    object: &ObjectSpec,
    source: &SourceAssets,
    vertex_count: usize,
    located: impl Fn(usize, &'static str, String) -> IoError,
    located_auto: impl Fn(String) -> IoError,
    load_mask: impl Fn(&VertexData) -> Result<Vec<f64>, IoError>,
) -> Result<ObjectArticulations, IoError> {
    let mut articulations = Vec::with_capacity(object.self_contact.len());
    let gltf = match source {
        SourceAssets::Gltf(g) => Some(g),
        _ => None,
    };
    let rest_positions = match gltf {
        Some(g) if !object.self_contact.is_none() => {
            let mesh = g.scene.nodes[g.node].mesh.and_then(|m| g.scene.meshes.get(m));
            mesh.filter(|m| m.positions.len() == vertex_count).map(|m| Arc::from(m.positions.as_slice()))
        }
        _ => None,
    };
    for (k, entry) in object.self_contact.iter().enumerate() {
        let name = &entry.name;
        let entry_params =
            ParamTracks::<ArticulationParams>::parse(&entry.params, SelfContactSpec::TABLE_KEYS, |_, _| Ok(None))
                .map_err(|e| located(k, "name", format!("{}: {}", e.key, e.message)))?;
        let (regions, joints) = match (&entry.joints, &entry.masks) {
            (Some(joint_names), _) => {
                let Some(g) = gltf else {
                    return Err(located(k, "joints", format!("articulation \"{name}\": joints need a glTF mesh")));
                };
                let (regions, points) = skin_regions(object, k, joint_names, g, &entry_params, &located)?;
                (regions, Some(points))
            }
            (None, Some([m1, m2])) => {
                let mut regions = [Vec::new(), Vec::new()];
                for (side, mask) in [m1, m2].into_iter().enumerate() {
                    let values = load_mask(mask)?;
                    regions[side] =
                        values.iter().enumerate().filter(|(_, v)| **v >= 0.5).map(|(v, _)| v as u32).collect();
                    if regions[side].is_empty() {
                        return Err(located(
                            k,
                            "masks",
                            format!(
                                "articulation \"{name}\": mask {} selects no vertex (every value is below 0.5); paint region {} with values ≥ 0.5",
                                side + 1,
                                side + 1
                            ),
                        ));
                    }
                }
                (regions, None)
            }
            (None, None) => {
                return Err(located(k, "name", format!("articulation \"{name}\" gives neither joints nor masks")));
            }
        };
        articulations.push(ArticulationAssets {
            regions: Arc::new(regions),
            joints,
            params: entry_params,
            automatic: false,
        });
    }
    let mut names: Vec<String> = object.self_contact.iter().map(|e| e.name.clone()).collect();
    let mut parts = None;
    if object.self_contact.auto {
        let Some(g) = gltf else {
            return Err(located_auto(format!(
                "object \"{}\": self_contact = \"auto\" needs a skinned glTF mesh (its skeleton gives the parts); give [[objects.self_contact]] entries with masks instead",
                object.name
            )));
        };
        let mut auto = auto_self_contact(object, g, vertex_count).map_err(&located_auto)?;
        // `[objects.articulations."parent / child"]`: the parameters of one of them.
        for (name, raw) in &object.articulations {
            let Some(found) = auto.names.iter().position(|n| n == name) else {
                let hint = match did_you_mean(name, &auto.names.iter().map(String::as_str).collect::<Vec<_>>()) {
                    Some(s) => format!(" (did you mean \"{s}\"?)"),
                    None => String::new(),
                };
                return Err(located_auto(format!(
                    "[objects.articulations.\"{name}\"]: no automatic articulation of \"{}\" has that name{hint}; they are {}",
                    object.name,
                    auto.names.iter().map(|n| format!("\"{n}\"")).collect::<Vec<_>>().join(", ")
                )));
            };
            auto.articulations[found].params = ParamTracks::<ArticulationParams>::parse(raw, &[], |_, _| Ok(None))
                .map_err(|e| located_auto(format!("[objects.articulations.\"{name}\"]: {}: {}", e.key, e.message)))?;
        }
        names.extend(auto.names);
        articulations.extend(auto.articulations);
        parts = Some(Arc::new(auto.parts));
    }
    Ok(ObjectArticulations { articulations, names, parts, rest_positions })
}

/// What `self_contact = "auto"` finds on a skinned glTF mesh.
struct AutoSelfContact {
    parts: SkinParts,
    articulations: Vec<ArticulationAssets>,
    names: Vec<String>,
}

/// What `self_contact = "auto"` finds on a skinned mesh, whatever it comes from (a glTF skin, a
/// Python caller's arrays, a Blender armature): its parts and the articulations of its skeleton.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AutomaticSelfContact {
    pub parts: SkinParts,
    pub articulations: Vec<AutomaticArticulation>,
}

/// An articulation found by [`automatic_self_contact`].
#[derive(Clone, Debug, PartialEq)]
pub struct AutomaticArticulation {
    /// `"parent / child"`, the joints' names.
    pub name: String,
    /// Region 1 (parent side) and region 2 (child side), sorted vertex ids.
    pub regions: [Vec<u32>; 2],
    /// The skin joints `[parent, child]`.
    pub joints: [usize; 2],
}

/// The parts of the skin of `rest` (the bind pose) and an articulation for every joint and its
/// parent whose two sides give a valid pair of overlapping regions on the bind pose (each side
/// with skin of its own next to a shared region) and for which `has_direction` holds (its
/// direction points can be found); the parent/child part pairs are left to them. `parents[j]`
/// is joint j's parent in the skin, `names[j]` its name.
pub fn automatic_self_contact(
    rest: &TriMesh,
    weights: &SkinWeights,
    parents: &[Option<usize>],
    names: &[String],
    has_direction: impl Fn([usize; 2]) -> bool,
) -> AutomaticSelfContact {
    let min_faces = MIN_PART_FACES.max((MIN_PART_FRACTION * rest.num_triangles() as f64).ceil() as usize);
    let mut parts = parts_from_skin(rest, weights, parents, names, min_faces);
    let topology = Topology::new(rest);
    let params = ArticulationParams::default();
    let mut articulations = Vec::new();
    let mut covered = Vec::new();
    let part_of_joint = |j: usize| parts.names.iter().position(|n| *n == names[j]);
    for child in 0..parents.len() {
        let Some(parent) = parents[child] else { continue };
        let (Some(a), Some(b)) = (part_of_joint(parent), part_of_joint(child)) else { continue };
        let Ok(regions) = regions_from_skin_weights(weights, parents, parent, child, params.min_weight) else {
            continue;
        };
        let candidate = Articulation { regions, params: params.clone(), ..Articulation::default() };
        if ArticulationSetup::new(rest, &topology, &candidate, rest).is_err() || !has_direction([parent, child]) {
            continue;
        }
        articulations.push(AutomaticArticulation {
            name: format!("{} / {}", names[parent], names[child]),
            regions: candidate.regions,
            joints: [parent, child],
        });
        covered.push([a.min(b) as u32, a.max(b) as u32]);
    }
    covered.sort_unstable();
    covered.dedup();
    // Parent/child part pairs without an articulation stay left alone too (their seam is a fold).
    parts.parent_child.extend(covered);
    parts.parent_child.sort_unstable();
    parts.parent_child.dedup();
    AutomaticSelfContact { parts, articulations }
}

/// `self_contact = "auto"` on the object's skinned glTF node ([`automatic_self_contact`]).
fn auto_self_contact(
    object: &ObjectSpec,
    g: &super::source::GltfAssets,
    vertex_count: usize,
) -> Result<AutoSelfContact, String> {
    let scene = &g.scene;
    let node = &scene.nodes[g.node];
    let file = scene.path.display();
    let mesh = node.mesh.and_then(|m| scene.meshes.get(m));
    let (Some(mesh), Some(skin)) = (mesh, node.skin.and_then(|s| scene.skins.get(s))) else {
        return Err(format!(
            "object \"{}\": self_contact = \"auto\": the node \"{}\" of {file} has no skinned mesh; give [[objects.self_contact]] entries instead",
            object.name, node.name
        ));
    };
    let Some(weights) = mesh.skin_weights.as_ref().filter(|w| w.len() == vertex_count) else {
        return Err(format!(
            "object \"{}\": self_contact = \"auto\": the mesh of \"{}\" in {file} has no skin weights for its {vertex_count} vertices",
            object.name, node.name
        ));
    };
    let rest = TriMesh { positions: mesh.positions.clone(), triangles: mesh.triangles.clone() };
    let joints = &skin.skin.joints;
    let names: Vec<String> =
        joints.iter().map(|&n| scene.nodes.get(n).map_or_else(String::new, |n| n.name.clone())).collect();
    let parents: Vec<Option<usize>> = joints
        .iter()
        .map(|&n| scene.nodes.get(n).and_then(|node| node.parent).and_then(|p| joints.iter().position(|&j| j == p)))
        .collect();
    let rest_world = scene.skeleton.rest_world_transforms();
    let points = |pair: [usize; 2]| JointPoints::of(&parents, pair, |j| joints[j], &rest_world);
    let found = automatic_self_contact(&rest, weights, &parents, &names, |pair| points(pair).is_some());
    let mut articulations = Vec::with_capacity(found.articulations.len());
    let mut articulation_names = Vec::with_capacity(found.articulations.len());
    for a in found.articulations {
        let tracks = ParamTracks::<ArticulationParams>::parse(&super::tracks::RawParams::new(), &[], |_, _| Ok(None))
            .map_err(|e| format!("{}: {}", e.key, e.message))?;
        articulations.push(ArticulationAssets {
            regions: Arc::new(a.regions),
            joints: points(a.joints),
            params: tracks,
            automatic: true,
        });
        articulation_names.push(a.name);
    }
    Ok(AutoSelfContact { parts: found.parts, articulations, names: articulation_names })
}

/// The regions and direction joints of `joints = [A, B]` on a glTF source.
fn skin_regions(
    object: &ObjectSpec,
    k: usize,
    [parent_name, child_name]: &[String; 2],
    g: &super::source::GltfAssets,
    entry_params: &ParamTracks<ArticulationParams>,
    located: &impl Fn(usize, &'static str, String) -> IoError,
) -> Result<([Vec<u32>; 2], JointPoints), IoError> {
    let entry = &object.self_contact[k];
    let name = &entry.name;
    let scene = &g.scene;
    let node = &scene.nodes[g.node];
    let file = scene.path.display();
    let mesh = node.mesh.and_then(|m| scene.meshes.get(m));
    let (Some(skin_index), Some(weights)) = (node.skin, mesh.and_then(|m| m.skin_weights.as_ref())) else {
        return Err(located(
            k,
            "joints",
            format!(
                "articulation \"{name}\": the mesh node \"{}\" of {file} has no skin (or no skin weights), so its joints cannot give the regions; use masks = [mask1, mask2] with direction = [x, y, z]",
                node.name
            ),
        ));
    };
    let Some(skin) = scene.skins.get(skin_index) else {
        return Err(located(
            k,
            "joints",
            format!("articulation \"{name}\": skin {skin_index} of {file} does not exist"),
        ));
    };
    let joints = &skin.skin.joints;
    let joint_name = |j: usize| scene.nodes.get(joints[j]).map_or("", |n| n.name.as_str());
    let names: Vec<&str> = (0..joints.len()).map(joint_name).collect();
    let list = || names.iter().map(|n| format!("\"{n}\"")).collect::<Vec<_>>().join(", ");
    let find = |wanted: &str| -> Result<usize, IoError> {
        let found: Vec<usize> = (0..joints.len()).filter(|&j| names[j] == wanted).collect();
        match found.as_slice() {
            [one] => Ok(*one),
            [] => {
                let hint = match did_you_mean(wanted, &names) {
                    Some(s) => format!(" (did you mean \"{s}\"?)"),
                    None => String::new(),
                };
                Err(located(
                    k,
                    "joints",
                    format!(
                        "articulation \"{name}\": the skin of \"{}\" in {file} has no joint named \"{wanted}\"{hint}; its joints are {}",
                        node.name,
                        list()
                    ),
                ))
            }
            _ => Err(located(
                k,
                "joints",
                format!(
                    "articulation \"{name}\": {} joints of the skin in {file} are named \"{wanted}\"; rename them in the file so that each name is unique",
                    found.len()
                ),
            )),
        }
    };
    let (parent, child) = (find(parent_name)?, find(child_name)?);
    // The parent of each skin joint within the skin (a joint whose node parent is not a joint
    // of the skin is a root).
    let parents: Vec<Option<usize>> = joints
        .iter()
        .map(|&n| scene.nodes.get(n).and_then(|node| node.parent).and_then(|p| joints.iter().position(|&j| j == p)))
        .collect();
    let children_of = |j: usize| -> Vec<usize> { (0..joints.len()).filter(|&c| parents[c] == Some(j)).collect() };
    if parents[child] != Some(parent) {
        let actual = match parents[child] {
            Some(p) => format!("the parent of \"{child_name}\" is \"{}\"", names[p]),
            None => format!("\"{child_name}\" is a root of the skin"),
        };
        let children: Vec<String> = children_of(parent).iter().map(|&c| format!("\"{}\"", names[c])).collect();
        let options = if children.is_empty() {
            format!("\"{parent_name}\" has no child joint")
        } else {
            format!("the children of \"{parent_name}\" are {}", children.join(", "))
        };
        return Err(located(
            k,
            "joints",
            format!(
                "articulation \"{name}\": joints = [\"{parent_name}\", \"{child_name}\"] are not consecutive ({actual}); name a joint and one of its children: {options}"
            ),
        ));
    }
    let min_weight = entry_params.at(0.0).map_err(|e| located(k, "min_weight", e.to_string()))?.min_weight;
    let regions = regions_from_skin_weights(weights, &parents, parent, child, min_weight)
        .map_err(|e| located(k, "joints", format!("articulation \"{name}\": {e}")))?;
    let rest_world = scene.skeleton.rest_world_transforms();
    let Some(points) = JointPoints::of(&parents, [parent, child], |j| joints[j], &rest_world) else {
        return Err(located(k, "joints", format!("articulation \"{name}\": the joints' nodes are missing in {file}")));
    };
    Ok((regions, points))
}
