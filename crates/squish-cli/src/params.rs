//! Parameters from the command line: `--params FILE.toml` and `--set KEY=VALUE`.
//!
//! Keys are the library's schema keys ([`squish::params`]) with a prefix naming what they apply
//! to: `a.` and `b.` for the two objects, `pair.` for the pair (`--set a.stiffness=2`,
//! `--set pair.contact_method=ball --set pair.ball_radius=0.3`). A parameters file has the same
//! keys in tables `[a]`, `[b]`, `[pair]`. Nothing here lists parameters: every key of the schema
//! is settable, and an unknown key is an error with the key meant.
//!
//! Values are read by the key's kind ([`squish::params::ParamInfo::parse`]): numbers, `true` /
//! `false`, vectors `0,1,0`, words (`auto`, `ball` …). A per-vertex parameter (`bulge_map`,
//! `region_mask`) is a list of numbers, a text file with one number per line, or an attribute
//! (`{ file = "mesh.ply", attribute = "bulge" }`); files are read with the meshes
//! ([`PairSettings::read_per_vertex`]).

use std::path::{Path, PathBuf};

use squish::params::{MappingMethod, ObjectParams, PairParams, ParamError, ParamKind, ParamValue, Params, Uvs};
use squish_io::scene::{VertexData, names_vertex_data, param_value, read_vertex_map};
use squish_shot::two_objects::PairParameters;

use crate::error::CliError;
use crate::input::InputMesh;

/// Parameters of a two-object command (`contact`, `deform`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PairSettings {
    pub a: ObjectParams,
    pub b: ObjectParams,
    pub pair: PairParams,
    /// Per-vertex parameters given as files: (object 0 or 1, key, data, where it was given).
    per_vertex: Vec<(usize, &'static str, VertexData, String)>,
}

/// The texture coordinates of a two-object command's input for the shared-parametrization mapping
/// (thesis §4.2.1): the file's (`squish_io::document_uvs`), per corner of the welded mesh when
/// it was welded. A file without them is an error naming it and the fix.
pub fn input_uvs(input: &InputMesh) -> Result<Uvs, CliError> {
    let uvs = squish_io::document_uvs(&input.document).map_err(|reason| {
        CliError::input(format!(
            "{}: pair.mapping = shared_parametrization matches the meshes in UV space (thesis §4.2.1), but {reason}; export the mesh with UVs or use pair.mapping=unique_direction",
            input.path.display()
        ))
    })?;
    Ok(match input.weld_map() {
        Some(map) => squish_io::welded_uvs(&uvs, &input.file.triangles, map),
        None => uvs,
    })
}

/// Where a value comes from, for messages: `--set a.extent=-1`, `params.toml: [a]`.
fn set_error(context: &str, e: ParamError) -> CliError {
    CliError::input(format!("{context}: {e}"))
}

impl PairSettings {
    /// The parameters set, for the one-frame calls of the shot machinery.
    pub fn parameters(&self) -> PairParameters {
        PairParameters { a: self.a.clone(), b: self.b.clone(), pair: self.pair }
    }

    /// The object of a prefix (`a` → 0, `b` → 1).
    fn object(&mut self, which: usize) -> &mut ObjectParams {
        if which == 0 { &mut self.a } else { &mut self.b }
    }

    /// Sets `prefix.key` to a value read by `read` (from `--set` text or a file's value).
    fn set(
        &mut self,
        prefix: &str,
        key: &str,
        context: &str,
        mut read: impl FnMut(&squish::params::ParamInfo) -> Result<Option<ParamValue>, String>,
    ) -> Result<(), CliError> {
        let unknown_prefix = || {
            CliError::input(format!(
                "{context}: \"{prefix}\" is not a, b or pair; write a.KEY, b.KEY or pair.KEY (see `squish params`)"
            ))
        };
        let fail = |info: &squish::params::ParamInfo, message: String| {
            set_error(context, ParamError::new(&info.qualified(prefix), None, message))
        };
        match prefix {
            "a" | "b" => {
                let which = usize::from(prefix == "b");
                let info = ObjectParams::info(key).ok_or_else(|| {
                    set_error(context, squish::params::unknown_key::<ObjectParams>(key).with_prefix(prefix))
                })?;
                match read(info).map_err(|m| fail(info, m))? {
                    Some(value) => {
                        self.per_vertex.retain(|(w, k, ..)| !(*w == which && *k == info.key));
                        self.object(which).set(key, &value).map_err(|e| set_error(context, e.with_prefix(prefix)))
                    }
                    None => Ok(()),
                }
            }
            "pair" => {
                let info = PairParams::info(key).ok_or_else(|| {
                    set_error(context, squish::params::unknown_key::<PairParams>(key).with_prefix(prefix))
                })?;
                match read(info).map_err(|m| fail(info, m))? {
                    Some(value) => self.pair.set(key, &value).map_err(|e| set_error(context, e.with_prefix(prefix))),
                    None => Ok(()),
                }
            }
            _ => Err(unknown_prefix()),
        }
    }

    /// Applies `--set KEY=VALUE`.
    pub fn apply_set(&mut self, set: &str) -> Result<(), CliError> {
        let context = format!("--set {set}");
        let (key, text) = set
            .split_once('=')
            .ok_or_else(|| CliError::input(format!("{context}: expected KEY=VALUE, e.g. --set a.extent=0.4")))?;
        let (prefix, key) = key.trim().split_once('.').ok_or_else(|| {
            CliError::input(format!("{context}: the key needs its object: a.{0}, b.{0} or pair.{0}", key.trim()))
        })?;
        let text = text.trim().to_string();
        let which = usize::from(prefix == "b");
        let mut file = None;
        self.set(prefix, key, &context, |info| {
            // A list of numbers or the key's word (`uniform`, `none`: the default) is a value;
            // anything else names a file.
            let value = info.parse(&text);
            if info.kind == ParamKind::PerVertex
                && !value.as_ref().is_ok_and(|v| matches!(v, ParamValue::List(_) | ParamValue::Word(_)))
            {
                let data = if text.starts_with('{') {
                    let value: toml::Value = toml::from_str(&format!("v = {text}"))
                        .map_err(|e| format!("cannot read {text}: {}", e.message()))?;
                    VertexData::from_value(&value["v"])?
                } else {
                    VertexData::Text { file: PathBuf::from(&text) }
                };
                file = Some((info.key, data));
                return Ok(None);
            }
            value.map(Some)
        })?;
        if let Some((key, data)) = file {
            self.per_vertex.push((which, key, data, context));
        }
        Ok(())
    }

    /// Merges a parameters file: tables `[a]`, `[b]`, `[pair]` of schema keys.
    pub fn apply_file(&mut self, path: &Path) -> Result<(), CliError> {
        let text = std::fs::read_to_string(path).map_err(|e| {
            let hint = match e.kind() {
                std::io::ErrorKind::NotFound => "; check the path (relative paths start from the current directory)",
                std::io::ErrorKind::IsADirectory => "; it is a folder: give a TOML file with tables [a], [b], [pair]",
                _ => "",
            };
            CliError::input(format!("cannot read parameters {}: {e}{hint}", path.display()))
        })?;
        // One line naming the file and line (the error's own display draws the line in ASCII art).
        let table: toml::Table = toml::from_str(&text).map_err(|e| {
            let line = e.span().map_or(1, |s| text[..s.start.min(text.len())].matches('\n').count() + 1);
            CliError::input(format!("{}:{line}: invalid TOML: {}", path.display(), e.message().trim()))
        })?;
        let base = path.parent().unwrap_or(Path::new("."));
        for (prefix, entries) in &table {
            let context = format!("{}: [{prefix}]", path.display());
            let toml::Value::Table(entries) = entries else {
                return Err(CliError::input(format!(
                    "{}: \"{prefix}\" must be a table [a], [b] or [pair] of parameters",
                    path.display()
                )));
            };
            for (key, value) in entries {
                let which = usize::from(prefix == "b");
                let mut file = None;
                self.set(prefix, key, &context, |info| {
                    if names_vertex_data(info, value) {
                        let mut data = VertexData::from_value(value)?;
                        if let Some(f) = data.file_mut().filter(|f| f.is_relative()) {
                            *f = base.join(&*f);
                        }
                        file = Some((info.key, data));
                        return Ok(None);
                    }
                    param_value(value).map(Some).map_err(|m| format!("{m}; expected {}", info.expected()))
                })?;
                if let Some((key, data)) = file {
                    self.per_vertex.push((which, key, data, context.clone()));
                }
            }
        }
        Ok(())
    }

    /// Completes the settings for the two meshes: reads the per-vertex parameters given as
    /// files, then checks every parameter, and that per-vertex lists have one value per vertex.
    pub fn complete(&mut self, inputs: &[InputMesh; 2]) -> Result<(), CliError> {
        self.read_per_vertex(inputs)?;
        self.validate()?;
        if self.pair.mapping == MappingMethod::SharedParametrization {
            for (which, input) in inputs.iter().enumerate() {
                self.object(which).uvs = Some(input_uvs(input)?);
            }
        }
        for (prefix, params, input) in [("a", &self.a, &inputs[0]), ("b", &self.b, &inputs[1])] {
            for info in ObjectParams::schema().iter().filter(|i| i.kind == ParamKind::PerVertex) {
                let Some(ParamValue::List(values)) = params.get(info.key) else { continue };
                let vertices = input.mesh.num_vertices();
                if values.len() != vertices {
                    return Err(CliError::input(format!(
                        "{prefix}.{}: {} values for the {vertices} vertices of {}; give one value per vertex (a list, a text file with one number per line, or {{ attribute = \"name\" }})",
                        info.key,
                        values.len(),
                        input.path.display()
                    )));
                }
            }
        }
        Ok(())
    }

    /// Reads the per-vertex parameters given as files, for the two meshes.
    fn read_per_vertex(&mut self, inputs: &[InputMesh; 2]) -> Result<(), CliError> {
        for (which, key, data, context) in std::mem::take(&mut self.per_vertex) {
            let input = &inputs[which];
            // The file's own message names the file; the context names the key that gave it.
            let values = read_vertex_map(&data, &input.path, input.mesh.num_vertices(), input.weld_map(), key)
                .map_err(|e| CliError::input(format!("{context}: {e}")))?;
            self.object(which)
                .set(key, &ParamValue::List(values))
                .map_err(|e| set_error(&context, e.with_prefix(if which == 0 { "a" } else { "b" })))?;
        }
        Ok(())
    }

    /// Checks every parameter and the conditions between them.
    pub(crate) fn validate(&self) -> Result<(), CliError> {
        let check = |prefix: &str, result: Result<(), ParamError>| {
            result.map_err(|e| CliError::input(format!("parameters: {}", e.with_prefix(prefix))))
        };
        check("a", self.a.validate())?;
        check("b", self.b.validate())?;
        check("pair", self.pair.validate())?;
        if self.a.rigid && self.b.rigid {
            return Err(CliError::input(
                "parameters: a.rigid and b.rigid are both true, so neither object can deform; set one of them to false (--set b.rigid=false)",
            ));
        }
        Ok(())
    }
}

/// Reads `--params` (if any), then applies every `--set`, in order.
pub fn pair_settings(params_file: Option<&Path>, sets: &[String]) -> Result<PairSettings, CliError> {
    let mut settings = PairSettings::default();
    if let Some(path) = params_file {
        settings.apply_file(path)?;
    }
    for set in sets {
        settings.apply_set(set)?;
    }
    Ok(settings)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use squish::params::{ContactMethod, DirectionFieldMethod, MappingMethod, RegionChoice};

    fn sets(items: &[&str]) -> Vec<String> {
        items.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn set_applies_values_to_the_library_structures() {
        let s = pair_settings(
            None,
            &sets(&[
                "b.rigid=true",
                "a.extent=0.4",
                "pair.contact_tau=0.5",
                "pair.direction=0,1,0",
                "a.bulge=1.5",
                "a.profile_v2=0.4",
                "b.direction_field=parallel_transport",
                "pair.contact_method=ball",
                "pair.ball_radius=0.3",
                "pair.mapping=shared_parametrization",
                "a.region=components",
                "b.region=distance",
                "b.region_distance=0.5",
            ]),
        )
        .unwrap();
        assert!(s.b.rigid);
        assert_eq!((s.a.extent, s.a.bulge, s.a.profile_v2), (Some(0.4), 1.5, 0.4));
        assert_eq!((s.pair.contact_tau, s.pair.direction), (0.5, Some(glam::DVec3::Y)));
        assert_eq!((s.pair.contact_method, s.pair.ball()), (ContactMethod::Ball, Some(0.3)));
        assert_eq!(s.pair.mapping, MappingMethod::SharedParametrization);
        assert_eq!(s.b.direction_field, DirectionFieldMethod::ParallelTransport);
        assert_eq!(
            (s.a.region, s.b.region, s.b.region_distance),
            (RegionChoice::Components, RegionChoice::Distance, 0.5)
        );
        assert_eq!(pair_settings(None, &sets(&["a.extent=auto"])).unwrap().a.extent, None);
        s.validate().unwrap();
    }

    #[test]
    fn unknown_keys_and_bad_values_name_the_key_and_the_fix() {
        let err = |items: &[&str]| pair_settings(None, &sets(items)).unwrap_err().to_string();
        let e = err(&["a.extnet=0.4"]);
        assert!(e.contains("a.extnet") && e.contains("did you mean \"a.extent\""), "{e}");
        let e = err(&["c.extent=0.4"]);
        assert!(e.contains("\"c\" is not a, b or pair"), "{e}");
        let e = err(&["a.stiffness=soft"]);
        assert!(e.contains("a.stiffness") && e.contains("cannot read \"soft\""), "{e}");
        let e = err(&["a.stiffness=nan"]);
        assert!(e.contains("a.stiffness") && e.contains("cannot read \"nan\""), "{e}");
        let e = err(&["a.rigid=maybe"]);
        assert!(e.contains("a.rigid") && e.contains("true or false"), "{e}");
        let e = err(&["a.extent"]);
        assert!(e.contains("KEY=VALUE"), "{e}");
        let e = err(&["a.profile.x2=0.4"]);
        assert!(e.contains("renamed (did you mean \"a.profile_v2\""), "{e}");
        let e = err(&["pair.safeguard_angle_degrees=70"]);
        assert!(e.contains("renamed (did you mean \"pair.safeguard_angle\""), "{e}");
        let s = pair_settings(None, &sets(&["pair.contact_method=ball"])).unwrap();
        let e = s.validate().unwrap_err().to_string();
        assert!(e.contains("pair.ball_radius") && e.contains("needs ball_radius"), "{e}");
    }

    /// The documented defaults of the per-vertex keys are words, not files: `--set` and a
    /// parameters file take them and put the default back over an earlier value.
    #[test]
    fn the_per_vertex_keys_take_their_default_words() {
        let s =
            pair_settings(None, &sets(&["a.bulge_map=0.5,1,1", "a.bulge_map=uniform", "b.region_mask=none"])).unwrap();
        assert_eq!((s.a.bulge_map.clone(), s.b.region_mask.clone()), (None, None));
        assert!(s.per_vertex.is_empty(), "no file to read");
        let s = pair_settings(None, &sets(&["a.region_mask=1,1,0"])).unwrap();
        assert_eq!(s.a.region_mask, Some(vec![1.0, 1.0, 0.0]));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("params.toml");
        std::fs::write(&path, "[a]\nbulge_map = \"uniform\"\nregion_mask = \"none\"\n").unwrap();
        let s = pair_settings(Some(&path), &[]).unwrap();
        assert!(s.a.bulge_map.is_none() && s.a.region_mask.is_none() && s.per_vertex.is_empty());
        // Any other word is still a file, with the file's message.
        let s = pair_settings(None, &sets(&["a.bulge_map=paint.txt"])).unwrap();
        assert_eq!(s.per_vertex.len(), 1);
    }

    #[test]
    fn a_parameters_file_is_merged_then_overridden_by_set() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("params.toml");
        std::fs::write(&path, "[a]\nextent = 0.3\nbulge = 2.0\nprofile_v2 = 0.45\n[pair]\ncontact_tau = -0.5\n")
            .unwrap();
        let s = pair_settings(Some(&path), &sets(&["a.bulge=0.5"])).unwrap();
        assert_eq!((s.a.extent, s.a.bulge, s.a.profile_v2, s.pair.contact_tau), (Some(0.3), 0.5, 0.45, -0.5));
        std::fs::write(&path, "[a]\nstifness = 2\n").unwrap();
        let e = pair_settings(Some(&path), &[]).unwrap_err().to_string();
        assert!(e.contains("stifness") && e.contains("params.toml"), "{e}");
        std::fs::write(&path, "[a]\nstiffness = nan\n").unwrap();
        let e = pair_settings(Some(&path), &[]).unwrap_err().to_string();
        assert!(e.contains("params.toml: [a]: a.stiffness = NaN: must be > 0"), "{e}");
    }
}
