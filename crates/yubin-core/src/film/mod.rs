//! The film: image size, crop window and reconstruction filter, and the
//! per-tile accumulation buffers the renderer merges. Film plugins:
//! `hdrfilm` (`hdrfilm.rs`).
//!
//! Tiles never share memory: each accumulates Σ w·value and Σ w into its
//! own buffer, padded by the filter radius, and the renderer adds the
//! buffers into the image in tile order, so the result is the same
//! whatever the thread count.

mod hdrfilm;

use crate::filter::{Filter, FilterTable};
use crate::params::{plugin_of, ParamError, Params};
use glam::{Vec2, Vec4};
use wide::{f32x8, i32x8, CmpGt, CmpLt};

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

impl Tile {
    /// Width in pixels.
    pub fn width(&self) -> usize {
        (self.x1 - self.x0) as usize
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        (self.y1 - self.y0) as usize
    }
}

/// ⌊v⌋ for |v| < 2³¹ (pixel coordinates), by truncation: baseline x86-64
/// has no rounding instruction and would call a software `floorf`. Other
/// values give an integer far outside any tile buffer.
#[inline]
fn floor_i32(v: f32) -> i32 {
    let t = v as i32;
    t - i32::from((t as f32) > v)
}

/// Along one axis, for eight sample coordinates `p` (pixels): the first
/// and last pixel a filter reaches (as [`ceil_i32`] and [`floor_i32`]
/// give them) and the weights of its first `columns` pixels
/// (`[k][lane]`), each pixel's offset formed as [`TileBuffer::splat`]
/// forms it.
fn footprint_axis(
    filter: &FilterTable,
    p: f32x8,
    columns: usize,
) -> ([i32; 8], [i32; 8], [[f32; 8]; BATCH_COLUMNS]) {
    let (r, half) = (f32x8::splat(filter.radius()), f32x8::splat(0.5));
    let lo = ceil_i32x8(p - r - half);
    let hi = floor_i32x8(p + r - half);
    let mut w = [[0.0; 8]; BATCH_COLUMNS];
    for (k, w) in w[..columns].iter_mut().enumerate() {
        let pixel = f32x8::from_i32x8(lo + i32x8::splat(k as i32));
        *w = filter.eval_8(pixel + half - p).to_array();
    }
    (lo.to_array(), hi.to_array(), w)
}

/// [`floor_i32`] of eight values (`wide`'s `floor` calls libm lane by
/// lane on baseline x86-64).
#[inline]
fn floor_i32x8(v: f32x8) -> i32x8 {
    let t = v.fast_trunc_int();
    // A mask lane is −1 where the truncation rounded up.
    t + bytemuck::cast::<f32x8, i32x8>(f32x8::from_i32x8(t).cmp_gt(v))
}

/// [`ceil_i32`] of eight values.
#[inline]
fn ceil_i32x8(v: f32x8) -> i32x8 {
    let t = v.fast_trunc_int();
    t - bytemuck::cast::<f32x8, i32x8>(f32x8::from_i32x8(t).cmp_lt(v))
}

/// ⌈v⌉ for |v| < 2³¹, as [`floor_i32`].
#[inline]
fn ceil_i32(v: f32) -> i32 {
    let t = v as i32;
    t + i32::from((t as f32) < v)
}

/// The widest footprint (pixels) that [`TileBuffer::splat`] takes on its
/// fast path: every filter up to a radius of 3.5 pixels.
const FIXED_COLUMNS: usize = 8;

/// The widest and tallest footprint [`TileBuffer::footprints`] weighs:
/// a tent's of radius 1 (two pixels, three for a sample on a pixel's
/// edge) and a Gaussian's of radius 2 (four, five on an edge).
const BATCH_COLUMNS: usize = 4;

/// The footprints of up to eight RGB samples in a [`TileBuffer`], their
/// filter weights computed for the eight at once
/// ([`TileBuffer::footprints`]), to be added one sample after the other
/// ([`TileBuffer::splat_footprint`]).
#[derive(Clone, Debug)]
pub(crate) struct Footprints {
    /// The samples whose footprint lies in the buffer and is at most
    /// ⌊2r⌋ + 1 and [`BATCH_COLUMNS`] pixels wide and tall, r the
    /// filter's radius (the others go through [`TileBuffer::splat`]).
    pub fast: u32,
    /// Per sample: its first pixel in the buffer and its columns and rows.
    origin: [[usize; 2]; 8],
    size: [[usize; 2]; 8],
    /// `wx[k][j]`: the weight of sample `j`'s column `k`; `wy` the rows'.
    wx: [[f32; 8]; BATCH_COLUMNS],
    wy: [[f32; 8]; BATCH_COLUMNS],
}

/// A sample's footprint in a [`TileBuffer`]: its first pixel and its size.
struct Footprint {
    origin: [usize; 2],
    columns: usize,
    rows: usize,
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
    pub fn new(tile: Tile, filter: &FilterTable, channels: usize) -> Self {
        Self::with_margin(tile, Self::margin(filter), channels)
    }

    /// The margin (pixels on each side of the tile) a buffer keeps for
    /// `filter`: every pixel a sample in the tile can reach.
    pub fn margin(filter: &FilterTable) -> u32 {
        (filter.radius() + 0.5).ceil() as u32
    }

    /// The values a buffer for `tile` holds with `margin`: per pixel of
    /// the tile and its margin, row by row, `channels` sums and a weight.
    pub fn data_len(tile: Tile, margin: u32, channels: usize) -> usize {
        let m = 2 * margin as usize;
        (tile.width() + m) * (tile.height() + m) * (channels + 1)
    }

    /// A buffer for `tile` holding `data` (as [`TileBuffer::data`] gives
    /// it); `None` when its length does not fit.
    pub fn from_data(tile: Tile, margin: u32, channels: usize, data: Vec<f32>) -> Option<Self> {
        let empty = Self::with_margin(tile, margin, channels);
        (data.len() == empty.data.len()).then_some(Self { data, ..empty })
    }

    /// What the buffer holds: per pixel of the tile and its margin, row by
    /// row, `channels` sums and the weight.
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// Adds `other`, a buffer of the same tile, value by value.
    pub fn add(&mut self, other: &TileBuffer) {
        debug_assert_eq!((self.origin, self.size), (other.origin, other.size));
        for (a, b) in self.data.iter_mut().zip(&other.data) {
            *a += b;
        }
    }

    fn with_margin(tile: Tile, margin: u32, channels: usize) -> Self {
        let margin = i64::from(margin);
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
    pub fn splat(&mut self, filter: &FilterTable, pos: Vec2, values: &[f32]) {
        let stride = self.channels + 1;
        if filter.is_box() {
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
        match *values {
            [r, g, b] => self.splat_fixed(filter, pos, [r, g, b]),
            [r, g, b, a] => self.splat_fixed(filter, pos, [r, g, b, a]),
            _ => self.splat_any(filter, pos, values),
        }
    }

    /// [`TileBuffer::splat`] for samples of `N` values whose footprint is
    /// at most [`FIXED_COLUMNS`] pixels wide, the common case: the weights
    /// of a row are one product each, and no pixel is bounds-checked (the
    /// footprint is checked once; the tile's margin holds it whenever the
    /// sample lies in the tile).
    #[inline]
    fn splat_fixed<const N: usize>(&mut self, filter: &FilterTable, pos: Vec2, values: [f32; N]) {
        let Some(footprint) = self.footprint(filter, pos) else {
            return self.splat_any(filter, pos, &values);
        };
        let [x0, y0] = footprint.origin;
        let mut column = [0.0f32; FIXED_COLUMNS];
        for (k, w) in column[..footprint.columns].iter_mut().enumerate() {
            *w = filter.eval_1d((self.origin[0] + (x0 + k) as i64) as f32 + 0.5 - pos.x);
        }
        let column = &column[..footprint.columns];
        let stride = N + 1;
        for y in y0..y0 + footprint.rows {
            let wy = filter.eval_1d((self.origin[1] + y as i64) as f32 + 0.5 - pos.y);
            if wy == 0.0 {
                continue;
            }
            let start = (y * self.size[0] + x0) * stride;
            let row = &mut self.data[start..start + column.len() * stride];
            if let Ok(&[r, g, b]) = <&[f32; 3]>::try_from(&values[..]) {
                // An RGB cell and its weight are one 4-wide step: w · (r, g, b, 1).
                let rgb1 = Vec4::new(r, g, b, 1.0);
                for (cell, &wx) in row.chunks_exact_mut(4).zip(column) {
                    let sum = Vec4::from_slice(cell) + rgb1 * (wy * wx);
                    sum.write_to_slice(cell);
                }
                continue;
            }
            for (cell, &wx) in row.chunks_exact_mut(stride).zip(column) {
                let w = wy * wx;
                for (acc, v) in cell.iter_mut().zip(values) {
                    *acc += w * v;
                }
                cell[N] += w;
            }
        }
    }

    /// The footprints of the RGB samples at crop-window positions `pos` (at
    /// most eight) and their filter weights, eight samples per operation:
    /// the offsets, floors and ceilings and table lookups of
    /// [`TileBuffer::splat`], lane by lane, bit for bit.
    ///
    /// # Panics
    /// For more than eight samples, a buffer of other than three values
    /// per sample or the box filter (whose weights are not tabulated).
    pub(crate) fn footprints(&self, filter: &FilterTable, pos: &[Vec2]) -> Footprints {
        assert!(pos.len() <= 8 && self.channels == 3 && !filter.is_box());
        let (mut xs, mut ys) = ([0.0f32; 8], [0.0f32; 8]);
        for ((x, y), p) in xs.iter_mut().zip(&mut ys).zip(pos) {
            (*x, *y) = (p.x, p.y);
        }
        // A footprint spans at most ⌊2r⌋ + 1 pixels (a tent's of radius 1:
        // two, or three when a sample lies on a pixel's edge).
        let columns = ((2.0 * filter.radius()) as usize + 1).min(BATCH_COLUMNS);
        let (x_lo, x_hi, wx) = footprint_axis(filter, f32x8::new(xs), columns);
        let (y_lo, y_hi, wy) = footprint_axis(filter, f32x8::new(ys), columns);
        let mut fp = Footprints {
            fast: 0,
            origin: [[0; 2]; 8],
            size: [[0; 2]; 8],
            wx,
            wy,
        };
        for j in 0..pos.len() {
            let lo = [
                i64::from(x_lo[j]) - self.origin[0],
                i64::from(y_lo[j]) - self.origin[1],
            ];
            let hi = [
                i64::from(x_hi[j]) - self.origin[0],
                i64::from(y_hi[j]) - self.origin[1],
            ];
            if let Some(f) = self.fitted(lo, hi, [columns; 2]) {
                fp.fast |= 1 << j;
                fp.origin[j] = f.origin;
                fp.size[j] = [f.columns, f.rows];
            }
        }
        fp
    }

    /// Adds sample `j` of `fp` (one of its `fast` ones), of value `rgb`:
    /// what [`TileBuffer::splat`] adds for it, bit for bit.
    #[inline]
    pub(crate) fn splat_footprint(&mut self, fp: &Footprints, j: usize, [r, g, b]: [f32; 3]) {
        debug_assert!(fp.fast >> j & 1 != 0);
        let ([x0, y0], [columns, rows]) = (fp.origin[j], fp.size[j]);
        let rgb1 = Vec4::new(r, g, b, 1.0);
        for (row, wy) in fp.wy[..rows].iter().enumerate() {
            let wy = wy[j];
            if wy == 0.0 {
                continue;
            }
            let start = ((y0 + row) * self.size[0] + x0) * 4;
            let cells = &mut self.data[start..start + columns * 4];
            for (cell, wx) in cells.chunks_exact_mut(4).zip(&fp.wx) {
                let sum = Vec4::from_slice(cell) + rgb1 * (wy * wx[j]);
                sum.write_to_slice(cell);
            }
        }
    }

    /// The pixels a filter of `filter`'s radius reaches from `pos`, in
    /// buffer coordinates, when they lie in the buffer and are at most
    /// [`FIXED_COLUMNS`] wide.
    #[inline]
    fn footprint(&self, filter: &FilterTable, pos: Vec2) -> Option<Footprint> {
        let r = filter.radius();
        let lo = [
            i64::from(ceil_i32(pos.x - r - 0.5)) - self.origin[0],
            i64::from(ceil_i32(pos.y - r - 0.5)) - self.origin[1],
        ];
        let hi = [
            i64::from(floor_i32(pos.x + r - 0.5)) - self.origin[0],
            i64::from(floor_i32(pos.y + r - 0.5)) - self.origin[1],
        ];
        self.fitted(lo, hi, [FIXED_COLUMNS, usize::MAX])
    }

    /// The footprint from pixel `lo` to `hi` (buffer coordinates,
    /// inclusive) when it is not empty, lies in the buffer and is at most
    /// `most` pixels wide and tall.
    #[inline]
    fn fitted(&self, lo: [i64; 2], hi: [i64; 2], most: [usize; 2]) -> Option<Footprint> {
        let fits = (0..2).all(|a| {
            lo[a] >= 0
                && hi[a] < self.size[a] as i64
                && hi[a] >= lo[a]
                && ((hi[a] - lo[a]) as u64) < most[a] as u64
        });
        fits.then(|| Footprint {
            origin: [lo[0] as usize, lo[1] as usize],
            columns: (hi[0] - lo[0]) as usize + 1,
            rows: (hi[1] - lo[1]) as usize + 1,
        })
    }

    /// [`TileBuffer::splat`] for any sample: any channel count, any
    /// footprint, pixels outside the buffer skipped.
    fn splat_any(&mut self, filter: &FilterTable, pos: Vec2, values: &[f32]) {
        let stride = self.channels + 1;
        let r = filter.radius();
        let (lo_x, hi_x) = (
            (pos.x - r - 0.5).ceil() as i64,
            (pos.x + r - 0.5).floor() as i64,
        );
        let (lo_y, hi_y) = (
            (pos.y - r - 0.5).ceil() as i64,
            (pos.y + r - 0.5).floor() as i64,
        );
        // The column weights are the same in every row: computed once
        // (for filters up to 64 pixels wide; wider ones per pixel).
        let mut column = [0.0f32; 64];
        let columns = (hi_x - lo_x + 1).max(0) as usize;
        let cached = columns <= column.len();
        let wx = |px: i64| filter.eval_1d(px as f32 + 0.5 - pos.x);
        if cached {
            for (k, w) in column[..columns].iter_mut().enumerate() {
                *w = wx(lo_x + k as i64);
            }
        }
        for py in lo_y..=hi_y {
            let wy = filter.eval_1d(py as f32 + 0.5 - pos.y);
            if wy == 0.0 {
                continue;
            }
            for px in lo_x..=hi_x {
                let w = wy
                    * if cached {
                        column[(px - lo_x) as usize]
                    } else {
                        wx(px)
                    };
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
        add_rows(
            self.origin,
            self.size,
            self.channels,
            &self.data,
            sums,
            crop,
        );
    }

    /// Adds `data`, what a buffer for `tile` with `margin` holds
    /// ([`TileBuffer::data`], of [`TileBuffer::data_len`] values), into
    /// `sums` as [`TileBuffer::merge_into`] does, without making the buffer.
    pub fn merge_data_into(
        (tile, margin, channels): (Tile, u32, usize),
        data: &[f32],
        sums: &mut [f32],
        crop: [u32; 2],
    ) {
        let m = i64::from(margin);
        let origin = [i64::from(tile.x0) - m, i64::from(tile.y0) - m];
        let size = [
            tile.width() + 2 * m as usize,
            tile.height() + 2 * m as usize,
        ];
        debug_assert_eq!(data.len(), size[0] * size[1] * (channels + 1));
        add_rows(origin, size, channels, data, sums, crop);
    }
}

/// Adds a buffer's `data` (`size` pixels from `origin`, `channels + 1`
/// values each) into the crop-sized `sums`.
fn add_rows(
    origin: [i64; 2],
    size: [usize; 2],
    channels: usize,
    data: &[f32],
    sums: &mut [f32],
    crop: [u32; 2],
) {
    let width = crop[0];
    let stride = channels + 1;
    // The columns of the buffer inside the crop window, the same on
    // every row: each row's run is added as one slice (vectorized).
    let x0 = (-origin[0]).clamp(0, size[0] as i64) as usize;
    let x1 = (i64::from(width) - origin[0]).clamp(x0 as i64, size[0] as i64) as usize;
    if x0 == x1 {
        return;
    }
    for y in 0..size[1] {
        let gy = origin[1] + y as i64;
        if gy < 0 || gy >= i64::from(crop[1]) {
            continue;
        }
        let src = (y * size[0] + x0) * stride;
        let gx0 = (origin[0] + x0 as i64) as usize;
        let dst = (gy as usize * width as usize + gx0) * stride;
        let len = (x1 - x0) * stride;
        for (d, s) in sums[dst..dst + len].iter_mut().zip(&data[src..src + len]) {
            *d += s;
        }
    }
}

/// An RGB image that takes splats anywhere (paths traced from the lights
/// land on any pixel). A splat at film position x adds
/// value · h(x − pⱼ) / ∫ h(y − pⱼ) dy to each pixel j within the filter's
/// reach, the integral taken over the full image: in expectation a pixel
/// is then ∫ h L / ∫ h over the image, exactly what camera paths give
/// (their Σ w L / Σ w), edge pixels included. Sums are kept in f64: a
/// pixel may take millions of splats.
#[derive(Clone, Debug)]
pub struct SplatImage {
    size: [u32; 2],
    /// Crop window origin in the full image.
    offset: [u32; 2],
    /// Per crop column and row: 1 / ∫ h₁ over the full image's extent.
    inv_norm: [Vec<f64>; 2],
    filter: FilterTable,
    data: Vec<f64>,
}

impl SplatImage {
    /// A black image for the crop window of `film`.
    pub fn new(film: &Film) -> Self {
        let size = film.crop_size;
        let filter = FilterTable::new(&film.filter);
        let inv_norm = [0, 1].map(|axis| {
            (0..size[axis])
                .map(|i| {
                    let centre = (film.crop_offset[axis] + i) as f64 + 0.5;
                    let full = [film.width, film.height][axis] as f64;
                    1.0 / filter_integral(&filter, centre, full)
                })
                .collect()
        });
        Self {
            size,
            offset: film.crop_offset,
            inv_norm,
            filter,
            data: vec![0.0; size[0] as usize * size[1] as usize * 3],
        }
    }

    /// Adds `rgb` at `pos` (pixels of the full image, continuous).
    pub fn splat(&mut self, pos: Vec2, rgb: [f32; 3]) {
        let filter = &self.filter;
        let pos = pos - Vec2::new(self.offset[0] as f32, self.offset[1] as f32);
        let r = filter.radius();
        let span = |c: f32, n: u32| {
            let lo = ((c - r - 0.5).ceil() as i64).max(0);
            let hi = ((c + r - 0.5).floor() as i64).min(n as i64 - 1);
            lo..=hi
        };
        for py in span(pos.y, self.size[1]) {
            let wy = filter.eval_1d(py as f32 + 0.5 - pos.y) as f64 * self.inv_norm[1][py as usize];
            if wy == 0.0 {
                continue;
            }
            for px in span(pos.x, self.size[0]) {
                let w = wy
                    * filter.eval_1d(px as f32 + 0.5 - pos.x) as f64
                    * self.inv_norm[0][px as usize];
                let i = (py as usize * self.size[0] as usize + px as usize) * 3;
                for (acc, v) in self.data[i..i + 3].iter_mut().zip(rgb) {
                    *acc += w * v as f64;
                }
            }
        }
    }

    /// The image scaled by `scale`, as a 3-channel framebuffer.
    pub fn to_framebuffer(&self, scale: f64) -> Framebuffer {
        Framebuffer {
            width: self.size[0],
            height: self.size[1],
            channels: 3,
            data: self.data.iter().map(|v| (v * scale) as f32).collect(),
        }
    }
}

/// ∫ h₁(y − centre) dy over [0, extent], by the midpoint rule on steps
/// much finer than a pixel (exact for the box filter).
fn filter_integral(filter: &FilterTable, centre: f64, extent: f64) -> f64 {
    const STEPS_PER_PIXEL: usize = 256;
    let r = filter.radius() as f64;
    let (lo, hi) = ((centre - r).max(0.0), (centre + r).min(extent));
    let n = ((hi - lo) * STEPS_PER_PIXEL as f64).ceil().max(1.0) as usize;
    let dy = (hi - lo) / n as f64;
    (0..n)
        .map(|k| filter.eval_1d((lo + (k as f64 + 0.5) * dy - centre) as f32) as f64)
        .sum::<f64>()
        * dy
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
    use crate::sampler::Pcg32;

    /// Samples splatted through [`TileBuffer::footprints`] (eight at a
    /// time) and through [`TileBuffer::splat`] (one at a time) leave the
    /// same buffer bit for bit, for every tabulated filter (footprints two
    /// to seven pixels wide, the widest not taken by the batch), samples
    /// all over the tile and just outside it, and at pixel centres, where
    /// a radius-2 footprint is five pixels wide.
    #[test]
    fn footprints_eight_at_a_time_splat_as_one_at_a_time() {
        let tile = Tile {
            x0: 16,
            y0: 8,
            x1: 32,
            y1: 24,
        };
        let mut rng = Pcg32::new(9, 1);
        let mut batched_somewhere = false;
        for filter in [
            Filter::Tent { radius: 1.0 },
            Filter::Tent { radius: 1.7 },
            Filter::Gaussian { stddev: 0.5 },
            Filter::Mitchell { b: 0.0, c: 0.5 },
            Filter::Lanczos { lobes: 3 },
        ] {
            let table = FilterTable::new(&filter);
            let mut one = TileBuffer::new(tile, &table, 3);
            let mut eight = one.clone();
            for round in 0..200 {
                let pos: Vec<Vec2> = (0..1 + round % 8)
                    .map(|k| {
                        let (x, y) = (16.0 + 18.0 * rng.next_f32(), 8.0 + 18.0 * rng.next_f32());
                        if k == 3 {
                            Vec2::new(x.floor() + 0.5, y.floor() + 0.5)
                        } else {
                            Vec2::new(x - 1.0, y - 1.0)
                        }
                    })
                    .collect();
                let rgb: Vec<[f32; 3]> = pos
                    .iter()
                    .map(|_| [rng.next_f32(), 2.0 * rng.next_f32(), rng.next_f32()])
                    .collect();
                let fp = eight.footprints(&table, &pos);
                for (j, (p, v)) in pos.iter().zip(&rgb).enumerate() {
                    one.splat(&table, *p, v);
                    if fp.fast >> j & 1 != 0 {
                        eight.splat_footprint(&fp, j, *v);
                        batched_somewhere = true;
                    } else {
                        eight.splat(&table, *p, v);
                    }
                }
            }
            let bits = |b: &TileBuffer| b.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&one), bits(&eight), "{filter:?}");
        }
        assert!(batched_somewhere);
    }

    /// Splats uniform over the film make every pixel of the crop window,
    /// edges included, the splat density (as camera samples of a uniform
    /// image would), whatever the filter.
    #[test]
    fn uniform_splats_give_a_uniform_image() {
        for filter in [
            Filter::Box,
            Filter::Tent { radius: 1.3 },
            Filter::Gaussian { stddev: 0.5 },
            Filter::Mitchell { b: 0.0, c: 0.5 },
            Filter::Lanczos { lobes: 3 },
        ] {
            let mut film = Film::new(10, 8, filter);
            film.crop_offset = [0, 3];
            film.crop_size = [6, 5];
            let mut img = SplatImage::new(&film);
            // A fine grid of splats, 64 per pixel, each of value 1/64.
            for j in 0..8 * 8 {
                for i in 0..10 * 8 {
                    let pos = Vec2::new((i as f32 + 0.5) / 8.0, (j as f32 + 0.5) / 8.0);
                    img.splat(pos, [1.0 / 64.0, 2.0 / 64.0, 0.0]);
                }
            }
            let fb = img.to_framebuffer(1.0);
            for px in fb.data.chunks_exact(3) {
                assert!((px[0] - 1.0).abs() < 0.02, "{filter:?}: {px:?}");
                assert!(
                    (px[1] - 2.0).abs() < 0.04 && px[2] == 0.0,
                    "{filter:?}: {px:?}"
                );
            }
        }
    }

    #[test]
    fn splat_weights_normalize_and_merge() {
        for filter in [
            Filter::Box,
            Filter::Tent { radius: 1.0 },
            Filter::Gaussian { stddev: 0.5 },
            Filter::Mitchell {
                b: 1.0 / 3.0,
                c: 1.0 / 3.0,
            },
            Filter::Lanczos { lobes: 2 },
        ] {
            let tile = Tile {
                x0: 0,
                y0: 0,
                x1: 4,
                y1: 4,
            };
            let table = FilterTable::new(&filter);
            let mut buf = TileBuffer::new(tile, &table, 1);
            buf.splat(&table, Vec2::new(1.3, 2.7), &[2.0]);
            let mut sums = vec![0.0; 4 * 4 * 2];
            buf.merge_into(&mut sums, [4, 4]);
            // Every pixel that received weight holds value 2 after division.
            let mut total_w = 0.0;
            for px in sums.chunks_exact(2) {
                if px[1] != 0.0 {
                    assert!((px[0] / px[1] - 2.0).abs() < 1e-5);
                    total_w += px[1];
                }
            }
            assert!(total_w > 0.0);
        }
    }

    /// Integer floor and ceiling agree with `f32::floor`/`ceil` on pixel
    /// coordinates: negative, integral, just off integers, large.
    #[test]
    fn integer_floor_and_ceiling() {
        let mut rng = crate::sampler::Pcg32::new(3, 9);
        let mut values = vec![0.0, -0.0, 1.0, -1.0, 2.5, -2.5, 16777215.0, -16777216.0];
        for k in -40..40 {
            let x = k as f32 * 0.5;
            values.extend([x, x.next_up(), x.next_down()]);
        }
        values.extend((0..1000).map(|_| (rng.next_f32() - 0.5) * 1e5));
        for v in values {
            assert_eq!(floor_i32(v) as f32, v.floor(), "floor {v}");
            assert_eq!(ceil_i32(v) as f32, v.ceil(), "ceil {v}");
        }
    }

    /// The fast path (3 or 4 values, narrow footprint inside the buffer)
    /// adds exactly what the general one adds, pixel by pixel, and leaves
    /// samples whose footprint leaves the buffer to the general one.
    #[test]
    fn fixed_splats_equal_general_splats() {
        let tile = Tile {
            x0: 8,
            y0: 4,
            x1: 16,
            y1: 12,
        };
        let mut rng = crate::sampler::Pcg32::new(7, 0);
        for filter in [
            Filter::Tent { radius: 1.0 },
            Filter::Gaussian { stddev: 0.5 },
            Filter::Mitchell {
                b: 1.0 / 3.0,
                c: 1.0 / 3.0,
            },
            Filter::Lanczos { lobes: 3 },
            // 8 or 9 columns: either side of the fast path's limit.
            Filter::Tent { radius: 4.2 },
            Filter::Gaussian { stddev: 2.0 },
        ] {
            let table = FilterTable::new(&filter);
            for channels in [3, 4] {
                let mut fast = TileBuffer::new(tile, &table, channels);
                let mut general = fast.clone();
                for _ in 0..200 {
                    // Within the tile and up to two pixels beyond it.
                    let pos = Vec2::new(6.0 + 12.0 * rng.next_f32(), 2.0 + 12.0 * rng.next_f32());
                    let values: Vec<f32> = (0..channels)
                        .map(|c| rng.next_f32() - 0.2 * c as f32)
                        .collect();
                    fast.splat(&table, pos, &values);
                    general.splat_any(&table, pos, &values);
                }
                assert!(fast.data.iter().any(|&v| v != 0.0));
                assert_eq!(fast.data, general.data, "{filter:?}, {channels} channels");
            }
        }
    }
}
