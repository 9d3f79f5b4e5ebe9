//! Keyframed parameters (`squish::animation::Keyframed`, spelled in scene files as
//! `squish_io::scene::Keyed`): values at and between keys, clamping,
//! step, smoothness (C¹ at keys, no overshoot on monotone data), vectors and booleans, rejected
//! key lists, and the three TOML spellings.

#![allow(clippy::unwrap_used)]

use glam::DVec3;
use squish::animation::{KeyInterpolation, KeyframeError, Keyframed};
use squish_io::scene::Keyed;

fn linear(keys: &[(f64, f64)]) -> Keyframed<f64> {
    Keyframed::keys(keys.to_vec(), KeyInterpolation::Linear).unwrap()
}

#[test]
fn linear_values_at_between_and_outside_keys() {
    let k = linear(&[(1.0, 0.5), (48.0, 2.0), (60.0, 1.0)]);
    assert_eq!(k.at(1.0), 0.5);
    assert_eq!(k.at(48.0), 2.0);
    assert_eq!(k.at(60.0), 1.0);
    // Midway between frames 1 and 48 (24.5): halfway between 0.5 and 2.0.
    assert!((k.at(24.5) - 1.25).abs() < 1e-12);
    assert!((k.at(54.0) - 1.5).abs() < 1e-12);
    // Fractional frames are sub-frames.
    assert!((k.at(1.5) - (0.5 + 1.5 * 0.5 / 47.0)).abs() < 1e-12);
    // Clamped outside the keys.
    assert_eq!(k.at(-100.0), 0.5);
    assert_eq!(k.at(0.0), 0.5);
    assert_eq!(k.at(61.0), 1.0);
    assert_eq!(k.at(1e9), 1.0);
    assert!(k.is_animated());
    assert_eq!(Keyframed::constant(3.0).at(17.0), 3.0);
}

#[test]
fn step_holds_the_previous_key() {
    let k = Keyframed::keys(vec![(1.0, 1.0), (10.0, 5.0), (20.0, 2.0)], KeyInterpolation::Step).unwrap();
    assert_eq!(k.at(0.0), 1.0);
    assert_eq!(k.at(9.999), 1.0);
    assert_eq!(k.at(10.0), 5.0);
    assert_eq!(k.at(19.5), 5.0);
    assert_eq!(k.at(20.0), 2.0);
    assert_eq!(k.at(25.0), 2.0);
}

fn smooth(keys: &[(f64, f64)]) -> Keyframed<f64> {
    Keyframed::keys(keys.to_vec(), KeyInterpolation::Smooth).unwrap()
}

#[test]
fn smooth_passes_through_keys_and_is_c1_at_keys() {
    // Uneven spacing and a local maximum at frame 10.
    let keys = [(1.0, 0.0), (4.0, 1.0), (10.0, 3.0), (12.0, 2.5), (30.0, -1.0)];
    let k = smooth(&keys);
    let h = 1e-6;
    for &(f, v) in &keys {
        assert!((k.at(f) - v).abs() < 1e-12, "value at key {f}");
        // One-sided difference quotients agree: the derivative is continuous across the key.
        let left = (k.at(f) - k.at(f - h)) / h;
        let right = (k.at(f + h) - k.at(f)) / h;
        assert!((left - right).abs() < 1e-4, "kink at frame {f}: left slope {left}, right slope {right}");
    }
    // First and last keys join the clamped constants without a kink: zero slope there.
    assert!(((k.at(1.0 + h) - k.at(1.0)) / h).abs() < 1e-4);
    assert!(((k.at(30.0) - k.at(30.0 - h)) / h).abs() < 1e-4);
    // Interior derivatives are continuous everywhere (sampled densely).
    let mut previous_slope: Option<f64> = None;
    let mut f = 1.0;
    while f < 30.0 {
        let slope = (k.at(f + h) - k.at(f - h)) / (2.0 * h);
        if let Some(p) = previous_slope {
            assert!((slope - p).abs() < 0.05, "derivative jumps near frame {f}");
        }
        previous_slope = Some(slope);
        f += 0.01;
    }
}

#[test]
fn smooth_does_not_overshoot_monotone_data() {
    // A steep step between flat parts: Catmull-Rom would overshoot above 1 and below 0 here.
    let keys = [(0.0, 0.0), (10.0, 0.0), (11.0, 1.0), (20.0, 1.0), (21.0, 1.05), (40.0, 3.0)];
    let k = smooth(&keys);
    let mut previous = k.at(0.0);
    let mut f = 0.0;
    while f <= 40.0 {
        let v = k.at(f);
        assert!(v >= previous - 1e-12, "not monotone at frame {f}: {v} < {previous}");
        previous = v;
        f += 0.005;
    }
    // Every segment stays within its two keys.
    for w in keys.windows(2) {
        let (lo, hi) = (w[0].1.min(w[1].1), w[0].1.max(w[1].1));
        for i in 0..=100 {
            let v = k.at(w[0].0 + (w[1].0 - w[0].0) * i as f64 / 100.0);
            assert!(v >= lo - 1e-12 && v <= hi + 1e-12, "{v} leaves [{lo}, {hi}]");
        }
    }
    // It is not linear: the curve eases (smooth differs from linear between keys).
    let lin = linear(&keys);
    assert!((k.at(30.0) - lin.at(30.0)).abs() > 1e-3);
}

#[test]
fn vectors_interpolate_per_component_and_booleans_step() {
    let d = Keyframed::keys(vec![(0.0, DVec3::Z), (10.0, DVec3::X)], KeyInterpolation::Linear).unwrap();
    assert!((d.at(5.0) - DVec3::new(0.5, 0.0, 0.5)).length() < 1e-12);
    // The caller normalizes a keyed direction.
    assert!((d.at(5.0).normalize().length() - 1.0).abs() < 1e-12);
    let s = Keyframed::keys(vec![(0.0, DVec3::ZERO), (10.0, DVec3::new(1.0, -2.0, 4.0))], KeyInterpolation::Smooth)
        .unwrap();
    assert_eq!(s.at(10.0), DVec3::new(1.0, -2.0, 4.0));
    let mid = s.at(5.0);
    assert!((mid - DVec3::new(0.5, -1.0, 2.0)).length() < 1e-12, "symmetric ease: {mid}");

    let on = Keyframed::keys(vec![(1.0, true), (10.0, false), (20.0, true)], KeyInterpolation::Step).unwrap();
    assert!(on.at(5.0));
    assert!(!on.at(10.0));
    assert!(!on.at(19.9));
    assert!(on.at(20.0));
    assert!(matches!(
        Keyframed::keys(vec![(1.0, true), (2.0, false)], KeyInterpolation::Linear),
        Err(KeyframeError::StepOnly { .. })
    ));
}

#[test]
fn bad_keys_are_rejected() {
    let unsorted = Keyframed::keys(vec![(10.0, 1.0), (5.0, 2.0)], KeyInterpolation::Linear).unwrap_err();
    assert_eq!(unsorted, KeyframeError::NotIncreasing { key: 1, previous: 10.0, frame: 5.0 });
    assert!(unsorted.to_string().contains("increasing frame order"), "{unsorted}");
    let repeated = Keyframed::keys(vec![(1.0, 1.0), (1.0, 2.0)], KeyInterpolation::Step).unwrap_err();
    assert!(matches!(repeated, KeyframeError::NotIncreasing { key: 1, .. }));
    let nan = Keyframed::keys(vec![(1.0, 1.0), (2.0, f64::NAN)], KeyInterpolation::Linear).unwrap_err();
    assert_eq!(nan, KeyframeError::NonFinite { key: 1 });
    let nan_frame = Keyframed::keys(vec![(f64::NAN, 1.0)], KeyInterpolation::Linear).unwrap_err();
    assert_eq!(nan_frame, KeyframeError::NonFinite { key: 0 });
    let inf_vec = Keyframed::keys(vec![(1.0, DVec3::new(0.0, f64::INFINITY, 0.0))], KeyInterpolation::Linear);
    assert_eq!(inf_vec.unwrap_err(), KeyframeError::NonFinite { key: 0 });
    assert_eq!(Keyframed::<f64>::keys(vec![], KeyInterpolation::Linear).unwrap_err(), KeyframeError::Empty);
}

#[derive(serde::Deserialize, serde::Serialize)]
struct Doc {
    a: Keyed<f64>,
    b: Keyed<f64>,
    c: Keyed<f64>,
    d: Keyed<DVec3>,
    e: Keyed<DVec3>,
    f: Keyed<bool>,
    g: Keyed<bool>,
}

#[test]
fn toml_spellings() {
    let doc: Doc = toml::from_str(
        r#"
        a = 2
        b = [[1, 0.5], [48, 2.0]]
        c = { keys = [[1, 0.5], [48, 2.0]], interpolation = "smooth" }
        d = [0, 0, 1]
        e = [[1, [0, 0, 1]], [24.5, [1, 0, 0]]]
        f = true
        g = [[1, false], [10, true]]
        "#,
    )
    .unwrap();
    assert_eq!(doc.a.0, Keyframed::constant(2.0));
    assert_eq!(doc.b.0, linear(&[(1.0, 0.5), (48.0, 2.0)]));
    assert_eq!(doc.c.0, smooth(&[(1.0, 0.5), (48.0, 2.0)]));
    assert_eq!(doc.d.0, Keyframed::constant(DVec3::Z));
    assert_eq!(doc.e.at(24.5), DVec3::X);
    assert_eq!(doc.f.0, Keyframed::constant(true));
    assert!(!doc.g.at(5.0) && doc.g.at(10.0));

    // JSON round trip keeps everything.
    let json = serde_json::to_string(&doc).unwrap();
    let back: Doc = serde_json::from_str(&json).unwrap();
    assert_eq!(back.c, doc.c);
    assert_eq!(back.e, doc.e);
    assert_eq!(back.g, doc.g);
    assert!(json.contains(r#""interpolation":"smooth""#), "{json}");
}

#[derive(Debug, serde::Deserialize)]
#[allow(dead_code)]
struct One {
    x: Keyed<f64>,
}

#[test]
fn toml_errors_name_the_problem_and_the_line() {
    let err = toml::from_str::<One>("\n\nx = [[10, 1.0], [5, 2.0]]\n").unwrap_err();
    assert!(err.to_string().contains("increasing frame order"), "{err}");
    let span = err.span().unwrap();
    assert_eq!(&"\n\nx = [[10, 1.0], [5, 2.0]]\n"[..span.start].matches('\n').count(), &2);
    let err = toml::from_str::<One>("x = { keys = [[1, 2.0]], interpolation = \"cubic\" }").unwrap_err();
    assert!(err.to_string().contains("cubic"), "{err}");
    let err = toml::from_str::<One>("x = { key = [[1, 2.0]] }").unwrap_err();
    assert!(err.to_string().contains("key"), "{err}");
    let err = toml::from_str::<One>("x = [[1, 2.0], 3]").unwrap_err();
    assert!(err.to_string().contains("key 2 must be [frame, value]"), "{err}");
    let err = toml::from_str::<One>("x = [[1, 2.0, 3.0]]").unwrap_err();
    assert!(err.to_string().contains("[frame, value]"), "{err}");
    let err = toml::from_str::<One>("x = \"fast\"").unwrap_err();
    assert!(err.to_string().contains("a number, a list of [frame, value] keys"), "{err}");
    let err = toml::from_str::<One>("x = [1, 2, 3]").unwrap_err();
    assert!(err.to_string().contains("expected a number, not a list of 3 values"), "{err}");
}
