//! `sphere`: an analytic sphere.
//!
//! | parameter      | type      | default   | meaning                                   |
//! |----------------|-----------|-----------|-------------------------------------------|
//! | `center`       | point     | (0, 0, 0) | centre (object space)                     |
//! | `radius`       | float     | 1         | radius                                    |
//! | `to_world`     | transform | identity  | placement; uniform scale multiplies radius|
//! | `flip_normals` | boolean   | false     | normals point inward                      |
//!
//! ```xml
//! <shape type="sphere"><float name="radius" value="0.5"/></shape>
//! ```
//!
//! uv: u = φ/2π with φ = atan2(y, x) in [0, 2π), v = θ/π with θ the angle
//! from +z (object space). Seen from outside, emitters sample the cone of
//! directions the sphere subtends (pbrt-v4 §6.2.4); from inside, by area.
//! Intersection uses the numerically robust form of Haines et al. 2019
//! ("Precision Improvements for Ray/Sphere Intersection", Ray Tracing Gems).

use super::{
    area_to_solid_angle, azimuth, azimuth_sin_cos, make_interaction, PositionSample, PrimHit,
    ShapeDirectionSample, ShapeModel, TriangleMesh,
};
use crate::interaction::SurfaceInteraction;
use crate::math::{coordinate_system, Bounds3, Ray, RayPacket};
use crate::params::{ParamError, Params};
use crate::sampling::{square_to_uniform_cone, square_to_uniform_sphere, uniform_cone_pdf};
use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::PI;
use wide::{f32x8, CmpGt, CmpLt, CmpNe};

/// A sphere in world space, with the rotation that orients its uv.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius.
    pub radius: f32,
    /// Object-to-world rotation (orthonormal), for the parameterization.
    pub rotation: Mat3,
    /// Normals point inward.
    pub flip_normals: bool,
}

impl Sphere {
    /// Builds the sphere from its scene parameters: `to_world` moves the
    /// centre and scales the radius (its rotation orients the uv).
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let flip_normals = p.boolean_or("flip_normals", false)?;
        let to_world = p.transform_or_identity("to_world")?;
        let center = p.point("center")?.unwrap_or(Vec3::ZERO);
        let radius = p.float_or("radius", 1.0)?;
        let m3 = Mat3::from(to_world.m.matrix3);
        let scales = [m3.x_axis, m3.y_axis, m3.z_axis].map(Vec3::length);
        let scale = scales[0];
        if uniform_scale(m3).is_none() {
            p.warn(
                None,
                &format!(
                    "sphere: to_world has a non-uniform scale {scales:?}; using {scale} for the radius"
                ),
            );
        }
        let rotation = rotation_of(m3);
        if radius.is_nan() || radius <= 0.0 {
            return Err(p.param_error("radius", &format!("must be positive, not {radius}")));
        }
        Ok(Self {
            center: to_world.point(center),
            radius: radius * scale,
            rotation,
            flip_normals,
        })
    }
}

/// The scale of a linear map that is a rotation times a uniform scale,
/// or `None` when it stretches some axis more than another.
fn uniform_scale(m: Mat3) -> Option<f32> {
    let scales = [m.x_axis, m.y_axis, m.z_axis].map(Vec3::length);
    let s = scales[0];
    scales
        .iter()
        .all(|x| (x - s).abs() <= 1e-4 * s)
        .then_some(s)
}

/// The rotation part of a rotation times a uniform scale.
fn rotation_of(m: Mat3) -> Mat3 {
    Mat3::from_cols(
        m.x_axis.normalize(),
        m.y_axis.normalize(),
        m.z_axis.normalize(),
    )
}

impl Sphere {
    /// The sphere moved by `t` (an instance's transform); `None` when `t`
    /// scales unevenly, which would make it an ellipsoid.
    pub fn placed(&self, t: &crate::math::Transform) -> Option<Sphere> {
        let m3 = Mat3::from(t.m.matrix3);
        let scale = uniform_scale(m3)?;
        Some(Sphere {
            center: t.point(self.center),
            radius: self.radius * scale,
            rotation: rotation_of(m3) * self.rotation,
            flip_normals: self.flip_normals,
        })
    }

    /// A sphere with the identity orientation.
    pub fn new(center: Vec3, radius: f32, flip_normals: bool) -> Self {
        Self {
            center,
            radius,
            rotation: Mat3::IDENTITY,
            flip_normals,
        }
    }

    fn outward_to_normal(&self, n: Vec3) -> Vec3 {
        if self.flip_normals {
            -n
        } else {
            n
        }
    }
}

impl Sphere {
    /// uv of the surface point in unit direction `outward` from the
    /// centre.
    fn uv_of(&self, outward: Vec3) -> Vec2 {
        self.angles_of(outward).uv
    }

    /// uv of the surface point in unit direction `outward` from the
    /// centre, with the sines and cosines of its azimuth φ and polar angle
    /// θ in the sphere's frame, read off the direction itself (no
    /// trigonometric calls: sin θ is its distance from the axis).
    #[inline(always)]
    fn angles_of(&self, outward: Vec3) -> SphereAngles {
        self.angles_with(outward, true)
    }

    /// [`Sphere::angles_of`], with uv left at zero unless `with_uv`.
    #[inline(always)]
    fn angles_with(&self, outward: Vec3, with_uv: bool) -> SphereAngles {
        let local = self.rotation.transpose() * outward;
        let rho = (local.x * local.x + local.y * local.y).sqrt();
        let (sin_phi, cos_phi) = azimuth_sin_cos(local.x, local.y);
        let uv = if with_uv {
            let phi = azimuth(local.x, local.y);
            let theta = crate::math::atan2(rho, local.z);
            Vec2::new(phi / (2.0 * PI), theta / PI)
        } else {
            Vec2::ZERO
        };
        SphereAngles {
            uv,
            sin_theta: rho,
            cos_theta: local.z,
            sin_phi,
            cos_phi,
        }
    }
}

impl Sphere {
    /// [`ShapeModel::interaction`] with uv left at zero, for scenes where
    /// nothing reads it (two arctangents fewer per hit).
    #[inline]
    pub(crate) fn interaction_without_uv(&self, ray: &Ray, hit: PrimHit) -> SurfaceInteraction {
        self.interaction_with(ray, hit, false)
    }

    /// [`Sphere::interaction_without_uv`] with the shading frame built
    /// from the normal alone ([`Frame::from_normal`]) and ∂p/∂u, ∂p/∂v set
    /// to its unit tangents, for a sphere whose BSDF turns freely about
    /// the normal ([`Material::turns_freely`]) in a scene where nothing reads
    /// uv or the derivatives: the turned frame gives the same
    /// distribution of samples (other samples, so other images, alike in
    /// the mean) for two square roots and two divisions fewer per hit.
    ///
    /// [`Frame::from_normal`]: crate::math::Frame::from_normal
    /// [`Material::turns_freely`]: crate::bsdf::Material::turns_freely
    #[inline]
    pub(crate) fn interaction_free_frame(&self, ray: &Ray, hit: PrimHit) -> SurfaceInteraction {
        let outward = (ray.at(hit.t) - self.center).normalize();
        // Re-project onto the surface to undo round-off in t.
        let p = self.center + outward * self.radius;
        let frame = crate::math::Frame::from_normal(self.outward_to_normal(outward));
        super::make_interaction_in_frame(ray, hit.t, p, frame, Vec2::ZERO, frame.s, frame.t)
    }

    #[inline(always)]
    fn interaction_with(&self, ray: &Ray, hit: PrimHit, with_uv: bool) -> SurfaceInteraction {
        let outward = (ray.at(hit.t) - self.center).normalize();
        // Re-project onto the surface to undo round-off in t.
        let p = self.center + outward * self.radius;
        let SphereAngles {
            uv,
            sin_theta: sin_t,
            cos_theta: cos_t,
            sin_phi: sin_p,
            cos_phi: cos_p,
        } = self.angles_with(outward, with_uv);
        let r = self.radius;
        let dpdu = self.rotation * Vec3::new(-sin_p * sin_t, cos_p * sin_t, 0.0) * (2.0 * PI * r);
        let dpdv = self.rotation * Vec3::new(cos_p * cos_t, sin_p * cos_t, -sin_t) * (PI * r);
        make_interaction(
            ray,
            hit.t,
            p,
            self.outward_to_normal(outward),
            uv,
            dpdu,
            dpdv,
        )
    }
}

/// A point of a sphere in its own angles (see [`Sphere::angles_of`]).
struct SphereAngles {
    uv: Vec2,
    sin_theta: f32,
    cos_theta: f32,
    sin_phi: f32,
    cos_phi: f32,
}

impl Sphere {
    /// [`ShapeModel::intersect`] for the eight rays of `rays` at once, each
    /// within its lane of `t_max`: the lanes that hit and the distances,
    /// which are the single-ray test's bit for bit (the same operations
    /// in the same order, lane by lane).
    #[inline]
    pub(crate) fn intersect_packet(&self, rays: &RayPacket, t_max: f32x8) -> (u32, f32x8) {
        let [dx, dy, dz] = rays.d;
        let f = std::array::from_fn::<_, 3, _>(|a| rays.o[a] - f32x8::splat(self.center[a]));
        let [fx, fy, fz] = f;
        let a = dx * dx + dy * dy + dz * dz;
        let b = -(fx * dx + fy * dy + fz * dz);
        let s = b / a;
        let (lx, ly, lz) = (fx + s * dx, fy + s * dy, fz + s * dz);
        let r2 = f32x8::splat(self.radius * self.radius);
        let disc = a * (r2 - (lx * lx + ly * ly + lz * lz));
        let q = b + disc.sqrt().copysign(b);
        let t0 = q / a;
        let far = (fx * fx + fy * fy + fz * fz - r2) / q;
        let t1 = q.cmp_ne(f32x8::ZERO).blend(far, t0);
        let swap = t0.cmp_gt(t1);
        let (t0, t1) = (swap.blend(t1, t0), swap.blend(t0, t1));
        let t = t0.cmp_gt(rays.t_min).blend(t0, t1);
        let hit = !disc.cmp_lt(f32x8::ZERO) & t.cmp_gt(rays.t_min) & t.cmp_lt(t_max);
        (hit.move_mask() as u32, t)
    }
}

impl ShapeModel for Sphere {
    fn prim_count(&self, _: &[TriangleMesh]) -> u32 {
        1
    }

    fn prim_bounds(&self, _: &[TriangleMesh], _: u32) -> Bounds3 {
        Bounds3 {
            min: self.center - Vec3::splat(self.radius),
            max: self.center + Vec3::splat(self.radius),
        }
    }

    #[inline]
    fn intersect(&self, _: &[TriangleMesh], _: u32, ray: &Ray) -> Option<PrimHit> {
        let f = ray.o - self.center;
        let a = ray.d.length_squared();
        let b = -f.dot(ray.d);
        // Discriminant via |f - (f·d/a) d|², robust for distant rays.
        let l = f + (b / a) * ray.d;
        let disc = a * (self.radius * self.radius - l.length_squared());
        if disc < 0.0 {
            return None;
        }
        let root = disc.sqrt();
        let q = b + root.copysign(b);
        let (mut t0, mut t1) = (
            q / a,
            if q != 0.0 {
                (f.length_squared() - self.radius * self.radius) / q
            } else {
                q / a
            },
        );
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        let t = if t0 > ray.t_min { t0 } else { t1 };
        (t > ray.t_min && t < ray.t_max).then_some(PrimHit { t, uv: Vec2::ZERO })
    }

    fn interaction(
        &self,
        _: &[TriangleMesh],
        _: u32,
        ray: &Ray,
        hit: PrimHit,
    ) -> SurfaceInteraction {
        self.interaction_with(ray, hit, true)
    }

    fn surface_area(&self, _: &[TriangleMesh]) -> f32 {
        4.0 * PI * self.radius * self.radius
    }

    fn sample_position(&self, _: &[TriangleMesh], u: Vec2) -> PositionSample {
        let d = square_to_uniform_sphere(u);
        PositionSample {
            p: self.center + d * self.radius,
            n: self.outward_to_normal(d),
            pdf: 1.0 / (4.0 * PI * self.radius * self.radius),
            uv: self.uv_of(d),
        }
    }

    fn sample_direction(
        &self,
        meshes: &[TriangleMesh],
        ref_p: Vec3,
        u: Vec2,
    ) -> ShapeDirectionSample {
        let to_center = self.center - ref_p;
        let dist2 = to_center.length_squared();
        let r2 = self.radius * self.radius;
        if dist2 <= r2 * 1.0001 {
            return ShapeDirectionSample::from_area(self.sample_position(meshes, u), ref_p);
        }
        let dist = dist2.sqrt();
        let sin_max2 = r2 / dist2;
        let cos_max = (1.0 - sin_max2).max(0.0).sqrt();
        let axis = to_center / dist;
        let (s, t) = coordinate_system(axis);
        let local = square_to_uniform_cone(u, cos_max);
        let d = s * local.x + t * local.y + axis * local.z;
        // The nearer intersection of the sampled direction with the sphere;
        // clamp the discriminant so grazing samples land on the silhouette.
        let proj = d.dot(to_center);
        let perp2 = (dist2 - proj * proj).min(r2);
        let t_hit = proj - (r2 - perp2).max(0.0).sqrt();
        let p_raw = ref_p + d * t_hit;
        let outward = (p_raw - self.center).normalize();
        ShapeDirectionSample {
            p: self.center + outward * self.radius,
            n: self.outward_to_normal(outward),
            pdf: uniform_cone_pdf(cos_max),
            uv: self.uv_of(outward),
        }
    }

    fn pdf_direction(&self, _: &[TriangleMesh], ref_p: Vec3, p: Vec3, n: Vec3) -> f32 {
        let dist2 = (self.center - ref_p).length_squared();
        let r2 = self.radius * self.radius;
        if dist2 <= r2 * 1.0001 {
            return area_to_solid_angle(1.0 / (4.0 * PI * r2), ref_p, p, n);
        }
        let cos_max = (1.0 - r2 / dist2).max(0.0).sqrt();
        uniform_cone_pdf(cos_max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::tests::{
        check_free_frame, check_shape_sampling, check_uv_derivatives, closest_hit,
    };
    use crate::shape::Shape;

    #[test]
    fn uv_derivatives_follow_the_surface() {
        let mut s = Sphere::new(Vec3::new(0.2, 0.1, 0.0), 0.7, false);
        s.rotation = Mat3::from_rotation_y(0.6) * Mat3::from_rotation_x(-0.4);
        let s = Shape::Sphere(s);
        check_uv_derivatives(&s, Vec3::new(0.5, 1.0, 3.0), Vec3::new(0.2, 0.1, 0.0));
        check_uv_derivatives(&s, Vec3::new(-2.0, -1.0, 0.5), Vec3::new(0.2, 0.1, 0.0));
    }

    /// The free frame keeps the point, distance and normal of the full
    /// interaction (both sides, flipped normals too).
    #[test]
    fn free_frame_keeps_the_point_and_normal() {
        for flip in [false, true] {
            let mut s = Sphere::new(Vec3::new(0.2, 0.1, -0.3), 0.7, flip);
            s.rotation = Mat3::from_rotation_y(0.6) * Mat3::from_rotation_x(-0.4);
            check_free_frame(&Shape::Sphere(s), |r, h| s.interaction_free_frame(r, h));
        }
    }

    #[test]
    fn chi2_sphere_cone_sampling() {
        let s = Shape::Sphere(Sphere::new(Vec3::new(0.2, 0.1, 0.0), 0.7, false));
        check_shape_sampling(&s, &[], Vec3::new(0.0, 0.0, 2.0));
        check_shape_sampling(&s, &[], Vec3::new(1.0, -0.5, 0.2));
    }

    #[test]
    fn chi2_sphere_sampling_from_inside() {
        let s = Shape::Sphere(Sphere::new(Vec3::ZERO, 1.0, true));
        check_shape_sampling(&s, &[], Vec3::new(0.3, 0.2, -0.1));
    }

    #[test]
    fn hits_from_outside_and_inside() {
        let s = Shape::Sphere(Sphere::new(Vec3::ZERO, 2.0, false));
        let si = closest_hit(&s, &[], &Ray::new(Vec3::new(0.0, 0.0, 10.0), -Vec3::Z)).unwrap();
        assert!((si.t - 8.0).abs() < 1e-5 && (si.n - Vec3::Z).length() < 1e-5);
        let si = closest_hit(&s, &[], &Ray::new(Vec3::ZERO, Vec3::X)).unwrap();
        assert!((si.t - 2.0).abs() < 1e-5 && (si.n - Vec3::X).length() < 1e-5);
        assert!(closest_hit(&s, &[], &Ray::new(Vec3::new(0.0, 3.0, 10.0), -Vec3::Z)).is_none());
    }
}
