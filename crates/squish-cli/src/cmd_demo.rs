//! `squish demo`: being built (see the issue tracker); this placeholder only reports that.

use clap::Args;

use crate::error::CliError;

#[derive(Args, Debug)]
pub struct DemoArgs {}

pub fn run(_args: &DemoArgs) -> Result<(), CliError> {
    Err(CliError::failure("`squish demo` is not available in this build yet"))
}
