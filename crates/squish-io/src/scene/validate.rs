//! Checks of a deserialized scene that serde cannot express: ranges of values, names that must
//! be unique or must exist, combinations that make no sense. Every error points at the key in
//! the file and says what to write instead.
//!
//! Keyed scalars are checked at their keys: linear, smooth and step curves never leave the range
//! of their neighbouring keys, so a bound that holds at every key holds at every frame.
//! Conditions that involve several curves (profile abscissas in order) or that interpolation can
//! break (a direction or scale passing through zero) are checked at every whole frame of the
//! scene and at every key; frame evaluation checks them again at fractional frames.

use std::collections::HashMap;

use squish::animation::{KeyInterpolation, KeyValue, Keyframed};

use super::diagnostics::{Seg, SourceText, did_you_mean};
use super::frames::FramePattern;
use super::types::{
    ContactMethod, Direction, MeshSource, ObjectSpec, Region, Scale, SceneDescription, SelfContactDirection,
    StiffnessPair,
};
use crate::IoError;

/// Longest accepted shot: beyond this a frame range is surely a typo, and checking every frame
/// would take noticeable time.
const MAX_FRAMES: i64 = 1_000_000;

/// Largest frame number: 2⁵³, beyond which an `f64` (frames become times and keyframe
/// positions) no longer holds every whole number, and far from `i64`'s ends so that a frame ± 1
/// never overflows.
pub(crate) const MAX_FRAME_NUMBER: u64 = 1 << 53;

pub(crate) fn validate(scene: &SceneDescription, src: &SourceText) -> Result<(), IoError> {
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
    let frames: Vec<f64> = (f.start..=f.end).map(|x| x as f64).collect();
    let mut names: HashMap<&str, usize> = HashMap::new();
    for (i, object) in scene.objects.iter().enumerate() {
        let at = |key: &'static str| [Seg::Key("objects"), Seg::Index(i), Seg::Key(key)];
        check_name(&object.name).map_err(|m| src.error_at_key(&at("name"), m))?;
        if let Some(first) = names.insert(&object.name, i) {
            return Err(src.error_at_key(
                &at("name"),
                format!(
                    "the name \"{}\" is already used by object #{}; object names must be unique (they name the output folders)",
                    object.name,
                    first + 1
                ),
            ));
        }
        validate_object(object, &frames, |key, m| src.error_at_key(&at(key), m))?;
        validate_self_contact(object, &frames, |k, key, m| {
            let path = [Seg::Key("objects"), Seg::Index(i), Seg::Key("self_contact"), Seg::Index(k), Seg::Key(key)];
            src.error_at_key(&path, m)
        })?;
    }
    let mut seen_pairs: HashMap<(usize, usize), usize> = HashMap::new();
    let object_names: Vec<&str> = scene.objects.iter().map(|o| o.name.as_str()).collect();
    for (i, pair) in scene.pairs.iter().enumerate() {
        let at = |key: &'static str| [Seg::Key("pairs"), Seg::Index(i), Seg::Key(key)];
        let mut ids = [0usize; 2];
        for (k, name) in pair.objects.iter().enumerate() {
            ids[k] = match names.get(name.as_str()) {
                Some(&id) => id,
                None => {
                    let hint = match did_you_mean(name, &object_names) {
                        Some(s) => format!("did you mean \"{s}\"?"),
                        None => format!("the objects are {}", quoted(&object_names)),
                    };
                    return Err(src.error_at_key(&at("objects"), format!("no object is named \"{name}\" ({hint})")));
                }
            };
        }
        let [a, b] = ids;
        let [na, nb] = &pair.objects;
        if a == b {
            return Err(src.error_at_key(
                &at("objects"),
                format!("pairs [\"{na}\", \"{nb}\"] names the same object twice; a pair is two different objects (for an object folding onto itself, use [[objects.self_contact]])"),
            ));
        }
        if let Some(first) = seen_pairs.insert((a.min(b), a.max(b)), i) {
            return Err(src.error_at_key(
                &at("objects"),
                format!("the pair \"{na}\" / \"{nb}\" is already listed as pair #{}; list each pair once", first + 1),
            ));
        }
        let (ra, rb) = (scene.objects[a].rigid, scene.objects[b].rigid);
        if ra && rb {
            return Err(src.error_at_key(
                &at("objects"),
                format!("both \"{na}\" and \"{nb}\" are rigid, so neither can deform; set rigid = false on one of them or remove the pair"),
            ));
        }
        check_range(&pair.contact_tau, |_| true, "a finite number")
            .map_err(|m| src.error_at_key(&at("contact_tau"), m))?;
        if let Direction::Fixed(d) = &pair.direction {
            check_frames(d, &frames, |v| v.length() > 1e-12, "a non-zero vector [x, y, z]")
                .map_err(|m| src.error_at_key(&at("direction"), m))?;
        }
        if let ContactMethod::Ball { radius } = &pair.contact_method {
            check_range(radius, |r| r > 0.0, "greater than 0 (the ball radius r_s, in scene units)")
                .map_err(|m| src.error_at_key(&at("contact_method"), m))?;
            if ra == rb {
                return Err(src.error_at_key(
                    &at("contact_method"),
                    format!(
                        "the ball method (method A) works between a rigid and an elastic object, but \"{na}\" and \"{nb}\" are both elastic; make one rigid or use contact_method = \"geometric\""
                    ),
                ));
            }
        }
    }
    Ok(())
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

fn validate_object(
    object: &ObjectSpec,
    frames: &[f64],
    err: impl Fn(&'static str, String) -> IoError,
) -> Result<(), IoError> {
    if let MeshSource::Sequence { pattern, .. } = &object.mesh {
        let text = pattern.to_string_lossy();
        FramePattern::parse(&text).map_err(|m| err("mesh", m))?;
    }
    check_range(&object.stiffness, |k| k > 0.0, "greater than 0 (relative stiffness; 1 is the default)")
        .map_err(|m| err("stiffness", m))?;
    if let Some(extent) = &object.extent {
        check_range(extent, |d| d > 0.0, "greater than 0 (a distance in scene units), or removed for automatic")
            .map_err(|m| err("extent", m))?;
    }
    check_range(&object.bulge, |_| true, "a finite number").map_err(|m| err("bulge", m))?;
    check_range(&object.bulge_height, |_| true, "a finite number").map_err(|m| err("bulge_height", m))?;
    let p = &object.profile;
    check_range(&p.wrinkle_frequency, |w| w >= 0.0, "≥ 0")
        .map_err(|m| err("profile", format!("wrinkle_frequency {m}")))?;
    // The three abscissas together: in order inside (0.2, 1) at every frame and key.
    let mut profile_frames: Vec<f64> = frames.to_vec();
    for k in [&p.v2, &p.v3, &p.v4] {
        profile_frames.extend_from_slice(k.key_frames());
    }
    for &f in &profile_frames {
        let (a, b, c) = (p.v2.at(f), p.v3.at(f), p.v4.at(f));
        if !(0.2 < a && a < b && b < c && c < 1.0) {
            return Err(err(
                "profile",
                format!(
                    "the abscissas v2, v3, v4 are {a:.4}, {b:.4}, {c:.4} at frame {f}; they must increase strictly within (0.2, 1), e.g. the defaults 0.3333, 0.8333, 0.9167"
                ),
            ));
        }
    }
    let an = &object.anisotropy;
    check_range(&an.exponent, |w| w > 0.0, "greater than 0 (ω; 2 is the default)")
        .map_err(|m| err("anisotropy", format!("exponent {m}")))?;
    check_range(&an.offset, |psi| psi > -1.0, "greater than −1 (ψ; at −1 or less no vertex would bulge)")
        .map_err(|m| err("anisotropy", format!("offset {m}")))?;
    if let Region::Distance(d) = &object.region {
        check_range(d, |d| d > 0.0, "greater than 0 (a distance in scene units)")
            .map_err(|m| err("region", format!("distance {m}")))?;
    }
    let t = &object.transform;
    check_scale(&t.scale).map_err(|m| err("transform", format!("scale {m}")))?;
    check_frames(&t.rotate, frames, |r| r.degrees == 0.0 || r.axis.length() > 1e-12, "about a non-zero axis")
        .map_err(|m| err("transform", format!("rotate {m}")))?;
    Ok(())
}

/// Checks the `[[objects.self_contact]]` entries of an object; `err(entry, key, message)`
/// locates a message at a key of an entry.
fn validate_self_contact(
    object: &ObjectSpec,
    frames: &[f64],
    err: impl Fn(usize, &'static str, String) -> IoError,
) -> Result<(), IoError> {
    let mut names: HashMap<&str, usize> = HashMap::new();
    for (k, entry) in object.self_contact.iter().enumerate() {
        let err = |key: &'static str, m: String| err(k, key, m);
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
        if object.rigid {
            return Err(err(
                "name",
                format!(
                    "object \"{}\" is rigid, so it never deforms and its articulation \"{name}\" would be ignored; set rigid = false or remove the [[objects.self_contact]] entries",
                    object.name
                ),
            ));
        }
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
                if entry.min_weight.is_some() {
                    return Err(err(
                        "min_weight",
                        format!(
                            "articulation \"{name}\": min_weight applies to regions read from joints, not to masks (a mask selects the vertices whose value is ≥ 0.5); remove it"
                        ),
                    ));
                }
                if entry.direction == SelfContactDirection::Joints {
                    return Err(err(
                        "direction",
                        format!(
                            "articulation \"{name}\" has masks but no joints to take its direction from; give direction = [x, y, z], pointing from region 1 toward region 2"
                        ),
                    ));
                }
            }
        }
        if let Some(w) = entry.min_weight
            && !(w > 0.0 && w <= 1.0)
        {
            return Err(err(
                "min_weight",
                format!("must lie in (0, 1] (a skinning weight; 0.05 is the default), got {w}"),
            ));
        }
        if let SelfContactDirection::Fixed(d) = &entry.direction {
            check_frames(
                d,
                frames,
                |v| v.length() > 1e-12,
                "a non-zero vector [x, y, z] (from region 1 toward region 2)",
            )
            .map_err(|m| err("direction", m))?;
        }
        check_range(&entry.contact_tau, |_| true, "a finite number").map_err(|m| err("contact_tau", m))?;
        check_frames(
            &entry.stiffness,
            &[],
            |StiffnessPair(k)| k.iter().all(|&k| k > 0.0),
            "greater than 0 on both sides (a number, or [k1, k2])",
        )
        .map_err(|m| err("stiffness", m))?;
        if let Some(extent) = &entry.extent {
            check_range(extent, |d| d > 0.0, "greater than 0 (a distance in scene units), or removed for automatic")
                .map_err(|m| err("extent", m))?;
        }
        check_range(&entry.cut_regional_weight, |w| w >= 0.0, "≥ 0 (1 is the default)")
            .map_err(|m| err("cut_regional_weight", m))?;
        check_range(
            &entry.safeguard_angle,
            |a| a > 0.0 && a <= 90.0,
            "an angle in degrees within (0, 90] (80 is the default)",
        )
        .map_err(|m| err("safeguard_angle", m))?;
        if let Some(gap) = &entry.contact_gap {
            check_range(gap, |g| g >= 0.0, "≥ 0 (a distance in scene units), or removed for automatic")
                .map_err(|m| err("contact_gap", m))?;
        }
    }
    Ok(())
}

/// Checks a keyed scalar at its keys (enough for bounds: interpolation stays between keys).
fn check_range(k: &Keyframed<f64>, ok: impl Fn(f64) -> bool, requirement: &str) -> Result<(), String> {
    match k {
        Keyframed::Constant(v) => {
            if ok(*v) {
                Ok(())
            } else {
                Err(format!("must be {requirement}, got {v}"))
            }
        }
        Keyframed::Keys(track) => {
            for (f, v) in track.frames().iter().zip(track.values()) {
                if !ok(*v) {
                    return Err(format!("must be {requirement}, got {v} at the key on frame {f}"));
                }
            }
            Ok(())
        }
    }
}

/// Checks a keyed value at every given frame and at its keys.
fn check_frames<T: KeyValue + std::fmt::Debug>(
    k: &Keyframed<T>,
    frames: &[f64],
    ok: impl Fn(T) -> bool,
    requirement: &str,
) -> Result<(), String> {
    if let Keyframed::Constant(v) = k {
        return if ok(*v) { Ok(()) } else { Err(format!("must be {requirement}, got {}", show(v))) };
    }
    for &f in frames.iter().chain(k.key_frames()) {
        let v = k.at(f);
        if !ok(v) {
            return Err(format!("must be {requirement}, got {} at frame {f}", show(&v)));
        }
    }
    Ok(())
}

/// A scale must not be zero on any axis at any frame. Linear and smooth curves stay between
/// their keys, so they cross zero exactly when two consecutive keys differ in sign on an axis.
fn check_scale(k: &Keyframed<Scale>) -> Result<(), String> {
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

/// A value as written in a scene file: `[x, y, z]` for vectors.
fn show<T: KeyValue>(v: &T) -> String {
    let parts: Vec<String> = (0..T::COMPONENTS).map(|i| v.component(i).to_string()).collect();
    if parts.len() == 1 { parts[0].clone() } else { format!("[{}]", parts.join(", ")) }
}
