//! Writing rendered images (EXR with extra layers, or sRGB PNG), always
//! through a temporary file that is renamed into place.

use anyhow::Result;
use std::path::Path;
use yubin_core::film::Framebuffer;
use yubin_core::render::RenderOutput;
use yubin_scene::image_io::{write_image, ExrLayer, Image};
use yubin_scene::tonemap::{to_display, ToneCurve};

/// How 8-bit outputs show the scene-linear image.
#[derive(Clone, Copy, Debug)]
pub struct Display {
    /// Exposure in stops.
    pub exposure: f32,
    /// Tone curve.
    pub curve: ToneCurve,
}

impl Default for Display {
    fn default() -> Self {
        Self {
            exposure: 0.0,
            curve: ToneCurve::Srgb,
        }
    }
}

fn to_image(fb: &Framebuffer) -> Image {
    Image {
        width: fb.width as usize,
        height: fb.height as usize,
        channels: fb.channels,
        data: fb.data.clone(),
    }
}

/// Writes the RGB image and, for EXR, every extra layer the integrator made,
/// each channel named `layer.suffix` as the integrator names it; a PNG
/// shows the image through `display` (EXR stays scene-linear).
pub fn write_output(path: &Path, out: &RenderOutput, display: &Display) -> Result<()> {
    let rgb = to_image(&out.image.select_channels(0..3));
    let mut offset = 3;
    let layers: Vec<Image> = out
        .layers
        .iter()
        .map(|layer| {
            let range = offset..offset + layer.width();
            offset = range.end;
            to_image(&out.image.select_channels(range))
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
    let rgb = if is_exr {
        rgb
    } else {
        to_display(&rgb, display.exposure, display.curve)
    };
    write_image(path, &rgb, &extra)?;
    Ok(())
}
