//! `path`: unidirectional path tracing with next-event estimation at every
//! bounce, multiple importance sampling (power heuristic) between light
//! and BSDF sampling, and Russian roulette (Veach 1997, ch. 9;
//! pbrt-v4 §13.4).
//!
//! | parameter       | type    | default | meaning                                                        |
//! |-----------------|---------|---------|----------------------------------------------------------------|
//! | `max_depth`     | integer | -1      | longest path in segments (−1: unlimited); 1 = visible emitters only, 2 = direct light |
//! | `rr_depth`      | integer | 5       | Russian roulette starts once a path has this many segments     |
//! | `hide_emitters` | boolean | false   | emitters seen directly by the camera render black              |
//! | `light_sampler` | string  | bvh     | how light sampling picks an emitter: `uniform` (Mitsuba's rule, by `sampling_weight`), `power`, `bvh` (yubin) |
//!
//! ```xml
//! <integrator type="path"><integer name="max_depth" value="8"/></integrator>
//! ```
//!
//! The roulette survival probability is min(max(β)·η², 0.95), with β the
//! throughput and η the accumulated relative index of refraction.

use super::max_depth_param;
use super::{environment_radiance, sample_light, surface_emission, Integrator, RayOrigin};
use crate::bsdf::{BsdfContext, BsdfFlags, BsdfModel};
use crate::light::LightSelection;
use crate::math::Ray;
use crate::params::{ParamError, Params};
use crate::sampler::SampleStream;
use crate::{Rgb, Scene};

/// Path tracer settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PathIntegrator {
    /// Longest path in segments; negative means unlimited.
    pub max_depth: i32,
    /// Path length at which Russian roulette starts.
    pub rr_depth: u32,
    /// Hide directly visible emitters.
    pub hide_emitters: bool,
    /// How emitters are chosen for light sampling (`None`: the default).
    pub light_selection: Option<LightSelection>,
}

impl PathIntegrator {
    /// Builds the integrator from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        Ok(Self {
            max_depth: max_depth_param(p)?,
            rr_depth: super::rr_depth_param(p)?,
            hide_emitters: p.boolean_or("hide_emitters", false)?,
            light_selection: LightSelection::from_params(p)?,
        })
    }
}

impl Default for PathIntegrator {
    fn default() -> Self {
        Self {
            max_depth: -1,
            rr_depth: 5,
            hide_emitters: false,
            light_selection: None,
        }
    }
}

impl Integrator for PathIntegrator {
    fn light_selection(&self) -> Option<LightSelection> {
        self.light_selection
    }

    fn li(&self, scene: &Scene, camera_ray: &Ray, sampler: &mut SampleStream) -> Rgb {
        let ctx = BsdfContext::default();
        let (mut l, mut beta, mut eta2) = (Rgb::ZERO, Rgb::ONE, 1.0f32);
        let mut ray = *camera_ray;
        // The vertex that BSDF-sampled `ray`, with the density (None for
        // camera rays and delta lobes: no MIS, the light could not sample
        // them). Crossing a pass-through surface keeps it: that vertex's
        // light samples reach the same emitters through the same surfaces.
        let mut origin = RayOrigin::camera(ray.o);
        // Number of segments traced so far minus one (0 at the first hit).
        let mut depth: u32 = 0;
        loop {
            let Some(hit) = scene.closest(&ray) else {
                if !(depth == 0 && self.hide_emitters) {
                    l += beta * environment_radiance(scene, &origin, ray.d.normalize());
                }
                break;
            };
            let si = scene.interaction_at(&ray, hit);
            if !(depth == 0 && self.hide_emitters) {
                l += beta * surface_emission(scene, &si, &origin);
            }
            if self.max_depth >= 0 && depth + 1 >= self.max_depth as u32 {
                break;
            }
            let bsdf = scene.bsdf_of(si.shape);
            let wo = si.to_local(si.wo);
            if bsdf.flags(&scene.materials).intersects(BsdfFlags::SMOOTH) {
                // The light sample's path may cross as many pass-through
                // surfaces as the BSDF sample's path could: each crossing
                // counts as a bounce (as in Mitsuba), and the last one must
                // still leave room for the segment that reaches the light.
                let crossings = match self.max_depth {
                    d if d < 0 => u32::MAX,
                    d => (d as u32).saturating_sub(depth + 2),
                };
                l += beta * sample_light(scene, &si, bsdf, wo, sampler, 1.0, crossings);
            }
            let u1 = sampler.next_1d();
            let u2 = sampler.next_2d();
            let Some(bs) = bsdf.sample(&scene.materials, &ctx, &si, wo, u1, u2) else {
                break;
            };
            beta *= bs.weight;
            eta2 *= bs.eta * bs.eta;
            if bs.sampled != BsdfFlags::NULL {
                let pdf = (!bs.sampled.intersects(BsdfFlags::DELTA)).then_some(bs.pdf);
                origin = RayOrigin::surface(&si, pdf);
            }
            ray = si.spawn_ray(si.to_world(bs.wi));
            depth += 1;
            if depth >= self.rr_depth {
                let q = (beta.max_element() * eta2).min(0.95);
                if sampler.next_1d() >= q {
                    break;
                }
                beta /= q;
            }
            if beta.max_element() <= 0.0 {
                break;
            }
        }
        l
    }
}
