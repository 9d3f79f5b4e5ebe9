//! `squish.Mesh`: a triangle mesh from NumPy arrays, and reading and writing mesh files.
//!
//! Vertices are float64 `(n, 3)` and faces integer `(m, 3)` (any integer dtype; counter-clockwise
//! seen from outside), and optionally UVs for the shared-parametrization mapping (thesis §4.2.1):
//! `(n, 2)` per vertex or `(m, 3, 2)` per face corner (seams). The arrays are copied once, into
//! the library's mesh; lists, tuples and other dtypes are converted by NumPy first. Results are
//! new float64 arrays. Wherever a mesh goes, a `Mesh`, a `(vertices, faces)` pair or an object
//! with `vertices` and `faces` attributes (a trimesh) is taken ([`mesh_from`]).

use std::path::PathBuf;

use glam::{DVec2, DVec3};
use numpy::ndarray::ArrayView2;
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use squish::TriMesh;
use squish::params::Uvs;

use crate::errors::{input_error, io_error};

/// A triangle mesh: float64 vertices `(n, 3)` and integer faces `(m, 3)` (counter-clockwise seen
/// from outside, indices into the vertices).
#[pyclass(module = "squish", frozen)]
#[derive(Clone, Debug)]
pub struct Mesh {
    pub mesh: TriMesh,
    /// Its UVs, if it has any: per vertex, or per face corner.
    pub uvs: Option<Uvs>,
}

#[pymethods]
impl Mesh {
    #[new]
    #[pyo3(signature = (vertices, faces, uvs=None))]
    fn new(vertices: &Bound<'_, PyAny>, faces: &Bound<'_, PyAny>, uvs: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        let positions = vertices_from(vertices)?;
        let triangles = faces_from(faces, positions.len())?;
        let mesh = TriMesh::new(positions, triangles).map_err(input_error)?;
        let uvs = uvs.map(|uvs| uvs_from(uvs, &mesh)).transpose()?;
        Ok(Self { mesh, uvs })
    }

    /// The UVs (texture coordinates) the shared-parametrization mapping reads: a new float64
    /// array `(n, 2)` (per vertex) or `(m, 3, 2)` (per face corner: a vertex on a seam has one UV
    /// per chart), or `None`.
    #[getter]
    fn uvs<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let Some(uvs) = &self.uvs else { return Ok(None) };
        let (flat, shape): (Vec<f64>, Vec<usize>) = match uvs {
            Uvs::PerVertex(values) => (values.iter().flat_map(|q| q.to_array()).collect(), vec![values.len(), 2]),
            Uvs::PerCorner(corners) => {
                (corners.iter().flatten().flat_map(|q| q.to_array()).collect(), vec![corners.len(), 3, 2])
            }
        };
        Ok(Some(PyArray1::from_vec(py, flat).reshape(shape)?.into_any()))
    }

    /// The vertices, a new float64 array `(n, 3)`.
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        positions_array(py, &self.mesh.positions)
    }

    /// The faces, a new int64 array `(m, 3)`.
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        faces_array(py, &self.mesh.triangles)
    }

    /// Number of vertices.
    #[getter]
    fn num_vertices(&self) -> usize {
        self.mesh.num_vertices()
    }

    /// Number of triangles.
    #[getter]
    fn num_faces(&self) -> usize {
        self.mesh.num_triangles()
    }

    /// The enclosed volume (signed: positive for a closed mesh oriented outward).
    fn volume(&self) -> f64 {
        squish::mesh::signed_volume(&self.mesh)
    }

    /// The number of faces that intersect another face of the mesh (faces sharing a vertex or an
    /// edge count only when they cross away from it): the exact triangle-triangle test of
    /// `squish info`'s "self-intersecting faces". Releases the GIL.
    fn self_intersecting_faces(&self, py: Python<'_>) -> PyResult<usize> {
        let mesh = &self.mesh;
        let found = py.detach(|| squish::spatial::self_intersections(mesh)).map_err(input_error)?;
        Ok(found.faces.len())
    }

    /// The same faces with other vertices (same count and order), e.g. a deformation's output.
    fn with_vertices(&self, vertices: &Bound<'_, PyAny>) -> PyResult<Self> {
        let positions = vertices_from(vertices)?;
        if positions.len() != self.mesh.num_vertices() {
            return Err(input_error(format!(
                "vertices: {} rows, but the mesh has {} vertices; give one row per vertex",
                positions.len(),
                self.mesh.num_vertices()
            )));
        }
        let mesh = TriMesh::new(positions, self.mesh.triangles.clone()).map_err(input_error)?;
        Ok(Self { mesh, uvs: self.uvs.clone() })
    }

    /// A sphere of `radius` centred at the origin: an icosahedron subdivided `subdivisions` times
    /// (0 to 7: 12 to 163 842 vertices), projected onto the sphere.
    #[staticmethod]
    #[pyo3(signature = (radius=1.0, subdivisions=3))]
    fn icosphere(radius: f64, subdivisions: u32) -> PyResult<Self> {
        if !(radius.is_finite() && radius > 0.0) || subdivisions > 7 {
            return Err(input_error(format!(
                "icosphere(radius={radius}, subdivisions={subdivisions}): give a radius > 0 and 0 to 7 subdivisions"
            )));
        }
        Ok(Self { mesh: squish::mesh::shapes::icosphere(radius, subdivisions), uvs: None })
    }

    /// A closed box of `size` (x, y, z) centred at the origin, each face an `n` × `n` grid of quads
    /// split into triangles (n from 1 to 256).
    #[staticmethod]
    #[pyo3(signature = (size, n=8))]
    fn cuboid(size: &Bound<'_, PyAny>, n: u32) -> PyResult<Self> {
        let size = vector_from(size, "size")?;
        if !(size.is_finite() && size.min_element() > 0.0 && (1..=256).contains(&n)) {
            return Err(input_error(format!("cuboid(size={size}, n={n}): give sizes > 0 and n from 1 to 256")));
        }
        Ok(Self { mesh: squish::mesh::shapes::cuboid(size, n), uvs: None })
    }

    fn __repr__(&self) -> String {
        format!("squish.Mesh({} vertices, {} faces)", self.mesh.num_vertices(), self.mesh.num_triangles())
    }
}

/// A mesh as Python code holds one: a `squish.Mesh`, a `(vertices, faces)` pair (arrays, lists or
/// tuples), or an object with `vertices` and `faces` attributes (a trimesh). `what` names the
/// argument in messages.
pub fn mesh_from(object: &Bound<'_, PyAny>, what: &str) -> PyResult<Mesh> {
    if let Ok(mesh) = object.cast::<Mesh>() {
        return Ok(mesh.get().clone());
    }
    let parts = if let Ok(tuple) = object.cast::<PyTuple>()
        && tuple.len() == 2
    {
        Some((tuple.get_item(0)?, tuple.get_item(1)?))
    } else if let (Ok(vertices), Ok(faces)) = (object.getattr("vertices"), object.getattr("faces")) {
        Some((vertices, faces))
    } else if let Ok(list) = object.cast::<pyo3::types::PyList>()
        && list.len() == 2
    {
        Some((list.get_item(0)?, list.get_item(1)?))
    } else {
        None
    };
    let Some((vertices, faces)) = parts else {
        return Err(input_error(format!(
            "{what}: cannot read {} as a mesh; give a squish.Mesh, a (vertices, faces) pair or an object with vertices and faces",
            object.get_type().name().map_or_else(|_| "the value".into(), |n| n.to_string())
        )));
    };
    let prefix = |e: PyErr| input_error(format!("{what}: {}", e.value(object.py())));
    let positions = vertices_from(&vertices).map_err(prefix)?;
    let triangles = faces_from(&faces, positions.len()).map_err(prefix)?;
    let mesh = TriMesh::new(positions, triangles).map_err(|e| input_error(format!("{what}: {e}")))?;
    Ok(Mesh { mesh, uvs: None })
}

/// Three numbers from any sequence or array (`[x, y, z]`, a tuple, an array of shape (3,)).
pub fn vector_from(value: &Bound<'_, PyAny>, what: &str) -> PyResult<DVec3> {
    let numbers = value.py().import("numpy")?.call_method1("asarray", (value, "float64"));
    let read = numbers.ok().and_then(|a| a.extract::<PyReadonlyArrayDyn<'_, f64>>().ok());
    match read {
        Some(array) if array.shape() == [3] => {
            let v = array.as_array();
            Ok(DVec3::new(v[0], v[1], v[2]))
        }
        _ => Err(input_error(format!(
            "{what}: {}: give three numbers [x, y, z]",
            value.repr().map_or_else(|_| "the value".to_string(), |r| r.to_string())
        ))),
    }
}

/// UVs of `mesh` from an array: `(n, 2)` per vertex or `(m, 3, 2)` per face corner.
pub fn uvs_from(value: &Bound<'_, PyAny>, mesh: &TriMesh) -> PyResult<Uvs> {
    let numbers = value.py().import("numpy")?.call_method1("asarray", (value, "float64"));
    let array = numbers.ok().and_then(|a| a.extract::<PyReadonlyArrayDyn<'_, f64>>().ok());
    let (n, m) = (mesh.num_vertices(), mesh.num_triangles());
    let wrong = |shape: String| {
        input_error(format!(
            "uvs: shape {shape}; give ({n}, 2) (one UV per vertex) or ({m}, 3, 2) (per face corner, for seams)"
        ))
    };
    let Some(array) = array else { return Err(wrong("unreadable".into())) };
    let view = array.as_array();
    let values: Vec<f64> = view.iter().copied().collect();
    if !values.iter().all(|x| x.is_finite()) {
        return Err(input_error("uvs: every UV must be finite"));
    }
    let pairs = || values.chunks_exact(2).map(|c| DVec2::new(c[0], c[1]));
    match array.shape() {
        [rows, 2] if *rows == n => Ok(Uvs::PerVertex(pairs().collect())),
        [rows, 3, 2] if *rows == m => {
            let corners: Vec<DVec2> = pairs().collect();
            Ok(Uvs::PerCorner(corners.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()))
        }
        shape => Err(wrong(format!("{shape:?}"))),
    }
}

/// An `(n, 3)` float64 array's rows as positions (one copy). Other dtypes and sequences are
/// converted by NumPy first.
pub fn vertices_from(vertices: &Bound<'_, PyAny>) -> PyResult<Vec<DVec3>> {
    let array = as_array::<f64>(vertices, "float64", "vertices")?;
    let view: ArrayView2<f64> = array.as_array();
    if view.ncols() != 3 {
        return Err(input_error(format!(
            "vertices: expected an array of shape (n, 3), got {:?}; give one x, y, z row per vertex",
            array.shape()
        )));
    }
    Ok(view.rows().into_iter().map(|r| DVec3::new(r[0], r[1], r[2])).collect())
}

/// An `(m, 3)` integer array's rows as triangles, each index checked against `vertex_count`.
fn faces_from(faces: &Bound<'_, PyAny>, vertex_count: usize) -> PyResult<Vec<[u32; 3]>> {
    let array = as_array::<i64>(faces, "int64", "faces")?;
    let view = array.as_array();
    if view.ncols() != 3 {
        return Err(input_error(format!(
            "faces: expected an array of shape (m, 3), got {:?}; give three vertex indices per triangle",
            array.shape()
        )));
    }
    let mut triangles = Vec::with_capacity(view.nrows());
    for (f, row) in view.rows().into_iter().enumerate() {
        let mut triangle = [0u32; 3];
        for (corner, &index) in triangle.iter_mut().zip(row) {
            *corner = u32::try_from(index).ok().filter(|&i| (i as usize) < vertex_count).ok_or_else(|| {
                input_error(format!(
                    "faces: face {f} has vertex index {index}, but the mesh has {vertex_count} vertices (indices 0 to {})",
                    vertex_count.saturating_sub(1)
                ))
            })?;
        }
        triangles.push(triangle);
    }
    Ok(triangles)
}

/// `object` as a 2-D array of `T`: itself when it already is one, else converted by
/// `numpy.asarray(object, dtype)` (integers from floats only when they are whole).
fn as_array<'py, T: numpy::Element>(
    object: &Bound<'py, PyAny>,
    dtype: &str,
    what: &str,
) -> PyResult<PyReadonlyArray2<'py, T>> {
    if let Ok(array) = object.extract::<PyReadonlyArray2<'py, T>>() {
        return Ok(array);
    }
    let py = object.py();
    let numpy = py.import("numpy")?;
    let converted = numpy.call_method1("asarray", (object,)).map_err(|e| {
        input_error(format!(
            "{what}: cannot read {} as an array: {e}",
            object.get_type().name().map_or_else(|_| "the value".into(), |n| n.to_string())
        ))
    })?;
    let ndim: usize = converted.getattr("ndim")?.extract()?;
    if ndim != 2 {
        let shape = converted.getattr("shape")?.str()?.to_string();
        return Err(input_error(format!("{what}: expected a 2-D array of shape (count, 3), got shape {shape}")));
    }
    if dtype == "int64" {
        // Floats are accepted as indices only when whole (np.asarray would truncate 1.5 to 1).
        let kind: String = converted.getattr("dtype")?.getattr("kind")?.extract()?;
        if !matches!(kind.as_str(), "i" | "u") {
            let whole: bool = numpy
                .call_method1(
                    "all",
                    (numpy.call_method1("equal", (&converted, numpy.call_method1("floor", (&converted,))?))?,),
                )?
                .extract()
                .unwrap_or(false);
            if kind != "f" || !whole {
                return Err(input_error(format!(
                    "{what}: expected integer vertex indices, got dtype {}",
                    converted.getattr("dtype")?.str()?
                )));
            }
        }
    } else {
        let kind: String = converted.getattr("dtype")?.getattr("kind")?.extract()?;
        if !matches!(kind.as_str(), "f" | "i" | "u") {
            return Err(input_error(format!(
                "{what}: expected numbers, got dtype {}",
                converted.getattr("dtype")?.str()?
            )));
        }
    }
    let cast = converted.call_method1("astype", (dtype,))?;
    cast.extract::<PyReadonlyArray2<'py, T>>().map_err(|e| input_error(format!("{what}: {e}")))
}

/// Positions as a new float64 array `(n, 3)`.
pub fn positions_array<'py>(py: Python<'py>, positions: &[DVec3]) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let flat: Vec<f64> = positions.iter().flat_map(|p| p.to_array()).collect();
    PyArray1::from_vec(py, flat).reshape([positions.len(), 3])
}

/// Triangles as a new int64 array `(m, 3)`.
pub fn faces_array<'py>(py: Python<'py>, triangles: &[[u32; 3]]) -> PyResult<Bound<'py, PyArray2<i64>>> {
    let flat: Vec<i64> = triangles.iter().flat_map(|t| t.map(i64::from)).collect();
    PyArray1::from_vec(py, flat).reshape([triangles.len(), 3])
}

/// Reads a mesh file (`.obj`, `.ply`, `.gltf`, `.glb`), keeping the file's vertices in number
/// and order (a glTF file: every mesh instance at rest, concatenated; seams not welded), with its
/// UVs when it has them (OBJ `vt` and glTF `TEXCOORD_0` per corner, PLY `u, v` per vertex).
#[pyfunction]
pub fn read_mesh(py: Python<'_>, path: PathBuf) -> PyResult<Mesh> {
    let document = py.detach(|| squish_io::MeshDocument::read(&path)).map_err(io_error)?;
    let mesh = document.mesh().map_err(io_error)?;
    // A file without usable UVs is still a mesh: the shared parametrization says so if asked.
    let uvs = squish_io::document_uvs(&document).ok();
    Ok(Mesh { mesh, uvs })
}

/// Writes `mesh` to `path` (format from the extension), atomically. With `like`, the file it was
/// read from: the output is a copy of that file with the new positions and the normals that
/// follow (UVs, materials, groups, colours, skins and extra properties kept); `like` must have
/// the mesh's vertex count.
#[pyfunction]
#[pyo3(signature = (path, mesh, like=None))]
pub fn write_mesh(py: Python<'_>, path: PathBuf, mesh: &Bound<'_, PyAny>, like: Option<PathBuf>) -> PyResult<()> {
    let mesh = &mesh_from(mesh, "mesh")?.mesh;
    py.detach(|| -> PyResult<()> {
        match like {
            None => squish_io::write_mesh(&path, mesh).map_err(io_error),
            Some(like) => {
                let document = squish_io::MeshDocument::read(&like).map_err(io_error)?;
                let file = document.mesh().map_err(io_error)?;
                if file.num_vertices() != mesh.num_vertices() {
                    return Err(input_error(format!(
                        "like={}: the file has {} vertices but the mesh has {}; give the file the mesh was read from",
                        like.display(),
                        file.num_vertices(),
                        mesh.num_vertices()
                    )));
                }
                document.write_with_positions(&path, &mesh.positions).map_err(io_error)
            }
        }
    })
}

/// The polygons and texture coordinates of a mesh file, in the file's vertex numbering, for
/// exporters that keep them (`squish.usd`): `face_vertex_counts` and `face_vertex_indices` (an
/// OBJ file's polygons as written; triangles for other formats), and `uv`: `None`, or
/// `(values (k, 2), indices per face corner)` for an OBJ file whose every corner has a `vt`.
#[pyfunction]
pub fn source_topology<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
    let document = py.detach(|| squish_io::MeshDocument::read(&path)).map_err(io_error)?;
    let result = pyo3::types::PyDict::new(py);
    type Uv = Option<(Vec<[f64; 2]>, Vec<i64>)>;
    let (counts, indices, uv): (Vec<i64>, Vec<i64>, Uv) = match &document {
        squish_io::MeshDocument::Obj(obj) => {
            let counts = obj.faces().iter().map(|f| f.len() as i64).collect();
            let indices = obj.faces().iter().flatten().map(|&(v, _)| i64::from(v)).collect();
            let (values, corners) = obj.texcoords();
            let uv_indices: Option<Vec<i64>> = corners.iter().flatten().map(|t| t.map(i64::from)).collect();
            (counts, indices, uv_indices.filter(|_| !values.is_empty()).map(|i| (values.to_vec(), i)))
        }
        _ => {
            let mesh = document.mesh().map_err(io_error)?;
            let counts = vec![3; mesh.num_triangles()];
            let indices = mesh.triangles.iter().flatten().map(|&v| i64::from(v)).collect();
            (counts, indices, None)
        }
    };
    result.set_item("face_vertex_counts", PyArray1::from_vec(py, counts))?;
    result.set_item("face_vertex_indices", PyArray1::from_vec(py, indices))?;
    match uv {
        Some((values, indices)) => {
            let count = values.len();
            let flat: Vec<f64> = values.into_iter().flatten().collect();
            let values = PyArray1::from_vec(py, flat).reshape([count, 2])?;
            result.set_item("uv", (values, PyArray1::from_vec(py, indices)))?;
        }
        None => result.set_item("uv", py.None())?,
    }
    Ok(result)
}
