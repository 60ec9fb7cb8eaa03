//! `ldsampler`: the low-discrepancy sampler of Mitsuba (Kollig and Keller
//! 2002, "Efficient Multidimensional Sampling"): every 2D dimension pair
//! is a (0, 2)-sequence in base 2 — the van der Corput sequence against
//! Sobol's second dimension, so that N = 2ᵐ samples put exactly one point
//! in every elementary interval of area 1/N (every 2ᵃ × 2ᵇ grid with
//! a + b = m) — randomized by random digit scrambling (an XOR of the
//! binary digits), and the pairs decorrelated by shuffling the samples'
//! order per pair ("padding"). 1D dimensions are scrambled, shuffled van
//! der Corput points.
//!
//! | parameter      | type    | default | meaning                                         |
//! |----------------|---------|---------|-------------------------------------------------|
//! | `sample_count` | integer | 4       | samples per pixel (rounded up to a power of 2)  |
//!
//! ```xml
//! <sampler type="ldsampler"><integer name="sample_count" value="16"/></sampler>
//! ```
//!
//! Scrambles and shuffles (Kensler's hash permutations) are keyed by
//! pixel, dimension and seed: values are a pure function of (pixel, sample
//! index, dimension, seed).

use super::{hash_u32, permute, Sampler};
use crate::params::{ParamError, Params};
use glam::Vec2;

/// (0, 2)-sequence samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LdSampler {
    /// Samples in the pattern (a power of two).
    pub sample_count: u32,
}

/// Builds the sampler from its scene parameters.
pub(super) fn from_params(p: &mut dyn Params, sample_count: u32) -> Result<Sampler, ParamError> {
    let rounded = sample_count.next_power_of_two();
    if rounded != sample_count {
        p.warn(
            Some("sample_count"),
            &format!(
                "ldsampler takes a power of two: {rounded} samples per pixel, not {sample_count}"
            ),
        );
    }
    Ok(Sampler::LdSampler(LdSampler {
        sample_count: rounded,
    }))
}

/// The van der Corput radical inverse of `i` in base 2, as 32 bits.
#[inline]
fn van_der_corput(i: u32) -> u32 {
    i.reverse_bits()
}

/// Sobol's second dimension of `i`, as 32 bits: the generator matrix is
/// Pascal's triangle mod 2 (each bit of i adds v, then v ^= v >> 1).
#[inline]
fn sobol_second(mut i: u32) -> u32 {
    let (mut v, mut r) = (1u32 << 31, 0u32);
    while i != 0 {
        if i & 1 != 0 {
            r ^= v;
        }
        i >>= 1;
        v ^= v >> 1;
    }
    r
}

/// 32 bits as a float in [0, 1).
#[inline]
fn unit(bits: u32) -> f32 {
    super::bits_to_unit_f32(bits)
}

impl LdSampler {
    /// Dimension value of pattern sample `i` under `key`.
    #[inline]
    pub(super) fn sample_1d(&self, i: u32, key: u32) -> f32 {
        let i = permute(i, self.sample_count, key);
        unit(van_der_corput(i) ^ hash_u32(key ^ 0x5bd1_e995))
    }

    /// Dimension pair of pattern sample `i` under `key`.
    #[inline]
    pub(super) fn sample_2d(&self, i: u32, key: u32) -> Vec2 {
        let i = permute(i, self.sample_count, key);
        Vec2::new(
            unit(van_der_corput(i) ^ hash_u32(key ^ 0x5bd1_e995)),
            unit(sobol_second(i) ^ hash_u32(key ^ 0x1b87_3593)),
        )
    }
}
