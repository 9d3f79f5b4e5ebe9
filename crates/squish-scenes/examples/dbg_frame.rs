use squish::pipeline::Deformer;
use squish_scenes::characters;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let shot_name = &args[1];
    let frame: f64 = args[2].parse().unwrap();
    let untangle = args.get(3).map(|s| s != "nountangle").unwrap_or(true);
    let shots = characters::humanoid_shots(0.024, 32);
    let shot = shots.iter().find(|s| s.name == shot_name).unwrap();
    let auto = shot.character.auto_self_contact();
    let mut object = shot.character.object(&shot.world(frame), Some(&auto)).unwrap();
    object.params.untangle = untangle;
    let frame = squish::OwnedFrame { objects: vec![object.clone()], pairs: vec![] };
    let r = Deformer::new().deform(&frame.frame()).unwrap();
    let edge = squish_scenes::shots::first_edge_mean(&object.mesh);
    let off = object.mesh.positions.iter().zip(&r.positions[0]).map(|(a,b)| (*a-*b).length()).fold(0.0, f64::max) / edge;
    println!("offset {off:.2} edges; faces {:?}; untangled {:?}", r.stats.objects[0].self_intersecting_faces, r.stats.objects[0].untangled);
    for a in &r.stats.articulations { if a.bulge_height != 0.0 || a.error.is_some() { println!("art {} h {:.4e} exact {} err {:?} faces {}→{}", a.name, a.bulge_height, a.volume_exact, a.error, a.self_intersecting_faces_before, a.self_intersecting_faces_after); } }
    for p in &r.stats.part_pairs { println!("pair {:?} {} faces {}→{} err {:?} rings {} grown {}", p.parts, p.kind, p.faces_before, p.faces_after, p.error, p.margin_rings, p.grown_from_intersection); }
}
