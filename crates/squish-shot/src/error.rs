//! Errors of shots and of the one-frame calls, as data: what went wrong and where — the file and
//! the line, key or element (squish-io's [`IoError`]), the frame, the object, the frames to run
//! again — so that each front end words them once, in its own terms.
//!
//! A message that tells the user what to change names a setting (the frames to run again, the
//! thread count, the output folder, a parameter). The command line calls it `--frames 3:4`, the
//! Python module `frames=(3, 4)`: [`ShotError::message`] takes the front end's [`Wording`].
//! [`ShotError::kind`] is what the front end maps to an exit code or an exception class.
//! `Display` uses [`Neutral`] words; it is what reports store (a failed frame's error).

use std::fmt;
use std::path::PathBuf;

use squish::contact::ContactError;
use squish::pipeline::PipelineError;
use squish_io::IoError;
use squish_io::scene::FrameSelectionError;

/// What kind of error it is, for exit codes and exception classes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorKind {
    /// Bad input: a file, a scene, a mesh, a frame selection, a setting (exit 2).
    Input,
    /// A parameter that cannot be set (exit 2; Python's `ParameterError`).
    Parameter,
    /// The work failed (a frame, a write, the machine): exit 1.
    Failure,
    /// Stopped on request (Ctrl-C, a signal, `KeyboardInterrupt`) after writing what was done.
    Interrupted,
}

/// A parameter's value as a fix names it. `Display` writes it as `--set` and scene files read it
/// (`0,0,1`, `geometric`, `true`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SettingValue<'a> {
    Vector([f64; 3]),
    Word(&'a str),
    Bool(bool),
}

impl fmt::Display for SettingValue<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Vector([x, y, z]) => write!(f, "{x},{y},{z}"),
            Self::Word(word) => f.write_str(word),
            Self::Bool(b) => write!(f, "{b}"),
        }
    }
}

/// How a front end names the settings a message tells the user to change.
pub trait Wording {
    /// The option that selects frames, as a message names it (`--frames`).
    fn frames_option(&self) -> &'static str;
    /// The frame selection the user gave, read as `text` (`--frames 40:60`).
    fn frames_given(&self, text: &str) -> String;
    /// The setting that runs frames `first..=last` (`--frames 3:4`).
    fn frames(&self, first: i64, last: i64) -> String;
    /// The thread count set to `n` (`--threads 0`).
    fn threads(&self, n: usize) -> String;
    /// The output folder's setting (`-o`).
    fn output(&self) -> &'static str;
    /// Where parameters are set (`on the command line`).
    fn place(&self) -> &'static str;
    /// Parameter `key` of `prefix` (`a`, `b` or `pair`) set to `value` (`--set pair.direction=0,0,1`).
    fn parameter(&self, prefix: &str, key: &str, value: SettingValue) -> String;
}

/// Words that belong to no front end, for reports and logs.
pub struct Neutral;

impl Wording for Neutral {
    fn frames_option(&self) -> &'static str {
        "frames"
    }
    fn frames_given(&self, text: &str) -> String {
        format!("frames {text}")
    }
    fn frames(&self, first: i64, last: i64) -> String {
        format!("frames {first}:{last}")
    }
    fn threads(&self, n: usize) -> String {
        format!("threads = {n}")
    }
    fn output(&self) -> &'static str {
        "the output setting"
    }
    fn place(&self) -> &'static str {
        "set"
    }
    fn parameter(&self, prefix: &str, key: &str, value: SettingValue) -> String {
        format!("{prefix}.{key} = {value}")
    }
}

/// A sequence file a shot needs that does not exist.
#[derive(Clone, Debug, PartialEq)]
pub struct MissingFile {
    pub object: String,
    pub frame: i64,
    pub path: PathBuf,
}

/// Frames of a shot that failed while the others were computed and written.
#[derive(Clone, Debug, PartialEq)]
pub struct FailedFrames {
    /// How many failed, of how many asked for.
    pub failed: usize,
    pub total: usize,
    /// The first failed frame and its error.
    pub first_frame: i64,
    pub first_error: String,
    /// True when writing a frame failed, which stopped the scheduling of frames.
    pub writing_stopped: bool,
    /// Frames computed and written.
    pub written: usize,
    /// True when the files holding every frame (glb, gltf, pc2) could not be written for want
    /// of every frame.
    pub shot_files_missing: bool,
    /// The merged report.
    pub report: PathBuf,
    /// The frames left to run, as inclusive runs.
    pub left: Vec<(i64, i64)>,
}

/// A shot stopped before its last frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Stopped {
    pub done: usize,
    pub total: usize,
    pub report: PathBuf,
    /// As [`FailedFrames::shot_files_missing`].
    pub shot_files_missing: bool,
    /// The frames not computed, as inclusive runs.
    pub missing: Vec<(i64, i64)>,
}

/// An error of a shot or of a one-frame call (see the module documentation).
#[derive(Debug)]
pub enum ShotError {
    /// A file, a scene or a mesh file (squish-io names the file and the line, key or element).
    Io(IoError),
    /// A frame selection that cannot be read or lies outside the scene's frames.
    Frames { scene: PathBuf, error: FrameSelectionError },
    /// The deformer refused frame `frame` of a shot.
    Frame { frame: i64, error: Box<PipelineError> },
    /// The deformer refused a frame of two objects.
    Pipeline(Box<PipelineError>),
    /// The contact definition of two objects failed.
    Contact(ContactError),
    /// A mesh the deformer cannot take.
    Mesh { object: String, message: String },
    /// A `{frame}` pattern that cannot be read.
    Pattern { pattern: String, message: String },
    /// A thread count of zero.
    NoThreads,
    /// The worker threads could not be started.
    ThreadPool { threads: usize, message: String },
    /// The output folder is a file.
    OutputIsFile { dir: PathBuf },
    /// The output folder cannot be created or written.
    OutputDir { dir: PathBuf, action: &'static str, error: std::io::Error },
    /// Sequence files the frames need do not exist.
    MissingSequenceFiles { scene: PathBuf, missing: Vec<MissingFile> },
    /// A report part that cannot be read, or the folder of the parts.
    Report { path: PathBuf, message: String },
    /// Parts of a split shot that cannot be merged into one file.
    Parts { path: PathBuf, message: String },
    /// Some frames failed; the others were computed and written.
    FramesFailed(Box<FailedFrames>),
    /// Stopped before the last frame, after writing the frames done and the report.
    Interrupted(Box<Stopped>),
    /// Not the user's doing: a serialization, a plot's encoding, a worker that panicked.
    Internal(String),
}

impl ShotError {
    /// What kind of error it is.
    pub fn kind(&self) -> ErrorKind {
        use std::io::ErrorKind as Io;
        match self {
            Self::Pipeline(e)
                if matches!(**e, PipelineError::Parameter { .. } | PipelineError::PerVertexLength { .. }) =>
            {
                ErrorKind::Parameter
            }
            Self::Io(_)
            | Self::Frames { .. }
            | Self::Frame { .. }
            | Self::Pipeline(_)
            | Self::Contact(_)
            | Self::Mesh { .. }
            | Self::Pattern { .. }
            | Self::NoThreads
            | Self::OutputIsFile { .. }
            | Self::MissingSequenceFiles { .. } => ErrorKind::Input,
            Self::OutputDir { error, .. } => match error.kind() {
                Io::PermissionDenied | Io::ReadOnlyFilesystem | Io::NotADirectory | Io::AlreadyExists => {
                    ErrorKind::Input
                }
                _ => ErrorKind::Failure,
            },
            Self::ThreadPool { .. }
            | Self::Report { .. }
            | Self::Parts { .. }
            | Self::FramesFailed(_)
            | Self::Internal(_) => ErrorKind::Failure,
            Self::Interrupted(_) => ErrorKind::Interrupted,
        }
    }

    /// The one-line message (a list of missing files takes a line each), naming settings in the
    /// front end's `words`.
    pub fn message(&self, words: &dyn Wording) -> String {
        match self {
            Self::Io(e) => e.to_string(),
            Self::Frames { scene, error } => {
                format!("{}: {}: {}", scene.display(), words.frames_given(&error.text), error.message)
            }
            Self::Frame { frame, error } => format!("frame {frame}: {error}"),
            Self::Pipeline(e) => match e.as_ref() {
                PipelineError::Contact { a, b, source } => {
                    format!("pair (\"{a}\", \"{b}\"): {}", contact_message(source, words))
                }
                e => e.to_string(),
            },
            Self::Contact(e) => contact_message(e, words),
            Self::Mesh { object, message } => format!("{object}: {message}"),
            Self::Pattern { pattern, message } => format!("{pattern}: {message}"),
            Self::NoThreads => {
                format!("{}: give at least 1 (or leave it out to use every core)", words.threads(0))
            }
            Self::ThreadPool { threads, message } => format!("cannot start {threads} worker threads: {message}"),
            Self::OutputIsFile { dir } => format!(
                "{} is a file, not a folder: give {} a folder (it is created if missing)",
                dir.display(),
                words.output()
            ),
            Self::OutputDir { dir, action, error } => {
                use std::io::ErrorKind as Io;
                let start = format!("cannot {action} the output folder {}: {error}", dir.display());
                match error.kind() {
                    Io::PermissionDenied | Io::ReadOnlyFilesystem => {
                        format!("{start}; choose a folder you can write with {}", words.output())
                    }
                    Io::NotADirectory | Io::AlreadyExists => {
                        format!("{start}; a file is in the way, give {} another folder", words.output())
                    }
                    _ => start,
                }
            }
            Self::MissingSequenceFiles { scene, missing } => {
                let list: Vec<String> = missing
                    .iter()
                    .take(5)
                    .map(|m| format!("  object \"{}\", frame {}: {}", m.object, m.frame, m.path.display()))
                    .collect();
                let more =
                    if missing.len() > 5 { format!("\n  … and {} more", missing.len() - 5) } else { String::new() };
                let (s, are) = if missing.len() == 1 { ("", "is") } else { ("s", "are") };
                format!(
                    "{}: {} file{s} of mesh sequences {are} missing:\n{}{more}\nexport those frames, or choose other frames with {}",
                    scene.display(),
                    missing.len(),
                    list.join("\n"),
                    words.frames_option()
                )
            }
            Self::Report { path, message } | Self::Parts { path, message } => format!("{}: {message}", path.display()),
            Self::FramesFailed(f) => {
                let stopped =
                    if f.writing_stopped { "; writing a frame failed, so no more frames were started" } else { "" };
                let shot_files = if f.shot_files_missing {
                    "; the files holding every frame need every frame and were not written"
                } else {
                    ""
                };
                format!(
                    "{} of {} frame{} failed (frame {}: {}){stopped}; {} frame{} written{shot_files} (report: {}); once fixed, run the frames left: {}",
                    f.failed,
                    f.total,
                    plural(f.total),
                    f.first_frame,
                    f.first_error,
                    f.written,
                    plural(f.written),
                    f.report.display(),
                    runs(&f.left, words)
                )
            }
            Self::Interrupted(s) => {
                let shot_files = if s.shot_files_missing {
                    "; the files holding every frame need every frame and were not written"
                } else {
                    ""
                };
                format!(
                    "interrupted: {} of {} frames done (report: {}){shot_files}; to finish, run the missing frames: {}",
                    s.done,
                    s.total,
                    s.report.display(),
                    runs(&s.missing, words)
                )
            }
            Self::Internal(message) => message.clone(),
        }
    }
}

/// A contact error with the fix in the front end's words: the library names the pair parameter
/// to set, the front end says how.
fn contact_message(error: &ContactError, words: &dyn Wording) -> String {
    let fix = match error {
        ContactError::DirectionUndefined => format!(
            "; {}: {} (the direction from A toward B)",
            words.place(),
            words.parameter("pair", "direction", SettingValue::Vector([0.0, 0.0, 1.0]))
        ),
        ContactError::BallTestingNeedsOneRigid => format!(
            "; {}: {}, or {}",
            words.place(),
            words.parameter("pair", "contact_method", SettingValue::Word("geometric")),
            words.parameter("a", "rigid", SettingValue::Bool(true))
        ),
        _ => String::new(),
    };
    format!("{error}{fix}")
}

/// Runs of frames as the settings that run them, comma separated.
fn runs(runs: &[(i64, i64)], words: &dyn Wording) -> String {
    runs.iter().map(|&(a, b)| words.frames(a, b)).collect::<Vec<_>>().join(", ")
}

/// "s" for a count other than one.
pub(crate) fn plural(count: usize) -> &'static str {
    if count == 1 { "" } else { "s" }
}

impl fmt::Display for ShotError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message(&Neutral))
    }
}

impl std::error::Error for ShotError {}

impl From<IoError> for ShotError {
    fn from(error: IoError) -> Self {
        Self::Io(error)
    }
}

impl From<serde_json::Error> for ShotError {
    fn from(error: serde_json::Error) -> Self {
        Self::Internal(format!("could not serialize JSON: {error}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A front end's words for the tests: options with dashes.
    struct Flags;

    impl Wording for Flags {
        fn frames_option(&self) -> &'static str {
            "--frames"
        }
        fn frames_given(&self, text: &str) -> String {
            format!("--frames {text}")
        }
        fn frames(&self, first: i64, last: i64) -> String {
            format!("--{}", Neutral.frames(first, last))
        }
        fn threads(&self, n: usize) -> String {
            format!("--threads {n}")
        }
        fn output(&self) -> &'static str {
            "-o"
        }
        fn place(&self) -> &'static str {
            "on the command line"
        }
        fn parameter(&self, prefix: &str, key: &str, value: SettingValue) -> String {
            format!("--set {prefix}.{key}={value}")
        }
    }

    #[test]
    fn messages_name_settings_in_the_front_ends_words() {
        let stopped = ShotError::Interrupted(Box::new(Stopped {
            done: 12,
            total: 400,
            report: PathBuf::from("out/report.json"),
            shot_files_missing: false,
            missing: vec![(13, 20), (22, 400)],
        }));
        assert_eq!(stopped.kind(), ErrorKind::Interrupted);
        assert_eq!(
            stopped.message(&Flags),
            "interrupted: 12 of 400 frames done (report: out/report.json); to finish, run the missing frames: --frames 13:20, --frames 22:400"
        );
        assert!(stopped.to_string().ends_with("frames 13:20, frames 22:400"), "{stopped}");
        let error = ShotError::Contact(ContactError::DirectionUndefined);
        assert!(
            error
                .message(&Flags)
                .ends_with("; on the command line: --set pair.direction=0,0,1 (the direction from A toward B)")
        );
        assert_eq!(
            ShotError::NoThreads.message(&Flags),
            "--threads 0: give at least 1 (or leave it out to use every core)"
        );
        let denied = ShotError::OutputDir {
            dir: PathBuf::from("/out"),
            action: "create",
            error: std::io::Error::from(std::io::ErrorKind::PermissionDenied),
        };
        assert_eq!(denied.kind(), ErrorKind::Input);
        assert!(denied.message(&Flags).ends_with("with -o"), "{}", denied.message(&Flags));
    }
}
