//! `direct`: direct illumination only, combining light and BSDF samples
//! with multiple importance sampling (power heuristic, Veach 1997 §9.2,
//! with the sample counts as weights).
//!
//! | parameter         | type    | default | meaning                                   |
//! |-------------------|---------|---------|-------------------------------------------|
//! | `shading_samples` | integer | 1       | sets both counts below                    |
//! | `emitter_samples` | integer | shading | light samples per hit                     |
//! | `bsdf_samples`    | integer | shading | BSDF samples per hit                      |
//! | `hide_emitters`   | boolean | false   | emitters seen by the camera render black  |
//! | `light_sampler` | string  | bvh     | how light sampling picks an emitter: `uniform` (Mitsuba's rule, by `sampling_weight`), `power`, `bvh` (yubin) |
//! | `mis_compensation` | boolean | true | with BSDF samples, leave to them the light they find well (see `path`) |
//!
//! ```xml
//! <integrator type="direct"><integer name="emitter_samples" value="4"/></integrator>
//! ```

use super::{environment_radiance, sample_light, surface_emission, Integrator, RayOrigin};
use crate::bsdf::{BsdfContext, BsdfFlags};
use crate::light::LightSelection;
use crate::math::Ray;
use crate::params::{ParamError, Params};
use crate::render::RenderScene;
use crate::sampler::SampleStream;
use crate::Rgb;

/// Direct-illumination settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DirectIntegrator {
    /// Light samples per hit.
    pub emitter_samples: u32,
    /// BSDF samples per hit.
    pub bsdf_samples: u32,
    /// Hide directly visible emitters.
    pub hide_emitters: bool,
    /// How emitters are chosen for light sampling (`None`: the default).
    pub light_selection: Option<LightSelection>,
    /// Leave to BSDF sampling the light it finds well, when there are BSDF
    /// samples (see `path`).
    pub mis_compensation: bool,
}

impl DirectIntegrator {
    /// Builds the integrator from its scene parameters: `shading_samples`
    /// is the default of both sample counts.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let shading = p.integer_or("shading_samples", 1)?.max(0);
        Ok(Self {
            emitter_samples: p.integer_or("emitter_samples", shading)?.max(0) as u32,
            bsdf_samples: p.integer_or("bsdf_samples", shading)?.max(0) as u32,
            hide_emitters: p.boolean_or("hide_emitters", false)?,
            light_selection: LightSelection::from_params(p)?,
            mis_compensation: p.boolean_or("mis_compensation", true)?,
        })
    }
}

impl Default for DirectIntegrator {
    fn default() -> Self {
        Self {
            emitter_samples: 1,
            bsdf_samples: 1,
            hide_emitters: false,
            light_selection: None,
            mis_compensation: true,
        }
    }
}

impl Integrator for DirectIntegrator {
    fn light_selection(&self) -> Option<LightSelection> {
        self.light_selection
    }

    /// Only with BSDF samples: without them light sampling is the only
    /// strategy and must cover every emitter whole.
    fn mis_compensation(&self) -> bool {
        self.mis_compensation && self.bsdf_samples > 0
    }

    fn li(&self, scene: &RenderScene, ray: &Ray, sampler: &mut SampleStream) -> Rgb {
        let Some(hit) = scene.closest(ray) else {
            return if self.hide_emitters {
                Rgb::ZERO
            } else {
                environment_radiance(scene, &RayOrigin::camera(ray.o), ray.d.normalize())
            };
        };
        let si = scene.interaction_at(ray, &hit);
        let mut l = if self.hide_emitters {
            Rgb::ZERO
        } else {
            surface_emission(scene, &si, &RayOrigin::camera(ray.o))
        };
        let wo = si.to_local(si.wo);
        let bsdf = scene.bsdf_of(si.shape).at(&scene.materials, &si, wo);
        let (ne, nb) = (self.emitter_samples as f32, self.bsdf_samples as f32);
        if scene.bsdf_flags_of(si.shape).intersects(BsdfFlags::SMOOTH) && self.emitter_samples > 0 {
            for _ in 0..self.emitter_samples {
                // The ratio ne/nb turns the count-weighted power heuristic
                // into the one-sample form sample_light computes.
                l += sample_light(scene, &si, &bsdf, sampler, ne / nb.max(1e-9), 0) / ne;
            }
        }
        let ctx = BsdfContext::default();
        for _ in 0..self.bsdf_samples {
            let u1 = sampler.next_1d();
            let u2 = sampler.next_2d();
            let Some(bs) = bsdf.sample(&ctx, u1, u2) else {
                continue;
            };
            let delta = bs.sampled.intersects(BsdfFlags::DELTA);
            // MIS against the light samples, scaled by the count ratio.
            let pdf = (!delta && self.emitter_samples > 0).then_some(bs.pdf * nb / ne.max(1e-9));
            let next = si.spawn_ray(si.to_world(bs.wi));
            let origin = RayOrigin::surface(&si, pdf);
            let le = match scene.closest(&next) {
                Some(hit) => surface_emission(scene, &scene.interaction_at(&next, &hit), &origin),
                None => environment_radiance(scene, &origin, next.d),
            };
            l += bs.weight * le / nb;
        }
        l
    }
}
