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
    let mut passes = Progressive::new(scene, integrator, *settings, settings.spp);
    passes.pass(progress);
    passes.output()
}

/// A render in passes over the whole image (for progressive and
/// time-limited renders): pass k takes samples k·n to (k + 1)·n − 1 of
/// every pixel (n = `pass_spp`; the last pass may take fewer), and the
/// image after any pass is the average of the samples so far. It is
/// bit-identical for any thread count: every sample depends only on
/// (pixel, index, dimension, seed), tiles are merged in order, passes in
/// turn. Not for particle tracers ([`Integrator::particle_tracer`]),
/// which render through their own loop.
#[derive(Debug)]
pub struct Progressive<'a> {
    scene: &'a Scene,
    integrator: &'a dyn Integrator,
    settings: RenderSettings,
    pass_spp: u32,
    filter: FilterTable,
    channels: usize,
    /// Per pixel: the weighted sums of each channel, then the weight.
    sums: Vec<f32>,
    /// Samples per pixel taken so far.
    done: u32,
    passes: u32,
    dropped: u64,
}

impl<'a> Progressive<'a> {
    /// A render of `settings.spp` samples per pixel in passes of
    /// `pass_spp` (at least 1).
    pub fn new(
        scene: &'a Scene,
        integrator: &'a dyn Integrator,
        settings: RenderSettings,
        pass_spp: u32,
    ) -> Self {
        let crop = scene.film.crop_size;
        let channels = integrator.channel_count();
        Self {
            scene,
            integrator,
            settings,
            pass_spp: pass_spp.max(1),
            filter: FilterTable::new(&scene.film.filter),
            channels,
            sums: vec![0.0; crop[0] as usize * crop[1] as usize * (channels + 1)],
            done: 0,
            passes: 0,
            dropped: 0,
        }
    }

    /// Samples per pixel taken so far.
    pub fn samples_done(&self) -> u32 {
        self.done
    }

    /// Passes rendered so far.
    pub fn passes_done(&self) -> u32 {
        self.passes
    }

    /// Every sample has been taken.
    pub fn finished(&self) -> bool {
        self.done >= self.settings.spp
    }

    /// Renders the next pass (nothing once finished); `progress` as in
    /// [`render`].
    pub fn pass(&mut self, progress: &(dyn Fn(u64) + Sync)) {
        if self.finished() {
            return;
        }
        let samples = self.done
            ..self
                .done
                .saturating_add(self.pass_spp)
                .min(self.settings.spp);
        let crop = self.scene.film.crop_size;
        let results: Vec<(TileBuffer, u64)> = tiles(crop)
            .par_iter()
            .map(|&tile| {
                let r = render_tile(
                    self.scene,
                    self.integrator,
                    self.settings.seed,
                    &self.filter,
                    tile,
                    self.channels,
                    samples.clone(),
                );
                progress(
                    u64::from(tile.x1 - tile.x0)
                        * u64::from(tile.y1 - tile.y0)
                        * u64::from(samples.end - samples.start),
                );
                r
            })
            .collect();
        for (buf, bad) in &results {
            buf.merge_into(&mut self.sums, crop);
            self.dropped += bad;
        }
        self.done = samples.end;
        self.passes += 1;
    }

    /// The image so far: the average of the samples taken.
    pub fn output(&self) -> RenderOutput {
        let crop = self.scene.film.crop_size;
        let channels = self.channels;
        let data = self
            .sums
            .chunks_exact(channels + 1)
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
            layers: self.integrator.extra_layers(),
            dropped_samples: self.dropped,
        }
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

/// Renders samples `samples` of every pixel of `tile`.
fn render_tile(
    scene: &Scene,
    integrator: &dyn Integrator,
    seed: u32,
    filter: &FilterTable,
    tile: Tile,
    channels: usize,
    samples: std::ops::Range<u32>,
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
            for index in samples.clone() {
                let mut stream = scene.sampler.stream(fx, fy, index, seed);
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
