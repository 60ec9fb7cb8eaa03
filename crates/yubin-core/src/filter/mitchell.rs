//! `mitchell`: the Mitchell–Netravali cubic (Mitchell and Netravali 1988,
//! "Reconstruction Filters in Computer Graphics"), radius 2 pixels, as in
//! Mitsuba 3. Its negative lobes sharpen; the family integrates to 1 for
//! every B and C.
//!
//! | parameter | type  | default | meaning                   |
//! |-----------|-------|---------|---------------------------|
//! | `B`       | float | 1/3     | the B parameter (blur)    |
//! | `C`       | float | 1/3     | the C parameter (ringing) |
//!
//! ```xml
//! <rfilter type="mitchell"><float name="B" value="0.3333"/><float name="C" value="0.3333"/></rfilter>
//! ```
//!
//! With |x| in pixels: (1/6)·((12 − 9B − 6C)|x|³ + (−18 + 12B + 6C)|x|² +
//! 6 − 2B) for |x| < 1, (1/6)·((−B − 6C)|x|³ + (6B + 30C)|x|² +
//! (−12B − 48C)|x| + 8B + 24C) for 1 ≤ |x| < 2, else 0.

use super::Filter;
use crate::params::{ParamError, Params};

/// Builds the filter from its scene parameters.
pub(super) fn from_params(p: &mut dyn Params) -> Result<Filter, ParamError> {
    let b = p.float_or("B", 1.0 / 3.0)?;
    let c = p.float_or("C", 1.0 / 3.0)?;
    if !(b.is_finite() && c.is_finite()) {
        return Err(p.error("B and C must be finite"));
    }
    Ok(Filter::Mitchell { b, c })
}

/// The Mitchell–Netravali cubic with parameters `b`, `c` at `x` pixels.
pub(super) fn eval(b: f32, c: f32, x: f32) -> f32 {
    let x = x.abs();
    let (x2, x3) = (x * x, x * x * x);
    let v = if x < 1.0 {
        (12.0 - 9.0 * b - 6.0 * c) * x3 + (-18.0 + 12.0 * b + 6.0 * c) * x2 + (6.0 - 2.0 * b)
    } else if x < 2.0 {
        (-b - 6.0 * c) * x3
            + (6.0 * b + 30.0 * c) * x2
            + (-12.0 * b - 48.0 * c) * x
            + (8.0 * b + 24.0 * c)
    } else {
        0.0
    };
    v / 6.0
}
