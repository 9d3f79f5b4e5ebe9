//! The setup stage of a frame (thesis ch. 3): the frame's pairs and parameters are checked before
//! any work, then every object's cache is brought to this frame — rebuilt when its connectivity
//! changed, its whole-object triangle tree refitted where this frame uses it, and the figures of
//! its connected components computed (the sizes of the automatic extent, the length scale h).

use rayon::prelude::*;

use super::cache::{ComponentFigures, ObjectCache};
use super::{Frame, PipelineError};
use crate::params::{Params, RegionChoice};

/// Who is paired with whom in a frame.
pub(super) struct Pairing {
    /// Per object: the other objects it is paired with, sorted, without repeats.
    pub partners: Vec<Vec<usize>>,
    /// Per object: whether this frame uses its whole-object triangle tree (`whole` regions, and
    /// the partners of automatic regions), which the setup then refits.
    pub needs_tree: Vec<bool>,
}

/// Checks the frame's pairs (object indices, self-pairs) and every object's parameters (stiffness,
/// extent, working region, UVs) and returns its [`Pairing`].
pub(super) fn check_frame(frame: &Frame) -> Result<Pairing, PipelineError> {
    let count = frame.objects.len();
    let mut partners: Vec<Vec<usize>> = vec![Vec::new(); count];
    for (p, pair) in frame.pairs.iter().enumerate() {
        for &index in &pair.objects {
            if index >= count {
                return Err(PipelineError::PairIndex { pair: p, index, count });
            }
        }
        let [a, b] = pair.objects;
        if a == b {
            if !frame.objects[a].params.region.allows_self_contact() {
                return Err(PipelineError::SelfPair { pair: p, object: frame.objects[a].name.to_string() });
            }
        } else {
            partners[a].push(b);
            partners[b].push(a);
        }
    }
    for list in &mut partners {
        list.sort_unstable();
        list.dedup();
    }
    for object in &frame.objects {
        let params = object.params;
        params.validate().map_err(|source| PipelineError::Parameter { object: object.name.to_string(), source })?;
        super::regions::validate_region(params, object.mesh.num_vertices())
            .map_err(|reason| PipelineError::invalid_region(object.name, reason))?;
        if let Some(uvs) = &params.uvs {
            let (counted, actual) = uvs.count();
            let expected = uvs.expected(object.mesh.num_vertices(), object.mesh.num_triangles());
            if actual != expected && counted == "vertices" {
                return Err(PipelineError::PerVertexLength {
                    object: object.name.to_string(),
                    what: "the UVs",
                    expected,
                    actual,
                });
            }
            if actual != expected {
                let message =
                    format!("{actual} corner triples for the mesh's {expected} triangles; give three per triangle");
                return Err(PipelineError::Parameter {
                    object: object.name.to_string(),
                    source: crate::params::ParamError::new("uvs", None, message),
                });
            }
        }
    }
    let needs_tree = (0..count)
        .map(|i| {
            frame.objects[i].params.region == RegionChoice::Whole
                || partners[i].iter().any(|&j| frame.objects[j].params.region.is_automatic())
        })
        .collect();
    Ok(Pairing { partners, needs_tree })
}

/// Brings every object's cache to this frame (in parallel; one cache per object, in frame order)
/// and returns the figures of each object's components at this frame's positions.
pub(super) fn update_objects(
    caches: &mut Vec<Option<ObjectCache>>,
    frame: &Frame,
    needs_tree: &[bool],
) -> Result<Vec<ComponentFigures>, PipelineError> {
    caches.resize_with(frame.objects.len(), || None);
    caches.truncate(frame.objects.len());
    caches
        .par_iter_mut()
        .zip(&frame.objects)
        .zip(needs_tree)
        .map(|((cache, object), &needs_tree)| -> Result<ComponentFigures, PipelineError> {
            object
                .mesh
                .check_structure()
                .map_err(|source| PipelineError::Mesh { object: object.name.to_string(), source })?;
            let cache = match cache {
                Some(c) if c.matches(object.mesh) => {
                    if needs_tree {
                        std::sync::Arc::make_mut(&mut c.bvh)
                            .refit(&object.mesh.positions)
                            .map_err(|source| PipelineError::Spatial { object: object.name.to_string(), source })?;
                    }
                    c
                }
                _ => cache.insert(ObjectCache::new(object.name, object.mesh)?),
            };
            Ok(cache.figures(object.mesh))
        })
        .collect()
}
