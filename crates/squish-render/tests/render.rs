//! Properties of rendered pictures: coverage, colours, depth, back faces, framing, PNG output,
//! determinism; and example pictures written to the test temp dir for a human to look at.

// Tests may unwrap: a panic is the failure report.
#![allow(clippy::unwrap_used)]

use glam::DVec3;
use squish::TriMesh;
use squish::mesh::{bounding_box, face_normals, shapes};
use squish_render::*;

fn out_dir() -> std::path::PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("squish-render-examples");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn luminance(p: [u8; 4]) -> f32 {
    let l = |b: u8| srgb_to_linear(f32::from(b) / 255.0);
    0.2126 * l(p[0]) + 0.7152 * l(p[1]) + 0.0722 * l(p[2])
}

/// Sum of alpha over the picture, in pixels.
fn coverage(image: &Image) -> f64 {
    image.rgba.chunks(4).map(|p| f64::from(p[3]) / 255.0).sum()
}

#[test]
fn icosphere_covers_the_expected_disc() {
    let sphere = shapes::icosphere(1.0, 5);
    let (w, h) = (240, 240);
    // Looking along an axis, the (symmetric) bounding box is centred on the sphere's centre, and
    // the sphere projects to a disc around the image centre.
    let camera = Camera::framing(&bounding_box(&sphere), DVec3::Y, DVec3::Z, 40.0, 1.0);
    let options = RenderOptions { background: Background::Transparent, supersampling: 3, ..RenderOptions::new(w, h) };
    let image = render(&[RenderMesh::new(&sphere)], &camera, &options).unwrap();

    // A sphere of radius r whose centre is at distance D projects to a disc of angular radius
    // asin(r / D), i.e. of radius tan(asin(r / D)) on the image plane at depth 1.
    let distance = camera.eye.length();
    let (_, tan_v) = camera.tangents(1.0);
    let radius_px = (1.0f64 / distance).asin().tan() / tan_v * f64::from(h) / 2.0;
    let expected = std::f64::consts::PI * radius_px * radius_px;
    let covered = coverage(&image);
    eprintln!("sphere coverage {covered:.1} px, expected {expected:.1} px");
    assert!((covered / expected - 1.0).abs() < 0.02, "covered {covered:.0} px, expected {expected:.0} px");

    let centre = camera.project(DVec3::ZERO, w, h).unwrap();
    assert!((centre.x - 120.0).abs() < 1e-6 && (centre.y - 120.0).abs() < 1e-6);
    let middle = image.pixel(120, 120).unwrap();
    assert_eq!(middle[3], 255);
    assert!(luminance(middle) > 0.2, "centre pixel is lit: {middle:?}");
    for (x, y) in [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)] {
        assert_eq!(image.pixel(x, y).unwrap()[3], 0, "corner ({x}, {y}) is background");
    }
    // Everything covered lies inside the predicted disc (plus a pixel of anti-aliasing).
    for y in 0..h {
        for x in 0..w {
            if image.pixel(x, y).unwrap()[3] > 0 {
                let r = ((f64::from(x) + 0.5 - centre.x).powi(2) + (f64::from(y) + 0.5 - centre.y).powi(2)).sqrt();
                assert!(r < radius_px + 1.5, "({x}, {y}) at {r} > {radius_px}");
            }
        }
    }

    // With the default gradient background, the corners are the gradient's colours.
    let image = render(&[RenderMesh::new(&sphere)], &camera, &RenderOptions::new(w, h)).unwrap();
    let Background::Gradient { top, bottom } = Background::default() else { panic!() };
    let (top, bottom) = (rgba8(top), rgba8(bottom));
    let close = |a: [u8; 4], b: [u8; 4]| (0..3).all(|c| a[c].abs_diff(b[c]) <= 2);
    assert!(close(image.pixel(0, 0).unwrap(), top));
    assert!(close(image.pixel(w - 1, h - 1).unwrap(), bottom));
}

/// Face colours of a box by outward normal: ±x red/cyan, ±y green/magenta, ±z blue/yellow.
fn axis_colors(mesh: &TriMesh) -> Vec<Rgb> {
    face_normals(mesh)
        .iter()
        .map(|n| {
            let pick = |v: f64, pos: Rgb, neg: Rgb| if v > 0.0 { pos } else { neg };
            if n.x.abs() > 0.9 {
                pick(n.x, [1.0, 0.0, 0.0], [0.0, 1.0, 1.0])
            } else if n.y.abs() > 0.9 {
                pick(n.y, [0.0, 1.0, 0.0], [1.0, 0.0, 1.0])
            } else {
                pick(n.z, [0.0, 0.0, 1.0], [1.0, 1.0, 0.0])
            }
        })
        .collect()
}

#[test]
fn cube_shows_the_colours_of_its_visible_faces() {
    let cube = shapes::cube(2.0, 2);
    let colors = axis_colors(&cube);
    let (w, h) = (200, 160);
    // Azimuth 60° puts the camera on the +x, −y side, elevation 30° above: the visible faces
    // are +x, −y and +z.
    let camera = Camera::orbit(&bounding_box(&cube), 60.0, 30.0, 35.0, 1.25);
    let options = RenderOptions::new(w, h);
    let image =
        render(&[RenderMesh::new(&cube).with_face_colors(&colors).with_shading(Shading::Flat)], &camera, &options)
            .unwrap();
    let at = |p: DVec3| {
        let q = camera.project(p, w, h).unwrap();
        image.pixel(q.x as u32, q.y as u32).unwrap()
    };
    // Dominant channels of each visible face's centre.
    let px = at(DVec3::new(1.0, 0.0, 0.0));
    assert!(px[0] > 100 && px[1] < px[0] / 3 && px[2] < px[0] / 3, "+x red: {px:?}");
    let my = at(DVec3::new(0.0, -1.0, 0.0));
    assert!(my[0] > 100 && my[2] > 100 && my[1] < my[0] / 3, "-y magenta: {my:?}");
    let pz = at(DVec3::new(0.0, 0.0, 1.0));
    assert!(pz[2] > 100 && pz[0] < pz[2] / 3 && pz[1] < pz[2] / 3, "+z blue: {pz:?}");
    // No pixel shows a hidden face's hue (cyan, green, yellow: green strong).
    let hidden = image.rgba.chunks(4).filter(|p| p[1] > 120 && p[1] > p[0] && p[1] > p[2]).count();
    assert_eq!(hidden, 0);
}

#[test]
fn a_small_sphere_in_front_occludes_a_big_one_whatever_the_order() {
    let big = shapes::icosphere(1.0, 3);
    let mut small = shapes::icosphere(0.25, 3);
    small.map_positions(|p| p + DVec3::new(0.0, -1.6, 0.0));
    let camera = Camera::framing(&bounding_box(&big), DVec3::Y, DVec3::Z, 40.0, 1.0);
    let red = [0.8, 0.05, 0.05];
    let grey = [0.5, 0.5, 0.5];
    let options = RenderOptions::new(120, 120);
    let a =
        render(&[RenderMesh::new(&big).with_color(grey), RenderMesh::new(&small).with_color(red)], &camera, &options)
            .unwrap();
    let b =
        render(&[RenderMesh::new(&small).with_color(red), RenderMesh::new(&big).with_color(grey)], &camera, &options)
            .unwrap();
    assert_eq!(a, b, "the depth test, not the drawing order, decides");
    let centre = a.pixel(60, 60).unwrap();
    assert!(u16::from(centre[0]) > 3 * u16::from(centre[1]).max(10), "small red sphere in front: {centre:?}");
    // Off the small sphere, the big grey one.
    let side = a.pixel(60, 30).unwrap();
    assert!(side[0].abs_diff(side[1]) < 30, "grey: {side:?}");
}

#[test]
fn back_faces_are_tinted() {
    let sphere = shapes::icosphere(1.0, 3);
    let mut inside_out = sphere.clone();
    for t in &mut inside_out.triangles {
        t.swap(1, 2);
    }
    let camera = Camera::framing(&bounding_box(&sphere), DVec3::Y, DVec3::Z, 40.0, 1.0);
    let options = RenderOptions::new(80, 80);
    let grey = [0.5, 0.5, 0.5];
    let front = render(&[RenderMesh::new(&sphere).with_color(grey)], &camera, &options).unwrap();
    let back = render(&[RenderMesh::new(&inside_out).with_color(grey)], &camera, &options).unwrap();
    let (f, b) = (front.pixel(40, 40).unwrap(), back.pixel(40, 40).unwrap());
    assert!(f[0].abs_diff(f[1]) < 20, "front is grey: {f:?}");
    assert!(b[0] > b[1] + 40 && b[2] > b[1] + 40, "back is magenta: {b:?}");
    assert!(luminance(b) < luminance(f), "back is darker: {f:?} {b:?}");

    // An open grid seen from below shows its back.
    let grid = shapes::grid(2.0, 2.0, 4, 4);
    let above = Camera::orbit(&bounding_box(&grid), 20.0, 40.0, 40.0, 1.0);
    let below = Camera::orbit(&bounding_box(&grid), 20.0, -40.0, 40.0, 1.0);
    let up = render(&[RenderMesh::new(&grid).with_color(grey)], &above, &options).unwrap();
    let down = render(&[RenderMesh::new(&grid).with_color(grey)], &below, &options).unwrap();
    let (u, d) = (up.pixel(40, 40).unwrap(), down.pixel(40, 40).unwrap());
    assert!(u[0].abs_diff(u[1]) < 20 && d[0] > d[1] + 40, "{u:?} {d:?}");
}

#[test]
fn framing_keeps_every_vertex_of_an_elongated_capsule_inside() {
    let mut capsule = shapes::capsule(0.3, 4.0, 24, 6, 12);
    // Lay it along a skew diagonal so that no axis is special.
    capsule.map_positions(|p| {
        let (s, c) = (0.7f64.sin(), 0.7f64.cos());
        let p = DVec3::new(p.x, c * p.y - s * p.z, s * p.y + c * p.z);
        DVec3::new(c * p.x + s * p.y, -s * p.x + c * p.y, p.z) + DVec3::new(5.0, -3.0, 2.0)
    });
    let bbox = bounding_box(&capsule);
    for (w, h) in [(320u32, 180u32), (150, 300), (200, 200)] {
        for (az, el) in [(0.0, 0.0), (35.0, 20.0), (120.0, -30.0), (270.0, 80.0), (10.0, 90.0)] {
            let aspect = f64::from(w) / f64::from(h);
            let camera = Camera::orbit(&bbox, az, el, 45.0, aspect);
            let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for &p in &capsule.positions {
                let q = camera.project(p, w, h).expect("in front of the camera");
                lo = lo.min(q);
                hi = hi.max(q);
            }
            assert!(lo.x > 0.0 && lo.y > 0.0 && hi.x < f64::from(w) && hi.y < f64::from(h), "{az} {el}: {lo} {hi}");
            // The fit is to the box, so the capsule fills a good part of the picture.
            let fill = ((hi.x - lo.x) / f64::from(w)).max((hi.y - lo.y) / f64::from(h));
            assert!(fill > 0.35, "{az} {el}: fill {fill}");
            // Fitting the vertices themselves is tight: 6% margin on the tightest side, centred.
            let tight = Camera::framing_points(&capsule.positions, orbit_direction(az, el), DVec3::Z, 45.0, aspect);
            let (mut tlo, mut thi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for &p in &capsule.positions {
                let q = tight.project(p, w, h).expect("in front of the camera");
                tlo = tlo.min(q);
                thi = thi.max(q);
            }
            assert!(tlo.x > 0.0 && tlo.y > 0.0 && thi.x < f64::from(w) && thi.y < f64::from(h));
            let fill = ((thi.x - tlo.x) / f64::from(w)).max((thi.y - tlo.y) / f64::from(h));
            assert!(fill > 0.85 && fill < 0.95, "{az} {el}: tight fill {fill}");
            assert!((tlo.x + thi.x - f64::from(w)).abs() < 1e-6 * f64::from(w), "{az} {el}: {tlo} {thi}");
            // And the rendered picture has no mesh pixel on its border.
            if (w, h) == (200, 200) {
                let options = RenderOptions { background: Background::Transparent, ..RenderOptions::new(w, h) };
                let image = render(&[RenderMesh::new(&capsule)], &camera, &options).unwrap();
                for x in 0..w {
                    assert_eq!(image.pixel(x, 0).unwrap()[3], 0);
                    assert_eq!(image.pixel(x, h - 1).unwrap()[3], 0);
                }
                for y in 0..h {
                    assert_eq!(image.pixel(0, y).unwrap()[3], 0);
                    assert_eq!(image.pixel(w - 1, y).unwrap()[3], 0);
                }
            }
        }
    }
}

#[test]
fn png_round_trips() {
    let sphere = shapes::icosphere(1.0, 2);
    let camera = Camera::orbit(&bounding_box(&sphere), 30.0, 20.0, 40.0, 1.5);
    let mut image = render(&[RenderMesh::new(&sphere)], &camera, &RenderOptions::new(96, 64)).unwrap();
    image.set_pixel(0, 0, [1, 2, 3, 4]);
    let bytes = encode_png(&image).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width, info.height), (96, 64));
    assert_eq!(info.color_type, png::ColorType::Rgba);
    assert_eq!(&buf[..info.buffer_size()], &image.rgba[..]);
    assert_eq!(&buf[..4], &[1, 2, 3, 4]);
}

#[test]
fn rendering_is_deterministic_across_runs_and_thread_counts() {
    let mut a = shapes::icosphere(1.0, 4);
    let mut b = shapes::capsule(0.4, 2.0, 32, 8, 8);
    a.map_positions(|p| p + DVec3::new(0.5, 0.0, 0.0));
    b.map_positions(|p| DVec3::new(p.z, p.y, p.x) - DVec3::new(0.3, 0.0, 0.0));
    let u: Vec<f64> = a.positions.iter().map(|p| p.z).collect();
    let colors = scalar_colors(&u, None);
    let bbox = bounding_box(&a);
    let camera = Camera::orbit(&bbox, 25.0, 15.0, 40.0, 4.0 / 3.0);
    let scene = [RenderMesh::new(&a).with_vertex_colors(&colors).with_wireframe(true), RenderMesh::new(&b)];
    let options = RenderOptions::new(160, 120);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| render(&scene, &camera, &options))
    };
    let first = run(1).unwrap();
    assert_eq!(first, run(1).unwrap());
    assert_eq!(first, run(4).unwrap());
    assert_eq!(first, render(&scene, &camera, &options).unwrap());
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let sphere = shapes::icosphere(1.0, 1);
    let camera = Camera::orbit(&bounding_box(&sphere), 0.0, 0.0, 40.0, 1.0);
    let few = vec![[1.0, 0.0, 0.0]; 3];
    let err = render(&[RenderMesh::new(&sphere).with_vertex_colors(&few)], &camera, &RenderOptions::new(8, 8));
    assert!(matches!(err, Err(RenderError::ColorCount { kind: "vertex", .. })));
    let err = render(&[RenderMesh::new(&sphere).with_face_colors(&few)], &camera, &RenderOptions::new(8, 8));
    assert!(matches!(err, Err(RenderError::ColorCount { kind: "face", .. })));
    let broken = TriMesh { positions: vec![DVec3::ZERO; 3], triangles: vec![[0, 1, 9]] };
    let err = render(&[RenderMesh::new(&broken)], &camera, &RenderOptions::new(8, 8));
    assert!(matches!(err, Err(RenderError::IndexOutOfRange { triangle: 0, index: 9, .. })));
    assert!(render(&[], &camera, &RenderOptions::new(0, 8)).is_err());
    assert!(render(&[], &camera, &RenderOptions { supersampling: 9, ..RenderOptions::new(8, 8) }).is_err());
    // Non-finite vertices are skipped, NaN colours become black, empty scenes are background.
    let mut nan = sphere.clone();
    nan.positions[0] = DVec3::NAN;
    let nan_colors = vec![[f32::NAN; 3]; sphere.num_vertices()];
    let image = render(&[RenderMesh::new(&nan).with_vertex_colors(&nan_colors)], &camera, &RenderOptions::new(16, 16));
    assert!(image.is_ok());
    assert!(render(&[], &camera, &RenderOptions::new(16, 16)).is_ok());
}

#[test]
fn camera_inside_the_mesh_clips_at_the_near_plane() {
    // Looking out from inside a big inside-facing sphere: every triangle crosses the guard band
    // or the near plane somewhere; the picture must be fully covered, with no crack.
    let sphere = shapes::icosphere(10.0, 3);
    let camera = Camera::look_at(DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.2), DVec3::Z, 100.0, 1.0);
    let options = RenderOptions { background: Background::Transparent, ..RenderOptions::new(64, 64) };
    let image = render(&[RenderMesh::new(&sphere)], &camera, &options).unwrap();
    assert!(image.rgba.chunks(4).all(|p| p[3] == 255));
    // A cube the camera sits in a face of: the near plane cuts triangles.
    let cube = shapes::cube(2.0, 1);
    let camera = Camera::look_at(DVec3::new(0.0, -1.0, 0.0), DVec3::new(0.0, 1.0, 0.0), DVec3::Z, 60.0, 1.0);
    let image = render(&[RenderMesh::new(&cube)], &camera, &options).unwrap();
    assert!(image.rgba.chunks(4).all(|p| p[3] == 255));
}

#[test]
fn example_pictures() {
    let dir = out_dir();
    // Two spheres pushed into each other, one with a scalar field and a wireframe.
    let mut a = shapes::icosphere(1.0, 4);
    let mut b = shapes::uv_sphere(0.8, 48, 24);
    a.map_positions(|p| p - DVec3::new(0.75, 0.0, 0.0));
    b.map_positions(|p| p + DVec3::new(0.75, 0.0, 0.1));
    let u: Vec<f64> = a.positions.iter().map(|p| (p.x + 1.75) / 2.0).collect();
    let colors = scalar_colors(&u, None);
    let options = RenderOptions::new(640, 480);
    let all: Vec<DVec3> = a.positions.iter().chain(&b.positions).copied().collect();
    let camera = Camera::framing_points(&all, orbit_direction(20.0, 20.0), DVec3::Z, 35.0, options.aspect());
    let scene = [
        RenderMesh::new(&a).with_vertex_colors(&colors).with_wireframe(true),
        RenderMesh::new(&b).with_color(Label::Contact.color()),
    ];
    let mut image = render(&scene, &camera, &options).unwrap();
    label(&mut image, "frame 12");
    std::fs::write(dir.join("spheres.png"), encode_png(&image).unwrap()).unwrap();

    // Before / after: flat cube with face colours, and an inside-out capsule.
    let cube = shapes::cube(2.0, 3);
    let face = axis_colors(&cube);
    let small = RenderOptions::new(320, 240);
    let cam = Camera::orbit(&bounding_box(&cube), 60.0, 30.0, 35.0, small.aspect());
    let mut left = render(
        &[RenderMesh::new(&cube).with_face_colors(&face).with_shading(Shading::Flat).with_wireframe(true)],
        &cam,
        &small,
    )
    .unwrap();
    label(&mut left, "before");
    let mut capsule = shapes::capsule(0.5, 2.0, 32, 8, 8);
    for t in capsule.triangles.iter_mut().take(400) {
        t.swap(1, 2);
    }
    let cam = Camera::orbit(&bounding_box(&capsule), 30.0, 10.0, 35.0, small.aspect());
    let mut right = render(&[RenderMesh::new(&capsule)], &cam, &small).unwrap();
    label(&mut right, "after");
    let row = hstack(&[&left, &right], 4, [255, 255, 255, 255]);
    std::fs::write(dir.join("before_after.png"), encode_png(&row).unwrap()).unwrap();
    eprintln!("example pictures in {}", dir.display());
}
