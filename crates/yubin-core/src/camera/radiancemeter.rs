//! `radiancemeter`: the radiance arriving along one ray (Mitsuba 3's
//! `radiancemeter`).
//!
//! | parameter   | type      | default  | meaning |
//! |-------------|-----------|----------|---------|
//! | `to_world`  | transform | —        | the ray leaves to_world·(0,0,0) along to_world·(0,0,1); wins over `origin` and `direction` |
//! | `origin`    | point     | —        | where the ray starts (with `direction`, when there is no `to_world`) |
//! | `direction` | vector    | —        | where it goes                     |
//!
//! ```xml
//! <sensor type="radiancemeter">
//!     <point name="origin" value="-5, 0, 0"/>
//!     <vector name="direction" value="1, 0, 0"/>
//!     <film type="hdrfilm">
//!         <integer name="width" value="1"/>
//!         <integer name="height" value="1"/>
//!         <rfilter type="box"/>
//!     </film>
//! </sensor>
//! ```
//!
//! Every sample traces the same ray, so each pixel estimates the radiance
//! L(o, −d) that arrives at the origin along it. As in Mitsuba 3.9.1 the
//! film must be one pixel wide or one pixel tall (the pixels of a 1 × N
//! film are N estimates of the same value), and the ray starts 8.94·10⁻⁵
//! (Mitsuba's ray epsilon) along its direction, so that it does not meet
//! a surface the origin lies on. The direction is normalized: a `to_world`
//! that scales gives Mitsuba's `depth` in units of the scaled direction,
//! yubin's in distance.
//!
//! Reference: Mitsuba 3 documentation, "Radiance meter (radiancemeter)".

use crate::math::Ray;
use crate::params::{ParamError, Params};
use glam::Vec3;

/// Mitsuba 3's ray epsilon in single precision (1500 ulps of 1).
const RAY_EPSILON: f32 = 8.940_697e-5;

/// A sensor of the radiance along one ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Radiancemeter {
    /// Where the ray starts (already moved off the origin).
    origin: Vec3,
    /// Its direction (unit).
    direction: Vec3,
}

impl Radiancemeter {
    /// Builds the sensor from its scene parameters, for a film of `size`
    /// pixels.
    pub fn from_params(p: &mut dyn Params, size: [u32; 2]) -> Result<Self, ParamError> {
        if size[0] != 1 && size[1] != 1 {
            return Err(p.error(&format!(
                "a radiancemeter measures one ray: its film must be 1 pixel wide or tall, not {}x{}",
                size[0], size[1]
            )));
        }
        let (origin, direction) = match p.transform("to_world")? {
            Some(m) => {
                let m = glam::Affine3A::from_mat4(m.as_mat4());
                let _ = (p.point("origin")?, p.vector("direction")?);
                (m.transform_point3(Vec3::ZERO), m.transform_vector3(Vec3::Z))
            }
            None => match (p.point("origin")?, p.vector("direction")?) {
                (Some(o), Some(d)) => (o, d),
                _ => {
                    return Err(p.error(
                        "needs \"origin\" and \"direction\" both (or a \"to_world\" transform)",
                    ))
                }
            },
        };
        let direction = direction
            .try_normalize()
            .ok_or_else(|| p.param_error("direction", "must not be zero"))?;
        Ok(Self {
            origin: origin + direction * RAY_EPSILON,
            direction,
        })
    }

    /// The sensor's ray.
    pub fn ray(&self) -> Ray {
        Ray::new(self.origin, self.direction)
    }

    /// Where its ray starts.
    pub fn origin(&self) -> Vec3 {
        self.origin
    }
}
