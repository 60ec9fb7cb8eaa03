//! `point`: an isotropic point light.
//!
//! | parameter   | type           | default   | meaning                          |
//! |-------------|----------------|-----------|----------------------------------|
//! | `intensity` | rgb / spectrum | 1         | radiant intensity I (W/sr)       |
//! | `position`  | point          | (0, 0, 0) | position (or `to_world`'s origin)|
//!
//! ```xml
//! <emitter type="point"><point name="position" value="0, 2, 0"/><rgb name="intensity" value="10"/></emitter>
//! ```
//!
//! Incident radiance-times-pdf at distance d is I/d²; a delta light:
//! its sample carries pdf 1 and `is_delta`, and `pdf_direction` is 0
//! because no ray can hit it.

use super::{EmitterContext, EmitterModel, EmitterSample};
use crate::params::{ColorKind, ParamError, Params};
use crate::Rgb;
use glam::{Vec2, Vec3};

/// A point light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointLight {
    /// World position.
    pub position: Vec3,
    /// Radiant intensity.
    pub intensity: Rgb,
}

impl PointLight {
    /// Builds the light from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let t = p.transform_or_identity("to_world")?;
        let position = p.point("position")?.unwrap_or(Vec3::ZERO);
        Ok(Self {
            position: t.point(position),
            intensity: p.color_or("intensity", ColorKind::Illuminant, Rgb::ONE)?,
        })
    }
}

impl EmitterModel for PointLight {
    fn sample_direction(&self, _: &EmitterContext, ref_p: Vec3, _u: Vec2) -> Option<EmitterSample> {
        let delta = self.position - ref_p;
        let dist2 = delta.length_squared();
        if dist2 == 0.0 {
            return None;
        }
        let dist = dist2.sqrt();
        Some(EmitterSample {
            wi: delta / dist,
            dist,
            pdf: 1.0,
            radiance: self.intensity / dist2,
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

    /// Emits uniformly over the sphere.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let mut v = Variant::new(
            "point",
            Emitter::Point(PointLight {
                position: Vec3::new(1.0, 0.5, -0.5),
                intensity: Rgb::new(3.0, 1.0, 2.0),
            }),
        );
        v.emission_pdf = Some(|_, _| 0.25 * std::f32::consts::FRAC_1_PI);
        vec![v]
    }

    #[test]
    fn point_light_pdf_conventions() {
        let l = PointLight {
            position: Vec3::new(0.0, 2.0, 0.0),
            intensity: Rgb::splat(8.0),
        };
        let ctx = EmitterContext::EMPTY;
        let s = l
            .sample_direction(&ctx, Vec3::ZERO, Vec2::new(0.3, 0.9))
            .unwrap();
        assert!(s.is_delta && s.pdf == 1.0 && l.is_delta());
        assert_eq!(s.wi, Vec3::Y);
        assert_eq!(s.dist, 2.0);
        assert_eq!(s.radiance, Rgb::splat(2.0), "inverse-square falloff");
        assert_eq!(
            l.pdf_direction(&ctx, Vec3::ZERO, l.position, Vec3::Z, Vec3::Y),
            0.0
        );
    }
}
