//! Warping functions from the unit square to the shapes renderers sample
//! (hemispheres, cones, triangles, disks), their densities, a discrete
//! alias table, and piecewise-constant 1D and 2D distributions. Formulas
//! follow pbrt-v4 chapter A.5 and Shirley & Chiu 1997.

mod alias;
mod distribution2d;
mod spherical_rectangle;
mod spherical_triangle;

pub use alias::AliasTable;
pub use distribution2d::{Distribution1D, Distribution2D};
pub use spherical_rectangle::{spherical_rectangle_pdf, RectangleFrame, SphericalRectangle};
pub use spherical_triangle::SphericalTriangle;

/// Below this solid angle (sr) a light is far enough that sampling it by
/// area is as good as by solid angle, and the spherical sampling's
/// rounding would be felt.
pub const SPHERICAL_MIN_SOLID_ANGLE: f32 = 1e-3;

/// Above it a point almost lies on a light's plane, inside its outline,
/// where the spherical parametrizations lose precision.
pub const SPHERICAL_MAX_SOLID_ANGLE: f32 = std::f32::consts::TAU - 0.06;

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_4, PI};

/// Uniform point on the unit disk by Shirley & Chiu's concentric map.
#[inline]
pub fn square_to_uniform_disk_concentric(u: Vec2) -> Vec2 {
    concentric_with_radius(u).0
}

/// [`square_to_uniform_disk_concentric`] and the point's distance from
/// the centre, which the map knows before the angle: θ = a in the wedges
/// around ±x, π/2 − a in those around ±y, |a| ≤ π/4 either way, chosen by
/// selects (which wedge a sample falls in is a coin flip).
#[inline]
fn concentric_with_radius(u: Vec2) -> (Vec2, f32) {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return (Vec2::ZERO, 0.0);
    }
    let around_x = o.x.abs() > o.y.abs();
    let (r, across) = if around_x { (o.x, o.y) } else { (o.y, o.x) };
    let (sin, cos) = crate::math::sin_cos_quarter(FRAC_PI_4 * (across / r));
    let (c, s) = if around_x { (cos, sin) } else { (sin, cos) };
    (r * Vec2::new(c, s), r)
}

/// Cosine-weighted direction on the +z hemisphere (Malley's method). The
/// height comes from the disk point's radius, in parallel with its angle.
#[inline]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let (d, r) = concentric_with_radius(u);
    let z = (1.0 - r * r).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Density of [`square_to_cosine_hemisphere`] per solid angle.
#[inline]
pub fn cosine_hemisphere_pdf(v: Vec3) -> f32 {
    v.z.max(0.0) * FRAC_1_PI
}

/// Uniform direction on the unit sphere.
#[inline]
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Density of [`square_to_uniform_sphere`].
pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

/// Uniform direction inside the cone around +z with the given cosine of
/// its half-angle.
#[inline]
pub fn square_to_uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let cos_theta = (1.0 - u.x) + u.x * cos_max;
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta)
}

/// Density of [`square_to_uniform_cone`] per solid angle.
#[inline]
pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_max))
}

/// Uniform barycentrics `(b1, b2)` on a triangle (the square-root map,
/// pbrt-v4 §A.5.4 / Osada et al. 2002).
#[inline]
pub fn square_to_uniform_triangle(u: Vec2) -> Vec2 {
    let su = u.x.sqrt();
    Vec2::new(1.0 - su, u.y * su)
}

/// Veach's power heuristic (β = 2) for one sample of each strategy.
#[inline]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    if a == 0.0 {
        0.0
    } else if a.is_infinite() {
        1.0
    } else {
        a / (a + b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warps_land_where_they_should() {
        for i in 0..100 {
            let u = Vec2::new((i as f32 + 0.5) / 100.0, ((i * 37) % 100) as f32 / 100.0);
            assert!(square_to_uniform_disk_concentric(u).length() <= 1.0 + 1e-6);
            let h = square_to_cosine_hemisphere(u);
            assert!(h.z >= 0.0 && (h.length() - 1.0).abs() < 1e-5);
            let c = square_to_uniform_cone(u, 0.8);
            assert!(c.z >= 0.8 - 1e-6);
            let b = square_to_uniform_triangle(u);
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
        }
    }

    #[test]
    fn power_heuristic_limits() {
        assert_eq!(power_heuristic(0.0, 1.0), 0.0);
        assert_eq!(power_heuristic(f32::INFINITY, 1.0), 1.0);
        assert!((power_heuristic(1.0, 1.0) - 0.5).abs() < 1e-6);
    }
}
