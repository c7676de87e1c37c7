//! The `blurlab` binary: thin subcommands over the study, render, runner and analysis crates.

use clap::Parser;

/// blurlab: perceptual studies of motion-blurred rendering.
#[derive(Parser)]
#[command(name = "blurlab", version, about)]
enum Command {}

fn main() -> anyhow::Result<()> {
    match Command::parse() {}
}
