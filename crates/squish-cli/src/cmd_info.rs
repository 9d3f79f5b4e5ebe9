//! `squish info MESH [--json]`: what a mesh is made of, before it goes through the deformer.

use std::path::PathBuf;

use clap::Args;
use serde::Serialize;
use squish::mesh::{Topology, bounding_box, face_areas, mean_edge_length, signed_volume};
use squish::spatial;
use squish_io::WeldMode;

use crate::console::say;
use crate::error::CliError;

#[derive(Args, Debug)]
pub struct InfoArgs {
    /// The mesh file (.obj, .ply, .gltf, .glb).
    pub mesh: PathBuf,
    /// Print a JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Weld vertices with identical positions first (glTF files duplicate vertices along UV seams).
    #[arg(long)]
    pub weld: bool,
}

/// Everything `squish info` reports.
#[derive(Serialize, Debug)]
pub struct MeshInfo {
    pub path: String,
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
    let weld = if args.weld { WeldMode::Exact } else { WeldMode::Off };
    let mesh = squish_io::read_mesh_with(&args.mesh, weld)?;
    let topology = Topology::new(&mesh);
    let manifold_problem = topology.check_manifold(&mesh).err().map(|e| e.to_string());
    let self_intersecting_faces = spatial::self_intersections(&mesh)
        .map_err(|e| CliError::failure(format!("{}: {e}", args.mesh.display())))?
        .faces
        .len();
    let bbox = bounding_box(&mesh);
    let info = MeshInfo {
        path: args.mesh.display().to_string(),
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
