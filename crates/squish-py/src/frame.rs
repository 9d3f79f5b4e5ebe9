//! One frame: `squish.deform` and `squish.contact` (two meshes, as `squish deform` and `squish
//! contact`), and `squish.Frame` (any number of objects, pairs and self-contact articulations).
//!
//! The two-mesh calls build their frame with the functions `squish deform` and `squish contact` use
//! ([`squish_shot::two_objects::deform_pair`], [`squish_shot::two_objects::define_contact`]), so the
//! results are those of the command on the same meshes and parameters, bit for bit, and the
//! report dicts hold the figures of its report files. `Frame.deform` reports the figures of a
//! `report.json` frame entry. The GIL is released while computing.

use glam::DVec3;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use squish::params::Articulation;
use squish::params::{ArticulationParams, MappingMethod, ObjectParams, PairParams, Params};
use squish::pipeline::{Deformer, FramePair};
use squish::pipeline::{OwnedFrame, OwnedObject};
use squish_shot::quality::FrameEntry;
use squish_shot::shot::{frame_record, worker_pool};
use squish_shot::two_objects::PairParameters as PairSettings;

use crate::errors::{input_error, parameter_error, pipeline_error, shot_error, to_python};
use crate::mesh::{Mesh, mesh_from, positions_array, vertices_from};
use crate::params::{apply, check_per_vertex, from_python, refuse_twice};
use crate::skin::{Skin, matrices_from};

/// The settings of a two-mesh call: `a_params`, `b_params`, `pair` and keyword arguments
/// `a_KEY`, `b_KEY`, `pair_KEY`, checked for the two meshes.
fn pair_settings(
    meshes: [&Mesh; 2],
    a_params: Option<&Bound<'_, PyDict>>,
    b_params: Option<&Bound<'_, PyDict>>,
    pair: Option<&Bound<'_, PyDict>>,
    kwargs: Option<&Bound<'_, PyDict>>,
) -> PyResult<PairSettings> {
    let mut settings = PairSettings::default();
    for (prefix, dict) in [("a", a_params), ("b", b_params)] {
        if let Some(dict) = dict {
            apply(if prefix == "a" { &mut settings.a } else { &mut settings.b }, prefix, dict)?;
        }
    }
    if let Some(dict) = pair {
        apply(&mut settings.pair, "pair", dict)?;
    }
    // A key in a dict and as a keyword argument: refused (which one was meant is a guess).
    let keywords: Vec<(String, Bound<'_, PyAny>)> =
        kwargs.into_iter().flat_map(|k| k.iter()).filter_map(|(k, v)| Some((k.extract::<String>().ok()?, v))).collect();
    for (prefix, dict, dict_name) in [("a", a_params, "a_params"), ("b", b_params, "b_params"), ("pair", pair, "pair")]
    {
        let mine: Vec<(String, Bound<'_, PyAny>)> = keywords
            .iter()
            .filter_map(|(k, v)| Some((k.strip_prefix(&format!("{prefix}_"))?.to_string(), v.clone())))
            .collect();
        refuse_twice(prefix, dict, dict_name, &mine, |key| format!("{prefix}_{key}"))?;
    }
    if let Some(kwargs) = kwargs {
        for (name, value) in kwargs.iter() {
            let name: String = name.extract()?;
            let (prefix, key) = ["a_", "b_", "pair_"]
                .iter()
                .find_map(|p| name.strip_prefix(p).map(|key| (p.trim_end_matches('_'), key)))
                .ok_or_else(|| {
                    parameter_error(squish::ParamError::new(
                        &name,
                        None,
                        "keyword arguments are a_KEY, b_KEY or pair_KEY (e.g. a_stiffness=2, pair_contact_tau=0.5); or pass a_params, b_params, pair dicts",
                    ))
                })?;
            let one = PyDict::new(kwargs.py());
            one.set_item(key, value)?;
            match prefix {
                "a" => apply(&mut settings.a, "a", &one)?,
                "b" => apply(&mut settings.b, "b", &one)?,
                _ => apply(&mut settings.pair, "pair", &one)?,
            }
        }
    }
    for (prefix, params) in [("a", &settings.a), ("b", &settings.b)] {
        params.validate().map_err(|e| parameter_error(e.with_prefix(prefix)))?;
    }
    settings.pair.validate().map_err(|e| parameter_error(e.with_prefix("pair")))?;
    check_per_vertex(&settings.a, "a", meshes[0].mesh.num_vertices())?;
    check_per_vertex(&settings.b, "b", meshes[1].mesh.num_vertices())?;
    if settings.pair.mapping == MappingMethod::SharedParametrization {
        for (prefix, mesh) in [("a", meshes[0]), ("b", meshes[1])] {
            let uvs = Some(mesh_uvs(mesh, prefix)?);
            if prefix == "a" { settings.a.uvs = uvs } else { settings.b.uvs = uvs }
        }
    }
    Ok(settings)
}

/// The UVs the shared-parametrization mapping needs of `mesh` (named `name`), or the fix.
fn mesh_uvs(mesh: &Mesh, name: &str) -> PyResult<squish::params::Uvs> {
    mesh.uvs.clone().ok_or_else(|| {
        parameter_error(squish::ParamError::new(
            &format!("{name}.uvs"),
            None,
            "mapping = \"shared_parametrization\" matches the meshes in UV space (thesis §4.2.1), but this mesh has none; read it from a file with UVs, give squish.Mesh(vertices, faces, uvs=...), or use mapping = \"unique_direction\"",
        ))
    })
}

/// Deforms two intersecting meshes into clean contact (one frame); see the package docs for the
/// parameters (`help(squish.deform)`).
#[pyfunction]
#[pyo3(signature = (a, b, a_params=None, b_params=None, pair=None, **params))]
pub fn deform<'py>(
    py: Python<'py>,
    a: &Bound<'py, PyAny>,
    b: &Bound<'py, PyAny>,
    a_params: Option<&Bound<'py, PyDict>>,
    b_params: Option<&Bound<'py, PyDict>>,
    pair: Option<&Bound<'py, PyDict>>,
    params: Option<&Bound<'py, PyDict>>,
) -> PyResult<(Bound<'py, PyTuple>, Bound<'py, PyAny>)> {
    let (a, b) = (&mesh_from(a, "a")?, &mesh_from(b, "b")?);
    let settings = pair_settings([a, b], a_params, b_params, pair, params)?;
    let (result, figures) = py
        .detach(|| {
            squish_shot::two_objects::deform_pair(["a", "b"], [&a.mesh, &b.mesh], &settings, &mut Deformer::new())
        })
        .map_err(shot_error)?;
    let vertices =
        PyTuple::new(py, [positions_array(py, &result.positions[0])?, positions_array(py, &result.positions[1])?])?;
    Ok((vertices, to_python(py, &figures)?))
}

/// The contact definition of two meshes (thesis ch. 4) without deforming them: per-vertex labels
/// (0 outside, 1 intersection, 2 mapping region, 3 contact zone), the regions' exact boundary
/// points, and the figures of `squish contact`'s contact.json.
#[pyfunction]
#[pyo3(signature = (a, b, a_params=None, b_params=None, pair=None, **params))]
pub fn contact<'py>(
    py: Python<'py>,
    a: &Bound<'py, PyAny>,
    b: &Bound<'py, PyAny>,
    a_params: Option<&Bound<'py, PyDict>>,
    b_params: Option<&Bound<'py, PyDict>>,
    pair: Option<&Bound<'py, PyDict>>,
    params: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let (a, b) = (&mesh_from(a, "a")?, &mesh_from(b, "b")?);
    let settings = pair_settings([a, b], a_params, b_params, pair, params)?;
    let definition = py
        .detach(|| squish_shot::two_objects::define_contact(["a", "b"], [&a.mesh, &b.mesh], &settings, [None, None]))
        .map_err(shot_error)?;
    let report = to_python(py, &definition.figures)?;
    let labels = definition.labels.map(|l| PyArray1::from_vec(py, l));
    report.set_item("labels", PyTuple::new(py, labels)?)?;
    let points = &definition.boundary_points;
    let positions: Vec<DVec3> = points.iter().map(|p| DVec3::from_array(p.0)).collect();
    let boundary = PyDict::new(py);
    boundary.set_item("positions", positions_array(py, &positions)?)?;
    boundary.set_item("kind", PyArray1::from_vec(py, points.iter().map(|p| p.1).collect::<Vec<i32>>()))?;
    boundary.set_item("side", PyArray1::from_vec(py, points.iter().map(|p| p.2).collect::<Vec<i32>>()))?;
    report.set_item("boundary_points", boundary)?;
    Ok(report)
}

/// Every object's deformed vertices and the frame's report.
type FrameOutput<'py> = (Vec<Bound<'py, PyArray2<f64>>>, Bound<'py, PyAny>);

/// One frame of any number of objects, pairs and self-contact articulations.
///
/// ```python
/// frame = squish.Frame()
/// ball = frame.add_object("ball", ball_mesh, stiffness=1.0)
/// ground = frame.add_object("ground", ground_mesh, rigid=True)
/// frame.add_pair(ball, ground, contact_tau=0.5)
/// vertices, report = frame.deform()
/// ```
/// (`squish.Frame` is a Python subclass whose methods carry the schema in their docstrings.)
#[pyclass(module = "squish", subclass)]
#[derive(Clone, Debug, Default)]
pub struct Frame {
    pub frame: OwnedFrame,
}

impl Frame {
    /// The object (index or name) an articulation `name` belongs to, and the articulation's
    /// prefix in messages (`object.name`).
    fn articulation_owner(&mut self, object: &Bound<'_, PyAny>, name: &str) -> PyResult<(&mut OwnedObject, String)> {
        let index = self.object_index(object)?;
        let target = &mut self.frame.objects[index];
        let prefix = format!("{}.{name}", target.name);
        Ok((target, prefix))
    }

    /// The index of an object given by index or name.
    fn object_index(&self, object: &Bound<'_, PyAny>) -> PyResult<usize> {
        if let Ok(i) = object.extract::<usize>() {
            if i < self.frame.objects.len() {
                return Ok(i);
            }
            return Err(input_error(format!("object {i}: the frame has {} objects", self.frame.objects.len())));
        }
        let name: String = object.extract().map_err(|_| input_error("an object is given by its index or name"))?;
        self.frame.objects.iter().position(|o| o.name == name).ok_or_else(|| {
            let names: Vec<&str> = self.frame.objects.iter().map(|o| o.name.as_str()).collect();
            input_error(format!("no object named \"{name}\"; the objects are {}", names.join(", ")))
        })
    }
}

#[pymethods]
impl Frame {
    #[new]
    fn new() -> Self {
        Self::default()
    }

    /// Adds an object; returns its index. `mesh`: a `squish.Mesh`, a `(vertices, faces)` pair or
    /// an object with `vertices` and `faces` (its UVs, if any, serve the shared-parametrization
    /// mapping). Parameters: a dict and/or keyword arguments (the object parameters of
    /// `squish.params_schema()`). `self_contact="auto"` with `skin` (a `squish.Skin` of this
    /// mesh) and `joint_matrices` (the joints' world matrices at this frame, `(J, 4, 4)`): the
    /// articulations of its skeleton and the contacts between its parts, as a scene file's
    /// `self_contact = "auto"` (parameters of one articulation: `set_articulation`).
    #[pyo3(signature = (name, mesh, params=None, *, self_contact=None, skin=None, joint_matrices=None, **kwargs))]
    #[allow(clippy::too_many_arguments)] // the Python signature
    fn add_object(
        &mut self,
        name: String,
        mesh: &Bound<'_, PyAny>,
        params: Option<&Bound<'_, PyDict>>,
        self_contact: Option<&Bound<'_, PyAny>>,
        skin: Option<&Skin>,
        joint_matrices: Option<&Bound<'_, PyAny>>,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<usize> {
        if self.frame.objects.iter().any(|o| o.name == name) {
            return Err(input_error(format!("an object is already named \"{name}\"; give each object its own name")));
        }
        let mesh = mesh_from(mesh, &name)?;
        let prefix = name.clone();
        let mut params: ObjectParams = from_python(&prefix, params, kwargs)?;
        check_per_vertex(&params, &prefix, mesh.mesh.num_vertices())?;
        params.uvs = mesh.uvs.clone();
        let wrong = |message: String| {
            parameter_error(squish::ParamError::new(&format!("{prefix}.self_contact"), None, message))
        };
        let auto = match self_contact {
            None => false,
            Some(value) => match value.extract::<String>().ok().as_deref() {
                Some("auto") => true,
                _ => {
                    return Err(wrong(format!(
                        "{}: give \"auto\" (with skin=squish.Skin(...) and joint_matrices=...), or add articulations one by one with add_articulation",
                        value.repr().map_or_else(|_| "?".to_string(), |r| r.to_string())
                    )));
                }
            },
        };
        match (auto, skin) {
            (true, Some(skin)) => {
                if skin.rest.triangles != mesh.mesh.triangles || skin.rest.num_vertices() != mesh.mesh.num_vertices() {
                    return Err(wrong(format!(
                        "the skin's mesh has {} vertices and {} faces, this mesh {} and {}; give the Skin of this mesh (its bind pose)",
                        skin.rest.num_vertices(),
                        skin.rest.num_triangles(),
                        mesh.mesh.num_vertices(),
                        mesh.mesh.num_triangles()
                    )));
                }
                let Some(matrices) = joint_matrices else {
                    return Err(wrong(
                        "needs joint_matrices: the joints' world matrices at this frame, (J, 4, 4), for the articulations' directions".into(),
                    ));
                };
                let world = matrices_from(matrices, &format!("{prefix}: joint_matrices"), skin.joint_names.len())?;
                params.self_contact.extend(skin.posed(&world)?);
                params.self_contact_parts = Some(skin.parts.clone());
                params.rest_positions = Some(skin.rest.positions.clone());
            }
            (true, None) => {
                return Err(wrong("\"auto\" needs skin=squish.Skin(rest mesh, joints, weights, parents, bind_matrices): the parts and articulations come from the skeleton".into()));
            }
            (false, _) if joint_matrices.is_some() || skin.is_some() => {
                return Err(wrong("skin and joint_matrices serve self_contact=\"auto\"; add it".into()));
            }
            (false, _) => {}
        }
        self.frame.objects.push(OwnedObject { name, mesh: mesh.mesh, params });
        Ok(self.frame.objects.len() - 1)
    }

    /// The names of an object's articulations (given with `add_articulation`, then those of
    /// `self_contact="auto"`).
    fn articulations(&self, object: &Bound<'_, PyAny>) -> PyResult<Vec<String>> {
        let index = self.object_index(object)?;
        Ok(self.frame.objects[index].params.self_contact.iter().map(|a| a.name.clone()).collect())
    }

    /// Sets parameters of an object's articulation (by name; automatic ones included) over its
    /// current ones: a dict and/or keyword arguments of the articulation parameters.
    #[pyo3(signature = (object, name, params=None, **kwargs))]
    fn set_articulation(
        &mut self,
        object: &Bound<'_, PyAny>,
        name: &str,
        params: Option<&Bound<'_, PyDict>>,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<()> {
        let (target, prefix) = self.articulation_owner(object, name)?;
        let names: Vec<String> = target.params.self_contact.iter().map(|a| format!("\"{}\"", a.name)).collect();
        let Some(articulation) = target.params.self_contact.iter_mut().find(|a| a.name == name) else {
            return Err(input_error(format!(
                "{}: no articulation is named \"{name}\"; its articulations are {}",
                target.name,
                if names.is_empty() { "none".to_string() } else { names.join(", ") }
            )));
        };
        let keywords: Vec<(String, Bound<'_, PyAny>)> = kwargs
            .into_iter()
            .flat_map(|k| k.iter())
            .filter_map(|(k, v)| Some((k.extract::<String>().ok()?, v)))
            .collect();
        refuse_twice(&prefix, params, "params", &keywords, str::to_string)?;
        let mut updated = articulation.params.clone();
        for items in [params, kwargs].into_iter().flatten() {
            apply(&mut updated, &prefix, items)?;
        }
        updated.validate().map_err(|e| parameter_error(e.with_prefix(&prefix)))?;
        articulation.params = updated;
        Ok(())
    }

    /// Adds a pair of objects (indices or names) that may be in contact; the mapping direction is
    /// oriented along the second's normals. Returns its index.
    #[pyo3(signature = (a, b, params=None, **kwargs))]
    fn add_pair(
        &mut self,
        a: &Bound<'_, PyAny>,
        b: &Bound<'_, PyAny>,
        params: Option<&Bound<'_, PyDict>>,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<usize> {
        let objects = [self.object_index(a)?, self.object_index(b)?];
        let prefix = format!("{}/{}", self.frame.objects[objects[0]].name, self.frame.objects[objects[1]].name);
        let params: PairParams = from_python(&prefix, params, kwargs)?;
        if params.mapping == MappingMethod::SharedParametrization
            && let Some(&i) = objects.iter().find(|&&i| self.frame.objects[i].params.uvs.is_none())
        {
            return Err(parameter_error(squish::ParamError::new(
                &format!("{prefix}.mapping"),
                None,
                format!(
                    "\"shared_parametrization\" matches the meshes in UV space (thesis §4.2.1), but object \"{}\" has no UVs; add it with a mesh that has them (a file with UVs, or squish.Mesh(vertices, faces, uvs=...)) or use \"unique_direction\"",
                    self.frame.objects[i].name
                ),
            )));
        }
        self.frame.pairs.push(FramePair { objects, params });
        Ok(self.frame.pairs.len() - 1)
    }

    /// Adds a self-contact articulation (thesis ch. 6) to an object: `regions` are the two
    /// overlapping working regions as vertex indices (the parent side, then the child side);
    /// `joints` the world positions `(3, 3)` of the parent bone's start, the articulation and
    /// the child bone's end (needed unless `direction` is given).
    #[pyo3(signature = (object, name, regions, joints=None, params=None, **kwargs))]
    #[allow(clippy::too_many_arguments)] // the Python signature
    fn add_articulation(
        &mut self,
        object: &Bound<'_, PyAny>,
        name: String,
        regions: (Vec<u32>, Vec<u32>),
        joints: Option<&Bound<'_, PyAny>>,
        params: Option<&Bound<'_, PyDict>>,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<()> {
        let (target, prefix) = self.articulation_owner(object, &name)?;
        let params: ArticulationParams = from_python(&prefix, params, kwargs)?;
        let count = target.mesh.num_vertices();
        for region in [&regions.0, &regions.1] {
            if let Some(&v) = region.iter().find(|&&v| v as usize >= count) {
                return Err(input_error(format!("{prefix}: region vertex {v}, but the mesh has {count} vertices")));
            }
        }
        let joints = match joints {
            Some(joints) => {
                let points = vertices_from(joints)?;
                let [p, q, r]: [DVec3; 3] = points
                    .try_into()
                    .map_err(|_| input_error(format!("{prefix}: joints: give three points (3, 3)")))?;
                Some([p, q, r])
            }
            None => None,
        };
        if joints.is_none() && params.direction.is_none() {
            return Err(parameter_error(squish::ParamError::new(
                &format!("{prefix}.direction"),
                None,
                "give the joints' positions or a direction [x, y, z]",
            )));
        }
        target.params.self_contact.push(Articulation {
            name,
            regions: [regions.0, regions.1],
            joints,
            params,
            automatic: false,
        });
        Ok(())
    }

    /// Sets an object's rest (bind) pose, one position per vertex: the articulations' partition
    /// of unity β and their automatic extent are computed on it (thesis §6.1.1), as `squish run`
    /// does with a glTF skin's bind pose. Without it, the frame's own mesh is the rest pose.
    fn set_rest_positions(&mut self, object: &Bound<'_, PyAny>, vertices: &Bound<'_, PyAny>) -> PyResult<()> {
        let index = self.object_index(object)?;
        let target = &mut self.frame.objects[index];
        let positions = vertices_from(vertices)?;
        if positions.len() != target.mesh.num_vertices() {
            return Err(input_error(format!(
                "{}: rest positions: {} rows, but the mesh has {} vertices; give one row per vertex",
                target.name,
                positions.len(),
                target.mesh.num_vertices()
            )));
        }
        target.params.rest_positions = Some(positions);
        Ok(())
    }

    /// The objects' names, in order.
    #[getter]
    fn objects(&self) -> Vec<String> {
        self.frame.objects.iter().map(|o| o.name.clone()).collect()
    }

    /// The mesh of an object (index or name).
    fn mesh(&self, object: &Bound<'_, PyAny>) -> PyResult<Mesh> {
        let object = &self.frame.objects[self.object_index(object)?];
        Ok(Mesh { mesh: object.mesh.clone(), uvs: object.params.uvs.clone() })
    }

    /// The parameters of an object (index or name), as a dict of the schema's keys.
    fn params<'py>(&self, py: Python<'py>, object: &Bound<'_, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let params = &self.frame.objects[self.object_index(object)?].params;
        to_python(py, &params.values().into_iter().collect::<std::collections::BTreeMap<_, _>>())
    }

    /// Deforms the frame: every object's vertices (same count and order as its mesh) and the
    /// frame's figures (those of a `report.json` frame entry). `threads`: worker threads (default:
    /// every core).
    #[pyo3(signature = (threads=None))]
    fn deform<'py>(&self, py: Python<'py>, threads: Option<usize>) -> PyResult<FrameOutput<'py>> {
        let pool = worker_pool(threads).map_err(shot_error)?;
        let shot = &self.frame;
        let (result, record) = py
            .detach(|| {
                pool.install(|| {
                    let frame = shot.frame();
                    let result = Deformer::new().deform(&frame)?;
                    let record = frame_record(0, &frame, &result);
                    Ok::<_, squish::pipeline::PipelineError>((result, record))
                })
            })
            .map_err(pipeline_error)?;
        let vertices = result.positions.iter().map(|p| positions_array(py, p)).collect::<PyResult<Vec<_>>>()?;
        let report = to_python(py, &FrameEntry::of(&record))?;
        report.del_item("frame")?;
        Ok((vertices, report))
    }

    fn __repr__(&self) -> String {
        format!("squish.Frame({} objects, {} pairs)", self.frame.objects.len(), self.frame.pairs.len())
    }
}
