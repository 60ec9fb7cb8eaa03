//! `constant`: uniform radiance arriving from every direction (an
//! environment at infinity).
//!
//! | parameter  | type           | default | meaning   |
//! |------------|----------------|---------|-----------|
//! | `radiance` | rgb / spectrum | 1       | radiance L|
//!
//! ```xml
//! <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
//! ```
//!
//! Sampled uniformly over the sphere of directions (density 1/4π) — except
//! under the MIS compensation of `path`, `volpath` and `direct` with BSDF
//! samples (their default), which leaves it to BSDF and phase sampling
//! alone unless it is hidden from indirect rays (`visible_indirect`):
//! cosine-weighted and glossy BSDF samples find a uniform sky better than
//! uniform directions, half of which point into the surface.

use super::{EmitterContext, EmitterModel, EmitterSample};
use crate::params::{ColorKind, ParamError, Params};
use crate::sampling::{square_to_uniform_sphere, UNIFORM_SPHERE_PDF};
use crate::Rgb;
use glam::{Vec2, Vec3};

/// A constant environment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConstantLight {
    /// Radiance.
    pub radiance: Rgb,
}

impl ConstantLight {
    /// Builds the light from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        Ok(Self {
            radiance: p.color_or("radiance", ColorKind::Illuminant, Rgb::ONE)?,
        })
    }
}

impl EmitterModel for ConstantLight {
    fn sample_direction(&self, _: &EmitterContext, _: Vec3, u: Vec2) -> Option<EmitterSample> {
        Some(EmitterSample {
            wi: square_to_uniform_sphere(u),
            dist: f32::INFINITY,
            pdf: UNIFORM_SPHERE_PDF,
            radiance: self.radiance,
            is_delta: false,
        })
    }

    fn pdf_direction(&self, _: &EmitterContext, _: Vec3, _: Vec3, _: Vec3, _: Vec3) -> f32 {
        UNIFORM_SPHERE_PDF
    }

    fn is_delta(&self) -> bool {
        false
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::light::tests::Variant;
    use crate::light::Emitter;

    pub(crate) fn test_variants() -> Vec<Variant> {
        let mut v = Variant::environment(
            "constant",
            Emitter::Constant(ConstantLight {
                radiance: Rgb::new(0.5, 1.0, 2.0),
            }),
        );
        // A constant integrates exactly on any grid.
        v.exact_power = true;
        vec![v]
    }
}
