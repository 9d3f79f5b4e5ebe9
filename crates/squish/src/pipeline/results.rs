//! The results of a frame: each object's positions and deformation, its regions written back
//! ([`object_results`]), and the frame's figures — per region pair, per object, per working region and
//! per stage, the stage times summed over region pairs and regions.
//!
//! Vertices outside every deformed region keep their input positions bit for bit. An object's
//! `extent`, `bulge_height` and `applied_bulge_height` are those of its first deformed region;
//! its counts are summed over its regions.

use std::time::Instant;

use super::cache::ObjectCache;
use super::contacts::RegionPair;
use super::deformations::object_results;
use super::plan::Trace;
use super::quality::{QualityCache, measure};
use super::self_contact::{SelfContactResult, relative_to_input};
use super::warnings::frame_warnings;
use super::{Frame, FrameResult, FrameStats, ObjectsLevel, PairStats, PipelineError};
use crate::contact::{DirectionSource, PairContact};
use crate::params::PairParams;
use crate::stage::Stage;

/// The result of a frame, assembled in one place for full frames and edits: the contacts between
/// objects written back into each object's positions (`between` is the frame they started from:
/// `frame` after its self-contacts, `resolved`), the figures of every region pair, object, region
/// and stage, then the quality and warnings pass (`quality`: its trees, `None` to leave it out).
/// `start` is when the frame began.
#[allow(clippy::too_many_arguments)]
pub(super) fn assemble(
    frame: &Frame,
    between: &Frame,
    caches: &[Option<ObjectCache>],
    level: ObjectsLevel,
    resolved: Vec<Option<SelfContactResult>>,
    quality: Option<&mut QualityCache>,
    mut trace: Trace,
    start: Instant,
) -> Result<FrameResult, PipelineError> {
    let ObjectsLevel { region_pairs, contacts, outcomes, zones, contained, closed, unseparated, edit } = level;
    let pairs = pair_stats(between, &region_pairs, &contacts);
    let mut objects = object_results(between, caches, &zones, outcomes);

    // The quality and warnings pass.
    let (warnings, quality) = trace.run(Stage::Quality, || {
        let params: Vec<&PairParams> = region_pairs.iter().map(|rp| &between.pairs[rp.pair].params).collect();
        let mut warnings = frame_warnings(&pairs, &contacts, &params, &contained, &objects.stats, &closed);
        warnings.extend(unseparated);
        relative_to_input(&mut objects.stats, frame, &objects.positions, &resolved);
        let quality = match quality {
            Some(cache) => {
                let (figures, residual) = measure(frame, &objects.positions, &pairs, cache);
                warnings.extend(residual);
                figures
            }
            None => Vec::new(),
        };
        (warnings, quality)
    });

    let Trace { stages, work, jobs, articulations, part_pairs } = trace;
    Ok(FrameResult {
        positions: objects.positions,
        contacts,
        deformations: objects.deformations,
        regions: objects.summaries,
        self_contact: resolved,
        stats: FrameStats {
            total: start.elapsed(),
            stages,
            work,
            objects: objects.stats,
            pairs,
            regions: objects.regions,
            articulations,
            part_pairs,
            edit,
            warnings,
            quality,
            jobs,
        },
    })
}

/// The figures of every region pair (same order as `region_pairs`).
pub(super) fn pair_stats(
    frame: &Frame,
    region_pairs: &[RegionPair],
    contacts: &[Option<PairContact>],
) -> Vec<PairStats> {
    let mut pair_stats = Vec::with_capacity(region_pairs.len());
    for (rp, contact) in region_pairs.iter().zip(contacts) {
        let names = frame.pairs[rp.pair].objects.map(|i| frame.objects[i].name.to_string());
        let base = PairStats { objects: names, pair: rp.pair, regions: rp.regions, ..PairStats::default() };
        let Some(contact) = contact else {
            pair_stats.push(base);
            continue;
        };
        let counts = &contact.stats.counts;
        pair_stats.push(PairStats {
            in_contact: !contact.is_empty(),
            direction: contact.direction.to_array(),
            direction_automatic: matches!(contact.direction_source, DirectionSource::Automatic),
            threshold: contact.criterion.threshold,
            mean_depth: contact.criterion.mean,
            depth_std_dev: contact.criterion.std_dev,
            contact_area: contact.contact_area,
            intersection_points: counts.intersection_points,
            zone_vertices: counts.zone_vertices,
            fallbacks: contact.stats.fallbacks.numerical(),
            ..base
        });
    }
    pair_stats
}
