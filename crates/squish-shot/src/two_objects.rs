//! One frame of two meshes, as `squish deform` and `squish contact` compute it and as the Python
//! module's `squish.deform` and `squish.contact` do: the deformation with the figures of
//! `report.json`, and the contact definition alone (thesis ch. 4) with the figures of
//! `contact.json`, per-vertex labels and the regions' exact boundary points.

use serde::Serialize;
use squish::contact::{BoundaryKind, ContactSide, PairContact, contact_pair, debug_export};
use squish::mesh::{Topology, vertex_normals};
use squish::pipeline::{Deformer, Frame, FrameObject, FramePair, FrameResult};
use squish::spatial::TriangleBvh;
use squish::stage::PerStage;
use squish::{ObjectParams, PairParams, TriMesh};

use crate::error::ShotError;
use crate::report::FrameReport;

/// The parameters of a frame of two objects `a` and `b` and their pair.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PairParameters {
    pub a: ObjectParams,
    pub b: ObjectParams,
    pub pair: PairParams,
}

/// The figures of a two-object deformation: what `report.json` of `squish deform` holds besides
/// the file names.
#[derive(Clone, Debug, Serialize)]
pub struct DeformFigures {
    pub parameters: PairParameters,
    /// Deepest vertex of either mesh inside the other, before and after (closed meshes only).
    pub penetration_before: Option<f64>,
    pub penetration_after: Option<f64>,
    pub frame: FrameReport,
}

/// Deforms mesh `a` against mesh `b` (one frame, one pair; `names` in messages and figures)
/// with `settings` (validated), as `squish deform` does: the result and its figures.
pub fn deform_pair(
    names: [&str; 2],
    meshes: [&TriMesh; 2],
    settings: &PairParameters,
    deformer: &mut Deformer,
) -> Result<(FrameResult, DeformFigures), ShotError> {
    let frame = Frame {
        objects: vec![
            FrameObject { name: names[0], mesh: meshes[0], params: &settings.a },
            FrameObject { name: names[1], mesh: meshes[1], params: &settings.b },
        ],
        pairs: vec![FramePair { objects: [0, 1], params: settings.pair }],
    };
    let result = deformer.deform(&frame).map_err(|e| ShotError::Pipeline(Box::new(e)))?;
    let quality = result.stats.quality.first();
    let penetration_before = quality.and_then(|q| q.penetration_before);
    let penetration_after = quality.and_then(|q| q.penetration_after);
    let figures = DeformFigures {
        parameters: settings.clone(),
        penetration_before,
        penetration_after,
        frame: FrameReport::from(&result.stats),
    };
    Ok((result, figures))
}

/// The contact figures of one side.
#[derive(Clone, Debug, Serialize)]
pub struct SideSummary {
    pub name: String,
    /// The PLY file with the labels (`squish contact`); none for meshes given in memory.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub labelled_mesh: Option<String>,
    pub intersection_vertices: usize,
    pub intersection_boundary_points: usize,
    pub intersection_area: f64,
    pub mapping_vertices: usize,
    pub mapping_boundary_points: usize,
    pub mapping_area: f64,
    pub contact_vertices: usize,
    pub contact_boundary_points: usize,
    pub contact_area_on_mesh: f64,
    pub contact_area_on_surface: f64,
    pub relative_stiffness: f64,
}

/// The contact definition's figures: what `contact.json` of `squish contact` holds besides the
/// file names.
#[derive(Clone, Debug, Serialize)]
pub struct ContactFigures {
    pub mapping_direction: [f64; 3],
    pub direction_automatic: bool,
    /// ε_c = m_S + τσ_S (Eq. 4.3).
    pub threshold: f64,
    pub mean_depth: f64,
    pub depth_std_dev: f64,
    pub contact_tau: f64,
    pub contact_area_on_surface: f64,
    pub intersection_points: Vec<[f64; 3]>,
    pub sides: [SideSummary; 2],
    pub timings_ms: Timings,
    pub numerical_fallbacks: usize,
    pub warnings: Vec<squish::pipeline::FrameWarning>,
}

/// The contact stage's times in ms, per stage (its own: intersection, mapping, contact zone), and
/// the whole call.
#[derive(Clone, Debug, Serialize)]
pub struct Timings {
    #[serde(flatten)]
    pub stages: PerStage<f64>,
    pub total: f64,
}

/// The contact definition of two meshes (thesis ch. 4) as `squish contact` computes it.
pub struct ContactDefinition {
    pub result: PairContact,
    /// Per mesh and vertex (processed numbering): 0 outside, 1 intersection, 2 mapping region,
    /// 3 contact zone.
    pub labels: [Vec<u8>; 2],
    /// The exact boundary points of the three regions: position, kind (1 intersection, 2
    /// mapping, 3 contact) and side (0 or 1).
    pub boundary_points: Vec<([f64; 3], i32, i32)>,
    pub figures: ContactFigures,
}

/// Computes the contact definition of `meshes` (named `names` in messages) with `settings`
/// (validated); `labelled_meshes` are the files the labels are written to, if any (for the
/// figures).
pub fn define_contact<'a>(
    names: [&str; 2],
    meshes: [&TriMesh; 2],
    settings: &'a PairParameters,
    labelled_meshes: [Option<String>; 2],
) -> Result<ContactDefinition, ShotError> {
    let mut prepared = Vec::new();
    for (mesh, name) in meshes.iter().zip(names) {
        let mesh_error =
            |e: &dyn std::fmt::Display| ShotError::Mesh { object: name.to_string(), message: e.to_string() };
        let topology = mesh.check_for_deformation().map_err(|e| mesh_error(&e))?;
        let bvh = TriangleBvh::new(mesh).map_err(|e| mesh_error(&e))?;
        prepared.push((topology, vertex_normals(mesh), bvh));
    }
    let side = |i: usize, params: &'a squish::ObjectParams| {
        let (topology, normals, bvh): &(Topology, _, TriangleBvh) = &prepared[i];
        ContactSide::new(meshes[i], topology, normals, bvh)
            .with_name(names[i])
            .with_stiffness(squish::contact::Stiffness::of(params))
            .with_uvs(params.uvs.as_ref())
    };
    let result =
        contact_pair(&side(0, &settings.a), &side(1, &settings.b), &settings.pair).map_err(ShotError::Contact)?;
    let debug = debug_export(&result, meshes);
    let [labelled_a, labelled_b] = labelled_meshes;
    let sides = [
        side_summary(&result, 0, names[0], labelled_a, meshes[0], &prepared[0].0),
        side_summary(&result, 1, names[1], labelled_b, meshes[1], &prepared[1].0),
    ];
    let mut boundary_points = Vec::new();
    for (l, data) in debug.iter().enumerate() {
        for p in &data.points {
            let kind = match p.kind {
                BoundaryKind::Intersection => 1,
                BoundaryKind::Mapping => 2,
                BoundaryKind::Contact => 3,
            };
            boundary_points.push((p.position.to_array(), kind, l as i32));
        }
    }
    // No edge crosses: one closed mesh may lie inside the other.
    let contained = if result.intersection_points.is_empty() {
        let inside = |i: usize| {
            let other = &prepared[1 - i];
            other.0.is_closed()
                && meshes[i].triangles.first().is_some_and(|t| other.2.contains(meshes[i].positions[t[0] as usize]))
        };
        if inside(0) {
            Some([0, 1])
        } else if inside(1) {
            Some([1, 0])
        } else {
            None
        }
    } else {
        None
    };
    let warnings =
        squish::pipeline::pair_warnings(&names.map(String::from), 0, Some(&result), &settings.pair, contained);
    let figures = ContactFigures {
        mapping_direction: result.direction.to_array(),
        direction_automatic: matches!(result.direction_source, squish::contact::DirectionSource::Automatic),
        threshold: result.criterion.threshold,
        mean_depth: result.criterion.mean,
        depth_std_dev: result.criterion.std_dev,
        contact_tau: settings.pair.contact_tau,
        contact_area_on_surface: result.contact_area,
        intersection_points: result.intersection_points.iter().map(|p| p.position.to_array()).collect(),
        sides,
        timings_ms: Timings { stages: result.stats.timings.millis(), total: result.stats.time.as_secs_f64() * 1e3 },
        numerical_fallbacks: result.stats.fallbacks.numerical(),
        warnings,
    };
    let [labels_a, labels_b] = debug.map(|d| d.labels);
    Ok(ContactDefinition { result, labels: [labels_a, labels_b], boundary_points, figures })
}

fn side_summary(
    result: &PairContact,
    l: usize,
    name: &str,
    labelled_mesh: Option<String>,
    mesh: &TriMesh,
    topology: &Topology,
) -> SideSummary {
    let side = &result.sides[l];
    SideSummary {
        name: name.to_string(),
        labelled_mesh,
        intersection_vertices: side.intersection.num_inside(),
        intersection_boundary_points: side.intersection.points().len(),
        intersection_area: side.intersection.area(mesh, topology),
        mapping_vertices: side.mapping.region.num_inside(),
        mapping_boundary_points: side.mapping.region.points().len(),
        mapping_area: side.mapping.region.area(mesh, topology),
        contact_vertices: side.zone.region.num_inside(),
        contact_boundary_points: side.zone.region.points().len(),
        contact_area_on_mesh: side.zone_area_on_mesh,
        contact_area_on_surface: side.zone_area_on_surface,
        relative_stiffness: side.relative_stiffness,
    }
}
