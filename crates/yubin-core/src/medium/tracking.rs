//! Ratio tracking (Novák et al. 2014): transmittance through a medium of
//! extinction σ_t(t) ≤ μ along a ray, by tentative collisions at rate μ,
//! each multiplying the estimate by the null-collision probability
//! 1 − σ_t / μ; unbiased for any majorant μ, exact when the medium is
//! homogeneous at μ.

use crate::Rgb;

/// An unbiased estimate of the transmittance over [0, `t_max`] through
/// the extinction `sigma_t(t)` (per channel, each ≤ `majorant`), drawing
/// uniform numbers from `next`.
pub fn ratio_tracking(
    sigma_t: impl Fn(f32) -> Rgb,
    majorant: f32,
    t_max: f32,
    mut next: impl FnMut() -> f32,
) -> Rgb {
    if majorant <= 0.0 {
        return Rgb::ONE;
    }
    let mut tr = Rgb::ONE;
    let mut t = 0.0;
    loop {
        t += -(1.0 - next()).ln() / majorant;
        if t >= t_max {
            return tr;
        }
        tr *= Rgb::ONE - sigma_t(t) / majorant;
        if tr.max_element() <= 0.0 {
            return Rgb::ZERO;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;

    /// Mean and standard error per channel of `n` estimates.
    fn mean_and_error(n: usize, mut estimate: impl FnMut() -> Rgb) -> (Rgb, Rgb) {
        let (mut s, mut s2) = (Rgb::ZERO, Rgb::ZERO);
        for _ in 0..n {
            let e = estimate();
            s += e;
            s2 += e * e;
        }
        let mean = s / n as f32;
        let se = ((s2 / n as f32 - mean * mean) / n as f32)
            .max(Rgb::ZERO)
            .powf(0.5);
        (mean, se)
    }

    /// On a homogeneous slab, with a majorant twice the largest σ_t (so
    /// estimates are random), the mean is e^(−σ_t L) per channel; on a
    /// varying medium, e^(−∫σ_t).
    #[test]
    fn ratio_tracking_is_unbiased() {
        let sigma = Rgb::new(0.4, 1.0, 2.5);
        let length = 1.5;
        let mut rng = Pcg32::new(1, 7);
        let (mean, se) = mean_and_error(200_000, || {
            ratio_tracking(|_| sigma, 5.0, length, || rng.next_f32())
        });
        let want = (-sigma * length).exp();
        for c in 0..3 {
            assert!(
                (mean[c] - want[c]).abs() < 4.0 * se[c] + 1e-5,
                "{mean} vs {want} (± {se})"
            );
            assert!(se[c] > 0.0, "the estimates should vary");
        }
        // σ_t(t) = a (1 + sin t): ∫₀^L = a (L + 1 − cos L).
        let a = Rgb::new(0.3, 0.8, 1.2);
        let varying = |t: f32| a * (1.0 + t.sin());
        let (mean, se) = mean_and_error(200_000, || {
            ratio_tracking(varying, 2.5, length, || rng.next_f32())
        });
        let want = (-a * (length + 1.0 - length.cos())).exp();
        for c in 0..3 {
            assert!(
                (mean[c] - want[c]).abs() < 4.0 * se[c] + 1e-5,
                "{mean} vs {want} (± {se})"
            );
        }
    }
}
