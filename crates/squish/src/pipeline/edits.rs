//! Fast edits: a frame that differs from the last one only by parameters of §5.4–5.5 reuses that
//! frame's contact stage (ch. 4) and each region's fields of §5.1–5.3, and recomputes only the
//! bulge map, the profiles, the volume, the separation pass (from the last pass's distance
//! bounds, `super::separation::SeparationSeed`) and the results.
//!
//! **The rule.** The *downstream* parameters ([`DOWNSTREAM_KEYS`]) are the object parameters
//! read by the deformation stage's last step only ([`crate::deform::RegionFields`]): the
//! profile abscissas `profile_v2`–`profile_v4`, `wrinkle_amplitude`, `wrinkle_frequency`,
//! `bulge`, `bulge_height`, `preserve_volume`, the painted `bulge_map` and the anisotropic map's
//! `anisotropy`, `anisotropy_exponent`, `anisotropy_offset`. No other stage reads them: the
//! contact stage reads the stiffness, rigidity, regions and the pair's parameters; the extent
//! and its clamping read sizes, areas and φ; §5.1–5.3 read the extent, the heat time, the domain
//! factor and the direction field's options. The anisotropic map changes η only (Eq. 5.6: the
//! factor of h in each vertex's displacement), and so do the painted map and γ; the volume cubic
//! is recomputed from the new displacement. A frame is an edit of the kept one when every object
//! has the same name, the same positions and triangles (bit for bit) and the same value of every
//! other parameter (bit for bit, the UVs included), and the pairs are the same (bit for bit);
//! objects with self-contact articulations (ch. 6, which reads the downstream parameters before
//! the pairs) are never edited.
//!
//! **Same bits.** The kept fields are those a fresh computation of the frame would produce (the
//! pipeline is deterministic and its caches never change results), and §5.4–5.5 runs the same
//! code on them, so an edit's positions, deformations and figures are a full computation's, bit
//! for bit (tested per downstream parameter against a fresh [`super::Deformer`]). Only the work
//! counters and times differ: an edit factorizes nothing and reports the time it took, with
//! [`super::FrameStats::edit`] set.
//!
//! Kept only when asked ([`super::Deformer::keep_for_edits`]): the copies cost memory and a
//! little time on every full frame, which a shot computed frame by frame does not need.

use glam::DVec3;

use super::FrameObject;
use super::contacts::RegionPair;
use super::deformations::KeptRegion;
use super::{Frame, FramePair};
use crate::contact::PairContact;
use crate::params::{ObjectParams, PairParams, ParamValue, Params};

/// The object parameters that only §5.4–5.5 read (see the module doc).
pub const DOWNSTREAM_KEYS: [&str; 12] = [
    "bulge",
    "bulge_height",
    "preserve_volume",
    "profile_v2",
    "profile_v3",
    "profile_v4",
    "wrinkle_amplitude",
    "wrinkle_frequency",
    "anisotropy",
    "anisotropy_exponent",
    "anisotropy_offset",
    "bulge_map",
];

/// True if `key` is an object parameter that only §5.4–5.5 read.
pub fn is_downstream(key: &str) -> bool {
    DOWNSTREAM_KEYS.contains(&key)
}

/// What the last full frame left for edits.
pub(super) struct EditState {
    key: FrameKey,
    /// The contact stage's results (zones in place).
    pub contacts: Vec<Option<PairContact>>,
    pub region_pairs: Vec<RegionPair>,
    /// Per object and region: what its deformation reuses (`None` without zones).
    pub regions: Vec<Vec<Option<KeptRegion>>>,
    /// Per region pair: which side lies inside the other (for the warnings, which an edit keeps).
    pub contained: Vec<Option<[usize; 2]>>,
    /// Per object: whether its mesh is closed.
    pub closed: Vec<bool>,
}

impl EditState {
    pub fn new(
        frame: &Frame,
        contacts: Vec<Option<PairContact>>,
        region_pairs: Vec<RegionPair>,
        regions: Vec<Vec<Option<KeptRegion>>>,
        contained: Vec<Option<[usize; 2]>>,
        closed: Vec<bool>,
    ) -> Self {
        Self { key: FrameKey::of(frame), contacts, region_pairs, regions, contained, closed }
    }

    /// True if `frame` is an edit of the kept frame (see the module doc).
    pub fn is_edit(&self, frame: &Frame) -> bool {
        self.key.matches(frame)
    }
}

/// Everything of a frame that the kept results depend on.
struct FrameKey {
    objects: Vec<ObjectKey>,
    pairs: Vec<PairKey>,
}

/// A pair's objects and parameter values.
type PairKey = ([usize; 2], Vec<(&'static str, ParamValue)>);

struct ObjectKey {
    name: String,
    positions: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    upstream: Vec<(&'static str, ParamValue)>,
    uvs: Option<crate::params::Uvs>,
}

/// The values of every object parameter but the downstream ones.
fn upstream_values(params: &ObjectParams) -> Vec<(&'static str, ParamValue)> {
    params.values().into_iter().filter(|(key, _)| !is_downstream(key)).collect()
}

fn pair_values(params: &PairParams) -> Vec<(&'static str, ParamValue)> {
    params.values()
}

/// Bitwise equality of parameter values (0.0 and −0.0 differ, a NaN equals itself).
fn same_values(a: &[(&'static str, ParamValue)], b: &[(&'static str, ParamValue)]) -> bool {
    let same = |x: &ParamValue, y: &ParamValue| match (x, y) {
        (ParamValue::Number(x), ParamValue::Number(y)) => x.to_bits() == y.to_bits(),
        (ParamValue::List(x), ParamValue::List(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(x, y)| x.to_bits() == y.to_bits())
        }
        (x, y) => x == y,
    };
    a.len() == b.len() && a.iter().zip(b).all(|((ka, va), (kb, vb))| ka == kb && same(va, vb))
}

fn same_points<const N: usize, T: Copy + Into<[f64; N]>>(a: &[T], b: &[T]) -> bool {
    let bits = |p: T| -> [u64; N] { p.into().map(f64::to_bits) };
    a.len() == b.len() && a.iter().zip(b).all(|(&p, &q)| bits(p) == bits(q))
}

impl FrameKey {
    fn of(frame: &Frame) -> Self {
        let objects = frame
            .objects
            .iter()
            .map(|o: &FrameObject| ObjectKey {
                name: o.name.to_string(),
                positions: o.mesh.positions.clone(),
                triangles: o.mesh.triangles.clone(),
                upstream: upstream_values(o.params),
                uvs: o.params.uvs.clone(),
            })
            .collect();
        let pairs = frame.pairs.iter().map(|p: &FramePair| (p.objects, pair_values(&p.params))).collect();
        Self { objects, pairs }
    }

    fn matches(&self, frame: &Frame) -> bool {
        let objects = self.objects.len() == frame.objects.len()
            && self.objects.iter().zip(&frame.objects).all(|(k, o)| {
                k.name == o.name
                    && !super::self_contact::has_self_contact(o.params)
                    && k.triangles == o.mesh.triangles
                    && same_points::<3, DVec3>(&k.positions, &o.mesh.positions)
                    && same_values(&k.upstream, &upstream_values(o.params))
                    && match (&k.uvs, &o.params.uvs) {
                        (None, None) => true,
                        (Some(a), Some(b)) => a.same_bits(b),
                        _ => false,
                    }
            });
        objects
            && self.pairs.len() == frame.pairs.len()
            && self
                .pairs
                .iter()
                .zip(&frame.pairs)
                .all(|((objects, values), p)| *objects == p.objects && same_values(values, &pair_values(&p.params)))
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn every_downstream_key_is_an_object_parameter() {
        for key in DOWNSTREAM_KEYS {
            assert!(ObjectParams::info(key).is_some(), "{key}");
        }
        assert!(!is_downstream("stiffness") && !is_downstream("extent"));
    }

    #[test]
    fn values_compare_bit_for_bit() {
        let a = vec![("x", ParamValue::Number(0.0))];
        let b = vec![("x", ParamValue::Number(-0.0))];
        assert!(!same_values(&a, &b));
        let nan = vec![("x", ParamValue::Number(f64::NAN))];
        assert!(same_values(&nan, &nan.clone()));
    }
}
