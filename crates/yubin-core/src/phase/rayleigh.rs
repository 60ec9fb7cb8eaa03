//! `rayleigh`: scattering by particles much smaller than the wavelength
//! (Rayleigh 1871), as Mitsuba 3's: p(θ) = 3 (1 + cos²θ) / 16π, as much
//! forward as backward.
//!
//! No parameters.
//!
//! ```xml
//! <phase type="rayleigh"/>
//! ```
//!
//! Sampled exactly: the distribution of μ = cos θ, F(μ) = (μ³ + 3μ + 4) / 8,
//! is inverted by Cardano's formula for the cubic μ³ + 3μ − q = 0,
//! q = 8u − 4: μ = ∛(q/2 + √(q²/4 + 1)) + ∛(q/2 − √(q²/4 + 1)).

use super::about_travel;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// p for `cos_wo_wi` = wo · wi (symmetric, so its sign does not matter).
#[inline]
pub(super) fn eval(cos_wo_wi: f32) -> f32 {
    3.0 / (16.0 * PI) * (1.0 + cos_wo_wi * cos_wo_wi)
}

/// A direction distributed as p about the direction of travel −wo.
#[inline]
pub(super) fn sample(wo: Vec3, u: Vec2) -> Vec3 {
    let q = 8.0 * u.x as f64 - 4.0;
    let root = (q * q / 4.0 + 1.0).sqrt();
    let mu = ((q / 2.0 + root).cbrt() + (q / 2.0 - root).cbrt()).clamp(-1.0, 1.0) as f32;
    about_travel(wo, mu, 2.0 * PI * u.y)
}
