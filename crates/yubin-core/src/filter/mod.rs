//! Pixel reconstruction filters (closed enum): `box`, `tent`, `gaussian`,
//! one file each. Each sample is splatted to every pixel within the
//! filter's radius with weight f(x)·f(y) of its offset from the pixel
//! centre; a pixel's value is Σ w L / Σ w.

mod r#box;
mod gaussian;
mod tent;

use crate::params::{plugin_of, ParamError, Params};

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
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filters_vanish_at_their_radius() {
        for f in [
            Filter::Tent { radius: 1.0 },
            Filter::Gaussian { stddev: 0.5 },
        ] {
            assert!(f.eval_1d(f.radius()) <= 1e-7);
            assert!(f.eval_1d(0.0) > 0.0);
            assert!(f.eval_1d(0.3) == f.eval_1d(-0.3));
        }
        assert_eq!(Filter::Box.eval_1d(0.49), 1.0);
        assert_eq!(Filter::Box.eval_1d(0.5), 0.0);
    }
}
