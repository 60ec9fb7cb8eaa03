//! `orthographic`: parallel projection (Mitsuba 3's).
//!
//! | parameter   | type      | default  | meaning                                                  |
//! |-------------|-----------|----------|----------------------------------------------------------|
//! | `to_world`  | transform | identity | camera to world, scale included: it sizes the view       |
//! | `near_clip` | float     | 0.01     | rays start this far along the view axis                  |
//! | `far_clip`  | float     | 10000    | and end this far                                         |
//!
//! ```xml
//! <sensor type="orthographic">
//!     <transform name="to_world">
//!         <scale x="2" y="2"/>
//!         <lookat origin="0,0,10" target="0,0,0" up="0,1,0"/>
//!     </transform>
//! </sensor>
//! ```
//!
//! Mitsuba's conventions: before `to_world`, the image spans x ∈ [−1, 1]
//! (left edge +1) and y ∈ [−h/w, h/w] (top +) of the plane z =
//! `near_clip`, and rays run along +z for `far_clip` − `near_clip`;
//! `to_world`'s scale sizes that window (unlike the projective cameras,
//! which drop it). It cannot be reached from a point, so `ptracer` refuses
//! it (Mitsuba's cannot be sampled either).

use crate::math::Ray;
use crate::params::{ParamError, Params};
use glam::{Affine3A, Vec2, Vec3};

/// A parallel-projection camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orthographic {
    to_world: Affine3A,
    /// The world direction of every ray.
    direction: Vec3,
    /// Half the window's height over its width (y spans ±this, x ±1).
    aspect_y: f32,
    resolution: Vec2,
    near_clip: f32,
    far_clip: f32,
}

impl Orthographic {
    /// Builds the camera from its scene parameters, for a film of `size`
    /// pixels.
    pub fn from_params(p: &mut dyn Params, size: [u32; 2]) -> Result<Self, ParamError> {
        let near = p.float_or("near_clip", 0.01)?;
        let far = p.float_or("far_clip", 10_000.0)?;
        if !(near >= 0.0 && far > near) {
            return Err(p.param_error(
                "near_clip",
                &format!("clip planes must satisfy 0 <= near < far (near {near}, far {far})"),
            ));
        }
        let to_world = p.transform_or_identity("to_world")?.m;
        Ok(Self::new(to_world, size[0], size[1], near, far))
    }

    /// A camera for a `width`×`height` film.
    pub fn new(to_world: Affine3A, width: u32, height: u32, near_clip: f32, far_clip: f32) -> Self {
        Self {
            to_world,
            direction: to_world.transform_vector3(Vec3::Z).normalize(),
            aspect_y: height as f32 / width as f32,
            resolution: Vec2::new(width as f32, height as f32),
            near_clip,
            far_clip,
        }
    }

    /// The ray through `film_p` (pixels, top-left origin).
    #[inline]
    pub fn generate_ray(&self, film_p: Vec2) -> Ray {
        let ndc = film_p / self.resolution;
        let local = Vec3::new(
            1.0 - 2.0 * ndc.x,
            (1.0 - 2.0 * ndc.y) * self.aspect_y,
            self.near_clip,
        );
        Ray {
            o: self.to_world.transform_point3(local),
            d: self.direction,
            t_min: 0.0,
            t_max: self.far_clip - self.near_clip,
        }
    }

    /// The centre of the window on the near plane.
    pub fn position(&self) -> Vec3 {
        self.to_world
            .transform_point3(Vec3::new(0.0, 0.0, self.near_clip))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values read from Mitsuba 3.9.1 `scalar_rgb` (`sample_ray` of a
    /// 200×100 `orthographic` with near 1, far 5 and to_world scale(2, 3, 1)).
    #[test]
    fn rays_match_mitsuba() {
        let c = Orthographic::new(
            Affine3A::from_scale(Vec3::new(2.0, 3.0, 1.0)),
            200,
            100,
            1.0,
            5.0,
        );
        for (ndc, o) in [
            (Vec2::new(0.5, 0.5), Vec3::new(0.0, 0.0, 1.0)),
            (Vec2::new(0.0, 0.5), Vec3::new(2.0, 0.0, 1.0)),
            (Vec2::new(0.5, 0.0), Vec3::new(0.0, 1.5, 1.0)),
            (Vec2::new(0.25, 0.75), Vec3::new(1.0, -0.75, 1.0)),
        ] {
            let r = c.generate_ray(ndc * Vec2::new(200.0, 100.0));
            assert!((r.o - o).length() < 1e-5, "{ndc}: {} vs {o}", r.o);
            assert_eq!(r.d, Vec3::Z);
            assert_eq!((r.t_min, r.t_max), (0.0, 4.0));
        }
    }
}
