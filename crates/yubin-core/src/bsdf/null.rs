//! `null`: a surface that does not interact with light; it only marks a
//! boundary (of a participating medium, later) or hides geometry.
//!
//! No parameters.
//!
//! ```xml
//! <bsdf type="null"/>
//! ```
//!
//! Its one lobe continues a path in its own direction with weight 1. Paths
//! count the crossing as a bounce (as Mitsuba 3's integrators do) and shadow
//! rays pass through. Mitsuba 3's `null`.

use super::{BsdfFlags, BsdfSample};
use crate::material::Materials;
use crate::params::{ParamError, Params};
use crate::Rgb;
use glam::Vec3;

/// The index-matched, invisible boundary.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Null;

impl Null {
    /// Builds the BSDF (it has no parameters).
    pub fn from_params(_: &mut dyn Params) -> Result<Self, ParamError> {
        Ok(Self)
    }
}

impl Null {
    /// Lobes this material has.
    pub fn flags(&self, _: &Materials) -> BsdfFlags {
        BsdfFlags::NULL | BsdfFlags::FRONT_SIDE | BsdfFlags::BACK_SIDE
    }
}

/// The one sample of `null` (and of a `mask`'s transparent part): the
/// path goes on along `-wo` with weight 1.
#[inline]
pub(super) fn pass_through(wo: Vec3) -> BsdfSample {
    BsdfSample {
        wi: -wo,
        pdf: 1.0,
        eta: 1.0,
        sampled: BsdfFlags::NULL,
        weight: Rgb::ONE,
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::tests::Variant;
    use crate::bsdf::Material;

    /// Configurations for the table-driven tests in `bsdf/mod.rs`.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let mut v = Variant::last("null", vec![Material::Null(Null)]);
        v.lossless = true;
        vec![v]
    }
}
