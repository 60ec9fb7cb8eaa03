//! Reading and writing images: textures in, renders out.
//!
//! All pixel data is `f32`, interleaved, top row first ([`Image`]).
//!
//! # Reading ([`read_image`])
//!
//! | format | how | colour |
//! |---|---|---|
//! | OpenEXR | [`exr`], first valid layer, largest resolution level; channels `R`,`G`,`B` (+`A`), or `Y` (+`A`) | linear, f16/f32/u32 → f32 |
//! | Radiance `.hdr` (RGBE) | [`image`] | linear |
//! | PNG, JPEG (8 or 16 bit), BMP, TGA | [`image`] | sRGB → linear unless [`ColorHandling::Raw`]; alpha is never converted |
//!
//! EXR files are recognised by their magic number, everything else by
//! content sniffing in the `image` crate. Grey images keep one channel,
//! grey+alpha two, RGB three, RGBA four.
//!
//! # Writing ([`write_exr`], [`write_png`], [`write_image`])
//!
//! EXR: linear `f32`, ZIP compression (lossless, so a write/read round trip
//! is bit-exact). The main image (layer name `""`) is stored as `R`,`G`,`B`;
//! every further layer `name` as `name.R`, `name.G`, `name.B` — the
//! single-part multi-layer convention that Mitsuba and most viewers use for
//! AOVs. Channel names by channel count: 1 → `Y`; 2 → `Y`,`A`; 3 →
//! `R`,`G`,`B`; 4 → `R`,`G`,`B`,`A`; more → `0`, `1`, …, unless the
//! layer names its channels ([`ExrLayer::channels`]: `depth.T`, `nn.X`).
//!
//! PNG: 8 bit; colour channels get the sRGB transfer function, then are
//! clamped to [0, 1] and rounded; alpha is written linearly. Tone mapping
//! and exposure are the caller's job.
//!
//! Every writer writes a temporary file next to the target and renames it
//! into place, so the target is never left half-written; the temporary is
//! removed on error.
//!
//! # Limitations
//!
//! TIFF is not enabled in the workspace's `image` features. Textures
//! ([`read_texture`]) also read PFM and keep 8-bit data as bytes.
//! EXR: only the data window is read (display-window offsets are ignored),
//! subsampled channels and deep data are rejected, and only the main
//! `R`,`G`,`B`(,`A`) or `Y` channels of the first layer are returned.
//! Image metadata (ICC profiles, gamma chunks) is ignored: 8-bit data is
//! assumed to be sRGB.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use yubin_core::limits::Limit;

use crate::error::SceneError;
use yubin_core::texture::image::ImageData;
use yubin_core::texture::TexImage;

/// A `width` × `height` image with `channels` interleaved `f32` values per
/// pixel, rows stored top row first.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Image {
    /// Pixels per row.
    pub width: usize,
    /// Number of rows.
    pub height: usize,
    /// Values per pixel.
    pub channels: usize,
    /// `width * height * channels` values: pixel `(x, y)` channel `c` is at
    /// `(y * width + x) * channels + c`.
    pub data: Vec<f32>,
}

impl Image {
    /// A black image.
    pub fn new(width: usize, height: usize, channels: usize) -> Self {
        Self {
            width,
            height,
            channels,
            data: vec![0.0; width * height * channels],
        }
    }

    /// The index of channel `c` of pixel `(x, y)` in [`Image::data`].
    pub fn index(&self, x: usize, y: usize, c: usize) -> usize {
        debug_assert!(x < self.width && y < self.height && c < self.channels);
        (y * self.width + x) * self.channels + c
    }

    /// Channel `c` of pixel `(x, y)`. Panics when out of bounds.
    pub fn get(&self, x: usize, y: usize, c: usize) -> f32 {
        self.data[self.index(x, y, c)]
    }

    /// Sets channel `c` of pixel `(x, y)`. Panics when out of bounds.
    pub fn set(&mut self, x: usize, y: usize, c: usize, value: f32) {
        let i = self.index(x, y, c);
        self.data[i] = value;
    }

    /// The colour of pixel `(x, y)`: the first three channels, or the grey
    /// value three times for one- and two-channel (grey, grey+alpha) images.
    pub fn rgb(&self, x: usize, y: usize) -> [f32; 3] {
        if self.channels >= 3 {
            [self.get(x, y, 0), self.get(x, y, 1), self.get(x, y, 2)]
        } else {
            [self.get(x, y, 0); 3]
        }
    }

    /// Whether `data` has exactly `width * height * channels` values.
    fn is_consistent(&self) -> bool {
        self.width
            .checked_mul(self.height)
            .and_then(|n| n.checked_mul(self.channels))
            .is_some_and(|n| n == self.data.len())
    }
}

/// How 8- and 16-bit images are interpreted when read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ColorHandling {
    /// The values are sRGB-encoded: colour channels are converted to linear
    /// (alpha is not). For colour textures.
    #[default]
    Srgb,
    /// The values are used as stored, scaled to [0, 1]. For data textures
    /// (roughness, normal maps); Mitsuba's `raw = true`.
    Raw,
}

/// Reads an image file; see the module docs for formats and conventions.
/// Floating-point formats (EXR, HDR) are linear whatever `color` says.
pub fn read_image(path: &Path, color: ColorHandling) -> Result<Image, SceneError> {
    if has_exr_magic(path)? {
        read_exr(path)
    } else {
        read_with_image_crate(path, color)
    }
}

/// Reads an image file as a texture: 8-bit PNG and JPEG keep one byte per
/// channel and 16-bit ones their encoded values (both decoded from sRGB
/// per texel at lookup, unless the texture is `raw`); EXR, HDR and PFM are
/// linear floats.
pub fn read_texture(path: &Path) -> Result<TexImage, SceneError> {
    let (width, height, channels, data, encoded) = if has_exr_magic(path)? {
        let img = read_exr(path)?;
        (
            img.width,
            img.height,
            img.channels,
            ImageData::F32(img.data),
            false,
        )
    } else if has_pfm_magic(path)? {
        let img = read_pfm(path)?;
        (
            img.width,
            img.height,
            img.channels,
            ImageData::F32(img.data),
            false,
        )
    } else {
        let decoded = decode_with_image_crate(path)?;
        let (w, h) = (decoded.width() as usize, decoded.height() as usize);
        let channels = usize::from(decoded.color().channel_count());
        match decoded.color() {
            // Kept as decoded: no float copy, not even for a moment.
            image::ColorType::L8
            | image::ColorType::La8
            | image::ColorType::Rgb8
            | image::ColorType::Rgba8 => {
                (w, h, channels, ImageData::U8(decoded.into_bytes()), true)
            }
            color => {
                let is_float =
                    matches!(color, image::ColorType::Rgb32F | image::ColorType::Rgba32F);
                let img = dynamic_to_linear(&decoded, ColorHandling::Raw);
                (w, h, channels, ImageData::F32(img.data), !is_float)
            }
        }
    };
    TexImage::new(width as u32, height as u32, channels as u32, data, encoded).ok_or_else(|| {
        SceneError::file(
            path,
            format!("unusable texture image ({width}x{height}, {channels} channels)"),
        )
    })
}

/// Whether the file starts like a Portable Float Map (`PF` or `Pf` and a
/// line break).
fn has_pfm_magic(path: &Path) -> Result<bool, SceneError> {
    use std::io::Read;
    let mut magic = [0u8; 3];
    let mut file = std::fs::File::open(path).map_err(|e| io_error(path, e))?;
    let n = file.read(&mut magic).map_err(|e| io_error(path, e))?;
    Ok(n == 3 && (magic[..2] == *b"PF" || magic[..2] == *b"Pf") && magic[2].is_ascii_whitespace())
}

/// Reads a Portable Float Map: a text header (`PF` for RGB or `Pf` for
/// grey, width and height, a scale whose sign gives the byte order), then
/// 32-bit floats, bottom row first.
fn read_pfm(path: &Path) -> Result<Image, SceneError> {
    let bytes = std::fs::read(path).map_err(|e| io_error(path, e))?;
    let bad = |msg: &str| SceneError::file(path, format!("invalid PFM file: {msg}"));
    // The header is three whitespace-separated tokens after the magic.
    let mut tokens = Vec::new();
    let mut pos = 0;
    while tokens.len() < 4 {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if start == pos {
            return Err(bad("truncated header"));
        }
        tokens.push(String::from_utf8_lossy(&bytes[start..pos]).into_owned());
    }
    pos += 1; // the single whitespace byte ending the header
    let channels = match tokens[0].as_str() {
        "PF" => 3,
        "Pf" => 1,
        _ => return Err(bad("unknown magic")),
    };
    let parse = |t: &str| t.parse::<usize>().ok().filter(|&v| v > 0);
    let (Some(width), Some(height)) = (parse(&tokens[1]), parse(&tokens[2])) else {
        return Err(bad("bad size"));
    };
    check_texels(path, width, height)?;
    let scale: f32 = tokens[3].parse().map_err(|_| bad("bad scale"))?;
    let count = width * height * channels;
    let body = pos
        .checked_add(4 * count)
        .and_then(|end| bytes.get(pos..end))
        .ok_or_else(|| bad("truncated data"))?;
    let mut image = Image::new(width, height, channels);
    for (i, chunk) in body.chunks_exact(4).enumerate() {
        let raw = [chunk[0], chunk[1], chunk[2], chunk[3]];
        let v = if scale < 0.0 {
            f32::from_le_bytes(raw)
        } else {
            f32::from_be_bytes(raw)
        };
        // Rows are stored bottom to top.
        let (x, y, c) = ((i / channels) % width, (i / channels) / width, i % channels);
        let index = image.index(x, height - 1 - y, c);
        image.data[index] = v;
    }
    Ok(image)
}

/// Whether the file starts with the OpenEXR magic number.
fn has_exr_magic(path: &Path) -> Result<bool, SceneError> {
    use std::io::Read;
    let mut magic = [0u8; 4];
    let mut file = std::fs::File::open(path).map_err(|e| io_error(path, e))?;
    let n = file.read(&mut magic).map_err(|e| io_error(path, e))?;
    Ok(n == 4 && magic == [0x76, 0x2f, 0x31, 0x01])
}

/// Refuses an image of `width` × `height` texels beyond
/// [`Limit::TexturePixels`] before it is decoded.
fn check_texels(path: &Path, width: usize, height: usize) -> Result<(), SceneError> {
    let texels = (width as u64).saturating_mul(height as u64);
    Limit::TexturePixels
        .check(texels, || format!("the image of {width} × {height} texels"))
        .map_err(|e| SceneError::file(path, e))
}

/// Refuses an image whose header asks for more memory (`bytes`, decoded)
/// than its file of `file_len` bytes can fill: no EXR or PNG compression
/// packs more than 1032 bytes into one (deflate's limit), so a header
/// claiming more than 2048 times its file's size (and 64 MiB) is damaged
/// or hostile, and is refused before the decoder allocates it.
fn check_decoded_size(path: &Path, file_len: u64, bytes: u64) -> Result<(), SceneError> {
    const FLOOR: u64 = 64 << 20;
    let most = file_len.saturating_mul(2048).max(FLOOR);
    if bytes <= most {
        return Ok(());
    }
    Err(SceneError::file(
        path,
        format!(
            "the header asks for {bytes} bytes of image data, more than its {file_len} bytes \
             can hold (the file is damaged or truncated)"
        ),
    ))
}

/// The first layer of a B44- or B44A-compressed EXR, decoded on this
/// thread with a panic turned into an error: the `exr` crate's B44
/// decoder (1.74) computes with unchecked subtractions that overflow on
/// damaged blocks, a panic wherever overflow is checked (debug builds,
/// fuzzing), and one on its own decoder threads aborts the process (the
/// image fuzzer's only crashes). Release builds wrap instead; either way a
/// damaged file is refused or decoded, never a crash.
fn read_b44_exr(path: &Path) -> Result<ExrFlatImage, SceneError> {
    use exr::prelude::{read, ReadChannels, ReadLayers};
    let decode = || {
        read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .non_parallel()
            .from_file(path)
    };
    match std::panic::catch_unwind(decode) {
        Ok(decoded) => decoded.map_err(|e| exr_error(path, e)),
        Err(_) => Err(SceneError::file(
            path,
            "EXR: the B44 decoder failed on damaged data",
        )),
    }
}

/// An EXR's first layer, every channel as flat samples.
type ExrFlatImage =
    exr::image::Image<exr::image::Layer<exr::image::AnyChannels<exr::image::FlatSamples>>>;

/// Reads the `R`,`G`,`B`(,`A`) or `Y`(,`A`) channels of the first layer.
fn read_exr(path: &Path) -> Result<Image, SceneError> {
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| exr_error(path, e))?;
    let file_len = std::fs::metadata(path)
        .map_err(|e| io_error(path, e))?
        .len();
    let b44 = meta.headers.iter().any(|h| {
        use exr::compression::Compression;
        matches!(h.compression, Compression::B44 | Compression::B44A)
    });
    for header in &meta.headers {
        let size = header.layer_size;
        check_texels(path, size.width(), size.height())?;
        // The reader allocates every channel's samples before it reads
        // them, as f32 (4 bytes each).
        let values = (size.width() as u64 * size.height() as u64)
            .saturating_mul(header.channels.list.len() as u64);
        check_decoded_size(path, file_len, values.saturating_mul(4))?;
    }
    let exr_image = if b44 {
        read_b44_exr(path)?
    } else {
        exr::prelude::read_first_flat_layer_from_file(path).map_err(|e| exr_error(path, e))?
    };
    let layer = &exr_image.layer_data;
    let (width, height) = (layer.size.width(), layer.size.height());
    let channels = &layer.channel_data.list;
    let find = |name: &str| channels.iter().find(|c| c.name.eq(name));
    let selected: Vec<_> = match (find("R"), find("G"), find("B"), find("Y")) {
        (Some(r), Some(g), Some(b), _) => [Some(r), Some(g), Some(b), find("A")]
            .into_iter()
            .flatten()
            .collect(),
        (_, _, _, Some(y)) => [Some(y), find("A")].into_iter().flatten().collect(),
        _ => {
            let names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
            return Err(SceneError::file(
                path,
                format!(
                    "EXR has no R,G,B or Y channels (it has: {})",
                    names.join(", ")
                ),
            ));
        }
    };
    let mut image = Image::new(width, height, selected.len());
    for (c, channel) in selected.iter().enumerate() {
        if channel.sample_data.len() != width * height {
            return Err(SceneError::file(
                path,
                format!("EXR channel {} is subsampled", channel.name),
            ));
        }
        for (i, value) in channel.sample_data.values_as_f32().enumerate() {
            image.data[i * image.channels + c] = value;
        }
    }
    Ok(image)
}

/// Reads PNG, JPEG or HDR through the `image` crate.
fn read_with_image_crate(path: &Path, color: ColorHandling) -> Result<Image, SceneError> {
    Ok(dynamic_to_linear(&decode_with_image_crate(path)?, color))
}

/// Decodes PNG, JPEG, HDR, BMP or TGA through the `image` crate.
fn decode_with_image_crate(path: &Path) -> Result<image::DynamicImage, SceneError> {
    let reader = image::ImageReader::open(path)
        .map_err(|e| io_error(path, e))?
        .with_guessed_format()
        .map_err(|e| io_error(path, e))?;
    if reader.format().is_none() {
        return Err(SceneError::file(
            path,
            "unsupported image format (supported: exr, hdr, pfm, png, jpg/jpeg, bmp, tga)",
        ));
    }
    // The header's size, checked before anything is decoded; the decoder's
    // own allocation cap (512 MiB by default) is the texel limit's instead.
    let mut reader = reader;
    let mut limits = image::Limits::default();
    let file_len = std::fs::metadata(path)
        .map_err(|e| io_error(path, e))?
        .len();
    limits.max_alloc = Some(Limit::TexturePixels.get().saturating_mul(16));
    reader.limits(limits);
    let cannot = |e: image::ImageError| SceneError::file(path, format!("cannot decode image: {e}"));
    let decoder = reader.into_decoder().map_err(cannot)?;
    let (width, height) = image::ImageDecoder::dimensions(&decoder);
    check_texels(path, width as usize, height as usize)?;
    // At least one byte per texel, whatever the format.
    check_decoded_size(path, file_len, u64::from(width) * u64::from(height))?;
    image::DynamicImage::from_decoder(decoder).map_err(cannot)
}

/// Converts a decoded image to `f32`, keeping its channel count and
/// linearising integer colour channels as `color` says.
fn dynamic_to_linear(decoded: &image::DynamicImage, color: ColorHandling) -> Image {
    let color_type = decoded.color();
    let channels = usize::from(color_type.channel_count());
    let has_alpha = color_type.has_alpha();
    let is_float = matches!(
        color_type,
        image::ColorType::Rgb32F | image::ColorType::Rgba32F
    );
    let data: Vec<f32> = match channels {
        1 => decoded.to_luma32f().into_raw(),
        2 => decoded.to_luma_alpha32f().into_raw(),
        3 => decoded.to_rgb32f().into_raw(),
        _ => decoded.to_rgba32f().into_raw(),
    };
    let mut image = Image {
        width: decoded.width() as usize,
        height: decoded.height() as usize,
        channels,
        data,
    };
    if color == ColorHandling::Srgb && !is_float {
        let color_channels = if has_alpha { channels - 1 } else { channels };
        for pixel in image.data.chunks_exact_mut(channels) {
            for v in &mut pixel[..color_channels] {
                *v = srgb_to_linear(*v);
            }
        }
    }
    image
}

/// The sRGB electro-optical transfer function (IEC 61966-2-1): encoded → linear.
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// The inverse sRGB transfer function: linear → encoded (not clamped).
pub fn linear_to_srgb(v: f32) -> f32 {
    if v <= 0.003_130_8 {
        v * 12.92
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// One layer of an EXR file for [`write_exr_layers`] and [`write_image`]:
/// its name (`""` for the main image), its channel suffixes (`None`: named
/// by channel count, see the module docs) and its pixels.
#[derive(Clone, Copy, Debug)]
pub struct ExrLayer<'a> {
    /// Layer name, the channel prefix (`""`: none).
    pub name: &'a str,
    /// Channel suffixes, one per image channel; `None` names them by count.
    pub channels: Option<&'a [String]>,
    /// The pixels.
    pub image: &'a Image,
}

impl<'a> ExrLayer<'a> {
    /// A layer whose channels are named by their count.
    pub fn new(name: &'a str, image: &'a Image) -> Self {
        Self {
            name,
            channels: None,
            image,
        }
    }
}

/// Writes `layers` as one single-part EXR: the layer named `""` as `R`,`G`,`B`,
/// the others as `name.R`, … (see the module docs). All layers must have the
/// same size.
pub fn write_exr(path: &Path, layers: &[(&str, &Image)]) -> Result<(), SceneError> {
    let layers: Vec<ExrLayer> = layers
        .iter()
        .map(|&(name, image)| ExrLayer::new(name, image))
        .collect();
    write_exr_layers(path, &layers)
}

/// [`write_exr`] with explicit channel suffixes: a layer `name` with
/// suffixes `["X", "Y", "Z"]` is written as `name.X`, `name.Y`, `name.Z`
/// (the main layer `""` as `X`, `Y`, `Z`).
pub fn write_exr_layers(path: &Path, layers: &[ExrLayer]) -> Result<(), SceneError> {
    let (width, height) = check_exr_layers(path, layers)?;
    let mut channels =
        exr::prelude::SmallVec::<[exr::prelude::AnyChannel<exr::prelude::FlatSamples>; 4]>::new();
    for layer in layers {
        let (name, image) = (layer.name, layer.image);
        let suffixes = match layer.channels {
            Some(names) if names.len() == image.channels => names.to_vec(),
            Some(names) => {
                return Err(SceneError::file(
                    path,
                    format!(
                        "layer '{name}' has {} channels but {} channel names",
                        image.channels,
                        names.len()
                    ),
                ))
            }
            None => channel_names(image.channels),
        };
        for (c, suffix) in suffixes.iter().enumerate() {
            let full_name = if name.is_empty() {
                suffix.clone()
            } else {
                format!("{name}.{suffix}")
            };
            if channels.iter().any(|ch| ch.name.to_string() == full_name) {
                return Err(SceneError::file(
                    path,
                    format!("two channels are named '{full_name}'"),
                ));
            }
            let text = exr::prelude::Text::new_or_none(&full_name).ok_or_else(|| {
                SceneError::file(
                    path,
                    format!("EXR channel name '{full_name}' is not Latin-1"),
                )
            })?;
            let samples = image
                .data
                .iter()
                .skip(c)
                .step_by(image.channels)
                .copied()
                .collect();
            channels.push(exr::prelude::AnyChannel::new(
                text,
                exr::prelude::FlatSamples::F32(samples),
            ));
        }
    }
    let layer = exr::prelude::Layer::new(
        (width, height),
        exr::prelude::LayerAttributes::default(),
        exr::prelude::Encoding::SMALL_LOSSLESS,
        exr::prelude::AnyChannels::sort(channels),
    );
    let exr_image = exr::prelude::Image::from_layer(layer);
    write_atomically(path, |tmp| {
        use exr::prelude::WritableImage;
        exr_image
            .write()
            .to_file(tmp)
            .map_err(|e| exr_error(path, e))
    })
}

/// Checks that the layers are non-empty, consistent, equally sized and
/// uniquely named; returns their size.
fn check_exr_layers(path: &Path, layers: &[ExrLayer]) -> Result<(usize, usize), SceneError> {
    let Some(first) = layers.first().map(|l| l.image) else {
        return Err(SceneError::file(path, "no image to write"));
    };
    for (i, &ExrLayer { name, image, .. }) in layers.iter().enumerate() {
        check_writable(path, image)?;
        if (image.width, image.height) != (first.width, first.height) {
            return Err(SceneError::file(
                path,
                format!(
                    "layer '{name}' is {}×{}, the image is {}×{}",
                    image.width, image.height, first.width, first.height
                ),
            ));
        }
        if layers[..i].iter().any(|other| other.name == name) {
            return Err(SceneError::file(
                path,
                format!("two layers are named '{name}'"),
            ));
        }
    }
    Ok((first.width, first.height))
}

/// Rejects empty images and images whose data doesn't match their size.
fn check_writable(path: &Path, image: &Image) -> Result<(), SceneError> {
    if image.width == 0 || image.height == 0 || image.channels == 0 {
        return Err(SceneError::file(path, "cannot write an empty image"));
    }
    if !image.is_consistent() {
        return Err(SceneError::file(
            path,
            format!(
                "image data has {} values, {}×{}×{} expected",
                image.data.len(),
                image.width,
                image.height,
                image.channels
            ),
        ));
    }
    Ok(())
}

/// EXR channel names for an image with `channels` channels.
fn channel_names(channels: usize) -> Vec<String> {
    let fixed: &[&str] = match channels {
        1 => &["Y"],
        2 => &["Y", "A"],
        3 => &["R", "G", "B"],
        4 => &["R", "G", "B", "A"],
        _ => &[],
    };
    if fixed.is_empty() {
        (0..channels).map(|c| c.to_string()).collect()
    } else {
        fixed.iter().map(|s| s.to_string()).collect()
    }
}

/// Writes an 8-bit sRGB PNG: grey, grey+alpha, RGB or RGBA by channel count.
pub fn write_png(path: &Path, img: &Image) -> Result<(), SceneError> {
    write_8bit(path, img, true, image::ImageFormat::Png)
}

/// Writes display values (already encoded for the display, as a view
/// transform leaves them) as an 8-bit PNG or JPEG, by the extension of
/// `path`: each value clamped to [0, 1] and rounded, nothing else done.
pub fn write_display_image(path: &Path, img: &Image) -> Result<(), SceneError> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let format = match extension.as_deref() {
        Some("png") => image::ImageFormat::Png,
        Some("jpg" | "jpeg") if img.channels != 2 && img.channels != 4 => image::ImageFormat::Jpeg,
        Some("jpg" | "jpeg") => return Err(SceneError::file(path, "JPEG cannot hold alpha")),
        _ => {
            return Err(SceneError::file(
                path,
                "display images are written as .png or .jpg",
            ))
        }
    };
    write_8bit(path, img, false, format)
}

fn write_8bit(
    path: &Path,
    img: &Image,
    srgb_encode: bool,
    format: image::ImageFormat,
) -> Result<(), SceneError> {
    check_writable(path, img)?;
    let color_type = match img.channels {
        1 => image::ColorType::L8,
        2 => image::ColorType::La8,
        3 => image::ColorType::Rgb8,
        4 => image::ColorType::Rgba8,
        n => {
            return Err(SceneError::file(
                path,
                format!("an 8-bit image cannot hold {n} channels (1 to 4)"),
            ))
        }
    };
    let (Ok(width), Ok(height)) = (u32::try_from(img.width), u32::try_from(img.height)) else {
        return Err(SceneError::file(
            path,
            "image too large for an 8-bit format",
        ));
    };
    let bytes = encode_8bit(img, srgb_encode);
    write_atomically(path, |tmp| {
        image::save_buffer_with_format(tmp, &bytes, width, height, color_type, format).map_err(
            |e| match e {
                image::ImageError::IoError(source) => io_error(path, source),
                other => SceneError::file(path, format!("cannot write {format:?}: {other}")),
            },
        )
    })
}

/// The image as 8-bit values: colour sRGB-encoded if `srgb_encode`, alpha
/// linear.
fn encode_8bit(img: &Image, srgb_encode: bool) -> Vec<u8> {
    let has_alpha = img.channels == 2 || img.channels == 4;
    let color_channels = if has_alpha {
        img.channels - 1
    } else {
        img.channels
    };
    img.data
        .chunks_exact(img.channels)
        .flat_map(|pixel| {
            pixel.iter().enumerate().map(move |(c, &v)| {
                let encoded = if srgb_encode && c < color_channels {
                    linear_to_srgb(v)
                } else {
                    v
                };
                quantize_unit(encoded)
            })
        })
        .collect()
}

/// A value in [0, 1] (clamped; NaN → 0) as the nearest 8-bit level.
fn quantize_unit(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// Writes `img` in the format named by the extension of `path` (`.exr`, `.png`,
/// case-insensitive). `extra_layers` (AOVs) need EXR.
pub fn write_image(path: &Path, img: &Image, extra_layers: &[ExrLayer]) -> Result<(), SceneError> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match extension.as_deref() {
        Some("exr") => {
            let layers: Vec<ExrLayer> = std::iter::once(ExrLayer::new("", img))
                .chain(extra_layers.iter().copied())
                .collect();
            write_exr_layers(path, &layers)
        }
        Some("png") if extra_layers.is_empty() => write_png(path, img),
        Some("png") => Err(SceneError::file(
            path,
            "PNG cannot hold extra layers (AOVs); write an .exr file instead",
        )),
        _ => Err(SceneError::file(
            path,
            "unsupported output format (supported extensions: .exr, .png)",
        )),
    }
}

/// Runs `write` on a temporary path next to `path`, then renames the result
/// over `path`; removes the temporary if anything fails.
fn write_atomically(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), SceneError>,
) -> Result<(), SceneError> {
    let tmp = temporary_sibling(path);
    let result =
        write(&tmp).and_then(|()| std::fs::rename(&tmp, path).map_err(|e| io_error(path, e)));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// A fresh hidden file name in the directory of `path`.
fn temporary_sibling(path: &Path) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{}-{n}.tmp", std::process::id()))
}

/// An I/O error on `path`.
fn io_error(path: &Path, source: std::io::Error) -> SceneError {
    SceneError::Io {
        path: path.to_path_buf(),
        error: source,
    }
}

/// An `exr` crate error on `path`.
fn exr_error(path: &Path, e: exr::error::Error) -> SceneError {
    match e {
        exr::error::Error::Io(source) => io_error(path, source),
        other => SceneError::file(path, format!("EXR: {other}")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A B44-compressed EXR (lossy 16-bit floats, decoded on this thread
    /// under a panic guard) reads as written, to half precision.
    #[test]
    fn b44_exr_reads_back() {
        use exr::prelude::*;
        let path = temp_path("exr");
        let (w, h) = (8usize, 8usize);
        let value = |x: usize, y: usize, c: usize| 0.25 + 0.01 * (x + 2 * y + 3 * c) as f32;
        let channels = SpecificChannels::rgb(|Vec2(x, y)| {
            (
                f16::from_f32(value(x, y, 0)),
                f16::from_f32(value(x, y, 1)),
                f16::from_f32(value(x, y, 2)),
            )
        });
        let layer = Layer::new(
            (w, h),
            LayerAttributes::named("rgb"),
            Encoding {
                compression: Compression::B44,
                ..Encoding::default()
            },
            channels,
        );
        Image::from_layer(layer).write().to_file(&path).unwrap();
        let img = read_image(&path, ColorHandling::Raw).unwrap();
        std::fs::remove_file(&path).ok();
        assert_eq!((img.width, img.height, img.channels), (w, h, 3));
        for y in 0..h {
            for x in 0..w {
                for c in 0..3 {
                    let got = img.data[img.index(x, y, c)];
                    assert!(
                        (got - value(x, y, c)).abs() < 0.01,
                        "({x}, {y}, {c}): {got}"
                    );
                }
            }
        }
    }

    /// A fresh, not yet existing path in the temp directory.
    fn temp_path(extension: &str) -> PathBuf {
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        std::env::temp_dir().join(format!(
            "yubin-image-test-{}-{n}.{extension}",
            std::process::id()
        ))
    }

    /// A test image with a different value in every channel of every pixel.
    fn gradient(width: usize, height: usize, channels: usize) -> Image {
        let mut img = Image::new(width, height, channels);
        for (i, v) in img.data.iter_mut().enumerate() {
            *v = (i as f32 * 0.37).fract();
        }
        img
    }

    #[test]
    fn helpers_index_interleaved_rows() {
        let mut img = Image::new(3, 2, 3);
        img.set(2, 1, 1, 5.0);
        assert_eq!(img.data[(3 + 2) * 3 + 1], 5.0);
        assert_eq!(img.get(2, 1, 1), 5.0);
        assert_eq!(img.rgb(2, 1), [0.0, 5.0, 0.0]);
        let mut grey = Image::new(1, 1, 1);
        grey.set(0, 0, 0, 0.5);
        assert_eq!(grey.rgb(0, 0), [0.5; 3]);
    }

    #[test]
    fn srgb_curves_are_inverse() {
        for i in 0..=100 {
            let v = i as f32 / 100.0;
            assert!((srgb_to_linear(linear_to_srgb(v)) - v).abs() < 1e-5, "{v}");
        }
        assert!((srgb_to_linear(0.5) - 0.214_041).abs() < 1e-5);
    }

    #[test]
    fn exr_round_trip_is_bit_exact() {
        let path = temp_path("exr");
        let mut img = gradient(7, 5, 3);
        let specials = [-0.0, 1e-40, -3.5, 65504.0, 1e30, f32::MIN_POSITIVE, 0.1];
        img.data[..specials.len()].copy_from_slice(&specials);
        write_exr(&path, &[("", &img)]).unwrap();
        let back = read_image(&path, ColorHandling::Srgb).unwrap();
        let _ = std::fs::remove_file(&path);
        assert_eq!((back.width, back.height, back.channels), (7, 5, 3));
        let bits = |d: &[f32]| d.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back.data), bits(&img.data));
    }

    #[test]
    fn exr_layers_get_prefixed_channel_names() {
        let path = temp_path("exr");
        let main = gradient(4, 3, 4);
        let albedo = gradient(4, 3, 3);
        let depth = gradient(4, 3, 1);
        let t = ["T".to_string()];
        let depth_t = ExrLayer {
            channels: Some(&t),
            ..ExrLayer::new("dd", &depth)
        };
        write_image(
            &path,
            &main,
            &[
                ExrLayer::new("albedo", &albedo),
                ExrLayer::new("depth", &depth),
                depth_t,
            ],
        )
        .unwrap();
        let raw = exr::prelude::read_first_flat_layer_from_file(&path).unwrap();
        let back = read_image(&path, ColorHandling::Raw).unwrap();
        let _ = std::fs::remove_file(&path);
        let mut names: Vec<String> = raw
            .layer_data
            .channel_data
            .list
            .iter()
            .map(|c| c.name.to_string())
            .collect();
        names.sort();
        assert_eq!(
            names,
            ["A", "B", "G", "R", "albedo.B", "albedo.G", "albedo.R", "dd.T", "depth.Y"]
        );
        let bad = ExrLayer {
            channels: Some(&t),
            ..ExrLayer::new("x", &albedo)
        };
        let err = write_exr_layers(&path, &[ExrLayer::new("", &main), bad]).unwrap_err();
        assert!(err.to_string().contains("3 channels but 1"), "{err}");
        // Distinct layers whose full channel names coincide: "a.b" + "C"
        // and "a" + "b.C" are both "a.b.C".
        let (c, bc) = (["C".to_string()], ["b.C".to_string()]);
        let ab = ExrLayer {
            channels: Some(&c),
            ..ExrLayer::new("a.b", &depth)
        };
        let a = ExrLayer {
            channels: Some(&bc),
            ..ExrLayer::new("a", &depth)
        };
        let err = write_exr_layers(&path, &[ExrLayer::new("", &main), ab, a]).unwrap_err();
        assert!(
            err.to_string().contains("two channels are named 'a.b.C'"),
            "{err}"
        );
        assert!(!path.exists());
        assert_eq!(back, main);
    }

    #[test]
    fn exr_rejects_mismatched_layers() {
        let path = temp_path("exr");
        let err = write_exr(
            &path,
            &[("", &gradient(4, 3, 3)), ("x", &gradient(3, 3, 3))],
        )
        .unwrap_err();
        assert!(err.to_string().contains("layer 'x' is 3×3"), "{err}");
        let err =
            write_exr(&path, &[("", &gradient(4, 3, 3)), ("", &gradient(4, 3, 3))]).unwrap_err();
        assert!(err.to_string().contains("two layers"), "{err}");
        let bad = Image {
            data: vec![0.0; 5],
            ..gradient(4, 3, 3)
        };
        assert!(write_exr(&path, &[("", &bad)]).is_err());
        assert!(!path.exists());
    }

    #[test]
    fn png_round_trip_within_one_level() {
        for channels in [1, 3, 4] {
            let path = temp_path("png");
            let img = gradient(9, 4, channels);
            write_image(&path, &img, &[]).unwrap();
            let back = read_image(&path, ColorHandling::Srgb).unwrap();
            let _ = std::fs::remove_file(&path);
            assert_eq!((back.width, back.height, back.channels), (9, 4, channels));
            let alpha = channels == 4;
            for (i, (&a, &b)) in img.data.iter().zip(&back.data).enumerate() {
                let is_alpha = alpha && i % channels == 3;
                let (a, b) = if is_alpha {
                    (a, b)
                } else {
                    (linear_to_srgb(a), linear_to_srgb(b))
                };
                assert!(
                    (a - b).abs() <= 0.5 / 255.0 + 1e-6,
                    "channel {i}: {a} vs {b}"
                );
            }
        }
    }

    #[test]
    fn png_clamps_out_of_range_values() {
        let path = temp_path("png");
        let mut img = Image::new(3, 1, 1);
        img.data.copy_from_slice(&[-1.0, 7.0, f32::NAN]);
        write_png(&path, &img).unwrap();
        let back = read_image(&path, ColorHandling::Raw).unwrap();
        let _ = std::fs::remove_file(&path);
        assert_eq!(back.data, [0.0, 1.0, 0.0]);
    }

    #[test]
    fn raw_skips_the_srgb_decoding() {
        let path = temp_path("png");
        image::save_buffer(&path, &[128, 128, 128], 1, 1, image::ColorType::Rgb8).unwrap();
        let raw = read_image(&path, ColorHandling::Raw).unwrap();
        let srgb = read_image(&path, ColorHandling::Srgb).unwrap();
        let _ = std::fs::remove_file(&path);
        assert_eq!(raw.data, [128.0 / 255.0; 3]);
        assert!((srgb.data[0] - 0.215_861).abs() < 1e-5, "{}", srgb.data[0]);
    }

    #[test]
    fn hdr_is_read_as_linear() {
        let path = temp_path("hdr");
        let pixels =
            image::Rgb32FImage::from_raw(2, 1, vec![0.5, 2.0, 8.0, 0.25, 0.125, 1000.0]).unwrap();
        image::DynamicImage::ImageRgb32F(pixels)
            .save_with_format(&path, image::ImageFormat::Hdr)
            .unwrap();
        let back = read_image(&path, ColorHandling::Srgb).unwrap();
        let _ = std::fs::remove_file(&path);
        assert_eq!(back.channels, 3);
        assert_eq!(back.rgb(0, 0), [0.5, 2.0, 8.0]);
        assert!((back.get(1, 0, 2) - 1000.0).abs() < 8.0);
    }

    #[test]
    fn write_into_missing_directory_fails_and_leaves_nothing() {
        let dir = temp_path("d");
        let img = gradient(2, 2, 3);
        for name in ["out.exr", "out.png"] {
            let err = write_image(&dir.join(name), &img, &[]).unwrap_err();
            assert!(matches!(err, SceneError::Io { .. }), "{err}");
            assert!(!dir.exists());
        }
    }

    #[test]
    fn failed_rename_removes_the_temporary() {
        let dir = temp_path("d");
        let target = dir.join("out.exr");
        std::fs::create_dir_all(target.join("occupied")).unwrap();
        let result = write_image(&target, &gradient(2, 2, 3), &[]);
        let entries: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .flatten()
            .map(|e| e.file_name())
            .collect();
        let _ = std::fs::remove_dir_all(&dir);
        assert!(result.is_err());
        assert_eq!(entries, ["out.exr"]);
    }

    #[test]
    fn unsupported_extension_lists_the_supported_ones() {
        let path = temp_path("bmp");
        let err = write_image(&path, &gradient(2, 2, 3), &[]).unwrap_err();
        assert!(err.to_string().contains(".exr, .png"), "{err}");
        assert!(!path.exists());
        let err = write_image(
            &temp_path("png"),
            &gradient(2, 2, 3),
            &[ExrLayer::new("x", &gradient(2, 2, 3))],
        )
        .unwrap_err();
        assert!(err.to_string().contains("AOVs"), "{err}");
    }

    #[test]
    fn unreadable_inputs_are_errors() {
        let missing = temp_path("png");
        assert!(matches!(
            read_image(&missing, ColorHandling::Srgb),
            Err(SceneError::Io { .. })
        ));
        for (extension, expected) in [
            ("dat", "unsupported image format"),
            ("png", "cannot decode"),
        ] {
            let path = temp_path(extension);
            std::fs::write(&path, b"this is not an image").unwrap();
            let err = read_image(&path, ColorHandling::Srgb).unwrap_err();
            let _ = std::fs::remove_file(&path);
            assert!(err.to_string().contains(expected), "{err}");
        }
        let path = temp_path("exr");
        std::fs::write(&path, [0x76, 0x2f, 0x31, 0x01, 2, 0]).unwrap();
        let err = read_image(&path, ColorHandling::Srgb).unwrap_err();
        let _ = std::fs::remove_file(&path);
        assert!(err.to_string().contains(&*path.to_string_lossy()), "{err}");
    }

    #[test]
    fn shared_reference_exrs_read() {
        let files = [
            "mitsuba-data/tests/scenes/instancing/refs/test_instancing_ref_rgb.exr",
            "mitsuba-data/tests/scenes/instancing/refs/test_instancing_ref_rgb_var.exr",
            "assets/cornell-box-bitterli/TungstenRender.exr",
        ];
        for file in files {
            let full = crate::shared_path(file);
            let path = full.as_path();
            if !path.exists() {
                println!(
                    "skipped: {} not found (../shared is absent)",
                    path.display()
                );
                continue;
            }
            let img = read_image(path, ColorHandling::Srgb).unwrap_or_else(|e| panic!("{e}"));
            assert!(
                img.width > 0 && img.height > 0 && img.channels >= 3,
                "{file}"
            );
            assert!(img.data.iter().all(|v| v.is_finite()), "{file}");
            let mean = img.data.iter().map(|&v| f64::from(v)).sum::<f64>() / img.data.len() as f64;
            assert!(mean > 0.0, "{file}: black image");
            println!(
                "{file}: {}×{}×{}, mean {mean:.4}",
                img.width, img.height, img.channels
            );
        }
    }
}
