//! The film: image size, crop window and reconstruction filter, and the
//! per-tile accumulation buffers the renderer merges. Film plugins:
//! `hdrfilm` (`hdrfilm.rs`).
//!
//! Tiles never share memory: each accumulates Σ w·value and Σ w into its
//! own buffer, padded by the filter radius, and the renderer adds the
//! buffers into the image in tile order, so the result is the same
//! whatever the thread count.

mod hdrfilm;

use crate::filter::Filter;
use crate::params::{plugin_of, ParamError, Params};
use glam::Vec2;

/// Builds a film plugin from its parameters.
pub type FilmFromParams = fn(&mut dyn Params) -> Result<Film, ParamError>;

/// Every film plugin: its scene type string and constructor.
pub const PLUGINS: &[(&str, FilmFromParams)] = &[("hdrfilm", hdrfilm::from_params)];

/// Film geometry and filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Film {
    /// Full image width.
    pub width: u32,
    /// Full image height.
    pub height: u32,
    /// Crop window origin (pixels).
    pub crop_offset: [u32; 2],
    /// Crop window size (pixels); the output image has this size.
    pub crop_size: [u32; 2],
    /// Reconstruction filter.
    pub filter: Filter,
}

impl Default for Film {
    /// Mitsuba's default film: 768×576, Gaussian filter.
    fn default() -> Self {
        Film::new(768, 576, Filter::default())
    }
}

impl Film {
    /// Builds the film `p` describes, by its plugin type.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        plugin_of(p, "film", PLUGINS, None)?(p)
    }

    /// A film without cropping.
    pub fn new(width: u32, height: u32, filter: Filter) -> Self {
        Self {
            width,
            height,
            crop_offset: [0, 0],
            crop_size: [width, height],
            filter,
        }
    }
}

/// A rectangle of pixels `[x0, x1) × [y0, y1)` in crop-window coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tile {
    /// Left.
    pub x0: u32,
    /// Top.
    pub y0: u32,
    /// Right (exclusive).
    pub x1: u32,
    /// Bottom (exclusive).
    pub y1: u32,
}

/// Filter-weighted accumulation for one tile, with a margin wide enough
/// for every pixel a sample in the tile can reach.
#[derive(Clone, Debug)]
pub struct TileBuffer {
    origin: [i64; 2],
    size: [usize; 2],
    channels: usize,
    /// `channels` weighted sums then the weight sum, per pixel.
    data: Vec<f32>,
}

impl TileBuffer {
    /// An empty buffer for `tile` with `channels` values per sample.
    pub fn new(tile: Tile, filter: &Filter, channels: usize) -> Self {
        let margin = (filter.radius() + 0.5).ceil() as i64;
        let origin = [tile.x0 as i64 - margin, tile.y0 as i64 - margin];
        let size = [
            (tile.x1 - tile.x0) as usize + 2 * margin as usize,
            (tile.y1 - tile.y0) as usize + 2 * margin as usize,
        ];
        Self {
            origin,
            size,
            channels,
            data: vec![0.0; size[0] * size[1] * (channels + 1)],
        }
    }

    /// Adds a sample at crop-window position `pos` (pixels, continuous).
    #[inline]
    pub fn splat(&mut self, filter: &Filter, pos: Vec2, values: &[f32]) {
        let stride = self.channels + 1;
        if let Filter::Box = filter {
            let (x, y) = (
                pos.x.floor() as i64 - self.origin[0],
                pos.y.floor() as i64 - self.origin[1],
            );
            if let Some(i) = self.index(x, y) {
                let px = &mut self.data[i * stride..(i + 1) * stride];
                for (acc, v) in px.iter_mut().zip(values) {
                    *acc += v;
                }
                px[self.channels] += 1.0;
            }
            return;
        }
        let r = filter.radius();
        let (lo_x, hi_x) = (
            (pos.x - r - 0.5).ceil() as i64,
            (pos.x + r - 0.5).floor() as i64,
        );
        let (lo_y, hi_y) = (
            (pos.y - r - 0.5).ceil() as i64,
            (pos.y + r - 0.5).floor() as i64,
        );
        for py in lo_y..=hi_y {
            let wy = filter.eval_1d(py as f32 + 0.5 - pos.y);
            if wy == 0.0 {
                continue;
            }
            for px in lo_x..=hi_x {
                let w = wy * filter.eval_1d(px as f32 + 0.5 - pos.x);
                if w == 0.0 {
                    continue;
                }
                if let Some(i) = self.index(px - self.origin[0], py - self.origin[1]) {
                    let cell = &mut self.data[i * stride..(i + 1) * stride];
                    for (acc, v) in cell.iter_mut().zip(values) {
                        *acc += w * v;
                    }
                    cell[self.channels] += w;
                }
            }
        }
    }

    #[inline]
    fn index(&self, x: i64, y: i64) -> Option<usize> {
        (x >= 0 && y >= 0 && (x as usize) < self.size[0] && (y as usize) < self.size[1])
            .then(|| y as usize * self.size[0] + x as usize)
    }

    /// Adds this buffer into `sums` (crop-sized, `channels + 1` per pixel).
    pub fn merge_into(&self, sums: &mut [f32], crop: [u32; 2]) {
        let stride = self.channels + 1;
        for y in 0..self.size[1] {
            let gy = self.origin[1] + y as i64;
            if gy < 0 || gy >= crop[1] as i64 {
                continue;
            }
            for x in 0..self.size[0] {
                let gx = self.origin[0] + x as i64;
                if gx < 0 || gx >= crop[0] as i64 {
                    continue;
                }
                let src = (y * self.size[0] + x) * stride;
                let dst = (gy as usize * crop[0] as usize + gx as usize) * stride;
                for c in 0..stride {
                    sums[dst + c] += self.data[src + c];
                }
            }
        }
    }
}

/// A rendered image: `channels` interleaved floats per pixel, rows top to
/// bottom, plus the name of each channel group.
#[derive(Clone, Debug, PartialEq)]
pub struct Framebuffer {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Values per pixel.
    pub channels: usize,
    /// Pixel data.
    pub data: Vec<f32>,
}

impl Framebuffer {
    /// The value of channel `c` at (x, y).
    pub fn get(&self, x: u32, y: u32, c: usize) -> f32 {
        self.data[(y as usize * self.width as usize + x as usize) * self.channels + c]
    }

    /// A new framebuffer with channels `range` of this one.
    pub fn select_channels(&self, range: std::ops::Range<usize>) -> Framebuffer {
        let n = range.len();
        let data = self
            .data
            .chunks_exact(self.channels)
            .flat_map(|px| px[range.clone()].iter().copied())
            .collect();
        Framebuffer {
            width: self.width,
            height: self.height,
            channels: n,
            data,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splat_weights_normalize_and_merge() {
        for filter in [
            Filter::Box,
            Filter::Tent { radius: 1.0 },
            Filter::Gaussian { stddev: 0.5 },
        ] {
            let tile = Tile {
                x0: 0,
                y0: 0,
                x1: 4,
                y1: 4,
            };
            let mut buf = TileBuffer::new(tile, &filter, 1);
            buf.splat(&filter, Vec2::new(1.3, 2.7), &[2.0]);
            let mut sums = vec![0.0; 4 * 4 * 2];
            buf.merge_into(&mut sums, [4, 4]);
            // Every pixel that received weight holds value 2 after division.
            let mut total_w = 0.0;
            for px in sums.chunks_exact(2) {
                if px[1] > 0.0 {
                    assert!((px[0] / px[1] - 2.0).abs() < 1e-6);
                    total_w += px[1];
                }
            }
            assert!(total_w > 0.0);
        }
    }
}
