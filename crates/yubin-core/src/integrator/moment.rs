//! `moment`: renders its nested integrator and also the second moment of
//! the samples, so mean and variance can be estimated together. This is
//! the wrapper Mitsuba 3's render-regression suite uses.
//!
//! | child      | type       | meaning                 |
//! |------------|------------|-------------------------|
//! | (nested)   | integrator | the integrator to run   |
//!
//! ```xml
//! <integrator type="moment"><integrator type="path"/></integrator>
//! ```
//!
//! Output: RGB of the nested integrator, then a layer `m2` holding the
//! (filter-weighted) mean of the squared samples; variance = m2 − mean².

use super::{Integrator, Layer};
use crate::math::Ray;
use crate::params::{Family, ParamError, Params};
use crate::render::RenderScene;
use crate::sampler::SampleStream;
use crate::Rgb;

/// Mean and second moment of a nested integrator.
#[derive(Debug)]
pub struct MomentIntegrator {
    /// The integrator whose samples are measured.
    pub nested: Box<dyn Integrator>,
}

impl MomentIntegrator {
    /// Builds the integrator and the one it wraps from scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let Some(mut nested) = p.child(Family::Integrator)? else {
            return Err(p.error("the moment integrator needs a nested integrator"));
        };
        Ok(Self {
            nested: super::nested_from_params(nested.as_mut(), "moment")?,
        })
    }
}

impl Integrator for MomentIntegrator {
    fn extra_layers(&self) -> Vec<Layer> {
        let mut layers = self.nested.extra_layers();
        layers.push(Layer::new("m2", &["R", "G", "B"]));
        layers
    }

    fn extra_channel_count(&self) -> usize {
        self.nested.extra_channel_count() + 3
    }

    fn light_selection(&self) -> Option<crate::light::LightSelection> {
        self.nested.light_selection()
    }

    fn reads_uv(&self) -> bool {
        self.nested.reads_uv()
    }

    fn mis_compensation(&self) -> bool {
        self.nested.mis_compensation()
    }

    fn li(&self, scene: &RenderScene, ray: &Ray, sampler: &mut SampleStream) -> Rgb {
        self.nested.li(scene, ray, sampler)
    }

    fn sample(&self, scene: &RenderScene, ray: &Ray, sampler: &mut SampleStream, out: &mut [f32]) {
        let n = self.nested.channel_count();
        self.nested.sample(scene, ray, sampler, &mut out[..n]);
        for c in 0..3 {
            out[n + c] = out[c] * out[c];
        }
    }
}
