//! Quality figures of one computed frame, measured by the shot's workers: per object, the relative
//! volume change, the contact area and the largest displacement from the input (the
//! frame-to-frame steps are set once the previous frame is known); per pair, the deepest
//! penetration of either mesh into the other before and after deformation (closed meshes only)
//! and how many faces of each intersect the other (exact triangle–triangle test, any mesh).

use glam::DVec3;
use serde::Serialize;
use squish::pipeline::{Frame, FrameResult};
use squish::spatial::{self, TriangleBvh};
use squish::{Topology, TriMesh};

/// Deepest penetration of either closed mesh into the other, or `None` if one is open.
pub fn deepest_penetration(a: &TriMesh, b: &TriMesh) -> Option<f64> {
    let ab = spatial::penetration_depths(a, b).ok()?;
    let ba = spatial::penetration_depths(b, a).ok()?;
    Some(ab.iter().chain(&ba).fold(0.0f64, |m, &d| m.max(d)))
}

/// Figures of one object at one frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ObjectQuality {
    pub name: String,
    /// True if the object was deformed at this frame.
    pub deformed: bool,
    /// (V_after − V_before) / |V_before|.
    pub relative_volume_change: f64,
    /// Largest contact area of the object's pairs (on the potential contact surface).
    pub contact_area: f64,
    /// Largest vertex displacement from this frame's input.
    pub max_deformation: f64,
    /// Largest vertex displacement from the previous frame's output (`None` for the first frame
    /// of the range, or after a frame that was not computed).
    pub output_step: Option<f64>,
    /// Largest vertex displacement of the input from the previous frame's input.
    pub input_step: Option<f64>,
    /// `output_step / input_step` (`None` when the input did not move).
    pub step_ratio: Option<f64>,
}

impl ObjectQuality {
    /// Sets the frame-to-frame steps.
    pub fn set_steps(&mut self, output: f64, input: f64) {
        self.output_step = Some(output);
        self.input_step = Some(input);
        self.step_ratio = (input > 0.0).then(|| output / input);
    }
}

/// Figures of one pair at one frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PairQuality {
    pub objects: [String; 2],
    pub in_contact: bool,
    /// Area of the contact zone on the potential contact surface.
    pub contact_area: f64,
    /// Deepest vertex of either mesh inside the other, before (input) and after (output); `None`
    /// when a mesh is not closed (inside is undefined).
    pub penetration_before: Option<f64>,
    pub penetration_after: Option<f64>,
    /// `penetration_after / penetration_before` (`None` when there was no penetration).
    pub penetration_ratio: Option<f64>,
    /// Faces of each object that intersect a face of the other (exact test, touching counts),
    /// before (input) and after (output). At the default `pair.contact_gap` the outputs have
    /// none; with a gap of 0 the coincident contact surfaces interleave.
    pub intersecting_faces_before: [usize; 2],
    pub intersecting_faces_after: [usize; 2],
}

/// What measuring a frame reuses from the previous frames a worker measured: per object,
/// whether it is closed and triangle trees over its input and its output, refitted to each
/// frame's positions (rebuilding two trees per object and frame would cost as much as a third
/// of the deformation itself).
#[derive(Default)]
pub struct MeasureCache {
    objects: Vec<Option<ObjectTrees>>,
}

struct ObjectTrees {
    triangles: Vec<[u32; 3]>,
    closed: bool,
    input: TriangleBvh,
    output: TriangleBvh,
}

impl MeasureCache {
    /// Trees of object `i` over `input` and `output` positions, built or refitted (kept in the
    /// cache for open meshes too: their faces are counted); `None` for an open mesh (no inside,
    /// no penetration) or a mesh the trees cannot be built for.
    fn trees(&mut self, i: usize, mesh: &TriMesh, output: &[DVec3]) -> Option<&ObjectTrees> {
        if self.objects.len() <= i {
            self.objects.resize_with(i + 1, || None);
        }
        let slot = &mut self.objects[i];
        let reusable = slot.as_ref().is_some_and(|t| t.triangles == mesh.triangles);
        if reusable {
            let trees = slot.as_mut()?;
            if trees.input.refit(&mesh.positions).is_err() || trees.output.refit(output).is_err() {
                *slot = None;
                return None;
            }
        } else {
            let closed = Topology::new(mesh).is_closed();
            let output_mesh = TriMesh { positions: output.to_vec(), triangles: mesh.triangles.clone() };
            let (input, output) = (TriangleBvh::new(mesh).ok()?, TriangleBvh::new(&output_mesh).ok()?);
            *slot = Some(ObjectTrees { triangles: mesh.triangles.clone(), closed, input, output });
        }
        slot.as_ref().filter(|t| t.closed)
    }
}

/// Distinct faces of each tree that intersect a face of the other.
fn intersecting_faces(a: &TriangleBvh, b: &TriangleBvh) -> [usize; 2] {
    if !a.bounds().intersects(&b.bounds()) {
        return [0, 0];
    }
    let pairs = a.intersections_with(b);
    let mut faces: [Vec<u32>; 2] = [pairs.iter().map(|p| p[0]).collect(), pairs.iter().map(|p| p[1]).collect()];
    faces.iter_mut().for_each(|f| {
        f.sort_unstable();
        f.dedup();
    });
    faces.map(|f| f.len())
}

/// Deepest vertex of either point set inside the other tree's closed mesh.
fn deepest(a: &[DVec3], tree_a: &TriangleBvh, b: &[DVec3], tree_b: &TriangleBvh) -> f64 {
    if !tree_a.bounds().intersects(&tree_b.bounds()) {
        return 0.0;
    }
    tree_b.penetration_depths(a).into_iter().chain(tree_a.penetration_depths(b)).fold(0.0, f64::max)
}

/// The quality figures of `frame`'s result (the frame-to-frame steps are filled in later, by the
/// shot).
pub fn measure(
    frame: &Frame,
    result: &FrameResult,
    cache: &mut MeasureCache,
) -> (Vec<ObjectQuality>, Vec<PairQuality>) {
    let stats = &result.stats;
    let mut area = vec![0.0f64; frame.objects.len()];
    let mut pairs = Vec::with_capacity(frame.pairs.len());
    for (pair, pair_stats) in frame.pairs.iter().zip(&stats.pairs) {
        let [a, b] = pair.objects;
        for &i in &pair.objects {
            area[i] = area[i].max(pair_stats.contact_area);
        }
        let (mesh_a, mesh_b) = (frame.objects[a].mesh, frame.objects[b].mesh);
        let (out_a, out_b) = (&result.positions[a], &result.positions[b]);
        let closed_a = cache.trees(a, mesh_a, out_a).is_some();
        let closed_b = cache.trees(b, mesh_b, out_b).is_some();
        let (before, after) = match (closed_a, closed_b, &cache.objects[a], &cache.objects[b]) {
            (true, true, Some(ta), Some(tb)) => (
                Some(deepest(&mesh_a.positions, &ta.input, &mesh_b.positions, &tb.input)),
                Some(deepest(out_a, &ta.output, out_b, &tb.output)),
            ),
            _ => (None, None),
        };
        let (faces_before, faces_after) = match (&cache.objects[a], &cache.objects[b]) {
            (Some(ta), Some(tb)) => {
                (intersecting_faces(&ta.input, &tb.input), intersecting_faces(&ta.output, &tb.output))
            }
            _ => ([0, 0], [0, 0]),
        };
        pairs.push(PairQuality {
            objects: pair_stats.objects.clone(),
            in_contact: pair_stats.in_contact,
            contact_area: pair_stats.contact_area,
            penetration_before: before,
            penetration_after: after,
            penetration_ratio: match (before, after) {
                (Some(b), Some(a)) if b > 0.0 => Some(a / b),
                _ => None,
            },
            intersecting_faces_before: faces_before,
            intersecting_faces_after: faces_after,
        });
    }
    let objects = stats
        .objects
        .iter()
        .zip(&area)
        .map(|(o, &contact_area)| ObjectQuality {
            name: o.name.clone(),
            deformed: o.deformed,
            relative_volume_change: o.relative_volume_change,
            contact_area,
            max_deformation: o.max_displacement,
            output_step: None,
            input_step: None,
            step_ratio: None,
        })
        .collect();
    (objects, pairs)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report
mod tests {
    use super::*;

    #[test]
    fn step_ratio_is_undefined_for_a_still_input() {
        let mut o = ObjectQuality {
            name: "a".into(),
            deformed: true,
            relative_volume_change: 0.0,
            contact_area: 0.0,
            max_deformation: 0.0,
            output_step: None,
            input_step: None,
            step_ratio: None,
        };
        o.set_steps(0.2, 0.1);
        assert_eq!(o.step_ratio, Some(2.0));
        o.set_steps(0.2, 0.0);
        assert_eq!(o.step_ratio, None);
    }

    #[test]
    fn penetrations_match_the_direct_measure_with_reused_trees() {
        use squish::mesh::shapes;
        let mut cache = MeasureCache::default();
        let a = shapes::icosphere(1.0, 2);
        let mut b = a.clone();
        for depth in [0.3, 0.5, -0.1] {
            b.positions = a.positions.iter().map(|p| *p + DVec3::new(0.0, 0.0, 2.0 - depth)).collect();
            let direct = deepest_penetration(&a, &b).unwrap();
            let ta = cache.trees(0, &a, &a.positions).map(|t| t.input.clone()).unwrap();
            let tb = cache.trees(1, &b, &b.positions).map(|t| t.input.clone()).unwrap();
            let cached = deepest(&a.positions, &ta, &b.positions, &tb);
            assert_eq!(cached, direct, "depth {depth}");
        }
        // An open mesh has no inside.
        let mut open = a.clone();
        open.triangles.pop();
        assert!(cache.trees(2, &open, &open.positions).is_none());
    }
}
