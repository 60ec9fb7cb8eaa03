//! Display transforms for 8-bit output (PNG): an exposure in stops, then a
//! tone curve from scene-linear to display-linear values in [0, 1] (the
//! PNG writer then applies the sRGB encoding). EXR output stays
//! scene-linear.
//!
//! - `srgb`: no curve; values above 1 clip.
//! - `filmic`: John Hable's filmic curve ("Filmic Tonemapping Operators",
//!   2010; the Uncharted 2 operator): f(x) = (x(Ax + CB) + DE) /
//!   (x(Ax + B) + DF) − E/F with A = 0.15, B = 0.50, C = 0.10, D = 0.20,
//!   E = 0.02, F = 0.30, applied to 2x and divided by f(W), W = 11.2: a toe
//!   that deepens shadows, a shoulder that rolls highlights off instead of
//!   clipping them, white at scene value W / 2 = 5.6.

use crate::image_io::Image;

/// A tone curve.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ToneCurve {
    /// `srgb`: clip at 1.
    Srgb,
    /// `filmic`: Hable's curve.
    Filmic,
}

/// Every tone curve by name.
pub const CURVES: &[(&str, ToneCurve)] =
    &[("srgb", ToneCurve::Srgb), ("filmic", ToneCurve::Filmic)];

/// Hable's constants (shoulder strength, linear strength, linear angle,
/// toe strength, toe numerator, toe denominator) and linear white point.
const HABLE: [f32; 6] = [0.15, 0.50, 0.10, 0.20, 0.02, 0.30];
const HABLE_WHITE: f32 = 11.2;
/// Hable's exposure bias: scene value 1 enters the curve at 2.
const HABLE_BIAS: f32 = 2.0;

fn hable(x: f32) -> f32 {
    let [a, b, c, d, e, f] = HABLE;
    (x * (a * x + c * b) + d * e) / (x * (a * x + b) + d * f) - e / f
}

impl ToneCurve {
    /// The curve called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        CURVES.iter().find(|(n, _)| *n == name).map(|(_, c)| *c)
    }

    /// Display-linear value in [0, 1] of scene-linear `x`.
    pub fn apply(self, x: f32) -> f32 {
        let x = x.max(0.0);
        match self {
            ToneCurve::Srgb => x.min(1.0),
            ToneCurve::Filmic => (hable(HABLE_BIAS * x) / hable(HABLE_WHITE)).min(1.0),
        }
    }
}

/// The display-linear image: each RGB value scaled by 2^`exposure` and
/// passed through `curve` (other channels dropped).
pub fn to_display(img: &Image, exposure: f32, curve: ToneCurve) -> Image {
    let scale = exposure.exp2();
    let data = img
        .data
        .chunks_exact(img.channels)
        .flat_map(|px| {
            let rgb = [
                px[0],
                px[1.min(img.channels - 1)],
                px[2.min(img.channels - 1)],
            ];
            rgb.map(|v| curve.apply(v * scale))
        })
        .collect();
    Image {
        width: img.width,
        height: img.height,
        channels: 3,
        data,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The curves' defining points: black stays black; `srgb` is the
    /// identity below 1 and clips above; `filmic` reaches white exactly at
    /// W / 2 = 5.6, stays below it before, rises monotonically, has its
    /// toe (below the identity near 0, f′(0) < 1) and keeps Hable's mid
    /// grey (0.18 → 0.12834: the formula at 0.36 over f(11.2), in f64).
    #[test]
    fn curves_keep_their_defining_points() {
        for (_, c) in CURVES {
            // DE/DF − E/F is 0 up to rounding.
            assert!(c.apply(0.0).abs() < 1e-6);
            assert!(c.apply(-1.0).abs() < 1e-6);
        }
        assert_eq!(ToneCurve::Srgb.apply(0.25), 0.25);
        assert_eq!(ToneCurve::Srgb.apply(3.0), 1.0);
        let f = |x| ToneCurve::Filmic.apply(x);
        assert!((f(5.6) - 1.0).abs() < 1e-6, "{}", f(5.6));
        assert!(f(5.5) < 1.0 && f(20.0) == 1.0);
        let mut last = 0.0;
        for i in 1..930 {
            let v = f(i as f32 * 0.006);
            assert!(v > last, "not increasing at {}", i as f32 * 0.006);
            last = v;
        }
        assert!(f(0.01) < 0.01, "toe: {}", f(0.01));
        assert!((f(0.18) - 0.128_338).abs() < 1e-5, "mid grey: {}", f(0.18));
        assert_eq!(ToneCurve::from_name("filmic"), Some(ToneCurve::Filmic));
        assert_eq!(ToneCurve::from_name("aces"), None);
    }

    /// Exposure scales before the curve: +1 stop doubles a value.
    #[test]
    fn exposure_is_in_stops() {
        let img = Image {
            width: 1,
            height: 1,
            channels: 4,
            data: vec![0.1, 0.2, 0.3, 1.0],
        };
        let out = to_display(&img, 1.0, ToneCurve::Srgb);
        assert_eq!(out.channels, 3);
        assert!((out.data[0] - 0.2).abs() < 1e-6 && (out.data[2] - 0.6).abs() < 1e-6);
    }
}
