//! The contact stage of a frame (thesis ch. 4, §4.5): the contact definition on every pair of
//! working regions whose boxes overlap, in parallel, each region pair with its own d̂ and ε_c.
//!
//! Inputs: the frame, the object caches with this frame's regions, and [`RegionInputs`] (normals,
//! names and UVs of the regions). Outputs: one [`RegionPair`] per pair of overlapping regions of
//! each [`FramePair`](super::FramePair) (or one without regions when none overlap) with its
//! [`PairContact`], and [`RegionContacts`]: per region, its contact zones (for chapter 5), the
//! regions it touches, and the contact area of its automatic extent.
//!
//! A cut region lying wholly inside a closed object it is paired with crosses no edge, so the
//! contact definition sees nothing: that is [`PipelineError::RegionTooSmall`].

use glam::DVec3;
use rayon::prelude::*;

use super::cache::{ObjectCache, RegionCache};
use super::{Frame, PipelineError};
use crate::contact::{ContactZone, PairContact, contact_pair};
use crate::mesh::vertex_normals;
use crate::params::Uvs;

/// A region pair of this frame.
#[derive(Clone, Copy, Debug)]
pub(super) struct RegionPair {
    /// Index of its [`FramePair`](super::FramePair).
    pub pair: usize,
    /// The two regions (indices among each object's regions); `None` when no region of one
    /// object overlaps a region of the other.
    pub regions: Option<[usize; 2]>,
}

/// What the contact stage needs about each object's regions besides their caches.
pub(super) struct RegionInputs {
    /// Per object: its vertex normals when one of its regions is the whole object (cut regions
    /// have their own).
    pub normals: Vec<Option<Vec<DVec3>>>,
    /// Per object and region: the name used in messages.
    pub names: Vec<Vec<String>>,
    /// Per object and region: the UVs of the shared-parametrization mapping (gathered for cut
    /// regions: per vertex or per face, as the object gives them).
    pub uvs: Vec<Vec<Option<Uvs>>>,
}

impl RegionInputs {
    pub fn new(caches: &[&ObjectCache], frame: &Frame) -> Self {
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
        Self { normals, names, uvs }
    }
}

/// Display name of a region for messages: the object's name, qualified when it has several
/// regions or is cut.
fn region_name(object: &str, cache: &RegionCache, index: usize, count: usize) -> String {
    if cache.sub.is_none() && count == 1 { object.to_string() } else { format!("{object} (region {index})") }
}

/// Every pair of regions of each frame pair whose boxes overlap (distinct regions for a pair of
/// an object with itself), in frame-pair order; a frame pair none of whose regions overlap gets
/// one entry without regions.
pub(super) fn region_pairs(frame: &Frame, caches: &[&ObjectCache]) -> Vec<RegionPair> {
    let mut region_pairs = Vec::new();
    for (p, pair) in frame.pairs.iter().enumerate() {
        let [a, b] = pair.objects;
        let before = region_pairs.len();
        for ra in 0..caches[a].regions.len() {
            let first = if a == b { ra + 1 } else { 0 };
            for rb in first..caches[b].regions.len() {
                if caches[a].region_bounds(ra).intersects(&caches[b].region_bounds(rb)) {
                    region_pairs.push(RegionPair { pair: p, regions: Some([ra, rb]) });
                }
            }
        }
        if region_pairs.len() == before {
            region_pairs.push(RegionPair { pair: p, regions: None });
        }
    }
    region_pairs
}

/// Chapter 4 on every region pair, in parallel (`None` for a pair without regions).
pub(super) fn contact_region_pairs(
    frame: &Frame,
    caches: &[&ObjectCache],
    inputs: &RegionInputs,
    region_pairs: &[RegionPair],
) -> Result<Vec<Option<PairContact>>, PipelineError> {
    let RegionInputs { normals, names, uvs } = inputs;
    region_pairs
        .par_iter()
        .map(|rp| -> Result<Option<PairContact>, PipelineError> {
            let Some([ra, rb]) = rp.regions else { return Ok(None) };
            let pair = &frame.pairs[rp.pair];
            let [ia, ib] = pair.objects;
            let (oa, ob) = (&frame.objects[ia], &frame.objects[ib]);
            let side_a = caches[ia].side(ra, oa, normals[ia].as_deref(), &names[ia][ra], uvs[ia][ra].as_ref());
            let side_b = caches[ib].side(rb, ob, normals[ib].as_deref(), &names[ib][rb], uvs[ib][rb].as_ref());
            let sides = side_a.zip(side_b);
            let Some((side_a, side_b)) = sides else { return Ok(None) };
            let contact = contact_pair(&side_a, &side_b, &pair.params).map_err(|source| PipelineError::Contact {
                a: names[ia][ra].clone(),
                b: names[ib][rb].clone(),
                source,
            })?;
            if contact.intersection_points.is_empty() {
                // No crossing: a cut region lying wholly inside a closed object would go unseen.
                for (o, r, other, other_r) in [(ia, ra, ib, rb), (ib, rb, ia, ra)] {
                    if let Some(v) = caches[o].inside_whole_closed(r, caches[other], other_r) {
                        return Err(PipelineError::RegionTooSmall {
                            object: frame.objects[o].name.to_string(),
                            region: r,
                            reason: format!(
                                "it lies wholly inside \"{}\" (its vertex {v} is inside, and no edge crosses)",
                                frame.objects[other].name
                            ),
                        });
                    }
                }
            }
            Ok(Some(contact))
        })
        .collect()
}

/// The contact stage's results per working region (indexed `[object][region]`).
pub(super) struct RegionContacts {
    /// The non-empty zones of the region pairs it is in, when its object is not rigid. They are
    /// moved out of the [`PairContact`]s for chapter 5 instead of being copied (each holds two
    /// vectors of the region's size), and moved back by [`RegionContacts::give_back`].
    pub zones: Vec<Vec<Vec<ContactZone>>>,
    /// The regions it is in contact with, as `[object, region]`.
    pub touching: Vec<Vec<Vec<[usize; 2]>>>,
    /// The largest contact area of its region pairs.
    pub contact_area: Vec<Vec<f64>>,
    /// Where each zone came from: (index of the region pair's contact, side).
    lent: Vec<Vec<Vec<(usize, usize)>>>,
}

impl RegionContacts {
    /// Gathers the zones, contact areas and touching regions of every region from the region
    /// pairs' `contacts` (same order as `region_pairs`).
    pub fn gather(
        frame: &Frame,
        caches: &[&ObjectCache],
        region_pairs: &[RegionPair],
        contacts: &mut [Option<PairContact>],
    ) -> Self {
        let per_region = |fill: f64| -> Vec<Vec<f64>> { caches.iter().map(|c| vec![fill; c.regions.len()]).collect() };
        let mut zones: Vec<Vec<Vec<ContactZone>>> =
            caches.iter().map(|c| (0..c.regions.len()).map(|_| Vec::new()).collect()).collect();
        let mut touching: Vec<Vec<Vec<[usize; 2]>>> =
            caches.iter().map(|c| vec![Vec::new(); c.regions.len()]).collect();
        let mut contact_area = per_region(0.0);
        let mut lent: Vec<Vec<Vec<(usize, usize)>>> =
            caches.iter().map(|c| vec![Vec::new(); c.regions.len()]).collect();
        for (k, (rp, contact)) in region_pairs.iter().zip(contacts.iter_mut()).enumerate() {
            let Some(regions) = rp.regions else { continue };
            let objects = frame.pairs[rp.pair].objects;
            let Some(contact) = contact else { continue };
            if contact.is_empty() {
                continue;
            }
            for side in 0..2 {
                let (o, r) = (objects[side], regions[side]);
                touching[o][r].push([objects[1 - side], regions[1 - side]]);
                contact_area[o][r] = contact_area[o][r].max(contact.contact_area);
                let zone = &mut contact.sides[side].zone;
                if !zone.is_empty() && !frame.objects[o].params.rigid {
                    zones[o][r].push(std::mem::take(zone));
                    lent[o][r].push((k, side));
                }
            }
        }
        Self { zones, touching, contact_area, lent }
    }

    /// Moves the zones back into the contacts they came from (the zone lists keep their lengths).
    pub fn give_back(&mut self, contacts: &mut [Option<PairContact>]) {
        for (zone, &(k, side)) in self.zones.iter_mut().flatten().flatten().zip(self.lent.iter().flatten().flatten()) {
            if let Some(Some(contact)) = contacts.get_mut(k) {
                contact.sides[side].zone = std::mem::take(zone);
            }
        }
    }
}
