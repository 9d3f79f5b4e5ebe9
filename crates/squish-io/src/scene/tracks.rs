//! The deformer's parameters in a scene file: every `[[objects]]`, `[[pairs]]` and
//! `[[objects.self_contact]]` table holds, beside its own keys (`name`, `mesh`, `transform` …),
//! any parameter of its level from the library's schema ([`squish::params`]), constant or
//! keyframed ([`super::keys`]). Nothing here lists parameters: keys, kinds, ranges and whether
//! a key may be keyframed come from [`Params::schema`].
//!
//! A table's parameters are kept as written ([`RawParams`]) in the description, and read into
//! [`ParamTracks`] — one curve or constant per key — which give the library's parameter struct at
//! any frame. Per-vertex parameters (`bulge_map`, `region_mask`) are file references in the scene
//! ([`super::VertexData`]), loaded once by [`super::Scene::load`].

use std::collections::BTreeMap;
use std::marker::PhantomData;

use glam::DVec3;
use squish::animation::{KeyInterpolation, Keyframed};
use squish::params::{ParamError, ParamInfo, ParamKind, ParamValue, Params};
use toml::Value;

use super::keys::{SceneValue, key_list, keyframed_to_value, keys_of, number, value};

/// A table's parameter keys as written (values in TOML's model).
pub type RawParams = BTreeMap<String, Value>;

/// One parameter's value over the shot.
#[derive(Clone, Debug, PartialEq)]
pub enum Track {
    Constant(ParamValue),
    Number(Keyframed<f64>),
    Vector(Keyframed<DVec3>),
    Pair(Keyframed<[f64; 2]>),
    Bool(Keyframed<bool>),
}

impl Track {
    /// The value at `frame`.
    pub fn at(&self, frame: f64) -> ParamValue {
        match self {
            Self::Constant(v) => v.clone(),
            Self::Number(k) => ParamValue::Number(k.at(frame)),
            Self::Vector(k) => ParamValue::List(k.at(frame).to_array().to_vec()),
            Self::Pair(k) => ParamValue::List(k.at(frame).to_vec()),
            Self::Bool(k) => ParamValue::Bool(k.at(frame)),
        }
    }

    /// The frames of its keys (none for a constant).
    pub fn key_frames(&self) -> &[f64] {
        match self {
            Self::Constant(_) => &[],
            Self::Number(k) => k.key_frames(),
            Self::Vector(k) => k.key_frames(),
            Self::Pair(k) => k.key_frames(),
            Self::Bool(k) => k.key_frames(),
        }
    }
}

/// A parameter that could not be read: its key and what is wrong.
#[derive(Clone, Debug, PartialEq)]
pub struct TrackError {
    pub key: String,
    pub message: String,
}

impl TrackError {
    fn new(key: &str, message: impl Into<String>) -> Self {
        Self { key: key.to_string(), message: message.into() }
    }
}

impl From<ParamError> for TrackError {
    fn from(e: ParamError) -> Self {
        let message = match &e.value {
            Some(v) => format!("{v}: {}{}", e.message, e.hint()),
            None => format!("{}{}", e.message, e.hint()),
        };
        Self { key: e.key, message }
    }
}

/// True if `v`, the value of a per-vertex parameter, names a file (or an attribute) to read
/// rather than giving the values (a list) or the parameter's word (`"uniform"`, `"none"`).
pub fn names_vertex_data(info: &ParamInfo, v: &Value) -> bool {
    info.kind == ParamKind::PerVertex && !matches!(v, Value::Array(_)) && v.as_str() != Some(info.word)
}

/// An unknown key of a table: the key meant among the table's own keys and `P`'s parameters, or
/// both lists.
fn unknown_in_table<P: Params>(key: &str, table_keys: &[&str]) -> TrackError {
    if let Some(k) = squish::params::did_you_mean(key, table_keys) {
        return TrackError::new(key, format!("unknown key (did you mean \"{k}\"?)"));
    }
    let e = squish::params::unknown_key::<P>(key);
    if e.suggestion.is_some() || table_keys.is_empty() {
        return e.into();
    }
    let params: Vec<&str> = P::schema().iter().map(|i| i.key).collect();
    TrackError::new(
        key,
        format!(
            "unknown key; the table's keys are {} and the {} parameters {}",
            table_keys.join(", "),
            P::LEVEL.name(),
            params.join(", ")
        ),
    )
}

/// A TOML value as a parameter value: numbers, booleans, words and lists of numbers.
pub fn param_value(v: &Value) -> Result<ParamValue, String> {
    match v {
        Value::Boolean(b) => Ok(ParamValue::Bool(*b)),
        // Parameters hold f64, exact for whole numbers up to 2⁵³: a larger integer would be
        // silently rounded (i64::MAX becomes 2⁶³), so it is refused with its own digits.
        Value::Integer(i) if i.unsigned_abs() > 1 << 53 => Err(format!(
            "{i} is beyond ±9007199254740992 (2^53), where whole numbers stop being exact; use a smaller number"
        )),
        Value::Integer(_) | Value::Float(_) => Ok(ParamValue::Number(number(v).unwrap_or_default())),
        Value::String(w) if w == "inf" => Ok(ParamValue::Number(f64::INFINITY)),
        Value::String(w) => Ok(ParamValue::Word(w.clone())),
        Value::Array(items) => items
            .iter()
            .map(number)
            .collect::<Option<Vec<f64>>>()
            .map(ParamValue::List)
            .ok_or_else(|| "expected a list of numbers".to_string()),
        Value::Table(_) => Err("expected a value, not a table".to_string()),
        Value::Datetime(_) => Err("expected a value, not a date".to_string()),
    }
}

/// A parameter value as a TOML value (the inverse of [`param_value`]).
pub fn toml_value(v: &ParamValue) -> Value {
    match v {
        ParamValue::Bool(b) => Value::Boolean(*b),
        ParamValue::Number(x) if x.is_infinite() => Value::String(squish::params::number(*x)),
        ParamValue::Number(x) => Value::Float(*x),
        ParamValue::List(xs) => Value::Array(xs.iter().map(|&x| Value::Float(x)).collect()),
        ParamValue::Word(w) => Value::String(w.clone()),
    }
}

/// The parameters of one table of a scene, as curves and constants.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamTracks<P> {
    tracks: Vec<(&'static ParamInfo, Track)>,
    params: PhantomData<P>,
}

impl<P: Params> Default for ParamTracks<P> {
    fn default() -> Self {
        Self { tracks: Vec::new(), params: PhantomData }
    }
}

impl<P: Params> ParamTracks<P> {
    /// Reads a table's parameters. Unknown keys, wrong kinds, out-of-range values (at every
    /// key), keys on a parameter that cannot be keyframed are errors naming the key.
    /// `table_keys` are the table's other keys (`name`, `mesh` …), offered when an unknown key is
    /// close to one. `per_vertex(info, raw)` gives the value of a per-vertex parameter (the
    /// caller loads its file); `None` leaves it at its default.
    pub fn parse(
        raw: &RawParams,
        table_keys: &[&str],
        mut per_vertex: impl FnMut(&'static ParamInfo, &Value) -> Result<Option<ParamValue>, String>,
    ) -> Result<Self, TrackError> {
        let mut tracks = Vec::with_capacity(raw.len());
        let mut scratch = P::default();
        for (key, v) in raw {
            let Some(info) = P::info(key) else {
                return Err(unknown_in_table::<P>(key, table_keys));
            };
            let fail = |m: String| TrackError::new(key, m);
            if names_vertex_data(info, v) {
                if let Some(value) = per_vertex(info, v).map_err(fail)? {
                    scratch.set(key, &value)?;
                    tracks.push((info, Track::Constant(value)));
                }
                continue;
            }
            let track = match key_list(v).map_err(fail)? {
                Some((items, interpolation)) => {
                    if !info.keyframable {
                        return Err(fail(format!("{key} cannot be keyframed; give one value ({})", info.expected())));
                    }
                    keyed(info, items, interpolation).map_err(fail)?
                }
                None => Track::Constant(param_value(v).map_err(|m| fail(format!("{m}; {}", info.expected())))?),
            };
            // Every key's value is checked: interpolation stays between neighbouring keys, so a
            // bound that holds at the keys holds at every frame.
            let frames = track.key_frames().to_vec();
            for f in if frames.is_empty() { vec![0.0] } else { frames } {
                scratch.set(key, &track.at(f)).map_err(|e| {
                    let mut e = TrackError::from(e);
                    if matches!(track, Track::Constant(_)) {
                        e
                    } else {
                        e.message = format!("{} at the key on frame {f}", e.message);
                        e
                    }
                })?;
            }
            tracks.push((info, track));
        }
        Ok(Self { tracks, params: PhantomData })
    }

    /// The parameters at `frame`: the defaults with every track's value set. Errors name the
    /// key (a value that interpolation made invalid between keys, a condition between keys).
    pub fn at(&self, frame: f64) -> Result<P, ParamError> {
        let mut p = P::default();
        for (info, track) in &self.tracks {
            p.set(info.key, &track.at(frame))?;
        }
        p.validate()?;
        Ok(p)
    }

    /// The frames at which a check of every value (and of the conditions between them) covers
    /// the shot: the keys' frames, and the shot's whole frames when a value is keyed.
    pub fn check_frames(&self, shot: impl Iterator<Item = f64>) -> Vec<f64> {
        let mut frames: Vec<f64> = self.tracks.iter().flat_map(|(_, t)| t.key_frames().iter().copied()).collect();
        if frames.is_empty() {
            frames.push(0.0);
        } else {
            frames.extend(shot);
        }
        frames.sort_by(f64::total_cmp);
        frames.dedup();
        frames
    }

    /// The track of `key`, if the table sets it.
    pub fn get(&self, key: &str) -> Option<&Track> {
        self.tracks.iter().find(|(info, _)| info.key == key).map(|(_, t)| t)
    }

    /// True if the table sets `key`.
    pub fn contains(&self, key: &str) -> bool {
        self.get(key).is_some()
    }

    /// The tracks as a scene file writes them (per-vertex values summarized).
    pub fn to_raw(&self) -> RawParams {
        self.tracks
            .iter()
            .map(|(info, track)| {
                let v = match track {
                    Track::Constant(ParamValue::List(xs)) if info.kind == ParamKind::PerVertex => {
                        Value::String(format!("{} values", xs.len()))
                    }
                    Track::Constant(v) => toml_value(v),
                    Track::Number(k) => keyframed_to_value(k),
                    Track::Vector(k) => keyframed_to_value(k),
                    Track::Pair(k) => keyframed_to_value(k),
                    Track::Bool(k) => keyframed_to_value(k),
                };
                (info.key.to_string(), v)
            })
            .collect()
    }
}

/// The keys of a keyframed parameter, by its kind.
fn keyed(info: &ParamInfo, items: &[Value], interpolation: Option<KeyInterpolation>) -> Result<Track, String> {
    fn curve<T: SceneValue>(items: &[Value], interpolation: Option<KeyInterpolation>) -> Result<Keyframed<T>, String> {
        let keys = keys_of(items, T::DESCRIPTION, value::<T>)?;
        Keyframed::keys(keys, interpolation.unwrap_or(T::DEFAULT_INTERPOLATION)).map_err(|e| e.to_string())
    }
    match info.kind {
        ParamKind::Number | ParamKind::Integer => curve(items, interpolation).map(Track::Number),
        ParamKind::Direction => curve(items, interpolation).map(Track::Vector),
        ParamKind::NumberPair => curve(items, interpolation).map(Track::Pair),
        ParamKind::Bool => curve(items, interpolation).map(Track::Bool),
        _ => Err(format!("{} cannot be keyframed", info.key)),
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use squish::{ArticulationParams, ObjectParams, PairParams};

    fn raw(text: &str) -> RawParams {
        toml::from_str(text).unwrap()
    }

    fn none(_: &ParamInfo, _: &Value) -> Result<Option<ParamValue>, String> {
        Ok(None)
    }

    #[test]
    fn constants_and_keys_of_every_kind() {
        let t = ParamTracks::<ObjectParams>::parse(
            &raw("stiffness = [[1, 1.0], [11, 3.0]]\nextent = \"auto\"\nrigid = false\nprofile_v2 = 0.3"),
            &[],
            none,
        )
        .unwrap();
        let p = t.at(6.0).unwrap();
        assert_eq!((p.stiffness, p.extent, p.profile_v2), (2.0, None, 0.3));
        let t = ParamTracks::<PairParams>::parse(
            &raw("direction = { keys = [[1, [0, 0, 1]], [3, [1, 0, 0]]], interpolation = \"step\" }\nenabled = [[1, true], [5, false]]"),
            &[],
            none,
        )
        .unwrap();
        let p = t.at(4.0).unwrap();
        assert_eq!((p.direction, p.enabled), (Some(DVec3::X), true));
        assert!(!t.at(5.0).unwrap().enabled);
        let t = ParamTracks::<ArticulationParams>::parse(&raw("stiffness = [[1, 1], [3, [1, 3]]]"), &[], none).unwrap();
        assert_eq!(t.at(2.0).unwrap().stiffness, [1.0, 2.0]);
    }

    #[test]
    fn errors_name_the_key_and_say_what_is_valid() {
        let err = |text: &str| {
            ParamTracks::<ObjectParams>::parse(&raw(text), &["name", "mesh", "transform"], none).unwrap_err()
        };
        let e = err("stifness = 2");
        assert_eq!(e.key, "stifness");
        assert!(e.message.contains("did you mean \"stiffness\""), "{e:?}");
        let e = err("stiffness = [[1, 1.0], [9, -1.0]]");
        assert!(e.message.contains("must be > 0") && e.message.contains("frame 9"), "{e:?}");
        let e = err("rigid = [[1, true], [9, false]]");
        assert!(e.message.contains("cannot be keyframed"), "{e:?}");
        let e = err("region = \"hole\"");
        assert!(e.message.contains("\"whole\""), "{e:?}");
        let e = err("transfrom = 1");
        assert!(e.message.contains("did you mean \"transform\""), "{e:?}");
        let e = err("anisotropic_bulge = true");
        assert!(e.message.contains("renamed (did you mean \"anisotropy\""), "{e:?}");
        // A condition between keys shows at the frames where it breaks.
        let t = ParamTracks::<ObjectParams>::parse(&raw("profile_v2 = [[1, 0.3], [48, 0.95]]"), &[], none).unwrap();
        assert!(t.at(1.0).is_ok());
        assert!(t.at(48.0).unwrap_err().to_string().contains("increase strictly"));
    }

    #[test]
    fn tracks_are_written_back_as_read() {
        let text =
            "stiffness = { keys = [[1.0, 1.0], [11.0, 3.0]], interpolation = \"smooth\" }\ndomain_factor = \"inf\"";
        let t = ParamTracks::<ObjectParams>::parse(&raw(text), &[], none).unwrap();
        let again = ParamTracks::<ObjectParams>::parse(&t.to_raw(), &[], none).unwrap();
        assert_eq!(again, t);
        assert_eq!(t.at(1.0).unwrap().domain_factor, f64::INFINITY);
    }
}
