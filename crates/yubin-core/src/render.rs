//! The render loop: the crop window is cut into fixed tiles; rayon renders
//! tiles in parallel, each into its own [`TileBuffer`]; buffers are merged
//! in tile order. Every sample value depends only on (pixel, sample index,
//! dimension, seed), so the image is bit-identical for any thread count.

use crate::film::{Framebuffer, Tile, TileBuffer};
use crate::filter::FilterTable;
use crate::integrator::{Integrator, Layer};
use crate::Scene;
use glam::Vec2;
use rayon::prelude::*;

/// Side of a render tile in pixels.
pub const TILE_SIZE: u32 = 16;

/// Per-render settings that are not part of the scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderSettings {
    /// Samples per pixel (the scene sampler's count unless overridden).
    pub spp: u32,
    /// Seed mixed into every sample.
    pub seed: u32,
}

/// Renders `scene` with `integrator`. `progress` is called after each tile
/// with the number of samples it took (from several threads at once).
/// Samples that come out non-finite are dropped and counted.
pub fn render(
    scene: &Scene,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> RenderOutput {
    if let Some(tracer) = integrator.particle_tracer() {
        return tracer.render(scene, settings, progress);
    }
    let film = &scene.film;
    let crop = film.crop_size;
    let channels = integrator.channel_count();
    let tiles = tiles(crop);
    let filter = FilterTable::new(&film.filter);
    let results: Vec<(TileBuffer, u64)> = tiles
        .par_iter()
        .map(|&tile| {
            let r = render_tile(scene, integrator, settings, &filter, tile, channels);
            progress(
                u64::from(tile.x1 - tile.x0)
                    * u64::from(tile.y1 - tile.y0)
                    * u64::from(settings.spp),
            );
            r
        })
        .collect();
    let stride = channels + 1;
    let mut sums = vec![0.0f32; crop[0] as usize * crop[1] as usize * stride];
    let mut dropped = 0;
    for (buf, bad) in &results {
        buf.merge_into(&mut sums, crop);
        dropped += bad;
    }
    let data = sums
        .chunks_exact(stride)
        .flat_map(|px| {
            let w = px[channels];
            let inv = if w > 0.0 { 1.0 / w } else { 0.0 };
            px[..channels].iter().map(move |v| v * inv)
        })
        .collect();
    RenderOutput {
        image: Framebuffer {
            width: crop[0],
            height: crop[1],
            channels,
            data,
        },
        layers: integrator.extra_layers(),
        dropped_samples: dropped,
    }
}

/// What [`render`] produces.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// RGB, then the channels of each extra layer in turn.
    pub image: Framebuffer,
    /// The extra layers after RGB (names and channel suffixes).
    pub layers: Vec<Layer>,
    /// Samples discarded because they were NaN or infinite.
    pub dropped_samples: u64,
}

fn tiles(crop: [u32; 2]) -> Vec<Tile> {
    let mut out = Vec::new();
    for y0 in (0..crop[1]).step_by(TILE_SIZE as usize) {
        for x0 in (0..crop[0]).step_by(TILE_SIZE as usize) {
            out.push(Tile {
                x0,
                y0,
                x1: (x0 + TILE_SIZE).min(crop[0]),
                y1: (y0 + TILE_SIZE).min(crop[1]),
            });
        }
    }
    out
}

fn render_tile(
    scene: &Scene,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    filter: &FilterTable,
    tile: Tile,
    channels: usize,
) -> (TileBuffer, u64) {
    let film = &scene.film;
    let mut buf = TileBuffer::new(tile, filter, channels);
    // One buffer per tile (not per sample), sized to the integrator.
    let mut values = vec![0.0f32; channels];
    let values = values.as_mut_slice();
    let mut dropped = 0;
    for y in tile.y0..tile.y1 {
        for x in tile.x0..tile.x1 {
            // Pixel coordinates of the full image (crop offset applied).
            let (fx, fy) = (x + film.crop_offset[0], y + film.crop_offset[1]);
            for index in 0..settings.spp {
                let mut stream = scene.sampler.stream(fx, fy, index, settings.seed);
                let offset = stream.next_2d();
                let film_p = Vec2::new(fx as f32, fy as f32) + offset;
                let u_lens = if scene.camera.needs_lens_sample() {
                    stream.next_2d()
                } else {
                    Vec2::ZERO
                };
                values.fill(0.0);
                // A ray the lens stops (cat's eye) counts as black.
                if let Some(ray) = scene.camera.generate_ray(film_p, u_lens) {
                    integrator.sample(scene, &ray, &mut stream, values);
                }
                if values.iter().all(|v| v.is_finite()) {
                    buf.splat(filter, Vec2::new(x as f32, y as f32) + offset, values);
                } else {
                    dropped += 1;
                }
            }
        }
    }
    (buf, dropped)
}
