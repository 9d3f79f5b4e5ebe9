//! `squish`: the command-line front end of the Squish deformer, and the shot machinery it shares
//! with the Python module (`crates/squish-py`).
//!
//! A thin layer over the `squish` core library and `squish-io`: every command parses its
//! arguments, reads files, calls the library and writes results atomically. Parameters are the
//! library's own structures; the command line never re-declares them.
//!
//! The binary (`src/main.rs`) only calls [`run_command_line`]. The public modules are what other
//! front ends reuse so that they write the same files and reports as `squish run` and
//! `squish deform`: [`cmd_run::run_scene`] (a scene file run into an output folder: frames in
//! parallel, atomic per-frame writes, report parts and their merge, a clean stop), [`shot`]
//! (frames in parallel), [`scene_shot`] (scene frames as library frames), [`params`] (parameters
//! of a two-object command), [`cmd_deform::deform_pair`] and [`cmd_contact::define_contact`] (one
//! frame of two meshes and its figures), [`quality`] and [`report`] (the figures of report.json),
//! [`error`] (errors with their exit codes) and [`interrupt`] (a stop request that lets the
//! frames in progress finish).

mod bench_report;
mod cmd_bench;
pub mod cmd_contact;
pub mod cmd_deform;
mod cmd_demo;
mod cmd_info;
pub mod cmd_params;
pub mod cmd_run;
mod console;
pub mod error;
pub mod frame_quality;
pub mod input;
pub mod interrupt;
pub mod params;
pub mod preview;
pub mod quality;
pub mod report;
pub mod report_parts;
pub mod scene_shot;
#[cfg(test)]
mod schema_tests;
pub mod shot;
pub mod shot_outputs;

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
}

/// The `squish` command: parses the process's arguments, runs the command, prints an error (if
/// any) and returns the exit code.
pub fn run_command_line() -> ExitCode {
    let cli = Cli::parse();
    let result: Result<(), CliError> = match cli.command {
        Command::Info(args) => cmd_info::run(&args),
        Command::Deform(args) => cmd_deform::run(&args),
        Command::Contact(args) => cmd_contact::run(&args),
        Command::Run(args) => cmd_run::run(&args),
        Command::Demo(args) => cmd_demo::run(&args),
        Command::Bench(args) => cmd_bench::run(&args),
        Command::Params(args) => cmd_params::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error}");
            ExitCode::from(error.exit_code())
        }
    }
}
