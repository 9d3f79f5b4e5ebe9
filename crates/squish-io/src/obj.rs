//! Wavefront OBJ: a small reader and writer for triangle and polygon meshes.
//!
//! Reading keeps the file's vertices exactly, in order and in number (`v` lines), including
//! vertices no face uses: vertex ids must stay stable across the frames of an animation exported
//! one OBJ per frame. Polygons are fan-triangulated (`[v0, vi, vi+1]`), which keeps their
//! orientation. Texture coordinates, normals, groups, objects, materials and smoothing groups
//! are accepted and ignored, as are statements this reader does not know (curves, `l` lines,
//! points). Face corners may be `v`, `v/vt`, `v//vn` or `v/vt/vn`; positive indices count from 1,
//! negative ones back from the last vertex defined *before* the face (OBJ's relative indices).
//! Positive indices are checked against the whole file, so faces may precede their vertices, as
//! some exporters write them.
//!
//! Writing prints coordinates with Rust's shortest round-trip formatting, so reading a written
//! file gives back exactly the same `f64` values.

use std::io::Write;
use std::path::Path;

use glam::DVec3;
use squish::TriMesh;

use crate::{IoError, write_atomically};

/// Reads an OBJ file into a triangle mesh (see the module documentation for what is kept).
pub fn read_obj(path: &Path) -> Result<TriMesh, IoError> {
    let bytes = std::fs::read(path).map_err(|e| IoError::io(path, "open", e))?;
    parse_obj(path, &bytes)
}

/// Parses OBJ text; `path` only names the file in errors.
pub fn parse_obj(path: &Path, bytes: &[u8]) -> Result<TriMesh, IoError> {
    let mut positions: Vec<DVec3> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    // Line of each triangle, to name it if a positive index turns out out of range at the end.
    let mut triangle_lines: Vec<u32> = Vec::new();
    let mut corners: Vec<i64> = Vec::new();
    let mut faces = 0usize;

    let mut lines = LogicalLines::new(bytes);
    while let Some((line_no, line)) = lines.next() {
        let line = String::from_utf8_lossy(&line);
        let content = line.split('#').next().unwrap_or("");
        let mut tokens = content.split_whitespace();
        let Some(keyword) = tokens.next() else { continue };
        match keyword {
            "v" => {
                let mut xyz = [0.0f64; 3];
                for (axis, value) in xyz.iter_mut().enumerate() {
                    let name = ["x", "y", "z"][axis];
                    let Some(token) = tokens.next() else {
                        return Err(IoError::line(
                            path,
                            line_no,
                            format!(
                                "vertex {} has no {name} coordinate; a 'v' line needs three numbers (the file may be truncated)",
                                positions.len() + 1
                            ),
                        ));
                    };
                    *value = token.parse::<f64>().map_err(|_| {
                        IoError::line(
                            path,
                            line_no,
                            format!("malformed number '{token}' for the {name} coordinate of vertex {}; expected a decimal number such as -1.25 or 3e-2", positions.len() + 1),
                        )
                    })?;
                    if !value.is_finite() {
                        return Err(IoError::line(
                            path,
                            line_no,
                            format!(
                                "vertex {} has a non-finite {name} coordinate ({token}); every coordinate must be a finite number (fix the exporting tool or the modelling step that produced it)",
                                positions.len() + 1
                            ),
                        ));
                    }
                }
                // A fourth number (w) or vertex colours may follow; they are not positions.
                positions.push(DVec3::from_array(xyz));
            }
            "f" | "fo" => {
                corners.clear();
                for token in tokens {
                    let index_text = token.split('/').next().unwrap_or("");
                    let index: i64 = index_text.parse().map_err(|_| {
                        IoError::line(
                            path,
                            line_no,
                            format!("malformed vertex index '{token}' in face {}; corners are written v, v/vt, v//vn or v/vt/vn with whole numbers", faces + 1),
                        )
                    })?;
                    let resolved = if index > 0 {
                        index - 1
                    } else if index < 0 {
                        let r = positions.len() as i64 + index;
                        if r < 0 {
                            return Err(IoError::line(
                                path,
                                line_no,
                                format!(
                                    "relative index {index} in face {} points before the first vertex: only {} vertices are defined above this line",
                                    faces + 1,
                                    positions.len()
                                ),
                            ));
                        }
                        r
                    } else {
                        return Err(IoError::line(
                            path,
                            line_no,
                            format!(
                                "vertex index 0 in face {}; OBJ indices start at 1 (negative indices count back from the last vertex)",
                                faces + 1
                            ),
                        ));
                    };
                    if resolved > u32::MAX as i64 - 1 {
                        return Err(IoError::line(
                            path,
                            line_no,
                            format!("vertex index {index} in face {} is too large", faces + 1),
                        ));
                    }
                    corners.push(resolved);
                }
                if corners.len() < 3 {
                    return Err(IoError::line(
                        path,
                        line_no,
                        format!(
                            "face {} has {} vertices; a face needs at least 3 (the file may be truncated)",
                            faces + 1,
                            corners.len()
                        ),
                    ));
                }
                faces += 1;
                for i in 1..corners.len() - 1 {
                    triangles.push([corners[0] as u32, corners[i] as u32, corners[i + 1] as u32]);
                    triangle_lines.push(line_no.min(u32::MAX as usize) as u32);
                }
            }
            // Everything else (vt, vn, vp, o, g, s, usemtl, mtllib, l, p, curves…) does not
            // change the surface.
            _ => {}
        }
    }
    let n = positions.len();
    for (t, tri) in triangles.iter().enumerate() {
        if let Some(&bad) = tri.iter().find(|&&i| i as usize >= n) {
            return Err(IoError::line(
                path,
                triangle_lines[t] as usize,
                format!(
                    "face refers to vertex {} but the file defines only {n} vertices; the file may be truncated or the indices wrong",
                    bad as u64 + 1
                ),
            ));
        }
    }
    if triangles.is_empty() {
        return Err(IoError::format(
            path,
            format!(
                "no faces found ({n} vertices, 0 faces); a mesh needs 'f' lines — is this an OBJ mesh export (not a point cloud or curves)?"
            ),
        ));
    }
    TriMesh::new(positions, triangles).map_err(|e| IoError::mesh(path, e))
}

/// Lines joined across trailing backslashes (OBJ line continuation), with the number of the
/// first physical line.
struct LogicalLines<'a> {
    rest: &'a [u8],
    line: usize,
}

impl<'a> LogicalLines<'a> {
    fn new(bytes: &'a [u8]) -> Self {
        Self { rest: bytes, line: 0 }
    }

    fn next_physical(&mut self) -> Option<&'a [u8]> {
        if self.rest.is_empty() {
            return None;
        }
        self.line += 1;
        let end = self.rest.iter().position(|&b| b == b'\n').unwrap_or(self.rest.len());
        let mut line = &self.rest[..end];
        self.rest = self.rest.get(end + 1..).unwrap_or(&[]);
        if let Some(stripped) = line.strip_suffix(b"\r") {
            line = stripped;
        }
        Some(line)
    }

    fn next(&mut self) -> Option<(usize, Vec<u8>)> {
        let first = self.next_physical()?;
        let start = self.line;
        let mut joined = first.to_vec();
        while joined.last() == Some(&b'\\') {
            joined.pop();
            joined.push(b' ');
            match self.next_physical() {
                Some(more) => joined.extend_from_slice(more),
                None => break,
            }
        }
        Some((start, joined))
    }
}

/// Writes a mesh as OBJ (`v` and `f` lines, 1-based indices), atomically.
pub fn write_obj(path: &Path, mesh: &TriMesh) -> Result<(), IoError> {
    mesh.check_structure().map_err(|e| IoError::mesh(path, e))?;
    write_atomically(path, |w| write_obj_to(w, mesh))
}

fn write_obj_to(w: &mut dyn Write, mesh: &TriMesh) -> std::io::Result<()> {
    writeln!(w, "# Squish: {} vertices, {} triangles", mesh.num_vertices(), mesh.num_triangles())?;
    for p in &mesh.positions {
        writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
    }
    for [a, b, c] in &mesh.triangles {
        writeln!(w, "f {} {} {}", *a as u64 + 1, *b as u64 + 1, *c as u64 + 1)?;
    }
    Ok(())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use squish::mesh::shapes;

    fn parse(text: &str) -> Result<TriMesh, IoError> {
        parse_obj(Path::new("test.obj"), text.as_bytes())
    }

    #[test]
    fn polygons_relative_indices_and_attributes() {
        let mesh = parse(
            "# comment\nmtllib a.mtl\no thing\nv 0 0 0\nv 1 0 0\nv 1 1 0 1.0\nv 0 1 0 0.5 0.5 0.5\nvt 0 0\nvn 0 0 1\n\
             g group\nusemtl m\ns off\nf 1/1/1 2/1/1 3/1/1 4/1/1\nv 5 5 5\nf -5//1 -3//1 -2//1\n",
        )
        .unwrap();
        assert_eq!(mesh.num_vertices(), 5, "unused vertex 5 is kept");
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 2, 3]]);
    }

    #[test]
    fn continuation_lines_and_crlf() {
        let mesh = parse("v 0 0 0\r\nv 1 0 0\r\nv 0 \\\r\n 1 0\r\nf 1 2 \\\n3\n").unwrap();
        assert_eq!(mesh.positions[2], DVec3::new(0.0, 1.0, 0.0));
        assert_eq!(mesh.triangles, vec![[0, 1, 2]]);
    }

    #[test]
    fn forward_references_are_accepted() {
        let mesh = parse("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n").unwrap();
        assert_eq!(mesh.triangles, vec![[0, 1, 2]]);
    }

    fn err(text: &str) -> String {
        let e = parse(text).unwrap_err();
        let s = e.to_string();
        assert!(s.contains("test.obj"), "{s}");
        s
    }

    #[test]
    fn bad_inputs_give_located_errors() {
        let s = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n");
        assert!(s.contains("test.obj:4:") && s.contains("start at 1"), "{s}");
        let s = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
        assert!(s.contains("test.obj:4:") && s.contains("vertex 4") && s.contains("only 3"), "{s}");
        let s = err("v 0 0 0\nv 1 0 0\nf -3 -2 -1\nv 0 1 0\n");
        assert!(s.contains("test.obj:3:") && s.contains("relative index -3"), "{s}");
        let s = err("v 0 0 0\nv 1 0 0\nv 0 1.5.2 0\nf 1 2 3\n");
        assert!(s.contains("test.obj:3:") && s.contains("'1.5.2'") && s.contains("y coordinate"), "{s}");
        let s = err("v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n");
        assert!(s.contains("test.obj:2:") && s.contains("non-finite"), "{s}");
        let s = err("v 0 0 0\nv 1 0 0\nv 0 1 inf\nf 1 2 3\n");
        assert!(s.contains("test.obj:3:") && s.contains("non-finite"), "{s}");
        let s = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n");
        assert!(s.contains("test.obj:4:") && s.contains("malformed vertex index 'x'"), "{s}");
        // Truncated in the middle of a vertex line, then of a face line.
        let s = err("v 0 0 0\nv 1 0 0\nv 0 1");
        assert!(s.contains("test.obj:3:") && s.contains("no z coordinate"), "{s}");
        let s = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2");
        assert!(s.contains("test.obj:4:") && s.contains("at least 3"), "{s}");
        // Empty.
        let s = err("");
        assert!(s.contains("no faces"), "{s}");
        let s = err("v 0 0 0\n");
        assert!(s.contains("no faces"), "{s}");
    }

    #[test]
    fn round_trip_is_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sphere.obj");
        let mut mesh = shapes::icosphere(1.0 / 3.0, 2);
        // Awkward values: tiny, huge, negative zero, not representable in decimal.
        mesh.positions[0] = DVec3::new(1e-300, -0.0, 1.0 / 7.0);
        mesh.positions[1] = DVec3::new(1.7976931348623157e308, f64::MIN_POSITIVE, -2.5e-8);
        write_obj(&path, &mesh).unwrap();
        let back = read_obj(&path).unwrap();
        assert_eq!(back.triangles, mesh.triangles);
        for (a, b) in back.positions.iter().zip(&mesh.positions) {
            assert_eq!(a.to_array().map(f64::to_bits), b.to_array().map(f64::to_bits));
        }
    }

    #[test]
    fn missing_file_names_the_path() {
        let e = read_obj(Path::new("/definitely/not/here.obj")).unwrap_err();
        let s = e.to_string();
        assert!(s.contains("/definitely/not/here.obj") && s.contains("check the path"), "{s}");
        assert!(matches!(e, IoError::Io { .. }));
    }
}
