//! PLY: round trips in the three encodings, extra properties and point clouds, header and body
//! errors (each naming the file), and truncation at every byte.

#![allow(clippy::unwrap_used)]

use std::path::Path;

use glam::DVec3;
use squish::mesh::shapes;
use squish_io::*;

fn exact(a: &[DVec3], b: &[DVec3]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(p, q)| p.to_array().map(f64::to_bits) == q.to_array().map(f64::to_bits))
}

fn awkward_mesh() -> squish::TriMesh {
    let mut mesh = shapes::icosphere(0.1 + 1.0 / 3.0, 2);
    mesh.positions[0] = DVec3::new(1e-300, -0.0, 1.0 / 7.0);
    mesh.positions[1] = DVec3::new(1.0e300, f64::MIN_POSITIVE, -2.5e-8);
    mesh
}

#[test]
fn round_trips_are_exact_in_every_encoding() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = awkward_mesh();
    for format in [PlyFormat::Ascii, PlyFormat::BinaryLittleEndian, PlyFormat::BinaryBigEndian] {
        let path = dir.path().join(format!("{format:?}.ply"));
        write_ply(&path, &mesh, &PlyWriteOptions::default().with_format(format)).unwrap();
        let back = read_ply(&path).unwrap();
        assert!(exact(&back.positions, &mesh.positions), "{format:?}");
        assert_eq!(back.triangles, mesh.triangles, "{format:?}");
    }
}

#[test]
fn float_positions_round_to_f32() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = shapes::icosphere(1.0 / 3.0, 1);
    let path = dir.path().join("f.ply");
    let options = PlyWriteOptions { position_type: ScalarType::F32, ..PlyWriteOptions::ascii() };
    write_ply(&path, &mesh, &options).unwrap();
    let back = read_ply(&path).unwrap();
    for (a, b) in back.positions.iter().zip(&mesh.positions) {
        assert_eq!(*a, b.as_vec3().as_dvec3());
    }
}

#[test]
fn colored_labelled_mesh_and_point_cloud() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = shapes::cube(1.0, 2);
    let n = mesh.num_vertices();
    let colors: Vec<[u8; 3]> = (0..n).map(|i| [(i * 7 % 256) as u8, 255, (i % 2 * 255) as u8]).collect();
    let labels: Vec<i32> = (0..n as i32).map(|i| i - 3).collect();
    let u: Vec<f32> = (0..n).map(|i| i as f32 / 3.0).collect();
    let mut properties = VertexProperty::rgb(&colors);
    properties.push(VertexProperty::int("label", &labels));
    properties.push(VertexProperty::float("u", &u));
    for format in [PlyFormat::Ascii, PlyFormat::BinaryLittleEndian, PlyFormat::BinaryBigEndian] {
        let options = PlyWriteOptions::default().with_format(format);
        let path = dir.path().join("debug.ply");
        write_ply_with(&path, &mesh.positions, Some(&mesh.triangles), &properties, &options).unwrap();
        let data = read_ply_data(&path).unwrap();
        assert!(exact(&data.positions, &mesh.positions));
        assert_eq!(data.triangles, mesh.triangles);
        assert_eq!(data.colors().unwrap(), colors);
        let label = data.property("label").unwrap();
        assert_eq!(label.ty, ScalarType::I32);
        assert_eq!(label.values, labels.iter().map(|&l| l as f64).collect::<Vec<_>>());
        assert_eq!(data.property("u").unwrap().values, u.iter().map(|&x| x as f64).collect::<Vec<_>>());

        let cloud = dir.path().join("points.ply");
        write_point_cloud_ply(&cloud, &mesh.positions[..5], &VertexProperty::rgb(&colors[..5]), &options).unwrap();
        let data = read_ply_data(&cloud).unwrap();
        assert_eq!(data.positions.len(), 5);
        assert!(data.triangles.is_empty());
        assert_eq!(data.colors().unwrap(), colors[..5].to_vec());
        let text = std::fs::read(&cloud).unwrap();
        assert!(!String::from_utf8_lossy(&text).contains("element face"));
        // A point cloud is not a mesh.
        let e = read_ply(&cloud).unwrap_err().to_string();
        assert!(e.contains("points.ply") && e.contains("point cloud"), "{e}");
    }
}

#[test]
fn writer_rejects_bad_properties_without_touching_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.ply");
    std::fs::write(&path, b"old").unwrap();
    let p = [DVec3::ZERO, DVec3::X];
    let cases = [
        VertexProperty::new("label", ScalarType::U8, vec![1.0, 300.0]),
        VertexProperty::new("label", ScalarType::I32, vec![1.0, 0.5]),
        VertexProperty::new("label", ScalarType::I32, vec![1.0]),
        VertexProperty::new("x", ScalarType::F32, vec![1.0, 2.0]),
        VertexProperty::new("bad name", ScalarType::F32, vec![1.0, 2.0]),
    ];
    for prop in cases {
        let e = write_point_cloud_ply(&path, &p, &[prop], &PlyWriteOptions::default()).unwrap_err();
        assert!(matches!(e, IoError::InvalidInput { .. }), "{e}");
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
    }
}

/// Hand-written files in the variations other tools produce.
#[test]
fn foreign_layouts_are_read() {
    let dir = tempfile::tempdir().unwrap();
    // Properties in unusual order, unknown properties of every type, a uint list count,
    // `vertex_index` naming, a quad, an extra element, comments, CRLF line ends.
    let text = "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\nobj_info test\r\nelement vertex 4\r\n\
        property uchar red\r\nproperty float z\r\nproperty int16 flags\r\nproperty double x\r\nproperty list uchar int junk\r\nproperty float32 y\r\n\
        element face 1\r\nproperty uchar tag\r\nproperty list uint uint16 vertex_index\r\n\
        element edge 1\r\nproperty int vertex1\r\nproperty int vertex2\r\nend_header\r\n\
        10 0 -1 0 2 5 6 0\r\n20 0 -2 1 0 0\r\n30 0 -3 1 3 7 7 7 1\r\n40 0 -4 0 0 1\r\n\
        9 4 0 1 2 3\r\n0 1\r\n";
    let path = dir.path().join("hand.ply");
    std::fs::write(&path, text).unwrap();
    let data = read_ply_data(&path).unwrap();
    assert_eq!(
        data.positions,
        vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0)
        ]
    );
    assert_eq!(data.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(data.property("red").unwrap().values, vec![10.0, 20.0, 30.0, 40.0]);
    assert_eq!(data.property("flags").unwrap().values, vec![-1.0, -2.0, -3.0, -4.0]);

    // The same in big-endian binary, built byte by byte with a short list count and u8 indices.
    let mut bytes = b"ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty short s\nproperty float x\nproperty float y\nproperty float z\n\
        element face 1\nproperty list ushort uchar vertex_indices\nend_header\n"
        .to_vec();
    for (s, p) in [(1i16, [0.0f32, 0.0, 0.0]), (2, [1.0, 0.0, 0.0]), (3, [0.0, 1.0, 0.0])] {
        bytes.extend_from_slice(&s.to_be_bytes());
        for c in p {
            bytes.extend_from_slice(&c.to_be_bytes());
        }
    }
    bytes.extend_from_slice(&3u16.to_be_bytes());
    bytes.extend_from_slice(&[0, 1, 2]);
    let path = dir.path().join("be.ply");
    std::fs::write(&path, &bytes).unwrap();
    let mesh = read_ply(&path).unwrap();
    assert_eq!(mesh.triangles, vec![[0, 1, 2]]);
    assert_eq!(mesh.positions[1], DVec3::X);
}

fn error_for(name: &str, contents: &[u8]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, contents).unwrap();
    let e = read_ply(&path).unwrap_err().to_string();
    assert!(e.contains(name), "error does not name the file: {e}");
    e
}

const HEADER: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";

#[test]
fn header_errors() {
    let e = error_for("a.ply", b"plx\nformat ascii 1.0\n");
    assert!(e.contains("a.ply:1:") && e.contains("first line must be 'ply'"), "{e}");
    let e = error_for("b.ply", b"ply\nformat binary_middle_endian 1.0\nend_header\n");
    assert!(e.contains("b.ply:2:") && e.contains("unknown PLY format 'binary_middle_endian'"), "{e}");
    let e = error_for(
        "c.ply",
        b"ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n3 0 1 2\n",
    );
    assert!(e.contains("no 'vertex' element"), "{e}");
    let e = error_for(
        "d.ply",
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n",
    );
    assert!(e.contains("d.ply:3:") && e.contains("no 'z' property"), "{e}");
    let e = error_for("e.ply", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n");
    assert!(e.contains("no 'end_header'"), "{e}");
    let e = error_for("f.ply", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n");
    assert!(e.contains("f.ply:4:") && e.contains("unknown property type 'quad'"), "{e}");
    let e = error_for(
        "g.ply",
        b"ply\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n",
    );
    assert!(e.contains("no 'format' line"), "{e}");
    let e = error_for("h.ply", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty uchar n\nend_header\n0 0 0\n1\n");
    assert!(e.contains("no 'vertex_indices'"), "{e}");
}

#[test]
fn body_errors() {
    let body = |b: &str| format!("{HEADER}{b}").into_bytes();
    let e = error_for("num.ply", &body("0 0 0\n1 0 0\n0 1.2.3 0\n3 0 1 2\n"));
    assert!(e.contains("num.ply:12:") && e.contains("malformed value '1.2.3'") && e.contains("vertex 2"), "{e}");
    let e = error_for("range.ply", &body("0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"));
    assert!(e.contains("range.ply:13:") && e.contains("refers to vertex 3") && e.contains("3 vertices"), "{e}");
    let e = error_for("neg.ply", &body("0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n"));
    assert!(e.contains("neg.ply:13:") && e.contains("vertex -1"), "{e}");
    let e = error_for("nan.ply", &body("0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n"));
    assert!(e.contains("nan.ply:11:") && e.contains("non-finite"), "{e}");
    let e = error_for("inf.ply", &body("0 0 0\n1 0 0\n0 1 inf\n3 0 1 2\n"));
    assert!(e.contains("inf.ply:12:") && e.contains("non-finite"), "{e}");
    let e = error_for("short.ply", &body("0 0 0\n1 0 0\n0 1\n3 0 1 2\n"));
    assert!(e.contains("short.ply:12:") && e.contains("ends too early"), "{e}");
    let e = error_for("long.ply", &body("0 0 0\n1 0 0 5\n0 1 0\n3 0 1 2\n"));
    assert!(e.contains("long.ply:11:") && e.contains("more values"), "{e}");
    let e = error_for("two.ply", &body("0 0 0\n1 0 0\n0 1 0\n2 0 1\n"));
    assert!(e.contains("at least 3"), "{e}");
    let e = error_for("trunc.ply", &body("0 0 0\n1 0 0\n"));
    assert!(e.contains("after 2 of 3 vertex records") && e.contains("truncated"), "{e}");
    let e = error_for("empty.ply", b"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n");
    assert!(e.contains("empty"), "{e}");

    // Binary: NaN coordinate and out-of-range index, located by byte offset.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bin.ply");
    write_ply(&path, &shapes::cube(1.0, 1), &PlyWriteOptions::default()).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    let body_start = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    bytes[body_start + 8..body_start + 16].copy_from_slice(&f64::NAN.to_le_bytes());
    let e = error_for("binnan.ply", &bytes);
    assert!(e.contains(&format!("at byte {}", body_start + 16)) && e.contains("non-finite"), "{e}");
    let mut bytes = std::fs::read(&path).unwrap();
    let n = bytes.len();
    bytes[n - 4..].copy_from_slice(&1000i32.to_le_bytes());
    let e = error_for("binidx.ply", &bytes);
    assert!(e.contains(&format!("at byte {n}")) && e.contains("refers to vertex 1000"), "{e}");
}

/// Every truncation of a binary (both endiannesses) or ASCII file is a clean error.
#[test]
fn truncation_at_every_byte_is_a_clean_error() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = shapes::cube(1.0, 1);
    for format in [PlyFormat::BinaryLittleEndian, PlyFormat::BinaryBigEndian, PlyFormat::Ascii] {
        let path = dir.path().join("full.ply");
        write_ply_with(
            &path,
            &mesh.positions,
            Some(&mesh.triangles),
            &[VertexProperty::int("label", &[7; 8])],
            &PlyWriteOptions::default().with_format(format),
        )
        .unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let cut = dir.path().join("cut.ply");
        for len in 0..bytes.len() {
            // ASCII cut right after a complete last line is still a complete file.
            if format == PlyFormat::Ascii && (len == bytes.len() - 1) {
                continue;
            }
            std::fs::write(&cut, &bytes[..len]).unwrap();
            match read_ply(&cut) {
                Err(e) => assert!(e.to_string().contains("cut.ply"), "{e}"),
                Ok(_) => panic!("{format:?} truncated to {len} of {} bytes was accepted", bytes.len()),
            }
        }
    }
}

#[test]
fn missing_file() {
    let e = read_ply(Path::new("/no/such/file.ply")).unwrap_err();
    assert!(matches!(e, IoError::Io { .. }) && e.to_string().contains("/no/such/file.ply"), "{e}");
}

/// Issue 28: a header that declares fewer faces than the body holds dropped the rest silently
/// (1230 of 1280 faces kept). Now an error names the file, the element, both counts and the
/// header line to fix, in ASCII and in both binary encodings.
#[test]
fn more_records_than_the_header_declares_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = shapes::icosphere(1.0, 3);
    assert_eq!(mesh.num_triangles(), 1280);
    for format in [PlyFormat::Ascii, PlyFormat::BinaryLittleEndian, PlyFormat::BinaryBigEndian] {
        let path = dir.path().join("full.ply");
        write_ply(&path, &mesh, &PlyWriteOptions::default().with_format(format)).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let text = String::from_utf8_lossy(&bytes);
        let header_end = text.find("end_header").unwrap();
        let face_line = text[..header_end].lines().position(|l| l.starts_with("element face")).unwrap() + 1;
        let cut = |from: &str, to: &str| {
            let mut b = bytes.clone();
            let at = b.windows(from.len()).position(|w| w == from.as_bytes()).unwrap();
            b.splice(at..at + from.len(), to.bytes());
            b
        };
        let e = error_for("faces.ply", &cut("element face 1280", "element face 1230"));
        assert!(
            e.contains("declares 1230 face records but the body holds 1280 (50 more")
                && e.contains(&format!("header line {face_line}")),
            "{format:?}: {e}"
        );
        // Data that is not whole records is still an error, not a silent drop.
        let mut junk = bytes.clone();
        junk.extend_from_slice(b"\x01\x02\x03garbage\n");
        let e = error_for("junk.ply", &junk);
        assert!(e.contains("past the 1280 face records"), "{format:?}: {e}");
        // A final line end after binary data is not data.
        let mut newline = bytes.clone();
        newline.push(b'\n');
        let dir2 = tempfile::tempdir().unwrap();
        let p = dir2.path().join("nl.ply");
        std::fs::write(&p, &newline).unwrap();
        assert_eq!(read_ply(&p).unwrap().num_triangles(), 1280, "{format:?}");
    }
    // Vertices: a point cloud whose header declares fewer vertices than it holds.
    let e = error_for(
        "cloud.ply",
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n\n",
    );
    assert!(e.contains("declares 1 vertex records but the body holds 2"), "{e}");
}
