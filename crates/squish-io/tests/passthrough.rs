//! Issue 23: results go back into the asset they came from. Each format is read as a document,
//! written back with new positions, and everything but positions and normals is compared with
//! the input (attribute arrays, indices, material and skin references); glTF outputs are also
//! opened by the `gltf` crate (validation and its own accessor readers), an independent reader.
//! Procedural inputs run everywhere; the shared characters skip when ../shared/data is absent.

#![allow(clippy::unwrap_used)]

mod common;

use std::path::{Path, PathBuf};

use common::{F32, Fixture, U32, bending_cylinder, shared_data};
use glam::DVec3;
use serde_json::{Value, json};
use squish::mesh::shapes;
use squish_io::*;

/// A smooth displacement that moves every vertex differently (a stand-in for a deformation).
fn deform(positions: &[DVec3]) -> Vec<DVec3> {
    positions.iter().map(|p| *p + 0.05 * DVec3::new((3.0 * p.y).sin(), (2.0 * p.z).cos(), (2.5 * p.x).sin())).collect()
}

// ------------------------------------------------------------------------------------------
// OBJ

/// A cube with UVs (a seam: corners with one position and two UVs), hard-edged normals shared
/// per face, materials, groups, smoothing groups, comments, CRLF endings and vertex colours.
const CUBE_OBJ: &str = "# a textured cube\r\nmtllib cube.mtl\r\no Cube\r\n\
v -1 -1 -1 0.5 0.5 0.5\r\nv 1 -1 -1\r\nv 1 1 -1\r\nv -1 1 -1\r\nv -1 -1 1\r\nv 1 -1 1\r\nv 1 1 1\r\nv -1 1 1\r\n\
vt 0 0\r\nvt 1 0\r\nvt 1 1\r\nvt 0 1\r\nvt 0.5 0.5\r\n\
vn 0 0 -1\r\nvn 0 0 1\r\nvn 0 -1 0\r\nvn 0 1 0\r\nvn -1 0 0\r\nvn 1 0 0\r\n\
g sides\r\nusemtl red\r\ns off\r\n\
f 1/1/1 4/4/1 3/3/1 2/2/1\r\nf 5/1/2 6/2/2 7/3/2 8/4/2\r\nf 1/1/3 2/2/3 6/3/3 5/4/3\r\n\
usemtl blue\r\ns 1\r\nf 4/1/4 8/4/4 7/3/4 3/2/4\r\nf 1/5/5 5/2/5 8/3/5 4/4/5\r\nf 2/1/6 3/2/6 7/3/6 6/4/6\r\n";

fn non_vertex_lines(text: &str) -> Vec<&str> {
    text.split_inclusive('\n').filter(|l| !l.starts_with("v ") && !l.starts_with("vn ")).collect()
}

#[test]
fn obj_keeps_everything_but_positions_and_normals() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("cube.obj");
    std::fs::write(&input, CUBE_OBJ).unwrap();
    let doc = ObjDocument::read(&input).unwrap();
    let moved: Vec<DVec3> = doc.mesh().positions.iter().map(|p| *p * DVec3::new(2.0, 1.0, 0.5)).collect();
    let output = dir.path().join("out.obj");
    doc.write_with_positions(&output, &moved).unwrap();
    let text = std::fs::read_to_string(&output).unwrap();
    // Every line but v and vn is the input's, byte for byte (CRLF included), in order.
    assert_eq!(non_vertex_lines(&text), non_vertex_lines(CUBE_OBJ));
    let back = ObjDocument::read(&output).unwrap();
    assert_eq!(back.mesh().positions, moved);
    assert_eq!(back.mesh().triangles, doc.mesh().triangles);
    assert_eq!(back.faces(), doc.faces(), "face corners (v and vn indices)");
    assert_eq!(back.attribute_counts(), doc.attribute_counts());
    assert_eq!(back.attribute_counts().texcoords, 5);
    assert_eq!(back.attribute_counts().materials, 2);
    // The vertex colours after the first vertex's coordinates are kept.
    assert!(text.contains("v -2 -1 -0.5 0.5 0.5 0.5\r\n"), "{text}");
    // A scaled cube keeps its axis-aligned face normals.
    for (n, expected) in back.normals().iter().zip(doc.normals()) {
        assert!((*n - *expected).length() < 1e-12, "{n} vs {expected}");
    }
}

#[test]
fn obj_normals_follow_the_deformed_faces_that_use_them() {
    // A sphere with one normal per vertex (`v//vn` with the same index): after deformation
    // each normal is the area-weighted vertex normal of the deformed sphere.
    let sphere = shapes::icosphere(1.0, 2);
    let mut text = String::new();
    for p in &sphere.positions {
        text += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    for p in &sphere.positions {
        text += &format!("vn {} {} {}\n", p.x, p.y, p.z);
    }
    for [a, b, c] in &sphere.triangles {
        text += &format!("f {0}//{0} {1}//{1} {2}//{2}\n", a + 1, b + 1, c + 1);
    }
    let doc = ObjDocument::parse(Path::new("sphere.obj"), text.as_bytes()).unwrap();
    let moved = deform(&sphere.positions);
    let normals = doc.recomputed_normals(&moved);
    let expected = squish::mesh::vertex_normals(&squish::TriMesh { positions: moved, triangles: sphere.triangles });
    for (n, e) in normals.iter().zip(&expected) {
        assert!((*n - *e).length() < 1e-12);
    }
}

#[test]
fn obj_out_of_range_texture_and_normal_indices_are_located_errors() {
    let base = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n";
    let err = |face: &str| {
        ObjDocument::parse(Path::new("bad.obj"), format!("{base}{face}\n").as_bytes()).unwrap_err().to_string()
    };
    let e = err("f 1/1 2/2 3/1");
    assert!(e.contains("bad.obj:6:") && e.contains("texture coordinate 2") && e.contains("only 1 ('vt' lines)"), "{e}");
    let e = err("f 1//1 2//1 3//7");
    assert!(e.contains("bad.obj:6:") && e.contains("normal 7") && e.contains("only 1"), "{e}");
    let e = err("f 1/-2 2/1 3/1");
    assert!(e.contains("relative index -2") && e.contains("texture coordinate"), "{e}");
    let e = err("f 1/0 2/1 3/1");
    assert!(e.contains("texture coordinate index 0"), "{e}");
}

#[test]
fn spot_keeps_its_texture_coordinates() {
    let Some(spot) = shared_data("meshes/spot_2930.obj") else { return };
    let doc = ObjDocument::read(&spot).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("spot.obj");
    doc.write_with_positions(&output, &deform(&doc.mesh().positions)).unwrap();
    let back = ObjDocument::read(&output).unwrap();
    assert_eq!(back.attribute_counts().texcoords, 3225);
    assert_eq!(back.faces(), doc.faces());
    let (a, b) = (std::fs::read_to_string(&spot).unwrap(), std::fs::read_to_string(&output).unwrap());
    assert_eq!(non_vertex_lines(&a), non_vertex_lines(&b));
}

// ------------------------------------------------------------------------------------------
// PLY

/// A tetrahedron with normals, colours, a custom scalar, a second list on the faces and an
/// extra element, in `format`.
fn rich_ply(format: &str) -> Vec<u8> {
    let positions = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let faces: [[i32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
    let header = format!(
        "ply\nformat {format} 1.0\ncomment made by hand\nobj_info custom\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
         property double temperature\nproperty float u\nproperty float v\nelement face 4\nproperty list uchar int vertex_indices\n\
         property list uchar float texcoord\nelement edge 2\nproperty int vertex1\nproperty int vertex2\nproperty uchar crease\nend_header\n"
    );
    let mut out = header.into_bytes();
    let big = format == "binary_big_endian";
    let put = |out: &mut Vec<u8>, bytes: Vec<u8>| {
        if big {
            out.extend(bytes.iter().rev());
        } else {
            out.extend(bytes);
        }
    };
    for (i, p) in positions.iter().enumerate() {
        let n = DVec3::from_array(*p).normalize_or_zero();
        let floats = [p[0], p[1], p[2], n.x, n.y, n.z];
        let rgb = [10 * i as u8, 200, 255 - i as u8];
        let temperature = 20.5 + i as f64 / 3.0;
        let uv = [i as f32 / 4.0, 1.0 - i as f32 / 8.0];
        if format == "ascii" {
            let f: Vec<String> = floats.iter().map(|x| format!("{}", *x as f32)).collect();
            out.extend(
                format!("{} {} {} {} {temperature} {} {}\n", f.join(" "), rgb[0], rgb[1], rgb[2], uv[0], uv[1]).bytes(),
            );
        } else {
            for x in floats {
                put(&mut out, (x as f32).to_le_bytes().to_vec());
            }
            out.extend(rgb);
            put(&mut out, temperature.to_le_bytes().to_vec());
            for x in uv {
                put(&mut out, x.to_le_bytes().to_vec());
            }
        }
    }
    for f in faces {
        if format == "ascii" {
            out.extend(format!("3 {} {} {} 2 0.25 0.75\n", f[0], f[1], f[2]).bytes());
        } else {
            out.push(3);
            for i in f {
                put(&mut out, i.to_le_bytes().to_vec());
            }
            out.push(2);
            for x in [0.25f32, 0.75] {
                put(&mut out, x.to_le_bytes().to_vec());
            }
        }
    }
    for (a, b, c) in [(0i32, 1i32, 7u8), (2, 3, 9)] {
        if format == "ascii" {
            out.extend(format!("{a} {b} {c}\n").bytes());
        } else {
            put(&mut out, a.to_le_bytes().to_vec());
            put(&mut out, b.to_le_bytes().to_vec());
            out.push(c);
        }
    }
    out
}

#[test]
fn ply_keeps_every_element_and_property_in_its_encoding() {
    let dir = tempfile::tempdir().unwrap();
    for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
        let input = dir.path().join(format!("{format}.ply"));
        std::fs::write(&input, rich_ply(format)).unwrap();
        let doc = PlyDocument::read(&input).unwrap();
        let mesh = doc.mesh().unwrap();
        let moved: Vec<DVec3> = mesh.positions.iter().map(|p| *p * 2.0 + DVec3::new(0.5, 0.0, 0.0)).collect();
        let output = dir.path().join(format!("{format}_out.ply"));
        doc.write_with_positions(&output, &moved).unwrap();
        // The header is the input's, byte for byte: same encoding, elements and comments.
        let (a, b) = (std::fs::read(&input).unwrap(), std::fs::read(&output).unwrap());
        let end = |bytes: &[u8]| bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        assert_eq!(a[..end(&a)], b[..end(&b)], "{format}");
        let back = PlyDocument::read(&output).unwrap();
        assert_eq!(back.format(), doc.format());
        assert_eq!(back.elements.len(), 3);
        for (x, y) in back.elements.iter().zip(&doc.elements) {
            assert_eq!((&x.name, x.count), (&y.name, y.count));
            for (p, q) in x.properties.iter().zip(&y.properties) {
                assert_eq!(p.name, q.name);
                if ["x", "y", "z", "nx", "ny", "nz"].contains(&p.name.as_str()) {
                    continue;
                }
                assert_eq!(p.values, q.values, "{format}: {} {}", x.name, p.name);
            }
        }
        let data = back.data();
        assert_eq!(data.positions, moved.iter().map(|p| p.as_vec3().as_dvec3()).collect::<Vec<_>>());
        // Normals are recomputed: a scaled, moved tetrahedron keeps its vertex normals' directions.
        let normal = |d: &PlyData, v: usize| {
            DVec3::new(
                d.property("nx").unwrap().values[v],
                d.property("ny").unwrap().values[v],
                d.property("nz").unwrap().values[v],
            )
        };
        let expected = squish::mesh::vertex_normals(&squish::TriMesh {
            positions: moved.clone(),
            triangles: mesh.triangles.clone(),
        });
        for (v, e) in expected.iter().enumerate() {
            assert!((normal(&data, v) - *e).length() < 1e-6, "{format} vertex {v}");
        }
        assert_eq!(data.colors(), doc.data().colors());
    }
}

// ------------------------------------------------------------------------------------------
// glTF

/// Opens a written glTF with the `gltf` crate (JSON validation) and reads its buffers.
fn open_with_gltf_crate(path: &Path) -> (gltf::Document, Vec<Vec<u8>>) {
    let bytes = std::fs::read(path).unwrap();
    let gltf = gltf::Gltf::from_slice(&bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut buffers = Vec::new();
    for buffer in gltf.document.buffers() {
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => gltf.blob.clone().unwrap(),
            gltf::buffer::Source::Uri(uri) => match uri.strip_prefix("data:application/octet-stream;base64,") {
                Some(b64) => {
                    use base64::Engine as _;
                    base64::engine::general_purpose::STANDARD.decode(b64).unwrap()
                }
                None => std::fs::read(path.parent().unwrap().join(uri.replace("%20", " "))).unwrap(),
            },
        };
        assert!(data.len() >= buffer.length());
        buffers.push(data);
    }
    (gltf.document, buffers)
}

/// Everything the `gltf` crate reads of each primitive except positions, normals and tangents.
#[derive(Debug, PartialEq)]
struct PrimitiveData {
    indices: Option<Vec<u32>>,
    uvs: Vec<Vec<[f32; 2]>>,
    colors: Vec<Vec<[f32; 4]>>,
    joints: Option<Vec<[u16; 4]>>,
    weights: Option<Vec<[f32; 4]>>,
    material: Option<usize>,
    vertices: usize,
}

fn primitive_data(path: &Path) -> Vec<PrimitiveData> {
    let (document, buffers) = open_with_gltf_crate(path);
    let mut out = Vec::new();
    for mesh in document.meshes() {
        for primitive in mesh.primitives() {
            let reader = primitive.reader(|b| Some(&buffers[b.index()]));
            let uvs = (0..4).filter_map(|s| reader.read_tex_coords(s).map(|t| t.into_f32().collect())).collect();
            let colors = (0..4).filter_map(|s| reader.read_colors(s).map(|c| c.into_rgba_f32().collect())).collect();
            out.push(PrimitiveData {
                indices: reader.read_indices().map(|i| i.into_u32().collect()),
                uvs,
                colors,
                joints: reader.read_joints(0).map(|j| j.into_u16().collect()),
                weights: reader.read_weights(0).map(|w| w.into_f32().collect()),
                material: primitive.material().index(),
                vertices: reader.read_positions().map_or(0, |p| p.count()),
            });
        }
    }
    out
}

/// The JSON of a glTF file (GLB or not).
fn json_of(path: &Path) -> Value {
    let bytes = std::fs::read(path).unwrap();
    let gltf = gltf::Gltf::from_slice(&bytes).unwrap();
    serde_json::to_value(gltf.document.into_json()).unwrap()
}

/// The parts of the JSON that writing positions must not touch.
const KEPT: &[&str] = &[
    "asset",
    "scene",
    "scenes",
    "nodes",
    "skins",
    "materials",
    "textures",
    "samplers",
    "cameras",
    "animations",
    "extensionsUsed",
];

fn assert_round_trip(input: &Path, output: &Path, positions: &[DVec3]) {
    let (a, b) = (json_of(input), json_of(output));
    for key in KEPT {
        assert_eq!(a.get(key), b.get(key), "{}: '{key}' changed", input.display());
    }
    // Meshes: only attribute accessor ids may change (repointed to new data).
    let strip = |v: &Value| {
        let mut v = v.clone();
        for mesh in v["meshes"].as_array_mut().into_iter().flatten() {
            for p in mesh["primitives"].as_array_mut().into_iter().flatten() {
                for key in ["POSITION", "NORMAL", "TANGENT"] {
                    p["attributes"].as_object_mut().map(|o| o.remove(key));
                }
            }
        }
        v["meshes"].clone()
    };
    assert_eq!(strip(&a), strip(&b));
    assert_eq!(primitive_data(input), primitive_data(output), "{}", input.display());
    // Our reader, posing the output at rest, gives back the positions written (to f32).
    let back = GltfDocument::read(output).unwrap().mesh().unwrap();
    let scale = squish::mesh::bounding_box(&back).diagonal();
    let worst = back.positions.iter().zip(positions).map(|(p, q)| (*p - *q).length()).fold(0.0, f64::max);
    assert!(worst < 1e-6 * scale, "{}: {worst}", input.display());
}

/// The bending cylinder with texture coordinates, normals, a material with an embedded
/// texture, and an extension and extras the reader does not know.
fn textured_cylinder() -> Fixture {
    let mut f = bending_cylinder(9, 12, |x| if x < 0.0 { ([0.0, 1.0], [1.0, 0.0]) } else { ([1.0, 0.0], [0.8, 0.2]) });
    let n = 9 * 12 + 2;
    let position = f.root["meshes"][0]["primitives"][0]["attributes"]["POSITION"].as_u64().unwrap() as usize;
    let _ = position;
    let uv: Vec<f64> = (0..n).flat_map(|v| [v as f64 / n as f64, (v % 7) as f64 / 7.0]).collect();
    let uv = f.accessor(F32, "VEC2", &uv);
    let normals: Vec<f64> = (0..n).flat_map(|v| if v < n - 2 { [0.0, 0.0, 1.0] } else { [1.0, 0.0, 0.0] }).collect();
    let normals = f.accessor(F32, "VEC3", &normals);
    let attributes = &mut f.root["meshes"][0]["primitives"][0]["attributes"];
    attributes["TEXCOORD_0"] = json!(uv);
    attributes["NORMAL"] = json!(normals);
    f.root["meshes"][0]["primitives"][0]["material"] = json!(0);
    f.root["materials"] = json!([{ "name": "skin", "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } }, "extras": { "studio": "x" } }]);
    f.root["textures"] = json!([{ "source": 0, "sampler": 0 }]);
    f.root["samplers"] = json!([{ "magFilter": 9729 }]);
    // A 1×1 PNG.
    f.root["images"] = json!([{ "uri": "data:image/png;base64,iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mP8z8BQDwAEhQGAhKmMIQAAAABJRU5ErkJggg==" }]);
    f.root["extensionsUsed"] = json!(["EXT_squish_test"]);
    f.root["nodes"][0]["extensions"] = json!({ "EXT_squish_test": { "kept": true } });
    f.root["nodes"][0]["extras"] = json!({ "rig": "v2" });
    let _ = U32;
    f
}

/// A glTF asset written as OBJ or PLY carries what those formats hold of it: its first UV set
/// (in their convention, v = 1 − glTF's v) and normals recomputed for the new positions.
#[test]
fn gltf_written_as_obj_or_ply_keeps_its_uvs_and_normals() {
    let dir = tempfile::tempdir().unwrap();
    let input = textured_cylinder().write_glb(dir.path(), "cylinder");
    let document = MeshDocument::read(&input).unwrap();
    let rest = document.mesh().unwrap();
    let moved = deform(&rest.positions);
    let n = rest.num_vertices();
    // The fixture's UVs, as f32 in the file.
    let uv = |v: usize| [(v as f64 / n as f64) as f32 as f64, 1.0 - ((v % 7) as f64 / 7.0) as f32 as f64];
    // Unit normals, which on the rings between the rims (9 rings of 12) point away from the
    // cylinder's axis (x); the rims' lean over the caps.
    let radial = |v: usize, normal: DVec3| {
        let p = moved[v];
        let away = DVec3::new(0.0, p.y, p.z).normalize_or_zero();
        (normal.length() - 1.0).abs() < 1e-6 && (!(12..8 * 12).contains(&v) || normal.dot(away) > 0.8)
    };

    let obj = dir.path().join("cylinder.obj");
    document.write_with_positions(&obj, &moved).unwrap();
    let back = ObjDocument::read(&obj).unwrap();
    assert_eq!(back.mesh().positions, moved);
    assert_eq!(back.mesh().triangles, rest.triangles);
    let (texcoords, corners) = back.texcoords();
    assert_eq!(texcoords.len(), n);
    for (v, t) in texcoords.iter().enumerate() {
        assert_eq!(*t, uv(v), "vt of vertex {v}");
    }
    for (face, vt) in back.faces().iter().zip(corners) {
        for ((vertex, vn), t) in face.iter().zip(vt) {
            assert_eq!((Some(*vertex), *vn), (*t, Some(*vertex)), "corners name the vertex's own vt and vn");
        }
    }
    assert_eq!(back.normals().len(), n);
    for (v, normal) in back.normals().iter().enumerate() {
        assert!(radial(v, *normal), "vertex {v} at {}: normal {normal}", moved[v]);
    }

    let ply = dir.path().join("cylinder.ply");
    document.write_with_positions(&ply, &moved).unwrap();
    let data = read_ply_data(&ply).unwrap();
    assert_eq!((data.positions.as_slice(), data.triangles.as_slice()), (moved.as_slice(), rest.triangles.as_slice()));
    let column = |name: &str| data.property(name).unwrap_or_else(|| panic!("no {name}")).values.clone();
    let (u, v) = (column("u"), column("v"));
    for k in 0..n {
        assert!((u[k] - uv(k)[0]).abs() < 1e-7 && (v[k] - uv(k)[1]).abs() < 1e-7, "u, v of vertex {k}");
        let normal = DVec3::new(column("nx")[k], column("ny")[k], column("nz")[k]);
        // Stored as f32.
        assert!(radial(k, normal.normalize()) && (normal.length() - 1.0).abs() < 1e-6, "vertex {k}: normal {normal}");
    }
}

#[test]
fn gltf_keeps_the_document_procedural() {
    let dir = tempfile::tempdir().unwrap();
    let fixture = textured_cylinder();
    let inputs = [fixture.write_glb(dir.path(), "cylinder"), fixture.write_gltf_embedded(dir.path(), "embedded")];
    for input in &inputs {
        let doc = GltfDocument::read(input).unwrap();
        let moved = deform(&doc.mesh().unwrap().positions);
        for ext in ["glb", "gltf"] {
            let output = dir.path().join(format!("out_{}.{ext}", input.file_stem().unwrap().to_string_lossy()));
            doc.write_with_positions(&output, &moved).unwrap();
            assert_round_trip(input, &output, &moved);
        }
        let counts = doc.attribute_counts();
        assert_eq!((counts.uv_sets, counts.primitives_with_normals, counts.skins, counts.materials), (1, 1, 1, 1));
    }
}

#[test]
fn gltf_with_external_buffers_writes_its_buffer_next_to_it() {
    let dir = tempfile::tempdir().unwrap();
    let input = textured_cylinder().write_gltf_external(dir.path(), "external", "my data.bin");
    let doc = GltfDocument::read(&input).unwrap();
    let moved = deform(&doc.mesh().unwrap().positions);
    let out_dir = dir.path().join("out");
    std::fs::create_dir(&out_dir).unwrap();
    let output = out_dir.join("result.gltf");
    doc.write_with_positions(&output, &moved).unwrap();
    assert!(out_dir.join("result.bin").is_file());
    assert_round_trip(&input, &output, &moved);
}

#[test]
fn gltf_attribute_counts_that_differ_are_located_errors() {
    let dir = tempfile::tempdir().unwrap();
    let mut f = textured_cylinder();
    let short = f.accessor(F32, "VEC2", &[0.0; 10]);
    f.root["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(short);
    let path = f.write_glb(dir.path(), "short");
    let err = GltfDocument::read(&path).unwrap_err().to_string();
    assert!(
        err.contains(&format!("accessor {short}")) && err.contains("TEXCOORD_0") && err.contains("5 elements"),
        "{err}"
    );
    assert!(err.contains("one element per vertex"), "{err}");
}

/// A glTF of one mesh with positions, normals and triangles.
fn mesh_with_normals(positions: &[DVec3], normals: &[DVec3], triangles: &[[u32; 3]]) -> Fixture {
    let mut f = Fixture::new();
    let pos = f.accessor(F32, "VEC3", &positions.iter().flat_map(|p| p.to_array()).collect::<Vec<_>>());
    let nrm = f.accessor(F32, "VEC3", &normals.iter().flat_map(|p| p.to_array()).collect::<Vec<_>>());
    let idx = f.accessor(U32, "SCALAR", &triangles.iter().flatten().map(|&i| i as f64).collect::<Vec<_>>());
    f.root = json!({
        "scenes": [{ "nodes": [0] }], "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": pos, "NORMAL": nrm }, "indices": idx }] }],
    });
    f
}

/// Seam copies (one position, equal input normals) get one normal; hard-edge copies (one
/// position, different input normals) keep one normal per side.
#[test]
fn gltf_normals_keep_the_input_splits() {
    let sphere = shapes::icosphere(1.0, 2);
    // Split the sphere along the plane x = 0: vertices used on both sides are duplicated.
    let mut positions: Vec<DVec3> = sphere.positions.clone();
    let mut copy_of: std::collections::HashMap<u32, u32> = Default::default();
    let mut triangles = Vec::new();
    for t in &sphere.triangles {
        let centre = t.iter().map(|&v| sphere.positions[v as usize]).sum::<DVec3>() / 3.0;
        if centre.x > 0.0 {
            triangles.push(t.map(|v| {
                *copy_of.entry(v).or_insert_with(|| {
                    positions.push(sphere.positions[v as usize]);
                    positions.len() as u32 - 1
                })
            }));
        } else {
            triangles.push(*t);
        }
    }
    let normals: Vec<DVec3> = positions.iter().map(|p| p.normalize()).collect();
    let f = mesh_with_normals(&positions, &normals, &triangles);
    let dir = tempfile::tempdir().unwrap();
    let input = f.write_glb(dir.path(), "seams");
    let doc = GltfDocument::read(&input).unwrap();
    let moved = deform(&doc.mesh().unwrap().positions);
    let output = dir.path().join("out.glb");
    doc.write_with_positions(&output, &moved).unwrap();
    let back = GltfDocument::read(&output).unwrap();
    let new_normals = back.scene().meshes[0].normals.clone().unwrap();
    assert!(!copy_of.is_empty());
    for (&original, &copy) in &copy_of {
        let (a, b) = (new_normals[original as usize], new_normals[copy as usize]);
        assert!((a - b).length() < 1e-6, "seam at vertex {original}: {a} vs {b}");
    }
    // The shared normal is the welded vertex normal of the deformed sphere.
    let welded = squish::mesh::vertex_normals(&squish::TriMesh {
        positions: deform(&sphere.positions),
        triangles: sphere.triangles.clone(),
    });
    for v in 0..sphere.positions.len() {
        assert!((new_normals[v] - welded[v]).length() < 1e-5, "vertex {v}");
    }

    // A cube with 24 vertices (one normal per face): each copy keeps its own face's normal.
    let cube = shapes::cuboid(DVec3::ONE, 1);
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut triangles = Vec::new();
    for t in &cube.triangles {
        let [a, b, c] = t.map(|v| cube.positions[v as usize]);
        let n = (b - a).cross(c - a).normalize();
        for p in [a, b, c] {
            positions.push(p);
            normals.push(n);
        }
        let k = positions.len() as u32;
        triangles.push([k - 3, k - 2, k - 1]);
    }
    let f = mesh_with_normals(&positions, &normals, &triangles);
    let input = f.write_glb(dir.path(), "cube");
    let doc = GltfDocument::read(&input).unwrap();
    let moved: Vec<DVec3> = doc.mesh().unwrap().positions.iter().map(|p| *p * DVec3::new(1.0, 2.0, 3.0)).collect();
    let output = dir.path().join("cube_out.glb");
    doc.write_with_positions(&output, &moved).unwrap();
    let back = GltfDocument::read(&output).unwrap();
    for (n, old) in back.scene().meshes[0].normals.as_ref().unwrap().iter().zip(&normals) {
        assert!((*n - *old).length() < 1e-6, "a scaled cube keeps its face normals: {n} vs {old}");
    }
}

fn shared_characters() -> Vec<PathBuf> {
    ["rigged/CesiumMan.glb", "rigged/Fox.glb", "rigged/RiggedSimple.glb"]
        .iter()
        .filter_map(|f| shared_data(f))
        .collect()
}

#[test]
fn shared_characters_keep_their_documents() {
    let dir = tempfile::tempdir().unwrap();
    for input in shared_characters() {
        let doc = GltfDocument::read(&input).unwrap();
        let moved = deform(&doc.mesh().unwrap().positions);
        for ext in ["glb", "gltf"] {
            let output = dir.path().join(format!("{}.{ext}", input.file_stem().unwrap().to_string_lossy()));
            doc.write_with_positions(&output, &moved).unwrap();
            assert_round_trip(&input, &output, &moved);
        }
    }
}

/// The deformation of a shot as morph targets: re-posing the output with its animation at each
/// frame's time gives back the deformed posed positions; the frames read back from the file are
/// the ones written, bit for bit.
fn check_morph_animation(input: &Path, animation: Option<usize>, times: &[f64]) {
    let doc = GltfDocument::read(input).unwrap();
    let scene = doc.scene();
    let node = scene.instances()[0].node;
    let frames: Vec<Vec<DVec3>> =
        times.iter().map(|&t| deform(&scene.posed_mesh(node, animation, t).unwrap().positions)).collect();
    let morphs: Vec<MorphFrame> = times
        .iter()
        .zip(&frames)
        .enumerate()
        .map(|(k, (&time, posed))| MorphFrame {
            name: format!("frame_{k:04}"),
            time,
            displacement: doc.morph_displacement(node, animation, time, posed, &vec![true; posed.len()]).unwrap(),
        })
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("animated.glb");
    doc.write_animated(&output, &MorphAnimation { node, animation, frames: &morphs, keys: MorphKeys::default() })
        .unwrap();
    let _ = open_with_gltf_crate(&output);
    let back = GltfDocument::read(&output).unwrap();
    let back_scene = back.scene();
    let animation_out = animation.or(Some(back_scene.animations.len() - 1));
    let mut worst: f64 = 0.0;
    for (k, &t) in times.iter().enumerate() {
        // The file keys the frames at f32 times: a player evaluates them there.
        let posed = back_scene.posed_mesh(node, animation_out, t as f32 as f64).unwrap();
        for (p, q) in posed.positions.iter().zip(&frames[k]) {
            worst = worst.max((*p - *q).length());
        }
    }
    let scale = squish::mesh::bounding_box(&doc.mesh().unwrap()).diagonal();
    assert!(worst < 2e-6 * scale.max(1.0), "{}: re-posed within {worst} (scale {scale})", input.display());
    let read: Vec<(String, SparseDisplacement)> = doc.shot_frames(&output, node).unwrap();
    assert_eq!(read.len(), morphs.len());
    for (m, (name, displacement)) in morphs.iter().zip(&read) {
        assert_eq!((&m.name, &m.displacement), (name, displacement));
    }
    // Materials, skins and the original channels are still there.
    let (a, b) = (json_of(input), json_of(&output));
    for key in ["skins", "materials", "textures", "images", "scenes"] {
        assert_eq!(a.get(key), b.get(key), "{key}");
    }
    if let Some(a_index) = animation {
        let (ca, cb) = (&a["animations"][a_index]["channels"], &b["animations"][a_index]["channels"]);
        assert_eq!(ca.as_array().unwrap()[..], cb.as_array().unwrap()[..ca.as_array().unwrap().len()]);
    }
    assert_eq!(primitive_data(input).len(), primitive_data(&output).len());
}

/// Vertices that do not move get no displacement, and their normals none: the targets hold only
/// the vertices around the deformation, as sparse accessors.
#[test]
fn morph_targets_store_only_what_moves() {
    let dir = tempfile::tempdir().unwrap();
    let input = textured_cylinder().write_glb(dir.path(), "cylinder");
    let doc = GltfDocument::read(&input).unwrap();
    let scene = doc.scene();
    let node = scene.instances()[0].node;
    let posed = scene.posed_mesh(node, Some(0), 0.5).unwrap().positions;
    // A dent in a few vertices.
    let moved: Vec<bool> = (0..posed.len()).map(|v| v % 17 == 3).collect();
    let dented: Vec<DVec3> =
        posed.iter().zip(&moved).map(|(p, &m)| if m { *p + DVec3::new(0.0, 0.0, 0.01) } else { *p }).collect();
    let displacement = doc.morph_displacement(node, Some(0), 0.5, &dented, &moved).unwrap();
    let count = moved.iter().filter(|&&m| m).count();
    assert_eq!(displacement.indices.len(), count);
    let frame = MorphFrame { name: "dent".into(), time: 0.5, displacement };
    let output = dir.path().join("dented.glb");
    doc.write_animated(
        &output,
        &MorphAnimation { node, animation: Some(0), frames: &[frame], keys: MorphKeys::default() },
    )
    .unwrap();
    let json = json_of(&output);
    let target = &json["meshes"][0]["primitives"][0]["targets"][0];
    let position = &json["accessors"][target["POSITION"].as_u64().unwrap() as usize];
    assert_eq!(position["sparse"]["count"], count);
    assert!(position.get("bufferView").is_none());
    let normal = &json["accessors"][target["NORMAL"].as_u64().unwrap() as usize];
    let changed = normal["sparse"]["count"].as_u64().unwrap() as usize;
    assert!(changed >= count && changed < posed.len() / 2, "{changed} normals change for {count} moved vertices");
    assert!(std::fs::metadata(&output).unwrap().len() < std::fs::metadata(&input).unwrap().len() * 3 / 2);
}

#[test]
fn morph_animation_reposes_to_the_deformed_frames_procedural() {
    let dir = tempfile::tempdir().unwrap();
    let input = textured_cylinder().write_glb(dir.path(), "cylinder");
    check_morph_animation(&input, Some(0), &[0.0, 0.25, 0.5, 0.75, 1.0]);
    check_morph_animation(&input, None, &[0.0, 1.0 / 24.0]);
}

#[test]
fn morph_animation_reposes_the_shared_characters() {
    for input in shared_characters() {
        let times: Vec<f64> = (0..6).map(|k| k as f64 / 12.0).collect();
        check_morph_animation(&input, Some(0), &times);
    }
}

#[test]
fn morph_animation_refuses_repeated_times() {
    let dir = tempfile::tempdir().unwrap();
    let input = textured_cylinder().write_glb(dir.path(), "cylinder");
    let doc = GltfDocument::read(&input).unwrap();
    let count = doc.mesh().unwrap().positions.len();
    let frame = |name: &str| MorphFrame {
        name: name.into(),
        time: 0.5,
        displacement: SparseDisplacement { count, ..Default::default() },
    };
    let frames = [frame("a"), frame("b")];
    let err = doc
        .write_animated(
            &dir.path().join("x.glb"),
            &MorphAnimation { node: 0, animation: Some(0), frames: &frames, keys: MorphKeys::default() },
        )
        .unwrap_err()
        .to_string();
    assert!(err.contains("increasing"), "{err}");
}
