//! Samplers. Every sample value is a pure function of
//! (pixel, sample index, dimension, seed), so an image does not depend on
//! how work is split over threads.
//!
//! A [`Sampler`] is the per-render configuration (`independent` or
//! `sobol`); [`Sampler::stream`] gives the [`SampleStream`] of one pixel
//! sample, which hands out dimensions in order.

mod independent;
mod sobol;

pub use independent::Independent;
pub use sobol::Sobol;

use crate::params::{plugin_of, ParamError, Params};
use glam::Vec2;

/// Builds a sampler plugin from its parameters and its sample count.
pub type SamplerFromParams = fn(&mut dyn Params, u32) -> Result<Sampler, ParamError>;

/// Every sampler plugin: its scene type string and constructor. Mitsuba's
/// stratified samplers render with the Sobol sampler, with a warning.
pub const PLUGINS: &[(&str, SamplerFromParams)] = &[
    ("independent", |_, sample_count| {
        Ok(Sampler::Independent(Independent { sample_count }))
    }),
    ("sobol", |_, sample_count| {
        Ok(Sampler::Sobol(Sobol { sample_count }))
    }),
    ("stratified", sobol_stand_in),
    ("multijitter", sobol_stand_in),
    ("orthogonal", sobol_stand_in),
    ("ldsampler", sobol_stand_in),
];

/// The Sobol sampler for one of Mitsuba's stratified samplers.
fn sobol_stand_in(p: &mut dyn Params, sample_count: u32) -> Result<Sampler, ParamError> {
    p.mark_ignored("jitter");
    p.mark_ignored("strength");
    let msg = format!(
        "sampler \"{}\" renders with yubin's Owen-scrambled Sobol sampler",
        p.plugin_type()
    );
    p.warn(None, &msg);
    Ok(Sampler::Sobol(Sobol { sample_count }))
}

/// The sampler of a render (a closed enum, dispatched by hand).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sampler {
    /// Uniform random numbers from a counter-based hash.
    Independent(Independent),
    /// Owen-scrambled Sobol (Burley 2020).
    Sobol(Sobol),
}

impl Default for Sampler {
    /// Mitsuba's default sampler: 4 independent samples per pixel.
    fn default() -> Self {
        Sampler::Independent(Independent { sample_count: 4 })
    }
}

impl Sampler {
    /// Builds the sampler `p` describes; returns it with its `seed`.
    pub fn from_params(p: &mut dyn Params) -> Result<(Self, u32), ParamError> {
        let sample_count = p.positive_integer_or("sample_count", 4)?;
        let seed = p.integer_or("seed", 0)? as u32;
        p.warn_ignored(
            &["light_samples"],
            "a Mitsuba 0.6 parameter; Mitsuba 3 has none",
        );
        let known =
            "independent, sobol (stratified, multijitter, orthogonal and ldsampler map to sobol)";
        let build = plugin_of(p, "sampler", PLUGINS, Some(known))?;
        Ok((build(p, sample_count)?, seed))
    }

    /// Samples per pixel.
    pub fn sample_count(&self) -> u32 {
        match self {
            Sampler::Independent(s) => s.sample_count,
            Sampler::Sobol(s) => s.sample_count,
        }
    }

    /// The same sampler with another sample count.
    pub fn with_sample_count(mut self, spp: u32) -> Self {
        match &mut self {
            Sampler::Independent(s) => s.sample_count = spp,
            Sampler::Sobol(s) => s.sample_count = spp,
        }
        self
    }

    /// The stream of sample `index` of pixel `(x, y)` under `seed`.
    #[inline]
    pub fn stream(&self, x: u32, y: u32, index: u32, seed: u32) -> SampleStream {
        let pixel_key = hash3(x, y, seed);
        SampleStream {
            kind: match self {
                Sampler::Independent(_) => StreamKind::Independent,
                Sampler::Sobol(_) => StreamKind::Sobol,
            },
            pixel_key,
            index,
            dim: 0,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum StreamKind {
    Independent,
    Sobol,
}

/// The sample values of one pixel sample, dimension after dimension.
#[derive(Clone, Copy, Debug)]
pub struct SampleStream {
    kind: StreamKind,
    pixel_key: u32,
    index: u32,
    dim: u32,
}

impl SampleStream {
    /// The next value in [0, 1).
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        let d = self.dim;
        self.dim += 1;
        match self.kind {
            StreamKind::Sobol if d < sobol::DIMENSIONS => {
                sobol::sample(self.index, d, self.pixel_key)
            }
            _ => independent::sample(self.pixel_key, self.index, d),
        }
    }

    /// The next two values.
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        let x = self.next_1d();
        Vec2::new(x, self.next_1d())
    }
}

/// A 32-bit integer hash with good avalanche (the "lowbias32" constants of
/// Chris Wellons' hash prospector).
#[inline]
pub fn hash_u32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// Hash of three words.
#[inline]
pub fn hash3(a: u32, b: u32, c: u32) -> u32 {
    hash_u32(a ^ hash_u32(b ^ hash_u32(c.wrapping_add(0x9e37_79b9))))
}

/// Maps 32 random bits to a float in [0, 1).
#[inline]
pub fn bits_to_unit_f32(bits: u32) -> f32 {
    (bits >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// O'Neill's PCG32 (XSH-RR) for tests and tools that need a plain stream
/// of random numbers.
#[derive(Clone, Debug)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    /// A generator from a seed and a stream selector.
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut r = Self {
            state: 0,
            inc: (stream << 1) | 1,
        };
        r.next_u32();
        r.state = r.state.wrapping_add(seed);
        r.next_u32();
        r
    }

    /// 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// A float in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        bits_to_unit_f32(self.next_u32())
    }

    /// Two floats in [0, 1).
    pub fn next_2d(&mut self) -> Vec2 {
        let x = self.next_f32();
        Vec2::new(x, self.next_f32())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn first_values(s: &Sampler, x: u32, y: u32, i: u32, seed: u32) -> Vec<f32> {
        let mut st = s.stream(x, y, i, seed);
        (0..401).map(|_| st.next_1d()).collect()
    }

    #[test]
    fn streams_are_pure_functions_of_their_key() {
        for s in [
            Sampler::Independent(Independent { sample_count: 4 }),
            Sampler::Sobol(Sobol { sample_count: 4 }),
        ] {
            assert_eq!(first_values(&s, 3, 4, 5, 6), first_values(&s, 3, 4, 5, 6));
            assert_ne!(first_values(&s, 3, 4, 5, 6), first_values(&s, 4, 3, 5, 6));
            assert_ne!(first_values(&s, 3, 4, 5, 6), first_values(&s, 3, 4, 5, 7));
            assert!(first_values(&s, 1, 2, 3, 4)
                .iter()
                .all(|v| (0.0..1.0).contains(v)));
        }
    }

    #[test]
    fn means_are_one_half() {
        for s in [
            Sampler::Independent(Independent { sample_count: 4 }),
            Sampler::Sobol(Sobol { sample_count: 4 }),
        ] {
            for dim in [0usize, 1, 7, 255, 256, 400] {
                let n = 4096;
                let mean: f64 = (0..n)
                    .map(|i| first_values(&s, 9, 2, i, 1)[dim] as f64)
                    .sum::<f64>()
                    / n as f64;
                assert!((mean - 0.5).abs() < 0.02, "dim {dim}: {mean}");
            }
        }
    }
}
