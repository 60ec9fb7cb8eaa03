//! Sampling of a sky with a sun disk (`preetham`, `sunsky`): the sky
//! tabulated on a 256 × 128 latitude–longitude grid of its frame (+y the
//! zenith, `envmap`'s mapping; cell centres, luminance × sin θ, the lower
//! half zero), kept as a [`Distribution2D`] in a render's state, and the
//! sun sampled uniformly in its cone. A sample picks the sun or the sky in
//! proportion to their powers (∫ luminance dω); densities are the
//! mixture's. Under MIS compensation the table holds the sky's excess over
//! its mean over the sphere, and the sky's power for the choice is that
//! excess's: BSDF sampling covers the even part of the sky, light
//! sampling the sun and the bright sky around it.

use super::{latlong, EmitterSample};
use crate::math::Frame;
use crate::sampling::{square_to_uniform_cone, uniform_cone_pdf, Distribution2D};
use crate::spectrum::luminance;
use crate::Rgb;
use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::PI;

/// Sky sampling table (latitude–longitude cells).
const TABLE_W: usize = 256;
const TABLE_H: usize = 128;

/// A sun disk: its direction (sky frame, unit) and the cosine of its
/// angular radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunDisk {
    /// Towards the sun's centre.
    pub direction: Vec3,
    /// Cosine of the disk's angular radius.
    pub cos_radius: f32,
}

impl SunDisk {
    /// Whether `d` (sky frame, unit) looks into the disk.
    #[inline]
    pub fn contains(&self, d: Vec3) -> bool {
        d.dot(self.direction) >= self.cos_radius
    }

    /// The disk's solid angle.
    #[inline]
    pub fn solid_angle(&self) -> f32 {
        2.0 * PI * (1.0 - self.cos_radius)
    }
}

/// Tabulates `sky` (radiance along a sky-frame direction, without the
/// sun) for sampling (its excess over its mean when `compensated`), and
/// the probability of sampling the sun, whose power is `sun_power`
/// (∫ luminance dω over its disk).
pub fn sky_table(
    sky: impl Fn(Vec3) -> Rgb,
    sun_power: f64,
    compensated: bool,
) -> (Distribution2D, f32) {
    let mut lum = vec![0.0f32; TABLE_W * TABLE_H];
    let sin_theta = |r: usize| (PI * (r as f32 + 0.5) / TABLE_H as f32).sin();
    for r in 0..TABLE_H / 2 {
        let v = (r as f32 + 0.5) / TABLE_H as f32;
        for c in 0..TABLE_W {
            let u = (c as f32 + 0.5) / TABLE_W as f32;
            lum[r * TABLE_W + c] = luminance(sky(latlong::direction_of(Vec2::new(u, v))));
        }
    }
    // Luminance above `offset` × sin θ per cell, and its power
    // (dω = 2π² sin θ du dv).
    let weigh = |offset: f32| -> (Vec<f32>, f64) {
        let weights: Vec<f32> = (lum.iter().enumerate())
            .map(|(i, &l)| (l - offset).max(0.0) * sin_theta(i / TABLE_W))
            .collect();
        let cell = 2.0 * (PI as f64).powi(2) / (TABLE_W * TABLE_H) as f64;
        let power = weights.iter().map(|&w| w as f64).sum::<f64>() * cell;
        (weights, power)
    };
    let (mut weights, mut sky_power) = weigh(0.0);
    if compensated {
        // The mean over the sphere (the ground below the horizon is black).
        (weights, sky_power) = weigh((sky_power / (4.0 * PI as f64)) as f32);
    }
    let sun_power = sun_power.max(0.0);
    let total = sky_power + sun_power;
    let sun_prob = if total > 0.0 {
        (sun_power / total) as f32
    } else {
        0.0
    };
    if sky_power <= 0.0 {
        // Never sampled; any valid table will do.
        weights.iter_mut().for_each(|w| *w = 1.0);
    }
    (Distribution2D::new(&weights, TABLE_W, TABLE_H), sun_prob)
}

/// Density (solid angle) of sampling sky-frame direction `d` (unit).
#[inline]
pub fn sky_pdf(dist: &Distribution2D, sun: &SunDisk, sun_prob: f32, d: Vec3) -> f32 {
    let mut pdf = 0.0;
    if sun_prob > 0.0 && sun.contains(d) {
        pdf += sun_prob * uniform_cone_pdf(sun.cos_radius);
    }
    let sky_prob = 1.0 - sun_prob;
    if sky_prob > 0.0 && d.y > 0.0 {
        let uv = latlong::uv_of(d);
        let x = uv.x - crate::math::floor(uv.x);
        pdf += sky_prob * latlong::solid_angle_pdf(dist.pdf(Vec2::new(x, uv.y)), d);
    }
    pdf
}

/// A sky-frame direction from the uniform `u`: the sun with probability
/// `sun_prob`, else the sky's table.
#[inline]
pub fn sky_sample(dist: &Distribution2D, sun: &SunDisk, sun_prob: f32, u: Vec2) -> Option<Vec3> {
    const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;
    if u.x < sun_prob {
        let ux = (u.x / sun_prob).min(ONE_MINUS_EPS);
        let cone = square_to_uniform_cone(Vec2::new(ux, u.y), sun.cos_radius);
        Some(Frame::from_normal(sun.direction).to_world(cone))
    } else {
        let ux = ((u.x - sun_prob) / (1.0 - sun_prob)).min(ONE_MINUS_EPS);
        let (uv, pdf_uv) = dist.sample(Vec2::new(ux, u.y));
        if pdf_uv == 0.0 || uv.y <= 0.0 {
            return None;
        }
        Some(latlong::direction_of(uv))
    }
}

/// A light sample of a sky whose frame is `world_from_light` (inverse
/// `light_from_world`): a direction by [`sky_sample`], with the radiance
/// (`radiance` of the sky-frame direction) and density a traced ray along
/// it finds, as `envmap`'s.
pub fn sky_light_sample(
    dist: &Distribution2D,
    sun: &SunDisk,
    sun_prob: f32,
    (world_from_light, light_from_world): (Mat3, Mat3),
    u: Vec2,
    radiance: impl Fn(Vec3) -> Rgb,
) -> Option<EmitterSample> {
    let local = sky_sample(dist, sun, sun_prob, u)?;
    let wi = (world_from_light * local).normalize();
    let local = (light_from_world * wi).normalize_or_zero();
    let pdf = sky_pdf(dist, sun, sun_prob, local);
    (pdf > 0.0).then(|| EmitterSample {
        wi,
        dist: f32::INFINITY,
        pdf,
        radiance: radiance(local),
        is_delta: false,
    })
}
