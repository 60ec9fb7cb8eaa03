//! `spot`: a point light that shines into a cone, with a linear falloff
//! towards its edge and an optional projected texture.
//!
//! | parameter      | type           | default            | meaning                                              |
//! |----------------|----------------|--------------------|------------------------------------------------------|
//! | `intensity`    | rgb / spectrum | 1                  | radiant intensity I on the axis (W/sr)               |
//! | `cutoff_angle` | float          | 20                 | half-angle of the cone in degrees, beyond which it is dark (0 < angle ≤ 90) |
//! | `beam_width`   | float          | ¾ · `cutoff_angle` | half-angle in degrees of the fully lit core (≤ `cutoff_angle`) |
//! | `texture`      | texture        | none               | image projected along the cone (multiplies I)        |
//! | `to_world`     | transform      | identity           | places the light at the origin looking down +z       |
//!
//! ```xml
//! <emitter type="spot">
//!     <rgb name="intensity" value="5"/>
//!     <float name="cutoff_angle" value="20"/>
//!     <transform name="to_world"><lookat origin="0, 3, 0" target="0, 0, 0" up="0, 0, 1"/></transform>
//! </emitter>
//! ```
//!
//! Mitsuba 3's conventions: in its own frame the light sits at the origin
//! and points along +z; at the angle θ from the axis the intensity is I
//! inside the beam (θ ≤ `beam_width`), falls linearly in θ to 0 at
//! `cutoff_angle`, and is 0 beyond. A `texture` is read at
//! u = ½ + ½ x / (z tan θc), v = ½ + ½ y / (z tan θc) for the local direction
//! (x, y, z): the image fills the square that circumscribes the cone's cross
//! section. The light is a delta light: no ray hits it, and its sample
//! carries pdf 1 and I · falloff / d².
//!
//! Emitted power (for light selection) is I · 2π (1 − (sin θc − sin θb) /
//! (θc − θb)), the falloff integrated over the sphere, times the texture's
//! mean. Emission sampling (paths that start at the light) picks directions
//! uniformly in the cutoff cone.

use super::{uv_interaction, EmitterContext, EmitterModel, EmitterSample};
use crate::math::Transform;
use crate::params::{ColorKind, ParamError, Params};
use crate::sampling::{square_to_uniform_cone, uniform_cone_pdf};
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};

/// A spot light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpotLight {
    /// Light frame to world (position = its origin, axis = its +z).
    pub to_world: Transform,
    /// Radiant intensity on the axis.
    pub intensity: Rgb,
    /// Projected texture, if any.
    pub texture: Option<Tex>,
    /// Cutoff half-angle in radians.
    pub cutoff: f32,
    /// Beam half-angle in radians (≤ `cutoff`).
    pub beam: f32,
    cos_cutoff: f32,
    cos_beam: f32,
    uv_factor: f32,
}

impl SpotLight {
    /// A spot light; angles in radians, `0 ≤ beam ≤ cutoff ≤ π/2`.
    pub fn new(to_world: Transform, intensity: Rgb, cutoff: f32, beam: f32) -> Self {
        Self {
            to_world,
            intensity,
            texture: None,
            cutoff,
            beam,
            cos_cutoff: cutoff.cos(),
            cos_beam: beam.cos(),
            uv_factor: cutoff.tan(),
        }
    }

    /// Builds the light from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let to_world = p.transform_or_identity("to_world")?;
        let intensity = p.color_or("intensity", ColorKind::Illuminant, Rgb::ONE)?;
        let cutoff_deg = p.float_or("cutoff_angle", 20.0)?;
        if !(cutoff_deg > 0.0 && cutoff_deg <= 90.0) {
            return Err(p.param_error(
                "cutoff_angle",
                &format!("must be in (0, 90] degrees, not {cutoff_deg}"),
            ));
        }
        let beam_deg = p.float_or("beam_width", cutoff_deg * 0.75)?;
        if !(0.0..=cutoff_deg).contains(&beam_deg) {
            return Err(p.param_error(
                "beam_width",
                &format!("must be in [0, cutoff_angle = {cutoff_deg}] degrees, not {beam_deg}"),
            ));
        }
        let texture = p.texture("texture", ColorKind::Illuminant)?;
        let mut light = Self::new(
            to_world,
            intensity,
            cutoff_deg.to_radians(),
            beam_deg.to_radians(),
        );
        light.texture = texture;
        Ok(light)
    }

    /// The falloff factor in [0, 1] for a unit direction in the light's
    /// frame.
    fn falloff(&self, local: Vec3) -> f32 {
        let cos_theta = local.z;
        if cos_theta <= self.cos_cutoff {
            0.0
        } else if cos_theta >= self.cos_beam {
            1.0
        } else {
            (self.cutoff - cos_theta.clamp(-1.0, 1.0).acos()) / (self.cutoff - self.beam)
        }
    }

    /// Where the projected texture is read for a local direction.
    fn direction_to_uv(&self, local: Vec3) -> Vec2 {
        let s = 0.5 / (local.z * self.uv_factor);
        Vec2::new(0.5 + local.x * s, 0.5 + local.y * s)
    }

    /// Intensity (W/sr) leaving the light in world direction `d` (unit).
    pub fn intensity_towards(&self, ctx: &EmitterContext, d: Vec3) -> Rgb {
        let local = self.to_world.inv.transform_vector3(d).normalize_or_zero();
        let falloff = self.falloff(local);
        if falloff == 0.0 {
            return Rgb::ZERO;
        }
        let i = self.intensity * falloff;
        match self.texture {
            None => i,
            Some(t) => {
                let p = self.to_world.point(Vec3::ZERO);
                i * t.eval(
                    ctx.materials,
                    &uv_interaction(p, d, self.direction_to_uv(local)),
                )
            }
        }
    }

    /// Total emitted power, largest channel (for light selection).
    pub fn power(&self, ctx: &EmitterContext) -> f32 {
        let (c, b) = (self.cutoff, self.beam);
        let cone = if c - b > 1e-6 {
            1.0 - (c.sin() - b.sin()) / (c - b)
        } else {
            1.0 - c.cos()
        };
        let texture_mean = self.texture.map_or(1.0, |t| t.mean(ctx.materials));
        self.intensity.max_element() * 2.0 * std::f32::consts::PI * cone * texture_mean
    }

    /// A world direction of emission, uniform in the cutoff cone, and its
    /// density per solid angle.
    pub fn sample_emission_direction(&self, u: Vec2) -> (Vec3, f32) {
        let local = square_to_uniform_cone(u, self.cos_cutoff);
        let d = self.to_world.vector(local).normalize();
        (d, uniform_cone_pdf(self.cos_cutoff))
    }

    /// Density of [`SpotLight::sample_emission_direction`] for world
    /// direction `d`.
    pub fn pdf_emission_direction(&self, d: Vec3) -> f32 {
        let local = self.to_world.inv.transform_vector3(d).normalize_or_zero();
        if local.z > self.cos_cutoff {
            uniform_cone_pdf(self.cos_cutoff)
        } else {
            0.0
        }
    }
}

impl EmitterModel for SpotLight {
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
    use glam::Affine3A;

    fn tilted_spot() -> SpotLight {
        let to_world = Transform::new(
            Affine3A::from_translation(Vec3::new(1.0, 2.0, 3.0)) * Affine3A::from_rotation_x(1.1),
        )
        .unwrap();
        SpotLight::new(
            to_world,
            Rgb::splat(4.0),
            30f32.to_radians(),
            20f32.to_radians(),
        )
    }

    #[test]
    fn spot_falloff_is_linear_in_angle() {
        let s = SpotLight::new(Transform::IDENTITY, Rgb::ONE, 0.4, 0.2);
        let dir = |theta: f32| Vec3::new(theta.sin(), 0.0, theta.cos());
        assert_eq!(s.falloff(dir(0.1)), 1.0);
        assert!((s.falloff(dir(0.3)) - 0.5).abs() < 1e-4);
        assert_eq!(s.falloff(dir(0.41)), 0.0);
        assert_eq!(s.falloff(-Vec3::Z), 0.0);
    }

    #[test]
    fn spot_sample_is_inverse_square_and_delta() {
        let s = tilted_spot();
        let ctx = EmitterContext::EMPTY;
        let axis = s.to_world.vector(Vec3::Z).normalize();
        let p = s.to_world.point(Vec3::ZERO) + 2.0 * axis;
        let ls = s.sample_direction(&ctx, p, Vec2::ZERO).unwrap();
        assert!(ls.is_delta && ls.pdf == 1.0);
        assert!((ls.wi + axis).length() < 1e-5);
        assert!((ls.radiance - Rgb::splat(1.0)).abs().max_element() < 1e-5);
        // Behind the light: dark.
        assert!(s
            .sample_direction(&ctx, s.to_world.point(Vec3::ZERO) - axis, Vec2::ZERO)
            .is_none());
    }

    #[test]
    fn spot_power_is_the_integrated_falloff() {
        let s = tilted_spot();
        // Midpoint rule over θ (the falloff is rotationally symmetric).
        let n = 200_000;
        let mut sum = 0.0f64;
        for i in 0..n {
            let theta = (i as f64 + 0.5) / n as f64 * std::f64::consts::PI;
            let local = Vec3::new(theta.sin() as f32, 0.0, theta.cos() as f32);
            sum += s.falloff(local) as f64 * theta.sin();
        }
        let integral = sum * std::f64::consts::PI / n as f64 * 2.0 * std::f64::consts::PI;
        let expected = integral * 4.0;
        let power = s.power(&EmitterContext::EMPTY) as f64;
        assert!(
            (power / expected - 1.0).abs() < 1e-4,
            "{power} vs {expected}"
        );
    }

    /// A tilted spot, and one without falloff (its beam is its whole cone).
    pub(crate) fn test_variants() -> Vec<Variant> {
        [
            ("spot", tilted_spot()),
            (
                "spot without falloff",
                SpotLight::new(Transform::IDENTITY, Rgb::new(1.0, 3.0, 2.0), 0.5, 0.5),
            ),
        ]
        .into_iter()
        .map(|(name, s)| {
            let mut v = Variant::new(name, Emitter::Spot(s));
            v.emission_pdf = Some(|e, d| match e {
                Emitter::Spot(s) => s.pdf_emission_direction(d),
                _ => unreachable!(),
            });
            v
        })
        .collect()
    }
}
