//! What a frame did not do that it was asked to (issue 28): a contact zone left empty while the
//! meshes intersect, a mesh wholly inside another, a contact parameter that had to be reduced,
//! an open mesh deformed with its volume preservation switched off and no bulge, a penetration left deeper than the tolerance. Each is
//! a [`FrameWarning`] in [`super::FrameStats::warnings`], naming the pair or object and saying
//! why and what to change; the command line prints them, writes them to its reports and fails
//! with `--strict` when there is any. Nothing here changes a result.

use serde::{Deserialize, Serialize};

use super::{ObjectStats, PairStats};
use crate::contact::PairContact;
use crate::params::PairParams;

/// Deepest residual penetration accepted, as a fraction of the input's deepest penetration.
pub const RESIDUAL_PENETRATION_TOLERANCE: f64 = 0.1;

/// What kind of shortfall a [`FrameWarning`] reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WarningKind {
    /// The meshes intersect but the pair has no contact zone: nothing was resolved.
    EmptyContactZone,
    /// One closed mesh lies wholly inside the other: no surfaces cross, nothing was resolved.
    Containment,
    /// τ asked for a threshold above every depth; ε_c was lowered to the typical penetration.
    ContactSpreadClamped,
    /// Method A's ball radius did not fit inside the elastic object; a smaller one was used.
    BallRadiusReduced,
    /// An open mesh was deformed with `preserve_volume = false` and no bulge height: it lost volume.
    NoBulge,
    /// The output still penetrates deeper than [`RESIDUAL_PENETRATION_TOLERANCE`] of the input.
    ResidualPenetration,
    /// Faces of a pair still intersect after the separation pass's rounds (`separation`).
    Unseparated,
}

/// One shortfall of a frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameWarning {
    pub kind: WarningKind,
    /// Index in [`crate::FrameStats::pairs`] of the region pair concerned, if any.
    pub pair: Option<usize>,
    /// Index of the object concerned, if any.
    pub object: Option<usize>,
    /// What happened, why, and what to change.
    pub message: String,
}

/// The pipeline's warnings for one frame: per region pair (`contacts[k]` with its
/// `pairs[k]`, parameters `params[k]` and whether one side lies inside the other,
/// `contained[k] = Some([inner, outer])` as indices into the pair's two sides), then per object.
/// Per region pair: `[inner, outer]` as sides of the pair when one whole closed region lies inside
/// the other with no edge crossing (a containment, which no contact zone can resolve).
pub(super) fn contained_sides(
    frame: &super::Frame,
    caches: &[&super::cache::ObjectCache],
    region_pairs: &[super::contacts::RegionPair],
    contacts: &[Option<PairContact>],
) -> Vec<Option<[usize; 2]>> {
    region_pairs
        .iter()
        .zip(contacts)
        .map(|(rp, contact)| {
            let (Some([ra, rb]), Some(contact)) = (rp.regions, contact) else { return None };
            if !contact.intersection_points.is_empty() {
                return None;
            }
            let [ia, ib] = frame.pairs[rp.pair].objects;
            let (ma, mb) = (frame.objects[ia].mesh, frame.objects[ib].mesh);
            if caches[ia].lies_inside(ra, ma, caches[ib], rb) {
                Some([0, 1])
            } else if caches[ib].lies_inside(rb, mb, caches[ia], ra) {
                Some([1, 0])
            } else {
                None
            }
        })
        .collect()
}

pub(super) fn frame_warnings(
    pairs: &[PairStats],
    contacts: &[Option<PairContact>],
    params: &[&PairParams],
    contained: &[Option<[usize; 2]>],
    objects: &[ObjectStats],
    closed: &[bool],
) -> Vec<FrameWarning> {
    let mut warnings = Vec::new();
    for (k, ((stats, contact), params)) in pairs.iter().zip(contacts).zip(params).enumerate() {
        let contained = contained.get(k).copied().flatten();
        warnings.extend(pair_warnings(&stats.objects, k, contact.as_ref(), params, contained));
    }
    for (i, object) in objects.iter().enumerate() {
        if object.deformed
            && !closed.get(i).copied().unwrap_or(true)
            && !object.preserve_volume
            && object.applied_bulge_height == 0.0
        {
            warnings.push(FrameWarning {
                kind: WarningKind::NoBulge,
                pair: None,
                object: Some(i),
                message: format!(
                    "object \"{}\" is an open mesh deformed with preserve_volume = false and no bulge_height: it lost the \
                     volume its contact pushed in; leave preserve_volume on (the swept volume is then kept) or set its \
                     bulge_height",
                    object.name
                ),
            });
        }
    }
    warnings
}

/// The warnings of region pair `k` (see [`FrameWarning`]): its objects' names, its contact
/// definition (`None` when their regions' boxes are apart), its parameters and, when no edge
/// crosses, which side lies inside the other (`[inner, outer]`).
pub fn pair_warnings(
    names: &[String; 2],
    k: usize,
    contact: Option<&PairContact>,
    params: &PairParams,
    contained: Option<[usize; 2]>,
) -> Vec<FrameWarning> {
    let mut found: Vec<(WarningKind, String)> = Vec::new();
    let [a, b] = names;
    let mut warn = |kind, message: String| found.push((kind, message));
    if let Some([inner, _]) = contained {
        let (inside, around) = if inner == 0 { (a, b) } else { (b, a) };
        warn(
            WarningKind::Containment,
            format!(
                "\"{inside}\" lies wholly inside \"{around}\" (no surfaces cross): the contact zones are bounded by the \
                 intersection curves (thesis §4.1), so nothing was resolved; move it so that the surfaces cross"
            ),
        );
    }
    let Some(contact) = contact else { return finish(names, k, found) };
    if let Some(unclamped) = contact.criterion.unclamped_threshold {
        warn(
            WarningKind::ContactSpreadClamped,
            format!(
                "pair.contact_tau = {} asks for ε_c = {unclamped:.3e}, above the typical penetration depth {:.3e}: \
                 ε_c was lowered to it so that the deepest part stays in contact (a smaller τ gives the same zone)",
                params.contact_tau, contact.criterion.threshold
            ),
        );
    }
    if let (Some(used), Some(radius)) = (contact.ball_radius, params.ball()) {
        warn(
            WarningKind::BallRadiusReduced,
            format!(
                "no ball of radius {radius} fits inside the elastic object at the contact (every ball touched its \
                 other side), so the contact zone used radius {used:.4}; set the pair's ball_radius ≤ {used:.4}"
            ),
        );
    }
    if !contact.intersection_points.is_empty() && contact.is_empty() {
        let why = if contact.sides.iter().all(|s| s.mapping.region.num_inside() == 0) {
            "no point of either intersection region maps onto the other mesh along the mapping direction; give \
             pair.direction (pointing along the second mesh's normals)"
                .to_string()
        } else if let Some(radius) = params.ball() {
            format!(
                "ball testing kept no vertex even with a radius of {:.3e} (asked {radius}); check which object is rigid",
                contact.ball_radius.unwrap_or(radius)
            )
        } else {
            format!(
                "no point of the mapping regions is both deeper than ε_c = {:.3e} and within the {}° safeguard angle; a \
                 smaller pair.contact_tau, a larger pair.safeguard_angle or pair.direction help",
                contact.criterion.threshold, params.safeguard_angle
            )
        };
        warn(
            WarningKind::EmptyContactZone,
            format!(
                "the meshes intersect ({} crossings) but the contact zone is empty: {why}",
                contact.intersection_points.len()
            ),
        );
    }

    finish(names, k, found)
}

fn finish(names: &[String; 2], k: usize, found: Vec<(WarningKind, String)>) -> Vec<FrameWarning> {
    let named = format!("pair (\"{}\", \"{}\")", names[0], names[1]);
    found
        .into_iter()
        .map(|(kind, message)| FrameWarning {
            kind,
            pair: Some(k),
            object: None,
            message: format!("{named}: {message}"),
        })
        .collect()
}
