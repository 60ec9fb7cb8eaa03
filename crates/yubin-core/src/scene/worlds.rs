//! Worlds and portals: groups of shapes and emitters with their own
//! environment, joined by pairs of surfaces that a ray crossing one leaves
//! from the other.
//!
//! World 0 holds everything outside a `<world>` (the camera's world; its
//! root is group 0). Each other world is a root group of its own. A
//! portal is a pair of shapes of the same geometry, one in each of two
//! worlds; a ray that meets one side continues from the matching point of
//! the other, in that side's world, its direction mapped by the pair's
//! relative transform (`PortalSide::map`). Radiance is unchanged along
//! the ray, so the crossing is exact: what a camera sees through a portal
//! is what it would see through an open window onto the other world
//! placed behind it.
//!
//! Light transport (the `path` integrator): a path carries the world it
//! is in. Next-event estimation connects a vertex only to the emitters of
//! its own world (a light sample of another world contributes nothing);
//! an emitter or environment a BSDF-sampled ray reaches through a portal
//! is counted in full (no MIS weight), because light sampling cannot
//! produce that path. Every path is then found by exactly one weighted
//! strategy or by both with weights summing to one, so the estimate stays
//! unbiased; light from another world reaches this one by BSDF sampling
//! alone.

use super::{HitRecord, Scene};
use crate::math::{offset_ray_origin, Ray, Transform};

/// One world: its root group and its emitters at infinity.
#[derive(Clone, Debug, Default)]
pub struct World {
    /// The group whose BVH holds its shapes (0 for world 0).
    pub group: u32,
    /// Its environment emitters (indices into [`Scene::emitters`]).
    pub environment: Vec<u32>,
}

/// One side of a portal: where a ray that meets it goes.
#[derive(Clone, Copy, Debug)]
pub struct PortalSide {
    /// The world of the other side.
    pub to_world: u32,
    /// This side's space to the other side's (points and directions).
    pub map: Transform,
}

/// At most this many portal crossings per ray (two portals facing each
/// other would otherwise pass a ray back and forth for ever).
pub const MAX_CROSSINGS: u32 = 16;

/// What [`Scene::trace`] found.
#[derive(Clone, Copy, Debug)]
pub struct Traced {
    /// The hit, on the last segment.
    pub hit: Option<HitRecord>,
    /// Whether the ray crossed a portal on its way.
    pub crossed: bool,
}

impl Scene {
    /// Whether the scene has portals.
    #[inline]
    pub fn has_portals(&self) -> bool {
        !self.portals.is_empty()
    }

    /// The world of emitter `e`.
    #[inline]
    pub fn emitter_world(&self, e: u32) -> u32 {
        self.emitter_world.get(e as usize).copied().unwrap_or(0)
    }

    /// The environment emitters of world `world`.
    #[inline]
    pub fn environment_of(&self, world: u32) -> &[u32] {
        match world {
            0 => &self.environment_emitters,
            w => self
                .worlds
                .get(w as usize)
                .map_or(&[][..], |w| &w.environment),
        }
    }

    /// The portal side `shape` is, if any.
    #[inline]
    pub fn portal_of(&self, shape: u32) -> Option<&PortalSide> {
        self.portals.get(shape as usize)?.as_ref()
    }

    /// The closest hit of `ray` in world `world`, following portals:
    /// `ray` and `world` become the last segment and its world.
    pub fn trace(&self, ray: &mut Ray, world: &mut u32) -> Traced {
        let mut crossed = false;
        for _ in 0..=MAX_CROSSINGS {
            let hit = self.closest_in_world(ray, *world);
            let Some(h) = hit else {
                return Traced { hit, crossed };
            };
            let Some(side) = self.portal_of(h.shape) else {
                return Traced { hit, crossed };
            };
            let si = self.interaction_at(ray, &h);
            let d = side.map.vector(ray.d).normalize();
            let n = side.map.normal(si.n).normalize();
            let p = side.map.point(si.p);
            *ray = Ray::new(offset_ray_origin(p, n, d), d);
            *world = side.to_world;
            crossed = true;
        }
        Traced { hit: None, crossed }
    }

    /// The closest hit of `ray` among world `world`'s shapes.
    #[inline]
    pub fn closest_in_world(&self, ray: &Ray, world: u32) -> Option<HitRecord> {
        let group = self.worlds.get(world as usize).map_or(0, |w| w.group);
        self.closest_in_group(&self.groups[group as usize], ray, None)
    }

    /// Whether anything of world `world` blocks `ray` (a portal side
    /// does: a straight segment does not pass through it).
    #[inline]
    pub fn occluded_in(&self, ray: &Ray, world: u32) -> bool {
        let group = self.worlds.get(world as usize).map_or(0, |w| w.group);
        self.occluded_in_group(&self.groups[group as usize], ray)
    }
}
