//! `box`: every sample counts fully in the pixel it falls in, and only
//! there (radius ½ pixel).
//!
//! No parameters.
//!
//! ```xml
//! <rfilter type="box"/>
//! ```

use super::Filter;
use crate::params::{ParamError, Params};

/// Builds the filter (it has no parameters).
pub(super) fn from_params(_: &mut dyn Params) -> Result<Filter, ParamError> {
    Ok(Filter::Box)
}
