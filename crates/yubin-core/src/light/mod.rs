//! Emitters: the contract every light implements and the closed enum the
//! scene stores.
//!
//! Conventions: [`EmitterModel::sample_direction`] picks a point on (or a
//! direction to) the light as seen from a reference point and returns the
//! incident radiance *unweighted* together with the solid-angle density
//! (1 for delta lights, flagged by `is_delta`). [`EmitterModel::pdf_direction`]
//! returns the same density for a point found by tracing a ray, so that
//! integrators can weight both strategies with MIS.
//!
//! Emitters at infinity ([`Emitter::is_environment`]) also give the
//! radiance of rays that escape the scene ([`Emitter::environment_radiance`]).
//! Scene front ends build emitters through [`PLUGINS`]; an emitter that
//! needs scene-owned data (an `envmap`'s or `preetham`'s sampling
//! distribution) gets it
//! when the scene is built ([`build_distributions`]).

mod area;
pub mod bvh;
mod constant;
mod directional;
mod directional_area;
mod emission;
mod envmap;
mod point;
mod preetham;
mod projector;
pub mod selection;
mod spot;

pub use area::AreaLight;
pub use constant::ConstantLight;
pub use directional::DirectionalLight;
pub use directional_area::DirectionalAreaLight;
pub use emission::{EmissionSample, SceneSphere};
pub use envmap::EnvMapLight;
pub use point::PointLight;
pub use preetham::PreethamLight;
pub use projector::ProjectorLight;
pub use selection::{EmitterOptions, LightChoice, LightSampler, LightSelection};
pub use spot::SpotLight;

use crate::interaction::SurfaceInteraction;
use crate::params::{ParamError, Params};
use crate::sampling::Distribution2D;
use crate::shape::{Shape, ShapeModel, TriangleMesh};
use crate::texture::TexImage;
use crate::Rgb;
use glam::{Vec2, Vec3};

/// What an emitter needs to know about the scene: shapes for area lights,
/// images and sampling distributions for environment maps.
#[derive(Clone, Copy, Debug)]
pub struct EmitterContext<'a> {
    /// The scene's shapes.
    pub shapes: &'a [Shape],
    /// The scene's meshes.
    pub meshes: &'a [TriangleMesh],
    /// The scene's images ([`crate::material::Materials::images`]).
    pub images: &'a [TexImage],
    /// The scene's materials, for textured emission.
    pub materials: &'a crate::material::Materials,
    /// Sampling distributions of emitters (`Scene::light_distributions`).
    pub distributions: &'a [Distribution2D],
}

impl EmitterContext<'static> {
    /// A context of an empty scene (for tests of lights that need none).
    pub const EMPTY: Self = Self {
        shapes: &[],
        meshes: &[],
        images: &[],
        materials: &crate::material::Materials::EMPTY,
        distributions: &[],
    };
}

/// A light sample seen from a reference point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmitterSample {
    /// Unit direction from the reference point towards the light.
    pub wi: Vec3,
    /// Distance to the sampled point (infinite for lights at infinity).
    pub dist: f32,
    /// Solid-angle density (1 for delta lights).
    pub pdf: f32,
    /// Incident radiance along `wi` (for point lights, I/d²; not divided
    /// by `pdf`).
    pub radiance: Rgb,
    /// The light is a delta distribution (no MIS with BSDF sampling).
    pub is_delta: bool,
}

/// The contract of every emitter.
pub trait EmitterModel {
    /// Samples the light from `ref_p`; `None` when nothing can be sampled.
    fn sample_direction(&self, ctx: &EmitterContext, ref_p: Vec3, u: Vec2)
        -> Option<EmitterSample>;
    /// Density of sampling the surface point `p` (normal `n`) or, for
    /// lights at infinity, the direction `wi`, from `ref_p`.
    fn pdf_direction(&self, ctx: &EmitterContext, ref_p: Vec3, p: Vec3, n: Vec3, wi: Vec3) -> f32;
    /// True for point and directional lights.
    fn is_delta(&self) -> bool;
}

/// An emitter (closed enum; see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Emitter {
    /// `area`.
    Area(AreaLight),
    /// `point`.
    Point(PointLight),
    /// `directional`.
    Directional(DirectionalLight),
    /// `constant`.
    Constant(ConstantLight),
    /// `envmap`.
    EnvMap(EnvMapLight),
    /// `spot`.
    Spot(SpotLight),
    /// `preetham`.
    Preetham(PreethamLight),
    /// `projector`.
    Projector(ProjectorLight),
    /// `directionalarea`.
    DirectionalArea(DirectionalAreaLight),
}

/// Builds an emitter plugin from its parameters.
pub type EmitterFromParams = fn(&mut dyn Params) -> Result<Emitter, ParamError>;

/// Every emitter plugin built from parameters alone: its scene type string
/// and constructor. (`area` belongs to a shape and is added with it.)
pub const PLUGINS: &[(&str, EmitterFromParams)] = &[
    ("point", |p| Ok(Emitter::Point(PointLight::from_params(p)?))),
    ("directional", |p| {
        Ok(Emitter::Directional(DirectionalLight::from_params(p)?))
    }),
    ("constant", |p| {
        Ok(Emitter::Constant(ConstantLight::from_params(p)?))
    }),
    ("envmap", |p| {
        Ok(Emitter::EnvMap(EnvMapLight::from_params(p)?))
    }),
    ("spot", |p| Ok(Emitter::Spot(SpotLight::from_params(p)?))),
    ("preetham", |p| {
        Ok(Emitter::Preetham(PreethamLight::from_params(p)?))
    }),
    ("projector", |p| {
        Ok(Emitter::Projector(ProjectorLight::from_params(p)?))
    }),
];

/// What a texture needs of a point an emitter looks up: position, normal
/// and uv (no triangle, so no mesh attributes).
pub(crate) fn uv_interaction(p: Vec3, n: Vec3, uv: Vec2) -> SurfaceInteraction {
    // As if hit from straight in front, at distance 0.
    crate::shape::make_interaction(
        &crate::math::Ray::new(p + n, -n),
        0.0,
        p,
        n,
        uv,
        Vec3::ZERO,
        Vec3::ZERO,
    )
}

/// The light sample of a source at the single point `position` whose
/// intensity towards the unit direction d is `intensity(d)`: I / dist²,
/// density 1, delta; `None` when it sends nothing towards `ref_p`.
pub(crate) fn point_source_sample(
    position: Vec3,
    ref_p: Vec3,
    intensity: impl FnOnce(Vec3) -> Rgb,
) -> Option<EmitterSample> {
    let delta = position - ref_p;
    let dist2 = delta.length_squared();
    if dist2 == 0.0 {
        return None;
    }
    let dist = dist2.sqrt();
    let wi = delta / dist;
    let i = intensity(-wi);
    if i == Rgb::ZERO {
        return None;
    }
    Some(EmitterSample {
        wi,
        dist,
        pdf: 1.0,
        radiance: i / dist2,
        is_delta: true,
    })
}

/// The mean of an emission texture for light selection: a constant's
/// largest channel (as [`Emitter::power`] counts), a texture's mean.
pub(crate) fn power_mean(t: crate::texture::Tex, m: &crate::material::Materials) -> f32 {
    match t.as_const() {
        Some(c) => c.max_element(),
        None => t.mean(m),
    }
}

/// Builds the sampling distributions that emitters keep in the scene
/// (`Scene::light_distributions`) and points each emitter at its own, and
/// fits projectors to their image's aspect ratio;
/// `SceneBuilder::build` calls it. Fails with the index of an image that
/// is not in `images`.
pub fn build_distributions(
    emitters: &mut [Emitter],
    materials: &crate::material::Materials,
) -> Result<Vec<Distribution2D>, u32> {
    let images = &materials.images;
    let mut distributions = Vec::new();
    for e in emitters {
        if let Emitter::Projector(l) = e {
            l.fit_image_plane(materials);
        }
        if let Emitter::EnvMap(env) = e {
            let image = images.get(env.image as usize).ok_or(env.image)?;
            env.distribution = distributions.len() as u32;
            distributions.push(env.sampling_distribution(image));
        }
        if let Emitter::Preetham(sky) = e {
            sky.distribution = distributions.len() as u32;
            distributions.push(sky.sampling_distribution());
        }
    }
    Ok(distributions)
}

macro_rules! dispatch {
    ($self:expr, $l:ident => $e:expr) => {
        match $self {
            Emitter::Area($l) => $e,
            Emitter::Point($l) => $e,
            Emitter::Directional($l) => $e,
            Emitter::Constant($l) => $e,
            Emitter::EnvMap($l) => $e,
            Emitter::Spot($l) => $e,
            Emitter::Preetham($l) => $e,
            Emitter::Projector($l) => $e,
            Emitter::DirectionalArea($l) => $e,
        }
    };
}

impl EmitterModel for Emitter {
    #[inline]
    fn sample_direction(
        &self,
        ctx: &EmitterContext,
        ref_p: Vec3,
        u: Vec2,
    ) -> Option<EmitterSample> {
        dispatch!(self, l => l.sample_direction(ctx, ref_p, u))
    }
    #[inline]
    fn pdf_direction(&self, ctx: &EmitterContext, ref_p: Vec3, p: Vec3, n: Vec3, wi: Vec3) -> f32 {
        dispatch!(self, l => l.pdf_direction(ctx, ref_p, p, n, wi))
    }
    #[inline]
    fn is_delta(&self) -> bool {
        dispatch!(self, l => l.is_delta())
    }
}

impl Emitter {
    /// Radiance leaving the emitting surface hit at `si` towards `si.wo`.
    /// Zero for non-surface lights.
    #[inline]
    pub fn surface_radiance(&self, m: &crate::material::Materials, si: &SurfaceInteraction) -> Rgb {
        match self {
            Emitter::Area(a) if si.sh_frame.n.dot(si.wo) > 0.0 => a.radiance.eval(m, si),
            _ => Rgb::ZERO,
        }
    }

    /// Radiance arriving along a ray with direction `d` that escaped the
    /// scene. Zero for lights that are not at infinity or are delta.
    #[inline]
    pub fn environment_radiance(&self, ctx: &EmitterContext, d: Vec3) -> Rgb {
        match self {
            Emitter::Constant(c) => c.radiance,
            Emitter::EnvMap(m) => m.radiance(ctx, d),
            Emitter::Preetham(s) => s.radiance(d),
            _ => Rgb::ZERO,
        }
    }

    /// Emitted power (its largest RGB channel: a light bright in one
    /// channel only is not rare there), for light selection; lights at infinity
    /// count what crosses a disk of the scene's bounding radius `radius`
    /// (pbrt-v4's convention).
    pub fn power(&self, ctx: &EmitterContext, radius: f32) -> f32 {
        use std::f32::consts::PI;
        let disk = PI * radius * radius;
        match self {
            Emitter::Area(a) => {
                let area = ctx.shapes[a.shape as usize].surface_area(ctx.meshes);
                PI * area * power_mean(a.radiance, ctx.materials)
            }
            Emitter::Point(p) => 4.0 * PI * p.intensity.max_element(),
            Emitter::Spot(s) => s.power(ctx),
            Emitter::Projector(l) => l.power(ctx),
            Emitter::DirectionalArea(a) => {
                let area = ctx.shapes[a.shape as usize].surface_area(ctx.meshes);
                area * power_mean(a.radiance, ctx.materials)
            }
            Emitter::Directional(d) => disk * d.irradiance.max_element(),
            Emitter::Constant(_) | Emitter::EnvMap(_) => disk * self.environment_integral(ctx),
            // The grid would miss the sun's disk: it is added in closed form.
            Emitter::Preetham(s) => {
                let sun = s.sun_radiance.max_element() * 2.0 * PI * (1.0 - s.cos_sun_radius);
                disk * (self.environment_integral(ctx) + sun)
            }
        }
    }

    /// ∫ max(L(ω)) dω (largest channel) over the sphere of an emitter at infinity, by
    /// the midpoint rule on an equal-area grid in (cos θ, φ).
    fn environment_integral(&self, ctx: &EmitterContext) -> f32 {
        const N_THETA: usize = 64;
        const N_PHI: usize = 128;
        let mut sum = 0.0f64;
        for i in 0..N_THETA {
            let cos_theta = 1.0 - 2.0 * (i as f32 + 0.5) / N_THETA as f32;
            let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
            for j in 0..N_PHI {
                let phi = 2.0 * std::f32::consts::PI * (j as f32 + 0.5) / N_PHI as f32;
                let d = Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta);
                sum += self.environment_radiance(ctx, d).max_element() as f64;
            }
        }
        (sum * 4.0 * std::f64::consts::PI / (N_THETA * N_PHI) as f64) as f32
    }

    /// True for lights that surround the scene (hit by escaping rays).
    pub fn is_environment(&self) -> bool {
        matches!(
            self,
            Emitter::Constant(_) | Emitter::EnvMap(_) | Emitter::Preetham(_)
        )
    }
}

/// Chi-square test of an emitter at infinity's direction sampling seen
/// from the origin (its density steps inside bins, so it is integrated
/// finely). Shared by the environment emitters' tests.
#[cfg(test)]
pub(crate) fn chi2_environment(light: &impl EmitterModel, ctx: &EmitterContext) {
    use crate::testing::chi2::{chi2_directions, Chi2Config};
    chi2_directions(
        &Chi2Config {
            cos_theta_bins: 30,
            phi_bins: 60,
            samples: 400_000,
            integration_res: 32,
            ..Chi2Config::default()
        },
        |r| {
            light
                .sample_direction(ctx, Vec3::ZERO, r.next_2d())
                .map(|s| (s.wi, s.pdf))
        },
        |wi| light.pdf_direction(ctx, Vec3::ZERO, Vec3::ZERO, Vec3::Z, wi),
    )
    .unwrap();
}
