//! `directional`: light arriving from one direction, as from a distant
//! source.
//!
//! | parameter    | type           | default    | meaning                                    |
//! |--------------|----------------|------------|--------------------------------------------|
//! | `irradiance` | rgb / spectrum | 1          | irradiance E on a surface facing the light |
//! | `direction`  | vector         | (0, 0, 1)  | direction the light travels (or `to_world` applied to +z) |
//!
//! ```xml
//! <emitter type="directional"><vector name="direction" value="0, 0, -1"/><rgb name="irradiance" value="1"/></emitter>
//! ```
//!
//! A delta light: the sample carries pdf 1 and radiance E, so a diffuse
//! surface facing the light reflects ρE/π.

use super::{EmitterContext, EmitterModel, EmitterSample};
use crate::params::{ColorKind, ParamError, Params};
use crate::Rgb;
use glam::{Vec2, Vec3};

/// A directional light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionalLight {
    /// Unit direction of travel.
    pub direction: Vec3,
    /// Irradiance.
    pub irradiance: Rgb,
}

impl DirectionalLight {
    /// Builds the light from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let t = p.transform_or_identity("to_world")?;
        let d = p.vector("direction")?.unwrap_or(Vec3::Z);
        let direction = t
            .vector(d)
            .try_normalize()
            .ok_or_else(|| p.param_error("direction", "must not be zero"))?;
        Ok(Self {
            direction,
            irradiance: p.color_or("irradiance", ColorKind::Illuminant, Rgb::ONE)?,
        })
    }
}

impl EmitterModel for DirectionalLight {
    fn sample_direction(&self, _: &EmitterContext, _: Vec3, _u: Vec2) -> Option<EmitterSample> {
        Some(EmitterSample {
            wi: -self.direction,
            dist: f32::INFINITY,
            pdf: 1.0,
            radiance: self.irradiance,
            is_delta: true,
        })
    }

    fn pdf_direction(&self, _: &EmitterContext, _: Vec3, _: Vec3, _: Vec3, _: Vec3) -> f32 {
        0.0
    }

    fn is_delta(&self) -> bool {
        true
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::light::tests::Variant;
    use crate::light::Emitter;

    pub(crate) fn test_variants() -> Vec<Variant> {
        vec![Variant::new(
            "directional",
            Emitter::Directional(DirectionalLight {
                direction: Vec3::new(0.3, -0.4, -0.8).normalize(),
                irradiance: Rgb::new(1.0, 2.0, 3.0),
            }),
        )]
    }

    #[test]
    fn directional_light_pdf_conventions() {
        let l = DirectionalLight {
            direction: -Vec3::Z,
            irradiance: Rgb::splat(3.0),
        };
        let ctx = EmitterContext::EMPTY;
        for p in [Vec3::ZERO, Vec3::new(5.0, -2.0, 1.0)] {
            let s = l.sample_direction(&ctx, p, Vec2::new(0.5, 0.5)).unwrap();
            assert!(s.is_delta && s.pdf == 1.0 && s.dist.is_infinite());
            assert_eq!(s.wi, Vec3::Z);
            assert_eq!(s.radiance, Rgb::splat(3.0), "no falloff");
        }
        assert_eq!(
            l.pdf_direction(&ctx, Vec3::ZERO, Vec3::ZERO, Vec3::Z, Vec3::Z),
            0.0
        );
    }
}
