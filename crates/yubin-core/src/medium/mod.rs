//! Participating media: the sampling routines the volumetric integrators
//! are built from (the media plugins and their scene wiring come next).
//!
//! - [`HomogeneousCoefficients::sample_distance`]: free-flight distances
//!   in a chromatic homogeneous medium, by spectral MIS (Miller et al.
//!   2019, "A null-scattering path integral formulation of light
//!   transport", §5): a channel is picked uniformly and the distance
//!   sampled from its exponential; the density is the average of the three
//!   channels' densities, so every channel's estimate stays bounded.
//! - [`Grid`]: voxel grids (Mitsuba's `.vol` data), trilinear lookup.
//! - [`MajorantGrid`]: per-cell majorants of a grid, walked by a DDA.
//! - [`Pyroclastic`]: seed 003's pyroclastic cloud density.
//! - [`ratio_tracking`]: unbiased transmittance through any medium below a
//!   majorant (Novák et al. 2014, "Residual ratio tracking for estimating
//!   attenuation in participating media").

mod grid;
mod majorant;
mod pyroclastic;
mod tracking;

pub use grid::{Grid, GridError};
pub use majorant::MajorantGrid;
pub use pyroclastic::Pyroclastic;
pub use tracking::ratio_tracking;

use crate::Rgb;

/// A homogeneous medium's coefficients (per unit length).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HomogeneousCoefficients {
    /// Extinction σ_t per channel.
    pub sigma_t: Rgb,
    /// Single-scattering albedo σ_s / σ_t per channel.
    pub albedo: Rgb,
}

/// Where a free flight ended, and the factor it multiplies a path's
/// throughput by.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DistanceSample {
    /// The distance travelled.
    pub t: f32,
    /// True when the flight ended inside the medium (a scattering event),
    /// false when it reached `t_max`.
    pub scattered: bool,
    /// Inside: T(t) σ_s / p(t); at `t_max`: T(t_max) / P(t ≥ t_max).
    pub weight: Rgb,
}

impl HomogeneousCoefficients {
    /// Transmittance over a distance `t`: e^(−σ_t t) per channel.
    #[inline]
    pub fn transmittance(&self, t: f32) -> Rgb {
        (-self.sigma_t * t).exp()
    }

    /// Samples how far a ray goes before it scatters, up to `t_max`
    /// (which may be infinite), from a uniform channel choice `u_channel`
    /// and a uniform `u`.
    pub fn sample_distance(&self, t_max: f32, u_channel: f32, u: f32) -> DistanceSample {
        let channel = ((u_channel * 3.0) as usize).min(2);
        let sigma = self.sigma_t[channel];
        let t = if sigma > 0.0 {
            -(1.0 - u).ln() / sigma
        } else {
            f32::INFINITY
        };
        if t < t_max {
            let tr = self.transmittance(t);
            // The mixture's density: the average of the channels'.
            let pdf = (self.sigma_t * tr).element_sum() / 3.0;
            DistanceSample {
                t,
                scattered: true,
                weight: tr * self.sigma_t * self.albedo / pdf,
            }
        } else {
            let tr = self.transmittance(t_max);
            let p_pass = tr.element_sum() / 3.0;
            DistanceSample {
                t: t_max,
                scattered: false,
                weight: if p_pass > 0.0 { tr / p_pass } else { Rgb::ZERO },
            }
        }
    }

    /// The density of [`HomogeneousCoefficients::sample_distance`] ending
    /// at `t` inside the medium.
    pub fn pdf_distance(&self, t: f32) -> f32 {
        (self.sigma_t * self.transmittance(t)).element_sum() / 3.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;
    use crate::testing::chi2::chi2_discrete;

    fn chromatic() -> HomogeneousCoefficients {
        HomogeneousCoefficients {
            sigma_t: Rgb::new(0.5, 1.5, 4.0),
            albedo: Rgb::new(0.9, 0.6, 0.3),
        }
    }

    /// Free-flight distances in a chromatic medium follow the mixture
    /// density: 40 bins over [0, t_max] and one for passing through,
    /// against the analytic bin masses.
    #[test]
    fn chi2_free_flight_distances() {
        let m = chromatic();
        let t_max = 2.0;
        let bins = 40;
        let n = 400_000;
        let mut counts = vec![0u64; bins + 1];
        let mut rng = Pcg32::new(3, 9);
        for _ in 0..n {
            let s = m.sample_distance(t_max, rng.next_f32(), rng.next_f32());
            let bin = if s.scattered {
                ((s.t / t_max * bins as f32) as usize).min(bins - 1)
            } else {
                bins
            };
            counts[bin] += 1;
        }
        let cdf = |t: f32| 1.0 - m.transmittance(t).element_sum() as f64 / 3.0;
        let mut expected: Vec<f64> = (0..bins)
            .map(|k| {
                let (a, b) = (
                    t_max * k as f32 / bins as f32,
                    t_max * (k + 1) as f32 / bins as f32,
                );
                (cdf(b) - cdf(a)) * n as f64
            })
            .collect();
        expected.push((1.0 - cdf(t_max)) * n as f64);
        chi2_discrete(&counts, &expected, 0.01).unwrap();
        // pdf_distance is the CDF's derivative (what MIS will weigh with).
        for t in [0.01, 0.3, 1.1, 1.9] {
            let h = 1e-3;
            let slope = (cdf(t + h) - cdf(t - h)) / (2.0 * h as f64);
            let pdf = m.pdf_distance(t) as f64;
            assert!(
                (pdf / slope - 1.0).abs() < 1e-3,
                "t {t}: pdf {pdf} vs slope {slope}"
            );
        }
    }

    /// The weights are bounded and make unbiased estimates per channel:
    /// passing through
    /// estimates T(t_max); a scattering event, weighted by 1/σ_s,
    /// estimates ∫₀^t_max T(t) dt.
    #[test]
    fn free_flight_weights_are_unbiased_per_channel() {
        let m = chromatic();
        let t_max = 1.3;
        let n = 400_000;
        let mut rng = Pcg32::new(5, 2);
        let (mut pass, mut pass2, mut scat, mut scat2) =
            (Rgb::ZERO, Rgb::ZERO, Rgb::ZERO, Rgb::ZERO);
        for _ in 0..n {
            let s = m.sample_distance(t_max, rng.next_f32(), rng.next_f32());
            // Spectral MIS keeps every channel's weight bounded: at most
            // 3 × albedo inside, 3 passing through (a single channel's
            // density would make the others' weights unbounded).
            let bound = if s.scattered {
                3.0 * m.albedo
            } else {
                Rgb::splat(3.0)
            };
            assert!(
                s.weight.cmple(bound * 1.0001).all(),
                "weight {} above {bound}",
                s.weight
            );
            if s.scattered {
                let w = s.weight / (m.sigma_t * m.albedo);
                scat += w;
                scat2 += w * w;
            } else {
                pass += s.weight;
                pass2 += s.weight * s.weight;
            }
        }
        let nf = n as f32;
        let check = |sum: Rgb, sum2: Rgb, want: Rgb, what: &str| {
            let mean = sum / nf;
            let se = ((sum2 / nf - mean * mean) / nf).max(Rgb::ZERO).powf(0.5);
            for c in 0..3 {
                assert!(
                    (mean[c] - want[c]).abs() < 4.0 * se[c] + 1e-4,
                    "{what}, channel {c}: {} vs {} (± {})",
                    mean[c],
                    want[c],
                    se[c]
                );
            }
        };
        check(pass, pass2, m.transmittance(t_max), "passing");
        let integral = (Rgb::ONE - m.transmittance(t_max)) / m.sigma_t;
        check(scat, scat2, integral, "scattering");
    }
}
