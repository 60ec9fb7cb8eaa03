//! `rectangle`: the square [-1, 1]² in the z = 0 plane of object space,
//! facing +z.
//!
//! | parameter      | type      | default  | meaning                          |
//! |----------------|-----------|----------|----------------------------------|
//! | `to_world`     | transform | identity | placement (any affine map)       |
//! | `flip_normals` | boolean   | false    | face −z instead                  |
//!
//! ```xml
//! <shape type="rectangle"><transform name="to_world"><scale value="2"/></transform></shape>
//! ```
//!
//! uv = ((x + 1)/2, (y + 1)/2). Area sampling is uniform in object space,
//! which an affine map keeps uniform.

use super::{
    intersect_local_plane, make_interaction, unit_square_bounds, world_normal, PositionSample,
    PrimHit, ShapeModel, TriangleMesh,
};
use crate::interaction::SurfaceInteraction;
use crate::math::{Bounds3, Ray, Transform};
use crate::params::{ParamError, Params};
use glam::{Vec2, Vec3};

/// A parallelogram: the transformed unit square.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rectangle {
    /// Object to world.
    pub to_world: Transform,
    /// Face −z.
    pub flip_normals: bool,
}

impl Rectangle {
    /// Builds the rectangle from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        Ok(Self {
            flip_normals: p.boolean_or("flip_normals", false)?,
            to_world: p.transform_or_identity("to_world")?,
        })
    }
}

impl Rectangle {
    fn normal(&self) -> Vec3 {
        world_normal(&self.to_world, Vec3::Z, self.flip_normals)
    }
}

impl ShapeModel for Rectangle {
    fn prim_count(&self, _: &[TriangleMesh]) -> u32 {
        1
    }

    fn prim_bounds(&self, _: &[TriangleMesh], _: u32) -> Bounds3 {
        unit_square_bounds(&self.to_world)
    }

    #[inline]
    fn intersect(&self, _: &[TriangleMesh], _: u32, ray: &Ray) -> Option<PrimHit> {
        let (t, local) = intersect_local_plane(&self.to_world, ray)?;
        (local.x.abs() <= 1.0 && local.y.abs() <= 1.0).then_some(PrimHit { t, uv: local })
    }

    fn interaction(
        &self,
        _: &[TriangleMesh],
        _: u32,
        ray: &Ray,
        hit: PrimHit,
    ) -> SurfaceInteraction {
        let local = hit.uv;
        let p = self.to_world.point(local.extend(0.0));
        let dpdu = self.to_world.vector(Vec3::new(2.0, 0.0, 0.0));
        let dpdv = self.to_world.vector(Vec3::new(0.0, 2.0, 0.0));
        let uv = (local + Vec2::ONE) * 0.5;
        make_interaction(ray, hit.t, p, self.normal(), uv, dpdu, dpdv)
    }

    fn surface_area(&self, _: &[TriangleMesh]) -> f32 {
        let dpdu = self.to_world.vector(Vec3::new(2.0, 0.0, 0.0));
        let dpdv = self.to_world.vector(Vec3::new(0.0, 2.0, 0.0));
        dpdu.cross(dpdv).length()
    }

    fn sample_position(&self, meshes: &[TriangleMesh], u: Vec2) -> PositionSample {
        let local = 2.0 * u - Vec2::ONE;
        PositionSample {
            p: self.to_world.point(local.extend(0.0)),
            n: self.normal(),
            pdf: 1.0 / self.surface_area(meshes),
            uv: u,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::tests::{check_shape_sampling, closest_hit};
    use crate::shape::Shape;
    use glam::Affine3A;

    fn skewed() -> Rectangle {
        let m = Affine3A::from_translation(Vec3::new(0.1, 0.2, 0.3))
            * Affine3A::from_rotation_x(0.7)
            * Affine3A::from_scale(Vec3::new(0.5, 1.3, 1.0));
        Rectangle {
            to_world: Transform::new(m).unwrap(),
            flip_normals: false,
        }
    }

    #[test]
    fn chi2_rectangle_sampling() {
        let s = Shape::Rectangle(skewed());
        check_shape_sampling(&s, &[], Vec3::new(0.2, -1.0, 1.2));
        check_shape_sampling(&s, &[], Vec3::new(-0.3, 0.5, -0.9));
    }

    #[test]
    fn parameterization_matches_mitsuba() {
        let r = Shape::Rectangle(Rectangle {
            to_world: Transform::IDENTITY,
            flip_normals: false,
        });
        let si = closest_hit(&r, &[], &Ray::new(Vec3::new(0.5, -0.5, 1.0), -Vec3::Z)).unwrap();
        assert!((si.uv - Vec2::new(0.75, 0.25)).length() < 1e-6);
        assert_eq!(si.n, Vec3::Z);
        assert!((r.surface_area(&[]) - 4.0).abs() < 1e-6);
        assert!(closest_hit(&r, &[], &Ray::new(Vec3::new(1.5, 0.0, 1.0), -Vec3::Z)).is_none());
    }
}
