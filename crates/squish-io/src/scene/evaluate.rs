//! A scene evaluated at one frame: for every object its mesh (posed, transformed) and its
//! parameters as plain values; for every pair its plain values. This is all the deformer needs
//! for that frame, with no reference to other frames (the method is time-independent).

use std::sync::Arc;

use glam::{DQuat, DVec3};
use serde::Serialize;
use squish::TriMesh;
use squish::skinning::{Articulation, ArticulationDirection, ArticulationParams};

use super::Scene;
use super::source::{SourceAssets, source_mesh};
use super::types::{
    AxisAngle, ContactMethod, Direction, PreserveVolume, Region, Scale, SelfContactDirection, Transform,
};
use crate::IoError;

/// Everything about one frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FrameSpec {
    /// The frame (fractional for sub-frames).
    pub frame: f64,
    /// In scene order.
    pub objects: Vec<ObjectFrame>,
    /// In scene order.
    pub pairs: Vec<PairFrame>,
}

/// An object at a frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ObjectFrame {
    pub name: String,
    /// Posed and transformed; same vertex count, order and triangles on every frame.
    pub mesh: TriMesh,
    pub rigid: bool,
    /// Relative stiffness k̄ (> 0).
    pub stiffness: f64,
    /// φ_max (> 0), or `None` for automatic.
    pub extent: Option<f64>,
    /// γ.
    pub bulge: f64,
    pub bulge_height: f64,
    pub preserve_volume: PreserveVolume,
    pub profile: ProfileValues,
    /// `None` when the anisotropic bulge map is off at this frame.
    pub anisotropy: Option<AnisotropyValues>,
    /// Painted bulge map η, one value per vertex; `None`: uniform.
    #[serde(serialize_with = "serialize_opt_slice")]
    pub bulge_map: Option<Arc<[f64]>>,
    pub region: RegionFrame,
    /// Articulations with self-contact (`[[objects.self_contact]]`), in order.
    pub self_contact: Vec<ArticulationFrame>,
    /// The bind pose (one position per vertex) on which the articulations' partition weights
    /// are computed: the glTF mesh's unskinned positions; `None`: the frame's own mesh.
    #[serde(serialize_with = "serialize_opt_slice")]
    pub rest_positions: Option<Arc<[DVec3]>>,
}

/// An articulation at a frame: the library's [`Articulation`] with its regions shared between
/// frames.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ArticulationFrame {
    pub name: String,
    /// Region 1 (parent side) and region 2 (child side), sorted object vertex ids.
    #[serde(serialize_with = "serialize_regions")]
    pub regions: Arc<[Vec<u32>; 2]>,
    /// d̂ at this frame: the joints' world positions (after the object's transform), or a unit
    /// vector.
    pub direction: ArticulationDirection,
    pub params: ArticulationParams,
}

impl ArticulationFrame {
    /// The library's articulation.
    pub fn to_articulation(&self) -> Articulation {
        Articulation {
            name: self.name.clone(),
            regions: (*self.regions).clone(),
            direction: self.direction,
            params: self.params.clone(),
        }
    }
}

fn serialize_regions<S: serde::Serializer>(v: &Arc<[Vec<u32>; 2]>, s: S) -> Result<S::Ok, S::Error> {
    v.as_ref().serialize(s)
}

/// Profile curve abscissas (0.2 < v2 < v3 < v4 < 1) and wrinkles.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ProfileValues {
    pub v2: f64,
    pub v3: f64,
    pub v4: f64,
    pub wrinkle_amplitude: f64,
    pub wrinkle_frequency: f64,
}

/// The anisotropic bulge map's ω and ψ (thesis Eq. 5.6).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct AnisotropyValues {
    pub exponent: f64,
    pub offset: f64,
}

/// The deformable part of an object at a frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RegionFrame {
    Whole,
    /// Per vertex: in the region (mask value ≥ 0.5).
    Mask(#[serde(serialize_with = "serialize_slice")] Arc<[bool]>),
    /// Vertices within this distance of the intersection.
    Distance(f64),
}

/// A pair at a frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PairFrame {
    /// Indices into [`FrameSpec::objects`].
    pub objects: [usize; 2],
    pub names: [String; 2],
    pub enabled: bool,
    /// τ.
    pub contact_tau: f64,
    /// Unit mapping direction d̂, or `None` for automatic.
    pub direction: Option<DVec3>,
    pub contact_method: ContactMethodFrame,
}

/// Contact zone method at a frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ContactMethodFrame {
    /// Method B.
    Geometric,
    /// Method A with ball radius r_s.
    Ball { radius: f64 },
}

fn serialize_slice<T: Serialize, S: serde::Serializer>(v: &Arc<[T]>, s: S) -> Result<S::Ok, S::Error> {
    v.as_ref().serialize(s)
}

fn serialize_opt_slice<T: Serialize, S: serde::Serializer>(v: &Option<Arc<[T]>>, s: S) -> Result<S::Ok, S::Error> {
    v.as_deref().serialize(s)
}

/// The affine map T·R·S of a transform at `frame`, as a function on points. Errors (zero
/// scale, zero rotation axis) are returned as text for the caller to place.
pub(crate) fn transform_at(t: &Transform, frame: f64) -> Result<impl Fn(DVec3) -> DVec3 + use<>, String> {
    let Scale(scale) = t.scale.at(frame);
    if scale.x == 0.0 || scale.y == 0.0 || scale.z == 0.0 {
        return Err(format!("transform scale is {scale} at frame {frame}; every axis must be non-zero"));
    }
    let AxisAngle { axis, degrees } = t.rotate.at(frame);
    let rotation = if degrees == 0.0 {
        DQuat::IDENTITY
    } else if axis.length() > 1e-12 {
        DQuat::from_axis_angle(axis.normalize(), degrees.to_radians())
    } else {
        return Err(format!(
            "transform rotate has a zero axis at frame {frame}; give a non-zero axis [x, y, z, degrees]"
        ));
    };
    let translation = t.translate.at(frame);
    Ok(move |p: DVec3| translation + rotation * (scale * p))
}

impl Scene {
    /// Evaluates the scene at `frame` (any finite frame; fractional frames are sub-frames:
    /// keys interpolate, glTF animations are sampled, and sequences interpolate linearly
    /// between their two neighbouring files). Errors name the file at fault (a missing or
    /// mismatched sequence frame) or the scene file and the frame.
    pub fn evaluate(&self, frame: f64) -> Result<FrameSpec, IoError> {
        if !frame.is_finite() {
            return Err(IoError::format(
                &self.path,
                format!("cannot evaluate frame {frame}; frames are finite numbers"),
            ));
        }
        let err = |object: &str, message: String| {
            IoError::format(&self.path, format!("frame {frame}: [[objects]] \"{object}\": {message}"))
        };
        let mut objects = Vec::with_capacity(self.description.objects.len());
        for (spec, assets) in self.description.objects.iter().zip(&self.assets) {
            let name = &spec.name;
            let mut mesh = source_mesh(name, &assets.source, frame)?;
            let map = if spec.transform.is_identity() {
                None
            } else {
                let map = transform_at(&spec.transform, frame).map_err(|m| err(name, m))?;
                mesh.map_positions(&map);
                Some(map)
            };
            let place = |p: DVec3| map.as_ref().map_or(p, |m| m(p));
            let self_contact = self.articulations_at(spec, assets, frame, &place).map_err(|m| err(name, m))?;
            let profile = ProfileValues {
                v2: spec.profile.v2.at(frame),
                v3: spec.profile.v3.at(frame),
                v4: spec.profile.v4.at(frame),
                wrinkle_amplitude: spec.profile.wrinkle_amplitude.at(frame),
                wrinkle_frequency: spec.profile.wrinkle_frequency.at(frame),
            };
            let ProfileValues { v2, v3, v4, .. } = profile;
            if !(0.2 < v2 && v2 < v3 && v3 < v4 && v4 < 1.0) {
                return Err(err(
                    name,
                    format!("profile abscissas {v2}, {v3}, {v4} must increase strictly within (0.2, 1)"),
                ));
            }
            let anisotropy = spec.anisotropy.enabled.at(frame).then(|| AnisotropyValues {
                exponent: spec.anisotropy.exponent.at(frame),
                offset: spec.anisotropy.offset.at(frame),
            });
            let region = match (&spec.region, &assets.mask) {
                (Region::Distance(d), _) => RegionFrame::Distance(d.at(frame)),
                (Region::Mask(_), Some(mask)) => RegionFrame::Mask(mask.clone()),
                _ => RegionFrame::Whole,
            };
            objects.push(ObjectFrame {
                name: name.clone(),
                mesh,
                rigid: spec.rigid,
                stiffness: spec.stiffness.at(frame),
                extent: spec.extent.as_ref().map(|e| e.at(frame)),
                bulge: spec.bulge.at(frame),
                bulge_height: spec.bulge_height.at(frame),
                preserve_volume: spec.preserve_volume,
                profile,
                anisotropy,
                bulge_map: assets.bulge_map.clone(),
                region,
                self_contact,
                rest_positions: assets.rest_positions.clone(),
            });
        }
        let mut pairs = Vec::with_capacity(self.description.pairs.len());
        for (pair, ids) in self.description.pairs.iter().zip(&self.pair_objects) {
            let direction = match &pair.direction {
                Direction::Auto => None,
                Direction::Fixed(d) => {
                    let v = d.at(frame);
                    if v.length() <= 1e-12 {
                        return Err(IoError::format(
                            &self.path,
                            format!(
                                "frame {frame}: [[pairs]] [\"{}\", \"{}\"]: the direction {v} vanishes; keys must not pass through zero",
                                pair.objects[0], pair.objects[1]
                            ),
                        ));
                    }
                    Some(v.normalize())
                }
            };
            let contact_method = match &pair.contact_method {
                ContactMethod::Geometric => ContactMethodFrame::Geometric,
                ContactMethod::Ball { radius } => ContactMethodFrame::Ball { radius: radius.at(frame) },
            };
            pairs.push(PairFrame {
                objects: *ids,
                names: pair.objects.clone(),
                enabled: pair.enabled.at(frame),
                contact_tau: pair.contact_tau.at(frame),
                direction,
                contact_method,
            });
        }
        Ok(FrameSpec { frame, objects, pairs })
    }

    /// The articulations of an object at `frame`; `place` is the object's transform at this
    /// frame. Errors are messages for the caller to place.
    fn articulations_at(
        &self,
        spec: &super::ObjectSpec,
        assets: &super::ObjectAssets,
        frame: f64,
        place: &impl Fn(DVec3) -> DVec3,
    ) -> Result<Vec<ArticulationFrame>, String> {
        if spec.self_contact.is_empty() {
            return Ok(Vec::new());
        }
        // Node world transforms, computed once for all of the object's joint directions.
        let world = match &assets.source {
            SourceAssets::Gltf(g) if assets.articulations.iter().any(|a| a.joints.is_some()) => {
                Some(g.scene.world_transforms(g.animation, g.time(frame)).map_err(|e| e.to_string())?)
            }
            _ => None,
        };
        let mut out = Vec::with_capacity(spec.self_contact.len());
        for (entry, loaded) in spec.self_contact.iter().zip(&assets.articulations) {
            let name = &entry.name;
            let direction = match (&entry.direction, loaded.joints, &world) {
                (SelfContactDirection::Fixed(d), _, _) => {
                    let v = d.at(frame);
                    if !(v.is_finite() && v.length() > 1e-12) {
                        return Err(format!(
                            "articulation \"{name}\": the direction {v} vanishes; keys must not pass through zero"
                        ));
                    }
                    ArticulationDirection::Fixed(v.normalize())
                }
                (SelfContactDirection::Joints, Some(joints), Some(world)) => {
                    let q = joints
                        .points(world)
                        .ok_or_else(|| format!("articulation \"{name}\": a joint node is missing from the pose"))?;
                    ArticulationDirection::Joints(q.map(place))
                }
                (SelfContactDirection::Joints, _, _) => {
                    return Err(format!(
                        "articulation \"{name}\": direction = \"joints\" needs joints = [\"parent\", \"child\"] on a skinned glTF mesh; give direction = [x, y, z]"
                    ));
                }
            };
            let params = ArticulationParams {
                contact_tau: entry.contact_tau.at(frame),
                stiffness: entry.stiffness.at(frame).0,
                extent: entry.extent.as_ref().map(|e| e.at(frame)),
                cut_regional_weight: entry.cut_regional_weight.at(frame),
                safeguard_angle_degrees: entry.safeguard_angle.at(frame),
                contact_gap: entry.contact_gap.as_ref().map(|g| g.at(frame)),
            };
            out.push(ArticulationFrame { name: name.clone(), regions: loaded.regions.clone(), direction, params });
        }
        Ok(out)
    }
}
