//! `independent`: uniform, uncorrelated sample values.
//!
//! | parameter      | type    | default | meaning            |
//! |----------------|---------|---------|--------------------|
//! | `sample_count` | integer | 4       | samples per pixel  |
//!
//! ```xml
//! <sampler type="independent"><integer name="sample_count" value="64"/></sampler>
//! ```
//!
//! Values come from hashing (pixel key, sample index, dimension): a
//! counter-based generator, so any sample can be recomputed on its own.

use super::{bits_to_unit_f32, hash3};

/// Independent uniform samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Independent {
    /// Samples per pixel.
    pub sample_count: u32,
}

/// The value of dimension `dim` of sample `index` of the pixel with key
/// `pixel_key`.
#[inline]
pub(crate) fn sample(pixel_key: u32, index: u32, dim: u32) -> f32 {
    bits_to_unit_f32(hash3(pixel_key, index, dim.wrapping_mul(0x2c1b_3c6d)))
}
