//! `shapetrack synth` (being built; replaced by its owner).

/// Arguments of `shapetrack synth`.
#[derive(clap::Args)]
pub struct Args {}

/// Runs the subcommand.
pub fn run(_args: Args) -> crate::CliResult {
    Err("this subcommand is not built yet".into())
}
