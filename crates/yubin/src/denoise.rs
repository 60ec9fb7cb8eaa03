//! `--denoise`: Intel Open Image Denoise's ray-tracing filter on the
//! finished image, guided by the albedo and normal layers
//! (`integrator::DenoiserGuides`), in HDR mode on the scene-linear values.
//! The render uses a box pixel filter: OIDN removes noise that is each
//! pixel's own, and a wider filter shares every sample among neighbours
//! (on the Cornell box at 4 spp, relMSE 0.021 → 0.013 with the tent
//! filter, 0.048 → 0.0012 with the box).
//!
//! OIDN is a C++ library that no registry package of Debian 12 carries;
//! PyPI's `pyoidn` wheel does (with TBB from the `tbb` wheel), so the
//! feature is off by default: `scripts/oidn-setup` fetches both and prints
//! the `OIDN_DIR` that the `oidn` crate links against, and
//! `cargo build --release -p yubin --features denoise` builds it in (the
//! binary finds the library through an rpath to `OIDN_DIR/lib`).

use anyhow::Result;
use yubin_core::render::RenderOutput;

/// The RGB, albedo and normal channels of `out`, as three interleaved
/// RGB images, or `None` for a guide layer that is missing.
#[cfg(feature = "denoise")]
fn planes(out: &RenderOutput) -> (Vec<f32>, Option<Vec<f32>>, Option<Vec<f32>>) {
    let fb = &out.image;
    let channel_range = |name: &str| {
        let mut offset = 3;
        for layer in &out.layers {
            if layer.name == name && layer.width() == 3 {
                return Some(offset);
            }
            offset += layer.width();
        }
        None
    };
    let take = |first: usize| -> Vec<f32> {
        fb.data
            .chunks_exact(fb.channels)
            .flat_map(|px| [px[first], px[first + 1], px[first + 2]])
            .collect()
    };
    (
        take(0),
        channel_range("albedo").map(take),
        channel_range("normal").map(take),
    )
}

/// Replaces the RGB channels of `out` with their denoised values.
#[cfg(feature = "denoise")]
pub fn denoise(out: &mut RenderOutput) -> Result<()> {
    use anyhow::{anyhow, Context};
    let (color, albedo, normal) = planes(out);
    let (Some(albedo), Some(normal)) = (albedo, normal) else {
        return Err(anyhow!("--denoise needs the albedo and normal layers"));
    };
    let device = oidn::Device::new().context("Open Image Denoise cannot start a device")?;
    let (w, h) = (out.image.width as usize, out.image.height as usize);
    let mut denoised = vec![0.0f32; color.len()];
    oidn::RayTracing::try_new(&device)
        .map_err(|e| anyhow!("Open Image Denoise has no ray-tracing filter: {e:?}"))?
        .hdr(true)
        .srgb(false)
        .albedo_normal(&albedo, &normal)
        .image_dimensions(w, h)
        .filter(&color, &mut denoised)
        .map_err(|e| anyhow!("Open Image Denoise failed: {e:?}"))?;
    device
        .get_error()
        .map_err(|e| anyhow!("Open Image Denoise failed: {e:?}"))?;
    let channels = out.image.channels;
    for (px, rgb) in out
        .image
        .data
        .chunks_exact_mut(channels)
        .zip(denoised.chunks_exact(3))
    {
        px[..3].copy_from_slice(rgb);
    }
    Ok(())
}

/// Without the `denoise` feature: says how to build it in.
#[cfg(not(feature = "denoise"))]
pub fn denoise(_out: &mut RenderOutput) -> Result<()> {
    check_available()
}

/// Fails, saying how to build it in, when this build cannot denoise.
pub fn check_available() -> Result<()> {
    if !cfg!(feature = "denoise") {
        anyhow::bail!(
            "--denoise: this yubin was built without Open Image Denoise; build it in with `OIDN_DIR=$(scripts/oidn-setup) cargo build --release -p yubin --features denoise`"
        );
    }
    Ok(())
}
