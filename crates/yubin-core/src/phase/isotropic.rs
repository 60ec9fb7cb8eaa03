//! `isotropic`: scattering equally in all directions, p = 1 / 4π
//! (Mitsuba 3's default phase function).
//!
//! No parameters.
//!
//! ```xml
//! <phase type="isotropic"/>
//! ```

use crate::sampling::square_to_uniform_sphere;
use glam::{Vec2, Vec3};

/// p = 1 / 4π.
#[inline]
pub(super) fn eval() -> f32 {
    0.25 * std::f32::consts::FRAC_1_PI
}

/// A uniform direction.
#[inline]
pub(super) fn sample(u: Vec2) -> Vec3 {
    square_to_uniform_sphere(u)
}
