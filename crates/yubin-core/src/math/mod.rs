//! Rays, bounding boxes, orthonormal frames and transforms (`f32`, glam).

mod bounds;
mod frame;
mod transform;

pub use bounds::Bounds3;
pub use frame::{coordinate_system, Frame};
pub use transform::Transform;

use glam::Vec3;

/// Relative epsilon used to push spawned rays off surfaces (in units of
/// the hit point's magnitude), enough for `f32` intersection round-off.
pub const RAY_EPSILON: f32 = 1e-4;
/// Shadow rays stop this fraction short of their target.
pub const SHADOW_EPSILON: f32 = 1e-3;

/// A ray `o + t d`, valid for `t` in `[t_min, t_max]`. `d` need not be
/// normalized for intersection, but camera and BSDF rays keep it unit length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin.
    pub o: Vec3,
    /// Direction.
    pub d: Vec3,
    /// Start of the valid interval.
    pub t_min: f32,
    /// End of the valid interval.
    pub t_max: f32,
}

impl Ray {
    /// An unbounded ray starting at `o`.
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Self {
            o,
            d,
            t_min: 0.0,
            t_max: f32::INFINITY,
        }
    }

    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}

/// Offsets `p` along the geometric normal `n`, to the side that `d` points
/// to, so that a ray leaving a surface doesn't hit it again.
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3, d: Vec3) -> Vec3 {
    let mag = (1.0 + p.abs().max_element()) * RAY_EPSILON;
    let offset = n * mag;
    if n.dot(d) >= 0.0 {
        p + offset
    } else {
        p - offset
    }
}

/// A ray leaving surface point `p` (geometric normal `n`) in direction `d`.
#[inline]
pub fn spawn_ray(p: Vec3, n: Vec3, d: Vec3) -> Ray {
    Ray::new(offset_ray_origin(p, n, d), d)
}

/// A shadow ray from surface point `p` (normal `n`) to `target`, stopping
/// just short of it; `d` is unit length and `t_max` the distance.
#[inline]
pub fn spawn_ray_to(p: Vec3, n: Vec3, target: Vec3) -> Ray {
    let o = offset_ray_origin(p, n, target - p);
    let delta = target - o;
    let dist = delta.length();
    Ray {
        o,
        d: delta / dist,
        t_min: 0.0,
        t_max: dist * (1.0 - SHADOW_EPSILON),
    }
}
