//! `squish`: the command-line front end of the Squish deformer.
//!
//! A thin layer over the `squish` core library and `squish-io`: every command parses its
//! arguments, reads files, calls the library and writes results atomically. Parameters are the
//! library's own structures; the command line never re-declares them.

mod cmd_info;
mod error;

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
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result: Result<(), CliError> = match cli.command {
        Command::Info(args) => cmd_info::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error}");
            ExitCode::from(error.exit_code())
        }
    }
}
