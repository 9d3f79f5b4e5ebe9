//! Frames: the `--frames A:B` selection that splits a shot into jobs, `{frame}` patterns of
//! mesh sequences, and the output paths `DIR/<object>/<frame:04>.<ext>`.
//!
//! Frame numbers are formatted as C's `%0Nd` (and Rust's `{:0N}`) do, which is what Blender,
//! Maya and Houdini write: the width counts the sign, so frame −5 at width 4 is `-005`.

use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};

use super::types::{FrameRange, OutputSpec};

/// A frame selection (`squish run --frames`, `Scene.run(frames=…)`) that is malformed or outside
/// the scene's range: the text read and what is wrong with it (front ends name their option).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("frames {text}: {message}")]
pub struct FrameSelectionError {
    pub text: String,
    pub message: String,
}

/// Parses a frame selection against the scene's range: `A:B` (inclusive), `A` (one frame),
/// `A:` (to the end) or `:B` (from the start). Frames may be negative (`-10:-1`). The selection
/// must lie inside the scene's frames.
pub fn parse_frame_selection(text: &str, scene: &FrameRange) -> Result<RangeInclusive<i64>, FrameSelectionError> {
    let err = |message: String| FrameSelectionError { text: text.to_string(), message };
    let parse = |s: &str, default: i64| -> Result<i64, FrameSelectionError> {
        let s = s.trim();
        if s.is_empty() {
            return Ok(default);
        }
        s.parse::<i64>().map_err(|_| err(format!("\"{s}\" is not a whole frame number; write A:B, e.g. 1:48")))
    };
    let (a, b) = match text.split_once(':') {
        Some((a, b)) => (parse(a, scene.start)?, parse(b, scene.end)?),
        None if text.trim().is_empty() => return Err(err("empty selection; write A:B, e.g. 1:48".into())),
        None => {
            let f = parse(text, scene.start)?;
            (f, f)
        }
    };
    if b < a {
        return Err(err(format!("the end {b} is before the start {a}; write the smaller frame first")));
    }
    if a < scene.start || b > scene.end {
        return Err(err(format!(
            "outside the scene's frames {}:{}; choose frames within them (or change `frames` in the scene)",
            scene.start, scene.end
        )));
    }
    Ok(a..=b)
}

/// `frame` zero-padded to `width` characters, the sign included (`%0Nd`).
pub fn format_frame(frame: i64, width: usize) -> String {
    format!("{frame:0width$}")
}

impl OutputSpec {
    /// The folder of an object's per-frame files: `DIR/<object>`.
    pub fn object_dir(&self, object: &str) -> PathBuf {
        self.dir.join(object)
    }

    /// The file of `object` at `frame`: `DIR/<object>/<frame:04>.obj|ply`; for `glb`, `gltf` and
    /// `pc2`, the one file of the object holding every frame, whatever the frame.
    pub fn path_for(&self, object: &str, frame: i64) -> PathBuf {
        if self.format.per_frame() {
            self.object_dir(object).join(format!("{}.{}", format_frame(frame, 4), self.format.extension()))
        } else {
            self.animated_path(object)
        }
    }

    /// `DIR/<object>.glb` (or `.gltf`, `.pc2`): where the result of an object holding every
    /// frame goes.
    pub fn animated_path(&self, object: &str) -> PathBuf {
        let ext = if self.format.per_frame() { "glb" } else { self.format.extension() };
        self.dir.join(format!("{object}.{ext}"))
    }
}

/// A path with `{frame}` / `{frame:0N}` placeholders (`{{` and `}}` are literal braces).
#[derive(Clone, Debug, PartialEq)]
pub struct FramePattern {
    parts: Vec<PatternPart>,
}

#[derive(Clone, Debug, PartialEq)]
enum PatternPart {
    Text(String),
    Frame { width: usize },
}

impl FramePattern {
    /// Parses `pattern`; the error says which placeholder is wrong and how to write it.
    pub fn parse(pattern: &str) -> Result<Self, String> {
        let mut parts = Vec::new();
        let mut text = String::new();
        let mut rest = pattern;
        while let Some(i) = rest.find(['{', '}']) {
            text.push_str(&rest[..i]);
            let tail = &rest[i..];
            if tail.starts_with("{{") || tail.starts_with("}}") {
                text.push_str(&tail[..1]);
                rest = &tail[2..];
                continue;
            }
            if tail.starts_with('}') {
                return Err(format!("a lone '}}' in \"{pattern}\"; write }}}} for a literal brace"));
            }
            let Some(end) = tail.find('}') else {
                return Err(format!("an unclosed '{{' in \"{pattern}\"; write {{frame}} or {{frame:04}}"));
            };
            let inside = &tail[1..end];
            let width = match inside.strip_prefix("frame") {
                Some("") => 0,
                Some(spec) if spec.starts_with(':') => match spec.strip_prefix(":0").map(str::parse::<usize>) {
                    Some(Ok(w)) if (1..=12).contains(&w) => w,
                    _ => {
                        return Err(format!(
                            "\"{{{inside}}}\" in \"{pattern}\" is not a frame placeholder; write {{frame}} or {{frame:0N}} with N from 1 to 12, e.g. {{frame:04}}"
                        ));
                    }
                },
                _ => {
                    return Err(format!(
                        "unknown placeholder \"{{{inside}}}\" in \"{pattern}\"; the only one is {{frame}} (or {{frame:04}} for zero padding)"
                    ));
                }
            };
            if !text.is_empty() {
                parts.push(PatternPart::Text(std::mem::take(&mut text)));
            }
            parts.push(PatternPart::Frame { width });
            rest = &tail[end + 1..];
        }
        text.push_str(rest);
        if !text.is_empty() {
            parts.push(PatternPart::Text(text));
        }
        if !parts.iter().any(|p| matches!(p, PatternPart::Frame { .. })) {
            return Err(format!("\"{pattern}\" has no {{frame}} placeholder"));
        }
        Ok(Self { parts })
    }

    /// True if `text` contains a frame placeholder (`{frame`), i.e. names a sequence.
    pub fn is_pattern(text: &str) -> bool {
        text.contains("{frame")
    }

    /// The path of `frame`.
    pub fn expand(&self, frame: i64) -> String {
        self.parts
            .iter()
            .map(|p| match p {
                PatternPart::Text(t) => t.clone(),
                PatternPart::Frame { width } => format_frame(frame, *width),
            })
            .collect()
    }

    /// The path of `frame`, as a path.
    pub fn path(&self, frame: i64) -> PathBuf {
        Path::new(&self.expand(frame)).to_path_buf()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn range() -> FrameRange {
        FrameRange { start: -10, end: 48, fps: 24.0 }
    }

    #[test]
    fn selections() {
        assert_eq!(parse_frame_selection("1:48", &range()), Ok(1..=48));
        assert_eq!(parse_frame_selection("5", &range()), Ok(5..=5));
        assert_eq!(parse_frame_selection(":3", &range()), Ok(-10..=3));
        assert_eq!(parse_frame_selection("40:", &range()), Ok(40..=48));
        assert_eq!(parse_frame_selection("-5:-1", &range()), Ok(-5..=-1));
        let e = parse_frame_selection("0:60", &range()).unwrap_err();
        assert!(e.to_string().contains("outside the scene's frames -10:48"), "{e}");
        assert!(parse_frame_selection("9:3", &range()).unwrap_err().message.contains("before"));
        assert!(parse_frame_selection("a:b", &range()).unwrap_err().message.contains("\"a\""));
        assert!(parse_frame_selection("1.5:3", &range()).is_err());
    }

    #[test]
    fn patterns_and_paths() {
        let p = FramePattern::parse("ball_{frame:04}.obj").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(p.expand(7), "ball_0007.obj");
        assert_eq!(p.expand(-5), "ball_-005.obj");
        assert_eq!(p.expand(12345), "ball_12345.obj");
        let p = FramePattern::parse("{{x}}/f{frame}.ply").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(p.expand(3), "{x}/f3.ply");
        assert!(FramePattern::parse("ball_{frames}.obj").unwrap_err().contains("unknown placeholder"));
        assert!(FramePattern::parse("ball_{frame:4}.obj").unwrap_err().contains("{frame:04}"));
        assert!(FramePattern::parse("ball.obj").is_err());
        let out = OutputSpec { dir: PathBuf::from("out"), format: super::super::types::OutputFormat::Ply };
        assert_eq!(out.path_for("ball", 7), PathBuf::from("out/ball/0007.ply"));
        assert_eq!(out.path_for("ball", -3), PathBuf::from("out/ball/-003.ply"));
        let glb = OutputSpec { dir: PathBuf::from("out"), format: super::super::types::OutputFormat::Glb };
        assert_eq!(glb.path_for("ball", 7), PathBuf::from("out/ball.glb"));
    }
}
