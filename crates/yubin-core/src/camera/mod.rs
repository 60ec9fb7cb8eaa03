//! Cameras (closed enum). A camera maps a position on the film (in pixels
//! of the full image, (0, 0) the top-left corner) to a world-space ray.

mod perspective;

pub use perspective::{FovAxis, Perspective};

use crate::math::Ray;
use glam::Vec2;

/// A camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Camera {
    /// `perspective`.
    Perspective(Perspective),
}

impl Camera {
    /// The primary ray through film position `film_p`; `_u_lens` is for
    /// cameras with an aperture.
    #[inline]
    pub fn generate_ray(&self, film_p: Vec2, _u_lens: Vec2) -> Ray {
        match self {
            Camera::Perspective(c) => c.generate_ray(film_p),
        }
    }
}
