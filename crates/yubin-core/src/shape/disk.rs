//! `disk`: the unit disk in the z = 0 plane of object space, facing +z.
//!
//! | parameter      | type      | default  | meaning                     |
//! |----------------|-----------|----------|-----------------------------|
//! | `to_world`     | transform | identity | placement (any affine map)  |
//! | `flip_normals` | boolean   | false    | face −z instead             |
//!
//! ```xml
//! <shape type="disk"><transform name="to_world"><scale value="0.3"/></transform></shape>
//! ```
//!
//! uv = (r, φ/2π) with φ = atan2(y, x) in [0, 2π), as in Mitsuba 3. Area
//! sampling uses the concentric map (Shirley & Chiu 1997), uniform in
//! object space and hence in world space.

use super::{
    azimuth, azimuth_sin_cos, intersect_local_plane, intersect_local_plane_packet,
    make_interaction, unit_square_bounds, world_normal, PositionSample, PrimHit, ShapeModel,
    TriangleMesh,
};
use crate::interaction::SurfaceInteraction;
use crate::math::{Bounds3, Ray, RayPacket, Transform};
use crate::params::{ParamError, Params};
use crate::sampling::square_to_uniform_disk_concentric;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;
use wide::{f32x8, CmpLe};

/// The transformed unit disk.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Disk {
    /// Object to world.
    pub(crate) to_world: Transform,
    /// Face −z.
    pub(crate) flip_normals: bool,
    /// The world unit normal, the area and its reciprocal, computed once
    /// (as the rectangle keeps its own).
    normal: Vec3,
    area: f32,
    inv_area: f32,
}

impl Disk {
    /// The unit disk placed by `to_world`, facing −z if `flip_normals`.
    pub fn new(to_world: Transform, flip_normals: bool) -> Self {
        let x = to_world.vector(Vec3::X);
        let y = to_world.vector(Vec3::Y);
        let area = PI * x.cross(y).length();
        Self {
            to_world,
            flip_normals,
            normal: world_normal(&to_world, Vec3::Z, flip_normals),
            area,
            inv_area: 1.0 / area,
        }
    }

    /// Builds the disk from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let (to_world, flip_normals) = super::placement(p)?;
        Ok(Self::new(to_world, flip_normals))
    }
}

impl Disk {
    fn normal(&self) -> Vec3 {
        self.normal
    }
}

impl Disk {
    /// [`ShapeModel::intersect`] for the eight rays of `rays` at once (see
    /// [`super::Rectangle::intersect_packet`]), bit for bit the
    /// single-ray test's hits.
    #[inline]
    pub(crate) fn intersect_packet(
        &self,
        rays: &RayPacket,
        t_max: f32x8,
    ) -> (u32, f32x8, [f32x8; 2]) {
        let (hit, t, [x, y]) = intersect_local_plane_packet(&self.to_world, rays, t_max);
        let inside = (x * x + y * y).cmp_le(f32x8::ONE);
        (hit & inside.move_mask() as u32, t, [x, y])
    }
}

impl Disk {
    /// The interaction with the shading frame built from the normal alone
    /// and uv left at zero, as [`super::Sphere::interaction_free_frame`]
    /// (no length, arctangent or Gram–Schmidt per hit).
    #[inline]
    pub(crate) fn interaction_free_frame(&self, ray: &Ray, hit: PrimHit) -> SurfaceInteraction {
        let p = self.to_world.point(hit.uv.extend(0.0));
        let frame = crate::math::Frame::from_normal(self.normal());
        super::make_interaction_in_frame(ray, hit.t, p, frame, Vec2::ZERO, frame.s, frame.t)
    }
}

impl ShapeModel for Disk {
    fn prim_count(&self, _: &[TriangleMesh]) -> u32 {
        1
    }

    fn prim_bounds(&self, _: &[TriangleMesh], _: u32) -> Bounds3 {
        unit_square_bounds(&self.to_world)
    }

    #[inline]
    fn intersect(&self, _: &[TriangleMesh], _: u32, ray: &Ray) -> Option<PrimHit> {
        let (t, local) = intersect_local_plane(&self.to_world, ray)?;
        (local.length_squared() <= 1.0).then_some(PrimHit { t, uv: local })
    }

    fn interaction(
        &self,
        _: &[TriangleMesh],
        _: u32,
        ray: &Ray,
        hit: PrimHit,
    ) -> SurfaceInteraction {
        let local = hit.uv;
        let r = local.length();
        let phi = azimuth(local.x, local.y);
        let (sin_p, cos_p) = azimuth_sin_cos(local.x, local.y);
        let p = self.to_world.point(local.extend(0.0));
        let dpdu = self.to_world.vector(Vec3::new(cos_p, sin_p, 0.0));
        let dpdv = self
            .to_world
            .vector(Vec3::new(-sin_p, cos_p, 0.0) * (2.0 * PI * r));
        make_interaction(
            ray,
            hit.t,
            p,
            self.normal(),
            Vec2::new(r, phi / (2.0 * PI)),
            dpdu,
            dpdv,
        )
    }

    fn surface_area(&self, _: &[TriangleMesh]) -> f32 {
        self.area
    }

    fn sample_position(&self, _: &[TriangleMesh], u: Vec2) -> PositionSample {
        let local = square_to_uniform_disk_concentric(u);
        PositionSample {
            p: self.to_world.point(local.extend(0.0)),
            n: self.normal(),
            pdf: self.inv_area,
            uv: Vec2::new(local.length(), azimuth(local.x, local.y) / (2.0 * PI)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::tests::{
        check_free_frame, check_shape_sampling, check_uv_derivatives, closest_hit,
    };
    use crate::shape::Shape;
    use glam::Affine3A;

    /// A disk turned about y and squashed into an ellipse.
    fn skewed() -> Shape {
        let m = Affine3A::from_rotation_y(0.5) * Affine3A::from_scale(Vec3::new(0.8, 0.5, 1.0));
        Shape::Disk(Disk::new(Transform::new(m).unwrap(), false))
    }

    #[test]
    fn uv_derivatives_follow_the_surface() {
        check_uv_derivatives(&skewed(), Vec3::new(0.3, 0.2, 2.0), Vec3::ZERO);
    }

    /// The free frame keeps the point, distance and normal of the full
    /// interaction (both sides, flipped normals too).
    #[test]
    fn free_frame_keeps_the_point_and_normal() {
        let m = Affine3A::from_rotation_y(0.5) * Affine3A::from_scale(Vec3::new(0.8, 0.5, 1.0));
        for flip in [false, true] {
            let d = Disk::new(Transform::new(m).unwrap(), flip);
            check_free_frame(&Shape::Disk(d), |r, h| d.interaction_free_frame(r, h));
        }
    }

    #[test]
    fn chi2_disk_sampling() {
        check_shape_sampling(&skewed(), &[], Vec3::new(0.1, 0.3, 1.0));
    }

    #[test]
    fn hit_and_miss() {
        let s = Shape::Disk(Disk::new(Transform::IDENTITY, true));
        let si = closest_hit(&s, &[], &Ray::new(Vec3::new(0.0, 0.5, 1.0), -Vec3::Z)).unwrap();
        assert!((si.uv.x - 0.5).abs() < 1e-6 && (si.uv.y - 0.25).abs() < 1e-6);
        assert_eq!(si.n, -Vec3::Z);
        assert!(closest_hit(&s, &[], &Ray::new(Vec3::new(0.8, 0.8, 1.0), -Vec3::Z)).is_none());
    }
}
