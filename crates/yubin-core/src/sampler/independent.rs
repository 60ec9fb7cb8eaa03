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

use super::{bits_to_unit_f32, hash_u32};

/// Independent uniform samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Independent {
    /// Samples per pixel.
    pub sample_count: u32,
}

/// The key of sample `index` of the pixel with key `pixel_key`.
#[inline]
pub(crate) fn sample_key(pixel_key: u32, index: u32) -> u32 {
    hash_u32(pixel_key ^ hash_u32(index.wrapping_add(0x9e37_79b9)))
}

/// The value of dimension `dim` of the sample with key `sample_key`: one
/// hash of the key advanced by `dim` steps of a Weyl sequence (the
/// golden-ratio increment keeps consecutive inputs far apart in bits).
#[inline]
pub(crate) fn sample(sample_key: u32, dim: u32) -> f32 {
    bits_to_unit_f32(hash_u32(
        sample_key.wrapping_add(dim.wrapping_mul(0x9e37_79b9)),
    ))
}
