//! Checks of a deserialized scene that serde cannot express: the parameters of every table
//! against the library's schema ([`super::tracks`]: kinds, ranges at every key, conditions between
//! keys at every frame), names that must be unique or must exist, combinations that make no
//! sense. Every error points at the key in the file and says what to write instead.
//!
//! Keyed values are checked at their keys: linear, smooth and step curves never leave the range
//! of their neighbouring keys, so a bound that holds at every key holds at every frame.
//! Conditions that interpolation can break (profile abscissas in order, a direction or scale
//! passing through zero) are checked at every whole frame of the scene and at every key; frame
//! evaluation checks them again at fractional frames.

use std::collections::HashMap;

use squish::animation::KeyInterpolation;
use squish::params::{ArticulationParams, ObjectParams, PairParams, ParamInfo, ParamValue, Params};
use toml::Value;

use super::diagnostics::{Seg, SourceText};
use super::frames::FramePattern;
use super::tracks::{ParamTracks, RawParams, TrackError};
use super::transform::Scale;
use super::types::{MeshSource, ObjectSpec, SceneDescription, SelfContactSpec, VertexData};
use crate::IoError;

/// Longest accepted shot: beyond this a frame range is surely a typo, and checking every frame
/// would take noticeable time.
pub(crate) const MAX_FRAMES: i64 = 1_000_000;

/// Largest frame number: 2⁵³, beyond which an `f64` (frames become times and keyframe
/// positions) no longer holds every whole number, and far from `i64`'s ends so that a frame ± 1
/// never overflows.
pub(crate) const MAX_FRAME_NUMBER: u64 = 1 << 53;

pub(crate) fn validate(scene: &SceneDescription, src: &SourceText) -> Result<(), IoError> {
    if let Some(problem) = scene.preview.as_ref().and_then(|p| p.problem()) {
        return Err(src.error_at_key(&[Seg::Key("preview")], problem));
    }
    let f = &scene.frames;
    if f.end < f.start {
        return Err(src.error_at_key(
            &[Seg::Key("frames"), Seg::Key("end")],
            format!("end {} is before start {}; frames are inclusive, so end must be ≥ start", f.end, f.start),
        ));
    }
    for (key, frame) in [("start", f.start), ("end", f.end)] {
        if frame.unsigned_abs() > MAX_FRAME_NUMBER {
            return Err(src.error_at_key(
                &[Seg::Key("frames"), Seg::Key(key)],
                format!(
                    "frame {frame} is beyond ±{MAX_FRAME_NUMBER}, where whole frames stop being exact in time \
                     computations; use frame numbers such as 1 to 240"
                ),
            ));
        }
    }
    // In i128: `end − start + 1` of two i64 can overflow i64.
    let count = f.end as i128 - f.start as i128 + 1;
    if count > MAX_FRAMES as i128 {
        return Err(src.error_at_key(
            &[Seg::Key("frames"), Seg::Key("end")],
            format!("{count} frames is more than the {MAX_FRAMES} a scene may hold; check start and end"),
        ));
    }
    if !(f.fps.is_finite() && f.fps > 0.0) {
        return Err(src.error_at_key(
            &[Seg::Key("frames"), Seg::Key("fps")],
            format!("fps must be a positive number, got {}", f.fps),
        ));
    }
    if scene.output.dir.as_os_str().is_empty() {
        return Err(
            src.error_at_key(&[Seg::Key("output"), Seg::Key("dir")], "dir is empty; give a folder, e.g. \"out\"")
        );
    }
    if scene.objects.is_empty() {
        return Err(src.error_at(0, "the scene has no [[objects]]; add at least one with a name and a mesh"));
    }
    let shot = || (f.start..=f.end).map(|x| x as f64);
    let mut names: HashMap<&str, usize> = HashMap::new();
    let mut rigid = Vec::with_capacity(scene.objects.len());
    for (i, object) in scene.objects.iter().enumerate() {
        let err = |key: &str, m: String| src.error_at_key(&[Seg::Key("objects"), Seg::Index(i), Seg::Key(key)], m);
        check_name(&object.name).map_err(|m| err("name", m))?;
        if let Some(first) = names.insert(&object.name, i) {
            return Err(err(
                "name",
                format!(
                    "the name \"{}\" is already used by object #{}; object names must be unique (they name the output folders)",
                    object.name,
                    first + 1
                ),
            ));
        }
        let params: ObjectParams = check_params(&object.params, ObjectSpec::TABLE_KEYS, shot(), err)?;
        rigid.push(params.rigid);
        validate_object(object, shot(), err)?;
        if object.self_contact.auto && params.rigid {
            return Err(err(
                "self_contact",
                format!(
                    "object \"{}\" is rigid, so it never deforms and self_contact = \"auto\" would be ignored; set rigid = false or remove self_contact",
                    object.name
                ),
            ));
        }
        if !object.articulations.is_empty() && !object.self_contact.auto {
            return Err(err(
                "articulations",
                "[objects.articulations] sets the parameters of automatic articulations; it needs self_contact = \"auto\" (explicit [[objects.self_contact]] entries hold their own parameters)".to_string(),
            ));
        }
        for (name, raw) in &object.articulations {
            let path = [Seg::Key("objects"), Seg::Index(i), Seg::Key("articulations"), Seg::Key(name)];
            let located = |key: &str, m: String| {
                let mut at = path.to_vec();
                at.push(Seg::Key(key));
                src.error_at_key(&at, m)
            };
            check_params::<ArticulationParams>(raw, &[], shot(), located)?;
        }
        validate_self_contact(object, params.rigid, shot, |k, key, m| {
            let path = [Seg::Key("objects"), Seg::Index(i), Seg::Key("self_contact"), Seg::Index(k), Seg::Key(key)];
            src.error_at_key(&path, m)
        })?;
    }
    let mut seen_pairs: HashMap<(usize, usize), usize> = HashMap::new();
    let object_names: Vec<&str> = scene.objects.iter().map(|o| o.name.as_str()).collect();
    for (i, pair) in scene.pairs.iter().enumerate() {
        let err = |key: &str, m: String| src.error_at_key(&[Seg::Key("pairs"), Seg::Index(i), Seg::Key(key)], m);
        let mut ids = [0usize; 2];
        for (k, name) in pair.objects.iter().enumerate() {
            ids[k] = match names.get(name.as_str()) {
                Some(&id) => id,
                None => {
                    let hint = match squish::params::did_you_mean(name, &object_names) {
                        Some(s) => format!("did you mean \"{s}\"?"),
                        None => format!("the objects are {}", quoted(&object_names)),
                    };
                    return Err(err("objects", format!("no object is named \"{name}\" ({hint})")));
                }
            };
        }
        let [a, b] = ids;
        let [na, nb] = &pair.objects;
        if a == b {
            return Err(err(
                "objects",
                format!(
                    "pairs [\"{na}\", \"{nb}\"] names the same object twice; a pair is two different objects (for an object folding onto itself, use [[objects.self_contact]])"
                ),
            ));
        }
        if let Some(first) = seen_pairs.insert((a.min(b), a.max(b)), i) {
            return Err(err(
                "objects",
                format!("the pair \"{na}\" / \"{nb}\" is already listed as pair #{}; list each pair once", first + 1),
            ));
        }
        if rigid[a] && rigid[b] {
            return Err(err(
                "objects",
                format!(
                    "both \"{na}\" and \"{nb}\" are rigid, so neither can deform; set rigid = false on one of them or remove the pair"
                ),
            ));
        }
        let params: PairParams = check_params(&pair.params, super::PairSpec::TABLE_KEYS, shot(), err)?;
        if params.contact_method == squish::params::ContactMethod::Ball && rigid[a] == rigid[b] {
            return Err(err(
                "contact_method",
                format!(
                    "the ball method (method A) works between a rigid and an elastic object, but \"{na}\" and \"{nb}\" are both elastic; make one rigid or use contact_method = \"geometric\""
                ),
            ));
        }
    }
    Ok(())
}

/// Reads a table's parameters ([`ParamTracks::parse`], per-vertex values checked for their
/// form only) and checks them at every frame that matters; returns them at the first frame.
/// `err(key, message)` locates a message at a key of the table.
fn check_params<P: Params>(
    raw: &RawParams,
    table_keys: &[&str],
    shot: impl Iterator<Item = f64>,
    err: impl Fn(&str, String) -> IoError,
) -> Result<P, IoError> {
    let located = |e: TrackError| err(&e.key, with_former_spelling(&e.key, raw.get(&e.key), e.message));
    let tracks = ParamTracks::<P>::parse(raw, table_keys, per_vertex_form).map_err(located)?;
    let frames = tracks.check_frames(shot);
    let mut first = None;
    for &frame in &frames {
        let params = tracks.at(frame).map_err(|e| {
            let when = if frames.len() > 1 { format!(" at frame {frame}") } else { String::new() };
            let mut e = TrackError::from(e);
            e.message.push_str(&when);
            located(e)
        })?;
        first.get_or_insert(params);
    }
    Ok(first.unwrap_or_default())
}

/// A per-vertex parameter's form (`"map.txt"` or `{ file, attribute }`), not its file: that is
/// read when the scene loads. An empty list stands for the values meanwhile, so that conditions
/// such as "a mask needs its values" hold.
fn per_vertex_form(_: &'static ParamInfo, v: &Value) -> Result<Option<ParamValue>, String> {
    VertexData::from_value(v).map(|_| Some(ParamValue::List(Vec::new())))
}

/// The fix for a value written in a form this version no longer reads (`region = { distance = … }`,
/// `profile = [v2, v3, v4]`, `contact_method = { ball = r }`, `anisotropy = { … }`), added to its
/// message.
fn with_former_spelling(key: &str, value: Option<&Value>, message: String) -> String {
    let Some(Value::Table(t)) = value else {
        if key == "profile" {
            return format!("{message}; the profile's abscissas are the keys profile_v2, profile_v3 and profile_v4");
        }
        return message;
    };
    let fix = match key {
        "region" if t.contains_key("distance") => "write region = \"distance\" and region_distance = …",
        "region" => "write region = \"mask\" and region_mask = \"file.txt\" or { attribute = \"name\" }",
        "contact_method" => "write contact_method = \"ball\" and ball_radius = …",
        "anisotropy" => "write anisotropy = true, anisotropy_exponent = … and anisotropy_offset = …",
        "profile" => {
            "write profile_v2 = …, profile_v3 = …, profile_v4 = …, wrinkle_amplitude = …, wrinkle_frequency = …"
        }
        _ => return message,
    };
    format!("{message}; {fix}")
}

fn quoted(names: &[&str]) -> String {
    names.iter().map(|n| format!("\"{n}\"")).collect::<Vec<_>>().join(", ")
}

/// Object names become folder names: keep them portable.
fn check_name(name: &str) -> Result<(), String> {
    if name.trim().is_empty() {
        return Err("the name is empty; give each object a name (it names its output folder)".into());
    }
    if name != name.trim() {
        return Err(format!("\"{name}\" starts or ends with spaces; remove them"));
    }
    if name == "." || name == ".." {
        return Err(format!("\"{name}\" cannot be a name (it names a folder); choose another"));
    }
    if let Some(c) = name.chars().find(|c| "/\\:*?\"<>|".contains(*c) || c.is_control()) {
        return Err(format!(
            "\"{name}\" contains '{}', which cannot appear in a folder name on every system; use letters, digits, '-', '_' or '.'",
            c.escape_default()
        ));
    }
    Ok(())
}

/// The object's own keys: its mesh's frame pattern and its transform.
fn validate_object(
    object: &ObjectSpec,
    shot: impl Iterator<Item = f64>,
    err: impl Fn(&str, String) -> IoError,
) -> Result<(), IoError> {
    if let MeshSource::Sequence { pattern, .. } = &object.mesh {
        let text = pattern.to_string_lossy();
        FramePattern::parse(&text).map_err(|m| err("mesh", m))?;
    }
    let t = &object.transform;
    check_scale(&t.scale.0).map_err(|m| err("transform", format!("scale {m}")))?;
    let rotate = &t.rotate.0;
    for f in shot.chain(rotate.key_frames().iter().copied()) {
        let r = rotate.at(f);
        if !(r.degrees == 0.0 || r.axis.length() > 1e-12) {
            return Err(err(
                "transform",
                format!(
                    "rotate must be about a non-zero axis, got [{}, {}, {}, {}] at frame {f}",
                    r.axis.x, r.axis.y, r.axis.z, r.degrees
                ),
            ));
        }
        if !rotate.is_animated() {
            break;
        }
    }
    Ok(())
}

/// Checks the `[[objects.self_contact]]` entries of an object; `err(entry, key, message)`
/// locates a message at a key of an entry.
fn validate_self_contact<I: Iterator<Item = f64>>(
    object: &ObjectSpec,
    rigid: bool,
    shot: impl Fn() -> I,
    err: impl Fn(usize, &str, String) -> IoError,
) -> Result<(), IoError> {
    let mut names: HashMap<&str, usize> = HashMap::new();
    for (k, entry) in object.self_contact.iter().enumerate() {
        let err = |key: &str, m: String| err(k, key, m);
        let name = &entry.name;
        if name.trim().is_empty() {
            return Err(err("name", "the name is empty; name each articulation (e.g. \"left knee\")".into()));
        }
        if let Some(first) = names.insert(name, k) {
            return Err(err(
                "name",
                format!(
                    "the name \"{name}\" is already used by self_contact entry #{} of this object; articulation names must be unique within an object",
                    first + 1
                ),
            ));
        }
        if rigid {
            return Err(err(
                "name",
                format!(
                    "object \"{}\" is rigid, so it never deforms and its articulation \"{name}\" would be ignored; set rigid = false or remove the [[objects.self_contact]] entries",
                    object.name
                ),
            ));
        }
        let params: ArticulationParams = check_params(&entry.params, SelfContactSpec::TABLE_KEYS, shot(), err)?;
        let direction_from_joints = entry.params.get("direction").is_none_or(|d| d.as_str() == Some("joints"));
        match (&entry.joints, &entry.masks) {
            (Some(_), Some(_)) => {
                return Err(err(
                    "masks",
                    format!(
                        "articulation \"{name}\" gives both joints and masks; keep one of them (joints read the regions from the skin weights)"
                    ),
                ));
            }
            (None, None) => {
                return Err(err(
                    "name",
                    format!(
                        "articulation \"{name}\" needs its two regions: joints = [\"parent joint\", \"child joint\"] (a skinned glTF) or masks = [mask1, mask2]"
                    ),
                ));
            }
            (Some([a, b]), None) => {
                if !matches!(object.mesh, MeshSource::Gltf(_)) {
                    return Err(err(
                        "joints",
                        format!(
                            "articulation \"{name}\": joints need a skinned glTF mesh, but the mesh of \"{}\" is {}; use masks = [mask1, mask2] with direction = [x, y, z] instead",
                            object.name,
                            object.mesh.file().display()
                        ),
                    ));
                }
                if a.is_empty() || b.is_empty() || a == b {
                    return Err(err(
                        "joints",
                        format!(
                            "articulation \"{name}\": joints = [\"{a}\", \"{b}\"] must name two different joints: a joint and one of its children"
                        ),
                    ));
                }
            }
            (None, Some(_)) => {
                if params.min_weight != ArticulationParams::default().min_weight {
                    return Err(err(
                        "min_weight",
                        format!(
                            "articulation \"{name}\": min_weight applies to regions read from joints, not to masks (a mask selects the vertices whose value is ≥ 0.5); remove it"
                        ),
                    ));
                }
                if direction_from_joints {
                    return Err(err(
                        "direction",
                        format!(
                            "articulation \"{name}\" has masks but no joints to take its direction from; give direction = [x, y, z], pointing from region 1 toward region 2"
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// A scale must not be zero on any axis at any frame. Linear and smooth curves stay between
/// their keys, so they cross zero exactly when two consecutive keys differ in sign on an axis.
fn check_scale(k: &squish::animation::Keyframed<Scale>) -> Result<(), String> {
    use squish::animation::Keyframed;
    const ZERO: &str = "must be non-zero on every axis (a zero scale flattens the mesh)";
    match k {
        Keyframed::Constant(Scale(s)) => {
            if s.x == 0.0 || s.y == 0.0 || s.z == 0.0 {
                Err(format!("{ZERO}, got {s}"))
            } else {
                Ok(())
            }
        }
        Keyframed::Keys(track) => {
            let keys: Vec<(f64, Scale)> = track.frames().iter().copied().zip(track.values().iter().copied()).collect();
            for &(f, Scale(s)) in &keys {
                if s.x == 0.0 || s.y == 0.0 || s.z == 0.0 {
                    return Err(format!("{ZERO}, got {s} at the key on frame {f}"));
                }
            }
            if track.interpolation() == KeyInterpolation::Step {
                return Ok(());
            }
            for w in keys.windows(2) {
                let ((f0, Scale(a)), (f1, Scale(b))) = (w[0], w[1]);
                for (axis, (x, y)) in ["x", "y", "z"].iter().zip(a.to_array().into_iter().zip(b.to_array())) {
                    if x * y < 0.0 {
                        return Err(format!(
                            "on axis {axis} goes from {x} at frame {f0} to {y} at frame {f1}, passing through 0 in between; keep one sign, or use interpolation = \"step\" to flip"
                        ));
                    }
                }
            }
            Ok(())
        }
    }
}
