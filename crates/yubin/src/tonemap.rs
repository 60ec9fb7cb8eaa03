//! `yubin tonemap`: shows a scene-linear image (an EXR from `yubin render`,
//! say) through an exposure and a tone curve or OCIO view, as an 8-bit
//! PNG or JPEG, without rendering again.

use crate::output::DisplayArgs;
use anyhow::{Context, Result};
use std::path::PathBuf;
use yubin_scene::image_io::{read_image, write_display_image, ColorHandling};
use yubin_scene::tonemap::to_display;

/// Arguments of `yubin tonemap`.
#[derive(Debug, clap::Args)]
pub struct TonemapArgs {
    /// Scene-linear input image (EXR; other formats are read as sRGB).
    input: PathBuf,
    /// Output image, .png or .jpg.
    #[arg(short, long)]
    output: PathBuf,
    /// The view.
    #[command(flatten)]
    display: DisplayArgs,
}

/// Reads, shows and writes.
pub fn run(args: TonemapArgs) -> Result<()> {
    let display = args.display.resolve()?;
    let image = read_image(&args.input, ColorHandling::Srgb)?;
    let shown = to_display(&image, display.exposure, &display.view);
    write_display_image(&args.output, &shown)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    Ok(())
}
