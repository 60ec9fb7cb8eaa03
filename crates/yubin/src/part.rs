//! Part files: what `yubin render --part K/N` writes and `yubin merge`
//! puts together (see `yubin_core::render::Part`).
//!
//! A part file is an OpenEXR image, uncompressed (the sums of noisy
//! samples hardly compress, and a merge reads them fastest so), written
//! to a temporary name and renamed into place. Its pixels are data, not a
//! picture: one float32 channel `sums`, one row per tile of the part in
//! tile order, each row what `TileBuffer::data` holds for the tile (the
//! tile and the margin its filter reaches; per pixel, `channels` sums and
//! a weight), edge tiles' rows padded with zeros.
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
use yubin_core::film::Tile;
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

/// The values in a row of a part file: a whole tile's sums (edge tiles,
/// smaller, leave the rest of their row zero).
fn row_len(margin: u32, channels: usize) -> usize {
    let full = Tile {
        x0: 0,
        y0: 0,
        x1: TILE_SIZE,
        y1: TILE_SIZE,
    };
    TileBuffer::data_len(full, margin, channels)
}

/// Writes a part file: `header` and the sums of its tiles (in tile order,
/// as `Progressive::part_sums` gives them), through a temporary file
/// renamed into place.
pub fn write(path: &Path, header: &PartHeader, sums: &[&[f32]]) -> Result<()> {
    let expected = header.tile_numbers().count();
    if expected != sums.len() {
        bail!(
            "part {}/{}: {} tiles rendered, {expected} expected",
            header.index,
            header.count,
            sums.len()
        );
    }
    let width = row_len(header.margin, header.channels);
    let mut rows = vec![0.0f32; width * sums.len()];
    for (row, data) in rows.chunks_exact_mut(width).zip(sums) {
        row[..data.len()].copy_from_slice(data);
    }
    let channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::from_elem(
        AnyChannel::new(Text::from("sums"), FlatSamples::F32(rows)),
        1,
    );
    let mut attributes = LayerAttributes::default();
    attributes.other.extend(
        header
            .attributes()
            .into_iter()
            .map(|(k, v)| (Text::from(k), AttributeValue::Text(Text::from(v.as_str())))),
    );
    let layer = Layer::new(
        (width, sums.len()),
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

/// A part file read whole: its header and its tiles' sums.
pub struct PartFile {
    /// What it says about itself.
    pub header: PartHeader,
    /// One row per tile, in tile order.
    rows: Vec<f32>,
}

impl PartFile {
    /// Each tile's sums with the place of the tile in the order of all
    /// tiles, in tile order.
    pub fn tiles(&self) -> impl Iterator<Item = (usize, &[f32])> {
        let h = &self.header;
        let all = tiles(h.crop);
        let width = row_len(h.margin, h.channels);
        h.tile_numbers()
            .zip(self.rows.chunks_exact(width))
            .map(move |(number, row)| {
                (
                    number,
                    &row[..TileBuffer::data_len(all[number], h.margin, h.channels)],
                )
            })
    }
}

/// Reads a part file whole.
pub fn read(path: &Path) -> Result<PartFile> {
    let image = exr::prelude::read_first_flat_layer_from_file(path)
        .map_err(|e| anyhow!("{}: not a readable part file ({e})", path.display()))?;
    let layer = image.layer_data;
    let header = PartHeader::from_attributes(path, &layer.attributes.other)?;
    let damaged = |why: &str| anyhow!("{}: damaged part file ({why})", path.display());
    let pixels = u64::from(header.crop[0]) * u64::from(header.crop[1]);
    if pixels == 0 || pixels > 1 << 30 || header.count == 0 || header.channels == 0 {
        return Err(damaged("its yubin.crop, yubin.part or yubin.channels"));
    }
    let width = row_len(header.margin, header.channels);
    let rows = header.tile_numbers().count();
    if (layer.size.width(), layer.size.height()) != (width, rows) {
        return Err(damaged("its size does not fit its tiles"));
    }
    let channel = layer
        .channel_data
        .list
        .into_iter()
        .find(|c| c.name.eq("sums"))
        .ok_or_else(|| damaged("no channel sums"))?;
    match channel.sample_data {
        FlatSamples::F32(rows) => Ok(PartFile { header, rows }),
        _ => Err(damaged("its sums are not float32")),
    }
}
