//! Writing rendered images (EXR with extra layers, or sRGB PNG), always
//! through a temporary file that is renamed into place.

use anyhow::Result;
use std::path::Path;
use yubin_core::film::Framebuffer;
use yubin_core::render::RenderOutput;
use yubin_scene::image_io::{write_image, ExrLayer, Image};

fn to_image(fb: &Framebuffer) -> Image {
    Image {
        width: fb.width as usize,
        height: fb.height as usize,
        channels: fb.channels,
        data: fb.data.clone(),
    }
}

/// Writes the RGB image and, for EXR, every extra layer the integrator made,
/// each channel named `layer.suffix` as the integrator names it.
pub fn write_output(path: &Path, out: &RenderOutput) -> Result<()> {
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
    write_image(path, &rgb, &extra)?;
    Ok(())
}
