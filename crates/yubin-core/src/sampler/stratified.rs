//! `stratified`: jittered stratification (Mitsuba 3's). The sample count
//! is rounded up to a square n²; every 1D dimension puts one sample in
//! each of its n² strata, and every 2D dimension pair one sample in each
//! cell of an n × n grid, with the strata of each dimension assigned to
//! samples by an independent random permutation.
//!
//! | parameter      | type    | default | meaning                                   |
//! |----------------|---------|---------|-------------------------------------------|
//! | `sample_count` | integer | 4       | samples per pixel (rounded up to a square) |
//! | `jitter`       | boolean | true    | jitter inside the strata (else centres)   |
//!
//! ```xml
//! <sampler type="stratified"><integer name="sample_count" value="16"/></sampler>
//! ```
//!
//! Values are a pure function of (pixel, sample index, dimension, seed):
//! the permutations are Kensler's hash permutations (2013, "Correlated
//! Multi-Jittered Sampling"), keyed by pixel, dimension and seed. A render
//! with more samples than the pattern renders it again with new keys.

use super::{jitter_of, permute, rounded_square_side, stratified_1d, Sampler};
use crate::params::{ParamError, Params};
use glam::Vec2;

/// Jittered stratified samples on an n × n pattern.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stratified {
    /// Strata per side (the pattern has `side²` samples).
    pub side: u32,
    /// Jitter inside the strata.
    pub jitter: bool,
}

/// Builds the sampler from its scene parameters.
pub(super) fn from_params(p: &mut dyn Params, sample_count: u32) -> Result<Sampler, ParamError> {
    Ok(Sampler::Stratified(Stratified {
        side: rounded_square_side(p, sample_count),
        jitter: p.boolean_or("jitter", true)?,
    }))
}

impl Stratified {
    /// Dimension value of pattern sample `i` under `key`.
    #[inline]
    pub(super) fn sample_1d(&self, i: u32, key: u32) -> f32 {
        stratified_1d(i, self.side * self.side, self.jitter, key)
    }

    /// Dimension pair of pattern sample `i` under `key`.
    #[inline]
    pub(super) fn sample_2d(&self, i: u32, key: u32) -> Vec2 {
        let n = self.side;
        let cell = permute(i, n * n, key);
        Vec2::new(
            ((cell % n) as f32 + jitter_of(self.jitter, key, i, 1)) / n as f32,
            ((cell / n) as f32 + jitter_of(self.jitter, key, i, 2)) / n as f32,
        )
    }
}
