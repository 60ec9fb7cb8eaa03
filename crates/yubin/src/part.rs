//! Part files: what `yubin render --part K/N` writes and `yubin merge`
//! puts together (see `yubin_core::render::Part`).
//!
//! A part file is an OpenEXR image, written to a temporary name and renamed
//! into place. Its pixels are data, not a picture: the sums of each tile of
//! the part (the tile and the margin its filter reaches; `channels` sums
//! and a weight per pixel, as `TileBuffer::data` holds them), each tile in
//! a cell of `TILE_SIZE + 2 · margin` pixels, top-left aligned, cells in
//! tile order row by row (`cols` to a row). Channels `c0`, `c1`, … hold
//! the sums and `w` the weights, as float32, so the values are exact.
//! Text attributes (`exrheader` lists them) say what the merge needs to
//! check that the part belongs: `yubin.part` (K/N), `yubin.version`,
//! `yubin.fingerprint` (the scene file's hash and every setting that
//! changes the samples, one `key=value` per line), and what it needs to
//! make the image (crop size, margin, layers, counts of samples and of
//! non-finite samples).

use crate::checkpoint::Fingerprint;
use anyhow::{anyhow, bail, Result};
use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Image, Layer, LayerAttributes,
    SmallVec, Text, WritableImage,
};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use yubin_core::film::TileBuffer;
use yubin_core::integrator::Layer as ExtraLayer;
use yubin_core::render::{tiles, NonFiniteSample, TILE_SIZE};

/// What the file format is called in `yubin.format`.
const FORMAT: &str = "yubin-part 1";

/// What a part file says about itself.
#[derive(Clone, Debug, PartialEq)]
pub struct PartHeader {
    /// Which part, from 0.
    pub index: u32,
    /// Of how many.
    pub count: u32,
    /// The yubin version that rendered it.
    pub version: String,
    /// What was rendered (as a checkpoint's).
    pub fingerprint: Fingerprint,
    /// The image's (crop window's) size.
    pub crop: [u32; 2],
    /// The crop window's place in the film.
    pub crop_offset: [u32; 2],
    /// Pixels of margin around each tile's sums.
    pub margin: u32,
    /// Values per sample (RGB and the extra layers').
    pub channels: usize,
    /// The extra layers after RGB.
    pub layers: Vec<ExtraLayer>,
    /// Samples per pixel asked for, and taken.
    pub spp: u32,
    /// Samples per pixel taken (a finished part: `spp`).
    pub done: u32,
    /// Samples taken over the part's pixels.
    pub samples: u64,
    /// Non-finite samples dropped.
    pub dropped: u64,
    /// Pixels with a non-finite sample.
    pub nonfinite_pixels: u64,
    /// The first non-finite samples, in the order the render met them.
    pub nonfinite: Vec<NonFiniteSample>,
    /// The sum of the pixels' estimated relative errors and their count.
    pub error: (f64, u64),
    /// Whether the merged image is to be denoised.
    pub denoise: bool,
}

impl PartHeader {
    /// The tiles of the image that are this part's, by their place in
    /// tile order.
    pub fn tile_numbers(&self) -> impl Iterator<Item = usize> {
        let total = tiles(self.crop).len();
        (self.index as usize..total).step_by(self.count.max(1) as usize)
    }

    fn attributes(&self) -> Vec<(&'static str, String)> {
        let layers: Vec<String> = self
            .layers
            .iter()
            .map(|l| format!("{}:{}", l.name, l.channels.join(",")))
            .collect();
        let nonfinite: Vec<String> = self
            .nonfinite
            .iter()
            .map(|s| format!("{},{},{}", s.x, s.y, s.index))
            .collect();
        let fingerprint: Vec<String> = self
            .fingerprint
            .iter()
            .map(|(k, v)| format!("{k}={}", v.replace('\n', " ")))
            .collect();
        vec![
            ("yubin.format", FORMAT.to_string()),
            ("yubin.part", format!("{}/{}", self.index, self.count)),
            ("yubin.version", self.version.clone()),
            ("yubin.fingerprint", fingerprint.join("\n")),
            (
                "yubin.crop",
                format!(
                    "{} {} {} {}",
                    self.crop[0], self.crop[1], self.crop_offset[0], self.crop_offset[1]
                ),
            ),
            ("yubin.margin", self.margin.to_string()),
            ("yubin.channels", self.channels.to_string()),
            ("yubin.layers", layers.join(";")),
            ("yubin.spp", format!("{} {}", self.done, self.spp)),
            ("yubin.samples", self.samples.to_string()),
            (
                "yubin.dropped",
                format!("{} {}", self.dropped, self.nonfinite_pixels),
            ),
            ("yubin.nonfinite", nonfinite.join(" ")),
            ("yubin.error", format!("{} {}", self.error.0, self.error.1)),
            ("yubin.denoise", u8::from(self.denoise).to_string()),
        ]
    }

    fn from_attributes(path: &Path, attrs: &HashMap<Text, AttributeValue>) -> Result<Self> {
        let text = |key: &str| -> Result<String> {
            match attrs.get(&Text::from(key)) {
                Some(AttributeValue::Text(t)) => Ok(t.to_string()),
                _ => Err(anyhow!(
                    "{}: not a yubin part file (no {key} attribute)",
                    path.display()
                )),
            }
        };
        let bad = |key: &str| anyhow!("{}: damaged part file (its {key})", path.display());
        if text("yubin.format")? != FORMAT {
            bail!(
                "{}: a part file of another format ({}; this yubin reads {FORMAT})",
                path.display(),
                text("yubin.format")?
            );
        }
        let numbers = |key: &str| -> Result<Vec<f64>> {
            text(key)?
                .split_whitespace()
                .map(|t| t.parse::<f64>().map_err(|_| bad(key)))
                .collect()
        };
        let pair = |key: &str| -> Result<(f64, f64)> {
            match numbers(key)?[..] {
                [a, b] => Ok((a, b)),
                _ => Err(bad(key)),
            }
        };
        let whole = |key: &str| -> Result<u64> { text(key)?.trim().parse().map_err(|_| bad(key)) };
        let (index, count) = text("yubin.part")?
            .split_once('/')
            .and_then(|(k, n)| Some((k.parse().ok()?, n.parse().ok()?)))
            .ok_or_else(|| bad("yubin.part"))?;
        let [w, h, x, y] = numbers("yubin.crop")?[..] else {
            return Err(bad("yubin.crop"));
        };
        let (done, spp) = pair("yubin.spp")?;
        let (dropped, nonfinite_pixels) = pair("yubin.dropped")?;
        let (error_sum, error_count) = pair("yubin.error")?;
        let layers = text("yubin.layers")?
            .split(';')
            .filter(|l| !l.is_empty())
            .map(|l| {
                let (name, channels) = l.split_once(':').ok_or_else(|| bad("yubin.layers"))?;
                let channels: Vec<&str> = channels.split(',').collect();
                Ok(ExtraLayer::new(name, &channels))
            })
            .collect::<Result<_>>()?;
        let nonfinite = text("yubin.nonfinite")?
            .split_whitespace()
            .map(|s| {
                let v: Vec<u32> = s.split(',').filter_map(|n| n.parse().ok()).collect();
                match v[..] {
                    [x, y, index] => Ok(NonFiniteSample { x, y, index }),
                    _ => Err(bad("yubin.nonfinite")),
                }
            })
            .collect::<Result<_>>()?;
        let fingerprint = text("yubin.fingerprint")?
            .lines()
            .filter_map(|l| l.split_once('='))
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        Ok(PartHeader {
            index,
            count,
            version: text("yubin.version")?,
            fingerprint,
            crop: [w as u32, h as u32],
            crop_offset: [x as u32, y as u32],
            margin: whole("yubin.margin")? as u32,
            channels: whole("yubin.channels")? as usize,
            layers,
            spp: spp as u32,
            done: done as u32,
            samples: whole("yubin.samples")?,
            dropped: dropped as u64,
            nonfinite_pixels: nonfinite_pixels as u64,
            nonfinite,
            error: (error_sum, error_count as u64),
            denoise: whole("yubin.denoise")? != 0,
        })
    }
}

/// The side of a tile's cell in a part file.
fn cell(margin: u32) -> usize {
    (TILE_SIZE + 2 * margin) as usize
}

/// Cells to a row for `n` tiles: about square.
fn columns(n: usize) -> usize {
    (1..).find(|c| c * c >= n).unwrap_or(1)
}

/// Writes a part file: `header` and the sums of its tiles (in tile order,
/// as `Progressive::part_sums` gives them), through a temporary file
/// renamed into place.
pub fn write(path: &Path, header: &PartHeader, sums: &[&[f32]]) -> Result<()> {
    let all = tiles(header.crop);
    let numbers: Vec<usize> = header.tile_numbers().collect();
    if numbers.len() != sums.len() {
        bail!(
            "part {}/{}: {} tiles rendered, {} expected",
            header.index,
            header.count,
            sums.len(),
            numbers.len()
        );
    }
    let side = cell(header.margin);
    let cols = columns(sums.len());
    let rows = sums.len().div_ceil(cols);
    let (width, height) = (cols * side, rows * side);
    let stride = header.channels + 1;
    let mut planes = vec![vec![0.0f32; width * height]; stride];
    for (j, (&number, data)) in numbers.iter().zip(sums).enumerate() {
        let tile = all[number];
        let m = 2 * header.margin as usize;
        let (bw, bh) = (tile.width() + m, tile.height() + m);
        let (cx, cy) = ((j % cols) * side, (j / cols) * side);
        for y in 0..bh {
            for x in 0..bw {
                let at = (cy + y) * width + cx + x;
                for (c, plane) in planes.iter_mut().enumerate() {
                    plane[at] = data[(y * bw + x) * stride + c];
                }
            }
        }
    }
    let channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = planes
        .into_iter()
        .enumerate()
        .map(|(c, plane)| {
            let name = if c == header.channels {
                "w".to_string()
            } else {
                format!("c{c}")
            };
            AnyChannel::new(Text::from(name.as_str()), FlatSamples::F32(plane))
        })
        .collect();
    let mut attributes = LayerAttributes::default();
    attributes.other.extend(
        header
            .attributes()
            .into_iter()
            .map(|(k, v)| (Text::from(k), AttributeValue::Text(Text::from(v.as_str())))),
    );
    let layer = Layer::new(
        (width, height),
        attributes,
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(channels),
    );
    let tmp = temporary_sibling(path);
    let written = Image::from_layer(layer)
        .write()
        .to_file(&tmp)
        .map_err(|e| anyhow!("{e}"))
        .and_then(|()| std::fs::rename(&tmp, path).map_err(Into::into));
    if let Err(e) = written {
        std::fs::remove_file(&tmp).ok();
        let kept = if path.exists() {
            format!(" (the previous {} is untouched)", path.display())
        } else {
            String::new()
        };
        return Err(e.context(format!("cannot write {}{kept}", path.display())));
    }
    Ok(())
}

/// A fresh hidden name in the directory of `path`.
fn temporary_sibling(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Reads a part file's header alone.
pub fn read_header(path: &Path) -> Result<PartHeader> {
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| anyhow!("{}: not a readable part file ({e})", path.display()))?;
    let header = meta
        .headers
        .first()
        .ok_or_else(|| anyhow!("{}: an EXR without layers", path.display()))?;
    PartHeader::from_attributes(path, &header.own_attributes.other)
}

/// Reads a part file whole: its header and each of its tiles' sums, in
/// tile order.
pub fn read(path: &Path) -> Result<(PartHeader, Vec<Vec<f32>>)> {
    let header = read_header(path)?;
    let image = exr::prelude::read_first_flat_layer_from_file(path)
        .map_err(|e| anyhow!("{}: not a readable part file ({e})", path.display()))?;
    let layer = image.layer_data;
    let damaged = |why: &str| anyhow!("{}: damaged part file ({why})", path.display());
    let plane = |name: &str| -> Result<&[f32]> {
        let channel = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.eq(name))
            .ok_or_else(|| damaged(&format!("no channel {name}")))?;
        match &channel.sample_data {
            FlatSamples::F32(v) => Ok(v.as_slice()),
            _ => Err(damaged(&format!("channel {name} is not float32"))),
        }
    };
    let stride = header.channels + 1;
    let planes: Vec<&[f32]> = (0..stride)
        .map(|c| {
            if c == header.channels {
                plane("w")
            } else {
                plane(&format!("c{c}"))
            }
        })
        .collect::<Result<_>>()?;
    let all = tiles(header.crop);
    let numbers: Vec<usize> = header.tile_numbers().collect();
    let side = cell(header.margin);
    let cols = columns(numbers.len());
    let width = layer.size.width();
    if width != cols * side || layer.size.height() != numbers.len().div_ceil(cols) * side {
        return Err(damaged("its size does not fit its tiles"));
    }
    let sums = numbers
        .iter()
        .enumerate()
        .map(|(j, &number)| {
            let tile = all[number];
            let m = 2 * header.margin as usize;
            let (bw, bh) = (tile.width() + m, tile.height() + m);
            let (cx, cy) = ((j % cols) * side, (j / cols) * side);
            let mut data =
                Vec::with_capacity(TileBuffer::data_len(tile, header.margin, header.channels));
            for y in 0..bh {
                for x in 0..bw {
                    let at = (cy + y) * width + cx + x;
                    data.extend(planes.iter().map(|p| p[at]));
                }
            }
            data
        })
        .collect();
    Ok((header, sums))
}
