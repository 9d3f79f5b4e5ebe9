//! The one parameter model seen from every entry point of the command line: every schema key set
//! through `--set`, a parameters file and a scene file reaches the library with the same value,
//! and the docs' parameter tables are the schema's.

#![allow(clippy::unwrap_used)]

use std::path::Path;

use squish::params::{
    ArticulationParams, ObjectParams, PairParams, ParamInfo, ParamKind, ParamValue, Params, SchemaEntry, entries,
};
use squish_io::Scene;
use squish_io::scene::toml_value;

use crate::cmd_params::{Level, markdown};
use crate::input::{InputMesh, WeldChoice};
use crate::params::pair_settings;

/// A valid value of `key`, different from its default, chosen so that every key of a struct can
/// hold its test value at once (`contact_method = "ball"` with a `ball_radius`, profile abscissas
/// that stay in order).
fn test_value(entry: &SchemaEntry, vertices: usize) -> ParamValue {
    let info: &ParamInfo = entry.info;
    let default = &entry.default;
    let number = |x: f64| ParamValue::Number(x);
    match info.kind {
        ParamKind::Bool => match default {
            ParamValue::Bool(b) => ParamValue::Bool(!b),
            _ => ParamValue::Bool(true),
        },
        ParamKind::Number | ParamKind::Integer => {
            let base = match default {
                ParamValue::Number(x) => *x,
                _ => 0.5,
            };
            let candidates = [base * 0.97 + 0.01, base + 0.1, 0.35, 1.5, 75.0];
            let x = candidates
                .into_iter()
                .find(|&x| info.range.contains(x) && ParamValue::Number(x) != *default)
                .unwrap_or_else(|| panic!("no test value for {}", info.key));
            number(x)
        }
        ParamKind::Direction => ParamValue::List(vec![0.0, 0.6, 0.8]),
        ParamKind::NumberPair => ParamValue::List(vec![1.5, 2.5]),
        ParamKind::Choice(words) => {
            let word = words.iter().rev().find(|w| !default.is_word(w)).unwrap();
            ParamValue::Word((*word).to_string())
        }
        ParamKind::PerVertex => ParamValue::List((0..vertices).map(|v| 0.5 + (v % 3) as f64 * 0.25).collect()),
        ParamKind::Text => ParamValue::Word("elsewhere".into()),
    }
}

/// Every key of `P` with its test value; the set as a whole is valid.
fn test_values<P: Params>(vertices: usize) -> Vec<(&'static str, ParamValue)> {
    let values: Vec<_> = entries::<P>().iter().map(|e| (e.info.key, test_value(e, vertices))).collect();
    let mut p = P::default();
    for (key, value) in &values {
        p.set(key, value).unwrap_or_else(|e| panic!("test value of {key}: {e}"));
    }
    p.validate().unwrap_or_else(|e| panic!("the test values together: {e}"));
    values
}

/// How `--set` writes a value.
fn as_text(value: &ParamValue) -> String {
    match value {
        ParamValue::List(xs) => xs.iter().map(|x| squish::params::number(*x)).collect::<Vec<_>>().join(","),
        ParamValue::Word(w) => w.clone(),
        v => v.to_string(),
    }
}

/// A TOML line `key = value`.
fn as_toml(key: &str, value: &ParamValue) -> String {
    format!("{key} = {}\n", toml_value(value))
}

fn assert_values<P: Params>(what: &str, params: &P, values: &[(&'static str, ParamValue)]) {
    for (key, expected) in values {
        let got = params.get(key).unwrap();
        assert_eq!(&got, expected, "{what}: {key}");
    }
}

#[test]
fn every_schema_key_reaches_the_library_from_every_entry_point() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = squish::mesh::shapes::icosphere(1.0, 1);
    let n = mesh.num_vertices();
    // With UVs (one `vt` per vertex): the test values give the pair method A's shared
    // parametrization, which reads them.
    let mut obj = String::new();
    for p in &mesh.positions {
        obj += &format!("v {:?} {:?} {:?}\nvt {:?} {:?}\n", p.x, p.y, p.z, p.x, p.y);
    }
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| v + 1);
        obj += &format!("f {a}/{a} {b}/{b} {c}/{c}\n");
    }
    std::fs::write(dir.path().join("a.obj"), &obj).unwrap();
    std::fs::write(dir.path().join("b.obj"), &obj).unwrap();
    let object = test_values::<ObjectParams>(n);
    let pair = test_values::<PairParams>(n);
    let articulation = test_values::<ArticulationParams>(n);
    // The test values make object a rigid and the pair method A: b stays elastic.
    let per_vertex = |info_key: &str| ObjectParams::info(info_key).unwrap().kind == ParamKind::PerVertex;

    // 1. --set, per-vertex values from text files.
    let mut sets = Vec::new();
    for (key, value) in &object {
        if per_vertex(key) {
            let file = dir.path().join(format!("{key}.txt"));
            std::fs::write(&file, as_text(value).replace(',', "\n")).unwrap();
            sets.push(format!("a.{key}={}", file.display()));
        } else {
            sets.push(format!("a.{key}={}", as_text(value)));
        }
    }
    sets.extend(pair.iter().map(|(key, value)| format!("pair.{key}={}", as_text(value))));
    let inputs = [
        InputMesh::read(&dir.path().join("a.obj"), WeldChoice::Never).unwrap(),
        InputMesh::read(&dir.path().join("b.obj"), WeldChoice::Never).unwrap(),
    ];
    let mut from_set = pair_settings(None, &sets).unwrap();
    from_set.complete(&inputs).unwrap();
    assert_values("--set", &from_set.a, &object);
    assert_values("--set", &from_set.pair, &pair);

    // 2. A parameters file, per-vertex values inline.
    let mut file = String::from("[a]\n");
    file.extend(object.iter().map(|(k, v)| as_toml(k, v)));
    file.push_str("[pair]\n");
    file.extend(pair.iter().map(|(k, v)| as_toml(k, v)));
    std::fs::write(dir.path().join("params.toml"), &file).unwrap();
    let mut from_file = pair_settings(Some(&dir.path().join("params.toml")), &[]).unwrap();
    from_file.complete(&inputs).unwrap();
    assert_eq!(from_file.a, from_set.a);
    assert_eq!(from_file.pair, from_set.pair);

    // 3. A scene file, per-vertex values from files, an articulation from two masks.
    let mut scene = String::from("frames = { start = 1, end = 2 }\n\n[[objects]]\nname = \"a\"\nmesh = \"a.obj\"\n");
    for (key, value) in &object {
        if per_vertex(key) {
            scene.push_str(&format!("{key} = \"{key}.txt\"\n"));
        } else {
            scene.push_str(&as_toml(key, value));
        }
    }
    scene.push_str("\n[[objects]]\nname = \"b\"\nmesh = \"b.obj\"\n");
    let half = |z: f64| mesh.positions.iter().map(|p| if p.z * z > -0.3 { "1\n" } else { "0\n" }).collect::<String>();
    std::fs::write(dir.path().join("top.txt"), half(1.0)).unwrap();
    std::fs::write(dir.path().join("bottom.txt"), half(-1.0)).unwrap();
    scene.push_str("\n[[objects.self_contact]]\nname = \"lips\"\nmasks = [\"top.txt\", \"bottom.txt\"]\n");
    // With masks, the skin's min_weight does not apply: it keeps its default there.
    let articulation: Vec<_> = articulation.into_iter().filter(|(k, _)| *k != "min_weight").collect();
    scene.extend(articulation.iter().map(|(k, v)| as_toml(k, v)));
    scene.push_str("\n[[pairs]]\nobjects = [\"a\", \"b\"]\n");
    scene.extend(pair.iter().map(|(k, v)| as_toml(k, v)));
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, &scene).unwrap();
    let loaded = Scene::load(&path).unwrap_or_else(|e| panic!("{e}\n{scene}"));
    let frame = loaded.evaluate(1.0).unwrap();
    let a = &frame.objects[0].params;
    let mut a_without_data = a.clone();
    a_without_data.self_contact.clear();
    assert_eq!(a_without_data, from_set.a, "scene file");
    assert_eq!(frame.pairs[0].params, from_set.pair, "scene file");
    let lips = &frame.objects[1].params.self_contact[0];
    assert_values("scene file", &lips.params, &articulation);
}

#[test]
fn the_docs_hold_the_schemas_tables() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let bless = std::env::var_os("SQUISH_BLESS_DOCS").is_some();
    let files = ["README.md", "docs/scene-format.md"];
    let mut seen = Vec::new();
    for name in files {
        let path = root.join(name);
        let text = std::fs::read_to_string(&path).unwrap();
        let mut out = String::new();
        let mut rest = text.as_str();
        while let Some(start) = rest.find("<!-- params:") {
            let head_end = start + rest[start..].find("-->").unwrap() + 3;
            let level_name = rest[start + "<!-- params:".len()..head_end - 3].trim().to_string();
            let level = match level_name.as_str() {
                "object" => Level::Object,
                "pair" => Level::Pair,
                "articulation" => Level::Articulation,
                "scene" => Level::Scene,
                other => panic!("{name}: unknown parameter table \"{other}\""),
            };
            let end = head_end + rest[head_end..].find("<!-- /params -->").unwrap();
            let table = markdown(level);
            let current = rest[head_end..end].trim_start_matches('\n');
            if !bless {
                assert_eq!(
                    current, table,
                    "{name}: the {level_name} parameter table differs from the schema; run \
                     `SQUISH_BLESS_DOCS=1 cargo test -p squish-cli the_docs_hold` to regenerate it"
                );
            }
            out.push_str(&rest[..head_end]);
            out.push('\n');
            out.push_str(&table);
            rest = &rest[end..];
            seen.push((name, level_name));
        }
        out.push_str(rest);
        if bless && out != text {
            std::fs::write(&path, out).unwrap();
        }
    }
    for level in ["object", "pair", "articulation", "scene"] {
        assert!(
            seen.iter().any(|(file, l)| *file == "docs/scene-format.md" && l == level),
            "docs/scene-format.md holds no {level} table"
        );
    }
}
