//! `hg`: the Henyey–Greenstein phase function (Henyey and Greenstein 1941,
//! "Diffuse radiation in the galaxy"), as Mitsuba 3's: one parameter, the
//! mean cosine g of the scattering angle; g > 0 scatters forward (light
//! keeps its direction), g < 0 backward, g = 0 is isotropic.
//!
//! | parameter | type  | default | meaning                              |
//! |-----------|-------|---------|--------------------------------------|
//! | `g`       | float | 0.8     | mean cosine, in (−1, 1)              |
//!
//! ```xml
//! <phase type="hg"><float name="g" value="0.7"/></phase>
//! ```
//!
//! With θ the angle between the new direction and the direction of
//! travel, p(θ) = (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2}). Sampled by
//! inverting its distribution in cos θ (Pharr et al., *Physically Based
//! Rendering*, 4th ed., §11.3.1), so the weight p / pdf is 1.

use super::{about_travel, PhaseFunction};
use crate::params::{ParamError, Params};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Builds the phase function from its scene parameters.
pub(super) fn from_params(p: &mut dyn Params) -> Result<PhaseFunction, ParamError> {
    let g = p.float_or("g", 0.8)?;
    if !(g > -1.0 && g < 1.0) {
        return Err(p.param_error(
            "g",
            &format!("must be between -1 and 1 (exclusive), not {g}"),
        ));
    }
    Ok(PhaseFunction::HenyeyGreenstein { g })
}

/// p for `cos_wo_wi` = wo · wi (wo pointing back along the path).
#[inline]
pub(super) fn eval(g: f32, cos_wo_wi: f32) -> f32 {
    // The angle to the direction of travel, −wo, has cosine −wo·wi.
    let denom = 1.0 + g * g + 2.0 * g * cos_wo_wi;
    (1.0 - g * g) / (4.0 * PI * denom * denom.max(0.0).sqrt())
}

/// A direction distributed as p about the direction of travel −wo.
#[inline]
pub(super) fn sample(g: f32, wo: Vec3, u: Vec2) -> Vec3 {
    let cos_theta = if g.abs() < 1e-3 {
        1.0 - 2.0 * u.x
    } else {
        let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u.x);
        ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
    };
    about_travel(wo, cos_theta, 2.0 * PI * u.y)
}
