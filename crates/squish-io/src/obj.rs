//! Wavefront OBJ: a reader that keeps the whole file, and writers.
//!
//! Reading keeps the file's vertices exactly, in order and in number (`v` lines), including
//! vertices no face uses: vertex ids must stay stable across the frames of an animation exported
//! one OBJ per frame. Polygons are fan-triangulated (`[v0, vi, vi+1]`), which keeps their
//! orientation. Face corners may be `v`, `v/vt`, `v//vn` or `v/vt/vn`; positive indices count
//! from 1, negative ones back from the last element defined *before* the face (OBJ's relative
//! indices). Positive indices are checked against the whole file, so faces may precede their
//! vertices, as some exporters write them; texture-coordinate and normal indices are checked
//! like vertex indices. Statements this reader does not know (curves, `l` lines, points) are
//! kept but do not change the surface.
//!
//! Pass-through ([`ObjDocument`]): the file is kept line by line, so that writing it back with
//! new positions changes only the `v` lines (anything after their three coordinates, such as
//! a `w` or vertex colours, is kept) and the `vn` lines (recomputed, see
//! [`ObjDocument::write_with_positions`]); texture coordinates, face corners, `mtllib`,
//! `usemtl`, `g`, `o`, `s`, comments and line endings are written as read.
//!
//! Writing prints coordinates with Rust's shortest round-trip formatting, so reading a written
//! file gives back exactly the same `f64` values.

use std::io::Write;
use std::path::{Path, PathBuf};

use glam::DVec3;
use squish::TriMesh;

use crate::{IoError, write_atomically};

/// Reads an OBJ file into a triangle mesh (see the module documentation for what is kept).
pub fn read_obj(path: &Path) -> Result<TriMesh, IoError> {
    Ok(ObjDocument::read(path)?.mesh)
}

/// Parses OBJ text; `path` only names the file in errors.
pub fn parse_obj(path: &Path, bytes: &[u8]) -> Result<TriMesh, IoError> {
    Ok(ObjDocument::parse(path, bytes)?.mesh)
}

/// An OBJ file kept whole for writing back: its logical lines, the mesh they describe and the
/// faces' normal indices.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjDocument {
    path: PathBuf,
    lines: Vec<ObjLine>,
    mesh: TriMesh,
    /// The `vn` values.
    normals: Vec<DVec3>,
    texcoords: usize,
    /// The `vt` values (u, v; a missing or unreadable number reads 0).
    texcoord_values: Vec<[f64; 2]>,
    /// Per face (polygon), its corners' vertex and normal indices (0-based).
    faces: Vec<Vec<(u32, Option<u32>)>>,
    /// Per face, its corners' `vt` indices (0-based).
    face_texcoords: Vec<Vec<Option<u32>>>,
}

/// What an OBJ file holds besides positions and faces: the figures `squish info` reports.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct ObjAttributeCounts {
    /// `vt` lines.
    pub texcoords: usize,
    /// `vn` lines.
    pub normals: usize,
    /// Distinct `usemtl` names.
    pub materials: usize,
    /// `mtllib` files named.
    pub material_libraries: Vec<String>,
    /// Distinct `g` and `o` names.
    pub groups: usize,
    pub objects: usize,
    /// Distinct smoothing groups other than `off` / `0`.
    pub smoothing_groups: usize,
}

/// A logical line: its bytes as in the file (physical lines with their terminators) and what
/// writing back does with it.
#[derive(Clone, Debug, PartialEq)]
struct ObjLine {
    raw: Vec<u8>,
    kind: LineKind,
}

#[derive(Clone, Debug, PartialEq)]
enum LineKind {
    /// `v x y z …`: vertex `index`; `tail` is the text after the three coordinates.
    Vertex { index: usize, tail: String },
    /// `vn x y z`: normal `index`.
    Normal { index: usize, tail: String },
    /// Written as read.
    Other,
}

/// Where an index of a face corner points.
#[derive(Clone, Copy)]
enum IndexKind {
    Vertex,
    Texcoord,
    Normal,
}

impl IndexKind {
    fn describe(self) -> (&'static str, &'static str) {
        match self {
            Self::Vertex => ("vertex", "v"),
            Self::Texcoord => ("texture coordinate", "vt"),
            Self::Normal => ("normal", "vn"),
        }
    }
}

impl ObjDocument {
    /// Reads an OBJ file.
    pub fn read(path: &Path) -> Result<Self, IoError> {
        let bytes = std::fs::read(path).map_err(|e| IoError::io(path, "open", e))?;
        Self::parse(path, &bytes)
    }

    /// The file read.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The mesh of the file.
    pub fn mesh(&self) -> &TriMesh {
        &self.mesh
    }

    /// The `vn` values as read.
    pub fn normals(&self) -> &[DVec3] {
        &self.normals
    }

    /// Per face (polygon, file order), its corners' vertex and `vn` indices (0-based).
    pub fn faces(&self) -> &[Vec<(u32, Option<u32>)>] {
        &self.faces
    }

    /// The `vt` values (u, v) and, per face (as [`Self::faces`]), its corners' `vt` indices
    /// (0-based): the texture coordinates an exporter to another format (USD) carries over.
    pub fn texcoords(&self) -> (&[[f64; 2]], &[Vec<Option<u32>>]) {
        (&self.texcoord_values, &self.face_texcoords)
    }

    /// What the file holds besides positions and faces.
    pub fn attribute_counts(&self) -> ObjAttributeCounts {
        use std::collections::BTreeSet;
        let mut materials = BTreeSet::new();
        let mut groups = BTreeSet::new();
        let mut objects = BTreeSet::new();
        let mut smoothing = BTreeSet::new();
        let mut libraries = Vec::new();
        for line in &self.lines {
            if line.kind != LineKind::Other {
                continue;
            }
            let text = String::from_utf8_lossy(&line.raw);
            let content = text.split('#').next().unwrap_or("");
            let mut tokens = content.split_whitespace();
            let rest = |t: std::str::SplitWhitespace| t.collect::<Vec<_>>().join(" ");
            match tokens.next() {
                Some("usemtl") => {
                    materials.insert(rest(tokens));
                }
                Some("mtllib") => libraries.extend(tokens.map(str::to_string)),
                Some("g") => {
                    groups.insert(rest(tokens));
                }
                Some("o") => {
                    objects.insert(rest(tokens));
                }
                Some("s") => {
                    let name = rest(tokens);
                    if name != "off" && name != "0" {
                        smoothing.insert(name);
                    }
                }
                _ => {}
            }
        }
        ObjAttributeCounts {
            texcoords: self.texcoords,
            normals: self.normals.len(),
            materials: materials.len(),
            material_libraries: libraries,
            groups: groups.len(),
            objects: objects.len(),
            smoothing_groups: smoothing.len(),
        }
    }

    /// The normals of the file recomputed for new positions, keeping the file's corner → normal
    /// structure: normal `k` becomes the normalized sum of the area vectors of the (deformed)
    /// faces with a corner using it, each face once; a normal no face uses, or whose faces
    /// have no area, keeps its value.
    pub fn recomputed_normals(&self, positions: &[DVec3]) -> Vec<DVec3> {
        let mut sums = vec![DVec3::ZERO; self.normals.len()];
        let mut used: Vec<u32> = Vec::new();
        for face in &self.faces {
            let p = |k: usize| positions[face[k].0 as usize];
            let mut area = DVec3::ZERO;
            for k in 1..face.len().saturating_sub(1) {
                area += (p(k) - p(0)).cross(p(k + 1) - p(0));
            }
            used.clear();
            for &(_, n) in face {
                if let Some(n) = n
                    && !used.contains(&n)
                {
                    used.push(n);
                    sums[n as usize] += area;
                }
            }
        }
        sums.iter()
            .zip(&self.normals)
            .map(|(s, old)| {
                let n = s.normalize_or_zero();
                if n == DVec3::ZERO { *old } else { n }
            })
            .collect()
    }

    /// Writes the file back to `path` (atomically) with new positions (one per `v` line, in
    /// order) and the normals recomputed for them ([`Self::recomputed_normals`]); every other
    /// line is written as read.
    pub fn write_with_positions(&self, path: &Path, positions: &[DVec3]) -> Result<(), IoError> {
        if positions.len() != self.mesh.num_vertices() {
            return Err(IoError::invalid_input(
                path,
                format!(
                    "{} positions for the {} vertices of {}",
                    positions.len(),
                    self.mesh.num_vertices(),
                    self.path.display()
                ),
            ));
        }
        if let Some(v) = positions.iter().position(|p| !p.is_finite()) {
            return Err(IoError::invalid_input(path, format!("vertex {v} has a non-finite coordinate")));
        }
        let normals = self.recomputed_normals(positions);
        write_atomically(path, |w| {
            for line in &self.lines {
                let (keyword, value, tail) = match &line.kind {
                    LineKind::Other => {
                        w.write_all(&line.raw)?;
                        continue;
                    }
                    LineKind::Vertex { index, tail } => ("v", positions[*index], tail),
                    LineKind::Normal { index, tail } => ("vn", normals[*index], tail),
                };
                write!(w, "{keyword} {} {} {}{tail}", value.x, value.y, value.z)?;
                w.write_all(line_terminator(&line.raw))?;
            }
            Ok(())
        })
    }

    /// Copies the material libraries the file names (`mtllib`, relative paths) from the input's
    /// folder next to `output` when they are not there yet, so that the written OBJ finds its
    /// materials; returns the files copied. Texture maps named inside them are not copied.
    pub fn copy_material_libraries(&self, output: &Path) -> Result<Vec<PathBuf>, IoError> {
        let from = self.path.parent().unwrap_or(Path::new("."));
        let to = output.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let mut copied = Vec::new();
        for name in self.attribute_counts().material_libraries {
            let relative = Path::new(&name);
            if relative.is_absolute() || relative.components().any(|c| matches!(c, std::path::Component::ParentDir)) {
                continue;
            }
            let (source, target) = (from.join(relative), to.join(relative));
            if target.exists() || !source.is_file() {
                continue;
            }
            let bytes = std::fs::read(&source).map_err(|e| IoError::io(&source, "read the material library", e))?;
            if let Some(dir) = target.parent() {
                std::fs::create_dir_all(dir).map_err(|e| IoError::io(dir, "create the folder of", e))?;
            }
            write_atomically(&target, |w| w.write_all(&bytes))?;
            copied.push(target);
        }
        Ok(copied)
    }

    /// Parses OBJ text; `path` only names the file in errors.
    pub fn parse(path: &Path, bytes: &[u8]) -> Result<Self, IoError> {
        let mut positions: Vec<DVec3> = Vec::new();
        let mut normals: Vec<DVec3> = Vec::new();
        let mut texcoords = 0usize;
        let mut texcoord_values: Vec<[f64; 2]> = Vec::new();
        let mut face_texcoords: Vec<Vec<Option<u32>>> = Vec::new();
        let mut corner_texcoords: Vec<Option<u32>> = Vec::new();
        let mut triangles: Vec<[u32; 3]> = Vec::new();
        let mut faces: Vec<Vec<(u32, Option<u32>)>> = Vec::new();
        let mut doc_lines: Vec<ObjLine> = Vec::new();
        // Positive indices may point forward: checked at the end, naming the face's line.
        let mut forward_checks: Vec<(usize, usize, IndexKind, i64)> = Vec::new();
        let mut corners: Vec<(u32, Option<u32>)> = Vec::new();

        let mut lines = LogicalLines::new(bytes);
        while let Some((line_no, line, raw)) = lines.next() {
            let line = String::from_utf8_lossy(&line);
            let content = line.split('#').next().unwrap_or("");
            let mut tokens = content.split_whitespace();
            let mut kind = LineKind::Other;
            match tokens.next() {
                Some(keyword @ ("v" | "vn")) => {
                    let is_vertex = keyword == "v";
                    let index = if is_vertex { positions.len() } else { normals.len() };
                    let what = if is_vertex { "vertex" } else { "normal" };
                    let mut xyz = [0.0f64; 3];
                    for (axis, value) in xyz.iter_mut().enumerate() {
                        let name = ["x", "y", "z"][axis];
                        let Some(token) = tokens.next() else {
                            return Err(IoError::line(
                                path,
                                line_no,
                                format!(
                                    "{what} {} has no {name} coordinate; a '{keyword}' line needs three numbers (the file may be truncated)",
                                    index + 1
                                ),
                            ));
                        };
                        *value = token.parse::<f64>().map_err(|_| {
                            IoError::line(
                                path,
                                line_no,
                                format!("malformed number '{token}' for the {name} coordinate of {what} {}; expected a decimal number such as -1.25 or 3e-2", index + 1),
                            )
                        })?;
                        if !value.is_finite() {
                            return Err(IoError::line(
                                path,
                                line_no,
                                format!(
                                    "{what} {} has a non-finite {name} coordinate ({token}); every coordinate must be a finite number (fix the exporting tool or the modelling step that produced it)",
                                    index + 1
                                ),
                            ));
                        }
                    }
                    // A fourth number (w) or vertex colours may follow: kept as they are.
                    let tail = after_tokens(&line, 4).to_string();
                    if is_vertex {
                        positions.push(DVec3::from_array(xyz));
                        kind = LineKind::Vertex { index, tail };
                    } else {
                        normals.push(DVec3::from_array(xyz));
                        kind = LineKind::Normal { index, tail };
                    }
                }
                Some("vt") => {
                    texcoords += 1;
                    // Lenient: the line is written back as read; only exports to other formats
                    // read these values.
                    let mut number = || tokens.next().and_then(|t| t.parse::<f64>().ok()).unwrap_or(0.0);
                    texcoord_values.push([number(), number()]);
                }
                Some("f" | "fo") => {
                    let face = faces.len();
                    corners.clear();
                    corner_texcoords.clear();
                    for token in tokens {
                        let mut parts = token.split('/');
                        let mut resolved = [None; 3];
                        let counts = [positions.len(), texcoords, normals.len()];
                        for (slot, kind) in
                            [IndexKind::Vertex, IndexKind::Texcoord, IndexKind::Normal].into_iter().enumerate()
                        {
                            let text = parts.next().unwrap_or("");
                            if text.is_empty() && slot > 0 {
                                continue;
                            }
                            let (name, _) = kind.describe();
                            let index: i64 = text.parse().map_err(|_| {
                                IoError::line(
                                    path,
                                    line_no,
                                    format!("malformed {name} index '{token}' in face {}; corners are written v, v/vt, v//vn or v/vt/vn with whole numbers", face + 1),
                                )
                            })?;
                            let r = resolve_index(path, line_no, face, kind, index, counts[slot])?;
                            if index > 0 {
                                forward_checks.push((line_no, face, kind, index));
                            }
                            resolved[slot] = Some(r);
                        }
                        let vertex = resolved[0].unwrap_or(0);
                        corners.push((vertex, resolved[2]));
                        corner_texcoords.push(resolved[1]);
                    }
                    if corners.len() < 3 {
                        return Err(IoError::line(
                            path,
                            line_no,
                            format!(
                                "face {} has {} vertices; a face needs at least 3 (the file may be truncated)",
                                face + 1,
                                corners.len()
                            ),
                        ));
                    }
                    for i in 1..corners.len() - 1 {
                        triangles.push([corners[0].0, corners[i].0, corners[i + 1].0]);
                    }
                    faces.push(corners.clone());
                    face_texcoords.push(corner_texcoords.clone());
                }
                // Everything else (vp, o, g, s, usemtl, mtllib, l, p, curves…) does not
                // change the surface.
                _ => {}
            }
            doc_lines.push(ObjLine { raw: raw.to_vec(), kind });
        }
        let totals = [positions.len(), texcoords, normals.len()];
        for &(line_no, face, kind, index) in &forward_checks {
            let total = totals[kind as usize];
            if index as u64 > total as u64 {
                let (name, keyword) = kind.describe();
                return Err(IoError::line(
                    path,
                    line_no,
                    format!(
                        "face {} refers to {name} {index} but the file defines only {total} ('{keyword}' lines); the file may be truncated or the indices wrong (export it again)",
                        face + 1
                    ),
                ));
            }
        }
        let n = positions.len();
        if triangles.is_empty() {
            return Err(IoError::format(
                path,
                format!(
                    "no faces found ({n} vertices, 0 faces); a mesh needs 'f' lines — is this an OBJ mesh export (not a point cloud or curves)?"
                ),
            ));
        }
        let mesh = TriMesh::new(positions, triangles).map_err(|e| IoError::mesh(path, e))?;
        Ok(Self {
            path: path.to_path_buf(),
            lines: doc_lines,
            mesh,
            normals,
            texcoords,
            texcoord_values,
            faces,
            face_texcoords,
        })
    }
}

/// Resolves a 1-based or relative OBJ index against the `count` elements defined so far.
/// Positive indices are only bounded here by `u32`; the caller checks them against the file's
/// totals at the end.
fn resolve_index(
    path: &Path,
    line_no: usize,
    face: usize,
    kind: IndexKind,
    index: i64,
    count: usize,
) -> Result<u32, IoError> {
    let (name, keyword) = kind.describe();
    let resolved = if index > 0 {
        index - 1
    } else if index < 0 {
        let r = count as i64 + index;
        if r < 0 {
            return Err(IoError::line(
                path,
                line_no,
                format!(
                    "relative index {index} in face {} points before the first {name}: only {count} '{keyword}' lines are defined above this line",
                    face + 1
                ),
            ));
        }
        r
    } else {
        return Err(IoError::line(
            path,
            line_no,
            format!(
                "{name} index 0 in face {}; OBJ indices start at 1 (negative indices count back from the last {name})",
                face + 1
            ),
        ));
    };
    u32::try_from(resolved)
        .ok()
        .filter(|&r| r < u32::MAX)
        .ok_or_else(|| IoError::line(path, line_no, format!("{name} index {index} in face {} is too large", face + 1)))
}

/// The text of `line` after its first `n` whitespace-separated tokens (with the whitespace
/// before what follows), or "" if it has no more.
fn after_tokens(line: &str, n: usize) -> &str {
    let mut rest = line;
    for _ in 0..n {
        rest = rest.trim_start();
        let end = rest.find(char::is_whitespace).unwrap_or(rest.len());
        rest = &rest[end..];
    }
    rest.trim_end_matches(['\r', '\n'])
}

/// The line ending of a raw line (`\r\n`, `\n` or none at the end of the file).
fn line_terminator(raw: &[u8]) -> &[u8] {
    if raw.ends_with(b"\r\n") {
        b"\r\n"
    } else if raw.ends_with(b"\n") {
        b"\n"
    } else {
        b""
    }
}

/// Lines joined across trailing backslashes (OBJ line continuation), with the number of the
/// first physical line and the raw bytes they span (terminators included).
struct LogicalLines<'a> {
    bytes: &'a [u8],
    offset: usize,
    line: usize,
}

impl<'a> LogicalLines<'a> {
    fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, offset: 0, line: 0 }
    }

    fn next_physical(&mut self) -> Option<&'a [u8]> {
        let rest = &self.bytes[self.offset..];
        if rest.is_empty() {
            return None;
        }
        self.line += 1;
        let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
        let mut line = &rest[..end];
        self.offset += (end + 1).min(rest.len());
        if let Some(stripped) = line.strip_suffix(b"\r") {
            line = stripped;
        }
        Some(line)
    }

    fn next(&mut self) -> Option<(usize, Vec<u8>, &'a [u8])> {
        let begin = self.offset;
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
        Some((start, joined, &self.bytes[begin..self.offset]))
    }
}

/// Writes a mesh as OBJ (`v` and `f` lines, 1-based indices), atomically.
pub fn write_obj(path: &Path, mesh: &TriMesh) -> Result<(), IoError> {
    write_obj_with(path, mesh, None, None)
}

/// Writes a mesh as OBJ, atomically, with one texture coordinate (`vt`, OBJ's convention: origin
/// at the image's bottom left) and one normal (`vn`) per vertex when given: faces are then
/// `f v/vt/vn` with the vertex's own index three times.
pub fn write_obj_with(
    path: &Path,
    mesh: &TriMesh,
    texcoords: Option<&[[f64; 2]]>,
    normals: Option<&[DVec3]>,
) -> Result<(), IoError> {
    mesh.check_structure().map_err(|e| IoError::mesh(path, e))?;
    let n = mesh.num_vertices();
    if texcoords.is_some_and(|t| t.len() != n) || normals.is_some_and(|v| v.len() != n) {
        return Err(IoError::invalid_input(path, format!("texture coordinates or normals not one per vertex ({n})")));
    }
    write_atomically(path, |w| write_obj_to(w, mesh, texcoords, normals))
}

fn write_obj_to(
    w: &mut dyn Write,
    mesh: &TriMesh,
    texcoords: Option<&[[f64; 2]]>,
    normals: Option<&[DVec3]>,
) -> std::io::Result<()> {
    writeln!(w, "# Squish: {} vertices, {} triangles", mesh.num_vertices(), mesh.num_triangles())?;
    for p in &mesh.positions {
        writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
    }
    for [u, v] in texcoords.unwrap_or_default() {
        writeln!(w, "vt {u} {v}")?;
    }
    for n in normals.unwrap_or_default() {
        writeln!(w, "vn {} {} {}", n.x, n.y, n.z)?;
    }
    let corner = |v: u32| {
        let k = v as u64 + 1;
        match (texcoords.is_some(), normals.is_some()) {
            (false, false) => format!("{k}"),
            (true, false) => format!("{k}/{k}"),
            (false, true) => format!("{k}//{k}"),
            (true, true) => format!("{k}/{k}/{k}"),
        }
    };
    for [a, b, c] in &mesh.triangles {
        writeln!(w, "f {} {} {}", corner(*a), corner(*b), corner(*c))?;
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
