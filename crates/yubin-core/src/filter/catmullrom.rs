//! `catmullrom`: the Catmull–Rom cubic, the Mitchell–Netravali filter
//! with B = 0 and C = 1/2 (radius 2 pixels), as in Mitsuba 3: an
//! interpolating spline, sharper than `mitchell`, with more ringing.
//!
//! No parameters.
//!
//! ```xml
//! <rfilter type="catmullrom"/>
//! ```

use super::Filter;
use crate::params::{ParamError, Params};

/// Builds the filter (it has no parameters).
pub(super) fn from_params(_: &mut dyn Params) -> Result<Filter, ParamError> {
    Ok(Filter::Mitchell { b: 0.0, c: 0.5 })
}
