//! Mitsuba's latitude–longitude parameterization of directions, shared by
//! `envmap` (its image) and `preetham` (its sampling table): +y is up
//! (v = 0 at the zenith, v = θ/π), and u = atan2(x, −z) / 2π.

use crate::math::atan2_pair;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

const INV_2PI: f32 = 0.5 * FRAC_1_PI;

/// The (u, v) of unit direction `d`.
#[inline]
pub(crate) fn uv_of(d: Vec3) -> Vec2 {
    // θ as the angle of (y, sin θ): no acos, and exact near the poles.
    let sin_theta = (d.x * d.x + d.z * d.z).sqrt();
    let [phi, theta] = atan2_pair([d.x, sin_theta], [-d.z, d.y]);
    Vec2::new(phi * INV_2PI, theta * FRAC_1_PI)
}

/// The unit direction at (u, v).
#[inline]
pub(crate) fn direction_of(uv: Vec2) -> Vec3 {
    direction_and_sin_theta(uv).0
}

/// [`direction_of`] and the sine of its polar angle (which converts
/// densities, [`solid_angle_pdf`]).
#[inline]
pub(crate) fn direction_and_sin_theta(uv: Vec2) -> (Vec3, f32) {
    let (sin_phi, cos_phi) = crate::math::sin_cos(2.0 * PI * uv.x);
    let (sin_theta, cos_theta) = crate::math::sin_cos(PI * uv.y);
    (
        Vec3::new(sin_theta * sin_phi, cos_theta, -sin_theta * cos_phi),
        sin_theta,
    )
}

/// The solid-angle density of unit direction `d` for the density
/// `pdf_uv` over the (u, v) square (dω = 2π² sin θ du dv); 0 at the poles.
#[inline]
pub(crate) fn solid_angle_pdf(pdf_uv: f32, d: Vec3) -> f32 {
    let sin_theta = (d.x * d.x + d.z * d.z).sqrt();
    if sin_theta > 0.0 {
        pdf_uv / (2.0 * PI * PI * sin_theta)
    } else {
        0.0
    }
}
