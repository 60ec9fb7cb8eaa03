//! Writing rendered images (EXR with extra layers, or 8-bit PNG or JPEG
//! through a view), always through a temporary file that is renamed into
//! place.

use anyhow::{bail, Context, Result};
use std::path::Path;
use std::path::PathBuf;
use std::sync::Arc;
use yubin_core::film::Framebuffer;
use yubin_core::render::RenderOutput;
use yubin_scene::image_io::{write_display_image, write_image, ExrLayer, Image};
use yubin_scene::ocio::Config;
use yubin_scene::tonemap::{to_display, ToneCurve, View};

/// Options of 8-bit output: exposure, then a built-in tone curve or an
/// OpenColorIO view.
#[derive(Debug, clap::Args)]
pub struct DisplayArgs {
    /// Exposure of PNG/JPEG output in stops (EXR stays scene-linear).
    #[arg(
        long,
        value_name = "EV",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    exposure: f32,
    /// Tone curve of PNG/JPEG output: srgb (clip), filmic (Hable) or agx
    /// (default: srgb, or the OCIO view when a config is given).
    #[arg(long, value_name = "CURVE", value_parser = parse_curve)]
    tonemap: Option<ToneCurve>,
    /// OpenColorIO config whose display view shows PNG/JPEG output
    /// (default: $OCIO unless --tonemap is given); the image enters as
    /// the config's scene_linear space.
    #[arg(long, value_name = "CONFIG")]
    ocio: Option<PathBuf>,
    /// OCIO display (default: the config's first active display).
    #[arg(long, value_name = "NAME")]
    display: Option<String>,
    /// OCIO view of the display (default: its first; Blender's config:
    /// Standard, AgX, Filmic, False Color, ...).
    #[arg(long, value_name = "NAME")]
    view: Option<String>,
    /// OCIO looks, in order, comma-separated, "-" inverting one
    /// (default: the view's own; Blender's Filmic: "High Contrast", ...).
    #[arg(long, value_name = "LOOKS")]
    look: Option<String>,
}

fn parse_curve(s: &str) -> Result<ToneCurve, String> {
    ToneCurve::from_name(s).ok_or_else(|| {
        let names: Vec<&str> = yubin_scene::tonemap::CURVES
            .iter()
            .map(|(n, _)| *n)
            .collect();
        format!("unknown tone curve \"{s}\" (known: {})", names.join(", "))
    })
}

impl DisplayArgs {
    /// The display these options ask for: `--tonemap`, or the OCIO config
    /// of `--ocio` or `$OCIO` with `--display`, `--view` and `--look`
    /// (read now, so that its errors come before any rendering).
    pub fn resolve(&self) -> Result<Display> {
        let args = self;
        if !args.exposure.is_finite() {
            bail!("--exposure must be a finite number of stops");
        }
        if args.ocio.is_some() && args.tonemap.is_some() {
            bail!("--tonemap and --ocio both choose how PNG/JPEG output looks; give one");
        }
        let config = match (&args.ocio, args.tonemap) {
            (Some(path), _) => Some(path.clone()),
            (None, None) => std::env::var_os("OCIO")
                .filter(|v| !v.is_empty())
                .map(PathBuf::from),
            (None, Some(_)) => None,
        };
        let view = match config {
            Some(path) => {
                let processor = Config::load(&path).and_then(|config| {
                    config.display_processor(
                        args.display.as_deref(),
                        args.view.as_deref(),
                        args.look.as_deref(),
                    )
                });
                let asked = args.ocio.is_some()
                    || args.display.is_some()
                    || args.view.is_some()
                    || args.look.is_some();
                match processor {
                    Ok(p) => View::Ocio(Arc::new(p)),
                    Err(e) if asked => return Err(e.into()),
                    // A config that only the environment names, for other
                    // programs perhaps, does not stop a render: as Blender
                    // does, fall back to the built-in view.
                    Err(e) => {
                        eprintln!("warning: $OCIO: {e}; PNG/JPEG output uses the srgb curve");
                        View::Curve(ToneCurve::Srgb)
                    }
                }
            }
            None => {
                if args.display.is_some() || args.view.is_some() || args.look.is_some() {
                    bail!("--display, --view and --look choose from an OpenColorIO config: give one with --ocio CONFIG (or $OCIO)");
                }
                View::Curve(args.tonemap.unwrap_or(ToneCurve::Srgb))
            }
        };
        Ok(Display {
            exposure: args.exposure,
            view,
        })
    }
}

/// How 8-bit outputs show the scene-linear image.
#[derive(Clone, Debug)]
pub struct Display {
    /// Exposure in stops.
    pub exposure: f32,
    /// Tone curve or OCIO view.
    pub view: View,
}

fn to_image(fb: Framebuffer) -> Image {
    Image {
        width: fb.width as usize,
        height: fb.height as usize,
        channels: fb.channels,
        data: fb.data,
    }
}

/// Writes the RGB image and, for EXR, every extra layer the integrator made,
/// each channel named `layer.suffix` as the integrator names it; a PNG or
/// JPEG shows the image through `display` (EXR stays scene-linear). The
/// file is written whole to a temporary name and renamed into place: a
/// write that fails (a full disk, a file size limit) leaves the previous
/// file as it was, and the error says so.
pub fn write_output(path: &Path, out: &RenderOutput, display: &Display) -> Result<()> {
    let existed = path.exists();
    write_layers(path, out, display).with_context(|| {
        if existed {
            format!(
                "cannot write {} (the previous {} is untouched)",
                path.display(),
                path.display()
            )
        } else {
            format!("cannot write {}", path.display())
        }
    })
}

fn write_layers(path: &Path, out: &RenderOutput, display: &Display) -> Result<()> {
    let rgb = to_image(out.image.select_channels(0..3));
    let mut offset = 3;
    let layers: Vec<Image> = out
        .layers
        .iter()
        .map(|layer| {
            let range = offset..offset + layer.width();
            offset = range.end;
            to_image(out.image.select_channels(range))
        })
        .collect();
    // Only EXR holds extra layers; a PNG gets the RGB image alone.
    let is_exr = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    let extra: Vec<ExrLayer> = if is_exr {
        out.layers
            .iter()
            .zip(&layers)
            .map(|(layer, image)| ExrLayer {
                name: &layer.name,
                channels: Some(&layer.channels),
                image,
            })
            .collect()
    } else {
        Vec::new()
    };
    if is_exr {
        write_image(path, &rgb, &extra)?;
    } else {
        write_display_image(path, &to_display(&rgb, display.exposure, &display.view))?;
    }
    Ok(())
}
