//! The render loop: the crop window is cut into fixed tiles; rayon renders
//! tiles in parallel, each into its own [`TileBuffer`]. Each tile keeps
//! its own sums over the passes (its pixels and the margin its filter
//! reaches), and the image adds the tiles' sums in tile order. Every
//! sample value depends only on (pixel, sample index, dimension, seed),
//! so the image is bit-identical for any thread count, and for any split
//! of the tiles into [`Part`]s rendered apart and put together again
//! ([`assemble`]): a pixel's value is the same sums added in the same
//! order.
//!
//! A render first builds what its integrator needs of the scene beyond
//! the scene itself, once ([`RenderState`], in `state.rs`: the light
//! sampler, the emitters' sampling distributions, the wide shading's
//! tables); its integrator sees the two together as a [`RenderScene`].

mod state;

pub use state::{LightOptions, RenderScene, RenderState};

use crate::camera::Perspective;
use crate::film::{Framebuffer, Tile, TileBuffer};
use crate::filter::FilterTable;
use crate::integrator::{Integrator, Layer};
use crate::math::Ray;
use crate::sampler::SampleStream;
use crate::{Rgb, Scene};
use glam::Vec2;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

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

/// Renders `scene` with `integrator` (building the render's
/// [`RenderState`] first). `progress` is called after each tile
/// with the number of samples it took (from several threads at once).
/// Samples that come out non-finite are dropped and counted.
pub fn render(
    scene: &Scene,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> RenderOutput {
    render_until(
        scene,
        integrator,
        settings,
        progress,
        &AtomicBool::new(false),
    )
}

/// [`render`], stopped early once `stop` is set (a signal, a user's
/// cancel): the image is then the average of the samples of the passes
/// finished before ([`RenderOutput::samples`] says how many; the pass
/// in flight is dropped, so every pixel has the same count). The render
/// runs in passes of growing size (1, 2, 4, … samples per pixel, at most
/// a sixteenth of the whole or 8, whichever is more), so that an early
/// stop keeps an image and a late one loses little of the work; the
/// passes cost 0.6–0.8 % more instructions than one pass at 64 spp
/// (cachegrind, `scenes/suite` rough and mesh).
pub fn render_until(
    scene: &Scene,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64) + Sync),
    stop: &AtomicBool,
) -> RenderOutput {
    if let Some(tracer) = integrator.particle_tracer() {
        return tracer.render(scene, settings, progress, stop);
    }
    let mut passes = Progressive::new(scene, integrator, *settings, 1)
        .with_passes(PassSize::growing(settings.spp));
    while !passes.finished() && passes.pass_unless(progress, stop) {}
    passes.output()
}

/// How many samples per pixel each pass of a [`Progressive`] render takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PassSize {
    /// The same number every pass (the last may take fewer).
    Fixed(u32),
    /// 1, 2, 4, … up to `largest`, then `largest` (the last may take
    /// fewer).
    Growing {
        /// The samples per pixel of the largest pass.
        largest: u32,
    },
}

impl PassSize {
    /// The passes of a plain render of `spp` samples per pixel ([`render`]):
    /// 1, 2, 4, … up to a sixteenth of the whole or 8, whichever is more.
    pub fn growing(spp: u32) -> Self {
        PassSize::Growing {
            largest: (spp / 16).max(8),
        }
    }

    /// The pass (from 0) that takes sample `index` of each pixel.
    pub fn pass_of_sample(self, index: u32) -> u32 {
        if let PassSize::Fixed(n) = self {
            return index / n.max(1);
        }
        let (mut pass, mut end) = (0, 0u64);
        loop {
            end += u64::from(self.of(pass));
            if u64::from(index) < end {
                return pass;
            }
            pass += 1;
        }
    }

    /// The samples per pixel of pass `pass` (from 0).
    fn of(self, pass: u32) -> u32 {
        match self {
            PassSize::Fixed(n) => n,
            PassSize::Growing { largest } => {
                1u32.checked_shl(pass).unwrap_or(u32::MAX).min(largest)
            }
        }
    }
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
    /// What the integrator needs of the scene, built once for the render.
    render_state: RenderState,
    integrator: &'a dyn Integrator,
    settings: RenderSettings,
    pass_spp: PassSize,
    filter: FilterTable,
    channels: usize,
    /// The tiles this render takes, in tile order (all of them, or one
    /// part's), with their place in the order of all tiles.
    tiles: Vec<(usize, Tile)>,
    /// Per tile of `tiles`: the filter-weighted sums of its samples over
    /// the passes so far.
    accum: Vec<TileBuffer>,
    /// Samples per pixel taken so far (by the pixels still sampling).
    done: u32,
    passes: u32,
    dropped: u64,
    /// The first [`NONFINITE_KEPT`] non-finite samples, in tile order.
    nonfinite: Vec<NonFiniteSample>,
    /// Per pixel of the crop window, its non-finite samples (empty until
    /// one).
    nonfinite_counts: Vec<u32>,
    /// Adaptive sampling, when asked for.
    adaptive: Option<Adaptive>,
    /// Per pixel: the luminance sums of its even and odd samples.
    halves: Vec<Halves>,
    /// Per pixel: still sampling.
    active: Vec<bool>,
}

/// A [`Progressive`] render's accumulated state (what a checkpoint holds).
#[derive(Clone, Debug, PartialEq)]
pub struct PassState {
    /// Per tile rendered, in tile order, what [`TileBuffer::data`] holds:
    /// per pixel of the tile and its margin, weighted channel sums, then
    /// the weight.
    pub sums: Vec<f32>,
    /// Adaptive sampling: per pixel, the luminance sums of even and odd
    /// samples (empty without).
    pub halves: Vec<f32>,
    /// Adaptive sampling: per pixel, the counts of even and odd samples.
    pub counts: Vec<u32>,
    /// Adaptive sampling: per pixel, still sampling.
    pub active: Vec<bool>,
    /// Samples per pixel taken.
    pub done: u32,
    /// Passes rendered.
    pub passes: u32,
    /// Non-finite samples dropped.
    pub dropped: u64,
}

/// Adaptive sampling: a pixel stops once the relative error of its mean,
/// estimated from two interleaved half-buffers (even and odd samples, as
/// Cycles does), is below `threshold` in its whole 3 × 3 neighbourhood,
/// after at least `min_spp` samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adaptive {
    /// Relative error of a pixel's mean at which it stops.
    pub threshold: f32,
    /// Samples a pixel takes before it may stop.
    pub min_spp: u32,
}

/// A pixel's own samples' luminance, split by the parity of their index.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Halves {
    sum: [f32; 2],
    count: [u32; 2],
}

impl Halves {
    fn add(&mut self, index: u32, luminance: f32) {
        let half = (index & 1) as usize;
        self.sum[half] += luminance;
        self.count[half] += 1;
    }

    fn merge(&mut self, o: &Halves) {
        for h in 0..2 {
            self.sum[h] += o.sum[h];
            self.count[h] += o.count[h];
        }
    }

    fn samples(&self) -> u32 {
        self.count[0] + self.count[1]
    }

    /// The estimated relative error of the pixel's mean: the standard
    /// error |A − B| / 2 of two half-means over the mean (with a floor of
    /// 0.01 for dark pixels); infinite before both halves have samples.
    fn relative_error(&self) -> f32 {
        if self.count[0] == 0 || self.count[1] == 0 {
            return f32::INFINITY;
        }
        let a = self.sum[0] / self.count[0] as f32;
        let b = self.sum[1] / self.count[1] as f32;
        let mean = (self.sum[0] + self.sum[1]) / self.samples() as f32;
        (a - b).abs() / (2.0 * (mean.abs() + 0.01))
    }
}

impl<'a> Progressive<'a> {
    /// A render of `settings.spp` samples per pixel in passes of
    /// `pass_spp` (at least 1); builds the render's [`RenderState`].
    pub fn new(
        scene: &'a Scene,
        integrator: &'a dyn Integrator,
        settings: RenderSettings,
        pass_spp: u32,
    ) -> Self {
        let crop = scene.film.crop_size;
        let channels = integrator.channel_count();
        let filter = FilterTable::new(&scene.film.filter);
        let tiles: Vec<(usize, Tile)> = tiles(crop).into_iter().enumerate().collect();
        let accum = tiles
            .iter()
            .map(|&(_, tile)| TileBuffer::new(tile, &filter, channels))
            .collect();
        Self {
            scene,
            render_state: RenderState::new(scene, integrator),
            integrator,
            settings,
            pass_spp: PassSize::Fixed(pass_spp.max(1)),
            filter,
            channels,
            tiles,
            accum,
            done: 0,
            passes: 0,
            dropped: 0,
            nonfinite: Vec::new(),
            nonfinite_counts: Vec::new(),
            adaptive: None,
            halves: vec![Halves::default(); crop[0] as usize * crop[1] as usize],
            active: Vec::new(),
        }
    }

    /// The same render with adaptive sampling: `settings.spp` becomes the
    /// most a pixel takes. Not with a [`Part`]: a pixel stops by its
    /// neighbours, which another part may render.
    pub fn with_adaptive(mut self, adaptive: Adaptive) -> Self {
        self.adaptive = Some(adaptive);
        self.active = vec![true; self.halves.len()];
        self
    }

    /// The same render in passes of `size` (before the first pass).
    pub fn with_passes(mut self, size: PassSize) -> Self {
        self.pass_spp = size;
        self
    }

    /// Only `part` of the render: its tiles (before the first pass;
    /// [`Progressive::part_sums`] then gives what [`assemble`] needs of
    /// it). Refused for an adaptive render and for a part with no tiles.
    pub fn with_part(mut self, part: Part) -> Result<Self, String> {
        if self.adaptive.is_some() {
            return Err("adaptive sampling cannot be split into parts (a pixel stops by its neighbours, which another part renders)".into());
        }
        let count = self.tiles.len();
        if part.count == 0 || part.index >= part.count {
            return Err(format!(
                "part {}/{}: parts are numbered 0 to N − 1 of N ≥ 1",
                part.index, part.count
            ));
        }
        if part.count as usize > count {
            return Err(format!(
                "{} parts: the image has only {count} tiles of {TILE_SIZE}×{TILE_SIZE} pixels, so at most {count} parts",
                part.count
            ));
        }
        let keep = |&(i, _): &(usize, Tile)| part.has_tile(i);
        let accum = std::mem::take(&mut self.accum);
        self.accum = self
            .tiles
            .iter()
            .zip(accum)
            .filter(|(t, _)| keep(t))
            .map(|(_, a)| a)
            .collect();
        self.tiles.retain(keep);
        Ok(self)
    }

    /// The margin of the tiles' sums (pixels on each side).
    pub fn margin(&self) -> u32 {
        TileBuffer::margin(&self.filter)
    }

    /// The sums of each tile rendered, in tile order, with its place in
    /// the order of all tiles (what [`assemble`] puts together).
    pub fn part_sums(&self) -> impl Iterator<Item = (usize, &[f32])> {
        self.tiles
            .iter()
            .zip(&self.accum)
            .map(|(&(i, _), a)| (i, a.data()))
    }

    /// The average relative error of this render's pixels as
    /// [`Progressive::estimated_error`] takes it, as its sum and the
    /// number of pixels it is over (parts add up).
    pub fn error_sum(&self) -> (f64, u64) {
        let width = self.scene.film.crop_size[0] as usize;
        let mut sum = 0.0;
        let mut count = 0;
        for &(_, tile) in &self.tiles {
            for y in tile.y0..tile.y1 {
                let row = y as usize * width;
                for h in &self.halves[row + tile.x0 as usize..row + tile.x1 as usize] {
                    let e = h.relative_error();
                    if e.is_finite() {
                        sum += f64::from(e);
                        count += 1;
                    }
                }
            }
        }
        (sum, count)
    }

    /// Everything the render has accumulated, to continue it later
    /// ([`Progressive::restore`]) exactly where it stopped.
    pub fn state(&self) -> PassState {
        PassState {
            sums: self.accum.iter().flat_map(|a| a.data()).copied().collect(),
            halves: self
                .halves
                .iter()
                .flat_map(|h| [h.sum[0], h.sum[1]])
                .collect(),
            counts: self.halves.iter().flat_map(|h| h.count).collect(),
            active: self.active.clone(),
            done: self.done,
            passes: self.passes,
            dropped: self.dropped,
        }
    }

    /// Continues from `state` (of a render of this scene with these
    /// settings); refuses a state whose sizes do not fit.
    pub fn restore(&mut self, state: PassState) -> Result<(), String> {
        let pixels = self.halves.len();
        let needed: usize = self.accum.iter().map(|a| a.data().len()).sum();
        let fits = state.sums.len() == needed
            && state.halves.len() == 2 * pixels
            && state.counts.len() == 2 * pixels
            && state.active.len() == self.active.len();
        if !fits {
            return Err(format!(
                "it holds {} values for an image that needs {needed}",
                state.sums.len(),
            ));
        }
        let mut sums = state.sums.into_iter();
        let margin = self.margin();
        for (a, &(_, tile)) in self.accum.iter_mut().zip(&self.tiles) {
            let data = sums.by_ref().take(a.data().len()).collect();
            *a = TileBuffer::from_data(tile, margin, self.channels, data)
                .expect("lengths checked above");
        }
        self.halves = state
            .halves
            .chunks_exact(2)
            .zip(state.counts.chunks_exact(2))
            .map(|(s, c)| Halves {
                sum: [s[0], s[1]],
                count: [c[0], c[1]],
            })
            .collect();
        self.active = state.active;
        self.done = state.done;
        self.passes = state.passes;
        self.dropped = state.dropped;
        Ok(())
    }

    /// The estimated relative error of the image so far: the mean over
    /// pixels of each one's half-buffer estimate (|A − B| / 2 over the
    /// mean, see [`Adaptive`]); `None` until the pixels have samples in
    /// both halves.
    pub fn estimated_error(&self) -> Option<f32> {
        let errors: Vec<f32> = self
            .halves
            .iter()
            .map(Halves::relative_error)
            .filter(|e| e.is_finite())
            .collect();
        (!errors.is_empty()).then(|| errors.iter().sum::<f32>() / errors.len() as f32)
    }

    /// Samples taken over the whole image.
    pub fn total_samples(&self) -> u64 {
        if self.adaptive.is_some() {
            self.halves.iter().map(|h| u64::from(h.samples())).sum()
        } else {
            let pixels: u64 = self
                .tiles
                .iter()
                .map(|(_, t)| (t.width() * t.height()) as u64)
                .sum();
            pixels * u64::from(self.done)
        }
    }

    /// After a pass: pixels whose whole neighbourhood has converged stop.
    fn update_active(&mut self) {
        let Some(adaptive) = self.adaptive else {
            return;
        };
        let [w, h] = self.scene.film.crop_size.map(|v| v as usize);
        let error: Vec<f32> = self
            .halves
            .iter()
            .map(|p| {
                if p.samples() < adaptive.min_spp {
                    f32::INFINITY
                } else {
                    p.relative_error()
                }
            })
            .collect();
        for y in 0..h {
            for x in 0..w {
                let worst = (y.saturating_sub(1)..(y + 2).min(h))
                    .flat_map(|ny| (x.saturating_sub(1)..(x + 2).min(w)).map(move |nx| ny * w + nx))
                    .map(|i| error[i])
                    .fold(0.0f32, f32::max);
                if worst < adaptive.threshold {
                    self.active[y * w + x] = false;
                }
            }
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

    /// Every sample has been taken (or, adaptively, every pixel stopped).
    pub fn finished(&self) -> bool {
        self.done >= self.settings.spp
            || (self.adaptive.is_some() && !self.active.iter().any(|&a| a))
    }

    /// Renders the next pass (nothing once finished); `progress` as in
    /// [`render`].
    pub fn pass(&mut self, progress: &(dyn Fn(u64) + Sync)) {
        self.pass_unless(progress, &AtomicBool::new(false));
    }

    /// [`Progressive::pass`], given up once `stop` is set: the tiles not
    /// yet begun are skipped and the pass's samples dropped, so the image
    /// stays the average of whole passes. False when it was given up.
    pub fn pass_unless(&mut self, progress: &(dyn Fn(u64) + Sync), stop: &AtomicBool) -> bool {
        if self.finished() {
            return true;
        }
        let samples = self.done
            ..self
                .done
                .saturating_add(self.pass_spp.of(self.passes))
                .min(self.settings.spp);
        let crop = self.scene.film.crop_size;
        let active = (!self.active.is_empty()).then_some(self.active.as_slice());
        let scene = RenderScene::new(self.scene, &self.render_state);
        let timed = scene.samples_times();
        // One job per tile: rayon's default splitting hands each thread
        // runs of tiles it cannot give away once started, which can leave
        // a thread idle at the end of a render while another finishes its
        // run.
        let results: Option<Vec<TileResult>> = self
            .tiles
            .par_iter()
            .with_max_len(1)
            .map(|&(_, tile)| {
                if stop.load(Ordering::Relaxed) {
                    return None;
                }
                let job = TileJob {
                    scene,
                    integrator: self.integrator,
                    seed: self.settings.seed,
                    filter: &self.filter,
                    channels: self.channels,
                    samples: samples.clone(),
                    active,
                    timed,
                };
                let r = job.render(tile);
                progress(
                    u64::from(tile.x1 - tile.x0)
                        * u64::from(tile.y1 - tile.y0)
                        * u64::from(samples.end - samples.start),
                );
                Some(r)
            })
            .collect();
        let Some(results) = results else {
            return false;
        };
        self.accum
            .par_iter_mut()
            .zip(&results)
            .for_each(|(a, r)| a.add(&r.buffer));
        for r in &results {
            self.dropped += r.dropped;
            self.count_nonfinite(r);
            for (y, row) in (r.tile.y0..r.tile.y1).zip(r.halves.chunks(r.tile.width())) {
                let start = y as usize * crop[0] as usize + r.tile.x0 as usize;
                for (h, add) in self.halves[start..start + row.len()].iter_mut().zip(row) {
                    h.merge(add);
                }
            }
        }
        self.done = samples.end;
        self.passes += 1;
        self.update_active();
        true
    }

    /// Adds the non-finite samples of tile result `r`.
    fn count_nonfinite(&mut self, r: &TileResult) {
        if r.dropped == 0 {
            return;
        }
        let room = NONFINITE_KEPT - self.nonfinite.len().min(NONFINITE_KEPT);
        self.nonfinite.extend(r.nonfinite.iter().take(room));
        let width = self.scene.film.crop_size[0] as usize;
        if self.nonfinite_counts.is_empty() {
            self.nonfinite_counts = vec![0; self.halves.len()];
        }
        for (y, row) in (r.tile.y0..r.tile.y1).zip(r.nonfinite_counts.chunks(r.tile.width())) {
            let start = y as usize * width + r.tile.x0 as usize;
            for (count, add) in self.nonfinite_counts[start..start + row.len()]
                .iter_mut()
                .zip(row)
            {
                *count += add;
            }
        }
    }

    /// The image so far: the average of the samples taken (of a part's
    /// tiles only, for a [`Part`]).
    pub fn output(&self) -> RenderOutput {
        let crop = self.scene.film.crop_size;
        let channels = self.channels;
        let mut sums = vec![0.0; crop[0] as usize * crop[1] as usize * (channels + 1)];
        for a in &self.accum {
            a.merge_into(&mut sums, crop);
        }
        let data = average(&sums, channels);
        let mut layers = self.integrator.extra_layers();
        let (data, channels) = if self.adaptive.is_some() {
            // Where the samples went: a `spp` layer.
            layers.push(Layer::new("spp", &["Y"]));
            let with_counts = data
                .chunks_exact(channels)
                .zip(&self.halves)
                .flat_map(|(px, h)| px.iter().copied().chain([h.samples() as f32]))
                .collect();
            (with_counts, channels + 1)
        } else {
            (data, channels)
        };
        RenderOutput {
            image: Framebuffer {
                width: crop[0],
                height: crop[1],
                channels,
                data,
            },
            layers,
            dropped_samples: self.dropped,
            nonfinite: NonFinite {
                pixels: self.nonfinite_counts.iter().filter(|&&c| c > 0).count() as u64,
                first: self.nonfinite.clone(),
            },
            estimated_error: self.estimated_error(),
            samples: self.total_samples(),
        }
    }
}

/// The image of weighted sums `sums` (`channels` sums and a weight per
/// pixel): each pixel's average. Finite samples can still sum past f32's
/// range (or to ∞ − ∞ under a filter's negative lobes): the image holds no
/// NaN or infinity, whatever the sums.
pub fn average(sums: &[f32], channels: usize) -> Vec<f32> {
    sums.chunks_exact(channels + 1)
        .flat_map(|px| {
            let w = px[channels];
            let inv = if w > 0.0 { 1.0 / w } else { 0.0 };
            px[..channels]
                .iter()
                .map(move |v| Some(v * inv).filter(|v| v.is_finite()).unwrap_or(0.0))
        })
        .collect()
}

/// One of `count` parts of a render ([`Progressive::with_part`]): the
/// tiles whose place in tile order is `index` modulo `count`. Tiles dealt
/// out in turn share the image's hard and easy regions among the parts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Part {
    /// Which part, from 0.
    pub index: u32,
    /// How many parts.
    pub count: u32,
}

impl Part {
    /// Whether tile number `tile` (in tile order) is this part's.
    pub fn has_tile(self, tile: usize) -> bool {
        tile % self.count as usize == self.index as usize
    }
}

/// The tiles of a render of a `crop`-sized image, in the order the render
/// adds them up.
pub fn tiles(crop: [u32; 2]) -> Vec<Tile> {
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

/// The weighted sums of a `crop`-sized image from the sums of every tile
/// (in tile order, as [`Progressive::part_sums`] gives them, each with
/// `margin` pixels around it and `channels` sums and a weight per pixel),
/// added as a render of the whole image adds them: [`average`] of it is
/// that render's image, bit for bit. Refuses a tile whose length does not
/// fit, naming it.
pub fn assemble<'a>(
    crop: [u32; 2],
    margin: u32,
    channels: usize,
    tile_sums: impl IntoIterator<Item = &'a [f32]>,
) -> Result<Vec<f32>, String> {
    let all = tiles(crop);
    let mut sums = vec![0.0; crop[0] as usize * crop[1] as usize * (channels + 1)];
    let mut given = 0;
    for (i, data) in tile_sums.into_iter().enumerate() {
        let Some(&tile) = all.get(i) else {
            return Err(format!("more tiles than the {} of the image", all.len()));
        };
        let expected = TileBuffer::data_len(tile, margin, channels);
        if data.len() != expected {
            return Err(format!(
                "tile {i} holds {} values, not {expected}",
                data.len()
            ));
        }
        TileBuffer::merge_data_into((tile, margin, channels), data, &mut sums, crop);
        given += 1;
    }
    if given != all.len() {
        return Err(format!("{given} tiles of the image's {}", all.len()));
    }
    Ok(sums)
}

/// At most this many non-finite samples are kept by place.
pub const NONFINITE_KEPT: usize = 100;

/// A sample that came out NaN or infinite: its pixel (in full-image
/// coordinates) and index, which `--crop x,y,1,1 --spp index+1` renders
/// again (every sample depends only on pixel, index and seed).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NonFiniteSample {
    /// Pixel column.
    pub x: u32,
    /// Pixel row.
    pub y: u32,
    /// Sample index within the pixel.
    pub index: u32,
}

/// Where a render's non-finite samples came from.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct NonFinite {
    /// Pixels with at least one (none for a particle tracer, whose
    /// samples are light paths).
    pub pixels: u64,
    /// The first [`NONFINITE_KEPT`] of them, in the order tiles are
    /// merged (the same on any thread count).
    pub first: Vec<NonFiniteSample>,
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
    /// Where they came from.
    pub nonfinite: NonFinite,
    /// Samples taken over the whole image (light paths traced, for a
    /// particle tracer): fewer than asked when the render was stopped.
    pub samples: u64,
    /// The estimated relative error of the image
    /// ([`Progressive::estimated_error`]), when known.
    pub estimated_error: Option<f32>,
}

/// What a pass asks of each tile.
struct TileJob<'a> {
    scene: RenderScene<'a>,
    integrator: &'a dyn Integrator,
    seed: u32,
    filter: &'a FilterTable,
    channels: usize,
    /// The sample indices each pixel takes.
    samples: std::ops::Range<u32>,
    /// Per pixel of the crop window, whether it still samples (adaptive
    /// sampling; all do without).
    active: Option<&'a [bool]>,
    /// Each camera sample is taken at a time of its own
    /// ([`RenderScene::samples_times`]).
    timed: bool,
}

/// A rendered tile: its buffer, its non-finite samples, and per pixel
/// (row by row) its samples' luminance halves.
struct TileResult {
    tile: Tile,
    buffer: TileBuffer,
    dropped: u64,
    nonfinite: Vec<NonFiniteSample>,
    /// Per pixel (row by row), its non-finite samples (empty without).
    nonfinite_counts: Vec<u32>,
    halves: Vec<Halves>,
}

impl TileJob<'_> {
    /// Renders the job's samples of every active pixel of `tile`, in
    /// batches of [`BATCH`] camera rays (see
    /// [`Integrator::sample_packet`]), splatted in the order they were
    /// taken.
    fn render(&self, tile: Tile) -> TileResult {
        let scene = self.scene;
        let film = &scene.film;
        let mut out = TileOutput {
            buffer: TileBuffer::new(tile, self.filter, self.channels),
            // One buffer per tile (not per sample), sized to the integrator.
            values: vec![0.0f32; self.channels * BATCH],
            bad: TileNonFinite::default(),
            halves: vec![Halves::default(); tile.width() * tile.height()],
            tile,
        };
        let mut batch = Batch::with_capacity();
        // A pinhole camera's rays are made eight at a time, when the batch
        // is traced.
        let pinhole = scene.camera.pinhole();
        for y in tile.y0..tile.y1 {
            for x in tile.x0..tile.x1 {
                let pixel = y as usize * film.crop_size[0] as usize + x as usize;
                if self.active.is_some_and(|a| !a[pixel]) {
                    continue;
                }
                let (fx, fy) = self.full_image_pixel(x, y);
                let streams = scene.sampler.pixel(fx, fy, self.seed);
                let mut first = self.samples.start;
                while first < self.samples.end {
                    let n = ((self.samples.end - first) as usize).min(8);
                    let drawn = streams.first_pairs(first, n);
                    for (j, (&stream, &offset)) in
                        drawn.streams[..n].iter().zip(&drawn.pairs).enumerate()
                    {
                        let index = first + j as u32;
                        let with_ray = pinhole.is_none();
                        batch.push(self.camera_sample(x, y, index, (stream, offset), with_ray));
                        if batch.rays.len() == BATCH {
                            self.trace(&mut batch, &mut out, pinhole);
                        }
                    }
                    first += n as u32;
                }
            }
        }
        self.trace(&mut batch, &mut out, pinhole);
        TileResult {
            tile,
            buffer: out.buffer,
            dropped: out.bad.dropped,
            nonfinite: out.bad.first,
            nonfinite_counts: out.bad.counts,
            halves: out.halves,
        }
    }

    /// Counts the non-finite sample at `spot` (dropped from the image).
    #[inline(never)]
    fn count_nonfinite(
        &self,
        bad: &mut TileNonFinite,
        tile: Tile,
        (x, y, index, _): (u32, u32, u32, Vec2),
    ) {
        bad.dropped += 1;
        if bad.counts.is_empty() {
            bad.counts = vec![0; tile.width() * tile.height()];
        }
        bad.counts[(y - tile.y0) as usize * tile.width() + (x - tile.x0) as usize] += 1;
        if bad.first.len() < NONFINITE_KEPT {
            let (x, y) = self.full_image_pixel(x, y);
            bad.first.push(NonFiniteSample { x, y, index });
        }
    }

    /// Pixel (`x`, `y`) of the crop window in full-image coordinates.
    fn full_image_pixel(&self, x: u32, y: u32) -> (u32, u32) {
        let film = &self.scene.film;
        (x + film.crop_offset[0], y + film.crop_offset[1])
    }

    /// Sample `index` of pixel (`x`, `y`) of the crop window, from its
    /// stream past its film offset and that offset (the stream's first
    /// pair): with its camera ray when `with_ray` (none when the lens
    /// stops it, a cat's eye: black; a pinhole's are made by
    /// [`TileJob::pinhole_rays`]).
    fn camera_sample(
        &self,
        x: u32,
        y: u32,
        index: u32,
        (mut stream, offset): (SampleStream, Vec2),
        with_ray: bool,
    ) -> CameraSample {
        let scene = self.scene;
        let ray = with_ray.then(|| {
            let (fx, fy) = self.full_image_pixel(x, y);
            let film_p = Vec2::new(fx as f32, fy as f32) + offset;
            let u_lens = if scene.camera.needs_lens_sample() {
                stream.next_2d()
            } else {
                Vec2::ZERO
            };
            scene.camera.generate_ray_in(&scene.meshes, film_p, u_lens)
        });
        let time = if self.timed {
            scene.shutter.time(stream.next_1d())
        } else {
            scene.time()
        };
        CameraSample {
            x,
            y,
            index,
            offset,
            ray: ray.flatten(),
            stream,
            time,
        }
    }

    /// The camera rays of the samples in `batch`, eight at a time (the
    /// same rays as [`TileJob::camera_sample`]'s).
    fn pinhole_rays(&self, camera: &Perspective, batch: &mut Batch) {
        for (rays, spots) in batch.rays.chunks_mut(8).zip(batch.spots.chunks(8)) {
            let (mut xs, mut ys) = ([0.0f32; 8], [0.0f32; 8]);
            for ((px, py), &(x, y, _, offset)) in xs.iter_mut().zip(&mut ys).zip(spots) {
                let (fx, fy) = self.full_image_pixel(x, y);
                (*px, *py) = (fx as f32 + offset.x, fy as f32 + offset.y);
            }
            let (xs, ys) = (wide::f32x8::new(xs), wide::f32x8::new(ys));
            for (ray, made) in rays.iter_mut().zip(camera.generate_pinhole_rays(xs, ys)) {
                *ray = Some(made);
            }
        }
    }

    /// Traces each sample of `batch` alone, in the scene at its time.
    fn trace_at_their_times(&self, batch: &mut Batch, values: &mut [f32]) {
        let samples = (batch.rays.iter())
            .zip(batch.streams.iter_mut())
            .zip(&batch.times)
            .zip(values.chunks_exact_mut(self.channels));
        for (((ray, stream), &time), values) in samples {
            let scene = self.scene.at_time(time);
            self.integrator.sample_packet(
                &scene,
                std::slice::from_ref(ray),
                std::slice::from_mut(stream),
                values,
            );
        }
    }

    /// Traces the samples waiting in `batch` and splats them in order;
    /// a `pinhole` camera's rays are still to be made.
    fn trace(&self, batch: &mut Batch, out: &mut TileOutput, pinhole: Option<&Perspective>) {
        if let Some(camera) = pinhole {
            self.pinhole_rays(camera, batch);
        }
        let n = batch.rays.len();
        let values = &mut out.values[..n * self.channels];
        if self.timed {
            self.trace_at_their_times(batch, values);
        } else {
            self.integrator
                .sample_packet(&self.scene, &batch.rays, &mut batch.streams, values);
        }
        let weight = self.scene.camera.sample_weight();
        if weight != 1.0 {
            values.iter_mut().for_each(|v| *v *= weight);
        }
        // RGB samples' footprints are weighed eight at a time.
        let by_eight = self.channels == 3 && !self.filter.is_box();
        for (spots, values) in batch.spots.chunks(8).zip(values.chunks(8 * self.channels)) {
            let film_pos =
                |&(x, y, _, offset): &(u32, u32, u32, Vec2)| Vec2::new(x as f32, y as f32) + offset;
            let footprints = by_eight.then(|| {
                let pos: arrayvec::ArrayVec<Vec2, 8> = spots.iter().map(film_pos).collect();
                out.buffer.footprints(self.filter, &pos)
            });
            for (j, (spot, values)) in spots
                .iter()
                .zip(values.chunks_exact(self.channels))
                .enumerate()
            {
                if !values.iter().all(|v| v.is_finite()) {
                    self.count_nonfinite(&mut out.bad, out.tile, *spot);
                    continue;
                }
                match &footprints {
                    Some(fp) if fp.fast >> j & 1 != 0 => {
                        out.buffer
                            .splat_footprint(fp, j, [values[0], values[1], values[2]]);
                    }
                    _ => out.buffer.splat(self.filter, film_pos(spot), values),
                }
                let (x, y, index, _) = *spot;
                let tile = out.tile;
                let i = (y - tile.y0) as usize * tile.width() + (x - tile.x0) as usize;
                let lum = crate::spectrum::luminance(Rgb::from_slice(&values[..3]));
                out.halves[i].add(index, lum);
            }
        }
        batch.clear();
    }
}

/// A camera sample before it is traced.
struct CameraSample {
    x: u32,
    y: u32,
    index: u32,
    offset: Vec2,
    ray: Option<Ray>,
    stream: SampleStream,
    /// When it is taken (the shutter's opening unless the render
    /// [`RenderScene::samples_times`]).
    time: f32,
}

/// Camera samples traced together: enough that a packet of
/// [`crate::accel::PACKET_RAYS`] paths, each lane taking the next sample
/// as its path ends, is seldom short of paths.
const BATCH: usize = 256;

/// Camera samples waiting to be traced together.
struct Batch {
    rays: Vec<Option<Ray>>,
    streams: Vec<SampleStream>,
    /// Pixel, sample index and film offset of each.
    spots: Vec<(u32, u32, u32, Vec2)>,
    /// Time of each.
    times: Vec<f32>,
}

impl Batch {
    fn with_capacity() -> Self {
        Self {
            rays: Vec::with_capacity(BATCH),
            streams: Vec::with_capacity(BATCH),
            spots: Vec::with_capacity(BATCH),
            times: Vec::with_capacity(BATCH),
        }
    }

    fn push(&mut self, s: CameraSample) {
        self.rays.push(s.ray);
        self.streams.push(s.stream);
        self.spots.push((s.x, s.y, s.index, s.offset));
        self.times.push(s.time);
    }

    fn clear(&mut self) {
        self.rays.clear();
        self.streams.clear();
        self.spots.clear();
        self.times.clear();
    }
}

/// What a tile's samples have added up to.
struct TileOutput {
    tile: Tile,
    buffer: TileBuffer,
    /// Room for one batch's values.
    values: Vec<f32>,
    /// Its non-finite samples.
    bad: TileNonFinite,
    halves: Vec<Halves>,
}

/// A tile's non-finite samples.
#[derive(Default)]
struct TileNonFinite {
    dropped: u64,
    /// The first [`NONFINITE_KEPT`] of them.
    first: Vec<NonFiniteSample>,
    /// Per pixel (row by row), their count (empty until one).
    counts: Vec<u32>,
}
