//! `squish deform A B -o DIR`: one frame of the deformer on two meshes from files.

use std::path::PathBuf;

use clap::Args;
use serde::Serialize;
use squish::pipeline::{Deformer, FramePair, OwnedFrame, OwnedObject};
use squish_io::MeshFormat;
use squish_shot::files::{create_dir, write_text};
use squish_shot::shot::PreviewFrame;
use squish_shot::two_objects::{DeformFigures, deform_pair};

use crate::console::{print_warnings, say};
use crate::error::CliError;
use crate::input::{
    FormatChoice, InputMesh, StagedOutputs, WeldChoice, display_names, note_undecodable_names, output_path,
    output_stems,
};
use crate::params::{PairSettings, pair_settings};
use crate::preview::{ColorMode, PictureArgs, SceneDefaults, write_frame_preview};

#[derive(Args, Debug)]
pub struct DeformArgs {
    /// The first mesh (its points are pushed along the mapping direction d̂).
    pub a: PathBuf,
    /// The second mesh (d̂ is oriented along its normals).
    pub b: PathBuf,
    /// Output directory: DIR/<stem of A>.<ext>, DIR/<stem of B>.<ext>, DIR/report.json. Written
    /// in the input's format, each output is a copy of its input with the deformed positions and
    /// normals (UVs, materials, skins, extra properties kept).
    #[arg(short, long, default_value = "squish-out")]
    pub output: PathBuf,
    /// Parameters file (TOML with tables [a], [b], [pair]).
    #[arg(long)]
    pub params: Option<PathBuf>,
    /// Set one parameter, e.g. --set a.extent=0.4 --set b.rigid=true --set pair.contact_tau=0.5.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// Output format (default: the format of each input).
    #[arg(long, value_enum)]
    pub format: Option<FormatChoice>,
    /// Weld duplicate vertices before processing (outputs keep the file's vertices): auto (glTF
    /// files), always (`--weld` alone) or never.
    #[arg(long, value_enum, num_args = 0..=1, default_missing_value = "always", default_value_t = WeldChoice::Auto)]
    pub weld: WeldChoice,
    /// Write DIR/preview.png: input | output, whole and cut through the contact.
    #[arg(long)]
    pub preview: bool,
    /// Colouring of the output in the picture.
    #[arg(long, value_enum, default_value_t = ColorMode::Deformable)]
    pub color: ColorMode,
    #[command(flatten)]
    pub pictures: PictureArgs,
    /// Exit with 1 (after writing the outputs) when there is a warning: a contact zone left
    /// empty, a mesh inside the other, a reduced parameter, an open mesh without bulge, or a
    /// penetration deeper than 10% of the input's left.
    #[arg(long)]
    pub strict: bool,
}

#[derive(Serialize)]
struct DeformReport {
    inputs: [String; 2],
    outputs: [String; 2],
    #[serde(flatten)]
    figures: DeformFigures,
}

pub fn run(args: &DeformArgs) -> Result<(), CliError> {
    let mut settings: PairSettings = pair_settings(args.params.as_deref(), &args.sets)?;
    let inputs = [InputMesh::read(&args.a, args.weld)?, InputMesh::read(&args.b, args.weld)?];
    settings.complete(&inputs)?;
    let stems = output_stems(&inputs[0], &inputs[1]);
    let display = display_names(&stems);
    note_undecodable_names(&stems);
    let names = [display[0].as_str(), display[1].as_str()];
    let (result, figures) =
        deform_pair(names, [&inputs[0].mesh, &inputs[1].mesh], &settings.parameters(), &mut Deformer::new())?;
    create_dir(&args.output)?;
    // Every output goes to a staging folder first and is moved into place at the end, so that
    // a failure (B cannot be written, the picture fails) leaves none of this run's files.
    let staged = StagedOutputs::new(&args.output)?;
    let mut outputs = [String::new(), String::new()];
    for (i, input) in inputs.iter().enumerate() {
        let ext = args.format.map_or(FormatChoice::extension_of(input.format), FormatChoice::extension);
        let path = output_path(&args.output, &stems[i], ext);
        input.write_result(&staged.path(&path), &result.positions[i])?;
        outputs[i] = path.display().to_string();
    }
    let report = DeformReport {
        inputs: [args.a.display().to_string(), args.b.display().to_string()],
        outputs: outputs.clone(),
        figures,
    };
    let report_path = args.output.join("report.json");
    write_text(&staged.path(&report_path), &serde_json::to_string_pretty(&report)?)?;
    let picture = if args.preview {
        let shot = OwnedFrame {
            objects: inputs
                .iter()
                .zip(names)
                .zip([&settings.a, &settings.b])
                .map(|((input, name), params)| OwnedObject {
                    name: name.to_string(),
                    mesh: input.mesh.clone(),
                    params: params.clone(),
                })
                .collect(),
            pairs: vec![FramePair { objects: [0, 1], params: settings.pair }],
        };
        let any_gltf = inputs.iter().any(|i| matches!(i.format, MeshFormat::Gltf | MeshFormat::Glb));
        let settings = args.pictures.settings(args.color, &SceneDefaults::default(), any_gltf);
        let picture = args.output.join("preview.png");
        write_frame_preview(&staged.path(&picture), &PreviewFrame::new(&shot, &result), &settings)?;
        Some(picture)
    } else {
        None
    };
    staged.commit()?;

    let pair = &result.stats.pairs[0];
    if pair.in_contact {
        say!(
            "contact: d̂ = [{:.3}, {:.3}, {:.3}] ({}), ε_c = {:.4}, contact area {:.4}",
            pair.direction[0],
            pair.direction[1],
            pair.direction[2],
            if pair.direction_automatic { "automatic" } else { "given" },
            pair.threshold,
            pair.contact_area
        );
    } else if pair.intersection_points > 0 {
        say!("the meshes intersect but have no contact zone: outputs are copies of the inputs");
    } else {
        say!("the meshes do not intersect: outputs are copies of the inputs");
    }
    for (object, output) in result.stats.objects.iter().zip(&outputs) {
        if object.deformed {
            say!(
                "{}: {} contact and {} deformed vertices, extent {:.4}, volume change {:.2e} → {output}",
                object.name,
                object.contact_vertices,
                object.deformable_vertices,
                object.extent,
                object.relative_volume_change
            );
        } else {
            say!("{}: unchanged → {output}", object.name);
        }
    }
    if let (Some(before), Some(after)) = (report.figures.penetration_before, report.figures.penetration_after) {
        say!("deepest penetration {before:.4e} → {after:.4e}");
    }
    say!("report: {} ({:.1} ms)", report_path.display(), result.stats.total.as_secs_f64() * 1e3);
    if let Some(picture) = picture {
        say!("preview: {}", picture.display());
    }
    let warnings = print_warnings(None, &result.stats.warnings);
    if args.strict && warnings > 0 {
        return Err(CliError::strict(warnings));
    }
    Ok(())
}
