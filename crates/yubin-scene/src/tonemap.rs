//! Display transforms for 8-bit output (PNG, JPEG): an exposure in stops,
//! then a view: a built-in tone curve followed by the sRGB encoding, or an
//! OpenColorIO display view ([`crate::ocio`]), which encodes for its
//! display itself. EXR output stays scene-linear.
//!
//! - `srgb`: no curve; values above 1 clip.
//! - `filmic`: John Hable's filmic curve ("Filmic Tonemapping Operators",
//!   2010; the Uncharted 2 operator): f(x) = (x(Ax + CB) + DE) /
//!   (x(Ax + B) + DF) − E/F with A = 0.15, B = 0.50, C = 0.10, D = 0.20,
//!   E = 0.02, F = 0.30, applied to 2x and divided by f(W), W = 11.2: a toe
//!   that deepens shadows, a shoulder that rolls highlights off instead of
//!   clipping them, white at scene value W / 2 = 5.6.
//! - `agx`: AgX (Troy Sobotka, 2022), with the curve of Blender's AgX view
//!   (Eary Chow's parameters, Blender 4.0): each channel, after Sobotka's
//!   inset of the Rec.709 primaries toward white, is encoded as
//!   t = (log2(x / 0.18) + 10) / 16.5 (10 stops below mid grey to 6.5
//!   above, clamped), shaped by the power sigmoid
//!   y = y_p + s·d / (1 + a·|d|^p)^(1/p), d = t − t_p, with pivot
//!   (t_p, y_p) = (10/16.5, 0.18^(1/2.4)), slope s = 2.4, toe and shoulder
//!   powers p = 1.5 and each side's a fixed so that the curve runs from
//!   (0, 0) to (1, 1), then outset (the inset's inverse) and decoded with
//!   the power 2.4: mid grey stays 0.18, highlights desaturate toward
//!   white instead of clipping to the primaries. On greys it is Blender's
//!   AgX view within a quarter of an 8-bit level (test:
//!   `ocio_reference`); colours differ a little, as Blender's formation
//!   works in E-Gamut with a hue rotation.

use crate::image_io::{linear_to_srgb, Image};
use crate::ocio::Processor;
use rayon::prelude::*;
use std::sync::{Arc, LazyLock};

/// A tone curve.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ToneCurve {
    /// `srgb`: clip at 1.
    Srgb,
    /// `filmic`: Hable's curve.
    Filmic,
    /// `agx`: AgX with Blender's curve.
    Agx,
}

/// Every tone curve by name.
pub const CURVES: &[(&str, ToneCurve)] = &[
    ("srgb", ToneCurve::Srgb),
    ("filmic", ToneCurve::Filmic),
    ("agx", ToneCurve::Agx),
];

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

/// Sobotka's AgX inset of linear Rec.709 (rows: output channels), as
/// published with his configuration (the same numbers as in Wrensch's
/// "Minimal AgX implementation", 2023).
const AGX_INSET: [[f32; 3]; 3] = [
    [0.842_479_06, 0.078_433_6, 0.079_223_745],
    [0.042_328_242, 0.878_468_64, 0.079_166_13],
    [0.042_375_655, 0.078_433_6, 0.879_143],
];
/// Stops below and above mid grey that the log encoding spans.
const AGX_STOPS_BELOW: f32 = 10.0;
const AGX_STOPS_ABOVE: f32 = 6.5;
/// Slope of the sigmoid at its pivot, its toe and shoulder powers, and
/// the power of the display encoding it produces.
const AGX_SLOPE: f32 = 2.4;
const AGX_POWER: f32 = 1.5;
const AGX_GAMMA: f32 = 2.4;

fn mat3_mul(m: &[[f32; 3]; 3], v: [f32; 3]) -> [f32; 3] {
    [0, 1, 2].map(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
}

/// The outset: the inset's inverse, computed once.
static AGX_OUTSET: LazyLock<[[f32; 3]; 3]> = LazyLock::new(|| mat3_inverse(&AGX_INSET));

fn mat3_inverse(m: &[[f32; 3]; 3]) -> [[f32; 3]; 3] {
    let cols = glam::Mat3::from_cols_array_2d(m).transpose().inverse();
    cols.transpose().to_cols_array_2d()
}

/// The AgX sigmoid on the log-encoded value t in [0, 1].
fn agx_sigmoid(t: f32) -> f32 {
    let pivot_t = AGX_STOPS_BELOW / (AGX_STOPS_BELOW + AGX_STOPS_ABOVE);
    let pivot_y = 0.18f32.powf(1.0 / AGX_GAMMA);
    let (s, p) = (AGX_SLOPE, AGX_POWER);
    // The side's a puts its end point, (0, 0) or (1, 1), on the curve:
    // s·w / (1 + a·w^p)^(1/p) = h for the side's width w and height h.
    let (w, h) = if t < pivot_t {
        (pivot_t, pivot_y)
    } else {
        (1.0 - pivot_t, 1.0 - pivot_y)
    };
    let a = ((s * w / h).powf(p) - 1.0) / w.powf(p);
    let d = t - pivot_t;
    pivot_y + s * d / (1.0 + a * d.abs().powf(p)).powf(1.0 / p)
}

/// AgX of a linear Rec.709 value, display-linear.
fn agx(rgb: [f32; 3]) -> [f32; 3] {
    let inset = mat3_mul(&AGX_INSET, rgb.map(|v| v.max(0.0)));
    let range = AGX_STOPS_BELOW + AGX_STOPS_ABOVE;
    let shaped = inset.map(|v| {
        let t = ((v.max(1e-10) / 0.18).log2() + AGX_STOPS_BELOW) / range;
        agx_sigmoid(t.clamp(0.0, 1.0))
    });
    let outset = mat3_mul(&AGX_OUTSET, shaped);
    outset.map(|v| v.clamp(0.0, 1.0).powf(AGX_GAMMA))
}

impl ToneCurve {
    /// The curve called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        CURVES.iter().find(|(n, _)| *n == name).map(|(_, c)| *c)
    }

    /// Display-linear value in [0, 1] of scene-linear (Rec.709) `rgb`.
    pub fn apply(self, rgb: [f32; 3]) -> [f32; 3] {
        match self {
            ToneCurve::Srgb => rgb.map(|x| x.clamp(0.0, 1.0)),
            ToneCurve::Filmic => {
                rgb.map(|x| (hable(HABLE_BIAS * x.max(0.0)) / hable(HABLE_WHITE)).min(1.0))
            }
            ToneCurve::Agx => agx(rgb),
        }
    }
}

/// How an 8-bit image shows scene-linear values.
#[derive(Clone, Debug)]
pub enum View {
    /// A built-in curve, then the sRGB encoding.
    Curve(ToneCurve),
    /// An OpenColorIO display view (with its looks).
    Ocio(Arc<Processor>),
}

impl View {
    /// The display-encoded value of a scene-linear RGB value.
    pub fn apply(&self, rgb: [f32; 3]) -> [f32; 3] {
        match self {
            View::Curve(curve) => curve.apply(rgb).map(linear_to_srgb),
            View::Ocio(processor) => processor.apply(rgb),
        }
    }
}

/// The display image: each RGB value scaled by 2^`exposure` and shown
/// through `view` (other channels dropped); values are display-encoded,
/// ready for 8 bits.
pub fn to_display(img: &Image, exposure: f32, view: &View) -> Image {
    let scale = exposure.exp2();
    let mut data = vec![0.0f32; img.width * img.height * 3];
    // Rows in parallel: an OCIO view is tens of operations per pixel.
    let row_in = img.width * img.channels;
    data.par_chunks_mut(img.width * 3)
        .zip(img.data.par_chunks(row_in.max(1)))
        .for_each(|(out, row)| {
            for (o, px) in out.chunks_exact_mut(3).zip(row.chunks_exact(img.channels)) {
                let rgb = [
                    px[0],
                    px[1.min(img.channels - 1)],
                    px[2.min(img.channels - 1)],
                ];
                o.copy_from_slice(&view.apply(rgb.map(|v| v * scale)));
            }
        });
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
        let grey = |c: ToneCurve, x: f32| c.apply([x; 3])[0];
        for (_, c) in CURVES {
            // DE/DF − E/F is 0 up to rounding.
            assert!(grey(*c, 0.0).abs() < 1e-6);
            assert!(grey(*c, -1.0).abs() < 1e-6);
        }
        assert_eq!(grey(ToneCurve::Srgb, 0.25), 0.25);
        assert_eq!(grey(ToneCurve::Srgb, 3.0), 1.0);
        let f = |x| grey(ToneCurve::Filmic, x);
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

    /// AgX's defining points: the sigmoid runs from (0, 0) through its
    /// pivot (10/16.5, 0.18^(1/2.4)) with slope 2.4 to (1, 1), rising;
    /// so black stays black, mid grey stays 0.18 (up to the inset's
    /// rounding), 6.5 stops above it is white, and 10 below is black.
    #[test]
    fn agx_keeps_its_defining_points() {
        assert!(agx_sigmoid(0.0).abs() < 1e-5, "{}", agx_sigmoid(0.0));
        assert!(
            (agx_sigmoid(1.0) - 1.0).abs() < 1e-5,
            "{}",
            agx_sigmoid(1.0)
        );
        let pivot = 10.0 / 16.5;
        assert!((agx_sigmoid(pivot) - 0.18f32.powf(1.0 / 2.4)).abs() < 1e-6);
        let h = 1e-3;
        let slope = (agx_sigmoid(pivot + h) - agx_sigmoid(pivot - h)) / (2.0 * h);
        assert!((slope - 2.4).abs() < 1e-2, "slope {slope}");
        let mut last = -1.0;
        for i in 0..=1000 {
            let y = agx_sigmoid(i as f32 / 1000.0);
            assert!(y > last, "not increasing at {i}");
            last = y;
        }
        let grey = |x: f32| ToneCurve::Agx.apply([x; 3]);
        for v in grey(0.18) {
            assert!((v - 0.18).abs() < 2e-3, "mid grey {v}");
        }
        assert!(grey(0.18 * 2f32.powf(6.5))[0] > 0.999);
        assert!(grey(0.18 * 2f32.powf(-10.0))[0] < 1e-6);
        // A saturated highlight desaturates toward white instead of
        // clipping to pure red.
        let hot = ToneCurve::Agx.apply([40.0, 0.5, 0.5]);
        assert!(hot[1] > 0.3 && hot[0] > 0.95, "{hot:?}");
        assert_eq!(ToneCurve::from_name("agx"), Some(ToneCurve::Agx));
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
        let out = to_display(&img, 1.0, &View::Curve(ToneCurve::Srgb));
        assert_eq!(out.channels, 3);
        let enc = |v| linear_to_srgb(v);
        assert!((out.data[0] - enc(0.2)).abs() < 1e-6 && (out.data[2] - enc(0.6)).abs() < 1e-6);
    }
}
