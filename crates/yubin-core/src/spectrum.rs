//! Colour. yubin renders in linear sRGB (Rec. 709 primaries), like
//! Mitsuba 3's `*_rgb` variants: a colour is a `glam::Vec3`.

/// A linear-sRGB triple (radiance, reflectance, throughput).
pub type Rgb = glam::Vec3;

/// Rec. 709 luminance of a linear-sRGB colour.
#[inline]
pub fn luminance(c: Rgb) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// Wyman, Sloan and Shirley 2013, "Simple Analytic Approximations to the
/// CIE XYZ Color Matching Functions" (JCGT 2(2)), the multi-lobe fit of the
/// CIE 1931 2° observer. `lambda` in nanometres.
pub fn cie1931_xyz(lambda: f32) -> [f32; 3] {
    let g = |x: f32, mu: f32, s1: f32, s2: f32| {
        let t = (x - mu) / if x < mu { s1 } else { s2 };
        (-0.5 * t * t).exp()
    };
    let x = 1.056 * g(lambda, 599.8, 37.9, 31.0) + 0.362 * g(lambda, 442.0, 16.0, 26.7)
        - 0.065 * g(lambda, 501.1, 20.4, 26.2);
    let y = 0.821 * g(lambda, 568.8, 46.9, 40.5) + 0.286 * g(lambda, 530.9, 16.3, 31.1);
    let z = 1.217 * g(lambda, 437.0, 11.8, 36.0) + 0.681 * g(lambda, 459.0, 26.0, 13.8);
    [x, y, z]
}

/// CIE XYZ to linear sRGB (D65 white), IEC 61966-2-1.
pub fn xyz_to_srgb(xyz: [f32; 3]) -> Rgb {
    let [x, y, z] = xyz;
    Rgb::new(
        3.240_479 * x - 1.537_15 * y - 0.498_535 * z,
        -0.969_256 * x + 1.875_992 * y + 0.041_556 * z,
        0.055_648 * x - 0.204_043 * y + 1.057_311 * z,
    )
}

/// CIE standard illuminant D65, relative spectral power at 10 nm steps
/// from 300 to 830 nm (CIE 15:2004, table T.1).
const D65_10NM: [f32; 54] = [
    0.0341, 3.2945, 20.236, 37.0535, 39.9488, 44.9117, 46.6383, 52.0891, 49.9755, 54.6482, 82.7549,
    91.486, 93.4318, 86.6823, 104.865, 117.008, 117.812, 114.861, 115.923, 108.811, 109.354,
    107.802, 104.790, 107.689, 104.405, 104.046, 100.0, 96.3342, 95.788, 88.6856, 90.0062, 89.5991,
    87.6987, 83.2886, 83.6992, 80.0268, 80.2146, 82.2778, 78.2842, 69.7213, 71.6091, 74.349,
    61.604, 69.8856, 75.087, 63.5927, 46.4182, 66.8054, 63.3828, 64.304, 59.4519, 51.959, 57.4406,
    60.3125,
];

/// D65's relative power at `lambda` nm (linear interpolation).
pub fn d65(lambda: f32) -> f32 {
    let x = ((lambda - 300.0) / 10.0).clamp(0.0, (D65_10NM.len() - 1) as f32);
    let i = (x as usize).min(D65_10NM.len() - 2);
    let t = x - i as f32;
    D65_10NM[i] * (1.0 - t) + D65_10NM[i + 1] * t
}

/// Converts a piecewise-linear spectrum (wavelength in nm, value) to
/// linear sRGB as Mitsuba 3's RGB variants do: integrate against the CIE
/// 1931 matching functions over 360–830 nm (0 outside the listed range)
/// and normalise by ∫ȳ. Reflectances (`bounded`) are weighted by the D65
/// illuminant (so a flat spectrum of 1 is white, (1, 1, 1)) and clamped to
/// [0, 1]; emission is not weighted (a flat spectrum is illuminant E, a
/// slightly pink white) and only clamped at 0.
pub fn sampled_spectrum_to_rgb(samples: &[(f32, f32)], bounded: bool) -> Rgb {
    const STEPS: usize = 1000;
    const LO: f32 = 360.0;
    const HI: f32 = 830.0;
    let (mut acc, mut y_norm) = ([0.0f32; 3], 0.0f32);
    for i in 0..STEPS {
        let lambda = LO + (HI - LO) * i as f32 / (STEPS - 1) as f32;
        let weight = if bounded { d65(lambda) } else { 1.0 };
        let cmf = cie1931_xyz(lambda);
        y_norm += cmf[1] * weight;
        let v = interpolate_spectrum(samples, lambda) * weight;
        for c in 0..3 {
            acc[c] += cmf[c] * v;
        }
    }
    let xyz = acc.map(|a| a / y_norm);
    let rgb = xyz_to_srgb(xyz);
    if bounded {
        rgb.clamp(Rgb::ZERO, Rgb::ONE)
    } else {
        rgb.max(Rgb::ZERO)
    }
}

fn interpolate_spectrum(samples: &[(f32, f32)], lambda: f32) -> f32 {
    let (Some(first), Some(last)) = (samples.first(), samples.last()) else {
        return 0.0;
    };
    if lambda < first.0 || lambda > last.0 {
        return 0.0;
    }
    for w in samples.windows(2) {
        let ((l0, v0), (l1, v1)) = (w[0], w[1]);
        if lambda >= l0 && lambda <= l1 {
            let t = if l1 > l0 {
                (lambda - l0) / (l1 - l0)
            } else {
                0.0
            };
            return v0 + t * (v1 - v0);
        }
    }
    first.1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_spectrum_is_white() {
        let rgb = sampled_spectrum_to_rgb(&[(360.0, 1.0), (830.0, 1.0)], false);
        // An equal-energy spectrum (illuminant E) is slightly pink in sRGB/D65.
        assert!((luminance(rgb) - 1.0).abs() < 0.01, "{rgb}");
        assert!(
            (rgb.x - 1.2).abs() < 0.1 && (rgb.z - 0.9).abs() < 0.1,
            "{rgb}"
        );
    }

    #[test]
    fn matches_mitsuba_rgb_mode() {
        // Values printed by Mitsuba 3.9.1 (scalar_rgb) for the same spectrum
        // as a diffuse reflectance and as an area light's radiance; the
        // tolerance covers the analytic fit of the matching functions.
        let s = [(400.0, 0.2), (500.0, 0.8), (600.0, 0.5), (700.0, 0.1)];
        let refl = sampled_spectrum_to_rgb(&s, true);
        let emit = sampled_spectrum_to_rgb(&s, false);
        assert!(
            (refl - Rgb::new(0.324_581, 0.707_191, 0.508_399))
                .abs()
                .max_element()
                < 0.01,
            "{refl}"
        );
        assert!(
            (emit - Rgb::new(0.420_713, 0.672_23, 0.452_322))
                .abs()
                .max_element()
                < 0.01,
            "{emit}"
        );
        let white = sampled_spectrum_to_rgb(&[(360.0, 1.0), (830.0, 1.0)], true);
        assert!((white - Rgb::ONE).abs().max_element() < 0.01, "{white}");
    }

    #[test]
    fn narrow_band_is_saturated() {
        let red = sampled_spectrum_to_rgb(&[(600.0, 1.0), (700.0, 1.0)], true);
        assert!(red.x > 0.7 && red.y < 0.05 && red.z < 0.05, "{red}");
    }
}
