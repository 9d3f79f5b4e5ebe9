//! The `squish` binary: everything is in the library (`lib.rs`), which the Python module shares.

fn main() -> std::process::ExitCode {
    squish_cli::run_command_line()
}
