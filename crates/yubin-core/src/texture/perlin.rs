//! `perlin`: Ken Perlin's improved gradient noise, a solid texture (or a
//! uv one), blending two colours.
//!
//! | parameter  | type          | default    | meaning                                                   |
//! |------------|---------------|------------|-----------------------------------------------------------|
//! | `color0`   | texture / rgb | 0          | the colour where the noise is −1                          |
//! | `color1`   | texture / rgb | 1          | the colour where the noise is +1                          |
//! | `scale`    | float         | 1          | frequency: noise-lattice cells per unit of texture space   |
//! | `space`    | string        | `world`    | `world`: a solid texture at the hit point; `uv`: at (u, v, 0) |
//! | `to_world` | transform     | identity   | (`world`) places the texture: p_tex = scale · to_world⁻¹ · p |
//! | `to_uv`    | transform     | identity   | (`uv`) applied to uv: p_tex = scale · (to_uv(u, v), 0)      |
//!
//! ```xml
//! <texture type="perlin" name="reflectance">
//!     <rgb name="color0" value="0.1, 0.2, 0.5"/>
//!     <rgb name="color1" value="0.9, 0.8, 0.6"/>
//!     <float name="scale" value="4"/>
//!     <transform name="to_world"><rotate y="1" angle="30"/></transform>
//! </texture>
//! ```
//!
//! The noise n, within [−1, 1] in practice (Perlin 2002, "Improving
//! Noise": quintic fade, 12 gradient directions, the paper's permutation
//! table), becomes the weight t = clamp(½(n + 1), 0, 1) and the colour
//! (1 − t)·`color0` + t·`color1`; read as a float it is the same blend of
//! the colours' values. The noise is 0 (t = ½) at the integer points of
//! texture space, has lattice features about one unit across, and repeats
//! every 256 units. The transform given for the other `space` is an error.
//! A solid texture follows the world position: to make it move with an
//! object, give the texture the shape's `to_world` (then texture space is
//! object space).
//!
//! As a bump height (`bumpmap`), the derivative with respect to (u, v) is
//! analytic: the noise's gradient chained with ∂p/∂u and ∂p/∂v (or with
//! `to_uv`). The mean, for sampling weights, is the colours' average (the
//! noise averages zero). Not a Mitsuba 3 plugin; the parameter names follow
//! its `checkerboard`.

use super::noise::{perlin, NoiseMap};
use super::TextureModel;
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ParamError, Params};
use crate::Rgb;
use glam::Vec2;

/// Improved Perlin noise between two colours.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Perlin {
    /// Space and colours.
    pub map: NoiseMap,
}

impl Perlin {
    /// Builds the texture from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        Ok(Self {
            map: NoiseMap::from_params(p)?,
        })
    }

    /// The noise at `si`.
    #[inline]
    pub fn noise(&self, si: &SurfaceInteraction) -> f32 {
        perlin(self.map.space.point(si).0).0
    }
}

impl TextureModel for Perlin {
    #[inline]
    fn eval(&self, m: &Materials, si: &SurfaceInteraction) -> Rgb {
        self.map.eval(m, si, self.noise(si))
    }

    #[inline]
    fn eval_1(&self, m: &Materials, si: &SurfaceInteraction) -> f32 {
        self.map.eval_1(m, si, self.noise(si))
    }

    fn eval_1_grad(&self, m: &Materials, si: &SurfaceInteraction) -> (f32, Vec2) {
        let (n, dn) = self.map.space.eval_grad(si, perlin);
        self.map.eval_1_grad(m, si, n, dn)
    }

    fn mean(&self, m: &Materials) -> f32 {
        self.map.mean(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::tests::flat_si;
    use crate::testing::params::{MapParams, Value};
    use crate::texture::noise::{check_gradient, uniform};
    use crate::texture::{Checkerboard, Tex, Texture};
    use glam::{DMat4, DVec3, Vec3};

    fn build(p: MapParams) -> Result<Perlin, ParamError> {
        let mut p = p;
        let t = Perlin::from_params(&mut p)?;
        assert!(p.unread().is_empty(), "unread {:?}", p.unread());
        Ok(t)
    }

    fn at(p: Vec3, uv: Vec2) -> SurfaceInteraction {
        SurfaceInteraction {
            p,
            uv,
            dpdu: Vec3::new(0.7, 0.2, -0.4),
            dpdv: Vec3::new(-0.1, 0.9, 0.3),
            ..flat_si()
        }
    }

    #[test]
    fn maps_noise_to_colours_and_is_half_at_lattice_points() {
        let t = build(
            MapParams::new()
                .color("color0", Rgb::new(0.2, 0.0, 0.0))
                .color("color1", Rgb::new(0.0, 0.0, 1.0))
                .float("scale", 2.0),
        )
        .unwrap();
        let m = Materials::default();
        // Lattice points of texture space (scale 2: half-integers in world).
        for p in [Vec3::ZERO, Vec3::new(0.5, -1.5, 3.0)] {
            let c = t.eval(&m, &at(p, Vec2::ZERO));
            assert!((c - Rgb::new(0.1, 0.0, 0.5)).length() < 1e-6, "{c}");
        }
        // Everywhere: the colour is the blend the noise says.
        let mut u = uniform(5);
        for _ in 0..1000 {
            let si = at(Vec3::new(u(), u(), u()) * 10.0, Vec2::ZERO);
            let n = perlin(si.p * 2.0).0;
            let tt = 0.5 * (n + 1.0);
            let c = t.eval(&m, &si);
            assert!((0.0..=1.0).contains(&tt));
            assert!((c - Rgb::new(0.2 * (1.0 - tt), 0.0, tt)).length() < 1e-5);
        }
        assert!((t.mean(&m) - 0.5 * (0.2 * 0.2126 + 0.0722)).abs() < 1e-6);
    }

    #[test]
    fn world_space_follows_to_world() {
        let mut p = MapParams::new().with(
            "to_world",
            Value::Transform(DMat4::from_translation(DVec3::new(0.25, 0.5, 0.0))),
        );
        let t = Perlin::from_params(&mut p).unwrap();
        let si = at(Vec3::new(1.25, 0.5, 0.0), Vec2::ZERO);
        assert_eq!(t.noise(&si), 0.0);
        let si = at(Vec3::new(1.0, 0.3, 0.7), Vec2::ZERO);
        assert!((t.noise(&si) - perlin(Vec3::new(0.75, -0.2, 0.7)).0).abs() < 1e-5);
    }

    #[test]
    fn uv_space_reads_uv() {
        let t = build(MapParams::new().string("space", "uv").float("scale", 3.0)).unwrap();
        let si = at(Vec3::new(0.3, 0.1, 0.2), Vec2::new(0.1, 0.7));
        assert!((t.noise(&si) - perlin(Vec3::new(0.3, 2.1, 0.0)).0).abs() < 1e-5);
    }

    #[test]
    fn gradients_match_finite_differences() {
        let mut m = Materials::default();
        m.textures.push(Texture::Checkerboard(Checkerboard {
            color0: Tex::value(0.9),
            color1: Tex::value(0.3),
            to_uv: glam::Affine2::IDENTITY,
            float_swapped: false,
        }));
        let mut u = uniform(9);
        for space in ["world", "uv"] {
            let transform = if space == "world" {
                "to_world"
            } else {
                "to_uv"
            };
            let m4 = DMat4::from_cols_array(&[
                1.2, 0.3, 0.0, 0.0, -0.2, 0.8, 0.1, 0.0, 0.0, 0.4, 1.1, 0.0, 0.3, 0.1, 0.2, 1.0,
            ]);
            let t = build(
                MapParams::new()
                    .string("space", space)
                    .float("scale", 2.5)
                    .with(transform, Value::Transform(m4))
                    .color("color0", Rgb::new(0.1, 0.5, 0.2)),
            )
            .unwrap();
            for _ in 0..50 {
                let si = at(Vec3::new(u(), u(), u()) * 4.0, Vec2::new(u(), u()) * 0.4);
                check_gradient(&t, &m, &si);
            }
            // A textured colour (a checkerboard, flat inside its squares).
            let t = Perlin {
                map: NoiseMap {
                    color1: Tex::Texture(0),
                    ..t.map
                },
            };
            let si = at(Vec3::new(0.3, 0.6, 0.1), Vec2::new(0.1, 0.2));
            check_gradient(&t, &m, &si);
        }
    }

    #[test]
    fn bad_parameters_are_errors() {
        let e = build(MapParams::new().float("scale", -1.0)).unwrap_err();
        assert!(e.0.contains("\"scale\""), "{e}");
        let e = build(MapParams::new().string("space", "object")).unwrap_err();
        assert!(e.0.contains("world, uv"), "{e}");
        let e = build(
            MapParams::new()
                .string("space", "uv")
                .with("to_world", Value::Transform(DMat4::IDENTITY)),
        )
        .unwrap_err();
        assert!(e.0.contains("\"to_world\""), "{e}");
        let e =
            build(MapParams::new().with("to_uv", Value::Transform(DMat4::IDENTITY))).unwrap_err();
        assert!(e.0.contains("\"to_uv\""), "{e}");
    }
}
