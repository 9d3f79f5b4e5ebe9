//! `squish contact A B -o DIR`: the contact definition of thesis chapter 4 alone, exported for
//! inspection: each mesh as a PLY with per-vertex labels and colours (outside / intersection /
//! mapping / contact), the exact boundary points as a point cloud and a JSON summary.

use std::path::PathBuf;

use clap::Args;
use serde::Serialize;
use squish_io::{PlyWriteOptions, VertexProperty, write_ply_with, write_point_cloud_ply};
use squish_render::{Label, rgba8};
use squish_shot::files::{create_dir, write_text};
use squish_shot::shot::PreviewFrame;
use squish_shot::two_objects::{ContactFigures, define_contact};

use crate::console::{print_warnings, say};
use crate::error::CliError;
use crate::input::{
    InputMesh, StagedOutputs, WeldChoice, display_names, note_undecodable_names, output_path, output_stems,
};
use crate::params::pair_settings;
use crate::preview::{ColorMode, PictureArgs, SceneDefaults, write_frame_preview};

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
    /// Weld duplicate vertices before processing (outputs keep the file's vertices): auto (glTF
    /// files), always (`--weld` alone) or never.
    #[arg(long, value_enum, num_args = 0..=1, default_missing_value = "always", default_value_t = WeldChoice::Auto)]
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

#[derive(Serialize)]
struct Summary {
    inputs: [String; 2],
    #[serde(flatten)]
    figures: ContactFigures,
    boundary_points: String,
}

const LABELS: [Label; 4] = [Label::Outside, Label::Intersection, Label::Mapping, Label::Contact];

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
        &settings.parameters(),
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
