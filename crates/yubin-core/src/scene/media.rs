//! What shadow rays and media see of the surfaces they cross: surfaces
//! that let light through (`null`, `mask`, `thindielectric` slabs), the
//! first surface a shadow ray meets ([`Scene::shadow_hit`]), the fraction
//! of light that gets along a ray past pass-through surfaces
//! ([`Scene::transmittance`]), and the medium on either side of a surface
//! ([`Scene::medium_after`]).

use super::traversal::to_local_ray;
use super::{Scene, ShadowHit};
use crate::bsdf::Material;
use crate::interaction::SurfaceInteraction;
use crate::math::Ray;
use crate::shape::ShapeModel;

impl Scene {
    /// Whether the scene has surfaces that let light through (`null`,
    /// `mask`): then shadow rays may have to cross them.
    #[inline]
    pub fn has_pass_through(&self) -> bool {
        self.has_pass_through
    }

    /// Whether light may pass straight through shape `shape`
    /// ([`Material::lets_light_through`]).
    #[inline]
    pub fn lets_light_through(&self, shape: u32) -> bool {
        self.bsdf_of(shape).lets_light_through(&self.materials)
    }

    /// The first surface along a shadow ray, with no more computed than the
    /// ray needs: nothing for a surface that lets no light straight
    /// through, the point and normal for a plain `null` one, the whole
    /// interaction otherwise.
    pub fn shadow_hit(&self, ray: &Ray) -> Option<ShadowHit> {
        let h = self.closest(ray)?;
        let bsdf = self.bsdf_of(h.shape);
        if !bsdf.lets_light_through(&self.materials) {
            return Some(ShadowHit::Opaque);
        }
        if !matches!(bsdf, Material::Null(_)) {
            return Some(ShadowHit::Surface(self.interaction(ray, &h)));
        }
        let shape = &self.shapes[h.shape as usize];
        let (p, n) = match h.instance {
            None => shape.point_and_normal(&self.meshes, h.prim, ray, *h.hit),
            Some(inst) => {
                let t = &self.instances[inst as usize].to_world;
                let local_ray = to_local_ray(ray, t);
                let (p, n) = shape.point_and_normal(&self.meshes, h.prim, &local_ray, *h.hit);
                (t.point(p), t.normal(n).normalize())
            }
        };
        Some(ShadowHit::Null {
            t: h.hit.t,
            p,
            n,
            shape: h.shape,
        })
    }

    /// The fraction of light that gets along `ray` (a generalized shadow
    /// ray): 0 when an opaque surface blocks it, else the product of what
    /// the pass-through surfaces it crosses (`null`, `mask`) let through,
    /// 0 as well when it would cross more than `max_crossings` of them.
    /// Scenes without pass-through surfaces pay one any-hit query.
    pub fn transmittance(&self, ray: &Ray, max_crossings: u32) -> f32 {
        if !self.has_pass_through() || max_crossings == 0 {
            return if self.occluded(ray) { 0.0 } else { 1.0 };
        }
        let mut tr = 1.0;
        let mut r = *ray;
        for _ in 0..=max_crossings.min(MAX_CROSSINGS) {
            let si = match self.intersect_if(&r, |shape| self.lets_light_through(shape)) {
                None => return tr,
                Some(Err(_)) => return 0.0,
                Some(Ok(si)) => si,
            };
            tr *= self.bsdf_of(si.shape).pass_through(&self.materials, &si);
            if tr <= 0.0 {
                return 0.0;
            }
            // Continue past the surface; `d` is unnormalized in general, so
            // the remaining interval is kept in units of `d`.
            let next = si.spawn_ray(r.d);
            r = Ray {
                t_max: r.t_max - si.t,
                ..next
            };
            if r.t_max <= r.t_min {
                return tr;
            }
        }
        0.0
    }

    /// The medium a ray leaving the hit `si` in direction `d` travels in,
    /// coming from `current`: the shape's interior or exterior when the
    /// shape bounds media (by the side of its normal `d` is on), else
    /// unchanged.
    #[inline]
    pub fn medium_after(
        &self,
        si: &SurfaceInteraction,
        d: glam::Vec3,
        current: Option<u32>,
    ) -> Option<u32> {
        self.medium_across(si.shape, si.n, d, current)
    }

    /// [`Scene::medium_after`] for a hit on `shape` whose geometric normal
    /// is `n`.
    #[inline]
    pub fn medium_across(
        &self,
        shape: u32,
        n: glam::Vec3,
        d: glam::Vec3,
        current: Option<u32>,
    ) -> Option<u32> {
        let info = &self.shape_info[shape as usize];
        if !info.is_medium_transition() {
            return current;
        }
        if d.dot(n) > 0.0 {
            info.exterior
        } else {
            info.interior
        }
    }

    /// Whether shadow rays may have to look past surfaces: some surface
    /// lets light straight through (`null`, `mask`, `thindielectric`
    /// slabs) or media fill shapes.
    #[inline]
    pub fn shadow_rays_cross_surfaces(&self) -> bool {
        self.has_null_transmission || self.has_media()
    }

    /// Whether any medium is in the scene.
    #[inline]
    pub fn has_media(&self) -> bool {
        !self.media.is_empty()
    }
}

/// The most pass-through surfaces one shadow ray looks past.
const MAX_CROSSINGS: u32 = 256;
