//! `depth`: the distance to the first surface each camera ray meets
//! (Mitsuba 3's `depth`).
//!
//! It has no parameters.
//!
//! ```xml
//! <integrator type="depth"/>
//! ```
//!
//! The value is grey: (t, t, t), t the distance along the ray from where
//! it starts, as Mitsuba 3 takes its `si.t`. Its cameras start rays on the
//! near-clip plane, so t is the distance from the eye less
//! `near_clip / cos θ` (θ the ray's angle to the view axis), as the `aov`
//! integrator's `depth` is. A ray that meets nothing gives 0. Every
//! surface stops the ray, `null` and `mask` ones included.
//!
//! Reference: Mitsuba 3 documentation, "Depth integrator (depth)".

use super::Integrator;
use crate::math::Ray;
use crate::params::{ParamError, Params};
use crate::render::RenderScene;
use crate::sampler::SampleStream;
use crate::Rgb;

/// The depth integrator (no settings).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DepthIntegrator;

impl DepthIntegrator {
    /// Builds the integrator (it reads no parameters).
    pub fn from_params(_p: &mut dyn Params) -> Result<Self, ParamError> {
        Ok(Self)
    }
}

impl Integrator for DepthIntegrator {
    /// It samples no lights: whatever its neighbours in an `aov` do.
    fn mis_compensation(&self) -> bool {
        true
    }

    fn li(&self, scene: &RenderScene, ray: &Ray, _sampler: &mut SampleStream) -> Rgb {
        match scene.intersect(ray) {
            Some(si) => Rgb::splat((si.t - ray.t_min) * ray.d.length()),
            None => Rgb::ZERO,
        }
    }
}
