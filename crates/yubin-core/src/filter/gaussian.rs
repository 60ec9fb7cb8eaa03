//! `gaussian`: a Gaussian of standard deviation `stddev` pixels, cut at
//! 4·`stddev` and shifted down by its value there so that it reaches 0
//! without a step, as in Mitsuba 3 and pbrt-v4 §8.8. Mitsuba's default
//! filter, and yubin's.
//!
//! | parameter | type  | default | meaning                          |
//! |-----------|-------|---------|----------------------------------|
//! | `stddev`  | float | 0.5     | standard deviation in pixels     |
//!
//! ```xml
//! <rfilter type="gaussian"><float name="stddev" value="0.5"/></rfilter>
//! ```

use super::{positive, Filter};
use crate::params::{ParamError, Params};

/// Builds the filter from its scene parameters.
pub(super) fn from_params(p: &mut dyn Params) -> Result<Filter, ParamError> {
    Ok(Filter::Gaussian {
        stddev: positive(p, "stddev", 0.5)?,
    })
}
