//! The hot stages of a frame (thesis ch. 7 §5, table 7.2's columns), one benchmark each, so that
//! a regression shows in the stage that caused it:
//! - on a ~10k-vertex pair (the "small sphere – big sphere" bench scene, mid-animation):
//!   intersection (§4.1), the build of the larger object's tree (every region and articulation
//!   side builds one), mapping (§4.2.2), the whole contact definition (ch. 4, up to the
//!   contact zones), the edge-path distances that bound the parametrization's domain (§5.1; by
//!   Dijkstra, and by the breadth-first bounds used when the domain holds the whole sphere),
//!   parametrization (§5.1, two factorizations and two solves), guide diffusion
//!   (§5.3, one factorization, one two-column solve), the deformation of one region (ch. 5) and
//!   the full frame on a reused [`Deformer`];
//! - on the hat–egg scene at quick size (a shell enveloping a rigid egg: many near misses), the
//!   intersection and mapping, whose spatial searches dominate there.
//!
//! Run: `cargo bench -p squish --bench pipeline -- --quick`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use squish::PairParams;
use squish::contact::{ContactSide, contact_pair, intersect, map_regions};
use squish::deform::{
    ContactSet, DirectionParams, GuideParams, ParametrizeParams, RegionSolver, deform_region, direction_field,
    guide_fields, parametrize,
};
use squish::mesh::{Topology, TriMesh, edge_path_distance_bound, edge_path_distance_field, vertex_normals};
use squish::pipeline::Deformer;
use squish::spatial::TriangleBvh;
use squish_scenes::bench::{self as bench_scenes, BenchScene, BenchSize};

/// What the contact stages need about one object.
struct Side {
    mesh: TriMesh,
    topology: Topology,
    normals: Vec<glam::DVec3>,
    bvh: TriangleBvh,
}

impl Side {
    fn new(mesh: &TriMesh) -> Self {
        Self {
            mesh: mesh.clone(),
            topology: Topology::new(mesh),
            normals: vertex_normals(mesh),
            bvh: TriangleBvh::new(mesh).expect("tree"),
        }
    }

    fn contact(&self) -> ContactSide<'_> {
        ContactSide::new(&self.mesh, &self.topology, &self.normals, &self.bvh)
    }
}

/// The two objects of the scene's first pair at time `t`, with the pair's parameters.
fn pair_at(scene: &BenchScene, t: f64) -> (Side, Side, PairParams) {
    let pose = scene.pose(t);
    let pair = pose.pairs[0];
    let [a, b] = pair.objects.map(|i| Side::new(&pose.objects[i].mesh));
    (a, b, pair.params)
}

fn group_settings<'a>(
    c: &'a mut Criterion,
    name: &str,
) -> criterion::BenchmarkGroup<'a, criterion::measurement::WallTime> {
    let mut group = c.benchmark_group(name);
    group.sample_size(10).measurement_time(Duration::from_secs(3)).warm_up_time(Duration::from_millis(500));
    group
}

fn contact_stages(c: &mut Criterion, group_name: &str, scene: &BenchScene) {
    let (a, b, params) = pair_at(scene, 0.5);
    let (sa, sb) = (a.contact(), b.contact());
    let contact = contact_pair(&sa, &sb, &params).expect("contact");
    let inter = intersect(&sa, &sb).expect("intersection");
    let mut group = group_settings(c, group_name);
    group.bench_function("intersection", |bench| bench.iter(|| black_box(intersect(&sa, &sb).expect("intersection"))));
    group.bench_function("tree build", |bench| bench.iter(|| black_box(TriangleBvh::new(&b.mesh).expect("tree"))));
    group.bench_function("mapping", |bench| {
        bench.iter(|| black_box(map_regions([&sa, &sb], [&inter.regions[0], &inter.regions[1]], contact.direction)))
    });
    group.bench_function("contact pair", |bench| {
        bench.iter(|| black_box(contact_pair(&sa, &sb, &params).expect("contact")))
    });
    group.finish();
}

fn deformation_stages(c: &mut Criterion, scene: &BenchScene) {
    // The deformed object of the pair (the big sphere) with the zone of the contact.
    let (a, b, params) = pair_at(scene, 0.5);
    let contact = contact_pair(&a.contact(), &b.contact(), &params).expect("contact");
    let zones = vec![&contact.sides[1].zone];
    let (mesh, topology) = (&b.mesh, &b.topology);
    let object = &scene.rest.objects[scene.rest.pairs[0].objects[1]];
    let deform_params = squish::deform::DeformParams::of(&object.params, object.params.extent.unwrap_or(1.0), true);
    let mut solver = RegionSolver::new(mesh, topology).expect("solver");
    let contact_set = ContactSet::new(mesh, topology, &zones).expect("contact set");
    let parametrize_params = ParametrizeParams {
        extent: deform_params.extent,
        domain_radius: deform_params.domain_radius(),
        heat_time_factor: deform_params.object.heat_time_factor,
        constraint_weight_factor: deform_params.constraint_weight_factor,
        edge_length: None,
    };
    let direction_params = DirectionParams {
        method: deform_params.object.direction_field,
        normalize_diffused: deform_params.object.normalize_diffused_direction,
        mapping_field: None,
    };
    let guide_params = GuideParams { constraint_weight_factor: deform_params.constraint_weight_factor };

    let mut group = group_settings(c, "deformation 10k");
    // The search for the parametrization domain 𝒫 (Dijkstra from ∂𝒞's edge ends, §5.1).
    let seeds: Vec<(u32, f64)> = contact_set
        .boundary
        .iter()
        .flat_map(|b| {
            [b.point.inside, b.point.outside].map(|v| (v, (mesh.positions[v as usize] - b.position).length()))
        })
        .collect();
    group.bench_function("domain distances", |bench| {
        bench.iter(|| black_box(edge_path_distance_field(mesh, topology, &seeds, parametrize_params.domain_radius)))
    });
    // The same question answered by breadth-first bounds, which the parametrization uses when the
    // whole sphere lies within 0.8·radius of ∂𝒞 (as here: the row checks it).
    let start = 0.8 * parametrize_params.domain_radius;
    assert!(edge_path_distance_bound(mesh, topology, &seeds, start).is_some(), "the bound applies to this scene");
    group.bench_function("domain distances (breadth-first bound)", |bench| {
        bench.iter(|| black_box(edge_path_distance_bound(mesh, topology, &seeds, start)))
    });
    group.bench_function("parametrization", |bench| {
        bench.iter(|| {
            let set = ContactSet::new(mesh, topology, &zones).expect("contact set");
            black_box(parametrize(mesh, topology, &mut solver, &set, &parametrize_params).expect("parametrization"))
        })
    });
    let parametrization = parametrize(mesh, topology, &mut solver, &contact_set, &parametrize_params).expect("p");
    let field = direction_field(mesh, &mut solver, &contact_set, &parametrization, &b.normals, &direction_params)
        .expect("direction field");
    group.bench_function("guide diffusion", |bench| {
        bench.iter(|| {
            black_box(
                guide_fields(mesh, topology, &mut solver, &contact_set, &parametrization, &field, &guide_params)
                    .expect("guide"),
            )
        })
    });
    group.bench_function("deform region", |bench| {
        bench.iter(|| black_box(deform_region(mesh, topology, &mut solver, &zones, &deform_params).expect("deform")))
    });
    group.finish();
}

fn full_frame(c: &mut Criterion, scene: &BenchScene) {
    let pose = scene.pose(0.5);
    let frame = pose.frame();
    let mut deformer = Deformer::new();
    deformer.deform(&frame).expect("first frame");
    let mut group = group_settings(c, "frame 10k");
    group
        .bench_function("deformer (reused)", |bench| bench.iter(|| black_box(deformer.deform(&frame).expect("frame"))));
    group.finish();
}

fn pipeline(c: &mut Criterion) {
    let spheres = bench_scenes::small_big_spheres(BenchSize::Full);
    contact_stages(c, "contact 10k", &spheres);
    deformation_stages(c, &spheres);
    full_frame(c, &spheres);
    contact_stages(c, "contact hat-egg", &bench_scenes::hat_egg(BenchSize::Quick));
}

criterion_group!(benches, pipeline);
criterion_main!(benches);
