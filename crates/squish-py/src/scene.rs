//! `squish.Scene`: a scene file, its frames, and runs of its shot that write the same files and
//! report as `squish run` ([`squish_shot::scene_run::RunPlan`], the command's own code).
//!
//! A run computes its frames in parallel with the GIL released, on a worker thread, while the
//! calling thread watches for Ctrl-C (`Python::check_signals`, every 50 ms): a `KeyboardInterrupt`
//! asks the run to stop scheduling frames, the frames in progress finish and are written, the
//! report lists the missing frames, and then the `KeyboardInterrupt` is raised with the command
//! line's message (how many frames were done and the frames to run again). A Ctrl-C that comes
//! while the last frames finish stops nothing (every frame is written and the report is
//! complete), but it is still raised, never dropped.

use std::collections::BTreeMap;
use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use glam::DVec3;
use numpy::PyArray2;
use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use squish_io::Scene as SceneFile;
use squish_io::scene::{MeshSource, OutputFormat, OutputSpec};
use squish_shot::Interrupt;
use squish_shot::ShotError;
use squish_shot::scene_run::{RunPlan, RunRequest};

use crate::errors::{input_error, io_error, json_to_python, shot_error};
use crate::frame::Frame;
use crate::mesh::{faces_array, positions_array};

/// A scene file (docs/scene-format.md), loaded with its meshes: `Scene.load(path)`.
#[pyclass(module = "squish", frozen)]
pub struct Scene {
    scene: Arc<SceneFile>,
}

/// Frames as the user gives them, by Python's conventions (docs/python.md, "Frames"): `None` (the
/// scene's), an int (that frame), a `range` (half-open, as Python's: `range(1, 4)` is frames 1, 2
/// and 3), a list, tuple or array of frames (those frames, which must follow each other: `[1, 2,
/// 3]`), or text `"A:B"` (inclusive, as `squish run --frames`). A sequence that skips frames —
/// `(1, 3)`, which once meant 1 to 3 — is refused with the spellings that say what was meant.
fn frame_selection(scene: &SceneFile, frames: Option<&Bound<'_, PyAny>>) -> PyResult<Option<RangeInclusive<i64>>> {
    let Some(frames) = frames else { return Ok(None) };
    let shown = frames.repr().map_or_else(|_| "?".to_string(), |r| r.to_string());
    let invalid = |why: &str| {
        input_error(format!(
            "frames={shown}: {why}; give a frame (12), a range (range(1, 25) is frames 1 to 24), consecutive frames ([1, 2, 3]) or \"1:24\" (inclusive)"
        ))
    };
    let text = if let Ok(text) = frames.extract::<String>() {
        text
    } else if frames.is_instance_of::<pyo3::types::PyBool>() {
        return Err(invalid("a boolean is not a frame"));
    } else if let Ok(frame) = frames.extract::<i64>() {
        format!("{frame}")
    } else if frames.get_type().name()? == "range" {
        let (start, stop, step): (i64, i64, i64) = (
            frames.getattr("start")?.extract()?,
            frames.getattr("stop")?.extract()?,
            frames.getattr("step")?.extract()?,
        );
        if step != 1 {
            return Err(invalid("a run computes consecutive frames (step 1)"));
        }
        if stop <= start {
            return Err(invalid("the range is empty"));
        }
        format!("{start}:{}", stop - 1)
    } else if let Ok(list) = frames.extract::<Vec<i64>>() {
        let (Some(&first), Some(&last)) = (list.first(), list.last()) else {
            return Err(invalid("no frame"));
        };
        if list.windows(2).any(|w| w[1] != w[0] + 1) {
            let hint = if list.len() == 2 && last > first {
                format!(" (for frames {first} to {last}: range({first}, {}) or \"{first}:{last}\")", last + 1)
            } else {
                String::new()
            };
            return Err(invalid(&format!(
                "a list gives the frames themselves, and these do not follow each other{hint}"
            )));
        }
        format!("{first}:{last}")
    } else {
        return Err(invalid("not a frame selection"));
    };
    squish_io::parse_frame_selection(&text, &scene.frame_range())
        .map(Some)
        .map_err(|error| shot_error(ShotError::Frames { scene: scene.path().to_path_buf(), error }))
}

/// An output format by its extension.
fn output_format(format: Option<&str>) -> PyResult<Option<OutputFormat>> {
    let Some(format) = format else { return Ok(None) };
    let formats = [OutputFormat::Obj, OutputFormat::Ply, OutputFormat::Glb, OutputFormat::Gltf, OutputFormat::Pc2];
    formats
        .into_iter()
        .find(|f| f.extension() == format)
        .map(Some)
        .ok_or_else(|| input_error(format!("format \"{format}\": use \"obj\", \"ply\", \"glb\", \"gltf\" or \"pc2\"")))
}

#[pymethods]
impl Scene {
    /// Reads, checks and loads a scene file and every mesh and data file it names.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let scene = py.detach(|| SceneFile::load(&path)).map_err(io_error)?;
        Ok(Self { scene: Arc::new(scene) })
    }

    /// The scene file.
    #[getter]
    fn path(&self) -> PathBuf {
        self.scene.path().to_path_buf()
    }

    /// The scene's frames, `(first, last)` inclusive (the scene file's `frames`).
    #[getter]
    fn frame_range(&self) -> (i64, i64) {
        let r = self.scene.frame_range();
        (r.start, r.end)
    }

    /// The scene's frames as a Python `range` (`range(first, last + 1)`).
    #[getter]
    fn frames<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let r = self.scene.frame_range();
        py.import("builtins")?.getattr("range")?.call1((r.start, r.end + 1))
    }

    /// Frames per second.
    #[getter]
    fn fps(&self) -> f64 {
        self.scene.frame_range().fps
    }

    /// The objects' names, in order.
    #[getter]
    fn objects(&self) -> Vec<String> {
        self.scene.description().objects.iter().map(|o| o.name.clone()).collect()
    }

    /// The output folder (the scene's `output.dir`, absolute) and format.
    #[getter]
    fn output(&self) -> (PathBuf, &'static str) {
        let output = self.scene.output();
        (output.dir.clone(), output.format.extension())
    }

    /// The frame `frame` as a `squish.Frame`: every object posed, with its parameters at that
    /// frame, and every pair enabled at that frame.
    fn frame<'py>(&self, py: Python<'py>, frame: f64) -> PyResult<Bound<'py, PyAny>> {
        let scene = &self.scene;
        let spec = py.detach(|| scene.evaluate(frame)).map_err(io_error)?;
        // The package's `squish.Frame` (the subclass with the documented methods).
        let object = py.import("squish")?.getattr("Frame")?.call0()?;
        object.cast::<Frame>()?.borrow_mut().frame = spec;
        Ok(object)
    }

    /// Runs the shot as `squish run` does: frames in parallel, each frame's files written
    /// atomically as it is done, `report.A-B.json` for the frames run and `report.json` merging
    /// every part in the folder. `output`: the folder (default: the scene's); `frames`: the frames
    /// to run — a frame, a `range` (half-open: `range(1, 25)` is 1 to 24), consecutive frames
    /// `[1, 2, 3]`, or `"A:B"` (inclusive, as `--frames`); default every frame; a selection writes
    /// a part, like `--frames`; `threads`: worker threads (default: every core); `format`: "obj",
    /// "ply", "glb", "gltf" or "pc2" (default: the scene's); `keep_points`: keep every frame's
    /// output vertices in the result (`ShotResult.points`, `squish.usd.write_shot`).
    ///
    /// Raises `InputError` for a bad scene or frame (after writing the report of the frames done),
    /// and `KeyboardInterrupt` after Ctrl-C, once the frames in progress are written and the report
    /// lists the missing frames.
    #[pyo3(signature = (output=None, frames=None, threads=None, format=None, keep_points=false))]
    fn run(
        &self,
        py: Python<'_>,
        output: Option<PathBuf>,
        frames: Option<&Bound<'_, PyAny>>,
        threads: Option<usize>,
        format: Option<&str>,
        keep_points: bool,
    ) -> PyResult<ShotResult> {
        let request = RunRequest {
            frames: frame_selection(&self.scene, frames)?,
            output_dir: output,
            format: output_format(format)?,
            threads,
            allow_missing_files: false,
        };
        let scene = &self.scene;
        let plan = py.detach(|| RunPlan::new(scene, &request)).map_err(shot_error)?;
        let interrupt = Interrupt::new();
        let (run, keyboard) = py.detach(|| {
            std::thread::scope(|s| {
                let worker = s.spawn(|| plan.run(None, keep_points, &interrupt));
                let mut keyboard: Option<PyErr> = None;
                while !worker.is_finished() {
                    std::thread::sleep(Duration::from_millis(50));
                    if keyboard.is_none()
                        && let Err(error) = Python::attach(|py| py.check_signals())
                    {
                        interrupt.request();
                        keyboard = Some(error);
                    }
                }
                let run = worker.join().unwrap_or_else(|_| {
                    Err(ShotError::Internal("internal error: the run's worker thread panicked".into()))
                });
                (run, keyboard)
            })
        });
        let mut run = run.map_err(shot_error)?;
        if let Some(error) = run.animated_error.take() {
            return Err(shot_error(error));
        }
        if let Some(failed) = run.failed_error() {
            return Err(shot_error(failed));
        }
        if let Some(stopped) = run.interrupted_error() {
            // A KeyboardInterrupt that is not Python's own (a signal handler raising something
            // else) is raised as it was.
            return Err(match keyboard {
                Some(error) if !error.is_instance_of::<PyKeyboardInterrupt>(py) => error,
                _ => shot_error(stopped),
            });
        }
        if let Some(error) = keyboard {
            // Caught while the last frames were finishing: nothing was left to stop.
            return Err(if error.is_instance_of::<PyKeyboardInterrupt>(py) {
                PyKeyboardInterrupt::new_err(format!(
                    "interrupted after the last frame: every frame was done (report: {})",
                    run.report.display()
                ))
            } else {
                error
            });
        }
        let report_text = std::fs::read_to_string(&run.report)
            .map_err(|e| input_error(format!("cannot read {}: {e}", run.report.display())))?;
        let objects = plan
            .first
            .objects
            .iter()
            .zip(&plan.numbering)
            .zip(&self.scene.description().objects)
            .map(|((object, numbering), spec)| ShotObject {
                name: object.name.clone(),
                source: spec.mesh.file().clone(),
                sequence: matches!(spec.mesh, MeshSource::Sequence { .. }),
                triangles: numbering.triangles.clone(),
                vertex_map: numbering.vertex_map.clone(),
            })
            .collect();
        Ok(ShotResult {
            output: plan.output.dir.clone(),
            format: plan.output.format.extension(),
            fps: self.scene.frame_range().fps,
            frames: run.outcome.records.iter().map(|r| r.frame).collect(),
            report_path: run.report,
            part_report_path: run.part_report,
            report_text,
            objects,
            points: std::mem::take(&mut run.outcome.kept),
        })
    }

    /// The frames whose results are already in `output` (default: the scene's folder): listed by
    /// a report part there, with every object's file of the frame present (for glb, gltf and pc2,
    /// the file of the run that computed it: its part `<object>.A-B.<ext>`, or the whole shot's).
    #[pyo3(signature = (output=None, format=None))]
    fn completed_frames(&self, output: Option<PathBuf>, format: Option<&str>) -> PyResult<Vec<i64>> {
        let spec = self.output_spec(output, format)?;
        Ok(squish_shot::parts::completed_frames(&self.scene, &spec))
    }

    /// Merges what the runs of parts of the shot (`run(frames=…)`, Ray tasks) wrote into `output`
    /// (default: the scene's folder): the report parts into `report.json`, and for glb, gltf and
    /// pc2 the parts `<object>.A-B.<ext>` into `<object>.<ext>` — the file one run of the whole
    /// shot writes, byte for byte — once they hold every frame. Returns a dict: `report` (the
    /// merged report's path), `files` (the merged files), `incomplete` (per object whose parts
    /// miss frames, the frames missing as `"A:B"` runs).
    #[pyo3(signature = (output=None, format=None))]
    fn merge<'py>(
        &self,
        py: Python<'py>,
        output: Option<PathBuf>,
        format: Option<&str>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let spec = self.output_spec(output, format)?;
        let scene = &self.scene;
        let range = scene.frame_range();
        let (report, merged) = py
            .detach(|| {
                let merged = squish_shot::parts::merge_parts(scene, &spec)?;
                let report = squish_shot::report_parts::merge_reports(&spec.dir, range.start, range.end)?;
                Ok((report, merged))
            })
            .map_err(shot_error)?;
        let result = PyDict::new(py);
        result.set_item("report", report)?;
        result.set_item("files", merged.files)?;
        result.set_item("incomplete", merged.incomplete.into_iter().collect::<BTreeMap<String, Vec<String>>>())?;
        Ok(result)
    }

    fn __repr__(&self) -> String {
        let r = self.scene.frame_range();
        format!(
            "squish.Scene({:?}, {} objects, frames {}:{})",
            self.scene.path().display().to_string(),
            self.scene.description().objects.len(),
            r.start,
            r.end
        )
    }
}

impl Scene {
    /// The scene's output folder and format, or the ones given.
    fn output_spec(&self, output: Option<PathBuf>, format: Option<&str>) -> PyResult<OutputSpec> {
        let mut spec = self.scene.output().clone();
        if let Some(dir) = output {
            spec.dir = std::path::absolute(&dir).unwrap_or(dir);
        }
        if let Some(format) = output_format(format)? {
            spec.format = format;
        }
        Ok(spec)
    }
}

/// An object of a shot's result.
#[derive(Clone, Debug)]
struct ShotObject {
    name: String,
    source: PathBuf,
    sequence: bool,
    /// The file's triangles, in the file's numbering.
    triangles: Vec<[u32; 3]>,
    /// File vertex → processed vertex, when the scene welded the source.
    vertex_map: Option<Vec<u32>>,
}

/// The result of `Scene.run`: where the files are, the merged report, and (with `keep_points`)
/// every frame's output vertices in each source file's numbering.
#[pyclass(module = "squish", frozen)]
pub struct ShotResult {
    output: PathBuf,
    format: &'static str,
    fps: f64,
    frames: Vec<i64>,
    report_path: PathBuf,
    part_report_path: PathBuf,
    report_text: String,
    objects: Vec<ShotObject>,
    points: BTreeMap<i64, Vec<Vec<DVec3>>>,
}

#[pymethods]
impl ShotResult {
    /// The output folder.
    #[getter]
    fn output(&self) -> PathBuf {
        self.output.clone()
    }

    /// The output format's extension.
    #[getter]
    fn format(&self) -> &'static str {
        self.format
    }

    /// Frames per second of the scene.
    #[getter]
    fn fps(&self) -> f64 {
        self.fps
    }

    /// The frames computed by this run, in order.
    #[getter]
    fn frames(&self) -> Vec<i64> {
        self.frames.clone()
    }

    /// The merged `report.json` (path).
    #[getter]
    fn report_path(&self) -> PathBuf {
        self.report_path.clone()
    }

    /// This run's report part `report.A-B.json` (path).
    #[getter]
    fn part_report_path(&self) -> PathBuf {
        self.part_report_path.clone()
    }

    /// The merged `report.json` as a dict.
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_python(py, &self.report_text)
    }

    /// The objects' names, in order.
    #[getter]
    fn objects(&self) -> Vec<String> {
        self.objects.iter().map(|o| o.name.clone()).collect()
    }

    /// The source file of an object (its mesh file, the glTF file, or a sequence's pattern), and
    /// whether it is a sequence.
    fn source(&self, object: usize) -> PyResult<(PathBuf, bool)> {
        let o = self.object(object)?;
        Ok((o.source.clone(), o.sequence))
    }

    /// The faces of an object in its source file's numbering, int64 `(m, 3)`.
    fn faces<'py>(&self, py: Python<'py>, object: usize) -> PyResult<Bound<'py, PyArray2<i64>>> {
        faces_array(py, &self.object(object)?.triangles)
    }

    /// Every object's output vertices at `frame`, in its source file's numbering (float64
    /// `(n, 3)` arrays). Needs `keep_points=True` in `Scene.run`.
    fn points<'py>(&self, py: Python<'py>, frame: i64) -> PyResult<Vec<Bound<'py, PyArray2<f64>>>> {
        let Some(positions) = self.points.get(&frame) else {
            let why = if self.points.is_empty() {
                "run the scene with keep_points=True to keep the output vertices".to_string()
            } else {
                format!("frames {}:{} were run", self.frames.first().unwrap_or(&0), self.frames.last().unwrap_or(&0))
            };
            return Err(input_error(format!("frame {frame}: no output vertices kept; {why}")));
        };
        positions
            .iter()
            .zip(&self.objects)
            .map(|(p, o)| match &o.vertex_map {
                Some(map) => {
                    let file: Vec<DVec3> = map.iter().map(|&v| p[v as usize]).collect();
                    positions_array(py, &file)
                }
                None => positions_array(py, p),
            })
            .collect()
    }

    fn __repr__(&self) -> String {
        format!(
            "squish.ShotResult({} frames, {} objects, {:?})",
            self.frames.len(),
            self.objects.len(),
            self.output.display().to_string()
        )
    }
}

impl ShotResult {
    fn object(&self, i: usize) -> PyResult<&ShotObject> {
        self.objects
            .get(i)
            .ok_or_else(|| input_error(format!("object {i}: the shot has {} objects", self.objects.len())))
    }
}

/// Merges every report part `report.A-B.json` in `output` into `output/report.json` (frames
/// `first..=last` of the scene; the missing ones listed in `missing_frames`), as `squish run`
/// does after each run. Returns the merged report's path.
#[pyfunction]
pub fn merge_reports(py: Python<'_>, output: PathBuf, first: i64, last: i64) -> PyResult<PathBuf> {
    let dir: &Path = &output;
    py.detach(|| squish_shot::report_parts::merge_reports(dir, first, last)).map_err(shot_error)
}
