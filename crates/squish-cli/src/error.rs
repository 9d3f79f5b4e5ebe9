//! Errors of the command line: a message for the user and an exit code. The shot machinery's
//! errors ([`ShotError`], data) are worded here, once, in the command line's terms
//! ([`CommandLine`]: `--frames 3:4`, `--threads 0`, `-o`, `--set pair.direction=0,0,1`), and
//! given their exit code by their kind.

use std::fmt;

use squish_shot::error::{ErrorKind, SettingValue, ShotError, Wording};

/// An error reported to the user. Exit code 1 for failures, 2 for bad usage or bad input, and
/// 128 + the signal when stopped by one after writing what was done (130 Ctrl-C, 143 SIGTERM,
/// 129 SIGHUP: the shell convention, so scripts can tell a stop from a failure).
#[derive(Debug)]
pub struct CliError {
    message: String,
    code: u8,
}

impl CliError {
    /// A failure with exit code 1.
    pub fn failure(message: impl Into<String>) -> Self {
        Self { message: message.into(), code: 1 }
    }

    /// `--strict` and `count` warnings were printed: exit 1.
    pub fn strict(count: usize) -> Self {
        Self::failure(format!(
            "--strict: {count} warning{} (above): a requested treatment did not happen or penetration remains; \
             the outputs were written",
            if count == 1 { "" } else { "s" }
        ))
    }

    /// Bad input or usage, exit code 2.
    pub fn input(message: impl Into<String>) -> Self {
        Self { message: message.into(), code: 2 }
    }

    /// Stopped by a signal after writing what was done: exit code 128 + the signal that stopped
    /// the job (130 for Ctrl-C, the default when none was received).
    pub fn interrupted(message: impl Into<String>) -> Self {
        Self { message: message.into(), code: crate::signals::stop_exit_code() }
    }

    /// The process exit code.
    pub fn exit_code(&self) -> u8 {
        self.code
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

/// The command line's names for the settings a message tells the user to change.
pub struct CommandLine;

impl Wording for CommandLine {
    fn frames_option(&self) -> &'static str {
        "--frames"
    }
    fn frames_given(&self, text: &str) -> String {
        format!("--frames {text}")
    }
    fn frames(&self, first: i64, last: i64) -> String {
        format!("--frames {first}:{last}")
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

impl From<ShotError> for CliError {
    fn from(error: ShotError) -> Self {
        let message = error.message(&CommandLine);
        match error.kind() {
            ErrorKind::Input | ErrorKind::Parameter => Self::input(message),
            ErrorKind::Failure => Self::failure(message),
            ErrorKind::Interrupted => Self::interrupted(message),
        }
    }
}

impl From<squish_io::IoError> for CliError {
    fn from(error: squish_io::IoError) -> Self {
        Self::input(error.to_string())
    }
}

impl From<std::io::Error> for CliError {
    fn from(error: std::io::Error) -> Self {
        Self::failure(error.to_string())
    }
}

impl From<serde_json::Error> for CliError {
    fn from(error: serde_json::Error) -> Self {
        Self::failure(format!("could not serialize JSON: {error}"))
    }
}
