//! The page's messages: JSON objects tagged by `type`, read strictly (unknown types and keys,
//! wrong kinds and out-of-range values are errors that say what to send), applied to the
//! session's edits.
//!
//! - `{"type": "frame", "frame": N}`: show frame N;
//! - `{"type": "set", "target": {"object": i} | {"pair": i} | {"articulation": [i, k]}, "key": K, "value": V, "keyframe": bool}`:
//!   a parameter's value (a number, a boolean, a list, or `"auto"`), constant or, with
//!   `keyframe`, as a key at the current frame;
//! - `{"type": "revert", "target": …, "key": K}`: back to the scene file's value;
//! - `{"type": "unkey", "target": …, "key": K}`: removes K's key at the current frame;
//! - `{"type": "paint", "object": i, "stroke": {kind, center, radius, operation, strength}}`: a
//!   brush stroke on the object's bulge map (§5.5.1), `kind` `"local"` (the default) or `"radial"`
//!   (along the profiles of the frame last computed, which must be the current frame);
//! - `{"type": "clear_paint", "object": i}`: back to the scene's bulge map;
//! - `{"type": "refresh"}`: send the current frame;
//! - `{"type": "export", "name": N}`: write the edited scene and the frame's meshes.

use serde::Deserialize;
use squish::params::ArticulationParams;
use squish::params::{ParamValue, Params};
use squish::{ObjectParams, PairParams};

use super::session::{BrushFrame, BrushKind, Session, Stroke, Target};

/// A message from the page.
#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Request {
    Frame {
        frame: i64,
    },
    Set {
        target: Target,
        key: String,
        value: ParamValue,
        #[serde(default)]
        keyframe: bool,
    },
    Revert {
        target: Target,
        key: String,
    },
    Unkey {
        target: Target,
        key: String,
    },
    Paint {
        object: usize,
        stroke: Stroke,
    },
    ClearPaint {
        object: usize,
    },
    Refresh,
    Export {
        name: String,
    },
}

/// What the server answers a message with.
pub enum Reply {
    /// The frame of this version of the edits (or a later one).
    Wait(u64),
    /// This JSON, at once.
    Now(String),
}

/// Reads a message.
pub fn parse(text: &[u8]) -> Result<Request, String> {
    let text = std::str::from_utf8(text).map_err(|_| "a message must be UTF-8 JSON text".to_string())?;
    serde_json::from_str(text).map_err(|e| {
        format!(
            "malformed message ({e}); send a JSON object with \"type\": frame, set, revert, unkey, paint, clear_paint, refresh or export"
        )
    })
}

/// Applies `request` to the session's edits; true if they changed. `computed` is what the radial
/// brush follows: the fields of the frame last computed.
pub fn apply(session: &mut Session, request: &Request, computed: Option<&BrushFrame>) -> Result<bool, String> {
    match request {
        Request::Frame { frame } => {
            let range = session.scene.frames();
            if !range.contains(frame) {
                return Err(format!("frame {frame} is outside the scene's frames {}–{}", range.start(), range.end()));
            }
            let changed = session.edits.frame != *frame;
            session.edits.frame = *frame;
            Ok(changed)
        }
        Request::Set { target, key, value, keyframe } => {
            check_key(*target, key)?;
            session.set(*target, key, value, *keyframe)?;
            Ok(true)
        }
        Request::Revert { target, key } => {
            check_key(*target, key)?;
            session.revert(*target, key)?;
            Ok(true)
        }
        Request::Unkey { target, key } => {
            check_key(*target, key)?;
            session.unkey(*target, key)?;
            Ok(true)
        }
        Request::Paint { object, stroke } => {
            stroke.check()?;
            let frame = session.frame(&session.edits)?;
            let count = frame.objects.len();
            let target =
                frame.objects.get(*object).ok_or_else(|| format!("no object {object}: the scene has {count}"))?;
            let vertices = target.mesh.num_vertices();
            let fields = match stroke.kind {
                BrushKind::Local => None,
                BrushKind::Radial => {
                    let computed = computed.filter(|c| c.frame == session.edits.frame).ok_or_else(|| {
                        format!(
                            "radial brush: frame {} is not computed yet; paint again once it shows",
                            session.edits.frame
                        )
                    })?;
                    computed.objects.get(*object).and_then(Option::as_ref).filter(|f| f.u.len() == vertices)
                }
            };
            let magnitudes =
                stroke.magnitudes(&target.mesh, fields).map_err(|e| format!("object \"{}\": {e}", target.name))?;
            let mut map =
                target.params.bulge_map.clone().filter(|m| m.len() == vertices).unwrap_or_else(|| vec![1.0; vertices]);
            stroke.paint(&target.mesh, &magnitudes, &mut map);
            session.edits.painted[*object] = Some(map);
            Ok(true)
        }
        Request::ClearPaint { object } => {
            let count = session.edits.painted.len();
            let slot = session
                .edits
                .painted
                .get_mut(*object)
                .ok_or_else(|| format!("no object {object}: the scene has {count}"))?;
            Ok(slot.take().is_some())
        }
        Request::Refresh => Ok(false),
        Request::Export { .. } => Ok(false),
    }
}

/// A key the page may edit: a parameter of the target's level with a single value (per-vertex
/// maps are painted, working regions belong in the scene file).
fn check_key(target: Target, key: &str) -> Result<(), String> {
    let info = match target {
        Target::Object(_) => {
            ObjectParams::info(key).ok_or_else(|| squish::params::unknown_key::<ObjectParams>(key).to_string())
        }
        Target::Pair(_) => {
            PairParams::info(key).ok_or_else(|| squish::params::unknown_key::<PairParams>(key).to_string())
        }
        Target::Articulation(_) => ArticulationParams::info(key)
            .ok_or_else(|| squish::params::unknown_key::<ArticulationParams>(key).to_string()),
    }?;
    if info.kind == squish::params::ParamKind::PerVertex {
        return Err(format!("{key} is per vertex: paint it (bulge_map) or set it in the scene file"));
    }
    Ok(())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report
mod tests {
    use super::*;

    #[test]
    fn malformed_messages_are_errors_that_say_what_to_send() {
        for bad in [
            &b"not json"[..],
            b"{}",
            b"[]",
            b"{\"type\": \"launch\"}",
            b"{\"type\": \"frame\"}",
            b"{\"type\": \"frame\", \"frame\": \"ten\"}",
            b"{\"type\": \"frame\", \"frame\": 1, \"extra\": 2}",
            b"{\"type\": \"set\", \"target\": {\"object\": -1}, \"key\": \"stiffness\", \"value\": 2}",
            b"{\"type\": \"set\", \"target\": {\"planet\": 0}, \"key\": \"stiffness\", \"value\": 2}",
            b"{\"type\": \"paint\", \"object\": 0, \"stroke\": {\"center\": [0, 0], \"radius\": 1, \"operation\": \"add\", \"strength\": 1}}",
            b"\xff\xfe",
            b"{\"type\": \"frame\", \"frame\": 1e400}",
        ] {
            let e = parse(bad).unwrap_err();
            assert!(e.contains("message"), "{e}");
        }
        assert!(matches!(parse(b"{\"type\": \"frame\", \"frame\": 3}").unwrap(), Request::Frame { frame: 3 }));
    }

    #[test]
    fn a_stroke_is_local_unless_it_says_radial() {
        let stroke = |kind: &str| {
            parse(
                format!(
                    "{{\"type\": \"paint\", \"object\": 0, \"stroke\": {{{kind}\"center\": [0, 0, 0], \"radius\": 1, \"operation\": \"add\", \"strength\": 1}}}}"
                )
                .as_bytes(),
            )
        };
        let kind = |r: Result<Request, String>| match r.unwrap() {
            Request::Paint { stroke, .. } => stroke.kind,
            other => panic!("{other:?}"),
        };
        assert_eq!(kind(stroke("")), BrushKind::Local, "the format before the radial brush");
        assert_eq!(kind(stroke("\"kind\": \"local\", ")), BrushKind::Local);
        assert_eq!(kind(stroke("\"kind\": \"radial\", ")), BrushKind::Radial);
        let e = stroke("\"kind\": \"cone\", ").unwrap_err();
        assert!(e.contains("message") && e.contains("radial"), "{e}");
    }

    #[test]
    fn only_single_values_of_known_keys_are_set() {
        assert!(check_key(Target::Object(0), "stiffness").is_ok());
        assert!(check_key(Target::Pair(0), "contact_tau").is_ok());
        assert!(check_key(Target::Object(0), "stiffnes").unwrap_err().contains("stiffness"));
        assert!(check_key(Target::Pair(0), "stiffness").is_err());
        assert!(check_key(Target::Object(0), "bulge_map").unwrap_err().contains("paint"));
    }
}
