//! How a keyframable value is spelled in a scene file, read into the library's
//! [`Keyframed`] curve (checked by [`Keyframed::keys`]) and written back.
//!
//! ```toml
//! stiffness = 2.0                                               # constant
//! stiffness = [[1, 0.5], [48, 2.0]]                             # keys [frame, value], linear
//! stiffness = { keys = [[1, 0.5], [48, 2.0]], interpolation = "smooth" }
//! ```
//!
//! A value is a number, `true`/`false`, or a list of numbers (a vector); a list whose first
//! element is itself a list is keys. Messages say what was expected; the caller adds the key and
//! the line.

use glam::DVec3;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use squish::animation::{KeyInterpolation, KeyValue, Keyframed};
use toml::Value;

/// A value type of the scene file: a [`KeyValue`] with its spelling.
pub trait SceneValue: KeyValue {
    /// True if one number stands for every component (`scale = 2`, `stiffness = 1` for a pair).
    const BROADCAST: bool = false;
}

impl SceneValue for f64 {}
impl SceneValue for bool {}
impl SceneValue for DVec3 {}
impl SceneValue for [f64; 2] {
    const BROADCAST: bool = true;
}

/// What a value of `T` looks like, for messages.
fn expected<T: SceneValue>() -> String {
    format!(
        "{}, a list of [frame, value] keys, or {{ keys = [[frame, value], …], interpolation = \"linear\" | \"smooth\" | \"step\" }}",
        T::DESCRIPTION
    )
}

/// A number of a TOML value (integers included), if it is one.
pub(crate) fn number(v: &Value) -> Option<f64> {
    match v {
        Value::Float(x) => Some(*x),
        Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

/// One value of `T` (not keys).
pub(crate) fn value<T: SceneValue>(v: &Value) -> Result<T, String> {
    let wrong = || format!("expected {}", T::DESCRIPTION);
    let value = if T::COMPONENTS == 0 {
        let b = v.as_bool().ok_or_else(wrong)?;
        T::from_components(|_| if b { 1.0 } else { 0.0 })
    } else if let Some(x) = number(v) {
        if T::COMPONENTS != 1 && !T::BROADCAST {
            return Err(format!("expected {}, not a single number", T::DESCRIPTION));
        }
        T::from_components(|_| x)
    } else if let Value::Array(items) = v {
        let numbers: Option<Vec<f64>> = items.iter().map(number).collect();
        match numbers {
            Some(xs) if xs.len() == T::COMPONENTS => T::from_components(|i| xs[i]),
            _ => return Err(format!("expected {}, not a list of {} values", T::DESCRIPTION, items.len())),
        }
    } else {
        return Err(wrong());
    };
    if (0..T::COMPONENTS).all(|i| value.component(i).is_finite()) {
        Ok(value)
    } else {
        Err(format!("{value:?} is not finite; give {} with finite numbers", T::DESCRIPTION))
    }
}

/// The keys of a keyed value and its interpolation, if it names one.
pub(crate) type KeyList<'v> = (&'v [Value], Option<KeyInterpolation>);

/// The keys of a value written as keys (`[[frame, value], …]` or `{ keys, interpolation }`),
/// or `None` for a plain value.
pub(crate) fn key_list(v: &Value) -> Result<Option<KeyList<'_>>, String> {
    match v {
        Value::Array(items) if matches!(items.first(), Some(Value::Array(_))) => Ok(Some((items, None))),
        Value::Table(t) => {
            if let Some(key) = t.keys().find(|k| !matches!(k.as_str(), "keys" | "interpolation")) {
                return Err(format!(
                    "unknown key \"{key}\" in a keyed value; write {{ keys = [[frame, value], …], interpolation = \"smooth\" }}"
                ));
            }
            let Some(Value::Array(items)) = t.get("keys") else {
                return Err("a keyed value's table needs keys = [[frame, value], …]".to_string());
            };
            let interpolation = match t.get("interpolation") {
                None => None,
                Some(Value::String(name)) => Some(KeyInterpolation::from_name(name).ok_or_else(|| {
                    format!("unknown interpolation \"{name}\"; use \"linear\", \"smooth\" or \"step\"")
                })?),
                Some(_) => return Err("interpolation is \"linear\", \"smooth\" or \"step\"".to_string()),
            };
            Ok(Some((items, interpolation)))
        }
        _ => Ok(None),
    }
}

/// `[frame, value]` pairs of a key list, each value read by `read`.
pub(crate) fn keys_of<U>(
    items: &[Value],
    describe: &str,
    mut read: impl FnMut(&Value) -> Result<U, String>,
) -> Result<Vec<(f64, U)>, String> {
    items
        .iter()
        .enumerate()
        .map(|(k, item)| {
            let shape = || format!("key {} must be [frame, value] with {describe} as the value", k + 1);
            let Value::Array(pair) = item else { return Err(shape()) };
            let [frame, value] = pair.as_slice() else { return Err(shape()) };
            let frame = number(frame).ok_or_else(shape)?;
            Ok((frame, read(value).map_err(|m| format!("key {} (frame {frame}): {m}", k + 1))?))
        })
        .collect()
}

/// A keyframable value of `T` in any of its spellings.
pub(crate) fn keyframed<T: SceneValue>(v: &Value) -> Result<Keyframed<T>, String> {
    match key_list(v)? {
        Some((items, interpolation)) => {
            let keys = keys_of(items, T::DESCRIPTION, value::<T>)?;
            Keyframed::keys(keys, interpolation.unwrap_or(T::DEFAULT_INTERPOLATION)).map_err(|e| e.to_string())
        }
        None => value::<T>(v).map(Keyframed::Constant).map_err(|m| format!("{m}; expected {}", expected::<T>())),
    }
}

/// A keyframable value as a scene file writes it: a constant as the bare value, keys as the
/// table form.
pub(crate) fn keyframed_to_value<T: SceneValue>(k: &Keyframed<T>) -> Value {
    let one = |v: &T| -> Value {
        match T::COMPONENTS {
            0 => Value::Boolean(v.component(0) != 0.0),
            1 => Value::Float(v.component(0)),
            n => Value::Array((0..n).map(|i| Value::Float(v.component(i))).collect()),
        }
    };
    match k {
        Keyframed::Constant(v) => one(v),
        Keyframed::Keys(track) => {
            let keys = track
                .frames()
                .iter()
                .zip(track.values())
                .map(|(f, v)| Value::Array(vec![Value::Float(*f), one(v)]))
                .collect();
            let mut table = toml::Table::new();
            table.insert("keys".into(), Value::Array(keys));
            table.insert("interpolation".into(), Value::String(track.interpolation().name().into()));
            Value::Table(table)
        }
    }
}

/// A keyframable scene-file value (a transform's translate, rotate, scale): the library's curve
/// with the scene file's spellings.
#[derive(Clone, Debug, PartialEq)]
pub struct Keyed<T>(pub Keyframed<T>);

impl<T: SceneValue> Keyed<T> {
    /// The value at `frame`.
    pub fn at(&self, frame: f64) -> T {
        self.0.at(frame)
    }
}

impl<T: SceneValue> Serialize for Keyed<T> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        keyframed_to_value(&self.0).serialize(s)
    }
}

impl<'de, T: SceneValue> Deserialize<'de> for Keyed<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Value::deserialize(d)?;
        keyframed(&v).map(Keyed).map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::scene::Scale;

    fn parse(text: &str) -> Value {
        let table: toml::Table = toml::from_str(&format!("v = {text}")).unwrap();
        table["v"].clone()
    }

    #[test]
    fn the_three_spellings_and_their_errors() {
        assert_eq!(keyframed::<f64>(&parse("2")).unwrap(), Keyframed::Constant(2.0));
        let k = keyframed::<f64>(&parse("[[1, 0.5], [48, 2.0]]")).unwrap();
        assert_eq!(k.at(48.0), 2.0);
        let k = keyframed::<DVec3>(&parse("{ keys = [[1, [0, 0, 1]], [9, [1, 0, 0]]], interpolation = \"step\" }"))
            .unwrap();
        assert_eq!(k.at(5.0), DVec3::Z);
        assert_eq!(keyframed::<Scale>(&parse("2")).unwrap(), Keyframed::Constant(Scale(DVec3::splat(2.0))));
        assert!(keyframed::<DVec3>(&parse("2")).unwrap_err().contains("not a single number"));
        assert!(keyframed::<f64>(&parse("[[2, 1], [1, 2]]")).unwrap_err().contains("increasing"));
        assert!(keyframed::<f64>(&parse("{ keys = [[1, 1]], interp = \"step\" }")).unwrap_err().contains("interp"));
        assert!(keyframed::<bool>(&parse("[[1, true], [2, 3]]")).unwrap_err().contains("key 2"));
        assert!(keyframed::<f64>(&parse("nan")).unwrap_err().contains("not finite"));
        // Written back and read again: the same curve.
        let k = keyframed::<DVec3>(&parse("{ keys = [[1, [0, 0, 1]], [9, [1, 0, 0]]], interpolation = \"smooth\" }"))
            .unwrap();
        assert_eq!(keyframed::<DVec3>(&keyframed_to_value(&k)).unwrap(), k);
    }
}
