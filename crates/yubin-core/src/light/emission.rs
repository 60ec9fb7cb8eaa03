//! Emission sampling: rays that leave a light, for paths traced from the
//! lights (`ptracer`). Each emitter samples a position and a direction and
//! returns the ray with its weight Le · cos / (p(position) · p(direction)),
//! the flux the ray carries per sample.
//!
//! - `area`: a point uniform on the shape's area, a cosine-weighted
//!   direction about its (emitting) normal: weight π Le / p_A.
//! - `directionalarea`: a point uniform on the shape's area, along its
//!   normal: weight E / p_A.
//! - `point`: a uniform direction: weight 4π I.
//! - `spot`, `projector`: their own direction sampling (uniform in the
//!   cutoff cone, uniform over the image plane): weight I(ω) / p(ω).
//! - `directional`, and the lights at infinity (`constant`, `envmap`,
//!   `preetham`): a direction (the fixed one, or the light's own direction
//!   sampling), then a point uniform on a disk of the scene's bounding
//!   radius R across it, outside the scene: weight π R² E, or
//!   π R² L(ω) / p(ω).

use super::{uv_interaction, Emitter, EmitterContext, EmitterModel};
use crate::math::{Frame, Ray};
use crate::sampling::{
    square_to_cosine_hemisphere, square_to_uniform_disk_concentric, square_to_uniform_sphere,
};
use crate::shape::ShapeModel;
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// A ray leaving a light.
#[derive(Clone, Copy, Debug)]
pub struct EmissionSample {
    /// The ray (unit direction).
    pub ray: Ray,
    /// Flux per sample: Le · cos / (p(position) · p(direction)).
    pub weight: Rgb,
    /// The surface normal at the ray's origin (zero for lights that are
    /// not surfaces), to offset the ray off its own shape.
    pub n: Vec3,
}

/// The scene's bounding sphere (centre, radius), where rays from lights at
/// infinity start.
#[derive(Clone, Copy, Debug)]
pub struct SceneSphere {
    /// Centre.
    pub center: Vec3,
    /// Radius (positive).
    pub radius: f32,
}

impl Emitter {
    /// Samples a ray leaving the light from two uniform 2D samples (the
    /// position's and the direction's); `None` when the light emits
    /// nothing there.
    pub fn sample_emission(
        &self,
        ctx: &EmitterContext,
        sphere: SceneSphere,
        u_pos: Vec2,
        u_dir: Vec2,
    ) -> Option<EmissionSample> {
        let (o, d, weight, n) = match self {
            Emitter::Area(a) => {
                let ps = ctx.shapes[a.shape as usize].sample_position(ctx.meshes, u_pos);
                if !(ps.pdf > 0.0 && ps.pdf.is_finite()) {
                    return None;
                }
                let d = Frame::from_normal(ps.n).to_world(square_to_cosine_hemisphere(u_dir));
                let le = match a.radiance {
                    Tex::Const(c) => c,
                    tex => tex.eval(ctx.materials, &uv_interaction(ps.p, ps.n, ps.uv)),
                };
                (ps.p, d, le * (PI / ps.pdf), ps.n)
            }
            Emitter::DirectionalArea(a) => {
                let ps = ctx.shapes[a.shape as usize].sample_position(ctx.meshes, u_pos);
                if !(ps.pdf > 0.0 && ps.pdf.is_finite()) {
                    return None;
                }
                let e = match a.radiance {
                    Tex::Const(c) => c,
                    tex => tex.eval(ctx.materials, &uv_interaction(ps.p, ps.n, ps.uv)),
                };
                (ps.p, ps.n, e / ps.pdf, ps.n)
            }
            Emitter::Point(l) => (
                l.position,
                square_to_uniform_sphere(u_dir),
                l.intensity * (4.0 * PI),
                Vec3::ZERO,
            ),
            Emitter::Spot(l) => {
                let (d, pdf) = l.sample_emission_direction(u_dir);
                let o = l.to_world.point(Vec3::ZERO);
                (o, d, l.intensity_towards(ctx, d) / pdf, Vec3::ZERO)
            }
            Emitter::Projector(l) => {
                let (d, pdf) = l.sample_emission_direction(u_dir);
                let o = l.to_world.point(Vec3::ZERO);
                (o, d, l.intensity_towards(ctx, d) / pdf, Vec3::ZERO)
            }
            Emitter::Directional(l) => {
                let d = l.direction;
                let o = disk_origin(sphere, d, u_pos);
                (o, d, l.irradiance * disk_area(sphere), Vec3::ZERO)
            }
            Emitter::Constant(_)
            | Emitter::EnvMap(_)
            | Emitter::Preetham(_)
            | Emitter::Sunsky(_)
            | Emitter::TimedSunsky(_) => {
                let s = self.sample_direction(ctx, sphere.center, u_dir)?;
                if s.pdf.is_nan() || s.pdf <= 0.0 {
                    return None;
                }
                let d = -s.wi;
                let o = disk_origin(sphere, d, u_pos);
                (o, d, s.radiance * (disk_area(sphere) / s.pdf), Vec3::ZERO)
            }
        };
        (weight.max_element() > 0.0 && weight.is_finite()).then_some(EmissionSample {
            ray: Ray::new(o, d),
            weight,
            n,
        })
    }
}

/// A point on the disk of radius R through the scene sphere's centre,
/// across `d`, pushed back by R along −d so that the whole scene lies
/// ahead of it.
fn disk_origin(sphere: SceneSphere, d: Vec3, u: Vec2) -> Vec3 {
    let frame = Frame::from_normal(d);
    let q = square_to_uniform_disk_concentric(u) * sphere.radius;
    sphere.center + frame.s * q.x + frame.t * q.y - d * sphere.radius
}

fn disk_area(sphere: SceneSphere) -> f32 {
    PI * sphere.radius * sphere.radius
}
