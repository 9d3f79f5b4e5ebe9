//! `squish`: the command-line front end of the Squish deformer.
//!
//! A thin layer over the `squish` core library, `squish-io` and the shot machinery it shares with
//! the Python module (`squish-shot`: scene runs, their files and reports, one-frame calls): every
//! command parses its arguments, reads files, calls the libraries, prints and draws. Parameters
//! are the library's own structures; the command line never re-declares them. The shot
//! machinery's errors are worded here in the command line's terms and given exit codes
//! ([`error`]); Ctrl-C, SIGTERM and SIGHUP stop long jobs cleanly ([`signals`]).
//!
//! The binary (`src/main.rs`) only calls [`run_command_line`]. The public modules are what the
//! integration tests and examples reach: [`params`] (`--set` / `--params` of a two-object
//! command), [`input`] (meshes read for the two-object commands), [`serve`] (the live preview's
//! server).

mod bench_report;
mod cmd_bench;
mod cmd_contact;
mod cmd_deform;
mod cmd_demo;
mod cmd_info;
mod cmd_params;
mod cmd_run;
mod console;
pub mod error;
pub mod input;
pub mod params;
mod preview;
#[cfg(test)]
mod schema_tests;
pub mod serve;
pub mod signals;

use std::ffi::OsString;
use std::path::Path;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use crate::error::CliError;

/// Squish — a time-independent deformer for elastic contacts.
///
/// Meshes that intersect at one frame go in; meshes in clean contact come out, squashed where
/// they touch and bulging around it with their volume preserved (Brunel, Bénard, Guennebaud
/// 2020/2021).
#[derive(Parser, Debug)]
#[command(name = "squish", version, about, long_about = None, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Report a mesh's size, topology, self-intersections, volume and bounding box.
    Info(cmd_info::InfoArgs),
    /// Deform two intersecting meshes into clean contact (one frame).
    Deform(cmd_deform::DeformArgs),
    /// Compute and export the contact definition of two meshes (labels, boundary points, JSON).
    Contact(cmd_contact::ContactArgs),
    /// Run an animated scene file: every frame in parallel, outputs, report and previews.
    Run(cmd_run::RunArgs),
    /// Build embedded animated scenes, deform them and write meshes, reports and pictures.
    Demo(cmd_demo::DemoArgs),
    /// Time the pipeline on reproducible scenes at the thesis' sizes.
    Bench(cmd_bench::BenchArgs),
    /// List every parameter: key, type, default, valid range, thesis symbol and meaning.
    Params(cmd_params::ParamsArgs),
    /// A live preview in the browser: edit parameters, profiles and bulge maps on a scene.
    Serve(serve::ServeArgs),
}

/// The `squish` command: parses the process's arguments, runs the command, prints an error (if
/// any) and returns the exit code.
pub fn run_command_line() -> ExitCode {
    let cli = Cli::parse_from(bare_weld_before_a_mesh(std::env::args_os().collect()));
    let result: Result<(), CliError> = match cli.command {
        Command::Info(args) => cmd_info::run(&args),
        Command::Deform(args) => cmd_deform::run(&args),
        Command::Contact(args) => cmd_contact::run(&args),
        Command::Run(args) => cmd_run::run(&args),
        Command::Demo(args) => cmd_demo::run(&args),
        Command::Bench(args) => cmd_bench::run(&args),
        Command::Params(args) => cmd_params::run(&args),
        Command::Serve(args) => serve::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error}");
            ExitCode::from(error.exit_code())
        }
    }
}

/// `--weld` given alone right before a mesh file (`squish info --weld mesh.glb`) is `--weld=always`:
/// clap would take the file for the option's value (`--weld` takes one, optionally). A word that
/// is not a mesh file stays the value, so a misspelt one is still reported as such.
fn bare_weld_before_a_mesh(mut args: Vec<OsString>) -> Vec<OsString> {
    let is_mesh = |arg: &OsString| {
        Path::new(arg).extension().is_some_and(|e| {
            matches!(e.to_string_lossy().to_ascii_lowercase().as_str(), "obj" | "ply" | "gltf" | "glb")
        })
    };
    for k in 0..args.len().saturating_sub(1) {
        if args[k] == "--weld" && is_mesh(&args[k + 1]) {
            args[k] = OsString::from("--weld=always");
        }
    }
    args
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bare_weld_before_a_mesh_welds_always() {
        let parse = |args: &[&str]| {
            let args = bare_weld_before_a_mesh(args.iter().map(OsString::from).collect());
            match Cli::try_parse_from(args).map(|cli| cli.command) {
                Ok(Command::Info(info)) => Ok((info.weld, info.mesh)),
                Ok(other) => panic!("{other:?}"),
                Err(e) => Err(e.kind()),
            }
        };
        let mesh = std::path::PathBuf::from("mesh.glb");
        assert_eq!(parse(&["squish", "info", "--weld", "mesh.glb"]), Ok((input::WeldChoice::Always, mesh.clone())));
        assert_eq!(parse(&["squish", "info", "mesh.glb", "--weld"]), Ok((input::WeldChoice::Always, mesh.clone())));
        assert_eq!(
            parse(&["squish", "info", "--weld", "never", "mesh.glb"]),
            Ok((input::WeldChoice::Never, mesh.clone()))
        );
        assert_eq!(parse(&["squish", "info", "--weld=never", "mesh.glb"]), Ok((input::WeldChoice::Never, mesh)));
        assert_eq!(parse(&["squish", "info", "--weld", "nevr", "mesh.glb"]), Err(clap::error::ErrorKind::InvalidValue));
    }
}
