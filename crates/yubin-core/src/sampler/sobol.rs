//! `sobol`: Owen-scrambled Sobol sequence (Burley 2020, "Practical
//! Hash-based Owen Scrambling", JCGT 9(4)), via the `sobol_burley` crate.
//!
//! | parameter      | type    | default | meaning            |
//! |----------------|---------|---------|--------------------|
//! | `sample_count` | integer | 4       | samples per pixel  |
//!
//! ```xml
//! <sampler type="sobol"><integer name="sample_count" value="64"/></sampler>
//! ```
//!
//! Each pixel scrambles the sequence with its own seed (a hash of pixel and
//! render seed), so neighbouring pixels are decorrelated while each pixel
//! keeps Sobol's stratification. Dimensions past the crate's table (256)
//! fall back to independent values.

/// Owen-scrambled Sobol samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sobol {
    /// Samples per pixel.
    pub sample_count: u32,
}

/// Dimensions with Sobol values.
pub(crate) const DIMENSIONS: u32 = sobol_burley::NUM_DIMENSIONS;

#[inline]
pub(crate) fn sample(index: u32, dim: u32, pixel_key: u32) -> f32 {
    sobol_burley::sample(index, dim, pixel_key)
}

#[cfg(test)]
mod tests {
    use crate::sampler::{Sampler, Sobol};

    #[test]
    fn sobol_stratifies_each_dimension() {
        // Any power-of-two prefix of an Owen-scrambled Sobol sequence puts
        // exactly one point in each of the n equal intervals.
        let s = Sampler::Sobol(Sobol { sample_count: 64 });
        for dim in 0..8u32 {
            let mut seen = [false; 64];
            for i in 0..64 {
                let mut st = s.stream(5, 6, i, 3);
                for _ in 0..dim {
                    st.next_1d();
                }
                seen[(st.next_1d() * 64.0) as usize] = true;
            }
            assert!(seen.iter().all(|&b| b), "dimension {dim}");
        }
    }
}
