//! `scale`: another texture (or a constant) times a number.
//!
//! | parameter | type          | default    | meaning                                               |
//! |-----------|---------------|------------|-------------------------------------------------------|
//! | `texture` | texture / rgb | (required) | the texture scaled; an unnamed nested texture also does |
//! | `scale`   | float         | 1          | the factor (any finite number)                        |
//!
//! ```xml
//! <texture type="scale" name="reflectance">
//!     <float name="scale" value="0.5"/>
//!     <texture type="bitmap" name="texture">
//!         <string name="filename" value="textures/wood.jpg"/>
//!     </texture>
//! </texture>
//! ```
//!
//! The colour, the value, its derivative with respect to (u, v) and the
//! mean are those of `texture` times `scale`. Nothing keeps a scaled
//! reflectance at or below 1 (a factor above 1 can make a surface reflect
//! more than it receives), and a negative factor inverts a bump map's
//! heights. (pbrt-v4's `scale` texture; Mitsuba 3 has none.)

use super::{Tex, TextureModel};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::Rgb;
use glam::Vec2;

/// A texture times a constant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scale {
    /// The texture scaled.
    pub texture: Tex,
    /// The factor.
    pub scale: f32,
}

impl Scale {
    /// Builds the texture from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let scale = p.float_or("scale", 1.0)?;
        if !scale.is_finite() {
            return Err(p.param_error("scale", &format!("must be finite, not {scale}")));
        }
        let texture = match p.texture("texture", ColorKind::Reflectance)? {
            Some(t) => t,
            None => match p.nested_textures()?.as_slice() {
                [t] => *t,
                [] => return Err(p.error("needs the texture to scale, \"texture\"")),
                kids => {
                    return Err(p.error(&format!(
                        "needs one texture to scale, found {} nested textures",
                        kids.len()
                    )))
                }
            },
        };
        Ok(Self { texture, scale })
    }
}

impl TextureModel for Scale {
    #[inline]
    fn eval(&self, m: &Materials, si: &SurfaceInteraction) -> Rgb {
        self.texture.eval(m, si) * self.scale
    }

    #[inline]
    fn eval_1(&self, m: &Materials, si: &SurfaceInteraction) -> f32 {
        self.texture.eval_1(m, si) * self.scale
    }

    fn eval_1_grad(&self, m: &Materials, si: &SurfaceInteraction) -> (f32, Vec2) {
        let (v, g) = self.texture.eval_1_grad(m, si);
        (v * self.scale, g * self.scale)
    }

    fn mean(&self, m: &Materials) -> f32 {
        self.texture.mean(m) * self.scale
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::tests::flat_si;
    use crate::testing::params::MapParams;
    use crate::texture::noise::check_gradient;
    use crate::texture::{NoiseMap, NoiseSpace, Perlin, Texture};
    use glam::Affine2;

    fn build(p: MapParams) -> Result<Scale, ParamError> {
        let mut p = p;
        let t = Scale::from_params(&mut p)?;
        assert!(p.unread().is_empty(), "unread {:?}", p.unread());
        Ok(t)
    }

    #[test]
    fn scales_value_gradient_and_mean() {
        let mut m = Materials::default();
        m.textures.push(Texture::Perlin(Perlin {
            map: NoiseMap {
                space: NoiseSpace::Uv(Affine2::from_scale(Vec2::splat(4.0))),
                color0: Tex::Const(Rgb::new(0.0, 0.1, 0.2)),
                color1: Tex::Const(Rgb::new(1.0, 0.6, 0.4)),
            },
        }));
        let t = build(MapParams::new().texture("texture", 0).float("scale", -2.5)).unwrap();
        let inner = Tex::Texture(0);
        for uv in [Vec2::new(0.13, 0.71), Vec2::new(0.52, 0.08)] {
            let si = SurfaceInteraction { uv, ..flat_si() };
            assert_eq!(t.eval(&m, &si), inner.eval(&m, &si) * -2.5);
            let (v, g) = t.eval_1_grad(&m, &si);
            let (vi, gi) = inner.eval_1_grad(&m, &si);
            assert_eq!((v, g), (vi * -2.5, gi * -2.5));
            assert!(g.length() > 0.0);
            check_gradient(&t, &m, &si);
        }
        assert_eq!(t.mean(&m), inner.mean(&m) * -2.5);
        let c = build(MapParams::new().color("texture", Rgb::new(0.2, 0.4, 0.1))).unwrap();
        assert_eq!(c.eval(&m, &flat_si()), Rgb::new(0.2, 0.4, 0.1));
        assert_eq!(c.eval_1_grad(&m, &flat_si()).1, Vec2::ZERO);
    }

    #[test]
    fn bad_input() {
        let e = build(MapParams::new().float("scale", 2.0)).unwrap_err();
        assert!(e.0.contains("\"texture\""), "{e}");
        let e = build(
            MapParams::new()
                .texture("texture", 0)
                .float("scale", f32::NAN),
        )
        .unwrap_err();
        assert!(e.0.contains("\"scale\""), "{e}");
    }
}
