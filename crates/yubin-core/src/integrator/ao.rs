//! `ao`: ambient occlusion (Mitsuba 0.6's `ao`) — the cosine-weighted
//! fraction of the hemisphere about the shading normal from which the
//! first hit of each camera ray is not occluded.
//!
//! | parameter         | type    | default | meaning                                                  |
//! |-------------------|---------|---------|----------------------------------------------------------|
//! | `shading_samples` | integer | 1       | occlusion rays per camera sample (`shadingSamples` too)  |
//! | `max_distance`    | float   | -1      | occlusion rays longer than this count as unoccluded; −1: unlimited (`rayLength` too) |
//!
//! ```xml
//! <integrator type="ao">
//!     <integer name="shading_samples" value="4"/>
//!     <float name="max_distance" value="2"/>
//! </integrator>
//! ```
//!
//! The value is grey: `(V, V, V)` with V the fraction of the
//! `shading_samples` cosine-distributed directions whose rays (spawned from
//! the hit) meet nothing within `max_distance`; its expectation is
//! (1/π) ∫ V(ω) cos θ dω. The hemisphere is the side of the shading normal
//! that faces the camera, so both sides of a surface get occlusion. Camera
//! rays that miss give 0, as in Mitsuba 0.6. Every surface occludes,
//! including `null` and `mask` ones and emitters.
//!
//! Differences from Mitsuba 0.6: its `rayLength` defaults to half the
//! radius of the scene's bounding sphere; yubin's default is unlimited
//! (give `max_distance` for the 0.6 look). A `max_distance` of 0 or any
//! negative value means unlimited.
//!
//! Reference: Mitsuba 0.6 documentation, "Ambient occlusion integrator
//! (ao)"; Zhukov, Iones and Kronin, "An ambient light illumination model"
//! (1998).

use super::Integrator;
use crate::math::Ray;
use crate::params::{ParamError, Params};
use crate::render::RenderScene;
use crate::sampler::SampleStream;
use crate::sampling::square_to_cosine_hemisphere;
use crate::Rgb;

/// Ambient-occlusion settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AoIntegrator {
    /// Occlusion rays per camera sample.
    pub shading_samples: u32,
    /// Occlusion rays count as unoccluded beyond this distance; `None`:
    /// unlimited.
    pub max_distance: Option<f32>,
}

impl Default for AoIntegrator {
    fn default() -> Self {
        Self {
            shading_samples: 1,
            max_distance: None,
        }
    }
}

impl AoIntegrator {
    /// Builds the integrator from its scene parameters (Mitsuba 0.6's
    /// `shadingSamples` and `rayLength` are accepted as aliases).
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let samples_name = if p.has("shadingSamples") {
            "shadingSamples"
        } else {
            "shading_samples"
        };
        let n = p.integer_or(samples_name, 1)?;
        let shading_samples = u32::try_from(n)
            .ok()
            .filter(|&n| n >= 1)
            .ok_or_else(|| p.param_error(samples_name, &format!("must be at least 1, not {n}")))?;
        let dist_name = if p.has("rayLength") {
            "rayLength"
        } else {
            "max_distance"
        };
        let d = p.float_or(dist_name, -1.0)?;
        if d.is_nan() {
            return Err(p.param_error(dist_name, "must be a number"));
        }
        Ok(Self {
            shading_samples,
            max_distance: (d > 0.0 && d.is_finite()).then_some(d),
        })
    }
}

impl Integrator for AoIntegrator {
    /// It samples no lights: whatever its neighbours in an `aov` do.
    fn mis_compensation(&self) -> bool {
        true
    }

    fn li(&self, scene: &RenderScene, ray: &Ray, sampler: &mut SampleStream) -> Rgb {
        let Some(si) = scene.intersect(ray) else {
            return Rgb::ZERO;
        };
        // The hemisphere on the camera's side of the shading normal.
        let flip = si.to_local(si.wo).z < 0.0;
        let mut unoccluded = 0u32;
        for _ in 0..self.shading_samples {
            let mut local = square_to_cosine_hemisphere(sampler.next_2d());
            if flip {
                local.z = -local.z;
            }
            let mut shadow = si.spawn_ray(si.to_world(local).normalize());
            if let Some(d) = self.max_distance {
                shadow.t_max = shadow.t_max.min(d);
            }
            if !scene.occluded(&shadow) {
                unoccluded += 1;
            }
        }
        Rgb::splat(unoccluded as f32 / self.shading_samples as f32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::params::MapParams;

    #[test]
    fn reads_parameters_and_aliases() {
        let a = AoIntegrator::from_params(&mut MapParams::new()).unwrap();
        assert_eq!(a, AoIntegrator::default());
        let mut p = MapParams::new()
            .with("shading_samples", crate::testing::params::Value::Integer(8))
            .float("max_distance", 2.5);
        let a = AoIntegrator::from_params(&mut p).unwrap();
        assert_eq!((a.shading_samples, a.max_distance), (8, Some(2.5)));
        let mut p = MapParams::new()
            .with("shadingSamples", crate::testing::params::Value::Integer(3))
            .float("rayLength", 1.0);
        let a = AoIntegrator::from_params(&mut p).unwrap();
        assert_eq!((a.shading_samples, a.max_distance), (3, Some(1.0)));
        assert!(p.unread().is_empty());
        let mut p = MapParams::new().float("max_distance", -1.0);
        assert_eq!(
            AoIntegrator::from_params(&mut p).unwrap().max_distance,
            None
        );
        let mut p =
            MapParams::new().with("shading_samples", crate::testing::params::Value::Integer(0));
        let err = AoIntegrator::from_params(&mut p).unwrap_err();
        assert!(err.0.contains("shading_samples"), "{}", err.0);
    }
}
