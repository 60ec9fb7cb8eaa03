//! `multijitter`: correlated multi-jittered sampling (Kensler 2013,
//! "Correlated Multi-Jittered Sampling", Pixar technical memo 13-01), as
//! Mitsuba 3's `multijitter`. The sample count is rounded up to m × n
//! (n = ⌈√count⌉); every 2D dimension pair is jittered on the m × n grid
//! and, at once, stratified into m·n strata along each axis (Latin
//! hypercube), the sub-strata shuffled by one permutation per row and
//! column ("correlated"); 1D dimensions put one sample in each of their
//! m·n strata.
//!
//! | parameter      | type    | default | meaning                                   |
//! |----------------|---------|---------|-------------------------------------------|
//! | `sample_count` | integer | 4       | samples per pixel (rounded up to m × n)   |
//! | `jitter`       | boolean | true    | jitter inside the sub-strata (else centres) |
//!
//! ```xml
//! <sampler type="multijitter"><integer name="sample_count" value="16"/></sampler>
//! ```
//!
//! The permutations are Kensler's hash permutations keyed by pixel,
//! dimension and seed, so values are a pure function of (pixel, sample
//! index, dimension, seed).

use super::{jitter_of, permute, stratified_1d, Sampler};
use crate::params::{ParamError, Params};
use glam::Vec2;

/// Correlated multi-jittered samples on an m × n grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MultiJitter {
    /// Columns.
    pub m: u32,
    /// Rows.
    pub n: u32,
    /// Jitter inside the sub-strata.
    pub jitter: bool,
}

/// Builds the sampler from its scene parameters.
pub(super) fn from_params(p: &mut dyn Params, sample_count: u32) -> Result<Sampler, ParamError> {
    let n = (sample_count as f64).sqrt().ceil() as u32;
    let m = sample_count.div_ceil(n);
    if m * n != sample_count {
        p.warn(
            Some("sample_count"),
            &format!(
                "multijitter uses an {m} × {n} grid: {} samples per pixel, not {sample_count}",
                m * n
            ),
        );
    }
    Ok(Sampler::MultiJitter(MultiJitter {
        m,
        n,
        jitter: p.boolean_or("jitter", true)?,
    }))
}

impl MultiJitter {
    /// Dimension value of pattern sample `i` under `key`.
    #[inline]
    pub(super) fn sample_1d(&self, i: u32, key: u32) -> f32 {
        stratified_1d(i, self.m * self.n, self.jitter, key)
    }

    /// Dimension pair of pattern sample `i` under `key` (Kensler's
    /// construction: cell (s mod m, s div m), sub-strata from the other
    /// axis's permuted index).
    #[inline]
    pub(super) fn sample_2d(&self, i: u32, key: u32) -> Vec2 {
        let (m, n) = (self.m, self.n);
        let s = permute(i, m * n, key.wrapping_mul(0x51633e2d));
        let sx = permute(s % m, m, key.wrapping_mul(0x68bc21eb));
        let sy = permute(s / m, n, key.wrapping_mul(0x02e5be93));
        let jx = jitter_of(self.jitter, key, i, 1);
        let jy = jitter_of(self.jitter, key, i, 2);
        Vec2::new(
            ((s % m) as f32 + (sy as f32 + jx) / n as f32) / m as f32,
            ((s / m) as f32 + (sx as f32 + jy) / m as f32) / n as f32,
        )
    }
}
