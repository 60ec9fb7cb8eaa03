//! Emitter queries of a [`Scene`]: the emitter of a shape and the world
//! copy of an emitting shape seen through an instance. Light selection,
//! the light a hit is as light selection counts it, and the view of the
//! scene that emitters sample with are a render's
//! (`render::RenderScene`).

use super::Scene;
use crate::light::Emitter;

impl Scene {
    /// The emitter of a shape, if it is an area light.
    #[inline]
    pub fn emitter_of(&self, shape: u32) -> Option<&Emitter> {
        self.shape_info[shape as usize]
            .emitter
            .map(|e| &self.emitters[e as usize])
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
