//! `squish contact A B -o DIR`: the contact definition of thesis chapter 4 alone, exported for
//! inspection: each mesh as a PLY with per-vertex labels and colours (outside / intersection /
//! mapping / contact), the exact boundary points as a point cloud and a JSON summary.

use std::path::PathBuf;

use clap::Args;
use serde::Serialize;
use squish::contact::{BoundaryKind, ContactSide, PairContact, contact_pair, debug_export};
use squish::mesh::{Topology, vertex_normals};
use squish::spatial::TriangleBvh;
use squish::stage::PerStage;
use squish_io::{PlyWriteOptions, VertexProperty, write_ply_with, write_point_cloud_ply};
use squish_render::{Label, rgba8};

use crate::console::{print_warnings, say};
use crate::error::CliError;
use crate::input::{
    InputMesh, StagedOutputs, WeldChoice, create_dir, display_names, note_undecodable_names, output_path, output_stems,
    write_text,
};
use crate::params::{PairSettings, contact_error, pair_settings};
use crate::preview::{ColorMode, PictureArgs, SceneDefaults, write_frame_preview};
use crate::shot::PreviewFrame;

#[derive(Args, Debug)]
pub struct ContactArgs {
    /// The first mesh (its points are pushed along the mapping direction d̂).
    pub a: PathBuf,
    /// The second mesh (d̂ is oriented along its normals).
    pub b: PathBuf,
    /// Output directory.
    #[arg(short, long, default_value = "squish-contact")]
    pub output: PathBuf,
    /// Parameters file (TOML with tables [a], [b], [pair]).
    #[arg(long)]
    pub params: Option<PathBuf>,
    /// Set one parameter, e.g. --set b.rigid=true --set pair.contact_tau=0.5.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// Weld duplicate vertices before processing (outputs keep the file's vertices).
    #[arg(long, value_enum, default_value_t = WeldChoice::Auto)]
    pub weld: WeldChoice,
    /// Write DIR/preview.png: the overlaps (input) and the contact zones, whole and cut.
    #[arg(long)]
    pub preview: bool,
    #[command(flatten)]
    pub pictures: PictureArgs,
    /// Exit with 1 (after writing the outputs) when there is a warning: a contact zone left
    /// empty while the meshes intersect, a mesh inside the other, a reduced parameter.
    #[arg(long)]
    pub strict: bool,
}

/// The contact figures of one side.
#[derive(Clone, Debug, Serialize)]
pub struct SideSummary {
    name: String,
    /// The PLY file with the labels (`squish contact`); none for meshes given in memory.
    #[serde(skip_serializing_if = "Option::is_none")]
    labelled_mesh: Option<String>,
    intersection_vertices: usize,
    intersection_boundary_points: usize,
    intersection_area: f64,
    mapping_vertices: usize,
    mapping_boundary_points: usize,
    mapping_area: f64,
    contact_vertices: usize,
    contact_boundary_points: usize,
    contact_area_on_mesh: f64,
    contact_area_on_surface: f64,
    relative_stiffness: f64,
}

#[derive(Serialize)]
struct Summary {
    inputs: [String; 2],
    #[serde(flatten)]
    figures: ContactFigures,
    boundary_points: String,
}

/// The contact definition's figures: what `contact.json` of `squish contact` holds besides the
/// file names.
#[derive(Clone, Debug, Serialize)]
pub struct ContactFigures {
    mapping_direction: [f64; 3],
    direction_automatic: bool,
    /// ε_c = m_S + τσ_S (Eq. 4.3).
    threshold: f64,
    mean_depth: f64,
    depth_std_dev: f64,
    contact_tau: f64,
    contact_area_on_surface: f64,
    intersection_points: Vec<[f64; 3]>,
    sides: [SideSummary; 2],
    timings_ms: Timings,
    numerical_fallbacks: usize,
    pub warnings: Vec<squish::pipeline::FrameWarning>,
}

/// The contact stage's times in ms, per stage (its own: intersection, mapping, contact zone), and
/// the whole call.
#[derive(Clone, Debug, Serialize)]
struct Timings {
    #[serde(flatten)]
    stages: PerStage<f64>,
    total: f64,
}

const LABELS: [Label; 4] = [Label::Outside, Label::Intersection, Label::Mapping, Label::Contact];

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
    meshes: [&squish::TriMesh; 2],
    settings: &'a PairSettings,
    labelled_meshes: [Option<String>; 2],
) -> Result<ContactDefinition, CliError> {
    let mut prepared = Vec::new();
    for (mesh, name) in meshes.iter().zip(names) {
        let topology = mesh.check_for_deformation().map_err(|e| CliError::input(format!("{name}: {e}")))?;
        let bvh = TriangleBvh::new(mesh).map_err(|e| CliError::input(format!("{name}: {e}")))?;
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
        contact_pair(&side(0, &settings.a), &side(1, &settings.b), &settings.pair).map_err(|e| contact_error(&e))?;
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

pub fn run(args: &ContactArgs) -> Result<(), CliError> {
    let mut settings = pair_settings(args.params.as_deref(), &args.sets)?;
    let inputs = [InputMesh::read(&args.a, args.weld)?, InputMesh::read(&args.b, args.weld)?];
    settings.complete(&inputs)?;
    let files = output_stems(&inputs[0], &inputs[1]);
    let stems = display_names(&files);
    note_undecodable_names(&files);
    let labelled = [0, 1].map(|l| output_path(&args.output, &files[l], "ply"));
    let contact = define_contact(
        [&stems[0], &stems[1]],
        [&inputs[0].mesh, &inputs[1].mesh],
        &settings,
        labelled.clone().map(|p| Some(p.display().to_string())),
    )?;
    create_dir(&args.output)?;
    // As `squish deform`: everything is written to a staging folder and moved into place at the
    // end, so a failure leaves none of this run's files.
    let staged = StagedOutputs::new(&args.output)?;
    for (l, input) in inputs.iter().enumerate() {
        let labels = input.to_file_values(&contact.labels[l]);
        let colors: Vec<[u8; 3]> = labels
            .iter()
            .map(|&k| {
                let c = rgba8(LABELS[usize::from(k).min(3)].color());
                [c[0], c[1], c[2]]
            })
            .collect();
        let mut properties = VertexProperty::rgb(&colors);
        properties.push(VertexProperty::int("label", &labels.iter().map(|&k| i32::from(k)).collect::<Vec<_>>()));
        write_ply_with(
            &staged.path(&labelled[l]),
            &input.file.positions,
            Some(&input.file.triangles),
            &properties,
            &PlyWriteOptions::default(),
        )?;
    }

    let points: Vec<glam::DVec3> = contact.boundary_points.iter().map(|p| glam::DVec3::from_array(p.0)).collect();
    let kinds: Vec<i32> = contact.boundary_points.iter().map(|p| p.1).collect();
    let sides: Vec<i32> = contact.boundary_points.iter().map(|p| p.2).collect();
    let colors: Vec<[u8; 3]> = kinds
        .iter()
        .map(|&k: &i32| {
            let c = rgba8(LABELS[k as usize].color());
            [c[0], c[1], c[2]]
        })
        .collect();
    let mut properties = VertexProperty::rgb(&colors);
    properties.push(VertexProperty::int("kind", &kinds));
    properties.push(VertexProperty::int("side", &sides));
    let points_path = args.output.join("boundary_points.ply");
    write_point_cloud_ply(&staged.path(&points_path), &points, &properties, &PlyWriteOptions::default())?;

    let summary = Summary {
        inputs: [args.a.display().to_string(), args.b.display().to_string()],
        figures: contact.figures,
        boundary_points: points_path.display().to_string(),
    };
    let json_path = args.output.join("contact.json");
    write_text(&staged.path(&json_path), &serde_json::to_string_pretty(&summary)?)?;
    let result = &contact.result;
    let picture = if args.preview {
        // No deformation: both sides show the input, the output side with its contact zones.
        let meshes: Vec<squish::TriMesh> = inputs.iter().map(|i| i.mesh.clone()).collect();
        let flags = |at_least: u8| -> Vec<Vec<bool>> {
            contact.labels.iter().map(|labels| labels.iter().map(|&k| k >= at_least).collect()).collect()
        };
        let zones: Vec<Vec<bool>> = contact.labels.iter().map(|l| l.iter().map(|&k| k == 3).collect()).collect();
        let frame = PreviewFrame {
            inputs: meshes.clone(),
            outputs: meshes,
            contact: zones.into_iter().map(Some).collect(),
            deformable: vec![None, None],
            u: vec![None, None],
            intersection: flags(1),
            self_intersection_left: Vec::new(),
        };
        let any_gltf =
            inputs.iter().any(|i| matches!(i.format, squish_io::MeshFormat::Gltf | squish_io::MeshFormat::Glb));
        let settings = args.pictures.settings(ColorMode::Contact, &SceneDefaults::default(), any_gltf);
        let picture = args.output.join("preview.png");
        write_frame_preview(&staged.path(&picture), &frame, &settings)?;
        Some(picture)
    } else {
        None
    };
    staged.commit()?;
    if result.is_empty() && !result.intersection_points.is_empty() {
        say!("the meshes intersect but have no contact zone");
    } else if result.is_empty() {
        say!("the meshes do not intersect (no contact zone)");
    } else {
        let d = result.direction;
        say!(
            "d̂ = [{:.4}, {:.4}, {:.4}], ε_c = {:.4e} (m = {:.4e}, σ = {:.4e}), contact area on S {:.4e}",
            d.x,
            d.y,
            d.z,
            result.criterion.threshold,
            result.criterion.mean,
            result.criterion.std_dev,
            result.contact_area
        );
        for s in &summary.figures.sides {
            say!(
                "{}: intersection {} vertices, mapping {}, contact {} → {}",
                s.name,
                s.intersection_vertices,
                s.mapping_vertices,
                s.contact_vertices,
                s.labelled_mesh.as_deref().unwrap_or_default()
            );
        }
    }
    say!("boundary points: {} ({} points)", points_path.display(), points.len());
    say!("summary: {}", json_path.display());
    if let Some(picture) = picture {
        say!("preview: {}", picture.display());
    }
    let count = print_warnings(None, &summary.figures.warnings);
    if args.strict && count > 0 {
        return Err(CliError::strict(count));
    }
    Ok(())
}

fn side_summary(
    result: &PairContact,
    l: usize,
    name: &str,
    labelled_mesh: Option<String>,
    mesh: &squish::TriMesh,
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
