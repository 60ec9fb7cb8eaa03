//! Pixel reconstruction filters (closed enum): `box`, `tent`, `gaussian`,
//! `mitchell`, `catmullrom`, `lanczos`, one file each. Each sample is
//! splatted to every pixel within the filter's radius with weight
//! f(x)·f(y) of its offset from the pixel centre; a pixel's value is
//! Σ w L / Σ w. Splatting reads the weights from a [`FilterTable`] built
//! once per render, so no `exp` or `sin` runs per pixel per sample.

mod r#box;
mod catmullrom;
mod gaussian;
mod lanczos;
mod mitchell;
mod tent;

use crate::params::{plugin_of, ParamError, Params};
use wide::{f32x8, i32x8, CmpLt};

/// A separable reconstruction filter (closed enum).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Filter {
    /// `box`: every sample goes to its own pixel, weight 1.
    Box,
    /// `tent`: linear falloff to zero at `radius`.
    Tent {
        /// Radius in pixels.
        radius: f32,
    },
    /// `gaussian`.
    Gaussian {
        /// Standard deviation in pixels.
        stddev: f32,
    },
    /// `mitchell` (and `catmullrom`: B = 0, C = 1/2).
    Mitchell {
        /// The B parameter.
        b: f32,
        /// The C parameter.
        c: f32,
    },
    /// `lanczos`.
    Lanczos {
        /// Lobes of the sinc (its radius in pixels).
        lobes: u32,
    },
}

impl Default for Filter {
    fn default() -> Self {
        Filter::Gaussian { stddev: 0.5 }
    }
}

/// Builds a filter plugin from its parameters.
pub type FilterFromParams = fn(&mut dyn Params) -> Result<Filter, ParamError>;

/// Every reconstruction filter plugin: its scene type string and constructor.
pub const PLUGINS: &[(&str, FilterFromParams)] = &[
    ("box", r#box::from_params),
    ("tent", tent::from_params),
    ("gaussian", gaussian::from_params),
    ("mitchell", mitchell::from_params),
    ("catmullrom", catmullrom::from_params),
    ("lanczos", lanczos::from_params),
];

/// A positive float parameter, `default` when absent.
fn positive(p: &mut dyn Params, name: &str, default: f32) -> Result<f32, ParamError> {
    let v = p.float_or(name, default)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(p.param_error(name, "must be positive"))
    }
}

impl Filter {
    /// Builds the filter `p` describes, by its plugin type.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        plugin_of(p, "rfilter", PLUGINS, None)?(p)
    }

    /// Support radius in pixels.
    pub fn radius(&self) -> f32 {
        match *self {
            Filter::Box => 0.5,
            Filter::Tent { radius } => radius,
            Filter::Gaussian { stddev } => 4.0 * stddev,
            Filter::Mitchell { .. } => 2.0,
            Filter::Lanczos { lobes } => lobes as f32,
        }
    }

    /// One-dimensional weight at offset `x`.
    #[inline]
    pub fn eval_1d(&self, x: f32) -> f32 {
        match *self {
            Filter::Box => {
                if (-0.5..0.5).contains(&x) {
                    1.0
                } else {
                    0.0
                }
            }
            Filter::Tent { radius } => (1.0 - x.abs() / radius).max(0.0),
            Filter::Gaussian { stddev } => {
                let r = 4.0 * stddev;
                let g = |v: f32| (-v * v / (2.0 * stddev * stddev)).exp();
                (g(x) - g(r)).max(0.0)
            }
            Filter::Mitchell { b, c } => mitchell::eval(b, c, x),
            Filter::Lanczos { lobes } => lanczos::eval(lobes, x),
        }
    }
}

/// Intervals of a [`FilterTable`] over the filter's radius.
const TABLE_SIZE: usize = 256;

/// A filter's profile tabulated over [0, radius] and read by linear
/// interpolation: what splatting evaluates, built once per render. Linear
/// interpolation at 256 intervals keeps every filter within 1e-3 of its
/// analytic weight (1e-4 of its peak for the Gaussian); the box filter is
/// read exactly.
#[derive(Clone, Debug, PartialEq)]
pub struct FilterTable {
    radius: f32,
    /// Table intervals per pixel.
    scale: f32,
    values: [f32; TABLE_SIZE + 1],
    is_box: bool,
}

impl FilterTable {
    /// Tabulates `filter`.
    pub fn new(filter: &Filter) -> Self {
        let radius = filter.radius();
        let step = radius / TABLE_SIZE as f32;
        let mut values = [0.0; TABLE_SIZE + 1];
        for (i, v) in values.iter_mut().enumerate() {
            *v = filter.eval_1d(i as f32 * step);
        }
        // The filters reach 0 at their radius (the box stops there).
        values[TABLE_SIZE] = 0.0;
        Self {
            radius,
            scale: TABLE_SIZE as f32 / radius,
            values,
            is_box: matches!(filter, Filter::Box),
        }
    }

    /// Support radius in pixels.
    #[inline]
    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// True for the box filter (a sample goes to its own pixel only).
    #[inline]
    pub fn is_box(&self) -> bool {
        self.is_box
    }

    /// One-dimensional weight at offset `x` (pixels).
    #[inline]
    pub fn eval_1d(&self, x: f32) -> f32 {
        if self.is_box {
            return if (-0.5..0.5).contains(&x) { 1.0 } else { 0.0 };
        }
        let t = x.abs() * self.scale;
        // NaN offsets weigh nothing too.
        if t >= TABLE_SIZE as f32 || t.is_nan() {
            return 0.0;
        }
        // In [0, TABLE_SIZE): a 32-bit conversion, cheaper than one to usize.
        let i = t as u32 as usize;
        let f = t - i as f32;
        self.values[i] + (self.values[i + 1] - self.values[i]) * f
    }

    /// [`FilterTable::eval_1d`] of eight offsets at once, lane by lane the
    /// same operations, bit for bit (the box filter excepted: its weights
    /// are not tabulated).
    #[inline]
    pub fn eval_8(&self, x: f32x8) -> f32x8 {
        debug_assert!(!self.is_box);
        let t = x.abs() * f32x8::splat(self.scale);
        // False for NaN too.
        let inside = t.cmp_lt(f32x8::splat(TABLE_SIZE as f32));
        // Lanes outside read entry 0 and are zeroed below.
        let i = (inside & t).fast_trunc_int().to_array();
        let f = t - f32x8::from_i32x8(i32x8::new(i));
        let (mut a, mut b) = ([0.0f32; 8], [0.0f32; 8]);
        for ((a, b), &i) in a.iter_mut().zip(&mut b).zip(&i) {
            let i = (i as usize).min(TABLE_SIZE - 1);
            (*a, *b) = (self.values[i], self.values[i + 1]);
        }
        let (a, b) = (f32x8::new(a), f32x8::new(b));
        inside.blend(a + (b - a) * f, f32x8::ZERO)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every filter with its defaults and a few other settings.
    fn every_filter() -> Vec<Filter> {
        vec![
            Filter::Box,
            Filter::Tent { radius: 1.0 },
            Filter::Tent { radius: 1.7 },
            Filter::Gaussian { stddev: 0.5 },
            Filter::Gaussian { stddev: 0.8 },
            Filter::Mitchell {
                b: 1.0 / 3.0,
                c: 1.0 / 3.0,
            },
            Filter::Mitchell { b: 0.0, c: 0.5 },
            Filter::Mitchell { b: 1.0, c: 0.0 },
            Filter::Lanczos { lobes: 3 },
            Filter::Lanczos { lobes: 2 },
        ]
    }

    /// Eight offsets at a time weigh what one at a time weighs, bit for
    /// bit: inside and outside the radius, at the table's ends, and for
    /// infinite and NaN offsets.
    #[test]
    fn eight_lane_weights_equal_single_ones() {
        let mut rng = crate::sampler::Pcg32::new(4, 7);
        for filter in every_filter().iter().filter(|f| !matches!(f, Filter::Box)) {
            let table = FilterTable::new(filter);
            let r = table.radius();
            for round in 0..500 {
                let mut x: [f32; 8] = std::array::from_fn(|_| (rng.next_f32() - 0.5) * 2.6 * r);
                if round == 0 {
                    x = [
                        0.0,
                        -0.0,
                        r,
                        -r,
                        r.next_down(),
                        f32::INFINITY,
                        f32::NAN,
                        1e30,
                    ];
                }
                let got = table.eval_8(f32x8::new(x)).to_array();
                for (x, got) in x.iter().zip(got) {
                    assert_eq!(
                        got.to_bits(),
                        table.eval_1d(*x).to_bits(),
                        "{filter:?} at {x}"
                    );
                }
            }
        }
    }

    /// ∫ f over its support, by the midpoint rule.
    fn integral(f: impl Fn(f32) -> f32, radius: f32) -> f64 {
        let n = 200_000;
        let h = 2.0 * radius as f64 / n as f64;
        (0..n)
            .map(|k| f((-radius as f64 + (k as f64 + 0.5) * h) as f32) as f64)
            .sum::<f64>()
            * h
    }

    #[test]
    fn filters_vanish_at_their_radius() {
        for f in every_filter() {
            let r = f.radius();
            assert!(f.eval_1d(r).abs() <= 1e-6, "{f:?}");
            assert!(f.eval_1d(0.0) > 0.0, "{f:?}");
            assert_eq!(f.eval_1d(0.3), f.eval_1d(-0.3), "{f:?}");
            let t = FilterTable::new(&f);
            assert!(t.eval_1d(r).abs() < 1e-6);
            assert_eq!(t.eval_1d(r + 0.1), 0.0);
            assert_eq!(t.eval_1d(f32::NAN), 0.0);
        }
        assert_eq!(Filter::Box.eval_1d(0.49), 1.0);
        assert_eq!(Filter::Box.eval_1d(0.5), 0.0);
    }

    /// The analytic forms at known points (Mitchell and Netravali 1988;
    /// the Lanczos window).
    #[test]
    fn filters_match_their_analytic_forms() {
        let mitchell = Filter::Mitchell {
            b: 1.0 / 3.0,
            c: 1.0 / 3.0,
        };
        let catmull_rom = Filter::Mitchell { b: 0.0, c: 0.5 };
        let lanczos = Filter::Lanczos { lobes: 3 };
        for (f, x, want) in [
            (mitchell, 0.0, 8.0 / 9.0),
            (mitchell, 1.0, 1.0 / 18.0),
            (mitchell, 1.5, -0.034_722_2),
            (catmull_rom, 0.0, 1.0),
            (catmull_rom, 1.0, 0.0),
            (catmull_rom, 0.5, 0.5625),
            (lanczos, 0.0, 1.0),
            (lanczos, 1.0, 0.0),
            (lanczos, 0.5, 0.607_927_1),
            (Filter::Tent { radius: 2.0 }, 0.5, 0.75),
        ] {
            let got = f.eval_1d(x);
            assert!((got - want).abs() < 1e-5, "{f:?} at {x}: {got}, not {want}");
        }
    }

    /// `ReconstructionFilter.eval` of Mitsuba 3.9.1 `scalar_rgb` with each
    /// plugin's defaults (and lanczos with 2 lobes) at x = 0, 0.3, 0.5, 1,
    /// 1.5, 1.9. Mitsuba's Gaussian deviates from its closed form by up to
    /// 8e-4 (its exponential is approximate); the others are exact.
    #[test]
    fn filters_match_mitsuba() {
        let xs = [0.0, 0.3, 0.5, 1.0, 1.5, 1.9];
        for (f, mitsuba, tolerance) in [
            (
                Filter::Mitchell {
                    b: 1.0 / 3.0,
                    c: 1.0 / 3.0,
                },
                [0.888889, 0.740389, 0.534722, 0.055556, -0.034722, -0.002944],
                1e-5,
            ),
            (
                Filter::Mitchell { b: 0.0, c: 0.5 },
                [1.0, 0.8155, 0.5625, 0.0, -0.0625, -0.0045],
                1e-5,
            ),
            (
                Filter::Lanczos { lobes: 3 },
                [1.0, 0.844343, 0.607927, 0.0, -0.135095, -0.02377],
                1e-5,
            ),
            (
                Filter::Lanczos { lobes: 2 },
                [1.0, 0.826975, 0.573159, 0.0, -0.063684, -0.002714],
                1e-5,
            ),
            (
                Filter::Gaussian { stddev: 0.5 },
                [0.999247, 0.835048, 0.606423, 0.13496, 0.010758, 0.000388],
                1e-3,
            ),
            (
                Filter::Tent { radius: 1.0 },
                [1.0, 0.7, 0.5, 0.0, 0.0, 0.0],
                1e-6,
            ),
            (Filter::Box, [1.0, 1.0, 0.0, 0.0, 0.0, 0.0], 0.0),
        ] {
            for (x, want) in xs.iter().zip(mitsuba) {
                let got = f.eval_1d(*x);
                assert!(
                    (got - want).abs() <= tolerance,
                    "{f:?} at {x}: {got} vs Mitsuba {want}"
                );
            }
        }
    }

    /// The table reads every filter within 1e-3 of its analytic weight
    /// (1e-4 for the Gaussian) and keeps its integral; the
    /// Mitchell–Netravali family integrates to 1 (the filters are used
    /// normalized by Σ w, as in Mitsuba, so only that is their scale).
    #[test]
    fn tables_follow_the_filters_and_their_integrals() {
        for f in every_filter() {
            let t = FilterTable::new(&f);
            let r = f.radius();
            let tolerance = if matches!(f, Filter::Gaussian { .. }) {
                1e-4
            } else {
                1e-3
            };
            for k in 0..10_000 {
                let x = -r + 2.0 * r * (k as f32 + 0.5) / 10_000.0;
                let (a, b) = (f.eval_1d(x), t.eval_1d(x));
                assert!((a - b).abs() < tolerance, "{f:?} at {x}: {a} vs table {b}");
            }
            let (exact, table) = (integral(|x| f.eval_1d(x), r), integral(|x| t.eval_1d(x), r));
            assert!(
                (table / exact - 1.0).abs() < 1e-4,
                "{f:?}: ∫ {exact} vs table {table}"
            );
            if let Filter::Mitchell { .. } = f {
                assert!((exact - 1.0).abs() < 1e-5, "{f:?}: ∫ = {exact}");
            }
            if let Filter::Lanczos { .. } = f {
                assert!((exact - 1.0).abs() < 0.02, "{f:?}: ∫ = {exact}");
            }
        }
    }
}
