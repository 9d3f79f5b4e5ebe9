//! `report.json` of a shot split over machines: every run of `squish run` writes the report of
//! the frames it computed as `report.A-B.json` (its part), then merges every part present in
//! the output folder into `report.json`.
//!
//! The merge depends only on the parts' contents, never on the order they were written in:
//! parts are taken by frame range (start, then end); per-frame entries are the union, by frame,
//! a frame computed by several parts taken from the last of them in that order; the summary's
//! counts and times add up and its extremes are the parts' largest. The merged report lists the
//! parts, and `missing_frames` (as `A:B` runs for `--frames`) holds the scene's frames that no
//! part computed. Written atomically.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde_json::{Value, json};

use crate::error::ShotError;
use crate::files::write_text;

/// The file name of the report of frames `start..=end`.
pub fn part_file_name(start: i64, end: i64) -> String {
    format!("report.{start}-{end}.json")
}

/// The frame range of a part's file name `<stem>.A-B.<extension>` (`report.1-24.json`), if it is
/// one.
pub fn part_range(name: &str, stem: &str, extension: &str) -> Option<(i64, i64)> {
    let middle = name.strip_prefix(stem)?.strip_prefix('.')?.strip_suffix(extension)?.strip_suffix('.')?;
    // The separator is the first '-' after the start's first character (which may be a sign).
    let split = middle.char_indices().skip(1).find(|&(_, c)| c == '-').map(|(i, _)| i)?;
    let (start, end) = (&middle[..split], &middle[split + 1..]);
    Some((start.parse().ok()?, end.parse().ok()?))
}

/// Merges every part in `dir` into `dir/report.json` (see the module documentation); the
/// scene's frames are `scene_start..=scene_end`. Returns the merged report's path.
pub fn merge_reports(dir: &Path, scene_start: i64, scene_end: i64) -> Result<PathBuf, ShotError> {
    let entries = std::fs::read_dir(dir).map_err(|e| ShotError::Report {
        path: dir.to_path_buf(),
        message: format!("cannot list the folder to merge the reports: {e}"),
    })?;
    let mut parts: Vec<((i64, i64), String, Value)> = Vec::new();
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some(range) = part_range(&name, "report", "json") else { continue };
        let text = std::fs::read_to_string(entry.path()).map_err(|e| ShotError::Report {
            path: entry.path(),
            message: format!("cannot read the report part: {e}"),
        })?;
        let value: Value = serde_json::from_str(&text).map_err(|e| ShotError::Report {
            path: entry.path(),
            message: format!("not a report ({e}); delete it or run its frames again"),
        })?;
        parts.push((range, name, value));
    }
    parts.sort_by(|a, b| a.0.cmp(&b.0).then_with(|| a.1.cmp(&b.1)));
    let merged = merge(&parts, scene_start, scene_end);
    let path = dir.join("report.json");
    write_text(&path, &serde_json::to_string_pretty(&merged)?)?;
    Ok(path)
}

fn merge(parts: &[((i64, i64), String, Value)], scene_start: i64, scene_end: i64) -> Value {
    let mut merged = parts.first().map_or_else(|| json!({}), |p| p.2.clone());
    let mut per_frame: BTreeMap<i64, Value> = BTreeMap::new();
    for (_, _, part) in parts {
        for entry in part["per_frame"].as_array().into_iter().flatten() {
            if let Some(frame) = entry["frame"].as_i64() {
                per_frame.insert(frame, entry.clone());
            }
        }
    }
    let done: Vec<i64> = per_frame.keys().copied().collect();
    if parts.len() > 1 {
        let start = parts.iter().map(|p| p.0.0).min().unwrap_or(scene_start);
        let end = parts.iter().map(|p| p.0.1).max().unwrap_or(scene_end);
        merged["frames"] = json!({ "start": start, "end": end, "computed": done.len() });
        let statuses: Vec<&Value> = parts.iter().map(|p| &p.2["run"]).collect();
        let failed = statuses.iter().find(|s| s["status"] != "complete");
        merged["run"] = json!({
            "status": failed.map_or(json!("complete"), |s| s["status"].clone()),
            "missing_frames": statuses.iter().flat_map(|s| s["missing_frames"].as_array().cloned().unwrap_or_default()).collect::<Vec<_>>(),
            "failed_frame": failed.map_or(Value::Null, |s| s["failed_frame"].clone()),
            "error": failed.map_or(Value::Null, |s| s["error"].clone()),
            "failed_frames": statuses.iter().flat_map(|s| s["failed_frames"].as_array().cloned().unwrap_or_default()).collect::<Vec<_>>(),
        });
        merged["summary"] = merge_summaries(parts.iter().map(|p| &p.2["summary"]).collect());
        for key in ["animated_files", "merged_files", "previews"] {
            if parts.iter().all(|p| p.2["outputs"].get(key).is_none()) {
                continue;
            }
            let mut all: Vec<Value> = Vec::new();
            for file in parts.iter().flat_map(|p| p.2["outputs"][key].as_array().cloned().unwrap_or_default()) {
                if !all.contains(&file) {
                    all.push(file);
                }
            }
            if merged["outputs"].is_object() {
                merged["outputs"][key] = json!(all);
            }
        }
        merged["per_frame"] = json!(per_frame.into_values().collect::<Vec<_>>());
    }
    merged["parts"] = json!(parts
        .iter()
        .map(|((a, b), name, part)| json!({ "file": name, "frames": format!("{a}:{b}"), "status": part["run"]["status"] }))
        .collect::<Vec<_>>());
    merged["scene_frames"] = json!({ "start": scene_start, "end": scene_end });
    merged["missing_frames"] = json!(runs(&done, scene_start, scene_end));
    merged
}

/// The frames of `start..=end` not in `done` (sorted), as "A:B" runs.
pub fn runs(done: &[i64], start: i64, end: i64) -> Vec<String> {
    let mut runs: Vec<(i64, i64)> = Vec::new();
    let mut next = done.iter().peekable();
    for f in start..=end {
        while next.peek().is_some_and(|&&d| d < f) {
            next.next();
        }
        if next.peek() == Some(&&f) {
            continue;
        }
        match runs.last_mut() {
            Some(run) if run.1 + 1 == f => run.1 = f,
            _ => runs.push((f, f)),
        }
    }
    runs.into_iter().map(|(a, b)| format!("{a}:{b}")).collect()
}

/// The summary of several parts: counts and times added, extremes the largest, lists joined.
fn merge_summaries(summaries: Vec<&Value>) -> Value {
    let mut out = summaries.first().map_or_else(|| json!({}), |s| (*s).clone());
    let Some(object) = out.as_object_mut() else { return out };
    let number = |s: &Value, key: &str| s[key].as_f64().unwrap_or(0.0);
    let sum = |key: &str| summaries.iter().map(|s| number(s, key)).sum::<f64>();
    let max = |key: &str| summaries.iter().map(|s| number(s, key)).fold(0.0, f64::max);
    for key in ["frames_requested", "frames_computed"] {
        object.insert(key.into(), json!(sum(key) as u64));
    }
    for key in ["total_frame_time_s", "wall_time_s"] {
        object.insert(key.into(), json!(sum(key)));
    }
    object.insert("max_frame_ms".into(), json!(max("max_frame_ms")));
    object.insert("threads".into(), json!(max("threads") as u64));
    let computed = sum("frames_computed");
    object.insert(
        "mean_frame_ms".into(),
        json!(if computed > 0.0 { 1e3 * sum("total_frame_time_s") / computed } else { 0.0 }),
    );
    let wall = sum("wall_time_s");
    object.insert("frames_per_second".into(), json!(if wall > 0.0 { computed / wall } else { 0.0 }));
    let keys: Vec<String> = object.keys().filter(|k| k.starts_with("max_")).cloned().collect();
    for key in keys {
        let largest = summaries
            .iter()
            .map(|s| &s[key.as_str()])
            .filter(|v| v["value"].is_number())
            .max_by(|a, b| number(a, "value").total_cmp(&number(b, "value")));
        if let Some(v) = largest {
            object.insert(key, v.clone());
        }
    }
    for key in ["articulations", "tight_regions"] {
        let all: Vec<Value> = summaries.iter().flat_map(|s| s[key].as_array().cloned().unwrap_or_default()).collect();
        if !all.is_empty() {
            object.insert(key.into(), json!(all));
        }
    }
    out
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report
mod tests {
    use super::*;

    fn part(start: i64, end: i64, skip: &[i64]) -> Value {
        let frames: Vec<Value> =
            (start..=end).filter(|f| !skip.contains(f)).map(|f| json!({ "frame": f, "time_ms": f as f64 })).collect();
        json!({
            "frames": { "start": start, "end": end, "computed": frames.len() },
            "run": { "status": "complete", "missing_frames": [] },
            "outputs": { "previews": [format!("p{start}")] },
            "summary": {
                "frames_requested": end - start + 1, "frames_computed": frames.len(),
                "total_frame_time_s": 1.0, "wall_time_s": 2.0, "max_frame_ms": end as f64, "threads": 2,
                "max_volume_change": { "value": 1e-3 * start as f64, "frame": start },
            },
            "per_frame": frames,
        })
    }

    #[test]
    fn part_names_read_back() {
        let range = |name: &str| part_range(name, "report", "json");
        assert_eq!(range(&part_file_name(1, 48)), Some((1, 48)));
        assert_eq!(range(&part_file_name(-5, -2)), Some((-5, -2)));
        assert_eq!(range("report.json"), None);
        assert_eq!(range("report.a-b.json"), None);
        assert_eq!(part_range("ball.v2.-3-7.glb", "ball.v2", "glb"), Some((-3, 7)));
        assert_eq!(part_range("ball.v2.glb", "ball.v2", "glb"), None);
        assert_eq!(part_range("ball.1-3.glb", "ball", "pc2"), None);
    }

    #[test]
    fn failed_frames_of_every_part_are_merged() {
        let dir = tempfile::tempdir().unwrap();
        let mut failed = part(11, 20, &[15]);
        failed["run"] = json!({
            "status": "failed", "missing_frames": ["15:15"], "failed_frame": 15, "error": "bad",
            "failed_frames": [{ "frame": 15, "error": "bad" }],
        });
        std::fs::write(dir.path().join(part_file_name(1, 10)), part(1, 10, &[]).to_string()).unwrap();
        std::fs::write(dir.path().join(part_file_name(11, 20)), failed.to_string()).unwrap();
        merge_reports(dir.path(), 1, 20).unwrap();
        let report: Value =
            serde_json::from_str(&std::fs::read_to_string(dir.path().join("report.json")).unwrap()).unwrap();
        assert_eq!(report["run"]["status"], "failed");
        assert_eq!(report["run"]["failed_frames"], json!([{ "frame": 15, "error": "bad" }]));
        assert_eq!(report["missing_frames"], json!(["15:15"]));
    }

    /// A figure read back from a part and written into the merged report keeps every bit (serde_json's
    /// default float parsing could be 1 ulp off: `float_roundtrip` is on).
    #[test]
    fn merged_figures_keep_every_bit() {
        let dir = tempfile::tempdir().unwrap();
        let figure = f64::from_bits(0xbcfc_b5bd_c64e_9867); // −6.374884393956365e-15, 1 ulp off before
        let mut value = part(1, 10, &[]);
        value["per_frame"][0]["volume_change"] = json!(figure);
        std::fs::write(dir.path().join(part_file_name(1, 10)), value.to_string()).unwrap();
        merge_reports(dir.path(), 1, 10).unwrap();
        let report: Value =
            serde_json::from_str(&std::fs::read_to_string(dir.path().join("report.json")).unwrap()).unwrap();
        assert_eq!(report["per_frame"][0]["volume_change"].as_f64().unwrap().to_bits(), figure.to_bits());
    }

    #[test]
    fn two_parts_merge_the_same_in_either_order() {
        let mut merged = Vec::new();
        for order in [[0, 1], [1, 0]] {
            let dir = tempfile::tempdir().unwrap();
            let parts = [((1, 10), part(1, 10, &[])), ((11, 20), part(11, 20, &[15]))];
            for k in order {
                let ((a, b), value) = &parts[k];
                std::fs::write(dir.path().join(part_file_name(*a, *b)), value.to_string()).unwrap();
                merge_reports(dir.path(), 1, 24).unwrap();
            }
            merged.push(std::fs::read_to_string(dir.path().join("report.json")).unwrap());
        }
        assert_eq!(merged[0], merged[1]);
        let report: Value = serde_json::from_str(&merged[0]).unwrap();
        assert_eq!(report["missing_frames"], json!(["15:15", "21:24"]));
        assert_eq!(report["per_frame"].as_array().unwrap().len(), 19);
        assert_eq!(report["frames"], json!({ "start": 1, "end": 20, "computed": 19 }));
        assert_eq!(report["summary"]["frames_computed"], 19);
        assert_eq!(report["summary"]["max_volume_change"]["frame"], 11);
        assert_eq!(report["summary"]["max_frame_ms"], 20.0);
        assert_eq!(report["parts"].as_array().unwrap().len(), 2);
        assert_eq!(report["outputs"]["previews"], json!(["p1", "p11"]));
    }
}
