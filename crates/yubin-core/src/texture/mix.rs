//! `mix`: a blend of two textures by a weight that may itself be a
//! texture.
//!
//! | parameter | type            | default | meaning                                        |
//! |-----------|-----------------|---------|------------------------------------------------|
//! | `color0`  | texture / rgb   | 0       | the colour where the weight is 0               |
//! | `color1`  | texture / rgb   | 1       | the colour where the weight is 1               |
//! | `weight`  | texture / float | 0.5     | w, clamped to [0, 1] (a colour texture: its luminance) |
//!
//! ```xml
//! <texture type="mix" name="reflectance">
//!     <texture type="bitmap" name="color0">
//!         <string name="filename" value="textures/wood.jpg"/>
//!     </texture>
//!     <rgb name="color1" value="0.6, 0.6, 0.55"/>
//!     <texture type="fbm" name="weight">
//!         <float name="scale" value="4"/>
//!     </texture>
//! </texture>
//! ```
//!
//! The colour is (1 − w)·`color0` + w·`color1` with w = clamp(`weight`, 0, 1);
//! read as a float, the same blend of the colours' values. The derivative
//! with respect to (u, v) follows the product rule,
//! (1 − w)·∇c₀ + w·∇c₁ + (c₁ − c₀)·∇w, with ∇w = 0 where the weight is
//! clamped. The mean (for sampling weights) is the blend of the means by
//! the weight's mean, exact when the weight is constant or independent of
//! the colours and stays within [0, 1]. (pbrt-v4's `mix` texture; Mitsuba 3
//! blends BSDFs, not textures.)

use super::{Tex, TextureModel};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::Rgb;
use glam::Vec2;

/// A weighted blend of two textures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mix {
    /// The colour at weight 0.
    pub color0: Tex,
    /// The colour at weight 1.
    pub color1: Tex,
    /// The weight (its value, clamped to [0, 1]).
    pub weight: Tex,
}

impl Mix {
    /// Builds the texture from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        Ok(Self {
            color0: p.texture_or("color0", ColorKind::Reflectance, Rgb::ZERO)?,
            color1: p.texture_or("color1", ColorKind::Reflectance, Rgb::ONE)?,
            weight: p.texture_or("weight", ColorKind::Reflectance, Rgb::splat(0.5))?,
        })
    }

    #[inline]
    fn weight(&self, m: &Materials, si: &SurfaceInteraction) -> f32 {
        self.weight.eval_1(m, si).clamp(0.0, 1.0)
    }
}

impl TextureModel for Mix {
    #[inline]
    fn eval(&self, m: &Materials, si: &SurfaceInteraction) -> Rgb {
        let w = self.weight(m, si);
        self.color0.eval(m, si) * (1.0 - w) + self.color1.eval(m, si) * w
    }

    #[inline]
    fn eval_1(&self, m: &Materials, si: &SurfaceInteraction) -> f32 {
        let w = self.weight(m, si);
        self.color0.eval_1(m, si) * (1.0 - w) + self.color1.eval_1(m, si) * w
    }

    fn eval_1_grad(&self, m: &Materials, si: &SurfaceInteraction) -> (f32, Vec2) {
        let (w, dw) = self.weight.eval_1_grad(m, si);
        let (w, dw) = if (0.0..=1.0).contains(&w) {
            (w, dw)
        } else {
            (w.clamp(0.0, 1.0), Vec2::ZERO)
        };
        let (a, da) = self.color0.eval_1_grad(m, si);
        let (b, db) = self.color1.eval_1_grad(m, si);
        (
            a * (1.0 - w) + b * w,
            da * (1.0 - w) + db * w + dw * (b - a),
        )
    }

    fn mean(&self, m: &Materials) -> f32 {
        let w = self.weight.mean(m).clamp(0.0, 1.0);
        self.color0.mean(m) * (1.0 - w) + self.color1.mean(m) * w
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::tests::flat_si;
    use crate::testing::params::MapParams;
    use crate::texture::noise::{check_gradient, uniform};
    use crate::texture::{Fbm, NoiseMap, NoiseSpace, Perlin, Texture};
    use glam::{Affine2, Affine3A, Vec3};

    fn build(p: MapParams) -> Mix {
        let mut p = p;
        let t = Mix::from_params(&mut p).unwrap();
        assert!(p.unread().is_empty(), "unread {:?}", p.unread());
        t
    }

    /// Two noise textures: 0 varies over uv, 1 over the world.
    fn materials() -> Materials {
        let mut m = Materials::default();
        let uv = NoiseMap {
            space: NoiseSpace::Uv(Affine2::from_scale(Vec2::splat(3.0))),
            color0: Tex::Const(Rgb::new(0.1, 0.2, 0.3)),
            color1: Tex::Const(Rgb::new(0.9, 0.5, 0.2)),
        };
        m.textures.push(Texture::Perlin(Perlin { map: uv }));
        let world = NoiseMap {
            space: NoiseSpace::World(Affine3A::from_scale(Vec3::splat(2.0))),
            color0: Tex::value(-0.5),
            color1: Tex::value(1.5),
        };
        m.textures.push(Texture::Fbm(Fbm {
            map: world,
            octaves: 3,
            lacunarity: 2.1,
            gain: 0.5,
        }));
        m
    }

    #[test]
    fn endpoints_and_middle() {
        let m = Materials::default();
        let si = flat_si();
        let (c0, c1) = (Rgb::new(0.8, 0.1, 0.0), Rgb::new(0.0, 0.2, 0.6));
        let mix = |w: f32| {
            build(
                MapParams::new()
                    .color("color0", c0)
                    .color("color1", c1)
                    .float("weight", w),
            )
        };
        assert_eq!(mix(0.0).eval(&m, &si), c0);
        assert_eq!(mix(1.0).eval(&m, &si), c1);
        assert_eq!(mix(-2.0).eval(&m, &si), c0); // clamped
        assert_eq!(mix(7.0).eval(&m, &si), c1);
        let half = build(MapParams::new().color("color0", c0).color("color1", c1));
        assert!((half.eval(&m, &si) - (c0 + c1) * 0.5).length() < 1e-6);
        assert!((half.mean(&m) - crate::spectrum::luminance((c0 + c1) * 0.5)).abs() < 1e-6);
        // Defaults: black to white by 0.5.
        assert!((build(MapParams::new()).eval_1(&m, &si) - 0.5).abs() < 1e-6);
    }

    #[test]
    fn textured_weight_and_colours() {
        let m = materials();
        let t = build(
            MapParams::new()
                .texture("color0", 0)
                .color("color1", Rgb::new(0.3, 0.3, 0.9))
                .texture("weight", 1),
        );
        let mut u = uniform(31);
        let mut clamped = 0;
        for _ in 0..200 {
            let si = SurfaceInteraction {
                p: Vec3::new(u(), u(), u()) * 3.0,
                uv: Vec2::new(u(), u()),
                dpdu: Vec3::new(0.4, 0.3, 0.1),
                dpdv: Vec3::new(-0.2, 0.1, 0.5),
                ..flat_si()
            };
            let w = Tex::Texture(1).eval_1(&m, &si);
            if !(0.02..=0.98).contains(&w) {
                clamped += 1;
                continue; // finite differences could straddle the clamp's kink
            }
            let expect = Tex::Texture(0).eval(&m, &si) * (1.0 - w) + Rgb::new(0.3, 0.3, 0.9) * w;
            assert!((t.eval(&m, &si) - expect).length() < 1e-5);
            check_gradient(&t, &m, &si);
        }
        assert!(clamped < 150, "too few unclamped samples");
    }
}
