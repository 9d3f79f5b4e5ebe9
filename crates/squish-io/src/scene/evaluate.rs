//! A scene evaluated at one frame ([`OwnedFrame`]): for every object its mesh (posed,
//! transformed) and the library's parameters at that frame; for every pair, disabled ones
//! included, its parameters. This is all the deformer needs
//! for that frame, with no reference to other frames (the method is time-independent).

use glam::{DQuat, DVec3};
use squish::params::{Articulation, MappingMethod};
use squish::pipeline::{FramePair, OwnedFrame, OwnedObject};

use super::Scene;
use super::source::{SourceAssets, source_mesh};
use super::transform::{AxisAngle, Scale, Transform};
use crate::IoError;

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
    pub fn evaluate(&self, frame: f64) -> Result<OwnedFrame, IoError> {
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
            let mut params = assets.params.at(frame).map_err(|e| err(name, e.to_string()))?;
            params.self_contact = self.articulations_at(assets, frame, &place).map_err(|m| err(name, m))?;
            params.self_contact_parts = assets.parts.as_deref().cloned();
            params.rest_positions = assets.rest_positions.as_deref().map(<[DVec3]>::to_vec);
            objects.push(OwnedObject { name: name.clone(), mesh, params });
        }
        let mut pairs = Vec::with_capacity(self.description.pairs.len());
        for ((pair, ids), tracks) in self.description.pairs.iter().zip(&self.pair_objects).zip(&self.pair_params) {
            let params = tracks.at(frame).map_err(|e| {
                IoError::format(
                    &self.path,
                    format!("frame {frame}: [[pairs]] [\"{}\", \"{}\"]: {e}", pair.objects[0], pair.objects[1]),
                )
            })?;
            if params.mapping == MappingMethod::SharedParametrization {
                for i in *ids {
                    if objects[i].params.uvs.is_none() {
                        objects[i].params.uvs = Some((*self.object_uvs(i)?).clone());
                    }
                }
            }
            pairs.push(FramePair { objects: *ids, params });
        }
        Ok(OwnedFrame { objects, pairs })
    }

    /// The articulations of an object at `frame`; `place` is the object's transform at this
    /// frame. Errors are messages for the caller to place.
    fn articulations_at(
        &self,
        assets: &super::ObjectAssets,
        frame: f64,
        place: &impl Fn(DVec3) -> DVec3,
    ) -> Result<Vec<Articulation>, String> {
        if assets.articulations.is_empty() {
            return Ok(Vec::new());
        }
        // Node world transforms, computed once for all of the object's joint directions.
        let world = match &assets.source {
            SourceAssets::Gltf(g) if assets.articulations.iter().any(|a| a.joints.is_some()) => {
                Some(g.scene.world_transforms(g.animation, g.time(frame)).map_err(|e| e.to_string())?)
            }
            _ => None,
        };
        let mut out = Vec::with_capacity(assets.articulations.len());
        for (name, loaded) in assets.articulation_names.iter().zip(&assets.articulations) {
            let params = loaded.params.at(frame).map_err(|e| format!("articulation \"{name}\": {e}"))?;
            let joints = match (params.direction, loaded.joints, &world) {
                (Some(_), _, _) => None,
                (None, Some(joints), Some(world)) => Some(
                    joints
                        .points(world)
                        .ok_or_else(|| format!("articulation \"{name}\": a joint node is missing from the pose"))?
                        .map(place),
                ),
                (None, _, _) => {
                    return Err(format!(
                        "articulation \"{name}\": direction = \"joints\" needs joints = [\"parent\", \"child\"] on a skinned glTF mesh; give direction = [x, y, z]"
                    ));
                }
            };
            out.push(Articulation {
                name: name.clone(),
                regions: (*loaded.regions).clone(),
                joints,
                params,
                automatic: loaded.automatic,
            });
        }
        Ok(out)
    }
}
