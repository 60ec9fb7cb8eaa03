//! `lanczos`: the windowed sinc sinc(x)·sinc(x/τ) with τ = `lobes`,
//! radius τ pixels (Duchon 1979, "Lanczos filtering in one and two
//! dimensions"), as Mitsuba 3's. The sharpest of the filters, with
//! ringing around edges.
//!
//! | parameter | type    | default | meaning                         |
//! |-----------|---------|---------|---------------------------------|
//! | `lobes`   | integer | 3       | lobes of the sinc (and radius)  |
//!
//! ```xml
//! <rfilter type="lanczos"><integer name="lobes" value="2"/></rfilter>
//! ```
//!
//! With sinc(x) = sin(πx)/(πx): the weight is sin(πx)·sin(πx/τ)/(π²x²/τ)
//! for |x| < τ, 1 at 0, and 0 beyond.

use super::Filter;
use crate::params::{ParamError, Params};
use std::f32::consts::PI;

/// Builds the filter from its scene parameters.
pub(super) fn from_params(p: &mut dyn Params) -> Result<Filter, ParamError> {
    let lobes = p.integer_or("lobes", 3)?;
    if !(1..=16).contains(&lobes) {
        return Err(p.param_error("lobes", &format!("must be between 1 and 16, not {lobes}")));
    }
    Ok(Filter::Lanczos {
        lobes: lobes as u32,
    })
}

/// The Lanczos window with `lobes` lobes at `x` pixels.
pub(super) fn eval(lobes: u32, x: f32) -> f32 {
    let tau = lobes as f32;
    let x = x.abs();
    if x < 1e-4 {
        1.0
    } else if x < tau {
        let px = PI * x;
        (px.sin() * (px / tau).sin()) / (px * px / tau)
    } else {
        0.0
    }
}
