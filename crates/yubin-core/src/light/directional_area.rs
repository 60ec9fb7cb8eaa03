//! `directionalarea`: a surface that emits only along its normal, as if
//! each point were a tiny directional light (Mitsuba 3's plugin).
//!
//! | parameter  | type          | default | meaning                                         |
//! |------------|---------------|---------|-------------------------------------------------|
//! | `radiance` | rgb / texture | 1       | power per unit area leaving along the normal (W/m²) |
//!
//! ```xml
//! <shape type="rectangle">
//!     <emitter type="directionalarea"><rgb name="radiance" value="3"/></emitter>
//! </shape>
//! ```
//!
//! Mitsuba's conventions, checked on its `scalar_rgb` variant: the emitted
//! flux is `radiance` × area, all of it travelling along the shape's
//! (emitting) normal, so a surface facing it head-on receives an
//! irradiance of `radiance`. Emission is a delta in direction: a ray from
//! the camera or a BSDF never meets it and a light sample from a point
//! never reaches it, so `path` and `direct` render it (and what it lights)
//! black, and the light BVH leaves it out. Only paths that start at the
//! lights see it: render it with `ptracer`, whose emission rays leave a
//! uniform point of the shape along its normal with weight
//! `radiance` × area.

use super::{EmitterContext, EmitterModel, EmitterSample};
use crate::texture::Tex;
use glam::{Vec2, Vec3};

/// A directional area light on shape `shape`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionalAreaLight {
    /// The shape it covers (index into the scene's shapes).
    pub shape: u32,
    /// Flux per unit area, along the normal.
    pub radiance: Tex,
}

impl EmitterModel for DirectionalAreaLight {
    fn sample_direction(&self, _: &EmitterContext, _: Vec3, _: Vec2) -> Option<EmitterSample> {
        None
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
    use crate::math::Transform;
    use crate::shape::{Rectangle, Shape};
    use crate::Rgb;

    /// A scaled, tilted square: emission weights average to radiance × area.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let to_world = Transform::new(
            glam::Affine3A::from_rotation_y(0.7)
                * glam::Affine3A::from_scale(Vec3::new(1.5, 0.5, 1.0)),
        )
        .unwrap();
        vec![Variant {
            shapes: vec![Shape::Rectangle(Rectangle::new(to_world, false))],
            ..Variant::new(
                "directionalarea on a rectangle",
                Emitter::DirectionalArea(DirectionalAreaLight {
                    shape: 0,
                    radiance: Tex::Const(Rgb::new(2.0, 1.0, 3.0)),
                }),
            )
        }]
    }
}
