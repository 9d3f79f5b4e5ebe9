//! Rendering time of a 50k-triangle mesh at 800 × 600 with 2 × 2 supersampling. The bound is
//! loose (machines differ); the printed timings are what matters.

// Tests may unwrap: a panic is the failure report.
#![allow(clippy::unwrap_used)]

use std::time::Instant;

use squish::mesh::{bounding_box, shapes};
use squish_render::*;

#[test]
fn fifty_thousand_triangles_at_800x600_render_fast() {
    // 160 segments × 160 rings: 50,880 triangles.
    let mesh = shapes::uv_sphere(1.0, 160, 160);
    assert!(mesh.num_triangles() >= 50_000);
    let camera = Camera::orbit(&bounding_box(&mesh), 30.0, 20.0, 40.0, 800.0 / 600.0);
    for (ss, wire) in [(2, false), (2, true), (3, false)] {
        let options = RenderOptions { supersampling: ss, ..RenderOptions::new(800, 600) };
        let scene = [RenderMesh::new(&mesh).with_wireframe(wire)];
        let _ = render(&scene, &camera, &options).unwrap();
        let mut best = f64::INFINITY;
        for _ in 0..3 {
            let start = Instant::now();
            let image = render(&scene, &camera, &options).unwrap();
            best = best.min(start.elapsed().as_secs_f64());
            assert_eq!(image.width, 800);
        }
        eprintln!(
            "{} triangles, 800x600, {ss}x{ss} supersampling, wireframe {wire}: {:.1} ms ({} threads)",
            mesh.num_triangles(),
            best * 1e3,
            rayon::current_num_threads()
        );
        if ss == 2 && !wire {
            assert!(best < 2.0, "{best} s");
        }
    }
    // Worst case for shading: a 51,200-triangle grid seen from above fills the picture's height.
    let grid = shapes::grid(2.0, 2.0, 160, 160);
    let camera = Camera::orbit(&bounding_box(&grid), 0.0, 90.0, 40.0, 800.0 / 600.0);
    let options = RenderOptions { supersampling: 2, ..RenderOptions::new(800, 600) };
    let scene = [RenderMesh::new(&grid).with_wireframe(true)];
    let _ = render(&scene, &camera, &options).unwrap();
    let start = Instant::now();
    let _ = render(&scene, &camera, &options).unwrap();
    eprintln!(
        "{} triangles filling the frame, 800x600, 2x2, wireframe: {:.1} ms",
        grid.num_triangles(),
        start.elapsed().as_secs_f64() * 1e3
    );

    // Encoding is part of producing a preview too.
    let options = RenderOptions { supersampling: 2, ..RenderOptions::new(800, 600) };
    let image = render(&[RenderMesh::new(&mesh)], &camera, &options).unwrap();
    let start = Instant::now();
    let bytes = encode_png(&image).unwrap();
    eprintln!("PNG encoding: {:.1} ms, {} KiB", start.elapsed().as_secs_f64() * 1e3, bytes.len() / 1024);
}
