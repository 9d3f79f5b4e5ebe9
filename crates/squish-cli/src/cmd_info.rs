//! `squish info MESH [--json]`: what a mesh is made of, before it goes through the deformer.
//!
//! glTF files are welded along their UV seams by default (`--weld auto`): glTF splits a vertex
//! wherever a UV seam or a hard edge passes, which would report a clean character as open and
//! self-intersecting; the topology figures are those of the surface the deformer works on, and
//! the output says that it welded. The attribute counts (UVs, normals, colours, skins, morph
//! targets, materials) are the file's.

use std::path::PathBuf;

use clap::Args;
use serde::Serialize;
use squish::mesh::{Topology, bounding_box, face_areas, mean_edge_length, signed_volume};
use squish::spatial;
use squish_io::{MeshDocument, MeshFormat, WeldMode, weld_positions};

use crate::console::say;
use crate::error::CliError;
use crate::input::WeldChoice;

#[derive(Args, Debug)]
pub struct InfoArgs {
    /// The mesh file (.obj, .ply, .gltf, .glb).
    pub mesh: PathBuf,
    /// Print a JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Weld vertices with identical positions before the topology figures: auto (glTF files,
    /// which duplicate vertices along UV seams), always (`--weld` alone) or never (the file's
    /// vertices).
    #[arg(long, value_enum, num_args = 0..=1, default_missing_value = "always", default_value_t = WeldChoice::Auto)]
    pub weld: WeldChoice,
}

/// Everything `squish info` reports.
#[derive(Serialize, Debug)]
pub struct MeshInfo {
    pub path: String,
    /// Vertices in the file, before welding.
    pub file_vertices: usize,
    /// Whether the figures below are of the welded mesh.
    pub welded: bool,
    /// What the file holds besides positions and faces (format-specific counts).
    pub attributes: serde_json::Value,
    pub vertices: usize,
    pub faces: usize,
    pub edges: usize,
    pub components: usize,
    pub closed: bool,
    pub manifold: bool,
    /// Why the mesh is not manifold (the first problem found), if it is not.
    pub manifold_problem: Option<String>,
    pub boundary_loops: usize,
    pub degenerate_faces: usize,
    pub self_intersecting_faces: usize,
    /// Signed volume (meaningful for closed meshes; positive for outward normals).
    pub volume: f64,
    pub area: f64,
    pub mean_edge_length: f64,
    pub bounding_box: BoundingBox,
}

#[derive(Serialize, Debug)]
pub struct BoundingBox {
    pub min: [f64; 3],
    pub max: [f64; 3],
    pub diagonal: f64,
}

pub fn run(args: &InfoArgs) -> Result<(), CliError> {
    let format = MeshFormat::from_path(&args.mesh)?;
    let document = MeshDocument::read(&args.mesh)?;
    let file_mesh = document.mesh()?;
    let weld = match args.weld {
        WeldChoice::Auto => matches!(format, MeshFormat::Gltf | MeshFormat::Glb),
        WeldChoice::Always => true,
        WeldChoice::Never => false,
    };
    let mesh = if weld {
        let welded = weld_positions(&file_mesh.positions, &file_mesh.triangles, WeldMode::Exact);
        squish::TriMesh::new(welded.positions, welded.triangles)
            .map_err(|e| CliError::input(format!("{}: welded: {e}", args.mesh.display())))?
    } else {
        file_mesh.clone()
    };
    let attributes = match &document {
        MeshDocument::Obj(d) => serde_json::to_value(d.attribute_counts())?,
        MeshDocument::Ply(d) => serde_json::json!({
            "format": format!("{:?}", d.format()),
            "elements": d.elements.iter().map(|e| serde_json::json!({
                "name": e.name,
                "count": e.count,
                "properties": e.properties.iter().map(|p| p.name.clone()).collect::<Vec<_>>(),
            })).collect::<Vec<_>>(),
        }),
        MeshDocument::Gltf(d) => serde_json::to_value(d.attribute_counts())?,
    };
    let topology = Topology::new(&mesh);
    let manifold_problem = topology.check_manifold(&mesh).err().map(|e| e.to_string());
    let self_intersecting_faces = spatial::self_intersections(&mesh)
        .map_err(|e| CliError::failure(format!("{}: {e}", args.mesh.display())))?
        .faces
        .len();
    let bbox = bounding_box(&mesh);
    let info = MeshInfo {
        path: args.mesh.display().to_string(),
        file_vertices: file_mesh.num_vertices(),
        welded: weld,
        attributes,
        vertices: mesh.num_vertices(),
        faces: mesh.num_triangles(),
        edges: topology.num_edges(),
        components: topology.face_components(&mesh).1,
        closed: topology.is_closed(),
        manifold: manifold_problem.is_none(),
        manifold_problem,
        boundary_loops: topology.boundary_loops(&mesh).len(),
        degenerate_faces: (0..mesh.num_triangles()).filter(|&t| mesh.degeneracy(t).is_some()).count(),
        self_intersecting_faces,
        volume: signed_volume(&mesh),
        area: face_areas(&mesh).iter().sum(),
        mean_edge_length: mean_edge_length(&mesh, &topology),
        bounding_box: BoundingBox { min: bbox.min.to_array(), max: bbox.max.to_array(), diagonal: bbox.diagonal() },
    };
    if args.json {
        say!("{}", serde_json::to_string_pretty(&info)?);
    } else {
        print_text(&info);
    }
    Ok(())
}

fn print_text(info: &MeshInfo) {
    let yes_no = |b: bool| if b { "yes" } else { "no" };
    say!("{}", info.path);
    if info.welded {
        say!(
            "  welded                   {} file vertices → {} (seam copies merged for the topology figures; --weld never for the file's)",
            info.file_vertices,
            info.vertices
        );
    }
    say!("  vertices                 {}", info.vertices);
    say!("  faces                    {}", info.faces);
    say!("  edges                    {}", info.edges);
    say!("  components               {}", info.components);
    say!("  closed                   {}", yes_no(info.closed));
    match &info.manifold_problem {
        None => say!("  manifold                 yes"),
        Some(problem) => say!("  manifold                 no ({problem})"),
    }
    say!("  boundary loops           {}", info.boundary_loops);
    say!("  degenerate faces         {}", info.degenerate_faces);
    say!("  self-intersecting faces  {}", info.self_intersecting_faces);
    say!("  volume                   {:.6}", info.volume);
    say!("  area                     {:.6}", info.area);
    say!("  mean edge length         {:.6}", info.mean_edge_length);
    if let Some(attributes) = info.attributes.as_object() {
        let line: Vec<String> = attributes
            .iter()
            .filter(|(k, _)| k.as_str() != "elements")
            .map(|(k, v)| format!("{} {}", k.replace('_', " "), v))
            .collect();
        say!("  attributes               {}", line.join(", "));
        for element in attributes.get("elements").and_then(|e| e.as_array()).into_iter().flatten() {
            say!(
                "    element {} × {}: {}",
                element["name"].as_str().unwrap_or(""),
                element["count"],
                element["properties"]
            );
        }
    }
    let b = &info.bounding_box;
    say!(
        "  bounding box             [{:.4}, {:.4}, {:.4}] – [{:.4}, {:.4}, {:.4}] (diagonal {:.4})",
        b.min[0],
        b.min[1],
        b.min[2],
        b.max[0],
        b.max[1],
        b.max[2],
        b.diagonal
    );
}
