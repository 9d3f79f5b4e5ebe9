//! `squish bench`: being built (see the issue tracker); this placeholder only reports that.

use clap::Args;

use crate::error::CliError;

#[derive(Args, Debug)]
pub struct BenchArgs {}

pub fn run(_args: &BenchArgs) -> Result<(), CliError> {
    Err(CliError::failure("`squish bench` is not available in this build yet"))
}
