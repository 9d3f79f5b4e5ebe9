//! Errors of the command line: a message for the user and an exit code.

use std::fmt;

/// An error reported to the user. Exit code 1 for failures, 2 for bad usage or bad input, 130 when
/// stopped by Ctrl-C (the shell convention 128 + SIGINT, so scripts can tell it from a failure).
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

    /// Bad input or usage, exit code 2.
    /// `--strict` and `count` warnings were printed: exit 1.
    pub fn strict(count: usize) -> Self {
        Self::failure(format!(
            "--strict: {count} warning{} (above): a requested treatment did not happen or penetration remains; \
             the outputs were written",
            if count == 1 { "" } else { "s" }
        ))
    }

    pub fn input(message: impl Into<String>) -> Self {
        Self { message: message.into(), code: 2 }
    }

    /// Stopped by Ctrl-C after writing what was done, exit code 130.
    pub fn interrupted(message: impl Into<String>) -> Self {
        Self { message: message.into(), code: 130 }
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
