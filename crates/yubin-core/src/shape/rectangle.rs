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
//! which an affine map keeps uniform. Seen from a point about as near as
//! it is large (squared distance to its centre at most twice its area), a
//! rectangle whose `to_world` keeps its corners square is sampled
//! uniformly in the solid angle it subtends (Ureña et al. 2013, "An
//! Area-Preserving Parametrization for Spherical Rectangles"), which
//! removes the noise of the 1/r² and cos θ that area sampling leaves near
//! a large light; farther points, nearly edge-on ones and sheared
//! rectangles are sampled by area.

use super::{
    area_to_solid_angle, intersect_local_plane, intersect_local_plane_packet,
    make_interaction_in_frame, unit_square_bounds, world_normal, PositionSample, PrimHit,
    ShapeDirectionSample, ShapeModel, TriangleMesh, NEAR_AREA_PER_DISTANCE2,
};
use crate::interaction::SurfaceInteraction;
use crate::math::{Bounds3, Frame, Ray, RayPacket, Transform};
use crate::params::{ParamError, Params};
use crate::sampling::{spherical_rectangle_pdf, RectangleFrame, SphericalRectangle};
use glam::{Vec2, Vec3};
use wide::{f32x8, CmpLe};

/// A parallelogram: the transformed unit square.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rectangle {
    /// Object to world.
    pub(crate) to_world: Transform,
    /// Face −z.
    pub(crate) flip_normals: bool,
    /// What hits and samples read of the placement, computed once: every
    /// light sample had transformed the centre and both edges, and
    /// normalized the normal and taken the area's square root again.
    geometry: Geometry,
}

/// A rectangle's world-space centre, edges (the uv derivatives), unit
/// normal and area, and the area's reciprocal.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Geometry {
    center: Vec3,
    ex: Vec3,
    ey: Vec3,
    normal: Vec3,
    /// The shading frame of every point: the normal and `ex`.
    frame: Frame,
    area: f32,
    inv_area: f32,
    /// What spherical sampling reads, for a square-cornered rectangle
    /// (a sheared one is sampled by area).
    spherical: Option<RectangleFrame>,
}

/// Whether `p` is near enough to a rectangle of area `area` around
/// `center` to sample it by the solid angle it subtends (about as near as
/// it is large; see [`NEAR_AREA_PER_DISTANCE2`]), on the side its normal
/// `normal` faces. Behind it, where an area light sends nothing, either
/// sampling finds nothing and the cheaper one serves (in the Cornell box,
/// the ceiling around the light).
#[inline]
fn is_near(center: Vec3, normal: Vec3, area: f32, p: Vec3) -> bool {
    let d = p - center;
    (d.dot(normal) > 0.0) & (area >= NEAR_AREA_PER_DISTANCE2 * d.length_squared())
}

/// The points from which a rectangle is sampled by the solid angle it
/// subtends ([`ShapeModel::sample_direction`]), and its frame for that;
/// by area from the others, and from every point when it is not
/// square-cornered.
#[derive(Clone, Copy, Debug)]
pub(crate) struct NearZone {
    center: Vec3,
    normal: Vec3,
    area: f32,
    frame: Option<RectangleFrame>,
}

impl NearZone {
    /// The frame for spherical sampling from `p`, where that applies.
    #[inline]
    pub fn frame_at(&self, p: Vec3) -> Option<&RectangleFrame> {
        (self.frame.as_ref()).filter(|_| is_near(self.center, self.normal, self.area, p))
    }
}

impl Rectangle {
    /// The unit square placed by `to_world`, facing −z if `flip_normals`.
    pub fn new(to_world: Transform, flip_normals: bool) -> Self {
        let ex = to_world.vector(Vec3::new(2.0, 0.0, 0.0));
        let ey = to_world.vector(Vec3::new(0.0, 2.0, 0.0));
        let area2 = ex.cross(ey).length_squared();
        let area = area2.sqrt();
        let normal = world_normal(&to_world, Vec3::Z, flip_normals);
        let center = to_world.point(Vec3::ZERO);
        let square = ex.dot(ey).powi(2) <= 1e-10 * area2;
        let geometry = Geometry {
            center,
            ex,
            ey,
            normal,
            frame: Frame::from_normal_and_tangent(normal, ex),
            area,
            inv_area: 1.0 / area,
            spherical: square.then(|| RectangleFrame::new(center - 0.5 * (ex + ey), ex, ey)),
        };
        Self {
            to_world,
            flip_normals,
            geometry,
        }
    }

    /// Builds the rectangle from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let (to_world, flip_normals) = super::placement(p)?;
        Ok(Self::new(to_world, flip_normals))
    }
}

impl Rectangle {
    fn normal(&self) -> Vec3 {
        self.geometry.normal
    }

    /// The rectangle's frame for spherical sampling, when `p` is near
    /// enough for that to pay and the rectangle is square-cornered.
    #[inline]
    fn near_frame(&self, p: Vec3) -> Option<&RectangleFrame> {
        let g = &self.geometry;
        let near = is_near(g.center, g.normal, g.area, p);
        g.spherical.as_ref().filter(|_| near)
    }

    /// Where the rectangle is sampled by solid angle.
    #[inline]
    pub(crate) fn near_zone(&self) -> NearZone {
        let g = &self.geometry;
        NearZone {
            center: g.center,
            normal: g.normal,
            area: g.area,
            frame: g.spherical,
        }
    }

    /// The rectangle's placement, normal and density per area, which its
    /// area sampling reads (for eight light samples at once: the path
    /// tracer's wide shading).
    pub(crate) fn area_sampling(&self) -> (&glam::Affine3A, Vec3, f32) {
        (&self.to_world.m, self.normal(), self.geometry.inv_area)
    }

    /// The rectangle as seen from `p`, where spherical sampling applies.
    #[cfg(test)]
    fn seen_from(&self, p: Vec3) -> Option<SphericalRectangle> {
        SphericalRectangle::new(p, self.near_frame(p)?)
    }
}

impl Rectangle {
    /// A point sampled uniformly in the solid angle the rectangle (its
    /// frame `r`) subtends from `ref_p`, where that applies.
    #[inline(never)]
    fn sample_spherical(
        &self,
        ref_p: Vec3,
        r: &RectangleFrame,
        u: Vec2,
    ) -> Option<ShapeDirectionSample> {
        let sr = SphericalRectangle::new(ref_p, r)?;
        let (p, uv) = sr.sample(u);
        Some(ShapeDirectionSample {
            p,
            n: self.normal(),
            pdf: 1.0 / sr.solid_angle(),
            uv,
        })
    }

    /// [`ShapeModel::intersect`] for the eight rays of `rays` at once, each
    /// within its lane of `t_max`: the lanes that hit, their distances and
    /// object-space x and y, which are the single-ray test's bit for bit
    /// (the same operations in the same order, lane by lane).
    #[inline]
    pub(crate) fn intersect_packet(
        &self,
        rays: &RayPacket,
        t_max: f32x8,
    ) -> (u32, f32x8, [f32x8; 2]) {
        let (hit, t, [x, y]) = intersect_local_plane_packet(&self.to_world, rays, t_max);
        let one = f32x8::ONE;
        let inside = x.abs().cmp_le(one) & y.abs().cmp_le(one);
        (hit & inside.move_mask() as u32, t, [x, y])
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
        let Geometry { ex, ey, frame, .. } = self.geometry;
        let uv = (local + Vec2::ONE) * 0.5;
        make_interaction_in_frame(ray, hit.t, p, frame, uv, ex, ey)
    }

    fn surface_area(&self, _: &[TriangleMesh]) -> f32 {
        self.geometry.area
    }

    fn sample_position(&self, _: &[TriangleMesh], u: Vec2) -> PositionSample {
        let local = 2.0 * u - Vec2::ONE;
        PositionSample {
            p: self.to_world.point(local.extend(0.0)),
            n: self.normal(),
            pdf: self.geometry.inv_area,
            uv: u,
        }
    }

    // Inline, its spherical sampling out of line: the area sample's
    // distance then reaches the light's code, which needs it too.
    #[inline]
    fn sample_direction(
        &self,
        meshes: &[TriangleMesh],
        ref_p: Vec3,
        u: Vec2,
    ) -> ShapeDirectionSample {
        self.near_frame(ref_p)
            .and_then(|r| self.sample_spherical(ref_p, r, u))
            .unwrap_or_else(|| {
                ShapeDirectionSample::from_area(self.sample_position(meshes, u), ref_p)
            })
    }

    fn pdf_direction(&self, meshes: &[TriangleMesh], ref_p: Vec3, p: Vec3, n: Vec3) -> f32 {
        self.near_frame(ref_p)
            .and_then(|r| spherical_rectangle_pdf(ref_p, r))
            .unwrap_or_else(|| area_to_solid_angle(1.0 / self.surface_area(meshes), ref_p, p, n))
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
        Rectangle::new(Transform::new(m).unwrap(), false)
    }

    #[test]
    fn chi2_rectangle_sampling() {
        let s = Shape::Rectangle(skewed());
        check_shape_sampling(&s, &[], Vec3::new(0.2, -1.0, 1.2));
        check_shape_sampling(&s, &[], Vec3::new(-0.3, 0.5, -0.9));
        // Close by, and nearly edge-on.
        check_shape_sampling(&s, &[], Vec3::new(0.3, 0.4, 0.7));
        check_shape_sampling(&s, &[], Vec3::new(0.4, -0.6, 0.5));
    }

    #[test]
    fn spherical_sampling_only_where_it_applies() {
        let square = skewed();
        assert!(square.seen_from(Vec3::new(0.2, -1.0, 1.2)).is_some());
        assert!(square.seen_from(Vec3::new(40.0, 120.0, -100.0)).is_none());
        let sheared = Rectangle::new(
            Transform::new(Affine3A::from_cols_array(&[
                1.0, 0.0, 0.0, 0.4, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0,
            ]))
            .unwrap(),
            false,
        );
        assert!(sheared.seen_from(Vec3::new(0.0, 0.0, 1.0)).is_none());
        let s = Shape::Rectangle(sheared);
        check_shape_sampling(&s, &[], Vec3::new(0.2, 0.1, 0.8));
    }

    #[test]
    fn parameterization_matches_mitsuba() {
        let r = Shape::Rectangle(Rectangle::new(Transform::IDENTITY, false));
        let si = closest_hit(&r, &[], &Ray::new(Vec3::new(0.5, -0.5, 1.0), -Vec3::Z)).unwrap();
        assert!((si.uv - Vec2::new(0.75, 0.25)).length() < 1e-6);
        assert_eq!(si.n, Vec3::Z);
        assert!((r.surface_area(&[]) - 4.0).abs() < 1e-6);
        assert!(closest_hit(&r, &[], &Ray::new(Vec3::new(1.5, 0.0, 1.0), -Vec3::Z)).is_none());
    }
}
