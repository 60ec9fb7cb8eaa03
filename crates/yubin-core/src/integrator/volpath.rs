//! `volpath`: volumetric path tracing (Mitsuba 3's `volpath`, with its
//! parameters and conventions): paths scatter at surfaces and inside
//! participating media. Free flights are sampled exactly in homogeneous
//! media and by delta tracking in heterogeneous ones; chromatic media use
//! spectral MIS over whole paths (a hero channel per path samples the
//! distances, the others' densities weigh the result by the balance
//! heuristic; Miller et al. 2019, "A null-scattering path integral
//! formulation of light transport"; pbrt-v4). Next-event estimation runs at
//! surfaces and at scattering points of media with `sample_emitters`;
//! shadow rays are *generalized*: they cross `null` and `mask` surfaces
//! (multiplying by what each lets through), change medium at shapes that
//! bound media, and take the transmittance of every medium on the way
//! (exact when homogeneous, ratio tracking otherwise; Novák et al. 2014).
//! Light and phase/BSDF sampling are combined by MIS (power heuristic),
//! and every light sample is followed by a phase or BSDF sample from the
//! same vertex, so light sampling may leave them the light they find well
//! (`mis_compensation`, as in `path`).
//!
//! | parameter       | type    | default | meaning                                                        |
//! |-----------------|---------|---------|----------------------------------------------------------------|
//! | `max_depth`     | integer | -1      | most scattering events + 1 (−1: unlimited); crossing a `null` surface does not count |
//! | `rr_depth`      | integer | 5       | Russian roulette starts after this many scattering events      |
//! | `hide_emitters` | boolean | false   | emitters seen directly by the camera render black              |
//! | `light_sampler` | string  | bvh     | how light sampling picks an emitter (see `path`)               |
//! | `mis_compensation` | boolean | true | leave to phase and BSDF sampling the light they find well (see `path`) |
//! | `shadow_rays`   | string  | generalized | `binary`: shadow rays stop at any surface (yubin; for comparison, seed 003) |
//!
//! ```xml
//! <integrator type="volpath"><integer name="max_depth" value="32"/></integrator>
//! ```
//!
//! `volpathmis` takes the same parameters (but only generalized shadow
//! rays) and weighs light and phase/BSDF sampling by the densities of the
//! whole paths each would have made (Miller et al. 2019; pbrt-v4's r_u and
//! r_l): the chance of flying through the media on the way, of the null
//! collisions and of the null lobes crossed, balanced over strategies and
//! channels, where `volpath` uses the power heuristic on the last
//! direction's densities (as Mitsuba's `volpath`).
//!
//! With `shadow_rays` = `binary`, a shadow ray that meets any surface
//! (even a `null` one) carries nothing, and an emitter a path reaches
//! through pass-through surfaces counts without MIS (light sampling could
//! not have found it): the same image, with more variance.

use super::{environment_emission, max_depth_param, sample_chosen_light, surface_emission_with};
use super::{Integrator, RayOrigin};
use crate::bsdf::{Bsdf, BsdfContext, BsdfFlags};
use crate::interaction::SurfaceInteraction;
use crate::light::{EmitterSample, LightSelection};
use crate::math::{spawn_ray, Ray, SHADOW_EPSILON};
use crate::medium::{mean_ratio, Flight, Medium, PathWeight};
use crate::params::{ParamError, Params};
use crate::phase::PhaseFunction;
use crate::render::RenderScene;
use crate::sampler::SampleStream;
use crate::sampling::power_heuristic;
use crate::scene::{HitRecord, ShadowHit};
use crate::Rgb;
use glam::Vec3;

/// The most pass-through surfaces a shadow ray crosses.
const MAX_SHADOW_CROSSINGS: u32 = 256;

/// Volumetric path tracer settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VolPathIntegrator {
    /// Most scattering events + 1; negative means unlimited.
    pub max_depth: i32,
    /// Scattering events after which Russian roulette starts.
    pub rr_depth: u32,
    /// Hide directly visible emitters.
    pub hide_emitters: bool,
    /// How emitters are chosen for light sampling (`None`: the default).
    pub light_selection: Option<LightSelection>,
    /// Shadow rays stop at the first surface whatever it is.
    pub binary_shadow_rays: bool,
    /// `volpathmis`: MIS weights from whole-path densities (free flights,
    /// null collisions and null lobes included), balance heuristic over
    /// strategies and channels.
    pub path_mis: bool,
    /// Leave to phase and BSDF sampling the light they find well (see
    /// `path`).
    pub mis_compensation: bool,
}

impl VolPathIntegrator {
    /// Builds the integrator from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        Ok(Self {
            max_depth: max_depth_param(p)?,
            rr_depth: super::rr_depth_param(p)?,
            hide_emitters: p.boolean_or("hide_emitters", false)?,
            light_selection: LightSelection::from_params(p)?,
            binary_shadow_rays: p.choice("shadow_rays", &["generalized", "binary"])? == 1,
            path_mis: false,
            mis_compensation: p.boolean_or("mis_compensation", true)?,
        })
    }

    /// Builds `volpathmis` from its scene parameters.
    pub fn from_params_mis(p: &mut dyn Params) -> Result<Self, ParamError> {
        let v = Self::from_params(p)?;
        if v.binary_shadow_rays {
            return Err(p.param_error(
                "shadow_rays",
                "volpathmis weighs shadow rays by what they cross: only \"generalized\"",
            ));
        }
        Ok(Self {
            path_mis: true,
            ..v
        })
    }
}

impl Default for VolPathIntegrator {
    fn default() -> Self {
        Self {
            max_depth: -1,
            rr_depth: 5,
            hide_emitters: false,
            light_selection: None,
            binary_shadow_rays: false,
            path_mis: false,
            mis_compensation: true,
        }
    }
}

/// BSDF queries as Mitsuba's `volpath` makes them: `thindielectric`
/// transmission is a null crossing.
fn volpath_context() -> BsdfContext {
    BsdfContext {
        null_slabs: true,
        ..BsdfContext::default()
    }
}

/// What a shadow ray found on its way.
#[derive(Clone, Copy, Debug)]
struct Shadow {
    /// The media's transmittance (an estimate in heterogeneous media).
    media: Rgb,
    /// What the pass-through surfaces let through.
    surfaces: Rgb,
    /// The probability that BSDF sampling takes the null lobes of those
    /// surfaces (for `volpathmis`'s path densities).
    null_probability: f32,
}

impl Shadow {
    const BLOCKED: Self = Self {
        media: Rgb::ZERO,
        surfaces: Rgb::ZERO,
        null_probability: 0.0,
    };
    const CLEAR: Self = Self {
        media: Rgb::ONE,
        surfaces: Rgb::ONE,
        null_probability: 1.0,
    };

    fn total(&self) -> Rgb {
        self.media * self.surfaces
    }
}

/// A light sample seen from a scattering point, before the shadow ray.
struct LightSample {
    ls: EmitterSample,
    /// Pick probability × direction density.
    pdf: f32,
    /// Light sampling is the only strategy that finds this light (delta
    /// lights, lights hidden from indirect rays): no MIS.
    alone: bool,
}

impl VolPathIntegrator {
    fn max_depth(&self) -> u32 {
        u32::try_from(self.max_depth).unwrap_or(u32::MAX)
    }

    /// Picks and samples a light from `p` (surface normal `n`, zero in a
    /// medium).
    fn pick_light(
        scene: &RenderScene,
        p: Vec3,
        n: Vec3,
        sampler: &mut SampleStream,
    ) -> Option<LightSample> {
        let u_pick = sampler.next_1d();
        let u = sampler.next_2d();
        let (light, pick_pdf) = scene.pick_light(u_pick, p, n)?;
        let ls = sample_chosen_light(scene, light, p, u)?;
        let alone = ls.is_delta || !scene.emitter_options[light.emitter as usize].visible_indirect;
        Some(LightSample {
            pdf: ls.pdf * pick_pdf,
            ls,
            alone,
        })
    }

    /// The light sample's contribution to the path: f · L · T · w / pdf
    /// times the path's weight, with `f` the BSDF or phase value and
    /// `pdf_other` that strategy's density.
    fn weigh(&self, path: &PathWeight, s: &LightSample, f: Rgb, pdf_other: f32, sh: Shadow) -> Rgb {
        let pdf_other = if s.alone { 0.0 } else { pdf_other };
        let l = f * s.ls.radiance * sh.total();
        if !self.path_mis {
            return path.contribution(l * (power_heuristic(s.pdf, pdf_other) / s.pdf));
        }
        // Balance over the strategies and channels: light sampling's
        // density, and the path's own, which had to pass the media and
        // pick the null lobes on the way.
        let r_light = path.ratio * s.pdf;
        let r_path = path.ratio * (pdf_other * sh.null_probability) * sh.media;
        path.beta * l / mean_ratio(r_light + r_path)
    }

    /// What emission `le` reaching the path (from a vertex at which light
    /// sampling had density `light_pdf`, `None` without MIS) contributes.
    fn weigh_emission(
        &self,
        path: &PathWeight,
        origin: &RayOrigin,
        le: Rgb,
        light_pdf: Option<f32>,
    ) -> Rgb {
        match (self.path_mis, origin.bsdf_pdf, light_pdf) {
            (true, Some(_), Some(light_pdf)) => {
                path.beta * le / mean_ratio(path.ratio + path.ratio_light * light_pdf)
            }
            (false, Some(pdf), Some(light_pdf)) => {
                path.contribution(le * power_heuristic(pdf, light_pdf))
            }
            _ => path.contribution(le),
        }
    }

    /// Next-event estimation at a medium scattering point `p`.
    #[allow(clippy::too_many_arguments)]
    fn light_from_medium(
        &self,
        scene: &RenderScene,
        path: &PathWeight,
        p: Vec3,
        wo: Vec3,
        phase: &PhaseFunction,
        medium: Option<u32>,
        sampler: &mut SampleStream,
    ) -> Rgb {
        let Some(s) = Self::pick_light(scene, p, Vec3::ZERO, sampler) else {
            return Rgb::ZERO;
        };
        let f = phase.eval(wo, s.ls.wi);
        if f <= 0.0 {
            return Rgb::ZERO;
        }
        let t_max = if s.ls.dist.is_finite() {
            s.ls.dist * (1.0 - SHADOW_EPSILON)
        } else {
            f32::INFINITY
        };
        let shadow = Ray {
            o: p,
            d: s.ls.wi,
            t_min: 0.0,
            t_max,
        };
        let sh = self.shadow(scene, shadow, medium, sampler);
        if sh.total() == Rgb::ZERO {
            return Rgb::ZERO;
        }
        self.weigh(path, &s, Rgb::splat(f), phase.pdf(wo, s.ls.wi), sh)
    }

    /// Next-event estimation at a surface; `medium` is the one the path
    /// arrived in.
    #[allow(clippy::too_many_arguments)]
    fn light_from_surface(
        &self,
        scene: &RenderScene,
        path: &PathWeight,
        si: &SurfaceInteraction,
        bsdf: &Bsdf,
        medium: Option<u32>,
        sampler: &mut SampleStream,
    ) -> Rgb {
        let Some(s) = Self::pick_light(scene, si.p, si.n, sampler) else {
            return Rgb::ZERO;
        };
        let ctx = volpath_context();
        let wi = si.to_local(s.ls.wi);
        let f = bsdf.eval(&ctx, wi);
        if f == Rgb::ZERO {
            return Rgb::ZERO;
        }
        let shadow = if s.ls.dist.is_finite() {
            si.spawn_ray_to(si.p + s.ls.wi * s.ls.dist)
        } else {
            si.spawn_ray(s.ls.wi)
        };
        let medium = scene.medium_after(si, s.ls.wi, medium);
        let sh = self.shadow(scene, shadow, medium, sampler);
        if sh.total() == Rgb::ZERO {
            return Rgb::ZERO;
        }
        let pdf = bsdf.pdf(&ctx, wi);
        self.weigh(path, &s, f, pdf, sh)
    }

    /// What reaches the end of a shadow ray that starts in `medium`:
    /// through pass-through surfaces (changing medium where shapes bound
    /// media) and media; nothing past the first opaque surface.
    fn shadow(
        &self,
        scene: &RenderScene,
        mut r: Ray,
        mut medium: Option<u32>,
        sampler: &mut SampleStream,
    ) -> Shadow {
        if self.binary_shadow_rays {
            return if scene.occluded(&r) {
                Shadow::BLOCKED
            } else {
                Shadow {
                    media: Self::medium_transmittance(scene, &r, r.t_max, medium, sampler),
                    ..Shadow::CLEAR
                }
            };
        }
        if !scene.shadow_rays_cross_surfaces() {
            return if scene.occluded(&r) {
                Shadow::BLOCKED
            } else {
                Shadow::CLEAR
            };
        }
        let mut sh = Shadow::CLEAR;
        for _ in 0..MAX_SHADOW_CROSSINGS {
            // The surface ahead, if any: where, its normal and shape, and
            // what crossing it takes (probability of the null lobes, what
            // passes).
            let crossing = match scene.shadow_hit(&r) {
                None => None,
                Some(ShadowHit::Opaque) => return Shadow::BLOCKED,
                Some(ShadowHit::Null { t, p, n, shape }) => Some((t, p, n, shape, (1.0, Rgb::ONE))),
                Some(ShadowHit::Surface(si)) => {
                    let bsdf = scene.bsdf_of(si.shape);
                    let c = bsdf.null_crossing(&scene.materials, &si, true);
                    Some((si.t, si.p, si.n, si.shape, c))
                }
            };
            let end = crossing.map_or(r.t_max, |c| c.0);
            sh.media *= Self::medium_transmittance(scene, &r, end, medium, sampler);
            if sh.media.max_element() <= 0.0 {
                return Shadow::BLOCKED;
            }
            let Some((t, p, n, shape, (probability, passes))) = crossing else {
                return sh;
            };
            sh.surfaces *= passes;
            sh.null_probability *= probability;
            if sh.surfaces.max_element() <= 0.0 {
                return Shadow::BLOCKED;
            }
            medium = scene.medium_across(shape, n, r.d, medium);
            r = Ray {
                t_max: r.t_max - t,
                ..spawn_ray(p, n, r.d)
            };
            if r.t_max <= r.t_min {
                return sh;
            }
        }
        Shadow::BLOCKED
    }

    /// Transmittance of `medium` along `r` up to `end`.
    fn medium_transmittance(
        scene: &RenderScene,
        r: &Ray,
        end: f32,
        medium: Option<u32>,
        sampler: &mut SampleStream,
    ) -> Rgb {
        match medium {
            Some(m) => {
                scene.media[m as usize].transmittance(r.o, r.d, end, &mut || sampler.next_1d())
            }
            None => Rgb::ONE,
        }
    }

    /// Follows `ray` through `medium` to its next event: the surface it
    /// reaches, if any, and the free flight through the medium (a
    /// scattering event before the surface, or the weight of passing).
    fn trace(
        scene: &RenderScene,
        ray: &Ray,
        medium: Option<u32>,
        path: &mut PathWeight,
        sampler: &mut SampleStream,
    ) -> (Option<HitRecord>, Option<Flight>) {
        match medium.map(|m| &scene.media[m as usize]) {
            None => (scene.closest(ray), None),
            // The distance is drawn first, and surfaces are looked for
            // only that far: a scattering event computes no hit.
            Some(Medium::Homogeneous(h)) => {
                let t = h.free_distance(ray.o, ray.d, path, sampler.next_1d());
                let hit = scene.closest(&Ray {
                    t_max: ray.t_max.min(t),
                    ..*ray
                });
                let end = hit.map_or(ray.t_max, |h| h.t());
                (hit, Some(h.end_flight(ray.o, ray.d, t, end, path)))
            }
            Some(m) => {
                let hit = scene.closest(ray);
                let end = hit.map_or(ray.t_max, |h| h.t());
                let mut next = || sampler.next_1d();
                let flight = m.sample_flight(ray.o, ray.d, end, path, &mut next);
                (hit, Some(flight))
            }
        }
    }

    /// Russian roulette after a scattering event; false ends the path.
    fn survives(
        &self,
        depth: u32,
        path: &mut PathWeight,
        eta2: f32,
        sampler: &mut SampleStream,
    ) -> bool {
        if depth < self.rr_depth {
            return true;
        }
        let q = (path.contribution(Rgb::ONE).max_element() * eta2).min(0.95);
        if sampler.next_1d() >= q {
            return false;
        }
        path.beta /= q;
        true
    }
}

impl Integrator for VolPathIntegrator {
    fn light_selection(&self) -> Option<LightSelection> {
        self.light_selection
    }

    fn mis_compensation(&self) -> bool {
        self.mis_compensation
    }

    fn li(&self, scene: &RenderScene, camera_ray: &Ray, sampler: &mut SampleStream) -> Rgb {
        let ctx = volpath_context();
        let max_depth = self.max_depth();
        let (mut l, mut eta2) = (Rgb::ZERO, 1.0f32);
        // Chromatic media sample distances by one channel per path.
        let hero = if scene.has_media() {
            ((sampler.next_1d() * 3.0) as usize).min(2)
        } else {
            0
        };
        let mut path = PathWeight::new(hero);
        // Media are sampled from the ray's origin: start it at the near
        // clip plane (as Mitsuba does).
        let mut ray = Ray {
            o: camera_ray.at(camera_ray.t_min),
            t_min: 0.0,
            t_max: camera_ray.t_max - camera_ray.t_min,
            ..*camera_ray
        };
        let mut medium = scene.camera_medium;
        // The last real scattering vertex, for MIS (see `path`); crossing
        // a pass-through surface keeps it.
        let mut origin = RayOrigin::camera(ray.o);
        // Under binary shadow rays, the path crossed a pass-through
        // surface since that vertex: light sampling could not see past it.
        let mut crossed = false;
        // Real scattering events so far.
        let mut depth: u32 = 0;
        while depth < max_depth {
            let (hit, flight) = Self::trace(scene, &ray, medium, &mut path, sampler);
            if let (Some(flight), Some(m)) = (flight, medium) {
                let m = &scene.media[m as usize];
                l += flight.emitted;
                if path.beta.max_element() <= 0.0 {
                    break;
                }
                if flight.scattered {
                    depth += 1;
                    if depth >= max_depth {
                        break;
                    }
                    let p = ray.at(flight.t);
                    let wo = -ray.d;
                    let phase = &m.phase().at(p);
                    if m.sample_emitters() {
                        l += self.light_from_medium(scene, &path, p, wo, phase, medium, sampler);
                    }
                    let ps = phase.sample(wo, sampler.next_2d());
                    path.beta *= ps.weight;
                    path.ratio_light = path.ratio / ps.pdf;
                    origin = RayOrigin {
                        p,
                        n: Vec3::ZERO,
                        bsdf_pdf: m.sample_emitters().then_some(ps.pdf),
                        camera: false,
                        world: 0,
                    };
                    crossed = false;
                    ray = Ray::new(p, ps.wi);
                    if !self.survives(depth, &mut path, eta2, sampler) {
                        break;
                    }
                    continue;
                }
            }
            let hidden = depth == 0 && self.hide_emitters;
            let mis_origin = if crossed {
                RayOrigin {
                    bsdf_pdf: None,
                    ..origin
                }
            } else {
                origin
            };
            let weigh = |le, light_pdf| self.weigh_emission(&path, &mis_origin, le, light_pdf);
            let Some(hit) = hit else {
                if !hidden {
                    l += environment_emission(scene, &mis_origin, ray.d, weigh);
                }
                break;
            };
            let si = scene.interaction_at(&ray, &hit);
            if !hidden {
                l += surface_emission_with(scene, &si, &mis_origin, weigh);
            }
            let wo = si.to_local(si.wo);
            let bsdf = scene.bsdf_of(si.shape).at(&scene.materials, &si, wo);
            if scene.bsdf_flags_of(si.shape).intersects(BsdfFlags::SMOOTH) && depth + 1 < max_depth
            {
                l += self.light_from_surface(scene, &path, &si, &bsdf, medium, sampler);
            }
            let u1 = sampler.next_1d();
            let u2 = sampler.next_2d();
            let Some(bs) = bsdf.sample(&ctx, u1, u2) else {
                break;
            };
            path.beta *= bs.weight;
            eta2 *= bs.eta * bs.eta;
            let wi = si.to_world(bs.wi);
            medium = scene.medium_after(&si, wi, medium);
            ray = si.spawn_ray(wi);
            if bs.sampled == BsdfFlags::NULL {
                crossed |= self.binary_shadow_rays;
                // Light sampling crosses the surface without choosing.
                path.ratio_light /= bs.pdf;
            } else {
                depth += 1;
                path.ratio_light = path.ratio / bs.pdf;
                let pdf = (!bs.sampled.intersects(BsdfFlags::DELTA)).then_some(bs.pdf);
                origin = RayOrigin::surface(&si, pdf);
                crossed = false;
                if !self.survives(depth, &mut path, eta2, sampler) {
                    break;
                }
            }
            if path.beta.max_element() <= 0.0 {
                break;
            }
        }
        l
    }
}
