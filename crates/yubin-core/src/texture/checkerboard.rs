//! `checkerboard`: two colours in a 2×2 checker pattern over the unit uv
//! square.
//!
//! | parameter | type              | default  | meaning                            |
//! |-----------|-------------------|----------|------------------------------------|
//! | `color0`  | texture / rgb     | 0.4      | where u and v fall in the same half |
//! | `color1`  | texture / rgb     | 0.2      | elsewhere                          |
//! | `to_uv`   | transform         | identity | applied to uv (`scale` for more squares) |
//! | `consistent_float` | boolean  | false    | yubin's own: read as a float, use the colour's pattern (see below) |
//!
//! ```xml
//! <texture type="checkerboard" name="reflectance">
//!     <rgb name="color0" value="0.8"/>
//!     <rgb name="color1" value="0.1"/>
//!     <transform name="to_uv"><scale x="5" y="5"/></transform>
//! </texture>
//! ```
//!
//! With `(u, v)` the transformed coordinates modulo 1, `color0` is used when
//! `u > ½` and `v > ½` agree, `color1` otherwise (Mitsuba 3's
//! `checkerboard`). Its derivative is zero almost everywhere.
//!
//! **Mitsuba's quirk, kept.** Mitsuba 3.9.1 swaps the two colours when
//! the texture is read as a float (`eval_1`: roughness, blend weights,
//! opacity, bump height) but not as a colour, and its reference images
//! carry that, so yubin does the same by default: Mitsuba's docs scenes
//! `bsdf_roughconductor_textured_carbon.xml` and
//! `bsdf_roughdielectric_textured.xml` pass its Z-test as written
//! (`scripts/docs-parity`). `consistent_float` (yubin's own parameter)
//! reads a float with the colour's pattern instead.

use super::{uv_transform_param, Tex, TextureModel};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::Rgb;
use glam::{Affine2, Vec2};

/// A checker pattern.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Checkerboard {
    /// Colour of the squares where u and v agree.
    pub color0: Tex,
    /// Colour of the other squares.
    pub color1: Tex,
    /// Applied to uv.
    pub to_uv: Affine2,
    /// Read as a float, the colours trade places (Mitsuba's quirk).
    pub float_swapped: bool,
}

impl Checkerboard {
    /// Builds the texture from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        Ok(Self {
            color0: p.texture_or("color0", ColorKind::Reflectance, Rgb::splat(0.4))?,
            color1: p.texture_or("color1", ColorKind::Reflectance, Rgb::splat(0.2))?,
            to_uv: uv_transform_param(p)?,
            float_swapped: !p.boolean_or("consistent_float", false)?,
        })
    }

    /// The colour of the square at `si`; `swap` trades the two.
    #[inline]
    fn pick(&self, si: &SurfaceInteraction, swap: bool) -> &Tex {
        let uv = self.to_uv.transform_point2(si.uv);
        let f = uv - crate::math::floor2(uv);
        if ((f.x > 0.5) == (f.y > 0.5)) != swap {
            &self.color0
        } else {
            &self.color1
        }
    }
}

impl TextureModel for Checkerboard {
    #[inline]
    fn eval(&self, m: &Materials, si: &SurfaceInteraction) -> Rgb {
        self.pick(si, false).eval(m, si)
    }

    #[inline]
    fn eval_1(&self, m: &Materials, si: &SurfaceInteraction) -> f32 {
        self.pick(si, self.float_swapped).eval_1(m, si)
    }

    fn eval_1_grad(&self, m: &Materials, si: &SurfaceInteraction) -> (f32, Vec2) {
        (self.eval_1(m, si), Vec2::ZERO)
    }

    fn mean(&self, m: &Materials) -> f32 {
        0.5 * (self.color0.mean(m) + self.color1.mean(m))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::tests::flat_si;
    use crate::spectrum::luminance;

    #[test]
    fn squares_alternate() {
        let c = Checkerboard {
            color0: Tex::value(0.8),
            color1: Tex::value(0.1),
            to_uv: Affine2::from_scale(Vec2::splat(2.0)),
            float_swapped: true,
        };
        let m = Materials::default();
        let at = |u, v| {
            let si = SurfaceInteraction {
                uv: Vec2::new(u, v),
                ..flat_si()
            };
            luminance(c.eval(&m, &si))
        };
        assert!((at(0.1, 0.1) - 0.8).abs() < 1e-6);
        assert!((at(0.35, 0.1) - 0.1).abs() < 1e-6);
        assert!((at(0.35, 0.35) - 0.8).abs() < 1e-6);
        // The same square read as a float: Mitsuba 3.9.1 answers color1
        // there (see the module docs), yubin's consistent reading color0.
        let si = SurfaceInteraction {
            uv: Vec2::new(0.1, 0.1),
            ..flat_si()
        };
        assert!((c.eval_1(&m, &si) - 0.1).abs() < 1e-6);
        let consistent = Checkerboard {
            float_swapped: false,
            ..c
        };
        assert!((consistent.eval_1(&m, &si) - 0.8).abs() < 1e-6);
        assert!((c.mean(&m) - 0.45).abs() < 1e-6);
    }
}
