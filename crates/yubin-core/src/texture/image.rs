//! Texture images as the scene stores them: 8-bit images keep one byte per
//! channel (a 4096² RGB map is 48 MiB, not 192 MiB as f32), others keep
//! `f32`. Pixels are row-major, top row first. sRGB-encoded data is decoded
//! per texel at lookup (unless a texture is `raw`), so bilinear filtering
//! blends linear values.

use glam::Vec4;
use std::sync::LazyLock;

/// The pixel storage of a [`TexImage`].
#[derive(Clone, Debug, PartialEq)]
pub enum ImageData {
    /// 8 bits per channel, as stored in the file.
    U8(Vec<u8>),
    /// Floating-point values.
    F32(Vec<f32>),
}

/// An image a texture reads.
#[derive(Clone, Debug, PartialEq)]
pub struct TexImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Channels per pixel (1 to 4).
    pub channels: u32,
    /// The pixels.
    pub data: ImageData,
    /// The colour channels are sRGB-encoded (8- and 16-bit PNG and JPEG):
    /// textures decode them unless told the data is `raw`. Alpha is never
    /// encoded.
    pub encoded: bool,
    /// Per-channel means of the raw values (bytes scaled to [0, 1]).
    pub mean_raw: [f32; 4],
    /// Per-channel means after sRGB decoding of encoded data (equal to
    /// `mean_raw` otherwise).
    pub mean_linear: [f32; 4],
}

/// The 256 sRGB-encoded byte values, decoded (IEC 61966-2-1).
static SRGB_TO_LINEAR: LazyLock<[f32; 256]> =
    LazyLock::new(|| std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0)));

/// The sRGB transfer function, inverted.
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

impl TexImage {
    /// An image of `channels` (1 to 4) per pixel, its colour channels
    /// sRGB-encoded when `encoded`; `None` when the sizes do not match or
    /// the image is empty.
    pub fn new(
        width: u32,
        height: u32,
        channels: u32,
        data: ImageData,
        encoded: bool,
    ) -> Option<Self> {
        let n = width as usize * height as usize * channels as usize;
        let len = match &data {
            ImageData::U8(d) => d.len(),
            ImageData::F32(d) => d.len(),
        };
        if n == 0 || len != n || !(1..=4).contains(&channels) {
            return None;
        }
        let mut img = Self {
            width,
            height,
            channels,
            data,
            encoded,
            mean_raw: [0.0; 4],
            mean_linear: [0.0; 4],
        };
        img.mean_raw = img.channel_means(false);
        img.mean_linear = img.channel_means(true);
        Some(img)
    }

    fn channel_means(&self, decode: bool) -> [f32; 4] {
        let mut sum = [0.0f64; 4];
        let c = self.channels as usize;
        let pixels = (self.width * self.height) as usize;
        for i in 0..pixels {
            for (k, s) in sum.iter_mut().enumerate().take(c) {
                *s += self.value(i * c + k, decode) as f64;
            }
        }
        sum.map(|s| (s / pixels as f64) as f32)
    }

    #[inline]
    fn value(&self, index: usize, decode: bool) -> f32 {
        let decode = decode && self.encoded;
        match &self.data {
            ImageData::U8(d) if decode => SRGB_TO_LINEAR[d[index] as usize],
            ImageData::U8(d) => d[index] as f32 * (1.0 / 255.0),
            ImageData::F32(d) if decode => srgb_to_linear(d[index]),
            ImageData::F32(d) => d[index],
        }
    }

    /// The texel at column `x`, row `y` (in range), as RGBA: a one-channel
    /// image fills RGB with its value; missing alpha is 1. Encoded colour
    /// values are sRGB-decoded when `decode`.
    #[inline(always)]
    pub fn texel(&self, x: u32, y: u32, decode: bool) -> Vec4 {
        let c = self.channels as usize;
        let i = (y as usize * self.width as usize + x as usize) * c;
        // Linear float RGB(A), what HDR maps hold: read straight through,
        // inline, without a per-channel match on the storage.
        if let (ImageData::F32(d), false, 3 | 4) = (&self.data, decode && self.encoded, c) {
            let a = if c == 4 { d[i + 3] } else { 1.0 };
            return Vec4::new(d[i], d[i + 1], d[i + 2], a);
        }
        self.converted_texel(i, decode)
    }

    /// [`TexImage::texel`] of any other storage, from its first value's
    /// index `i`.
    #[inline(never)]
    fn converted_texel(&self, i: usize, decode: bool) -> Vec4 {
        match self.channels {
            1 => {
                let v = self.value(i, decode);
                Vec4::new(v, v, v, 1.0)
            }
            2 => {
                let v = self.value(i, decode);
                Vec4::new(v, v, v, self.value(i + 1, false))
            }
            3 => Vec4::new(
                self.value(i, decode),
                self.value(i + 1, decode),
                self.value(i + 2, decode),
                1.0,
            ),
            _ => Vec4::new(
                self.value(i, decode),
                self.value(i + 1, decode),
                self.value(i + 2, decode),
                self.value(i + 3, false),
            ),
        }
    }

    /// Asks the cache for the texel at column `x`, row `y` (a hint only;
    /// nothing off x86-64 or out of range).
    #[inline]
    pub fn prefetch(&self, x: u32, y: u32) {
        let i = (y as usize * self.width as usize + x as usize) * self.channels as usize;
        #[cfg(target_arch = "x86_64")]
        match &self.data {
            ImageData::F32(d) => {
                if let Some(v) = d.get(i) {
                    safe_arch::prefetch_t0(v);
                }
            }
            ImageData::U8(d) => {
                if let Some(v) = d.get(i) {
                    safe_arch::prefetch_t0(v);
                }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = i;
    }

    /// Bytes of pixel memory.
    pub fn memory_bytes(&self) -> usize {
        match &self.data {
            ImageData::U8(d) => d.len(),
            ImageData::F32(d) => d.len() * 4,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_decoding_matches_the_standard() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        // 0.5 encoded is 0.2140 linear (IEC 61966-2-1).
        assert!((srgb_to_linear(0.5) - 0.214_041).abs() < 1e-5);
    }

    #[test]
    fn texels_and_means() {
        let img = TexImage::new(2, 1, 3, ImageData::U8(vec![255, 128, 0, 0, 0, 0]), true).unwrap();
        let t = img.texel(0, 0, true);
        assert!((t.y - srgb_to_linear(128.0 / 255.0)).abs() < 1e-6);
        assert_eq!(img.texel(0, 0, false).x, 1.0);
        assert!((img.mean_raw[0] - 0.5).abs() < 1e-6);
        assert!(TexImage::new(2, 2, 3, ImageData::U8(vec![0; 3]), true).is_none());
        let grey = TexImage::new(1, 1, 1, ImageData::F32(vec![0.25]), false).unwrap();
        assert_eq!(grey.texel(0, 0, true), Vec4::new(0.25, 0.25, 0.25, 1.0));
    }
}
