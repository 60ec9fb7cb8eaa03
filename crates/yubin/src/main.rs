//! `yubin`: the command-line renderer.
//!
//! ```text
//! yubin render [SCENE] [-o OUT] [--spp N] [--threads N] [--seed S] [-D name=value]... [--quiet]
//! yubin compare IMAGE.exr REFERENCE.exr
//! yubin tonemap IMAGE.exr -o OUT.png [--exposure EV] [--tonemap CURVE | --ocio CONFIG --view VIEW --look LOOKS]
//! ```
#![warn(missing_docs)]

mod checkpoint;
mod compare;
mod denoise;
mod interrupt;
mod output;
mod render;
mod tonemap;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// A physically based path tracer that renders Mitsuba 3 scenes.
#[derive(Debug, Parser)]
#[command(name = "yubin", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Render a scene (the built-in Cornell box when no scene is given).
    Render(Box<render::RenderArgs>),
    /// Compare an image with a reference: relMSE, RMSE and mean-luminance bias.
    Compare(compare::CompareArgs),
    /// Show a scene-linear image through an exposure and a tone curve or
    /// OpenColorIO view, as PNG or JPEG.
    Tonemap(tonemap::TonemapArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => render::run(*args),
        Command::Compare(args) => compare::run(args),
        Command::Tonemap(args) => tonemap::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
