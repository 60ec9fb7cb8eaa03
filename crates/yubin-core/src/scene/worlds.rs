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
//! is in. Next-event estimation at a vertex in world W looks one of k
//! ways ([`LightView`]), chosen uniformly: at W's own emitters, or
//! through one of W's portal sides whose map keeps angles (a
//! similarity: `PortalSide::lit_through`) at its far world's, each only
//! when the world looked into has an emitter the render's light sampler
//! may choose (the views are the render's:
//! `RenderScene::light_views`). Through side S it samples an
//! emitter of S's far world as seen from the vertex mapped there, S(x),
//! and maps the direction back; the sample counts only if its shadow ray
//! meets S first and, continued from the far side, reaches the emitter
//! unblocked; each view chooses among the emitters of the world it
//! looks into alone. The light density of a direction is thus 1/k times the density of the emitter sample from x (no
//! crossing) or from S(x) (one crossing through S); a BSDF-sampled ray
//! that finds an emitter is MIS-weighted with exactly that density, and
//! one that crossed two portals or more (or went a way light sampling
//! does not look) counts in full, because light sampling cannot produce
//! it. Every path is then found by one strategy with weight one or by
//! both with weights summing to one, so the estimate stays unbiased, and
//! a lamp behind a portal lights this world with the noise of a lamp in
//! it (`tests/portals.rs` measures both).

use super::{HitRecord, Scene};
use crate::math::{offset_ray_origin, shadow_ray_to, Ray, Transform};
use glam::Vec3;

/// One world: its root group and its emitters at infinity.
#[derive(Clone, Debug, Default)]
pub struct World {
    /// The group whose BVH holds its shapes (0 for world 0).
    pub group: u32,
    /// Its environment emitters (indices into [`Scene::emitters`]).
    pub environment: Vec<u32>,
    /// The portal sides in it that light sampling may look through
    /// (shape indices; see the module's docs).
    pub lit_sides: Vec<u32>,
}

/// Which way next-event estimation at a vertex looks (see the module's
/// docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightView {
    /// At the emitters of the vertex's own world.
    Own,
    /// Through the portal side (a shape index) at its far world's.
    Through(u32),
}

/// One side of a portal: where a ray that meets it goes.
#[derive(Clone, Copy, Debug)]
pub struct PortalSide {
    /// The world of the other side.
    pub to_world: u32,
    /// This side's space to the other side's (points and directions).
    pub map: Transform,
    /// Whether light sampling looks through it: its map keeps angles (a
    /// rotation, reflection and uniform scale), so a density over
    /// directions on the far side is the same density on this one.
    pub lit_through: bool,
}

impl PortalSide {
    /// A side leading to world `to_world` by `map`.
    pub fn new(to_world: u32, map: Transform) -> Self {
        Self {
            to_world,
            map,
            lit_through: keeps_angles(&map),
        }
    }
}

/// Whether `t`'s linear part is a similarity (its columns orthogonal and
/// of one length, to 1e-4 relative).
fn keeps_angles(t: &Transform) -> bool {
    let m = glam::Mat3::from(t.m.matrix3);
    let g = m.transpose() * m;
    let s = (g.x_axis.x + g.y_axis.y + g.z_axis.z) / 3.0;
    let tolerance = 1e-4 * s;
    s > 0.0
        && (g - glam::Mat3::from_diagonal(glam::Vec3::splat(s)))
            .to_cols_array()
            .iter()
            .all(|e| e.abs() <= tolerance)
}

/// At most this many portal crossings per ray (two portals facing each
/// other would otherwise pass a ray back and forth for ever).
pub const MAX_CROSSINGS: u32 = 16;

/// What [`Scene::trace`] found.
#[derive(Clone, Copy, Debug)]
pub struct Traced {
    /// The hit, on the last segment.
    pub hit: Option<HitRecord>,
    /// How many portals the ray crossed on its way.
    pub crossings: u32,
    /// The portal side it crossed first (when `crossings > 0`).
    pub first_side: u32,
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
        let mut traced = Traced {
            hit: None,
            crossings: 0,
            first_side: 0,
        };
        while traced.crossings <= MAX_CROSSINGS {
            traced.hit = self.closest_in_world(ray, *world);
            let Some(h) = traced.hit else {
                return traced;
            };
            let Some(side) = self.portal_of(h.shape) else {
                return traced;
            };
            *ray = self.continued(ray, &h, side);
            *world = side.to_world;
            if traced.crossings == 0 {
                traced.first_side = h.shape;
            }
            traced.crossings += 1;
        }
        traced.hit = None;
        traced
    }

    /// `ray` continued from the far side of the portal side `side` it
    /// meets at `hit`, with a unit direction.
    fn continued(&self, ray: &Ray, hit: &HitRecord, side: &PortalSide) -> Ray {
        let si = self.interaction_at(ray, hit);
        let d = side.map.vector(ray.d).normalize();
        let n = side.map.normal(si.n).normalize();
        let p = side.map.point(si.p);
        Ray::new(offset_ray_origin(p, n, d), d)
    }

    /// The portal sides of world `world` that light sampling may look
    /// through.
    #[inline]
    pub fn lit_sides(&self, world: u32) -> &[u32] {
        self.worlds
            .get(world as usize)
            .map_or(&[][..], |w| &w.lit_sides)
    }

    /// Whether a shadow ray `ray` (unit direction) in world `world` meets
    /// the portal side `side` first and, continued from its far side,
    /// reaches `target` there unblocked (`None`: a light at infinity,
    /// along the continued ray).
    pub fn visible_through(&self, ray: &Ray, world: u32, side: u32, target: Option<Vec3>) -> bool {
        let Some(portal) = self.portal_of(side) else {
            return false;
        };
        let Some(hit) = self.closest_in_world(ray, world) else {
            return false;
        };
        if hit.shape != side {
            return false;
        }
        let beyond = self.continued(ray, &hit, portal);
        let beyond = match target {
            Some(target) => shadow_ray_to(beyond.o, Vec3::ZERO, target),
            None => beyond,
        };
        !self.occluded_in(&beyond, portal.to_world)
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
