//! `squish run`: being built (see the issue tracker); this placeholder only reports that.

use clap::Args;

use crate::error::CliError;

#[derive(Args, Debug)]
pub struct RunArgs {}

pub fn run(_args: &RunArgs) -> Result<(), CliError> {
    Err(CliError::failure("`squish run` is not available in this build yet"))
}
