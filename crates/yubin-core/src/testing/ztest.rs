//! The per-pixel Z-test of Mitsuba 3's render-regression suite
//! (`src/render/tests/test_renders.py`), written from its description:
//!
//! - images are compared in CIE XYZ (mean, reference and reference
//!   variance are all converted from linear sRGB with the same matrix);
//! - for every pixel and channel, z = |mean − ref| · √(spp / max(var, 10⁻⁴)),
//!   where `var` is the reference's *per-sample* variance;
//! - the two-sided p-value is erfc(z/√2);
//! - the significance level 0.01 is Šidák-corrected over the N pixels:
//!   α = 1 − 0.99^(1/N);
//! - the test passes when at least 99.75 % of the 3N channel tests have
//!   p > α.

/// Outcome of a Z-test.
#[derive(Clone, Debug)]
pub struct ZTestReport {
    /// True when enough values passed.
    pub passed: bool,
    /// How many channel tests failed.
    pub failures: usize,
    /// The smallest p-value seen and its index in the data.
    pub min_p: (f64, usize),
    /// The Šidák-corrected level each p-value is held to.
    pub alpha_corrected: f64,
    /// Channel tests made.
    pub count: usize,
}

/// Floor on the reference variance, so that pixels with (near-)zero
/// variance in the reference don't make any round-off a failure.
pub const VARIANCE_FLOOR: f64 = 1e-4;
/// Fraction of channel tests that must pass.
pub const PASS_FRACTION: f64 = 0.9975;

/// Linear sRGB → CIE XYZ (D65).
fn srgb_to_xyz(c: [f64; 3]) -> [f64; 3] {
    [
        0.412_453 * c[0] + 0.357_580 * c[1] + 0.180_423 * c[2],
        0.212_671 * c[0] + 0.715_160 * c[1] + 0.072_169 * c[2],
        0.019_334 * c[0] + 0.119_193 * c[1] + 0.950_227 * c[2],
    ]
}

fn to_xyz(rgb: &[f32]) -> Vec<f64> {
    rgb.chunks_exact(3)
        .flat_map(|c| srgb_to_xyz([c[0] as f64, c[1] as f64, c[2] as f64]))
        .collect()
}

/// Runs the Z-test of `mean` (an estimate from `spp` samples per pixel)
/// against `reference` with per-sample variance `reference_var`. All three
/// are interleaved linear-sRGB images of the same size.
pub fn z_test(
    mean: &[f32],
    spp: u32,
    reference: &[f32],
    reference_var: &[f32],
    alpha: f64,
) -> ZTestReport {
    let (mean, reference, var) = (to_xyz(mean), to_xyz(reference), to_xyz(reference_var));
    let n = mean.len().min(reference.len()).min(var.len());
    let pixels = (n / 3).max(1);
    let alpha_corrected = 1.0 - (1.0 - alpha).powf(1.0 / pixels as f64);
    let (mut failures, mut min_p) = (0, (1.0f64, 0usize));
    for i in 0..n {
        let v = var[i].max(VARIANCE_FLOOR);
        let z = (mean[i] - reference[i]).abs() * (spp as f64 / v).sqrt();
        let p = if z.is_finite() {
            erfc(z / std::f64::consts::SQRT_2)
        } else {
            0.0
        };
        if p < min_p.0 {
            min_p = (p, i);
        }
        if p <= alpha_corrected {
            failures += 1;
        }
    }
    ZTestReport {
        passed: n > 0 && (n - failures) as f64 >= PASS_FRACTION * n as f64,
        failures,
        min_p,
        alpha_corrected,
        count: n,
    }
}

/// Complementary error function with fractional error below 1.2e-7
/// everywhere (Numerical Recipes, 2nd ed., §6.2, Chebyshev fit).
pub fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * poly.exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;

    #[test]
    fn erfc_known_values() {
        assert!((erfc(0.0) - 1.0).abs() < 1e-7);
        assert!((erfc(1.0) - 0.157_299_207).abs() < 1e-7);
        assert!((erfc(3.0) / 2.209_049_7e-5 - 1.0).abs() < 1e-6);
    }

    #[test]
    fn passes_noise_and_fails_bias() {
        // Means of 64 uniform samples with variance 1/12 around 0.5.
        let mut rng = Pcg32::new(3, 3);
        let n = 3 * 4096;
        let mean: Vec<f32> = (0..n)
            .map(|_| (0..64).map(|_| rng.next_f32()).sum::<f32>() / 64.0)
            .collect();
        let reference = vec![0.5f32; n];
        let var = vec![1.0f32 / 12.0; n];
        assert!(z_test(&mean, 64, &reference, &var, 0.01).passed);
        let biased: Vec<f32> = mean.iter().map(|m| m * 1.2).collect();
        let r = z_test(&biased, 64, &reference, &var, 0.01);
        assert!(!r.passed && r.failures > 100, "{r:?}");
    }
}
