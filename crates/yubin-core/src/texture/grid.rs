//! `grid`: lines of one colour on a background of another, along the
//! integer u and v of (scaled) uv (Mitsuba 0.6's `gridtexture`).
//!
//! | parameter    | type          | default  | meaning                                               |
//! |--------------|---------------|----------|-------------------------------------------------------|
//! | `color0`     | texture / rgb | 0.2      | the background                                        |
//! | `color1`     | texture / rgb | 0.4      | the lines                                             |
//! | `line_width` | float         | 0.01     | half the width of a line, in cells (≥ 0; ≥ ½ fills all) |
//! | `uscale`     | float         | 1        | cells per unit of u                                   |
//! | `vscale`     | float         | 1        | cells per unit of v                                   |
//! | `to_uv`      | transform     | identity | applied to uv before `uscale` and `vscale`            |
//!
//! ```xml
//! <texture type="grid" name="reflectance">
//!     <rgb name="color0" value="0.8"/>
//!     <rgb name="color1" value="0.05"/>
//!     <float name="line_width" value="0.02"/>
//!     <float name="uscale" value="8"/>
//!     <float name="vscale" value="8"/>
//! </texture>
//! ```
//!
//! With (u, v) = `to_uv`(uv) and x = u·`uscale` − ⌊u·`uscale`⌋, less 1
//! when above ½ (so x ∈ (−½, ½] is the signed distance to the nearest
//! integer, in cells), and y the same for v with `vscale`: the point is on a
//! line, and gets `color1`, when |x| < `line_width` or |y| < `line_width`;
//! elsewhere it gets `color0`. A line is therefore 2·`line_width` cells
//! wide, centred on the cell border, and lines cover the fraction
//! f = 1 − (1 − 2w)² of every cell (w = min(`line_width`, ½)), which is
//! what the mean (for sampling weights) mixes the colours' means by.
//! The derivative with respect to (u, v) is that of the colour picked
//! (zero for constants; the steps at the line edges have none).
//! Mitsuba 0.6 names the width `lineWidth`; Mitsuba 3 has no grid texture.

use super::{uv_transform_param, Tex, TextureModel};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::Rgb;
use glam::{Affine2, Vec2};

/// Grid lines over a background.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    /// The background.
    pub color0: Tex,
    /// The lines.
    pub color1: Tex,
    /// Half a line's width, in cells.
    pub line_width: f32,
    /// Applied to uv, then scaled by (`uscale`, `vscale`).
    pub to_uv: Affine2,
}

impl Grid {
    /// Builds the texture from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let color0 = p.texture_or("color0", ColorKind::Reflectance, Rgb::splat(0.2))?;
        let color1 = p.texture_or("color1", ColorKind::Reflectance, Rgb::splat(0.4))?;
        let line_width = p.float_or("line_width", 0.01)?;
        if !(line_width >= 0.0 && line_width.is_finite()) {
            return Err(p.param_error(
                "line_width",
                &format!("must be a finite number ≥ 0, not {line_width}"),
            ));
        }
        if p.has("lineWidth") {
            return Err(p.param_error("lineWidth", "is Mitsuba 0.6's name: use \"line_width\""));
        }
        let mut scale = Vec2::ONE;
        for (i, name) in ["uscale", "vscale"].into_iter().enumerate() {
            scale[i] = p.float_or(name, 1.0)?;
            if !scale[i].is_finite() {
                return Err(p.param_error(name, &format!("must be finite, not {}", scale[i])));
            }
        }
        let to_uv = Affine2::from_scale(scale) * uv_transform_param(p)?;
        Ok(Self {
            color0,
            color1,
            line_width,
            to_uv,
        })
    }

    /// Whether `si` is on a line.
    #[inline]
    pub fn on_line(&self, si: &SurfaceInteraction) -> bool {
        let uv = self.to_uv.transform_point2(si.uv);
        let mut d = uv - crate::math::floor2(uv);
        for i in 0..2 {
            if d[i] > 0.5 {
                d[i] -= 1.0;
            }
        }
        d.x.abs() < self.line_width || d.y.abs() < self.line_width
    }

    /// The fraction of a cell that lines cover.
    pub fn line_fraction(&self) -> f32 {
        let w = self.line_width.min(0.5);
        1.0 - (1.0 - 2.0 * w) * (1.0 - 2.0 * w)
    }

    #[inline]
    fn pick(&self, si: &SurfaceInteraction) -> &Tex {
        if self.on_line(si) {
            &self.color1
        } else {
            &self.color0
        }
    }
}

impl TextureModel for Grid {
    #[inline]
    fn eval(&self, m: &Materials, si: &SurfaceInteraction) -> Rgb {
        self.pick(si).eval(m, si)
    }

    #[inline]
    fn eval_1(&self, m: &Materials, si: &SurfaceInteraction) -> f32 {
        self.pick(si).eval_1(m, si)
    }

    fn eval_1_grad(&self, m: &Materials, si: &SurfaceInteraction) -> (f32, Vec2) {
        self.pick(si).eval_1_grad(m, si)
    }

    fn mean(&self, m: &Materials) -> f32 {
        let f = self.line_fraction();
        (1.0 - f) * self.color0.mean(m) + f * self.color1.mean(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::tests::flat_si;
    use crate::testing::params::{MapParams, Value};
    use glam::{DMat4, DVec3};

    fn build(p: MapParams) -> Result<Grid, ParamError> {
        let mut p = p;
        let t = Grid::from_params(&mut p)?;
        assert!(p.unread().is_empty(), "unread {:?}", p.unread());
        Ok(t)
    }

    fn at(u: f32, v: f32) -> SurfaceInteraction {
        SurfaceInteraction {
            uv: Vec2::new(u, v),
            ..flat_si()
        }
    }

    #[test]
    fn lines_sit_on_cell_borders() {
        let g = build(
            MapParams::new()
                .float("line_width", 0.1)
                .float("uscale", 4.0)
                .float("vscale", 2.0),
        )
        .unwrap();
        let m = Materials::default();
        let value = |u, v| g.eval_1(&m, &at(u, v));
        // Cells are ¼ wide in u and ½ in v; lines 0.1 cells each side.
        assert!((value(0.125, 0.25) - 0.2).abs() < 1e-6); // cell centre
        assert!((value(0.26, 0.25) - 0.4).abs() < 1e-6); // 0.04 cells past u = ¼
        assert!((value(0.24, 0.25) - 0.4).abs() < 1e-6); // 0.04 cells before
        assert!((value(0.125, 0.53) - 0.4).abs() < 1e-6); // 0.06 cells past v = ½
        assert!((value(0.125, 0.56) - 0.2).abs() < 1e-6); // 0.12 cells past
        assert!((value(-0.01, 0.25) - 0.4).abs() < 1e-6); // negative u
    }

    #[test]
    fn line_fraction_matches_uniform_sampling() {
        let m = Materials::default();
        for w in [0.0, 0.01, 0.05, 0.2, 0.37, 0.5, 0.8] {
            let g = build(
                MapParams::new()
                    .float("line_width", w)
                    .color("color0", Rgb::ZERO)
                    .color("color1", Rgb::ONE)
                    .float("uscale", 3.0)
                    .float("vscale", 5.0)
                    .with(
                        "to_uv",
                        Value::Transform(DMat4::from_translation(DVec3::new(0.123, 0.456, 0.0))),
                    ),
            )
            .unwrap();
            // Cell-centred samples of a 1000² grid over the unit square (15
            // whole cells).
            let n = 1000;
            let mut on = 0usize;
            for i in 0..n {
                for j in 0..n {
                    let si = at((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                    on += g.on_line(&si) as usize;
                }
            }
            let measured = on as f32 / (n * n) as f32;
            let w2 = 1.0 - 2.0 * w.min(0.5);
            let expected = 1.0 - w2 * w2;
            assert!((g.line_fraction() - expected).abs() < 1e-6);
            assert!(
                (measured - expected).abs() < 0.005,
                "w {w}: measured {measured}, expected {expected}"
            );
            assert!((g.mean(&m) - expected).abs() < 1e-6);
        }
    }

    #[test]
    fn defaults_and_bad_input() {
        let g = build(MapParams::new()).unwrap();
        assert_eq!(g.line_width, 0.01);
        assert_eq!(g.color0, Tex::value(0.2));
        assert_eq!(g.color1, Tex::value(0.4));
        assert_eq!(g.to_uv, Affine2::IDENTITY);
        let e = build(MapParams::new().float("line_width", -0.1)).unwrap_err();
        assert!(e.0.contains("\"line_width\"") && e.0.contains("≥ 0"), "{e}");
        let e = build(MapParams::new().float("line_width", f32::NAN)).unwrap_err();
        assert!(e.0.contains("\"line_width\""), "{e}");
        let e = build(MapParams::new().float("lineWidth", 0.1)).unwrap_err();
        assert!(e.0.contains("line_width"), "{e}");
        let e = build(MapParams::new().float("uscale", f32::INFINITY)).unwrap_err();
        assert!(e.0.contains("\"uscale\""), "{e}");
    }
}
