//! `shapetrack track` (being built; replaced by its owner).

/// Arguments of `shapetrack track`.
#[derive(clap::Args)]
pub struct Args {}

/// Runs the subcommand.
pub fn run(_args: Args) -> crate::CliResult {
    Err("this subcommand is not built yet".into())
}
