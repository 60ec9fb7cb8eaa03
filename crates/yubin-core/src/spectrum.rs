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

/// Converts a piecewise-linear spectrum (wavelength in nm, value) to
/// linear sRGB the way an RGB renderer must: integrate against the CIE
/// matching functions over 360–830 nm and normalise so that a constant
/// spectrum of 1 gives Y = 1; outside the listed range the spectrum is 0.
/// `bounded` (reflectances) clamps the result to [0, 1].
pub fn sampled_spectrum_to_rgb(samples: &[(f32, f32)], bounded: bool) -> Rgb {
    const STEPS: usize = 1000;
    const LO: f32 = 360.0;
    const HI: f32 = 830.0;
    let (mut acc, mut y_norm) = ([0.0f32; 3], 0.0f32);
    for i in 0..STEPS {
        let lambda = LO + (HI - LO) * i as f32 / (STEPS - 1) as f32;
        let cmf = cie1931_xyz(lambda);
        y_norm += cmf[1];
        let v = interpolate_spectrum(samples, lambda);
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
    fn narrow_band_is_saturated() {
        let red = sampled_spectrum_to_rgb(&[(600.0, 1.0), (700.0, 1.0)], true);
        assert!(red.x > 0.9 && red.z < 0.05, "{red}");
    }
}
