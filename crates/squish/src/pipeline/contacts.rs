//! The contact stage of a frame (thesis ch. 4, §4.5): the contact definition on every pair of
//! working regions whose boxes overlap, in parallel, each region pair with its own d̂ and ε_c.
//!
//! Inputs: the frame, the object caches with this frame's regions, and the [`FrameStore`]
//! (normals, names and UVs of the regions). Outputs: one [`RegionPair`] per pair of overlapping
//! regions of each [`FramePair`](super::FramePair) (or one without regions when none overlap) —
//! the jobs of the plan's level of contacts between objects — with its [`PairContact`], and
//! [`RegionZones`]: per region, its contact zones borrowed from the contacts (for chapter 5), the
//! regions it touches, and the contact area of its automatic extent.
//!
//! A cut region lying wholly inside a closed object it is paired with crosses no edge, so the
//! contact definition sees nothing: that is [`PipelineError::RegionTooSmall`].

use rayon::prelude::*;

use super::cache::ObjectCache;
use super::plan::{JobKind, JobLevel, JobRecord, Trace};
use super::store::FrameStore;
use super::{Frame, PipelineError};
use crate::contact::{ContactZone, PairContact, contact_pair};

/// A region pair of this frame.
#[derive(Clone, Copy, Debug)]
pub(super) struct RegionPair {
    /// Index of its [`FramePair`](super::FramePair).
    pub pair: usize,
    /// The two regions (indices among each object's regions); `None` when no region of one
    /// object overlaps a region of the other.
    pub regions: Option<[usize; 2]>,
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

/// Chapter 4 on every region pair, in parallel (`None` for a pair without regions); each pair's
/// stage times go to its job's record (`jobs[k]` for `region_pairs[k]`).
pub(super) fn contact_region_pairs(
    frame: &Frame,
    caches: &[&ObjectCache],
    store: &FrameStore,
    region_pairs: &[RegionPair],
    jobs: &[usize],
    trace: &mut Trace,
) -> Result<Vec<Option<PairContact>>, PipelineError> {
    let FrameStore { normals, names, uvs, .. } = store;
    let contacts: Vec<Option<PairContact>> =
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
                let contact = contact_pair(&side_a, &side_b, &pair.params).map_err(|source| {
                    PipelineError::Contact { a: names[ia][ra].clone(), b: names[ib][rb].clone(), source }
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
            .collect::<Result<_, _>>()?;
    for ((contact, &job), rp) in contacts.iter().zip(jobs).zip(region_pairs) {
        let Some(contact) = contact else { continue };
        trace.add_to_job(job, &contact.stats.timings, &contact.stats.work);
        let record = &mut trace.jobs[job];
        record.in_contact = !contact.is_empty();
        record.objects = frame.pairs[rp.pair].objects;
    }
    Ok(contacts)
}

/// One [`JobRecord`] per region pair, appended to the trace; returns their indices.
pub(super) fn job_records(
    frame: &Frame,
    store: &FrameStore,
    region_pairs: &[RegionPair],
    trace: &mut Trace,
) -> Vec<usize> {
    region_pairs
        .iter()
        .map(|rp| {
            let [a, b] = frame.pairs[rp.pair].objects;
            let name = match rp.regions {
                Some([ra, rb]) => format!("{} – {}", store.names[a][ra], store.names[b][rb]),
                None => format!("{} – {} (no overlapping regions)", frame.objects[a].name, frame.objects[b].name),
            };
            trace.push_job(JobRecord::new(JobLevel::Objects, JobKind::Regions, name, [a, b]))
        })
        .collect()
}

/// The contact stage's results per working region (indexed `[object][region]`), borrowed from
/// the region pairs' contacts.
pub(super) struct RegionZones<'c> {
    /// The non-empty zones of the region pairs it is in, when its object is not rigid.
    pub zones: Vec<Vec<Vec<&'c ContactZone>>>,
    /// The regions it is in contact with, as `[object, region]`.
    pub touching: Vec<Vec<Vec<[usize; 2]>>>,
    /// The largest contact area of its region pairs.
    pub contact_area: Vec<Vec<f64>>,
}

/// What the results read of [`RegionZones`], owned: per object and region, the number of zones
/// and the regions it touches.
pub(super) struct ZoneSummary {
    pub zones: Vec<Vec<usize>>,
    pub touching: Vec<Vec<Vec<[usize; 2]>>>,
}

impl<'c> RegionZones<'c> {
    /// The zone counts and touching regions.
    pub fn summary(&self) -> ZoneSummary {
        ZoneSummary {
            zones: self.zones.iter().map(|o| o.iter().map(Vec::len).collect()).collect(),
            touching: self.touching.clone(),
        }
    }

    /// Gathers the zones, contact areas and touching regions of every region from the region
    /// pairs' `contacts` (same order as `region_pairs`); `regions[object]` is its number of
    /// working regions.
    pub fn gather(
        frame: &Frame,
        regions: &[usize],
        region_pairs: &[RegionPair],
        contacts: &'c [Option<PairContact>],
    ) -> Self {
        let mut zones: Vec<Vec<Vec<&ContactZone>>> = regions.iter().map(|&n| vec![Vec::new(); n]).collect();
        let mut touching: Vec<Vec<Vec<[usize; 2]>>> = regions.iter().map(|&n| vec![Vec::new(); n]).collect();
        let mut contact_area: Vec<Vec<f64>> = regions.iter().map(|&n| vec![0.0; n]).collect();
        for (rp, contact) in region_pairs.iter().zip(contacts) {
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
                let zone = &contact.sides[side].zone;
                if !zone.is_empty() && !frame.objects[o].params.rigid {
                    zones[o][r].push(zone);
                }
            }
        }
        Self { zones, touching, contact_area }
    }
}
