//! Mitsuba 3's spectrum plugins (`<spectrum type="...">`), turned into one
//! RGB value when the scene is built.
//!
//! | type          | parameter                          | type   | default | meaning |
//! |---------------|------------------------------------|--------|---------|---------|
//! | `uniform`     | `value`                            | float  | 1       | constant spectrum |
//! |               | `wavelength_min`, `wavelength_max` | float  | 360, 830 | its support (read; no effect in RGB) |
//! | `rawconstant` | `value`                            | float  | 1       | constant, never converted |
//! | `d65`         | `scale`                            | float  | 1       | CIE illuminant D65, scaled |
//! | `srgb`        | `color`                            | rgb    | —       | an RGB colour |
//! | `blackbody`   | `temperature`                      | float  | —       | Planck emitter at T kelvin |
//! |               | `wavelength_min`, `wavelength_max` | float  | 360, 830 | zero outside |
//! | `regular`     | `wavelength_min`, `wavelength_max` | float  | —       | range of the samples (nm) |
//! |               | `values`                           | string | —       | evenly spaced samples, `"0.2, 0.8, ..."` |
//! | `irregular`   | `wavelengths`, `values`            | string | —       | `"400, 500, ..."` and as many values |
//!
//! ```xml
//! <emitter type="area">
//!     <spectrum name="radiance" type="blackbody"><float name="temperature" value="5000"/></spectrum>
//! </emitter>
//! <bsdf type="diffuse">
//!     <spectrum name="reflectance" type="irregular">
//!         <string name="wavelengths" value="400, 500, 600, 700"/>
//!         <string name="values" value="0.2, 0.8, 0.5, 0.1"/>
//!     </spectrum>
//! </bsdf>
//! ```
//!
//! What each becomes, checked against Mitsuba 3.9.1's `scalar_rgb` (where it
//! renders the plugin) and `scalar_spectral` (where it does not):
//! - `uniform`, `rawconstant`: (v, v, v) in every role — even as an
//!   emitter's radiance, unlike a plain `<spectrum value="v"/>`, which is
//!   illuminant E there ([`super::constant_spectrum_to_rgb`]).
//! - `d65`: (s, s, s): D65 is the white of sRGB, and Mitsuba's RGB variants
//!   evaluate it as exactly that.
//! - `srgb`: the colour as given.
//! - `regular`, `irregular`: Mitsuba's RGB variants load them but fail when
//!   they are evaluated ("not implemented"). yubin converts them like the
//!   equivalent inline `<spectrum value="400:0.2, ..."/>`, by role (see
//!   [`super`]), which is also what Mitsuba's spectral variants render
//!   (to Monte Carlo noise) for an emitter.
//! - `blackbody`: not implemented in Mitsuba's RGB variants either. yubin
//!   integrates Planck's law in W·m⁻²·sr⁻¹·nm⁻¹ (the units of Mitsuba's
//!   spectral `blackbody`) against the matching functions like any emission
//!   spectrum; a 5000 K rectangle rendered with `scalar_spectral` agrees to
//!   0.3 % (its noise).
//!
//! References: Planck's law, e.g. pbrt-v4 §4.4.1; CIE 15:2004 for D65.

use super::{spectrum_fn_to_rgb, spectrum_to_rgb, Rgb};
use crate::params::{ColorKind, ParamError, Params};

/// A spectrum plugin with its parameters, as a scene front end reads it
/// (or fills it in directly).
#[derive(Clone, Debug, PartialEq)]
pub enum SpectrumPlugin {
    /// `uniform`: a constant.
    Uniform(f32),
    /// `rawconstant`: a constant that is never converted.
    RawConstant(f32),
    /// `d65`, with its `scale`.
    D65(f32),
    /// `srgb`: an RGB colour used as is.
    Srgb(Rgb),
    /// `blackbody`: temperature (K) and the wavelength range (nm) outside
    /// which it is zero.
    Blackbody {
        /// Temperature in kelvin.
        temperature: f32,
        /// Lower end of the support (nm).
        wavelength_min: f32,
        /// Upper end of the support (nm).
        wavelength_max: f32,
    },
    /// `regular`: evenly spaced samples from `wavelength_min` to
    /// `wavelength_max` (both included).
    Regular {
        /// Wavelength of the first value (nm).
        wavelength_min: f32,
        /// Wavelength of the last value (nm).
        wavelength_max: f32,
        /// At least two values.
        values: Vec<f32>,
    },
    /// `irregular`: samples at increasing wavelengths.
    Irregular {
        /// Increasing wavelengths (nm).
        wavelengths: Vec<f32>,
        /// One value per wavelength.
        values: Vec<f32>,
    },
}

/// Planck's law: spectral radiance of a black body at `temperature` K, in
/// W·m⁻²·sr⁻¹ per nanometre of wavelength, at `lambda` nm.
pub fn blackbody(lambda: f32, temperature: f32) -> f32 {
    // SI constants (2019 definitions); f64 because hc/λkT and λ⁵ span many
    // orders of magnitude.
    const C: f64 = 299_792_458.0;
    const H: f64 = 6.626_070_15e-34;
    const K_B: f64 = 1.380_649e-23;
    let l = f64::from(lambda) * 1e-9;
    let per_metre =
        2.0 * H * C * C / (l.powi(5) * ((H * C / (l * K_B * f64::from(temperature))).exp_m1()));
    (per_metre * 1e-9) as f32
}

/// The RGB colour of a black body at `temperature_k` as an emitter's
/// radiance (W·m⁻²·sr⁻¹ per nm, averaged over the visible range by the
/// luminance response; see the module docs).
pub fn blackbody_rgb(temperature_k: f32) -> Rgb {
    spectrum_fn_to_rgb(|l| Some(blackbody(l, temperature_k)), ColorKind::Illuminant)
}

/// A comma- or space-separated list of floats (`"0.2, 0.8 0.5"`).
fn float_list(p: &dyn Params, name: &str, text: &str) -> Result<Vec<f32>, ParamError> {
    text.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(|t| {
            t.parse::<f32>()
                .map_err(|_| p.param_error(name, &format!("\"{t}\" is not a number")))
        })
        .collect()
}

impl SpectrumPlugin {
    /// The plugin type strings [`SpectrumPlugin::from_params`] knows.
    pub const NAMES: &'static [&'static str] = &[
        "uniform",
        "rawconstant",
        "d65",
        "srgb",
        "blackbody",
        "regular",
        "irregular",
    ];

    /// Reads plugin `kind`'s parameters (see the module's table).
    pub fn from_params(kind: &str, p: &mut dyn Params) -> Result<Self, ParamError> {
        let required = |p: &mut dyn Params, name: &str| -> Result<f32, ParamError> {
            p.float(name)?
                .ok_or_else(|| p.error(&format!("{kind} spectrum needs \"{name}\"")))
        };
        let list = |p: &mut dyn Params, name: &str| -> Result<Vec<f32>, ParamError> {
            let text = p
                .string(name)?
                .ok_or_else(|| p.error(&format!("{kind} spectrum needs \"{name}\"")))?;
            float_list(p, name, &text)
        };
        let s = match kind {
            "uniform" => {
                p.mark_ignored("wavelength_min");
                p.mark_ignored("wavelength_max");
                Self::Uniform(p.float_or("value", 1.0)?)
            }
            "rawconstant" => Self::RawConstant(p.float_or("value", 1.0)?),
            "d65" => Self::D65(p.float_or("scale", 1.0)?),
            "srgb" => Self::Srgb(
                p.color("color", ColorKind::Unbounded)?
                    .ok_or_else(|| p.error("srgb spectrum needs \"color\""))?,
            ),
            "blackbody" => Self::Blackbody {
                temperature: required(p, "temperature")?,
                wavelength_min: p.float_or("wavelength_min", super::cie::CIE_MIN)?,
                wavelength_max: p.float_or("wavelength_max", super::cie::CIE_MAX)?,
            },
            "regular" => Self::Regular {
                wavelength_min: required(p, "wavelength_min")?,
                wavelength_max: required(p, "wavelength_max")?,
                values: list(p, "values")?,
            },
            "irregular" => Self::Irregular {
                wavelengths: list(p, "wavelengths")?,
                values: list(p, "values")?,
            },
            _ => {
                return Err(p.error(&format!(
                    "unknown spectrum type \"{kind}\" (known: {})",
                    Self::NAMES.join(", ")
                )))
            }
        };
        s.validate().map_err(|e| p.error(&e))?;
        Ok(s)
    }

    /// Checks the parameters (ranges, lengths, finiteness).
    pub fn validate(&self) -> Result<(), String> {
        let finite = |v: &[f32]| v.iter().all(|x| x.is_finite());
        match self {
            Self::Uniform(v) | Self::RawConstant(v) | Self::D65(v) if !v.is_finite() => {
                Err(format!("value {v} is not finite"))
            }
            Self::Srgb(c) if !c.is_finite() => Err(format!("colour {c} is not finite")),
            Self::Blackbody {
                temperature,
                wavelength_min,
                wavelength_max,
            } => {
                if !(*temperature > 0.0 && temperature.is_finite()) {
                    Err(format!("temperature must be positive, not {temperature}"))
                } else if wavelength_min.partial_cmp(wavelength_max)
                    != Some(std::cmp::Ordering::Less)
                {
                    Err(format!(
                        "wavelength_min ({wavelength_min}) must be below wavelength_max ({wavelength_max})"
                    ))
                } else {
                    Ok(())
                }
            }
            Self::Regular {
                wavelength_min,
                wavelength_max,
                values,
            } => {
                if values.len() < 2 || !finite(values) {
                    Err(format!(
                        "a regular spectrum needs at least two finite values, not {values:?}"
                    ))
                } else if wavelength_min.partial_cmp(wavelength_max)
                    != Some(std::cmp::Ordering::Less)
                {
                    Err(format!(
                        "wavelength_min ({wavelength_min}) must be below wavelength_max ({wavelength_max})"
                    ))
                } else {
                    Ok(())
                }
            }
            Self::Irregular {
                wavelengths,
                values,
            } => {
                if wavelengths.len() != values.len() {
                    Err(format!(
                        "{} wavelengths but {} values",
                        wavelengths.len(),
                        values.len()
                    ))
                } else if values.len() < 2 || !finite(values) || !finite(wavelengths) {
                    Err("an irregular spectrum needs at least two finite samples".into())
                } else if wavelengths.windows(2).any(|w| w[0] >= w[1]) {
                    Err(format!("wavelengths must increase: {wavelengths:?}"))
                } else {
                    Ok(())
                }
            }
            _ => Ok(()),
        }
    }

    /// The RGB value for a colour in `role` (see the module docs).
    pub fn to_rgb(&self, role: ColorKind) -> Result<Rgb, String> {
        self.validate()?;
        Ok(match self {
            Self::Uniform(v) | Self::RawConstant(v) | Self::D65(v) => Rgb::splat(*v),
            Self::Srgb(c) => *c,
            Self::Blackbody {
                temperature,
                wavelength_min,
                wavelength_max,
            } => spectrum_fn_to_rgb(
                |l| {
                    (*wavelength_min..=*wavelength_max)
                        .contains(&l)
                        .then(|| blackbody(l, *temperature))
                },
                role,
            ),
            Self::Regular {
                wavelength_min,
                wavelength_max,
                values,
            } => {
                let step = (wavelength_max - wavelength_min) / (values.len() - 1) as f32;
                let samples: Vec<(f32, f32)> = values
                    .iter()
                    .enumerate()
                    .map(|(i, &v)| (wavelength_min + step * i as f32, v))
                    .collect();
                spectrum_to_rgb(&samples, role)
            }
            Self::Irregular {
                wavelengths,
                values,
            } => {
                let samples: Vec<(f32, f32)> = wavelengths
                    .iter()
                    .copied()
                    .zip(values.iter().copied())
                    .collect();
                spectrum_to_rgb(&samples, role)
            }
        })
    }
}

/// The scene builder's entry point: reads spectrum plugin `kind` from `p`
/// and converts it for a colour in `role`.
pub fn spectrum_plugin_to_rgb(
    kind: &str,
    p: &mut dyn Params,
    role: ColorKind,
) -> Result<Rgb, ParamError> {
    let s = SpectrumPlugin::from_params(kind, p)?;
    let rgb = s.to_rgb(role).map_err(|e| p.error(&e))?;
    if role == ColorKind::Reflectance && rgb.min_element() < 0.0 {
        return Err(p.error(&format!("a reflectance cannot be negative: {rgb}")));
    }
    Ok(rgb)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::params::{MapParams, Value};

    fn close(a: Rgb, b: [f32; 3], rel: f32) -> bool {
        (a - Rgb::from_array(b)).abs().max_element() <= rel * Rgb::from_array(b).max_element()
    }

    /// Mitsuba 3.9.1 `scalar_spectral`, a 5000 K `blackbody` rectangle
    /// filling a 2×2 hdrfilm (rgb), 65536 samples a pixel, mean pixel: its
    /// Monte Carlo error is about 0.3 %.
    #[test]
    fn blackbody_matches_mitsuba_spectral() {
        let c = blackbody_rgb(5000.0);
        assert!(close(c, [15275.3, 12095.2, 9626.0], 0.006), "{c}");
        let warm = blackbody_rgb(2700.0);
        assert!(close(warm, [314.33, 130.66, 31.29], 0.006), "{warm}");
        // Planck's law itself: B(500 nm, 5000 K) = 1.2107e13 W m⁻³ sr⁻¹.
        assert!((blackbody(500.0, 5000.0) / 1.2107e4 - 1.0).abs() < 1e-3);
    }

    /// `regular` and `irregular` convert like inline spectra. Mitsuba 3.9.1
    /// `scalar_rgb`, `<spectrum value="400:0.2, 500:0.8, 600:0.5, 700:0.1"/>`
    /// as a `diffuse` reflectance (the BSDF's eval·π), an area emitter's
    /// radiance and a conductor's eta (`mi.traverse`).
    #[test]
    fn sampled_plugins_match_mitsuba_inline_spectra() {
        let regular = SpectrumPlugin::Regular {
            wavelength_min: 400.0,
            wavelength_max: 700.0,
            values: vec![0.2, 0.8, 0.5, 0.1],
        };
        let irregular = SpectrumPlugin::Irregular {
            wavelengths: vec![400.0, 500.0, 600.0, 700.0],
            values: vec![0.2, 0.8, 0.5, 0.1],
        };
        for s in [regular, irregular] {
            let refl = s.to_rgb(ColorKind::Reflectance).unwrap();
            let emit = s.to_rgb(ColorKind::Illuminant).unwrap();
            let eta = s.to_rgb(ColorKind::Unbounded).unwrap();
            assert!(close(refl, [0.324581, 0.707191, 0.508399], 1e-4), "{refl}");
            assert!(close(emit, [0.420713, 0.67223, 0.452322], 1e-4), "{emit}");
            assert!(close(eta, [0.324581, 0.707191, 0.508399], 1e-4), "{eta}");
        }
        // Unbounded is D65-weighted but not clamped at one: Mitsuba gives
        // eta (1.80056, 0.631952, 1.17118) for "400:1.5, 550:0.5, 700:3.0"
        // and the reflectance (1, 0.631952, 1).
        let big = SpectrumPlugin::Irregular {
            wavelengths: vec![400.0, 550.0, 700.0],
            values: vec![1.5, 0.5, 3.0],
        };
        let eta = big.to_rgb(ColorKind::Unbounded).unwrap();
        assert!(close(eta, [1.80056, 0.631952, 1.17118], 1e-4), "{eta}");
        let refl = big.to_rgb(ColorKind::Reflectance).unwrap();
        assert!(close(refl, [1.0, 0.631952, 1.0], 1e-4), "{refl}");
    }

    /// Mitsuba 3.9.1 `scalar_rgb`: `uniform` 0.789 and `d65` (scale 2) are
    /// grey in every role, `srgb` is its colour.
    #[test]
    fn constant_plugins() {
        for role in [
            ColorKind::Reflectance,
            ColorKind::Unbounded,
            ColorKind::Illuminant,
        ] {
            let u = SpectrumPlugin::Uniform(0.789).to_rgb(role).unwrap();
            assert_eq!(u, Rgb::splat(0.789));
            assert_eq!(SpectrumPlugin::RawConstant(0.789).to_rgb(role), Ok(u));
            assert_eq!(SpectrumPlugin::D65(2.0).to_rgb(role), Ok(Rgb::splat(2.0)));
            let c = Rgb::new(0.2, 0.4, 0.9);
            assert_eq!(SpectrumPlugin::Srgb(c).to_rgb(role), Ok(c));
        }
    }

    #[test]
    fn from_params_reads_everything() {
        let mut p = MapParams::new()
            .with("wavelengths", Value::String("400, 500 600,700".into()))
            .with("values", Value::String("0.2,0.8, 0.5, 0.1".into()));
        let rgb = spectrum_plugin_to_rgb("irregular", &mut p, ColorKind::Reflectance).unwrap();
        assert!(close(rgb, [0.324581, 0.707191, 0.508399], 1e-4), "{rgb}");
        assert!(p.unread().is_empty());

        let mut p = MapParams::new()
            .with("wavelength_min", Value::Float(400.0))
            .with("wavelength_max", Value::Integer(700))
            .with("values", Value::String("0.2, 0.8, 0.5, 0.1".into()));
        let s = SpectrumPlugin::from_params("regular", &mut p).unwrap();
        assert!(matches!(s, SpectrumPlugin::Regular { ref values, .. } if values.len() == 4));

        let mut p = MapParams::new().with("temperature", Value::Float(5000.0));
        let rgb = spectrum_plugin_to_rgb("blackbody", &mut p, ColorKind::Illuminant).unwrap();
        assert_eq!(rgb, blackbody_rgb(5000.0));

        let mut p = MapParams::new()
            .with("value", Value::Float(0.5))
            .with("wavelength_min", Value::Float(400.0));
        assert_eq!(
            spectrum_plugin_to_rgb("uniform", &mut p, ColorKind::Illuminant),
            Ok(Rgb::splat(0.5))
        );
        assert!(p.unread().is_empty());

        let mut p = MapParams::new().with("color", Value::Rgb(Rgb::new(0.1, 0.2, 0.3)));
        assert_eq!(
            spectrum_plugin_to_rgb("srgb", &mut p, ColorKind::Unbounded),
            Ok(Rgb::new(0.1, 0.2, 0.3))
        );
        assert_eq!(
            spectrum_plugin_to_rgb("d65", &mut MapParams::new(), ColorKind::Illuminant),
            Ok(Rgb::ONE)
        );
    }

    #[test]
    fn bad_parameters_are_errors() {
        let err = |kind: &str, p: MapParams| {
            let mut p = p;
            spectrum_plugin_to_rgb(kind, &mut p, ColorKind::Reflectance)
                .unwrap_err()
                .0
        };
        assert!(err("rainbow", MapParams::new()).contains("known: uniform"));
        assert!(err("blackbody", MapParams::new()).contains("temperature"));
        let neg = MapParams::new().with("temperature", Value::Float(-5.0));
        assert!(err("blackbody", neg).contains("positive"));
        let mismatch = MapParams::new()
            .with("wavelengths", Value::String("400, 500".into()))
            .with("values", Value::String("1, 2, 3".into()));
        assert!(err("irregular", mismatch).contains("2 wavelengths but 3 values"));
        let unsorted = MapParams::new()
            .with("wavelengths", Value::String("500, 400".into()))
            .with("values", Value::String("1, 2".into()));
        assert!(err("irregular", unsorted).contains("increase"));
        let nan = MapParams::new()
            .with("wavelength_min", Value::Float(400.0))
            .with("wavelength_max", Value::Float(700.0))
            .with("values", Value::String("0.1, x".into()));
        assert!(err("regular", nan).contains("\"x\" is not a number"));
        let backwards = MapParams::new()
            .with("wavelength_min", Value::Float(700.0))
            .with("wavelength_max", Value::Float(400.0))
            .with("values", Value::String("0.1, 0.2".into()));
        assert!(err("regular", backwards).contains("below"));
    }
}
