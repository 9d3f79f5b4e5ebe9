//! A scene file as a shot: each frame of the scene ([`Scene::evaluate`]) mapped to the library's
//! frame ([`library_frame`]), and each object's file numbering, so that results are written
//! with the vertices of the input file — same count, same order — even when the scene layer
//! welded them (glTF seams, `weld = true`).

use std::path::PathBuf;

use glam::DVec3;
use squish::contact::{ContactMethod, PairParams};
use squish::deform::{ProfileShape, Wrinkles};
use squish::pipeline::{FramePair, WorkingRegion};
use squish::{ObjectParams, TriMesh};
use squish_io::scene::{
    ContactMethodFrame, FramePattern, MeshSource, ObjectFrame, PairFrame, PreserveVolume, RegionFrame, Weld,
};
use squish_io::{FrameSpec, GltfReadOptions, Scene, WeldMode, read_gltf, read_mesh, weld_positions};

use crate::error::CliError;
use crate::shot::{ShotFrame, ShotObject, ShotSource};

/// The library's parameters for an object at a frame.
pub fn object_params(object: &ObjectFrame) -> ObjectParams {
    let defaults = ObjectParams::default();
    ObjectParams {
        rigid: object.rigid,
        stiffness: object.stiffness,
        extent: object.extent,
        bulge: object.bulge,
        bulge_height: object.bulge_height,
        preserve_volume: match object.preserve_volume {
            PreserveVolume::Auto => None,
            PreserveVolume::On => Some(true),
            PreserveVolume::Off => Some(false),
        },
        profile: ProfileShape { x2: object.profile.v2, x3: object.profile.v3, x4: object.profile.v4 },
        wrinkles: Wrinkles { amplitude: object.profile.wrinkle_amplitude, frequency: object.profile.wrinkle_frequency },
        anisotropy: object.anisotropy.is_some(),
        anisotropy_exponent: object.anisotropy.map_or(defaults.anisotropy_exponent, |a| a.exponent),
        anisotropy_offset: object.anisotropy.map_or(defaults.anisotropy_offset, |a| a.offset),
        bulge_map: object.bulge_map.as_deref().map(<[f64]>::to_vec),
        self_contact: object.self_contact.iter().map(|a| a.to_articulation()).collect(),
        rest_positions: object.rest_positions.as_deref().map(<[DVec3]>::to_vec),
        ..defaults
    }
}

/// The library's parameters for a pair at a frame.
pub fn pair_params(pair: &PairFrame) -> PairParams {
    let contact_method = match pair.contact_method {
        ContactMethodFrame::Geometric => ContactMethod::Geometric,
        ContactMethodFrame::Ball { radius } => ContactMethod::Ball { radius },
    };
    PairParams { contact_tau: pair.contact_tau, direction: pair.direction, contact_method, ..PairParams::default() }
}

/// The library's working region of an object at a frame.
fn working_region(region: &RegionFrame) -> WorkingRegion {
    match region {
        RegionFrame::Whole => WorkingRegion::Whole,
        RegionFrame::Mask(mask) => WorkingRegion::Mask(mask.to_vec()),
        RegionFrame::Distance(distance) => WorkingRegion::Distance(*distance),
    }
}

/// A scene frame as the library's frame: every object, and the pairs enabled at this frame.
///
/// The only place where scene values become library values; the library checks them (and its
/// errors name the object or pair).
pub fn library_frame(spec: FrameSpec) -> ShotFrame {
    let pairs = spec
        .pairs
        .iter()
        .filter(|p| p.enabled)
        .map(|pair| FramePair { objects: pair.objects, params: pair_params(pair) })
        .collect();
    let objects = spec
        .objects
        .into_iter()
        .map(|o| {
            let params = ObjectParams { region: working_region(&o.region), ..object_params(&o) };
            ShotObject { name: o.name, mesh: o.mesh, params }
        })
        .collect();
    ShotFrame { objects, pairs }
}

/// A loaded scene as a [`ShotSource`].
pub struct SceneShot<'a> {
    pub scene: &'a Scene,
}

impl ShotSource for SceneShot<'_> {
    fn frame(&self, frame: i64) -> Result<ShotFrame, CliError> {
        let spec = self.scene.evaluate(frame as f64)?;
        Ok(library_frame(spec))
    }
}

/// How an object's processed vertices relate to its file's.
#[derive(Clone, Debug)]
pub struct FileNumbering {
    /// The file's triangles, in file numbering.
    pub triangles: Vec<[u32; 3]>,
    /// For each file vertex, its processed vertex (`None`: the same numbering).
    pub vertex_map: Option<Vec<u32>>,
    /// Why the file numbering could not be rebuilt, if it could not (the results are then
    /// written with the processed, welded vertices).
    pub note: Option<String>,
}

impl FileNumbering {
    /// Number of vertices written.
    pub fn vertex_count(&self, processed: usize) -> usize {
        self.vertex_map.as_ref().map_or(processed, Vec::len)
    }

    /// Processed positions expanded to the file's vertices.
    pub fn positions(&self, positions: &[DVec3]) -> Vec<DVec3> {
        match &self.vertex_map {
            Some(map) => map.iter().map(|&v| positions[v as usize]).collect(),
            None => positions.to_vec(),
        }
    }

    /// The mesh to write.
    pub fn file_mesh(&self, positions: &[DVec3]) -> TriMesh {
        TriMesh { positions: self.positions(positions), triangles: self.triangles.clone() }
    }
}

/// The file numbering of every object of `scene`, given the objects at one frame (`reference`).
///
/// The scene layer welds some sources (glTF by default, OBJ/PLY with `weld = …`) and keeps no
/// public trace of the file's vertices, so this re-reads the source once and welds it the same
/// way (welding is deterministic), then checks the result against the scene's own mesh. When the
/// check fails, results keep the scene's vertices and the note says so.
pub fn file_numbering(scene: &Scene, reference: &ShotFrame) -> Vec<FileNumbering> {
    let description = scene.description();
    description
        .objects
        .iter()
        .zip(&reference.objects)
        .map(|(spec, object)| {
            let same = |note: Option<String>| FileNumbering {
                triangles: object.mesh.triangles.clone(),
                vertex_map: None,
                note,
            };
            if spec.mesh.weld() == Weld::Off {
                return same(None);
            }
            let file = match source_file_mesh(&spec.mesh, scene) {
                Ok(mesh) => mesh,
                Err(why) => return same(Some(why)),
            };
            let welded = weld_positions(&file.positions, &file.triangles, spec.mesh.weld().mode());
            if welded.triangles != object.mesh.triangles || welded.positions.len() != object.mesh.num_vertices() {
                return same(Some(format!(
                    "the welded file mesh ({} vertices) does not match the scene's ({} vertices)",
                    welded.positions.len(),
                    object.mesh.num_vertices()
                )));
            }
            FileNumbering { triangles: file.triangles, vertex_map: Some(welded.vertex_map), note: None }
        })
        .map(|mut n| {
            if let Some(note) = &mut n.note {
                *note = format!("{note}; results are written with the welded vertices");
            }
            n
        })
        .collect()
}

/// The unwelded mesh of a source, as in its file (the rest pose for glTF: only the numbering
/// and triangles are used).
fn source_file_mesh(source: &MeshSource, scene: &Scene) -> Result<TriMesh, String> {
    match source {
        MeshSource::File { file, .. } => read_mesh(file).map_err(|e| e.to_string()),
        MeshSource::Sequence { pattern, .. } => {
            // The scene welds every frame like the first file of its range that exists.
            let text = pattern.to_str().ok_or("the sequence path is not UTF-8")?;
            let pattern = FramePattern::parse(text)?;
            let reference: Option<PathBuf> = scene.frames().map(|f| pattern.path(f)).find(|p| p.is_file());
            let path = reference.ok_or("no file of the sequence exists")?;
            read_mesh(&path).map_err(|e| e.to_string())
        }
        MeshSource::Gltf(g) => {
            let file = read_gltf(&g.file, &GltfReadOptions { weld: WeldMode::Off }).map_err(|e| e.to_string())?;
            let instances = file.instances();
            let node = match &g.node {
                Some(name) => instances.iter().find(|i| file.nodes[i.node].name == *name),
                None => instances.first().filter(|_| instances.len() == 1),
            }
            .ok_or("cannot find the node's mesh")?;
            let mesh = file.meshes.get(node.mesh).ok_or("cannot find the node's mesh")?;
            Ok(TriMesh { positions: mesh.positions.clone(), triangles: mesh.triangles.clone() })
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report
mod tests {
    use super::*;
    use squish_io::scene::{AnisotropyValues, ProfileValues};
    use std::sync::Arc;

    fn object() -> ObjectFrame {
        ObjectFrame {
            name: "ball".into(),
            mesh: squish::mesh::shapes::icosphere(1.0, 0),
            rigid: false,
            stiffness: 2.0,
            extent: Some(0.4),
            bulge: 1.5,
            bulge_height: 0.1,
            preserve_volume: PreserveVolume::Off,
            profile: ProfileValues { v2: 0.3, v3: 0.8, v4: 0.9, wrinkle_amplitude: 0.01, wrinkle_frequency: 3.0 },
            anisotropy: Some(AnisotropyValues { exponent: 3.0, offset: 0.2 }),
            bulge_map: Some(Arc::from(vec![0.5; 12])),
            region: RegionFrame::Whole,
            self_contact: Vec::new(),
            rest_positions: None,
        }
    }

    #[test]
    fn every_object_value_reaches_the_library() {
        let p = object_params(&object());
        assert!(!p.rigid);
        assert_eq!((p.stiffness, p.extent, p.bulge, p.bulge_height), (2.0, Some(0.4), 1.5, 0.1));
        assert_eq!(p.preserve_volume, Some(false));
        assert_eq!((p.profile.x2, p.profile.x3, p.profile.x4), (0.3, 0.8, 0.9));
        assert_eq!((p.wrinkles.amplitude, p.wrinkles.frequency), (0.01, 3.0));
        assert!(p.anisotropy);
        assert_eq!((p.anisotropy_exponent, p.anisotropy_offset), (3.0, 0.2));
        assert_eq!(p.bulge_map.as_deref(), Some(&[0.5; 12][..]));
    }

    #[test]
    fn articulations_and_the_rest_pose_reach_the_library() {
        use squish::skinning::{ArticulationDirection, ArticulationParams};
        use squish_io::scene::ArticulationFrame;
        let mut o = object();
        let params = ArticulationParams { contact_tau: 0.5, stiffness: [2.0, 0.5], ..ArticulationParams::default() };
        let direction = ArticulationDirection::Joints([DVec3::NEG_X, DVec3::ZERO, DVec3::Y]);
        o.self_contact = vec![ArticulationFrame {
            name: "elbow".into(),
            regions: Arc::new([vec![0, 1, 2], vec![2, 3]]),
            direction,
            params: params.clone(),
        }];
        o.rest_positions = Some(Arc::from(o.mesh.positions.clone()));
        let p = object_params(&o);
        let [a] = p.self_contact.as_slice() else { panic!("one articulation") };
        assert_eq!(a.name, "elbow");
        assert_eq!(a.regions, [vec![0, 1, 2], vec![2, 3]]);
        assert_eq!(a.direction, direction);
        assert_eq!(a.params, params);
        assert_eq!(p.rest_positions.as_deref(), Some(o.mesh.positions.as_slice()));
        assert!(object_params(&object()).self_contact.is_empty());
    }

    #[test]
    fn regions_and_contact_methods_reach_the_library() {
        let mut masked = object();
        masked.region = RegionFrame::Mask(vec![true; 12].into());
        let mut near = object();
        near.region = RegionFrame::Distance(0.5);
        let pair = PairFrame {
            objects: [0, 1],
            names: ["ball".into(), "ground".into()],
            enabled: true,
            contact_tau: 0.5,
            direction: Some(DVec3::Z),
            contact_method: ContactMethodFrame::Ball { radius: 0.3 },
        };
        let geometric = PairFrame { contact_method: ContactMethodFrame::Geometric, ..pair.clone() };
        let disabled = PairFrame { enabled: false, ..pair.clone() };
        let spec = FrameSpec { frame: 7.0, objects: vec![masked, near], pairs: vec![pair, geometric, disabled] };
        let frame = library_frame(spec);
        assert_eq!(frame.objects[0].params.region, WorkingRegion::Mask(vec![true; 12]));
        assert_eq!(frame.objects[1].params.region, WorkingRegion::Distance(0.5));
        // Disabled pairs are left out.
        assert_eq!(frame.pairs.len(), 2);
        assert_eq!(frame.pairs[0].params.contact_method, ContactMethod::Ball { radius: 0.3 });
        assert_eq!(frame.pairs[1].params.contact_method, ContactMethod::Geometric);
        assert_eq!(frame.pairs[1].params.contact_tau, 0.5);
        assert_eq!(frame.pairs[1].params.direction, Some(DVec3::Z));
    }
}
