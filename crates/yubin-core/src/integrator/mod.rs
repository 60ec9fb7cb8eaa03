//! Integrators. The choice of integrator is made once per render, so it is
//! a trait object ([`Integrator`]); everything it calls per ray is enum
//! dispatch.
//!
//! An integrator turns one camera ray into `channel_count()` values: RGB
//! radiance first, then the channels of any extra [`Layer`]s it defines
//! (`moment` adds the second moment, `aov` depth, normals, …); a layer is
//! as wide as it needs (depth 1, uv 2, RGBA 4).

mod ao;
mod aov;
mod depth;
mod direct;
mod guides;
mod moment;
mod path;
mod ptracer;
mod volpath;
pub(crate) mod wide;

pub use ao::AoIntegrator;
pub use aov::{parse_aovs, AovIntegrator, AovKind};
pub use depth::DepthIntegrator;
pub use direct::DirectIntegrator;
pub use guides::{DenoiserGuides, Guide};
pub use moment::MomentIntegrator;
pub use path::PathIntegrator;
pub use ptracer::ParticleTracer;
pub use volpath::VolPathIntegrator;

/// Builds an integrator plugin from its parameters.
pub type IntegratorFromParams = fn(&mut dyn Params) -> Result<Box<dyn Integrator>, ParamError>;

/// Every integrator plugin: its scene type string and constructor.
pub const PLUGINS: &[(&str, IntegratorFromParams)] = &[
    ("path", |p| Ok(Box::new(PathIntegrator::from_params(p)?))),
    ("direct", |p| {
        Ok(Box::new(DirectIntegrator::from_params(p)?))
    }),
    ("moment", |p| {
        Ok(Box::new(MomentIntegrator::from_params(p)?))
    }),
    ("aov", |p| Ok(Box::new(AovIntegrator::from_params(p)?))),
    ("ao", |p| Ok(Box::new(AoIntegrator::from_params(p)?))),
    ("depth", |p| Ok(Box::new(DepthIntegrator::from_params(p)?))),
    ("ptracer", |p| Ok(Box::new(ParticleTracer::from_params(p)?))),
    ("volpath", |p| {
        Ok(Box::new(VolPathIntegrator::from_params(p)?))
    }),
    ("volpathmis", |p| {
        Ok(Box::new(VolPathIntegrator::from_params_mis(p)?))
    }),
];

/// Builds the integrator `p` describes, by its plugin type.
pub fn from_params(p: &mut dyn Params) -> Result<Box<dyn Integrator>, ParamError> {
    plugin_of(p, "integrator", PLUGINS, None)?(p)
}

/// Builds an integrator nested in `parent` (which runs it per camera
/// ray): anything but a particle tracer.
pub(crate) fn nested_from_params(
    p: &mut dyn Params,
    parent: &str,
) -> Result<Box<dyn Integrator>, ParamError> {
    let integrator = from_params(p)?;
    if integrator.particle_tracer().is_some() {
        return Err(p.error(&format!(
            "ptracer traces paths from the lights and cannot be nested in {parent}"
        )));
    }
    Ok(integrator)
}

/// `max_depth`: −1 (unlimited) or a non-negative path length.
pub(crate) fn max_depth_param(p: &mut dyn Params) -> Result<i32, ParamError> {
    let v = p.integer_or("max_depth", -1)?;
    i32::try_from(v).ok().filter(|&d| d >= -1).ok_or_else(|| {
        p.param_error(
            "max_depth",
            &format!("must be -1 (unlimited) or at least 0, not {v}"),
        )
    })
}

/// `rr_depth`: the path length at which Russian roulette starts
/// (default 5, Mitsuba's; negative values read as 0).
pub(crate) fn rr_depth_param(p: &mut dyn Params) -> Result<u32, ParamError> {
    Ok(p.integer_or("rr_depth", 5)?.clamp(0, u32::MAX as i64) as u32)
}

use crate::interaction::SurfaceInteraction;
use crate::math::Ray;
use crate::params::{plugin_of, ParamError, Params};
use crate::render::RenderScene;
use crate::sampler::SampleStream;
use crate::sampling::power_heuristic;
use crate::Rgb;
use glam::Vec3;

/// A group of output channels after RGB, written to EXR as `name.C` for
/// each channel suffix `C` (`m2.R`, `depth.T`, `nn.X`, …).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Layer {
    /// The layer name (the EXR channel prefix).
    pub name: String,
    /// The channel suffixes, one per value.
    pub channels: Vec<String>,
}

impl Layer {
    /// A layer `name` with the channel suffixes `channels`.
    pub fn new(name: impl Into<String>, channels: &[&str]) -> Self {
        Self {
            name: name.into(),
            channels: channels.iter().map(|c| c.to_string()).collect(),
        }
    }

    /// Number of channels.
    pub fn width(&self) -> usize {
        self.channels.len()
    }
}

/// A light-transport algorithm.
pub trait Integrator: Send + Sync + std::fmt::Debug {
    /// The channel groups after RGB (e.g. `m2` with `R`,`G`,`B`), in the
    /// order their values follow RGB in [`Integrator::sample`]'s output.
    fn extra_layers(&self) -> Vec<Layer> {
        Vec::new()
    }

    /// Number of values after RGB: the summed widths of
    /// `extra_layers()`, without allocating (it is asked per sample).
    fn extra_channel_count(&self) -> usize {
        0
    }

    /// Values per sample: RGB, then the extra layers' channels.
    fn channel_count(&self) -> usize {
        3 + self.extra_channel_count()
    }

    /// How the integrator wants emitters chosen for light sampling, if it
    /// says (`light_sampler`); the default otherwise. A render builds its
    /// light sampler so ([`crate::render::RenderState`]).
    fn light_selection(&self) -> Option<crate::light::LightSelection> {
        None
    }

    /// Whether light sampling may leave to BSDF sampling the light that
    /// BSDF sampling finds well (MIS compensation: `constant` emitters are
    /// not light-sampled, `envmap`s and `preetham`'s sky sample their excess
    /// over their mean; see [`crate::light::selection`]). Only an integrator
    /// that follows every light sample with a BSDF sample from the same
    /// vertex, and weighs the two by MIS, may say yes: where the light's
    /// density is then zero, BSDF sampling alone finds the light.
    fn mis_compensation(&self) -> bool {
        false
    }

    /// Whether the integrator reads hits' uv itself (not through textures,
    /// which the scene accounts for): an AOV of uv does. Where neither it
    /// nor a texture does, shapes may leave uv out of their hits.
    fn reads_uv(&self) -> bool {
        false
    }

    /// The particle tracer, for integrators that trace paths from the
    /// lights and so render through their own loop
    /// ([`ParticleTracer::render`]) instead of per camera ray.
    fn particle_tracer(&self) -> Option<&ParticleTracer> {
        None
    }

    /// Radiance arriving along `ray`.
    fn li(&self, scene: &RenderScene, ray: &Ray, sampler: &mut SampleStream) -> Rgb;

    /// Fills `out` (`channel_count()` values) for one camera ray.
    fn sample(&self, scene: &RenderScene, ray: &Ray, sampler: &mut SampleStream, out: &mut [f32]) {
        let l = self.li(scene, ray, sampler);
        out[..3].copy_from_slice(&l.to_array());
    }

    /// [`Integrator::sample`] for several camera rays, each with its own
    /// sample stream and its `channel_count()` values of `out` in turn
    /// (zero for a missing ray, one the lens stopped). An integrator that
    /// traces its paths together ([`crate::Scene::closest_packet`]) overrides
    /// it; every value is the one `sample` gives.
    fn sample_packet(
        &self,
        scene: &RenderScene,
        rays: &[Option<Ray>],
        samplers: &mut [SampleStream],
        out: &mut [f32],
    ) {
        let channels = self.channel_count();
        for ((ray, sampler), out) in rays.iter().zip(samplers).zip(out.chunks_mut(channels)) {
            out.fill(0.0);
            if let Some(ray) = ray {
                self.sample(scene, ray, sampler, out);
            }
        }
    }
}

/// The vertex a ray left from, as emission and MIS see it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RayOrigin {
    /// Where the ray was sampled (for the light sampler's probability).
    pub p: Vec3,
    /// The surface normal there (zero for the camera).
    pub n: Vec3,
    /// Density of the BSDF sample that produced the ray, or `None` when it
    /// was not BSDF-sampled with a finite density (camera rays, delta
    /// lobes): then no MIS.
    pub bsdf_pdf: Option<f32>,
    /// The ray is a camera ray (emitters with `visible = false` hide).
    pub camera: bool,
    /// The world the ray ends in, whose environment an escaping ray
    /// sees (0 without portals).
    pub world: u32,
}

impl RayOrigin {
    /// A camera ray from `p`.
    pub fn camera(p: Vec3) -> Self {
        Self {
            p,
            n: Vec3::ZERO,
            bsdf_pdf: None,
            camera: true,
            world: 0,
        }
    }

    /// A ray BSDF-sampled at `si` (density `bsdf_pdf`, `None` for delta).
    pub fn surface(si: &SurfaceInteraction, bsdf_pdf: Option<f32>) -> Self {
        Self::surface_at(si.p, si.n, bsdf_pdf)
    }

    /// A ray BSDF-sampled at the surface point `p` (geometric normal `n`).
    pub fn surface_at(p: Vec3, n: Vec3, bsdf_pdf: Option<f32>) -> Self {
        Self {
            p,
            n,
            bsdf_pdf,
            camera: false,
            world: 0,
        }
    }

    /// Whether emitter `e` shows itself to this ray.
    #[inline]
    fn sees(&self, scene: &RenderScene, e: u32) -> bool {
        let o = &scene.emitter_options[e as usize];
        if self.camera {
            o.visible
        } else {
            o.visible_indirect
        }
    }
}

/// Radiance from emitters at infinity along an escaped ray `d`, MIS-weighted
/// against the BSDF sample that produced it.
pub(crate) fn environment_radiance(scene: &RenderScene, origin: &RayOrigin, d: Vec3) -> Rgb {
    environment_emission(scene, origin, d, |le, light_pdf| {
        power_weighted(origin, le, light_pdf)
    })
}

/// Adds [`environment_radiance`] times `beta` to `l`, in place and out of
/// line: a result handed back was written in pieces and read whole by
/// the caller at once, which the CPU cannot forward.
#[inline(never)]
pub(crate) fn add_environment_radiance(
    scene: &RenderScene,
    origin: &RayOrigin,
    d: Vec3,
    beta: Rgb,
    l: &mut Rgb,
) {
    let le = environment_emission(scene, origin, d, |le, light_pdf| {
        power_weighted(origin, le, light_pdf)
    });
    *l += beta * le;
}

/// `le` weighted by the power heuristic between the origin's BSDF density
/// and the light density `light_pdf` (unweighted without either).
fn power_weighted(origin: &RayOrigin, le: Rgb, light_pdf: Option<f32>) -> Rgb {
    match (origin.bsdf_pdf, light_pdf) {
        (Some(pdf), Some(light_pdf)) => le * power_heuristic(pdf, light_pdf),
        _ => le,
    }
}

/// The sum over emitters at infinity of `weigh(radiance, light density)`
/// along an escaped ray `d`: the density with which light sampling from
/// `origin` gives that direction (`None` when the origin asks for no MIS).
pub(crate) fn environment_emission(
    scene: &RenderScene,
    origin: &RayOrigin,
    d: Vec3,
    mut weigh: impl FnMut(Rgb, Option<f32>) -> Rgb,
) -> Rgb {
    use crate::light::LightChoice;
    let ctx = scene.emitter_context();
    let mut l = Rgb::ZERO;
    for &e in scene.environment_of(origin.world) {
        if !origin.sees(scene, e) {
            continue;
        }
        let emitter = scene.emitter(e);
        let (le, light_pdf) = if origin.bsdf_pdf.is_some() {
            if scene.light_sampler().never_chooses(e) {
                // Left to BSDF sampling (MIS compensation): light sampling
                // never finds it, and its density and choice need no work.
                // A constant sky's radiance is read in its own branch: out
                // of a match with the other emitters' calls, it came
                // through memory in pieces the CPU cannot forward.
                l += match emitter {
                    crate::light::Emitter::Constant(c) => weigh(c.radiance, Some(0.0)),
                    _ => weigh(emitter.environment_radiance(&ctx, d), Some(0.0)),
                };
                continue;
            }
            let (le, pdf) = emitter.environment_radiance_and_pdf(&ctx, origin.p, d);
            let choice = LightChoice {
                emitter: e,
                prim: LightChoice::WHOLE,
            };
            (
                le,
                Some(scene.light_pmf_in(origin.world, choice, origin.p, origin.n) * pdf),
            )
        } else {
            (emitter.environment_radiance(&ctx, d), None)
        };
        l += weigh(le, light_pdf);
    }
    l
}

/// Radiance emitted by the surface at `si` towards the ray's origin,
/// MIS-weighted as in [`environment_radiance`].
pub(crate) fn surface_emission(
    scene: &RenderScene,
    si: &SurfaceInteraction,
    origin: &RayOrigin,
) -> Rgb {
    surface_emission_with(scene, si, origin, |le, light_pdf| {
        power_weighted(origin, le, light_pdf)
    })
}

/// `weigh(radiance, light density)` for the surface at `si` (zero when it
/// does not emit towards the origin), as in [`environment_emission`].
pub(crate) fn surface_emission_with(
    scene: &RenderScene,
    si: &SurfaceInteraction,
    origin: &RayOrigin,
    weigh: impl FnOnce(Rgb, Option<f32>) -> Rgb,
) -> Rgb {
    use crate::light::{Emitter, EmitterModel, LightChoice};
    let Some(light) = scene.light_of_hit(si) else {
        return Rgb::ZERO;
    };
    if !origin.sees(scene, light.emitter) {
        return Rgb::ZERO;
    }
    let emitter = scene.emitter(light.emitter);
    let le = emitter.surface_radiance(&scene.materials, si);
    if le == Rgb::ZERO {
        return Rgb::ZERO;
    }
    let light_pdf = origin.bsdf_pdf.map(|_| {
        let ctx = scene.emitter_context();
        let n = si.sh_frame.n;
        let pdf_direction = match emitter {
            Emitter::Area(a) if light.prim != LightChoice::WHOLE => {
                a.pdf_triangle_direction(&ctx, light.prim, origin.p, si.p, n)
            }
            _ => emitter.pdf_direction(&ctx, origin.p, si.p, n, -si.wo),
        };
        scene.light_pmf_in(origin.world, light, origin.p, origin.n) * pdf_direction
    });
    weigh(le, light_pdf)
}

/// The numbers one light sample draws, in the order it draws them: which
/// light, and where on it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LightDraw {
    /// Chooses the emitter.
    pub u_pick: f32,
    /// Chooses the point on it.
    pub u: glam::Vec2,
}

impl LightDraw {
    /// Draws the light sample's numbers from `sampler`.
    #[inline]
    pub fn draw(sampler: &mut SampleStream) -> Self {
        let u_pick = sampler.next_1d();
        Self {
            u_pick,
            u: sampler.next_2d(),
        }
    }
}

/// A light sample and how it was chosen.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PickedLightSample {
    /// The sample of the chosen emitter.
    pub ls: crate::light::EmitterSample,
    /// The probability of choosing that emitter (or triangle).
    pub pick_pdf: f32,
    /// The chosen emitter.
    pub emitter: u32,
}

/// One light sample at `si` with MIS against the BSDF: the contribution
/// f · Li · T · w / pdf (before path throughput), with `light_count_ratio`
/// scaling the light density in the heuristic (sample-count ratios) and T
/// the transmittance of the shadow ray through at most `max_crossings`
/// pass-through surfaces.
pub(crate) fn sample_light(
    scene: &RenderScene,
    si: &SurfaceInteraction,
    bsdf: &crate::bsdf::Bsdf,
    sampler: &mut SampleStream,
    light_count_ratio: f32,
    max_crossings: u32,
) -> Rgb {
    let ctx = crate::bsdf::BsdfContext::default();
    let eval = |wi, mis| bsdf.eval_pdf_if(&ctx, wi, mis);
    sample_light_unshadowed_by(scene, si, sampler, light_count_ratio, eval)
        .map_or(Rgb::ZERO, |l| l.shadowed(scene, max_crossings))
}

/// [`sample_light`] up to its shadow ray: the light sample's
/// contribution should nothing block it, and its shadow ray (`None` when
/// it contributes nothing anyway), with the BSDF's value and density
/// towards a local direction given by `eval` (as
/// [`light_sample_unshadowed_by`] takes them).
#[inline(always)]
pub(crate) fn sample_light_unshadowed_by(
    scene: &RenderScene,
    si: &SurfaceInteraction,
    sampler: &mut SampleStream,
    light_count_ratio: f32,
    eval: impl FnOnce(Vec3, bool) -> (Rgb, f32),
) -> Option<UnshadowedSample> {
    let draw = LightDraw::draw(sampler);
    let (light, pick_pdf) = scene.pick_light(draw.u_pick, si.p, si.n)?;
    let ls = sample_chosen_light(scene, light, si.p, draw.u)?;
    let picked = PickedLightSample {
        ls,
        pick_pdf,
        emitter: light.emitter,
    };
    light_sample_unshadowed_by(scene, si, &picked, light_count_ratio, eval)
}

/// A light sample's contribution before its shadow ray is traced
/// ([`light_sample_unshadowed_by`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct UnshadowedSample {
    /// BSDF value times radiance.
    f_le: Rgb,
    /// MIS weight.
    w: f32,
    /// Light density (choice included).
    light_pdf: f32,
    /// The shadow ray towards the sample.
    pub shadow: crate::math::Ray,
}

impl UnshadowedSample {
    /// The contribution when the fraction `tr` of the light gets through.
    #[inline]
    pub fn through(&self, tr: f32) -> Rgb {
        if tr <= 0.0 {
            return Rgb::ZERO;
        }
        self.f_le * (tr * self.w / self.light_pdf)
    }

    /// The contribution, its shadow ray traced through at most
    /// `max_crossings` pass-through surfaces.
    #[inline]
    pub fn shadowed(&self, scene: &RenderScene, max_crossings: u32) -> Rgb {
        self.through(scene.transmittance(&self.shadow, max_crossings))
    }
}

/// The light sample `picked` at `si` with MIS against the BSDF, as
/// [`sample_light`] weighs it, up to its shadow ray (`None` when the BSDF
/// reflects nothing towards the light); the BSDF's value and density
/// (0 when the second argument, whether MIS weighs the sample, is false)
/// towards a local direction are `eval`'s.
#[inline(always)]
pub(crate) fn light_sample_unshadowed_by(
    scene: &RenderScene,
    si: &SurfaceInteraction,
    picked: &PickedLightSample,
    light_count_ratio: f32,
    eval: impl FnOnce(Vec3, bool) -> (Rgb, f32),
) -> Option<UnshadowedSample> {
    let ls = &picked.ls;
    let wi_local = si.to_local(ls.wi);
    // Lights hidden from indirect rays cannot be found by BSDF sampling:
    // light sampling is then their only strategy, and needs no BSDF density.
    let mis = !ls.is_delta && scene.emitter_options[picked.emitter as usize].visible_indirect;
    let (f, bsdf_pdf) = eval(wi_local, mis);
    if f == Rgb::ZERO {
        return None;
    }
    let light_pdf = ls.pdf * picked.pick_pdf;
    let w = if mis {
        power_heuristic(light_pdf * light_count_ratio, bsdf_pdf)
    } else {
        1.0
    };
    Some(UnshadowedSample {
        f_le: f * ls.radiance,
        w,
        light_pdf,
        shadow: shadow_ray_towards(si.p, si.n, ls.wi, ls.dist),
    })
}

/// The shadow ray from the surface point `p` (geometric normal `n`)
/// towards a light sample `dist` away along `wi` (infinitely far: a
/// light at infinity).
#[inline]
pub(crate) fn shadow_ray_towards(p: Vec3, n: Vec3, wi: Vec3, dist: f32) -> crate::math::Ray {
    if dist.is_finite() {
        crate::math::shadow_ray_to(p, n, p + wi * dist)
    } else {
        crate::math::spawn_ray(p, n, wi)
    }
}

/// Samples the emitter (or the emitting triangle) `light` picked by the
/// light sampler, as seen from `p`.
pub(crate) fn sample_chosen_light(
    scene: &RenderScene,
    light: crate::light::LightChoice,
    p: Vec3,
    u: glam::Vec2,
) -> Option<crate::light::EmitterSample> {
    use crate::light::{Emitter, EmitterModel, LightChoice};
    let ctx = scene.emitter_context();
    let emitter = scene.emitter(light.emitter);
    match emitter {
        Emitter::Area(a) if light.prim != LightChoice::WHOLE => {
            a.sample_triangle_direction(&ctx, light.prim, p, u)
        }
        _ => emitter.sample_direction(&ctx, p, u),
    }
}
