//! `orthogonal`: orthogonal-array sampling (Jarosz et al. 2019,
//! "Orthogonal Array Sampling for Monte Carlo Rendering", EGSR), as
//! Mitsuba 3's `orthogonal`. The pattern has N = s^t samples, s prime and
//! t the array's `strength`: Bush's construction (1952) gives sample i,
//! with base-s digits a₀ … a_{t−1}, the stratum Σ aₖ jᵏ mod s in dimension
//! j, so that any t of the first s dimensions see every combination of
//! strata exactly once — the projections onto every t-dimensional face
//! are stratified, not only the pairs a 2D sampler stratifies. Inside its
//! stratum a sample takes one of N/s sub-strata ("multi-jittered"
//! offsets), so each dimension alone is stratified into N intervals.
//! Dimensions are used in blocks of s, each block with its own permutation
//! of the samples.
//!
//! | parameter      | type    | default | meaning                                          |
//! |----------------|---------|---------|--------------------------------------------------|
//! | `sample_count` | integer | 4       | samples per pixel (rounded up to s^t, s ≥ t prime) |
//! | `strength`     | integer | 2       | t: dimensions stratified jointly (2 to 4)        |
//! | `jitter`       | boolean | true    | jitter inside the sub-strata (else centres)      |
//!
//! ```xml
//! <sampler type="orthogonal"><integer name="sample_count" value="25"/></sampler>
//! ```
//!
//! Permutations are Kensler's hash permutations (2013) keyed by pixel,
//! dimension and seed: values are a pure function of (pixel, sample
//! index, dimension, seed).

use super::{jitter_of, permute, Sampler};
use crate::params::{ParamError, Params};

/// Orthogonal-array samples of strength `strength` in base `base`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orthogonal {
    /// s, a prime.
    pub base: u32,
    /// t.
    pub strength: u32,
    /// Jitter inside the sub-strata.
    pub jitter: bool,
}

/// Builds the sampler from its scene parameters.
pub(super) fn from_params(p: &mut dyn Params, sample_count: u32) -> Result<Sampler, ParamError> {
    let strength = p.integer_or("strength", 2)?;
    if !(2..=4).contains(&strength) {
        return Err(p.param_error("strength", &format!("must be 2, 3 or 4, not {strength}")));
    }
    let t = strength as u32;
    // Bush's construction needs s >= t (t dimensions among s).
    let mut base: u32 = t;
    while base.pow(t) < sample_count || !is_prime(base) {
        base += 1;
    }
    if base.pow(t) != sample_count {
        p.warn(
            Some("sample_count"),
            &format!(
                "an orthogonal array of strength {t} has a prime power of samples: {} = {base}^{t}, not {sample_count}",
                base.pow(t)
            ),
        );
    }
    Ok(Sampler::Orthogonal(Orthogonal {
        base,
        strength: t,
        jitter: p.boolean_or("jitter", true)?,
    }))
}

fn is_prime(n: u32) -> bool {
    n >= 2
        && (2..)
            .take_while(|d| d * d <= n)
            .all(|d| !n.is_multiple_of(d))
}

impl Orthogonal {
    /// Samples in the pattern.
    pub fn count(&self) -> u32 {
        self.base.pow(self.strength)
    }

    /// The stratum (before scrambling) of dimension `j` < s for the sample
    /// with index `i`: its digits as polynomial coefficients, evaluated
    /// at j (Bush 1952); one reduction mod s at the end (the sum stays
    /// below t·s^t, which fits in 64 bits).
    #[inline]
    pub(super) fn bush_stratum(&self, i: u32, j: u32) -> u32 {
        let s = self.base as u64;
        let (mut digits, mut value, mut power) = (i as u64, 0u64, 1u64);
        for _ in 0..self.strength {
            value += (digits % s) * power;
            digits /= s;
            power *= j as u64;
        }
        (value % s) as u32
    }

    /// The sample order of the block of s dimensions holding `dim`: the
    /// index pattern sample `i` takes there (what a stream caches for the
    /// block's dimensions).
    #[inline]
    pub(super) fn block_index(&self, i: u32, dim: u32, pixel_key: u32) -> u32 {
        let block_key = super::dimension_key(pixel_key ^ 0x0a7b_5c31, dim / self.base);
        permute(i, self.count(), block_key)
    }

    /// Dimension `dim` of the sample with index `i` in its block (from
    /// [`Orthogonal::block_index`]); `pixel_key` picks the permutations of
    /// the dimension's strata and sub-strata.
    #[inline]
    pub(super) fn sample(&self, i: u32, dim: u32, pixel_key: u32) -> f32 {
        let s = self.base;
        let key = super::dimension_key(pixel_key, dim);
        let stratum = permute(self.bush_stratum(i, dim % s), s, key);
        // Within a dimension's stratum the samples differ in digits 1…t−1:
        // those pick the sub-stratum.
        let sub_count = self.count() / s;
        let sub = permute(i / s, sub_count, key.wrapping_mul(0x9e37_79b9));
        let jitter = jitter_of(self.jitter, key, i, 0);
        (stratum as f32 + (sub as f32 + jitter) / sub_count as f32) / s as f32
    }
}
