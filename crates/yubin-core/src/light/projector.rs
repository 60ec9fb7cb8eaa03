//! `projector`: a point light that projects an image through a pinhole, the
//! reciprocal of the `perspective` camera.
//!
//! | parameter      | type           | default  | meaning                                              |
//! |----------------|----------------|----------|------------------------------------------------------|
//! | `irradiance`   | rgb / texture  | 1        | irradiance E on the virtual image plane at distance 1 |
//! | `scale`        | float          | 1        | multiplies `irradiance`                              |
//! | `fov`          | float          | —        | field of view in degrees along `fov_axis`            |
//! | `fov_axis`     | string         | `x`      | `x`, `y`, `diagonal`, `smaller` or `larger`          |
//! | `focal_length` | string         | `50mm`   | instead of `fov`: a 35 mm-equivalent focal length    |
//! | `to_world`     | transform      | identity | places the light at the origin looking down +z       |
//!
//! ```xml
//! <emitter type="projector">
//!     <float name="fov" value="32"/>
//!     <float name="scale" value="85.8"/>
//!     <texture type="bitmap" name="irradiance">
//!         <string name="filename" value="textures/flower.bmp"/>
//!     </texture>
//!     <transform name="to_world"><lookat origin="4, 0, 5.5" target="0, 0, 1" up="-1, 0, 0"/></transform>
//! </emitter>
//! ```
//!
//! Mitsuba 3's conventions, measured on its `scalar_rgb` variant: the image
//! plane sits at z = 1 in the light's frame and spans the field of view of
//! a perspective camera whose image has the texture's aspect ratio (square
//! for a constant or procedural `irradiance`). As for the camera, image
//! left is the light's +x and image top its +y: a local direction (x, y, z)
//! reads the texture at u = ½ − ½ x / (z tx), v = ½ − ½ y / (z ty), with
//! tx, ty the tangents of the half fields of view; directions outside the
//! plane's rectangle are dark. The radiant intensity is
//! I(ω) = π · `scale` · E(u, v) / cos³θ (θ from the axis), so that the
//! irradiance on the plane z = 1 is π · `scale` · E, uniform for a constant
//! E, and a point at distance d receives I / d². It is a delta light.
//!
//! Emitted power (for light selection) is π · `scale` · mean(E) · 4 tx ty.
//! Emission sampling (paths that start at the light) picks a point
//! uniformly on the image plane: density 1 / (4 tx ty cos³θ) per solid
//! angle.

use super::{uv_interaction, EmitterContext, EmitterModel, EmitterSample};
use crate::camera::{field_of_view, image_plane_half_extent, FovAxis};
use crate::material::Materials;
use crate::math::Transform;
use crate::params::{ColorKind, ParamError, Params};
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// A projector light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProjectorLight {
    /// Light frame to world (position = its origin, axis = its +z).
    pub to_world: Transform,
    /// Irradiance on the image plane (before `scale` and π).
    pub irradiance: Tex,
    /// `scale`.
    pub scale: f32,
    /// Field of view in degrees along `fov_axis`.
    pub fov: f32,
    /// The axis `fov` is measured along.
    pub fov_axis: FovAxis,
    /// tan of the half fields of view (x, y): the plane at z = 1 spans
    /// [−tx, tx] × [−ty, ty]. Set from the texture's aspect ratio by
    /// [`ProjectorLight::fit_image_plane`].
    tan_half: Vec2,
}

impl ProjectorLight {
    /// A projector with a square image plane (call
    /// [`ProjectorLight::fit_image_plane`] for a bitmap's aspect ratio).
    pub fn new(
        to_world: Transform,
        irradiance: Tex,
        scale: f32,
        fov: f32,
        fov_axis: FovAxis,
    ) -> Self {
        Self {
            to_world,
            irradiance,
            scale,
            fov,
            fov_axis,
            tan_half: image_plane_half_extent(fov, fov_axis, 1, 1),
        }
    }

    /// Builds the light from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let to_world = p.transform_or_identity("to_world")?;
        let (fov, fov_axis) = field_of_view(p)?;
        let scale = p.float_or("scale", 1.0)?;
        let irradiance = p
            .texture("irradiance", ColorKind::Illuminant)?
            .unwrap_or(Tex::value(1.0));
        Ok(Self::new(to_world, irradiance, scale, fov, fov_axis))
    }

    /// Gives the image plane the aspect ratio of the `irradiance` bitmap,
    /// once the scene's textures exist.
    pub fn fit_image_plane(&mut self, m: &Materials) {
        let [w, h] = self.irradiance.resolution(m).unwrap_or([1, 1]);
        self.tan_half = image_plane_half_extent(self.fov, self.fov_axis, w.max(1), h.max(1));
    }

    /// Where a local direction (z > 0) meets the texture, or `None`
    /// outside the image plane.
    fn direction_to_uv(&self, local: Vec3) -> Option<Vec2> {
        if local.z <= 0.0 {
            return None;
        }
        let plane = Vec2::new(local.x, local.y) / (local.z * self.tan_half);
        let uv = Vec2::splat(0.5) - 0.5 * plane;
        (uv.cmpge(Vec2::ZERO).all() && uv.cmple(Vec2::ONE).all()).then_some(uv)
    }

    /// Radiant intensity (W/sr) leaving the light in world direction `d`.
    pub fn intensity_towards(&self, ctx: &EmitterContext, d: Vec3) -> Rgb {
        let local = self.to_world.inv.transform_vector3(d).normalize_or_zero();
        let Some(uv) = self.direction_to_uv(local) else {
            return Rgb::ZERO;
        };
        let p = self.to_world.point(Vec3::ZERO);
        let e = self
            .irradiance
            .eval(ctx.materials, &uv_interaction(p, d, uv));
        e * (PI * self.scale / (local.z * local.z * local.z))
    }

    /// Area of the image plane at distance 1.
    fn plane_area(&self) -> f32 {
        4.0 * self.tan_half.x * self.tan_half.y
    }

    /// Total emitted power, largest channel (for light selection).
    pub fn power(&self, ctx: &EmitterContext) -> f32 {
        PI * self.scale * super::power_mean(self.irradiance, ctx.materials) * self.plane_area()
    }

    /// Half-angle of the cone around the axis that holds every lit
    /// direction (the image plane's corners).
    pub fn cos_half_diagonal(&self) -> f32 {
        1.0 / (1.0 + self.tan_half.length_squared()).sqrt()
    }

    /// A world direction of emission, uniform over the image plane, and
    /// its density per solid angle.
    pub fn sample_emission_direction(&self, u: Vec2) -> (Vec3, f32) {
        let local = Vec3::new(
            (1.0 - 2.0 * u.x) * self.tan_half.x,
            (1.0 - 2.0 * u.y) * self.tan_half.y,
            1.0,
        )
        .normalize();
        let d = self.to_world.vector(local).normalize();
        (d, self.pdf_local(local))
    }

    /// Density of [`ProjectorLight::sample_emission_direction`] for world
    /// direction `d`.
    pub fn pdf_emission_direction(&self, d: Vec3) -> f32 {
        let local = self.to_world.inv.transform_vector3(d).normalize_or_zero();
        match self.direction_to_uv(local) {
            Some(_) => self.pdf_local(local),
            None => 0.0,
        }
    }

    /// Solid-angle density of a uniform point on the image plane seen in
    /// the unit local direction `local`: dA = dω / cos³θ.
    fn pdf_local(&self, local: Vec3) -> f32 {
        1.0 / (self.plane_area() * local.z * local.z * local.z)
    }
}

impl EmitterModel for ProjectorLight {
    fn sample_direction(
        &self,
        ctx: &EmitterContext,
        ref_p: Vec3,
        _u: Vec2,
    ) -> Option<EmitterSample> {
        super::point_source_sample(self.to_world.point(Vec3::ZERO), ref_p, |d| {
            self.intensity_towards(ctx, d)
        })
    }

    fn pdf_direction(&self, _: &EmitterContext, _: Vec3, _: Vec3, _: Vec3, _: Vec3) -> f32 {
        0.0
    }

    fn is_delta(&self) -> bool {
        true
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::light::tests::Variant;
    use crate::light::Emitter;
    use crate::spectrum::luminance;
    use glam::Affine3A;

    fn tilted_projector(fov_axis: FovAxis) -> ProjectorLight {
        let to_world = Transform::new(
            Affine3A::from_translation(Vec3::new(1.0, 2.0, 3.0)) * Affine3A::from_rotation_y(0.7),
        )
        .unwrap();
        let mut l = ProjectorLight::new(to_world, Tex::value(2.0), 1.5, 60.0, fov_axis);
        l.tan_half = image_plane_half_extent(60.0, fov_axis, 4, 2);
        l
    }

    /// Values read from Mitsuba 3.9.1 `scalar_rgb` (`Emitter.sample_direction`
    /// of `projector` with fov 90 and irradiance 1, at the light's origin
    /// looking down +z).
    #[test]
    fn projector_matches_mitsuba_intensity() {
        let l = ProjectorLight::new(Transform::IDENTITY, Tex::value(1.0), 1.0, 90.0, FovAxis::X);
        let ctx = EmitterContext::EMPTY;
        for (p, expected) in [
            (Vec3::new(0.0, 0.0, 1.0), PI),
            (Vec3::new(0.0, 0.0, 2.0), PI / 4.0),
            (Vec3::new(0.5, 0.0, 1.0), 3.5124075),
            (Vec3::new(0.5, 0.5, 1.0), 3.8476498),
            (Vec3::new(0.0, 0.9, 1.0), 4.226_581),
        ] {
            let s = l.sample_direction(&ctx, p, Vec2::ZERO).unwrap();
            assert!(s.is_delta && s.pdf == 1.0);
            assert!(
                (s.radiance.x / expected - 1.0).abs() < 1e-5,
                "{p}: {:?}",
                s.radiance
            );
        }
        assert!(l
            .sample_direction(&ctx, Vec3::new(1.1, 0.0, 1.0), Vec2::ZERO)
            .is_none());
        assert!(l
            .sample_direction(&ctx, Vec3::new(0.0, 0.0, -1.0), Vec2::ZERO)
            .is_none());
    }

    /// Mitsuba's image orientation: light +x is image left, +y image top.
    #[test]
    fn projector_uv_follows_the_camera_convention() {
        let mut l =
            ProjectorLight::new(Transform::IDENTITY, Tex::value(1.0), 1.0, 90.0, FovAxis::X);
        l.tan_half = image_plane_half_extent(90.0, FovAxis::X, 4, 2);
        let uv = |x: f32, y: f32| l.direction_to_uv(Vec3::new(x, y, 1.0).normalize());
        assert!((uv(0.9, 0.4).unwrap() - Vec2::new(0.05, 0.1)).length() < 1e-5);
        assert!((uv(-0.9, -0.4).unwrap() - Vec2::new(0.95, 0.9)).length() < 1e-5);
        assert!(uv(0.0, 0.55).is_none());
    }

    #[test]
    fn projector_power_is_the_integrated_intensity() {
        let l = tilted_projector(FovAxis::Y);
        let ctx = EmitterContext::EMPTY;
        // Midpoint rule over the sphere in (cos θ, φ) of the light's frame.
        let (n_theta, n_phi) = (2000, 2000);
        let mut sum = 0.0f64;
        for i in 0..n_theta {
            let cos_theta = 1.0 - (i as f32 + 0.5) / n_theta as f32;
            let sin_theta = (1.0 - cos_theta * cos_theta).sqrt();
            for j in 0..n_phi {
                let phi = 2.0 * PI * (j as f32 + 0.5) / n_phi as f32;
                let local = Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta);
                let d = l.to_world.vector(local);
                sum += luminance(l.intensity_towards(&ctx, d)) as f64;
            }
        }
        let integral = sum * 2.0 * std::f64::consts::PI / (n_theta * n_phi) as f64;
        let power = l.power(&ctx) as f64;
        assert!(
            (power / integral - 1.0).abs() < 2e-3,
            "{power} vs {integral}"
        );
    }

    /// A tilted projector under each field-of-view axis.
    pub(crate) fn test_variants() -> Vec<Variant> {
        [FovAxis::X, FovAxis::Y, FovAxis::Diagonal]
            .into_iter()
            .map(|axis| {
                let l = tilted_projector(axis);
                let mut v = Variant::new(
                    format!("projector, fov along {axis:?}"),
                    Emitter::Projector(l),
                );
                v.emission_pdf = Some(|e, d| match e {
                    Emitter::Projector(l) => l.pdf_emission_direction(d),
                    _ => unreachable!(),
                });
                v.chi2.integration_res = 16;
                v
            })
            .collect()
    }
}
