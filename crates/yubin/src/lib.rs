//! `yubin`: the command-line renderer. The binary is `main.rs`, which
//! parses its arguments ([`Cli`]) and [`run`]s them; the library holds
//! the rest, so that tests and fuzzing reach the argument parser.
//!
//! ```text
//! yubin render [SCENE] [-o OUT] [--spp N] [--threads N] [--seed S] [-D name=value]... [--quiet]
//! yubin render SCENE --part K/N -o PART.exr     (one of N parts)
//! yubin merge PART.exr... -o IMAGE.exr
//! yubin farm slurm SCENE --parts N -o DIR [--frames A-B] [--submit] [-- RENDER OPTIONS]
//! yubin farm status DIR | yubin farm resubmit DIR
//! yubin compare IMAGE.exr REFERENCE.exr
//! yubin tonemap IMAGE.exr -o OUT.png [--exposure EV] [--tonemap CURVE | --ocio CONFIG --view VIEW --look LOOKS]
//! ```
#![warn(missing_docs)]

mod checkpoint;
mod compare;
mod denoise;
mod farm;
mod interrupt;
mod merge;
mod output;
mod part;
mod render;
mod tonemap;

pub use clap::Parser;
use clap::Subcommand;
use std::process::ExitCode;

/// A physically based path tracer that renders Mitsuba 3 scenes.
#[derive(Debug, Parser)]
#[command(name = "yubin", version, about)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Render a scene (the built-in Cornell box when no scene is given).
    Render(Box<render::RenderArgs>),
    /// Put the parts of a render (`render --part K/N`) together into its
    /// image, bit for bit the image of one render.
    Merge(merge::MergeArgs),
    /// Render on a cluster: Slurm job arrays of parts and their merge.
    Farm(farm::FarmArgs),
    /// Compare an image with a reference: relMSE, RMSE and mean-luminance bias.
    Compare(compare::CompareArgs),
    /// Show a scene-linear image through an exposure and a tone curve or
    /// OpenColorIO view, as PNG or JPEG.
    Tonemap(tonemap::TonemapArgs),
}

/// Runs the command `cli` holds; an error is printed whole (its chain of
/// causes), exit status 1.
pub fn run(cli: Cli) -> ExitCode {
    let result = match cli.command {
        Command::Render(args) => render::run(*args),
        Command::Merge(args) => merge::run(args),
        Command::Farm(args) => farm::run(args),
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

/// The fuzz target of the command line (`fuzz/`; its regressions are
/// replayed by `tests/fuzz_regressions.rs`): `data` split at NUL bytes
/// into arguments after `yubin`, parsed as the binary parses them
/// (errors are fine, panics are not); a `render` command's `-D` defines
/// are then substituted into the built-in scene, which is loaded (not
/// rendered).
#[doc(hidden)]
pub fn fuzz_arguments(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    let args = std::iter::once("yubin").chain(text.split('\0'));
    let Ok(cli) = Cli::try_parse_from(args) else {
        return;
    };
    if let Command::Render(args) = cli.command {
        render::load_builtin_with_defines(&args);
    }
}
