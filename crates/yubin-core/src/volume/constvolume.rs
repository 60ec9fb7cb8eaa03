//! `constvolume`: the same value everywhere (Mitsuba 3's `const`
//! volume). A number or colour given where a volume is expected is one.
//!
//! | parameter | type            | default | meaning        |
//! |-----------|-----------------|---------|----------------|
//! | `value`   | float/rgb/spectrum | 1    | the value      |
//! | `to_world` | transform      | identity | places the volume's box, the unit cube [0, 1]³: a `heterogeneous` medium is empty outside it (as in Mitsuba) |
//!
//! ```xml
//! <volume type="constvolume" name="albedo"><rgb name="value" value="0.9, 0.5, 0.2"/></volume>
//! ```

use super::Volume;
use crate::params::{ColorKind, ParamError, Params};
use crate::Rgb;

/// Builds the volume from its scene parameters.
pub(super) fn from_params(p: &mut dyn Params) -> Result<Volume, ParamError> {
    p.transform("to_world")?;
    Ok(Volume::Const(p.color_or(
        "value",
        ColorKind::Unbounded,
        Rgb::ONE,
    )?))
}
