//! `squish.Skin`: a skinned mesh's bind pose, weights and skeleton, for `self_contact = "auto"`
//! from Python (`Frame.add_object(..., self_contact="auto", skin=skin, joint_matrices=M)`): the
//! scene files' own analysis ([`squish_io::scene::automatic_self_contact`], issue 27 and thesis
//! ch. 6) run once on the bind pose — the parts of the skin and the articulations of its
//! skeleton — and then posed at every frame by the joints' world matrices.
//!
//! Matrices are NumPy's `(J, 4, 4)` row-major affine matrices (`M @ [x, y, z, 1]`), world space,
//! as a DCC gives them (Blender: `armature.matrix_world @ pose_bone.matrix`).

use glam::DMat4;
use numpy::{PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use squish::TriMesh;
use squish::params::{Articulation, ArticulationParams, SkinParts};
use squish::skinning::SkinWeights;
use squish_io::scene::{JointPoints, automatic_self_contact};

use crate::errors::input_error;
use crate::mesh::mesh_from;

/// A skinned mesh's bind pose, weights and skeleton, analysed once for `self_contact = "auto"`.
#[pyclass(module = "squish", frozen)]
#[derive(Clone, Debug)]
pub struct Skin {
    pub rest: TriMesh,
    pub parts: SkinParts,
    /// Per automatic articulation: its name, regions and direction points (skin joint ids).
    pub articulations: Vec<(String, [Vec<u32>; 2], JointPoints)>,
    pub joint_names: Vec<String>,
}

/// `(J, 4, 4)` row-major matrices as the library's (column-major) matrices.
pub fn matrices_from(value: &Bound<'_, PyAny>, what: &str, count: usize) -> PyResult<Vec<DMat4>> {
    let numbers = value.py().import("numpy")?.call_method1("asarray", (value, "float64"));
    let array = numbers.ok().and_then(|a| a.extract::<PyReadonlyArrayDyn<'_, f64>>().ok());
    let Some(array) = array.filter(|a| a.shape() == [count, 4, 4]) else {
        return Err(input_error(format!(
            "{what}: give one 4 × 4 world matrix per joint, an array of shape ({count}, 4, 4)"
        )));
    };
    let view = array.as_array();
    let matrices: Vec<DMat4> = (0..count)
        .map(|j| DMat4::from_cols_array_2d(&std::array::from_fn(|c| std::array::from_fn(|r| view[[j, r, c]]))))
        .collect();
    if let Some(j) = matrices.iter().position(|m| !m.is_finite()) {
        return Err(input_error(format!("{what}: matrix {j} is not finite")));
    }
    Ok(matrices)
}

#[pymethods]
impl Skin {
    /// `mesh`: the bind pose (a `squish.Mesh`, a `(vertices, faces)` pair…); `joints` and
    /// `weights`: `(n, k)` joint indices and weights per vertex (the four largest weights of each
    /// vertex are kept, normalized); `parents`: each joint's parent index (`None` or a negative
    /// number for a root); `names`: each joint's name (default `joint 0`, …); `bind_matrices`:
    /// the joints' world matrices at the bind pose `(J, 4, 4)`.
    #[new]
    #[pyo3(signature = (mesh, joints, weights, parents, bind_matrices, names=None))]
    fn new(
        py: Python<'_>,
        mesh: &Bound<'_, PyAny>,
        joints: &Bound<'_, PyAny>,
        weights: &Bound<'_, PyAny>,
        parents: Vec<Option<i64>>,
        bind_matrices: &Bound<'_, PyAny>,
        names: Option<Vec<String>>,
    ) -> PyResult<Self> {
        let rest = mesh_from(mesh, "mesh")?.mesh;
        let count = parents.len();
        let parents: Vec<Option<usize>> = parents
            .iter()
            .enumerate()
            .map(|(j, p)| match p {
                Some(p) if *p >= 0 => {
                    usize::try_from(*p).ok().filter(|&p| p < count && p != j).map(Some).ok_or_else(|| {
                        input_error(format!("parents: joint {j} has parent {p}, but there are {count} joints"))
                    })
                }
                _ => Ok(None),
            })
            .collect::<PyResult<_>>()?;
        let names = names.unwrap_or_else(|| (0..count).map(|j| format!("joint {j}")).collect());
        if names.len() != count {
            return Err(input_error(format!("names: {} names for {count} joints", names.len())));
        }
        let bind = matrices_from(bind_matrices, "bind_matrices", count)?;
        let weights = skin_weights(joints, weights, rest.num_vertices(), count)?;
        let points = |pair: [usize; 2]| JointPoints::of(&parents, pair, |j| j, &bind);
        let found =
            py.detach(|| automatic_self_contact(&rest, &weights, &parents, &names, |pair| points(pair).is_some()));
        let articulations =
            found.articulations.into_iter().filter_map(|a| Some((a.name, a.regions, points(a.joints)?))).collect();
        Ok(Self { rest, parts: found.parts, articulations, joint_names: names })
    }

    /// The names of the articulations `self_contact = "auto"` resolves ("parent / child").
    #[getter]
    fn articulations(&self) -> Vec<String> {
        self.articulations.iter().map(|a| a.0.clone()).collect()
    }

    /// The names of the skin's parts (faces grouped by their dominant joint).
    #[getter]
    fn parts(&self) -> Vec<String> {
        self.parts.names.clone()
    }

    /// The joints' names.
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.joint_names.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "squish.Skin({} vertices, {} joints, {} parts, {} articulations)",
            self.rest.num_vertices(),
            self.joint_names.len(),
            self.parts.names.len(),
            self.articulations.len()
        )
    }
}

impl Skin {
    /// The automatic articulations posed by the joints' world matrices `world` (one per joint).
    pub fn posed(&self, world: &[DMat4]) -> PyResult<Vec<Articulation>> {
        self.articulations
            .iter()
            .map(|(name, regions, points)| {
                let joints =
                    points.points(world).ok_or_else(|| input_error(format!("{name}: a joint matrix is missing")))?;
                Ok(Articulation {
                    name: name.clone(),
                    regions: regions.clone(),
                    joints: Some(joints),
                    params: ArticulationParams::default(),
                    automatic: true,
                })
            })
            .collect()
    }
}

/// Per-vertex joints and weights `(n, k)` as the library's four influences per vertex (the
/// largest, in a stable order).
fn skin_weights(
    joints: &Bound<'_, PyAny>,
    weights: &Bound<'_, PyAny>,
    vertices: usize,
    count: usize,
) -> PyResult<SkinWeights> {
    let numpy = joints.py().import("numpy")?;
    let read = |value: &Bound<'_, PyAny>, what: &str| -> PyResult<(Vec<f64>, usize)> {
        let array = numpy.call_method1("asarray", (value, "float64"))?;
        let array = array.extract::<PyReadonlyArrayDyn<'_, f64>>()?;
        match array.shape() {
            [n, k] if *n == vertices && *k >= 1 => Ok((array.as_array().iter().copied().collect(), *k)),
            shape => {
                Err(input_error(format!("{what}: shape {shape:?}; give ({vertices}, k): k influences per vertex")))
            }
        }
    };
    let (j, k) = read(joints, "joints")?;
    let (w, kw) = read(weights, "weights")?;
    if kw != k {
        return Err(input_error(format!("joints has {k} influences per vertex but weights {kw}; give the same")));
    }
    let mut out_joints = Vec::with_capacity(vertices);
    let mut out_weights = Vec::with_capacity(vertices);
    for v in 0..vertices {
        let mut influences: Vec<(u32, f64)> = Vec::with_capacity(k);
        for i in 0..k {
            let (joint, weight) = (j[v * k + i], w[v * k + i]);
            if weight == 0.0 {
                continue;
            }
            let valid_joint = joint >= 0.0 && joint.fract() == 0.0 && (joint as usize) < count;
            if !(valid_joint && weight.is_finite() && weight > 0.0) {
                return Err(input_error(format!(
                    "vertex {v}: joint {joint} with weight {weight}; joints are indices below {count}, weights finite and ≥ 0"
                )));
            }
            influences.push((joint as u32, weight));
        }
        influences.sort_by(|a, b| b.1.total_cmp(&a.1));
        let (mut jr, mut wr) = ([0u32; 4], [0.0f64; 4]);
        for (slot, (joint, weight)) in influences.into_iter().take(4).enumerate() {
            jr[slot] = joint;
            wr[slot] = weight;
        }
        out_joints.push(jr);
        out_weights.push(wr);
    }
    SkinWeights::new(out_joints, out_weights).map_err(|e| input_error(format!("weights: {e}")))
}
