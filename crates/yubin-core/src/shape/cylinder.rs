//! `cylinder`: an open cylinder (no caps).
//!
//! | parameter      | type      | default     | meaning                          |
//! |----------------|-----------|-------------|----------------------------------|
//! | `p0`           | point     | (0, 0, 0)   | centre of the bottom             |
//! | `p1`           | point     | (0, 0, 1)   | centre of the top                |
//! | `radius`       | float     | 1           | radius                           |
//! | `to_world`     | transform | identity    | placement, applied after p0/p1   |
//! | `flip_normals` | boolean   | false       | normals point inward             |
//!
//! ```xml
//! <shape type="cylinder"><float name="radius" value="0.3"/></shape>
//! ```
//!
//! In object space the cylinder is x² + y² = 1, 0 ≤ z ≤ 1; uv = (φ/2π, z).
//! The builder folds p0, p1 and radius into `to_world`.

use super::{
    azimuth, azimuth_sin_cos, make_interaction, world_normal, PositionSample, PrimHit, ShapeModel,
    TriangleMesh,
};
use crate::interaction::SurfaceInteraction;
use crate::math::{Bounds3, Ray, Transform};
use crate::params::{ParamError, Params};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// The transformed unit cylinder.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cylinder {
    /// Object (unit cylinder) to world.
    pub to_world: Transform,
    /// Normals point inward.
    pub flip_normals: bool,
}

impl Cylinder {
    /// Builds the cylinder from its scene parameters: the axis from `p0`
    /// to `p1` and the `radius`, then `to_world`.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let flip_normals = p.boolean_or("flip_normals", false)?;
        let to_world = p.transform_or_identity("to_world")?;
        let p0 = p.point("p0")?.unwrap_or(Vec3::ZERO);
        let p1 = p.point("p1")?.unwrap_or(Vec3::Z);
        let radius = p.float_or("radius", 1.0)?;
        if radius.is_nan() || radius <= 0.0 || p0 == p1 {
            return Err(p.error("a cylinder needs a positive radius and p0 != p1"));
        }
        let local = Transform::new(Self::object_to_world(p0, p1, radius))
            .ok_or_else(|| p.error("degenerate cylinder"))?;
        Ok(Self {
            to_world: to_world.after(&local),
            flip_normals,
        })
    }

    /// The object-to-world map of Mitsuba's (p0, p1, radius) cylinder.
    pub fn object_to_world(p0: Vec3, p1: Vec3, radius: f32) -> glam::Affine3A {
        let axis = p1 - p0;
        let len = axis.length();
        let frame = crate::math::Frame::from_normal(axis / len);
        glam::Affine3A::from_cols(
            (frame.s * radius).into(),
            (frame.t * radius).into(),
            (frame.n * len).into(),
            p0.into(),
        )
    }
}

impl ShapeModel for Cylinder {
    fn prim_count(&self, _: &[TriangleMesh]) -> u32 {
        1
    }

    fn prim_bounds(&self, _: &[TriangleMesh], _: u32) -> Bounds3 {
        let corners = Bounds3 {
            min: Vec3::new(-1.0, -1.0, 0.0),
            max: Vec3::ONE,
        }
        .corners();
        Bounds3::from_points(corners.map(|c| self.to_world.point(c)))
    }

    #[inline]
    fn intersect(&self, _: &[TriangleMesh], _: u32, ray: &Ray) -> Option<PrimHit> {
        let o = self.to_world.inv.transform_point3(ray.o);
        let d = self.to_world.inv.transform_vector3(ray.d);
        let a = d.x * d.x + d.y * d.y;
        if a == 0.0 {
            return None;
        }
        let b = o.x * d.x + o.y * d.y;
        let c = o.x * o.x + o.y * o.y - 1.0;
        let disc = b * b - a * c;
        if disc < 0.0 {
            return None;
        }
        let root = disc.sqrt();
        let q = -(b + root.copysign(b));
        let (mut t0, mut t1) = (q / a, if q != 0.0 { c / q } else { q / a });
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        [t0, t1].into_iter().find_map(|t| {
            let z = o.z + t * d.z;
            (t > ray.t_min && t < ray.t_max && (0.0..=1.0).contains(&z))
                .then_some(PrimHit { t, uv: Vec2::ZERO })
        })
    }

    fn interaction(
        &self,
        _: &[TriangleMesh],
        _: u32,
        ray: &Ray,
        hit: PrimHit,
    ) -> SurfaceInteraction {
        let local = self.to_world.inv.transform_point3(ray.at(hit.t));
        let phi = azimuth(local.x, local.y);
        let (sin_p, cos_p) = azimuth_sin_cos(local.x, local.y);
        let on_surface = Vec3::new(cos_p, sin_p, local.z.clamp(0.0, 1.0));
        let p = self.to_world.point(on_surface);
        let n = world_normal(
            &self.to_world,
            Vec3::new(cos_p, sin_p, 0.0),
            self.flip_normals,
        );
        let dpdu = self
            .to_world
            .vector(Vec3::new(-sin_p, cos_p, 0.0) * (2.0 * PI));
        let dpdv = self.to_world.vector(Vec3::Z);
        make_interaction(
            ray,
            hit.t,
            p,
            n,
            Vec2::new(phi / (2.0 * PI), on_surface.z),
            dpdu,
            dpdv,
        )
    }

    fn surface_area(&self, _: &[TriangleMesh]) -> f32 {
        let r = self.to_world.vector(Vec3::X).length();
        let h = self.to_world.vector(Vec3::Z).length();
        2.0 * PI * r * h
    }

    fn sample_position(&self, meshes: &[TriangleMesh], u: Vec2) -> PositionSample {
        let phi = 2.0 * PI * u.y;
        let (sin_p, cos_p) = phi.sin_cos();
        let n = world_normal(
            &self.to_world,
            Vec3::new(cos_p, sin_p, 0.0),
            self.flip_normals,
        );
        PositionSample {
            p: self.to_world.point(Vec3::new(cos_p, sin_p, u.x)),
            n,
            pdf: 1.0 / self.surface_area(meshes),
            uv: Vec2::new(azimuth(cos_p, sin_p) / (2.0 * PI), u.x),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::tests::{check_shape_sampling, check_uv_derivatives, closest_hit};
    use crate::shape::Shape;

    #[test]
    fn uv_derivatives_follow_the_surface() {
        check_uv_derivatives(&cyl(), Vec3::new(2.0, 0.5, 0.2), Vec3::new(0.1, 0.05, 0.1));
    }

    fn cyl() -> Shape {
        let m = Cylinder::object_to_world(Vec3::new(0.0, 0.0, -0.5), Vec3::new(0.2, 0.1, 0.7), 0.4);
        Shape::Cylinder(Cylinder {
            to_world: Transform::new(m).unwrap(),
            flip_normals: false,
        })
    }

    #[test]
    fn chi2_cylinder_sampling_from_inside() {
        // From a point on the axis every direction meets the wall once.
        check_shape_sampling(&cyl(), &[], Vec3::new(0.1, 0.05, 0.1));
    }

    #[test]
    fn hits_outside_wall_with_outward_normal() {
        let s = Shape::Cylinder(Cylinder {
            to_world: Transform::IDENTITY,
            flip_normals: false,
        });
        let si = closest_hit(&s, &[], &Ray::new(Vec3::new(3.0, 0.0, 0.5), -Vec3::X)).unwrap();
        assert!((si.t - 2.0).abs() < 1e-5 && (si.n - Vec3::X).length() < 1e-5);
        assert!((si.uv - Vec2::new(0.0, 0.5)).length() < 1e-5);
        assert!(closest_hit(&s, &[], &Ray::new(Vec3::new(3.0, 0.0, 1.5), -Vec3::X)).is_none());
        assert!((s.surface_area(&[]) - 2.0 * PI).abs() < 1e-4);
    }
}
