//! `normal_deviation`: a blend of two colours by how far the surface faces
//! a given world direction (dust or snow on upward faces, moss on a
//! north side).
//!
//! | parameter   | type          | default   | meaning                                              |
//! |-------------|---------------|-----------|------------------------------------------------------|
//! | `direction` | vector        | (0, 1, 0) | the world direction (normalised; y is up in most Mitsuba scenes) |
//! | `color0`    | texture / rgb | 0         | the colour where the normal faces away (90° or more) |
//! | `color1`    | texture / rgb | 1         | the colour where the normal is `direction`           |
//! | `exponent`  | float         | 1         | sharpens (> 1) or widens (< 1) the transition (> 0)  |
//!
//! ```xml
//! <texture type="normal_deviation" name="reflectance">
//!     <vector name="direction" x="0" y="1" z="0"/>
//!     <rgb name="color0" value="0.3, 0.05, 0.02"/>
//!     <rgb name="color1" value="0.8, 0.78, 0.7"/>
//!     <float name="exponent" value="4"/>
//! </texture>
//! ```
//!
//! With n the shading normal (interpolated, before any bump or normal map
//! of the BSDF; the shape's outward side, whichever side the ray hits) and
//! d the unit `direction`, the weight is t = max(0, n · d)^`exponent` and
//! the colour (1 − t)·`color0` + t·`color1`; read as a float, the same blend
//! of the colours' values. A point's normal changes over the surface, but
//! the hit record carries no ∂n/∂u, so the derivative with respect to
//! (u, v) (for bump mapping) leaves the weight's change out: it is
//! (1 − t)·∇c₀ + t·∇c₁, zero for constant colours. The mean (for sampling
//! weights) assumes normals spread uniformly over the sphere, where the
//! weight averages 1 / (2(`exponent` + 1)). Not a Mitsuba 3 plugin.

use super::{Tex, TextureModel};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::Rgb;
use glam::{Vec2, Vec3};

/// A blend by the angle between the normal and a direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalDeviation {
    /// The unit world direction.
    pub direction: Vec3,
    /// Facing away.
    pub color0: Tex,
    /// Facing `direction`.
    pub color1: Tex,
    /// Shapes the weight: max(0, cos)^exponent.
    pub exponent: f32,
}

impl NormalDeviation {
    /// Builds the texture from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let d = p.vector("direction")?.unwrap_or(Vec3::Y);
        let direction = d.try_normalize().ok_or_else(|| {
            p.param_error("direction", &format!("must be a non-zero vector, not {d}"))
        })?;
        Ok(Self {
            direction,
            color0: p.texture_or("color0", ColorKind::Reflectance, Rgb::ZERO)?,
            color1: p.texture_or("color1", ColorKind::Reflectance, Rgb::ONE)?,
            exponent: p.positive_float_or("exponent", 1.0)?,
        })
    }

    /// The blend weight at `si`.
    #[inline]
    pub fn weight(&self, si: &SurfaceInteraction) -> f32 {
        let c = si.sh_frame.n.dot(self.direction).clamp(0.0, 1.0);
        if self.exponent == 1.0 {
            c
        } else {
            c.powf(self.exponent)
        }
    }
}

impl TextureModel for NormalDeviation {
    #[inline]
    fn eval(&self, m: &Materials, si: &SurfaceInteraction) -> Rgb {
        let t = self.weight(si);
        self.color0.eval(m, si) * (1.0 - t) + self.color1.eval(m, si) * t
    }

    #[inline]
    fn eval_1(&self, m: &Materials, si: &SurfaceInteraction) -> f32 {
        let t = self.weight(si);
        self.color0.eval_1(m, si) * (1.0 - t) + self.color1.eval_1(m, si) * t
    }

    fn eval_1_grad(&self, m: &Materials, si: &SurfaceInteraction) -> (f32, Vec2) {
        let t = self.weight(si);
        let (a, da) = self.color0.eval_1_grad(m, si);
        let (b, db) = self.color1.eval_1_grad(m, si);
        (a * (1.0 - t) + b * t, da * (1.0 - t) + db * t)
    }

    fn mean(&self, m: &Materials) -> f32 {
        let t = 0.5 / (self.exponent + 1.0);
        self.color0.mean(m) * (1.0 - t) + self.color1.mean(m) * t
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::tests::flat_si;
    use crate::math::Frame;
    use crate::testing::params::{MapParams, Value};

    fn build(p: MapParams) -> Result<NormalDeviation, ParamError> {
        let mut p = p;
        let t = NormalDeviation::from_params(&mut p)?;
        assert!(p.unread().is_empty(), "unread {:?}", p.unread());
        Ok(t)
    }

    fn facing(n: Vec3) -> SurfaceInteraction {
        let n = n.normalize();
        SurfaceInteraction {
            n,
            sh_frame: Frame::from_normal(n),
            ..flat_si()
        }
    }

    #[test]
    fn aligned_opposite_and_between() {
        let (c0, c1) = (Rgb::new(0.3, 0.05, 0.02), Rgb::new(0.8, 0.8, 0.7));
        let t = build(
            MapParams::new()
                .with("direction", Value::Vector(Vec3::new(0.0, 2.0, 0.0)))
                .color("color0", c0)
                .color("color1", c1)
                .float("exponent", 2.0),
        )
        .unwrap();
        let m = Materials::default();
        assert_eq!(t.direction, Vec3::Y);
        assert!((t.eval(&m, &facing(Vec3::Y)) - c1).length() < 1e-6);
        assert!((t.eval(&m, &facing(-Vec3::Y)) - c0).length() < 1e-6);
        assert!((t.eval(&m, &facing(Vec3::X)) - c0).length() < 1e-6);
        // 60° away: cos = ½, weight ¼.
        let n = Vec3::new(3f32.sqrt() / 2.0, 0.5, 0.0);
        let expect = c0 * 0.75 + c1 * 0.25;
        assert!((t.eval(&m, &facing(n)) - expect).length() < 1e-5);
        let (v, g) = t.eval_1_grad(&m, &facing(n));
        assert!((v - t.eval_1(&m, &facing(n))).abs() < 1e-6);
        assert_eq!(g, Vec2::ZERO);
    }

    #[test]
    fn mean_matches_uniform_normals() {
        let m = Materials::default();
        for exponent in [0.5, 1.0, 3.0] {
            let t = build(
                MapParams::new()
                    .with("direction", Value::Vector(Vec3::new(0.3, -0.2, 0.9)))
                    .float("exponent", exponent),
            )
            .unwrap();
            // A Fibonacci lattice: near-uniform normals over the sphere.
            let n = 20_000;
            let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
            let sum: f32 = (0..n)
                .map(|i| {
                    let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
                    let r = (1.0 - z * z).sqrt();
                    let phi = golden * i as f32;
                    let normal = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                    t.eval_1(&m, &facing(normal))
                })
                .sum();
            let measured = sum / n as f32;
            assert!(
                (measured - t.mean(&m)).abs() < 2e-3,
                "exponent {exponent}: {measured} vs {}",
                t.mean(&m)
            );
        }
    }

    #[test]
    fn defaults_and_bad_input() {
        let t = build(MapParams::new()).unwrap();
        assert_eq!((t.direction, t.exponent), (Vec3::Y, 1.0));
        let e = build(MapParams::new().with("direction", Value::Vector(Vec3::ZERO))).unwrap_err();
        assert!(e.0.contains("\"direction\""), "{e}");
        let e = build(MapParams::new().float("exponent", 0.0)).unwrap_err();
        assert!(e.0.contains("\"exponent\""), "{e}");
    }
}
