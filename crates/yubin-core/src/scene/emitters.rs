//! Emitter queries of a [`Scene`]: the emitter of a shape, the light a
//! hit is, light selection for next-event estimation, the world copy of
//! an emitting shape seen through an instance, and the view of the scene
//! that emitters sample and evaluate with ([`EmitterContext`]).

use super::Scene;
use crate::integrator::wide::RectangleLight;
use crate::interaction::SurfaceInteraction;
use crate::light::{Emitter, EmitterContext, LightChoice};

impl Scene {
    /// What emitters need to see of the scene.
    #[inline]
    pub fn emitter_context(&self) -> EmitterContext<'_> {
        EmitterContext {
            shapes: &self.shapes,
            meshes: &self.meshes,
            images: &self.materials.images,
            materials: &self.materials,
            distributions: &self.light_distributions,
        }
    }

    /// The emitter of a shape, if it is an area light.
    #[inline]
    pub fn emitter_of(&self, shape: u32) -> Option<&Emitter> {
        self.shape_info[shape as usize]
            .emitter
            .map(|e| &self.emitters[e as usize])
    }

    /// Chooses a light for next-event estimation at `p` (surface normal
    /// `n`, or zero); returns it and its probability.
    #[inline]
    pub fn pick_light(&self, u: f32, p: glam::Vec3, n: glam::Vec3) -> Option<(LightChoice, f32)> {
        self.light_sampler.sample(u, p, n)
    }

    /// Probability that [`Scene::pick_light`] at (`p`, `n`) chooses `light`.
    #[inline]
    pub fn light_pmf(&self, light: LightChoice, p: glam::Vec3, n: glam::Vec3) -> f32 {
        self.light_sampler.pmf(light, p, n)
    }

    /// The light a hit on an emitting surface is, as the light sampler
    /// counts lights (the triangle, when it chooses them one by one).
    #[inline]
    pub fn light_of_hit(&self, si: &SurfaceInteraction) -> Option<LightChoice> {
        let emitter = self.shape_info[si.shape as usize].emitter?;
        let prim = if self.light_sampler.splits(emitter) {
            si.prim
        } else {
            LightChoice::WHOLE
        };
        Some(LightChoice { emitter, prim })
    }

    /// Emitter `emitter`, when it is an area light of constant radiance on
    /// a rectangle.
    #[inline]
    pub(crate) fn rectangle_light(&self, emitter: u32) -> Option<&RectangleLight> {
        self.rectangle_lights[emitter as usize].as_ref()
    }

    /// The shape a hit on `shape` through instance `inst` is: its world
    /// copy when it emits (which carries that instance's light), else
    /// itself.
    #[inline]
    pub(super) fn placed_shape(&self, inst: u32, shape: u32) -> u32 {
        let (start, count) = self.instances[inst as usize].placed_emitters;
        self.placed_emitters[start as usize..(start + count) as usize]
            .iter()
            .find(|(local, _)| *local == shape)
            .map_or(shape, |&(_, world)| world)
    }
}
