//! What the jobs of the contacts between objects share at one frame, computed once: per object its
//! vertex normals (when one of its regions is the whole object; cut regions have their own), its
//! component figures and whether it is closed; per working region its name for messages, its size
//! (of the components it touches) and its UVs (gathered for cut regions, per vertex or per face
//! corner as the object gives them).

use glam::DVec3;
use rayon::prelude::*;

use super::Frame;
use super::cache::{ComponentFigures, ObjectCache, RegionCache};
use crate::mesh::vertex_normals;
use crate::params::Uvs;

/// The per-frame store of the contacts between objects (see the module doc), indexed by object,
/// then by working region.
pub(super) struct FrameStore {
    pub normals: Vec<Option<Vec<DVec3>>>,
    pub names: Vec<Vec<String>>,
    pub uvs: Vec<Vec<Option<Uvs>>>,
    pub figures: Vec<ComponentFigures>,
    pub sizes: Vec<Vec<f64>>,
    pub closed: Vec<bool>,
}

impl FrameStore {
    pub fn new(caches: &[&ObjectCache], frame: &Frame, figures: Vec<ComponentFigures>) -> Self {
        let normals = caches
            .par_iter()
            .zip(&frame.objects)
            .map(|(c, o)| c.regions.iter().any(|r| r.sub.is_none()).then(|| vertex_normals(o.mesh)))
            .collect();
        let names = caches
            .iter()
            .zip(&frame.objects)
            .map(|(c, o)| {
                c.regions
                    .iter()
                    .enumerate()
                    .map(|(r, region)| region_name(o.name, region, r, c.regions.len()))
                    .collect()
            })
            .collect();
        let uvs = caches
            .iter()
            .zip(&frame.objects)
            .map(|(c, o)| {
                c.regions
                    .iter()
                    .map(|region| {
                        let uvs = o.params.uvs.as_ref()?;
                        Some(match (region.sub.as_deref(), uvs) {
                            (None, _) => uvs.clone(),
                            (Some(sub), Uvs::PerVertex(values)) => Uvs::PerVertex(sub.sub.gather(values)),
                            (Some(sub), Uvs::PerCorner(corners)) => {
                                Uvs::PerCorner(sub.sub.parent_face.iter().map(|&f| corners[f as usize]).collect())
                            }
                        })
                    })
                    .collect()
            })
            .collect();
        let sizes = caches
            .iter()
            .zip(&figures)
            .map(|(c, f)| c.regions.iter().map(|r| f.size_of(&r.components)).collect())
            .collect();
        let closed = caches.iter().map(|c| c.closed).collect();
        Self { normals, names, uvs, figures, sizes, closed }
    }
}

/// Display name of a region for messages: the object's name, qualified when it has several
/// regions or is cut.
fn region_name(object: &str, cache: &RegionCache, index: usize, count: usize) -> String {
    if cache.sub.is_none() && count == 1 { object.to_string() } else { format!("{object} (region {index})") }
}
