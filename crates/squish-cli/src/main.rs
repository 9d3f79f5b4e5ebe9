//! `squish`: the command-line front end of the Squish deformer.
//!
//! A thin layer over the `squish` core library and `squish-io`: every command parses its
//! arguments, reads files, calls the library and writes results atomically. Parameters are the
//! library's own structures; the command line never re-declares them.

mod bench_report;
mod cmd_bench;
mod cmd_contact;
mod cmd_deform;
mod cmd_demo;
mod cmd_info;
mod cmd_params;
mod cmd_run;
mod console;
mod error;
mod frame_quality;
mod input;
mod interrupt;
mod params;
mod preview;
mod quality;
mod report;
mod report_parts;
mod scene_shot;
#[cfg(test)]
mod schema_tests;
mod shot;
mod shot_outputs;

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

fn main() -> ExitCode {
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
