//! Samplers. Every sample value is a pure function of
//! (pixel, sample index, dimension, seed), so an image does not depend on
//! how work is split over threads.
//!
//! A [`Sampler`] is the per-render configuration; [`Sampler::stream`]
//! gives the [`SampleStream`] of one pixel sample, which hands out
//! dimensions in order (`next_1d`, or `next_2d` for a pair that the
//! stratifying samplers stratify jointly).
//!
//! The pattern samplers (`stratified`, `multijitter`, `orthogonal`,
//! `ldsampler`) stratify a pattern of a fixed size per pixel; a render
//! with more samples than the pattern draws it again, pass after pass,
//! under new keys (sample index i is sample i mod N of pass i div N).

mod independent;
mod ldsampler;
mod multijitter;
mod orthogonal;
mod sobol;
mod stratified;

pub use independent::Independent;
pub use ldsampler::LdSampler;
pub use multijitter::MultiJitter;
pub use orthogonal::Orthogonal;
pub use sobol::Sobol;
pub use stratified::Stratified;

use crate::params::{plugin_of, ParamError, Params};
use glam::Vec2;

/// Builds a sampler plugin from its parameters and its sample count.
pub type SamplerFromParams = fn(&mut dyn Params, u32) -> Result<Sampler, ParamError>;

/// Every sampler plugin: its scene type string and constructor.
pub const PLUGINS: &[(&str, SamplerFromParams)] = &[
    ("independent", |_, sample_count| {
        Ok(Sampler::Independent(Independent { sample_count }))
    }),
    ("sobol", |_, sample_count| {
        Ok(Sampler::Sobol(Sobol { sample_count }))
    }),
    ("stratified", stratified::from_params),
    ("multijitter", multijitter::from_params),
    ("orthogonal", orthogonal::from_params),
    ("ldsampler", ldsampler::from_params),
];

/// The side of the smallest square pattern with at least `sample_count`
/// samples, with a warning when it has more.
fn rounded_square_side(p: &mut dyn Params, sample_count: u32) -> u32 {
    let side = (sample_count as f64).sqrt().ceil() as u32;
    if side * side != sample_count {
        let msg = format!(
            "{} takes a square number of samples: {} per pixel, not {sample_count}",
            p.plugin_type(),
            side * side
        );
        p.warn(Some("sample_count"), &msg);
    }
    side
}

/// Kensler's permutation (2013, "Correlated Multi-Jittered Sampling",
/// §3): the image of `i` under a pseudo-random bijection of [0, l) that
/// `p` selects, computed without tables by cycle-walking an invertible
/// hash on the next power of two.
#[inline]
pub(crate) fn permute(mut i: u32, l: u32, p: u32) -> u32 {
    if l <= 1 {
        return 0;
    }
    let mut w = l - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    loop {
        i ^= p;
        i = i.wrapping_mul(0xe170_893d);
        i ^= p >> 16;
        i ^= (i & w) >> 4;
        i ^= p >> 8;
        i = i.wrapping_mul(0x0929_eb3f);
        i ^= p >> 23;
        i ^= (i & w) >> 1;
        i = i.wrapping_mul(1 | p >> 27);
        i = i.wrapping_mul(0x6935_fa69);
        i ^= (i & w) >> 11;
        i = i.wrapping_mul(0x74dc_b303);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0x9e50_1cc3);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0xc860_a3df);
        i &= w;
        i ^= i >> 5;
        if i < l {
            break;
        }
    }
    (i.wrapping_add(p)) % l
}

/// The key of dimension `d` under the (well-mixed) pixel key: one hash.
#[inline]
fn dimension_key(pixel_key: u32, d: u32) -> u32 {
    hash_u32(pixel_key.wrapping_add(d.wrapping_mul(0x9e37_79b9)))
}

/// Pattern sample `i` of a dimension cut into `count` strata, one sample
/// each, assigned by the permutation `key` selects.
#[inline]
fn stratified_1d(i: u32, count: u32, jitter: bool, key: u32) -> f32 {
    (permute(i, count, key) as f32 + jitter_of(jitter, key, i, 0)) / count as f32
}

/// A jitter in [0, 1) for sample `i` under `key` (`which` tells the
/// coordinates of one sample apart), or the stratum's centre without
/// jitter.
#[inline]
fn jitter_of(jitter: bool, key: u32, i: u32, which: u32) -> f32 {
    if jitter {
        bits_to_unit_f32(hash_u32(
            key ^ i.wrapping_mul(0x85eb_ca6b) ^ which.wrapping_mul(0xc2b2_ae35),
        ))
    } else {
        0.5
    }
}

/// The sampler of a render (a closed enum, dispatched by hand).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sampler {
    /// Uniform random numbers from a counter-based hash.
    Independent(Independent),
    /// Owen-scrambled Sobol (Burley 2020).
    Sobol(Sobol),
    /// Jittered strata (`stratified`).
    Stratified(Stratified),
    /// Correlated multi-jittered (`multijitter`).
    MultiJitter(MultiJitter),
    /// Orthogonal arrays (`orthogonal`).
    Orthogonal(Orthogonal),
    /// (0, 2)-sequences (`ldsampler`).
    LdSampler(LdSampler),
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
        let build = plugin_of(p, "sampler", PLUGINS, None)?;
        Ok((build(p, sample_count)?, seed))
    }

    /// Samples per pixel (of the pattern, for the pattern samplers).
    pub fn sample_count(&self) -> u32 {
        match self {
            Sampler::Independent(s) => s.sample_count,
            Sampler::Sobol(s) => s.sample_count,
            Sampler::Stratified(s) => s.side * s.side,
            Sampler::MultiJitter(s) => s.m * s.n,
            Sampler::Orthogonal(s) => s.count(),
            Sampler::LdSampler(s) => s.sample_count,
        }
    }

    /// The stream of sample `index` of pixel `(x, y)` under `seed`.
    #[inline]
    pub fn stream(&self, x: u32, y: u32, index: u32, seed: u32) -> SampleStream {
        self.pixel(x, y, seed).stream(index)
    }

    /// The streams of pixel `(x, y)`'s samples under `seed`: what they
    /// share, computed once for all of them.
    #[inline]
    pub fn pixel(&self, x: u32, y: u32, seed: u32) -> PixelStreams {
        let draws_patterns = !matches!(self, Sampler::Independent(_) | Sampler::Sobol(_));
        PixelStreams {
            sampler: *self,
            x,
            y,
            seed,
            // The pattern samplers key each pass anew.
            key: if draws_patterns { 0 } else { hash3(x, y, seed) },
        }
    }
}

/// Up to eight consecutive samples of one pixel
/// ([`PixelStreams::first_pairs`]): each one's stream past its first pair,
/// and that pair.
#[derive(Clone, Copy, Debug)]
pub struct FirstPairs {
    /// The streams, each at its third dimension.
    pub streams: [SampleStream; 8],
    /// Each stream's first two values.
    pub pairs: [Vec2; 8],
}

/// The sample streams of one pixel ([`Sampler::pixel`]).
#[derive(Clone, Copy, Debug)]
pub struct PixelStreams {
    sampler: Sampler,
    x: u32,
    y: u32,
    seed: u32,
    /// The pixel's key, for the samplers without patterns.
    key: u32,
}

impl PixelStreams {
    /// The streams of the pixel's samples `first..first + n` (`n` at
    /// most eight), each after a first [`SampleStream::next_2d`], and
    /// the pairs those gave: for the independent sampler, the hashes of
    /// the eight computed side by side (the same values).
    #[inline]
    pub fn first_pairs(&self, first: u32, n: usize) -> FirstPairs {
        debug_assert!(n <= 8);
        let mut out = FirstPairs {
            streams: [self.stream(first); 8],
            pairs: [Vec2::ZERO; 8],
        };
        if let Sampler::Independent(_) = self.sampler {
            // Eight side by side (vectorized), fewer one by one: a render
            // in passes of one sample per pixel asks for one at a time.
            if n == 8 {
                self.independent_pairs::<8>(first, &mut out.streams, &mut out.pairs);
            } else {
                for i in 0..n {
                    let at = first.wrapping_add(i as u32);
                    let (stream, pair) = (&mut out.streams[i..=i], &mut out.pairs[i..=i]);
                    self.independent_pairs::<1>(at, stream, pair);
                }
            }
            return out;
        }
        for (i, (stream, pair)) in out.streams[..n].iter_mut().zip(&mut out.pairs).enumerate() {
            *stream = self.stream(first + i as u32);
            *pair = stream.next_2d();
        }
        out
    }

    /// The independent sampler's `N` streams (from `streams`' copies of
    /// the pixel's) and pairs from sample `first`, their hashes computed
    /// side by side.
    #[inline(always)]
    fn independent_pairs<const N: usize>(
        &self,
        first: u32,
        streams: &mut [SampleStream],
        pairs: &mut [Vec2],
    ) {
        let mut keys = [0u32; N];
        for (i, k) in keys.iter_mut().enumerate() {
            *k = independent::sample_key(self.key, first.wrapping_add(i as u32));
        }
        let (mut xs, mut ys) = ([0.0f32; N], [0.0f32; N]);
        for ((x, y), &k) in xs.iter_mut().zip(&mut ys).zip(&keys) {
            (*x, *y) = (independent::sample(k, 0), independent::sample(k, 1));
        }
        for (i, (stream, pair)) in streams[..N].iter_mut().zip(pairs).enumerate() {
            stream.index = first.wrapping_add(i as u32);
            stream.sample_key = keys[i];
            stream.dim = 2;
            *pair = Vec2::new(xs[i], ys[i]);
        }
    }

    /// The stream of the pixel's sample `index`.
    #[inline]
    pub fn stream(&self, index: u32) -> SampleStream {
        let (x, y, seed) = (self.x, self.y, self.seed);
        let pattern = match self.sampler {
            Sampler::Independent(_) | Sampler::Sobol(_) => 1,
            s => s.sample_count(),
        };
        let (pixel_key, index) = if pattern == 1 {
            (self.key, index)
        } else {
            // The pass (index div N) keys the pattern's permutations.
            (
                hash3(x, y, seed ^ hash_u32(index / pattern)),
                index % pattern,
            )
        };
        SampleStream {
            sampler: self.sampler,
            pixel_key,
            index,
            // Only the samplers that draw independent values need it.
            sample_key: match self.sampler {
                Sampler::Independent(_) | Sampler::Sobol(_) => {
                    independent::sample_key(pixel_key, index)
                }
                _ => 0,
            },
            dim: 0,
            block: 0,
            block_index: 0,
        }
    }
}

/// The sample values of one pixel sample, dimension after dimension.
#[derive(Clone, Copy, Debug)]
pub struct SampleStream {
    sampler: Sampler,
    pixel_key: u32,
    /// The sample's index (in its pattern, for the pattern samplers).
    index: u32,
    /// `independent` and `sobol` (past its dimensions): the hash of
    /// (pixel key, index) that keys the independent values, so that each
    /// dimension costs one hash. Zero for the pattern samplers.
    sample_key: u32,
    dim: u32,
    /// `orthogonal`: the block of dimensions (plus one; 0: none yet) whose
    /// sample order `block_index` holds.
    block: u32,
    block_index: u32,
}

/// The largest float below 1: pattern values computed in floating point
/// are kept in [0, 1).
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

impl SampleStream {
    /// The key of dimension `d` of this pixel and pass.
    #[inline]
    fn key(&self, d: u32) -> u32 {
        dimension_key(self.pixel_key, d)
    }

    /// The next value in [0, 1).
    #[inline(always)]
    pub fn next_1d(&mut self) -> f32 {
        // The independent sampler (Mitsuba's default) inline at every
        // call; the pattern samplers out of line.
        if let Sampler::Independent(_) = self.sampler {
            let d = self.dim;
            self.dim += 1;
            return independent::sample(self.sample_key, d);
        }
        self.next_1d_patterned()
    }

    /// [`SampleStream::next_1d`] for every sampler.
    #[inline(never)]
    fn next_1d_patterned(&mut self) -> f32 {
        let d = self.dim;
        self.dim += 1;
        let i = self.index;
        match self.sampler {
            Sampler::Sobol(_) if d < sobol::DIMENSIONS => sobol::sample(i, d, self.pixel_key),
            Sampler::Independent(_) | Sampler::Sobol(_) => independent::sample(self.sample_key, d),
            Sampler::Stratified(s) => s.sample_1d(i, self.key(d)).min(ONE_MINUS_EPSILON),
            Sampler::MultiJitter(s) => s.sample_1d(i, self.key(d)).min(ONE_MINUS_EPSILON),
            Sampler::Orthogonal(s) => {
                let block = d / s.base + 1;
                if self.block != block {
                    self.block = block;
                    self.block_index = s.block_index(i, d, self.pixel_key);
                }
                s.sample(self.block_index, d, self.pixel_key)
                    .min(ONE_MINUS_EPSILON)
            }
            Sampler::LdSampler(s) => s.sample_1d(i, self.key(d)),
        }
    }

    /// The next two values (a pair the pattern samplers stratify jointly).
    #[inline(always)]
    pub fn next_2d(&mut self) -> Vec2 {
        // Inline for the independent sampler, as `next_1d`.
        if let Sampler::Independent(_) = self.sampler {
            let x = self.next_1d();
            return Vec2::new(x, self.next_1d());
        }
        self.next_2d_patterned()
    }

    /// [`SampleStream::next_2d`] for every sampler.
    #[inline(never)]
    fn next_2d_patterned(&mut self) -> Vec2 {
        let (d, i) = (self.dim, self.index);
        let v = match &self.sampler {
            Sampler::Stratified(s) => s.sample_2d(i, self.key(d)),
            Sampler::MultiJitter(s) => s.sample_2d(i, self.key(d)),
            Sampler::LdSampler(s) => s.sample_2d(i, self.key(d)),
            // Orthogonal arrays stratify every pair (and more) already.
            Sampler::Independent(_) | Sampler::Sobol(_) | Sampler::Orthogonal(_) => {
                let x = self.next_1d();
                return Vec2::new(x, self.next_1d());
            }
        };
        self.dim += 2;
        v.min(Vec2::splat(ONE_MINUS_EPSILON))
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

    /// One sampler of every kind.
    fn every_sampler() -> Vec<Sampler> {
        vec![
            Sampler::Independent(Independent { sample_count: 4 }),
            Sampler::Sobol(Sobol { sample_count: 4 }),
            Sampler::Stratified(Stratified {
                side: 4,
                jitter: true,
            }),
            Sampler::MultiJitter(MultiJitter {
                m: 3,
                n: 4,
                jitter: true,
            }),
            Sampler::Orthogonal(Orthogonal {
                base: 5,
                strength: 2,
                jitter: true,
            }),
            Sampler::LdSampler(LdSampler { sample_count: 16 }),
        ]
    }

    /// The first values of a stream, mixing 1D and 2D draws as renders do.
    fn first_values(s: &Sampler, x: u32, y: u32, i: u32, seed: u32) -> Vec<f32> {
        let mut st = s.stream(x, y, i, seed);
        let mut out = Vec::new();
        while out.len() < 401 {
            let v = st.next_2d();
            out.extend([v.x, v.y, st.next_1d()]);
        }
        out.truncate(401);
        out
    }

    /// Eight samples drawn together are the samples drawn one by one: the
    /// same first pairs and, after them, the same streams.
    #[test]
    fn first_pairs_equal_single_streams() {
        for s in every_sampler() {
            for (first, n) in [(0, 8), (5, 3), (61, 8), (u32::MAX - 2, 3)] {
                let drawn = s.pixel(7, 11, 19).first_pairs(first, n);
                for j in 0..n {
                    let index = first.wrapping_add(j as u32);
                    let mut single = s.stream(7, 11, index, 19);
                    assert_eq!(drawn.pairs[j], single.next_2d(), "{s:?} sample {index}");
                    let mut together = drawn.streams[j];
                    for _ in 0..9 {
                        assert_eq!(together.next_2d(), single.next_2d(), "{s:?} sample {index}");
                        assert_eq!(together.next_1d(), single.next_1d(), "{s:?} sample {index}");
                    }
                }
            }
        }
    }

    #[test]
    fn streams_are_pure_functions_of_their_key() {
        for s in every_sampler() {
            assert_eq!(first_values(&s, 3, 4, 5, 6), first_values(&s, 3, 4, 5, 6));
            assert_ne!(first_values(&s, 3, 4, 5, 6), first_values(&s, 4, 3, 5, 6));
            assert_ne!(first_values(&s, 3, 4, 5, 6), first_values(&s, 3, 4, 5, 7));
            assert_ne!(first_values(&s, 3, 4, 5, 6), first_values(&s, 3, 4, 6, 6));
            for i in 0..64 {
                assert!(
                    first_values(&s, 1, 2, i, 4)
                        .iter()
                        .all(|v| (0.0..1.0).contains(v)),
                    "{s:?}"
                );
            }
        }
    }

    /// The independent sampler's values are uniform on [0, 1)² and
    /// independent for every pairing a render relies on: neighbouring
    /// dimensions, distant dimensions, the same dimension of consecutive
    /// samples and of neighbouring pixels (chi-square on a 16 × 16 grid,
    /// Šidák-corrected over the pairings).
    #[test]
    fn chi2_independent_pairs_are_uniform() {
        let s = Sampler::Independent(Independent { sample_count: 64 });
        let value = |x: u32, y: u32, i: u32, dim: usize| {
            let mut st = s.stream(x, y, i, 0);
            (0..dim).for_each(|_| {
                st.next_1d();
            });
            st.next_1d()
        };
        type Pair = fn(&dyn Fn(u32, u32, u32, usize) -> f32, u32, u32, u32) -> (f32, f32);
        let pairings: [(&str, Pair); 5] = [
            ("dims 0 and 1", |v, x, y, i| (v(x, y, i, 0), v(x, y, i, 1))),
            ("dims 3 and 4", |v, x, y, i| (v(x, y, i, 3), v(x, y, i, 4))),
            ("dims 2 and 40", |v, x, y, i| {
                (v(x, y, i, 2), v(x, y, i, 40))
            }),
            ("samples i and i+1", |v, x, y, i| {
                (v(x, y, i, 5), v(x, y, i + 1, 5))
            }),
            ("pixels x and x+1", |v, x, y, i| {
                (v(x, y, i, 5), v(x + 1, y, i, 5))
            }),
        ];
        const GRID: usize = 16;
        let alpha = 1.0 - (1.0 - 1e-3f64).powf(1.0 / pairings.len() as f64);
        for (name, pair) in pairings {
            let mut counts = vec![0u64; GRID * GRID];
            for y in 0..32 {
                for x in 0..32 {
                    for i in 0..64 {
                        let (a, b) = pair(&value, x, y, i);
                        let cell = (a * GRID as f32) as usize * GRID + (b * GRID as f32) as usize;
                        counts[cell] += 1;
                    }
                }
            }
            let n: u64 = counts.iter().sum();
            let expected = vec![n as f64 / (GRID * GRID) as f64; GRID * GRID];
            crate::testing::chi2::chi2_discrete(&counts, &expected, alpha)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }

    #[test]
    fn means_are_one_half() {
        for s in every_sampler() {
            for dim in [0usize, 1, 2, 7, 255, 256, 400] {
                let n = 4800;
                let mean: f64 = (0..n)
                    .map(|i| first_values(&s, 9, 2, i, 1)[dim] as f64)
                    .sum::<f64>()
                    / n as f64;
                assert!((mean - 0.5).abs() < 0.02, "{s:?} dim {dim}: {mean}");
            }
        }
    }

    #[test]
    fn permute_is_a_bijection() {
        for l in (1..70).chain([256, 625, 1000]) {
            for p in [0, 1, 0xdead_beef, 12345] {
                let mut seen = vec![false; l as usize];
                for i in 0..l {
                    let j = permute(i, l, p) as usize;
                    assert!(!seen[j], "l {l} p {p}: {j} twice");
                    seen[j] = true;
                }
            }
        }
    }

    /// Draws of the pattern's N samples of one pixel and pass, after
    /// `skip_2d` pairs: (1D value, 2D pair).
    fn pattern(s: &Sampler, pass: u32, skip_2d: usize) -> Vec<(f32, Vec2)> {
        let n = s.sample_count();
        (0..n)
            .map(|i| {
                let mut st = s.stream(7, 3, pass * n + i, 11);
                for _ in 0..skip_2d {
                    st.next_2d();
                }
                let v1 = st.next_1d();
                (v1, st.next_2d())
            })
            .collect()
    }

    /// Each of `cells` bins of `values` (cell indices) holds one value.
    fn one_per_cell(cells: impl Iterator<Item = usize>, count: usize) -> bool {
        let mut seen = vec![0; count];
        for c in cells {
            seen[c.min(count - 1)] += 1;
        }
        seen.iter().all(|&k| k == 1)
    }

    #[test]
    fn stratified_has_one_sample_per_stratum() {
        let s = Sampler::Stratified(Stratified {
            side: 5,
            jitter: true,
        });
        for (pass, skip) in [(0, 0), (0, 3), (2, 1)] {
            let p = pattern(&s, pass, skip);
            assert!(one_per_cell(p.iter().map(|(v, _)| (v * 25.0) as usize), 25));
            assert!(one_per_cell(
                p.iter()
                    .map(|(_, v)| (v.y * 5.0) as usize * 5 + (v.x * 5.0) as usize),
                25
            ));
        }
    }

    #[test]
    fn multijitter_is_jittered_and_latin_at_once() {
        for (m, n) in [(4, 4), (3, 4)] {
            let s = Sampler::MultiJitter(MultiJitter { m, n, jitter: true });
            let count = (m * n) as usize;
            for (pass, skip) in [(0, 0), (1, 2)] {
                let p = pattern(&s, pass, skip);
                let cells =
                    |v: &Vec2| (v.y * n as f32) as usize * m as usize + (v.x * m as f32) as usize;
                assert!(one_per_cell(p.iter().map(|(_, v)| cells(v)), count));
                assert!(one_per_cell(
                    p.iter().map(|(_, v)| (v.x * count as f32) as usize),
                    count
                ));
                assert!(one_per_cell(
                    p.iter().map(|(_, v)| (v.y * count as f32) as usize),
                    count
                ));
                assert!(one_per_cell(
                    p.iter().map(|(v, _)| (v * count as f32) as usize),
                    count
                ));
            }
        }
    }

    /// Every t of the first s dimensions (and of the next block of s) see
    /// each combination of strata exactly once, and each dimension alone
    /// is stratified into N intervals.
    #[test]
    fn orthogonal_is_an_orthogonal_array() {
        for (base, strength) in [(5, 2), (3, 3), (5, 3), (7, 2)] {
            let o = Orthogonal {
                base,
                strength,
                jitter: true,
            };
            let s = Sampler::Orthogonal(o);
            let n = o.count();
            for pass in [0, 1] {
                let values: Vec<Vec<f32>> = (0..n)
                    .map(|i| {
                        let mut st = s.stream(2, 9, pass * n + i, 5);
                        (0..2 * base).map(|_| st.next_1d()).collect()
                    })
                    .collect();
                for block in [0, base] {
                    let dims: Vec<u32> = (block..block + strength).collect();
                    let stratum = |v: &Vec<f32>| {
                        dims.iter().fold(0usize, |acc, &d| {
                            acc * base as usize + (v[d as usize] * base as f32) as usize
                        })
                    };
                    assert!(
                        one_per_cell(values.iter().map(stratum), n as usize),
                        "s {base} t {strength} dims {dims:?}"
                    );
                    // Another choice of t dimensions within the block.
                    let last: Vec<u32> = (block + base - strength..block + base).collect();
                    let stratum = |v: &Vec<f32>| {
                        last.iter().fold(0usize, |acc, &d| {
                            acc * base as usize + (v[d as usize] * base as f32) as usize
                        })
                    };
                    assert!(one_per_cell(values.iter().map(stratum), n as usize));
                }
                for d in 0..2 * base as usize {
                    let fine = values.iter().map(|v| (v[d] * n as f32) as usize);
                    assert!(
                        one_per_cell(fine, n as usize),
                        "s {base} t {strength} dim {d}"
                    );
                }
            }
        }
    }

    /// The 2D draws are (0, 2)-nets in base 2: every elementary interval
    /// of area 1/N holds one point; the 1D draws are stratified.
    #[test]
    fn ldsampler_pairs_are_0_2_nets() {
        for count in [16u32, 32, 64] {
            let s = Sampler::LdSampler(LdSampler {
                sample_count: count,
            });
            let m = count.trailing_zeros();
            for (pass, skip) in [(0, 0), (0, 5), (3, 1)] {
                let p = pattern(&s, pass, skip);
                for a in 0..=m {
                    let (nx, ny) = (1usize << a, 1usize << (m - a));
                    let cells = p
                        .iter()
                        .map(|(_, v)| (v.y * ny as f32) as usize * nx + (v.x * nx as f32) as usize);
                    assert!(
                        one_per_cell(cells, count as usize),
                        "N {count}: {nx} × {ny}"
                    );
                }
                let fine = p.iter().map(|(v, _)| (v * count as f32) as usize);
                assert!(one_per_cell(fine, count as usize));
            }
        }
    }
}
