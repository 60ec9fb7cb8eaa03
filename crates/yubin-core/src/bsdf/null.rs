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

use super::{BsdfContext, BsdfFlags, BsdfModel, BsdfSample};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ParamError, Params};
use crate::Rgb;
use glam::{Vec2, Vec3};

/// The index-matched, invisible boundary.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Null;

impl Null {
    /// Builds the BSDF (it has no parameters).
    pub fn from_params(_: &mut dyn Params) -> Result<Self, ParamError> {
        Ok(Self)
    }
}

impl BsdfModel for Null {
    fn flags(&self, _: &Materials) -> BsdfFlags {
        BsdfFlags::NULL | BsdfFlags::FRONT_SIDE | BsdfFlags::BACK_SIDE
    }

    fn sample(
        &self,
        _: &Materials,
        _: &BsdfContext,
        _: &SurfaceInteraction,
        wo: Vec3,
        _: f32,
        _: Vec2,
    ) -> Option<BsdfSample> {
        Some(BsdfSample {
            wi: -wo,
            pdf: 1.0,
            eta: 1.0,
            sampled: BsdfFlags::NULL,
            weight: Rgb::ONE,
        })
    }

    fn eval(
        &self,
        _: &Materials,
        _: &BsdfContext,
        _: &SurfaceInteraction,
        _: Vec3,
        _: Vec3,
    ) -> Rgb {
        Rgb::ZERO
    }

    fn pdf(&self, _: &Materials, _: &BsdfContext, _: &SurfaceInteraction, _: Vec3, _: Vec3) -> f32 {
        0.0
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::tests::Variant;
    use crate::bsdf::Bsdf;

    /// Configurations for the table-driven tests in `bsdf/mod.rs`.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let mut v = Variant::last("null", vec![Bsdf::Null(Null)]);
        v.lossless = true;
        vec![v]
    }
}
