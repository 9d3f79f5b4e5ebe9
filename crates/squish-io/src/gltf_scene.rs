//! The glTF document model returned by [`crate::read_gltf`]: nodes, meshes, skins and
//! animations as plain data, with conversions to the core types and posing (morph weights,
//! skeletal animation, linear blend skinning) at any time.

use std::ops::Range;
use std::path::PathBuf;

use glam::{DMat4, DVec2, DVec3};
use squish::TriMesh;
use squish::animation::{AnimationClip, NodeTransform, Sampler, Skeleton};
use squish::skinning::{Skin, SkinWeights, joint_matrices, linear_blend_skinning};

use crate::IoError;

/// A glTF file as read.
#[derive(Clone, Debug)]
pub struct GltfScene {
    /// The file read (errors of later conversions name it).
    pub path: PathBuf,
    /// All nodes, indexed as in the file.
    pub nodes: Vec<GltfNode>,
    /// The node hierarchy as a skeleton whose node ids are the file's node indices, so that
    /// skin joints and animation channels index it directly.
    pub skeleton: Skeleton,
    /// Root nodes of the default scene (or of the first scene, or every parentless node when
    /// the file has no scene).
    pub roots: Vec<usize>,
    pub meshes: Vec<GltfMesh>,
    pub skins: Vec<GltfSkin>,
    pub animations: Vec<GltfAnimation>,
}

/// A node.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfNode {
    /// Name (empty if the file has none).
    pub name: String,
    pub parent: Option<usize>,
    pub children: Vec<usize>,
    /// Local transform.
    pub transform: NodeTransform,
    /// Mesh instanced at this node.
    pub mesh: Option<usize>,
    /// Skin deforming that mesh.
    pub skin: Option<usize>,
    /// Morph-target weights of this instance (overrides the mesh's defaults).
    pub weights: Option<Vec<f64>>,
}

/// A mesh: all its primitives concatenated (welded if asked).
#[derive(Clone, Debug, PartialEq)]
pub struct GltfMesh {
    pub name: String,
    /// Positions in the mesh's own space.
    pub positions: Vec<DVec3>,
    /// Counter-clockwise triangles.
    pub triangles: Vec<[u32; 3]>,
    /// Vertex normals (`NORMAL`), when a primitive has them (zero for the vertices of
    /// primitives without); averaged and normalized over welded vertices.
    pub normals: Option<Vec<DVec3>>,
    /// Texture coordinates (`TEXCOORD_0`, as stored: v points down the image) of the three
    /// corners of each triangle of [`Self::triangles`], when every primitive has them; a welded
    /// vertex on a UV seam has different UVs at its corners.
    pub corner_uvs: Option<Vec<[DVec2; 3]>>,
    /// Tangents (`TANGENT`, xyz and the handedness w), when a primitive has them (zero
    /// elsewhere); dropped by welding.
    pub tangents: Option<Vec<[f64; 4]>>,
    /// Texture coordinates (`TEXCOORD_0`, glTF's convention: origin at the image's top left),
    /// when a primitive has them (zero elsewhere); dropped by welding, which joins UV seams.
    pub texcoords: Option<Vec<[f64; 2]>>,
    /// Skin weights, when the primitives have `JOINTS_0` / `WEIGHTS_0`.
    pub skin_weights: Option<SkinWeights>,
    /// Position displacements of each morph target (one per vertex).
    pub morph_targets: Vec<Vec<DVec3>>,
    /// Default morph-target weights.
    pub default_weights: Vec<f64>,
    /// Names of the morph targets (`extras.targetNames`, as Blender writes them), if present.
    pub target_names: Vec<String>,
    /// The file vertices of each primitive, in file numbering (before welding).
    pub primitive_vertices: Vec<Range<usize>>,
    /// Number of vertices in the file (before welding).
    pub file_vertex_count: usize,
    /// With welding: for each file vertex, its welded vertex. The skin weights and morph
    /// displacements of a welded vertex are the average of its file copies' (exporters may
    /// give seam copies slightly different weights).
    pub vertex_map: Option<Vec<u32>>,
    /// With welding: triangles dropped because two of their corners were merged.
    pub collapsed_triangles: usize,
}

impl GltfMesh {
    /// The mesh as a [`TriMesh`] in its own space (checked by [`TriMesh::new`]).
    pub fn to_tri_mesh(&self) -> Result<TriMesh, squish::MeshError> {
        TriMesh::new(self.positions.clone(), self.triangles.clone())
    }

    /// Positions with morph targets applied with `weights` (missing weights count as zero).
    pub fn morphed_positions(&self, weights: &[f64]) -> Vec<DVec3> {
        let mut positions = self.positions.clone();
        for (target, &w) in self.morph_targets.iter().zip(weights) {
            if w != 0.0 {
                for (p, d) in positions.iter_mut().zip(target) {
                    *p += w * *d;
                }
            }
        }
        positions
    }
}

/// A skin.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfSkin {
    pub name: String,
    /// Joints (node ids) and inverse bind matrices.
    pub skin: Skin,
    /// The `skeleton` property: the common root of the joints, if the file names it.
    pub skeleton_root: Option<usize>,
}

/// An animation.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfAnimation {
    pub name: String,
    /// Translation, rotation and scale channels.
    pub clip: AnimationClip,
    /// Morph-target weight channels.
    pub morph_weights: Vec<MorphWeightsTrack>,
}

impl GltfAnimation {
    /// Latest key time over all channels, morph weights included (the animation plays from 0).
    pub fn duration(&self) -> f64 {
        self.morph_weights
            .iter()
            .flat_map(|t| t.samplers.iter().map(|s| s.end_time()))
            .fold(self.clip.duration(), f64::max)
    }
}

/// Morph-target weights of one node over time: one sampler per target.
#[derive(Clone, Debug, PartialEq)]
pub struct MorphWeightsTrack {
    pub node: usize,
    pub samplers: Vec<Sampler<f64>>,
}

impl MorphWeightsTrack {
    /// The weights at `time`.
    pub fn weights_at(&self, time: f64) -> Vec<f64> {
        self.samplers.iter().map(|s| s.sample(time)).collect()
    }
}

/// A node that instances a mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MeshInstance {
    pub node: usize,
    pub mesh: usize,
    pub skin: Option<usize>,
}

impl GltfScene {
    /// Nodes that instance a mesh, in node order.
    pub fn instances(&self) -> Vec<MeshInstance> {
        self.nodes
            .iter()
            .enumerate()
            .filter_map(|(node, n)| n.mesh.map(|mesh| MeshInstance { node, mesh, skin: n.skin }))
            .collect()
    }

    /// The animation with this name.
    pub fn find_animation(&self, name: &str) -> Option<usize> {
        self.animations.iter().position(|a| a.name == name)
    }

    /// Local node transforms: the rest pose, or `animation` evaluated at `time`.
    pub fn local_transforms(&self, animation: Option<usize>, time: f64) -> Result<Vec<NodeTransform>, IoError> {
        match animation {
            None => Ok(self.skeleton.rest_pose()),
            Some(a) => {
                let anim = self.animation(a)?;
                anim.clip.evaluate(&self.skeleton, time).map_err(|source| IoError::Animation {
                    path: self.path.clone(),
                    element: format!("animation {a} '{}'", anim.name),
                    source,
                })
            }
        }
    }

    /// World transforms of every node: the rest pose, or `animation` evaluated at `time`.
    pub fn world_transforms(&self, animation: Option<usize>, time: f64) -> Result<Vec<DMat4>, IoError> {
        Ok(self.skeleton.world_transforms(&self.local_transforms(animation, time)?))
    }

    fn animation(&self, a: usize) -> Result<&GltfAnimation, IoError> {
        self.animations.get(a).ok_or_else(|| {
            IoError::element(
                &self.path,
                format!("animation {a}"),
                format!("no such animation; the file has {}", self.animations.len()),
            )
        })
    }

    /// The mesh of `node` in world space, posed: morph weights (animated, else the node's,
    /// else the mesh's defaults), then skinning by the node's skin if any (glTF ignores the
    /// transform of a skinned mesh's node: the joints place it) or else the node's world
    /// transform. `animation: None` gives the rest pose.
    pub fn posed_mesh(&self, node: usize, animation: Option<usize>, time: f64) -> Result<TriMesh, IoError> {
        let world = self.world_transforms(animation, time)?;
        self.posed_mesh_with(node, animation, time, &world)
    }

    /// Every instance posed as in [`GltfScene::posed_mesh`], in node order.
    pub fn posed_meshes(&self, animation: Option<usize>, time: f64) -> Result<Vec<(usize, TriMesh)>, IoError> {
        let world = self.world_transforms(animation, time)?;
        self.instances()
            .iter()
            .map(|inst| Ok((inst.node, self.posed_mesh_with(inst.node, animation, time, &world)?)))
            .collect()
    }

    /// The mesh of `node` transformed by the node's rest world transform, without skinning or
    /// morphing (the "world-transformed" mesh of a static scene).
    pub fn world_mesh(&self, node: usize) -> Result<TriMesh, IoError> {
        let (mesh, _) = self.node_mesh(node)?;
        let world = self.skeleton.rest_world_transforms();
        let m = world[node];
        let positions = mesh.positions.iter().map(|p| m.transform_point3(*p)).collect();
        TriMesh::new(positions, mesh.triangles.clone()).map_err(|e| IoError::mesh(&self.path, e))
    }

    fn node_mesh(&self, node: usize) -> Result<(&GltfMesh, &GltfNode), IoError> {
        let n = self.nodes.get(node).ok_or_else(|| {
            IoError::element(
                &self.path,
                format!("node {node}"),
                format!("no such node; the file has {}", self.nodes.len()),
            )
        })?;
        let mesh = n
            .mesh
            .and_then(|m| self.meshes.get(m))
            .ok_or_else(|| IoError::element(&self.path, format!("node {node} '{}'", n.name), "the node has no mesh"))?;
        Ok((mesh, n))
    }

    fn posed_mesh_with(
        &self,
        node: usize,
        animation: Option<usize>,
        time: f64,
        world: &[DMat4],
    ) -> Result<TriMesh, IoError> {
        let (mesh, _) = self.node_mesh(node)?;
        let weights = self.morph_weights(node, animation, time)?;
        let positions = mesh.morphed_positions(&weights);
        let positions = match self.skinning(node, world)? {
            Some((skin_weights, matrices)) => linear_blend_skinning(&positions, skin_weights, &matrices)
                .map_err(|source| self.skin_error(node, source))?,
            None => positions.iter().map(|p| world[node].transform_point3(*p)).collect(),
        };
        TriMesh::new(positions, mesh.triangles.clone()).map_err(|e| IoError::mesh(&self.path, e))
    }

    /// The skin weights of `node`'s mesh and its joint matrices for the world transforms
    /// `world`, if the node is skinned.
    fn skinning(&self, node: usize, world: &[DMat4]) -> Result<Option<(&SkinWeights, Vec<DMat4>)>, IoError> {
        let (mesh, n) = self.node_mesh(node)?;
        let (Some(s), Some(skin_weights)) = (n.skin, &mesh.skin_weights) else { return Ok(None) };
        let skin = &self
            .skins
            .get(s)
            .ok_or_else(|| {
                IoError::element(&self.path, format!("node {node} '{}'", n.name), format!("skin {s} does not exist"))
            })?
            .skin;
        let matrices = joint_matrices(skin, world).map_err(|source| self.skin_error(node, source))?;
        Ok(Some((skin_weights, matrices)))
    }

    fn skin_error(&self, node: usize, source: squish::skinning::SkinError) -> IoError {
        let name = self.nodes.get(node).map_or("", |n| n.name.as_str());
        IoError::Skin { path: self.path.clone(), element: format!("node {node} '{name}'"), source }
    }

    /// The morph-target weights of `node`'s mesh: animated by `animation` at `time` if it
    /// animates them, else the node's, else the mesh's defaults.
    pub fn morph_weights(&self, node: usize, animation: Option<usize>, time: f64) -> Result<Vec<f64>, IoError> {
        let (mesh, n) = self.node_mesh(node)?;
        let animated = match animation {
            Some(a) => {
                self.animation(a)?.morph_weights.iter().rev().find(|t| t.node == node).map(|t| t.weights_at(time))
            }
            None => None,
        };
        Ok(animated.or_else(|| n.weights.clone()).unwrap_or_else(|| mesh.default_weights.clone()))
    }

    /// The pose of `node`'s mesh at `time` as affine maps, one per vertex, and morph weights:
    /// vertex `v` lands at `matrices[v] · (positions[v] + Σₜ weights[t] · targets[t][v])`. For a
    /// skinned mesh `matrices[v]` blends the joint matrices by the vertex's (normalized) weights,
    /// which is linear blend skinning written as one matrix; otherwise it is the node's world
    /// transform. This is what un-posing inverts ([`InstancePose::unpose`]).
    pub fn instance_pose(&self, node: usize, animation: Option<usize>, time: f64) -> Result<InstancePose, IoError> {
        let world = self.world_transforms(animation, time)?;
        let (mesh, _) = self.node_mesh(node)?;
        let weights = self.morph_weights(node, animation, time)?;
        let skin_error = |source| self.skin_error(node, source);
        let matrices = match self.skinning(node, &world)? {
            Some((skin_weights, joints)) => {
                let mut matrices = Vec::with_capacity(skin_weights.len());
                for (v, (js, ws)) in skin_weights.joints().iter().zip(skin_weights.weights()).enumerate() {
                    let mut m = DMat4::ZERO;
                    let mut any = false;
                    for (&j, &w) in js.iter().zip(ws) {
                        if w != 0.0 {
                            let joint = joints.get(j as usize).ok_or_else(|| {
                                skin_error(squish::skinning::SkinError::JointOutOfRange {
                                    vertex: v,
                                    joint: j,
                                    joints: joints.len(),
                                })
                            })?;
                            m += *joint * w;
                            any = true;
                        }
                    }
                    // Linear blend skinning leaves a vertex without weights where it is.
                    matrices.push(if any { m } else { DMat4::IDENTITY });
                }
                matrices
            }
            _ => vec![world[node]; mesh.positions.len()],
        };
        Ok(InstancePose { node, matrices, weights })
    }

    /// All instances posed at rest and concatenated in node order; a file with meshes but no
    /// node instancing them gives its meshes in their own space. This is what
    /// [`crate::read_mesh`] returns for glTF.
    pub fn merged_mesh(&self) -> Result<TriMesh, IoError> {
        let mut merged = TriMesh::default();
        let instances = self.instances();
        if instances.is_empty() {
            for m in &self.meshes {
                merged.append(&TriMesh { positions: m.positions.clone(), triangles: m.triangles.clone() });
            }
        } else {
            for (_, mesh) in self.posed_meshes(None, 0.0)? {
                merged.append(&mesh);
            }
        }
        merged.check_structure().map_err(|e| IoError::mesh(&self.path, e))?;
        Ok(merged)
    }

    /// The UVs of [`Self::merged_mesh`]'s triangles, three per triangle (`TEXCOORD_0`), or
    /// `None` when a mesh of it has none.
    pub fn merged_corner_uvs(&self) -> Option<Vec<[DVec2; 3]>> {
        let instances = self.instances();
        let meshes: Vec<&GltfMesh> = if instances.is_empty() {
            self.meshes.iter().collect()
        } else {
            instances.iter().filter_map(|i| self.meshes.get(i.mesh)).collect()
        };
        let mut corners = Vec::new();
        for mesh in meshes {
            corners.extend_from_slice(mesh.corner_uvs.as_ref()?);
        }
        Some(corners)
    }
}

/// The pose of one mesh instance at one time (see [`GltfScene::instance_pose`]).
#[derive(Clone, Debug, PartialEq)]
pub struct InstancePose {
    pub node: usize,
    /// One affine map per vertex of the mesh.
    pub matrices: Vec<DMat4>,
    /// The morph-target weights.
    pub weights: Vec<f64>,
}

impl InstancePose {
    /// The mesh-space positions (before morph targets) that this pose takes to `posed`: the
    /// inverse of posing, vertex by vertex. Errors name the first vertex whose map cannot be
    /// inverted (a zero scale, or skin weights on joints that collapse it).
    pub fn unpose(&self, scene: &GltfScene, posed: &[DVec3]) -> Result<Vec<DVec3>, IoError> {
        let (mesh, n) = scene.node_mesh(self.node)?;
        if posed.len() != self.matrices.len() {
            return Err(IoError::invalid_input(
                &scene.path,
                format!(
                    "{} positions for the {} vertices of node {} '{}'",
                    posed.len(),
                    self.matrices.len(),
                    self.node,
                    n.name
                ),
            ));
        }
        let morph = mesh.morphed_positions(&self.weights);
        posed
            .iter()
            .zip(&self.matrices)
            .enumerate()
            .map(|(v, (p, m))| {
                let determinant = m.determinant();
                if !(determinant.is_finite() && determinant.abs() > 1e-300) {
                    return Err(IoError::element(
                        &scene.path,
                        format!("node {} '{}'", self.node, n.name),
                        format!(
                            "vertex {v} is posed by a singular transform (determinant {determinant:e}): its deformed position cannot be written back into the mesh's own space"
                        ),
                    ));
                }
                // Un-pose, then take away what the morph targets add at this pose.
                Ok(m.inverse().transform_point3(*p) - (morph[v] - mesh.positions[v]))
            })
            .collect()
    }
}

impl GltfScene {
    /// A copy whose animation `animation` turns every joint `amplitude` times as far from its
    /// rest rotation: each rotation key `q` of a node at rest rotation `r` becomes
    /// `r · (r⁻¹ · q)^amplitude` (same axis, angle × amplitude). Translations, scales and morph
    /// weights are kept. Between keys the clip still interpolates the (new) keys, so a clip
    /// whose keys turn about one axis per joint is scaled exactly at every time. Cubic-spline
    /// rotation channels are refused (their tangents have no such scaling).
    pub fn with_amplified_rotations(&self, animation: usize, amplitude: f64) -> Result<GltfScene, IoError> {
        use squish::animation::{ChannelValues, Interpolation};
        let mut out = self.clone();
        let rest = self.skeleton.rest_pose();
        let anim = out
            .animations
            .get_mut(animation)
            .ok_or_else(|| IoError::element(&self.path, format!("animation {animation}"), "no such animation"))?;
        let element = format!("animation {animation} '{}'", anim.name);
        for channel in &mut anim.clip.channels {
            let ChannelValues::Rotation(sampler) = &channel.values else { continue };
            if sampler.interpolation() == Interpolation::CubicSpline {
                return Err(IoError::element(
                    &self.path,
                    element,
                    format!(
                        "node {}'s rotation is a cubic spline: `amplitude` only scales LINEAR or STEP rotation keys; remove `amplitude`",
                        channel.node
                    ),
                ));
            }
            let r = rest.get(channel.node).map_or(glam::DQuat::IDENTITY, |t| t.to_trs().rotation);
            let values = sampler
                .values()
                .iter()
                .map(|&q| {
                    let (axis, angle) = (r.inverse() * q).normalize().to_axis_angle();
                    // The shorter way round, so that amplifying never takes the long way.
                    let angle = if angle > std::f64::consts::PI { angle - std::f64::consts::TAU } else { angle };
                    r * glam::DQuat::from_axis_angle(axis, angle * amplitude)
                })
                .collect();
            let scaled = Sampler::new_rotation(sampler.times().to_vec(), values, sampler.interpolation())
                .map_err(|source| IoError::Animation { path: self.path.clone(), element: element.clone(), source })?;
            channel.values = ChannelValues::Rotation(scaled);
        }
        Ok(out)
    }
}
