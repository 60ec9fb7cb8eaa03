//! `rawconstant`: a constant returned as given, never converted or
//! checked (Mitsuba 3's `rawconstant`): a float, or three values given as
//! a `vector` or `rgb`, e.g. a constant normal map.
//!
//! | parameter | type                  | default | meaning |
//! |-----------|-----------------------|---------|---------|
//! | `value`   | float / vector / rgb  | 1       | the value; a float is used for all three channels |
//!
//! ```xml
//! <bsdf type="normalmap">
//!     <texture type="rawconstant" name="normalmap"><vector name="value" value="0.5, 0.5, 1"/></texture>
//!     <bsdf type="diffuse"/>
//! </bsdf>
//! ```
//!
//! Read as a single value (roughness, a weight), three values give their
//! mean. Unlike a colour parameter, the value is not limited to [0, 1]
//! for reflectances: it is the user's as written.

use super::TextureModel;
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::Rgb;
use glam::Vec2;

/// A constant, unconverted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawConstant {
    /// The value (a float repeated three times).
    pub value: Rgb,
}

impl RawConstant {
    /// Builds the texture from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let value = if !p.has("value") {
            Rgb::ONE
        } else if let Ok(Some(v)) = p.float("value") {
            Rgb::splat(v)
        } else if let Ok(Some(v)) = p.vector("value") {
            Rgb::new(v.x, v.y, v.z)
        } else {
            p.color("value", ColorKind::Unbounded)?.unwrap_or(Rgb::ONE)
        };
        if !(value.x.is_finite() && value.y.is_finite() && value.z.is_finite()) {
            return Err(p.param_error("value", "must be finite"));
        }
        Ok(Self { value })
    }
}

impl TextureModel for RawConstant {
    #[inline]
    fn eval(&self, _: &Materials, _: &SurfaceInteraction) -> Rgb {
        self.value
    }

    #[inline]
    fn eval_1(&self, _: &Materials, _: &SurfaceInteraction) -> f32 {
        (self.value.x + self.value.y + self.value.z) / 3.0
    }

    fn eval_1_grad(&self, m: &Materials, si: &SurfaceInteraction) -> (f32, Vec2) {
        (self.eval_1(m, si), Vec2::ZERO)
    }

    fn mean(&self, _: &Materials) -> f32 {
        (self.value.x + self.value.y + self.value.z) / 3.0
    }
}
