//! Colour. yubin renders in linear sRGB (Rec. 709 primaries), like
//! Mitsuba 3's `*_rgb` variants: a colour is a `glam::Vec3`.
//!
//! Spectra in a scene (sampled spectra, measured IOR files, the spectrum
//! plugins of [`plugin`]) become RGB when the scene is built, the way
//! Mitsuba 3's RGB variants convert them, which depends on the role the
//! colour plays ([`ColorKind`]):
//!
//! | role          | spectrum weighted by | clamped to | a constant `v` becomes |
//! |---------------|----------------------|------------|------------------------|
//! | `Reflectance` | D65                  | [0, 1]     | (v, v, v)              |
//! | `Unbounded`   | D65                  | [0, ∞)     | (v, v, v)              |
//! | `Illuminant`  | nothing (equal energy) | [0, ∞)   | v · sRGB(illuminant E) |
//!
//! The conversion integrates the spectrum against the CIE 1931 matching
//! functions on Mitsuba's grid (1000 points from 360 to 830 nm, tables at
//! 5 nm interpolated linearly; see [`cie`]) and normalises by the same sum
//! of ȳ, so a flat spectrum of 1 has luminance 1, then maps XYZ to linear
//! sRGB (IEC 61966-2-1). Checked against Mitsuba 3.9.1 to 1e-5.

pub mod cie;
pub mod ior;
mod ior_table;
pub mod plugin;

pub use plugin::{spectrum_plugin_to_rgb, SpectrumPlugin};

use crate::params::ColorKind;
use cie::{CIE1931_XYZ, CIE_D65, CIE_MAX, CIE_MIN, CIE_STEP};

/// A linear-sRGB triple (radiance, reflectance, throughput).
pub type Rgb = glam::Vec3;

/// Rec. 709 luminance of a linear-sRGB colour.
#[inline]
pub fn luminance(c: Rgb) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// Linear interpolation in a table sampled every [`CIE_STEP`] nm from
/// [`CIE_MIN`]; `None` outside the table.
#[inline]
fn cie_lookup(lambda: f32) -> Option<(usize, f32)> {
    if !(CIE_MIN..=CIE_MAX).contains(&lambda) {
        return None;
    }
    let x = (lambda - CIE_MIN) / CIE_STEP;
    let i = (x as usize).min(CIE1931_XYZ.len() - 2);
    Some((i, x - i as f32))
}

/// The CIE 1931 2° colour matching functions x̄, ȳ, z̄ at `lambda` nm:
/// the 5 nm table interpolated linearly, zero outside 360–830 nm.
pub fn cie1931_xyz(lambda: f32) -> [f32; 3] {
    let Some((i, t)) = cie_lookup(lambda) else {
        return [0.0; 3];
    };
    let (a, b) = (CIE1931_XYZ[i], CIE1931_XYZ[i + 1]);
    [0, 1, 2].map(|c| a[c] + t * (b[c] - a[c]))
}

/// CIE standard illuminant D65's relative power at `lambda` nm (100 at
/// 560 nm; linear between the 5 nm samples, zero outside 360–830 nm).
pub fn d65(lambda: f32) -> f32 {
    let Some((i, t)) = cie_lookup(lambda) else {
        return 0.0;
    };
    CIE_D65[i] + t * (CIE_D65[i + 1] - CIE_D65[i])
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

/// Number of wavelengths the conversions integrate over (Mitsuba 3's
/// `spectrum_list_to_srgb` uses the same evenly spaced 1000, ends
/// included, so the two agree to rounding).
const STEPS: usize = 1000;

/// D65 enters reflectance conversions divided by this (Mitsuba 3.9.1's
/// `MI_CIE_D65_NORMALIZATION`, ≈ the ȳ-weighted mean of the table on a
/// finer grid). Using the same constant makes a flat reflectance of 1 come
/// out as 0.9989 rather than 1, exactly as in Mitsuba, so colours match it
/// to rounding rather than to 0.1 %.
const D65_MEAN: f32 = 98.997_42;

/// Converts a spectrum given as a function of wavelength (nm; `None` where
/// it is not defined, which counts as zero) to linear sRGB for `role` (see
/// the module docs).
pub fn spectrum_fn_to_rgb(f: impl Fn(f32) -> Option<f32>, role: ColorKind) -> Rgb {
    let weighted = role != ColorKind::Illuminant;
    let (mut acc, mut y_sum) = ([0.0f64; 3], 0.0f64);
    for i in 0..STEPS {
        let lambda = CIE_MIN + (CIE_MAX - CIE_MIN) * i as f32 / (STEPS - 1) as f32;
        let cmf = cie1931_xyz(lambda);
        y_sum += f64::from(cmf[1]);
        let Some(mut v) = f(lambda) else { continue };
        if weighted {
            v *= d65(lambda) / D65_MEAN;
        }
        for c in 0..3 {
            acc[c] += f64::from(cmf[c] * v);
        }
    }
    let rgb = xyz_to_srgb(acc.map(|a| (a / y_sum) as f32)).max(Rgb::ZERO);
    match role {
        ColorKind::Reflectance => rgb.min(Rgb::ONE),
        _ => rgb,
    }
}

/// Converts a piecewise-linear spectrum (wavelength in nm, increasing;
/// value) to linear sRGB for `role`. Zero outside the listed wavelengths.
pub fn spectrum_to_rgb(samples: &[(f32, f32)], role: ColorKind) -> Rgb {
    spectrum_fn_to_rgb(|lambda| interpolate_spectrum(samples, lambda), role)
}

/// [`spectrum_to_rgb`] for a reflectance (`bounded`) or an emission
/// spectrum. Unbounded non-emissive quantities (IORs) are D65-weighted in
/// Mitsuba: use [`spectrum_to_rgb`] with [`ColorKind::Unbounded`] for them.
pub fn sampled_spectrum_to_rgb(samples: &[(f32, f32)], bounded: bool) -> Rgb {
    let role = if bounded {
        ColorKind::Reflectance
    } else {
        ColorKind::Illuminant
    };
    spectrum_to_rgb(samples, role)
}

/// A constant spectrum of value `v` in RGB: grey, except for emission,
/// where it is `v` times the sRGB colour of an equal-energy spectrum
/// (illuminant E, a slightly pink white), as in Mitsuba 3's RGB variants
/// for `<spectrum value="v"/>`. (The `uniform` plugin is grey in every
/// role: see [`SpectrumPlugin`].)
///
/// Mitsuba takes E's colour as its exact chromaticity, XYZ = (1, 1, 1),
/// rather than integrating a flat spectrum over the tables (which gives
/// 1.20488, 0.948229, 0.909267; 4e-4 away): so does yubin.
pub fn constant_spectrum_to_rgb(v: f32, role: ColorKind) -> Rgb {
    match role {
        ColorKind::Illuminant => xyz_to_srgb([v; 3]),
        _ => Rgb::splat(v),
    }
}

/// Linear interpolation of sorted samples; `None` outside their range.
fn interpolate_spectrum(samples: &[(f32, f32)], lambda: f32) -> Option<f32> {
    let (first, last) = (samples.first()?, samples.last()?);
    if lambda < first.0 || lambda > last.0 {
        return None;
    }
    // First sample at or beyond lambda; the one before starts its interval.
    let j = samples.partition_point(|s| s.0 < lambda).max(1);
    if j >= samples.len() {
        return Some(last.1);
    }
    let ((l0, v0), (l1, v1)) = (samples[j - 1], samples[j]);
    let t = if l1 > l0 {
        (lambda - l0) / (l1 - l0)
    } else {
        0.0
    };
    Some(v0 + t * (v1 - v0))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Rgb, b: [f32; 3], tol: f32) -> bool {
        (a - Rgb::from_array(b)).abs().max_element() < tol
    }

    #[test]
    fn constant_spectrum_is_illuminant_e() {
        // Mitsuba 3.9.1 (scalar_rgb): `<spectrum name="radiance"
        // value="0.789"/>` on an area emitter is (0.950582, 0.748202,
        // 0.717135); the same as a reflectance or an eta is 0.789 grey.
        let e = constant_spectrum_to_rgb(0.789, ColorKind::Illuminant);
        assert!(close(e, [0.950_582, 0.748_202, 0.717_135], 1e-5), "{e}");
        assert!((luminance(e / 0.789) - 1.0).abs() < 1e-4, "{e}");
        for role in [ColorKind::Reflectance, ColorKind::Unbounded] {
            assert_eq!(constant_spectrum_to_rgb(0.789, role), Rgb::splat(0.789));
        }
    }

    #[test]
    fn matches_mitsuba_rgb_mode() {
        // Mitsuba 3.9.1 (scalar_rgb), `<spectrum value="400:0.2, 500:0.8,
        // 600:0.5, 700:0.1"/>` as a diffuse reflectance and as an area
        // light's radiance, and `mi.spectrum_list_to_srgb` of a flat 1 with
        // D65 weighting (0.998983, 0.998872, 0.998802): the same tables and
        // grid make the match exact to rounding.
        let s = [(400.0, 0.2), (500.0, 0.8), (600.0, 0.5), (700.0, 0.1)];
        let refl = sampled_spectrum_to_rgb(&s, true);
        let emit = sampled_spectrum_to_rgb(&s, false);
        assert!(
            close(refl, [0.324_581, 0.707_191, 0.508_399], 1e-5),
            "{refl}"
        );
        assert!(
            close(emit, [0.420_713, 0.672_23, 0.452_322], 1e-5),
            "{emit}"
        );
        let white = sampled_spectrum_to_rgb(&[(360.0, 1.0), (830.0, 1.0)], true);
        assert!(
            close(white, [0.998_983, 0.998_872, 0.998_802], 1e-5),
            "{white}"
        );
        let e = sampled_spectrum_to_rgb(&[(360.0, 1.0), (830.0, 1.0)], false);
        assert!(close(e, [1.204_88, 0.948_229, 0.909_267], 1e-5), "{e}");
        // A conductor's `eta` and `k` from wavelength:value lists (Mitsuba's
        // docs scene bsdf_blendbsdf.xml), read back with `mi.traverse`.
        let eta = [
            (300.0, 1.8),
            (400.0, 1.65),
            (500.0, 0.9),
            (600.0, 0.2),
            (700.0, 0.16),
            (800.0, 0.18),
        ];
        let k = [
            (300.0, 1.92),
            (400.0, 1.95),
            (500.0, 1.95),
            (600.0, 2.97),
            (700.0, 3.8),
            (800.0, 5.12),
        ];
        let eta = spectrum_to_rgb(&eta, ColorKind::Unbounded);
        let k = spectrum_to_rgb(&k, ColorKind::Unbounded);
        assert!(
            close(eta, [0.045_234_1, 0.585_709, 1.336_92], 1e-4),
            "{eta}"
        );
        assert!(close(k, [3.388_69, 2.349_04, 1.875_16], 1e-4), "{k}");
    }

    #[test]
    fn narrow_band_is_saturated() {
        let red = sampled_spectrum_to_rgb(&[(600.0, 1.0), (700.0, 1.0)], true);
        assert!(red.x > 0.7 && red.y < 0.05 && red.z < 0.05, "{red}");
        // Out of gamut: negative channels are clamped to zero in every role
        // (Mitsuba warns and does the same).
        let green = spectrum_to_rgb(&[(500.0, 1.0), (501.0, 1.0)], ColorKind::Illuminant);
        assert!(
            close(green, [0.0, 0.005_514_65, 0.001_892_75], 1e-6),
            "{green}"
        );
    }

    #[test]
    fn tables_interpolate() {
        assert_eq!(cie1931_xyz(500.0), [0.0049, 0.323, 0.272]);
        assert_eq!(cie1931_xyz(359.0), [0.0; 3]);
        assert_eq!(cie1931_xyz(831.0), [0.0; 3]);
        assert!((d65(560.0) - 100.0).abs() < 1e-4);
        // Halfway between the 360 and 365 nm entries.
        assert!((d65(362.5) - 0.5 * (46.6383 + 49.3637)).abs() < 1e-4);
        assert_eq!(
            interpolate_spectrum(&[(400.0, 1.0), (500.0, 3.0)], 450.0),
            Some(2.0)
        );
        assert_eq!(
            interpolate_spectrum(&[(400.0, 1.0), (500.0, 3.0)], 500.0),
            Some(3.0)
        );
        assert_eq!(
            interpolate_spectrum(&[(400.0, 1.0), (500.0, 3.0)], 501.0),
            None
        );
    }
}
