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
use squish::params::{ArticulationParams, did_you_mean};
use squish::skinning::regions_from_skin_weights;

use super::source::SourceAssets;
use super::tracks::ParamTracks;
use super::types::{ObjectSpec, SelfContactSpec, VertexData};
use crate::IoError;

/// Where an articulation's three direction points come from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum JointPoints {
    /// Node ids of the parent joint, the joint and the end of the child bone.
    Nodes([usize; 3]),
    /// Node ids of the parent joint and the joint; the third point is `end_local` in the
    /// joint's frame (B + (B − A) in the rest pose, carried by B).
    Extended { nodes: [usize; 2], end_local: DVec3 },
}

impl JointPoints {
    /// The three points in the skeleton's world space for these node world transforms.
    pub(crate) fn points(self, world: &[DMat4]) -> Option<[DVec3; 3]> {
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
}

/// The self-contact assets of an object: its articulations, and its bind pose when the mesh is a
/// glTF node (`None` otherwise: the frame's own mesh serves as the rest pose).
pub(crate) struct ObjectArticulations {
    pub(crate) articulations: Vec<ArticulationAssets>,
    pub(crate) rest_positions: Option<Arc<[DVec3]>>,
}

/// Loads the articulations of `object`. `located(entry, key, message)` places a message at a key
/// of an entry in the scene file; `load_mask` reads a per-vertex mask in the object's numbering.
pub(crate) fn load_articulations(
    object: &ObjectSpec,
    source: &SourceAssets,
    vertex_count: usize,
    located: impl Fn(usize, &'static str, String) -> IoError,
    load_mask: impl Fn(&VertexData) -> Result<Vec<f64>, IoError>,
) -> Result<ObjectArticulations, IoError> {
    let mut articulations = Vec::with_capacity(object.self_contact.len());
    let gltf = match source {
        SourceAssets::Gltf(g) => Some(g),
        _ => None,
    };
    let rest_positions = match gltf {
        Some(g) if !object.self_contact.is_empty() => {
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
        articulations.push(ArticulationAssets { regions: Arc::new(regions), joints, params: entry_params });
    }
    Ok(ObjectArticulations { articulations, rest_positions })
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
    let points = match children_of(child).first() {
        Some(&end) => JointPoints::Nodes([joints[parent], joints[child], joints[end]]),
        None => {
            let rest = scene.skeleton.rest_world_transforms();
            let (a, b) = (joints[parent], joints[child]);
            let (Some(rest_a), Some(rest_b)) = (rest.get(a), rest.get(b)) else {
                return Err(located(
                    k,
                    "joints",
                    format!("articulation \"{name}\": the joints' nodes are missing in {file}"),
                ));
            };
            let (pa, pb) = (rest_a.w_axis.truncate(), rest_b.w_axis.truncate());
            JointPoints::Extended { nodes: [a, b], end_local: rest_b.inverse().transform_point3(pb + (pb - pa)) }
        }
    };
    Ok((regions, points))
}
