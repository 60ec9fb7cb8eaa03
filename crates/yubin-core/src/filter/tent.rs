//! `tent`: weight falling linearly from 1 at the pixel centre to 0 at
//! `radius`.
//!
//! | parameter | type  | default | meaning            |
//! |-----------|-------|---------|--------------------|
//! | `radius`  | float | 1       | radius in pixels   |
//!
//! ```xml
//! <rfilter type="tent"><float name="radius" value="1.5"/></rfilter>
//! ```

use super::{positive, Filter};
use crate::params::{ParamError, Params};

/// Builds the filter from its scene parameters.
pub(super) fn from_params(p: &mut dyn Params) -> Result<Filter, ParamError> {
    Ok(Filter::Tent {
        radius: positive(p, "radius", 1.0)?,
    })
}
