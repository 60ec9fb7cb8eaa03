//! Writing rendered images (EXR with extra layers, or sRGB PNG), always
//! through a temporary file that is renamed into place.

use anyhow::Result;
use std::path::Path;
use yubin_core::film::Framebuffer;
use yubin_core::render::RenderOutput;
use yubin_scene::image_io::{write_image, Image};

fn to_image(fb: &Framebuffer) -> Image {
    Image {
        width: fb.width as usize,
        height: fb.height as usize,
        channels: fb.channels,
        data: fb.data.clone(),
    }
}

/// Writes the RGB image and, for EXR, every extra layer the integrator made.
pub fn write_output(path: &Path, out: &RenderOutput) -> Result<()> {
    let rgb = to_image(&out.image.select_channels(0..3));
    let layers: Vec<(String, Image)> = out
        .layers
        .iter()
        .enumerate()
        .map(|(i, name)| {
            (
                name.clone(),
                to_image(&out.image.select_channels(3 + 3 * i..6 + 3 * i)),
            )
        })
        .collect();
    // Only EXR holds extra layers; a PNG gets the RGB image alone.
    let is_exr = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    let extra: Vec<(&str, &Image)> = if is_exr {
        layers.iter().map(|(n, img)| (n.as_str(), img)).collect()
    } else {
        Vec::new()
    };
    write_image(path, &rgb, &extra)?;
    Ok(())
}
