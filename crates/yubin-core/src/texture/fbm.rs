//! `fbm`: fractional Brownian motion, a sum of octaves of Perlin noise
//! (clouds, stains, rough heights), blending two colours.
//!
//! | parameter    | type          | default  | meaning                                                   |
//! |--------------|---------------|----------|-----------------------------------------------------------|
//! | `octaves`    | integer       | 6        | number of noise octaves summed, 1 to 32                   |
//! | `lacunarity` | float         | 2        | frequency ratio of successive octaves (> 0)               |
//! | `gain`       | float         | 0.5      | amplitude ratio of successive octaves (> 0)               |
//! | `color0`     | texture / rgb | 0        | the colour where the sum is −1 (and below)                |
//! | `color1`     | texture / rgb | 1        | the colour where the sum is +1 (and above)                |
//! | `scale`      | float         | 1        | frequency of the first octave                             |
//! | `space`      | string        | `world`  | `world`: a solid texture at the hit point; `uv`: at (u, v, 0) |
//! | `to_world`   | transform     | identity | (`world`) places the texture: p_tex = scale · to_world⁻¹ · p |
//! | `to_uv`      | transform     | identity | (`uv`) applied to uv: p_tex = scale · (to_uv(u, v), 0)      |
//!
//! ```xml
//! <texture type="fbm" name="reflectance">
//!     <integer name="octaves" value="5"/>
//!     <float name="scale" value="3"/>
//!     <rgb name="color0" value="0.05, 0.1, 0.3"/>
//!     <rgb name="color1" value="0.9"/>
//! </texture>
//! ```
//!
//! The sum f(p) = Σᵢ gainⁱ · n(lacunarityⁱ · p), i = 0 … octaves − 1, of
//! improved Perlin noise n (see `perlin`; Musgrave's fBm, in Ebert et
//! al., "Texturing and Modeling: A Procedural Approach", 3rd ed. 2003) lies within
//! ±Σᵢ gainⁱ (< 2 for the default gain) but stays mostly in [−1, 1]. It is
//! mapped to colours as `perlin` maps its noise, t = clamp(½(f + 1), 0, 1),
//! colour (1 − t)·`color0` + t·`color1`, without normalising, so one octave
//! is exactly `perlin` and more octaves add detail without lowering the
//! contrast. With an integer lacunarity every octave vanishes at the
//! integer points of texture space; a lacunarity like 1.99 avoids that
//! regularity. The octaves are not band-limited: far away or at high
//! `octaves`, the finest ones alias into noise that the pixel samples
//! average.
//!
//! As a bump height the derivative with respect to (u, v) is analytic (the
//! sum of the octaves' gradients, chained with ∂p/∂u, ∂p/∂v or `to_uv`). The
//! mean is the colours' average. Not a Mitsuba 3 plugin.

use super::noise::{perlin, NoiseMap};
use super::TextureModel;
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ParamError, Params};
use crate::Rgb;
use glam::{Vec2, Vec3};

/// The most octaves (beyond about 24 octaves of ratio 2, f32 positions have
/// no bits left for the finest ones).
pub const MAX_OCTAVES: u32 = 32;

/// Fractional Brownian motion between two colours.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fbm {
    /// Space and colours.
    pub map: NoiseMap,
    /// Number of octaves, 1 to [`MAX_OCTAVES`].
    pub octaves: u32,
    /// Frequency ratio of successive octaves.
    pub lacunarity: f32,
    /// Amplitude ratio of successive octaves.
    pub gain: f32,
}

impl Fbm {
    /// Builds the texture from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let octaves = p.integer_or("octaves", 6)?;
        if !(1..=MAX_OCTAVES as i64).contains(&octaves) {
            return Err(p.param_error(
                "octaves",
                &format!("must be between 1 and {MAX_OCTAVES}, not {octaves}"),
            ));
        }
        Ok(Self {
            octaves: octaves as u32,
            lacunarity: p.positive_float_or("lacunarity", 2.0)?,
            gain: p.positive_float_or("gain", 0.5)?,
            map: NoiseMap::from_params(p)?,
        })
    }

    /// The octave sum at texture-space point `p` and its gradient.
    #[inline]
    pub fn fbm(&self, p: Vec3) -> (f32, Vec3) {
        let (mut value, mut grad) = (0.0, Vec3::ZERO);
        let (mut freq, mut amp) = (1.0, 1.0);
        for _ in 0..self.octaves {
            let (n, g) = perlin(p * freq);
            value += amp * n;
            grad += g * (amp * freq);
            freq *= self.lacunarity;
            amp *= self.gain;
        }
        (value, grad)
    }

    /// The bound of |sum|: Σᵢ gainⁱ.
    pub fn bound(&self) -> f32 {
        (0..self.octaves).map(|i| self.gain.powi(i as i32)).sum()
    }

    #[inline]
    fn value(&self, si: &SurfaceInteraction) -> f32 {
        self.fbm(self.map.space.point(si).0).0
    }
}

impl TextureModel for Fbm {
    #[inline]
    fn eval(&self, m: &Materials, si: &SurfaceInteraction) -> Rgb {
        self.map.eval(m, si, self.value(si))
    }

    #[inline]
    fn eval_1(&self, m: &Materials, si: &SurfaceInteraction) -> f32 {
        self.map.eval_1(m, si, self.value(si))
    }

    fn eval_1_grad(&self, m: &Materials, si: &SurfaceInteraction) -> (f32, Vec2) {
        let (n, dn) = self.map.space.eval_grad(si, |p| self.fbm(p));
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
    use crate::texture::Perlin;
    use glam::DMat4;

    fn build(p: MapParams) -> Result<Fbm, ParamError> {
        let mut p = p;
        let t = Fbm::from_params(&mut p)?;
        assert!(p.unread().is_empty(), "unread {:?}", p.unread());
        Ok(t)
    }

    fn at(p: Vec3, uv: Vec2) -> SurfaceInteraction {
        SurfaceInteraction {
            p,
            uv,
            dpdu: Vec3::new(0.5, 0.1, -0.3),
            dpdv: Vec3::new(0.2, 0.6, 0.4),
            ..flat_si()
        }
    }

    #[test]
    fn one_octave_is_perlin() {
        let params = || {
            MapParams::new()
                .float("scale", 3.0)
                .color("color0", Rgb::new(0.3, 0.1, 0.0))
                .with(
                    "to_world",
                    Value::Transform(
                        DMat4::from_rotation_z(0.4) * DMat4::from_scale(glam::DVec3::splat(2.0)),
                    ),
                )
        };
        let f = build(params().with("octaves", Value::Integer(1))).unwrap();
        let mut p = params();
        let pn = Perlin::from_params(&mut p).unwrap();
        let m = Materials::default();
        let mut u = uniform(17);
        for _ in 0..1000 {
            let si = at(Vec3::new(u(), u(), u()) * 8.0 - 4.0, Vec2::new(u(), u()));
            assert_eq!(f.eval(&m, &si), pn.eval(&m, &si));
            assert_eq!(f.eval_1_grad(&m, &si), pn.eval_1_grad(&m, &si));
        }
        assert_eq!(f.mean(&m), pn.mean(&m));
    }

    #[test]
    fn bounded_by_the_sum_of_gains() {
        let mut u = uniform(23);
        for (octaves, gain, lacunarity) in [(6, 0.5, 2.0), (3, 0.9, 1.7), (8, 0.7, 2.3)] {
            let f = Fbm {
                map: build(MapParams::new()).unwrap().map,
                octaves,
                lacunarity,
                gain,
            };
            let bound = f.bound();
            let mut max = 0.0f32;
            for _ in 0..20_000 {
                let p = Vec3::new(u(), u(), u()) * 50.0;
                max = max.max(f.fbm(p).0.abs());
            }
            assert!(max <= bound, "{max} > {bound}");
            assert!(max > 0.5, "a dead field: max {max}");
        }
    }

    #[test]
    fn defaults() {
        let f = build(MapParams::new()).unwrap();
        assert_eq!((f.octaves, f.lacunarity, f.gain), (6, 2.0, 0.5));
        assert!((f.bound() - 1.96875).abs() < 1e-6);
        // Every octave vanishes at integer points with lacunarity 2.
        assert_eq!(f.fbm(Vec3::new(3.0, -2.0, 5.0)).0, 0.0);
    }

    #[test]
    fn gradients_match_finite_differences() {
        let m = Materials::default();
        let mut u = uniform(29);
        for space in ["world", "uv"] {
            let f = build(
                MapParams::new()
                    .string("space", space)
                    .float("scale", 1.5)
                    .with("octaves", Value::Integer(4))
                    .float("lacunarity", 1.9)
                    .float("gain", 0.6),
            )
            .unwrap();
            for _ in 0..50 {
                let si = at(Vec3::new(u(), u(), u()) * 4.0, Vec2::new(u(), u()));
                check_gradient(&f, &m, &si);
            }
        }
    }

    #[test]
    fn bad_parameters_are_errors() {
        for octaves in [0, -3, 33] {
            let e = build(MapParams::new().with("octaves", Value::Integer(octaves))).unwrap_err();
            assert!(
                e.0.contains("\"octaves\"") && e.0.contains("between 1 and 32"),
                "{e}"
            );
        }
        for lacunarity in [0.0, -2.0, f32::NAN] {
            let e = build(MapParams::new().float("lacunarity", lacunarity)).unwrap_err();
            assert!(
                e.0.contains("\"lacunarity\"") && e.0.contains("positive"),
                "{e}"
            );
        }
        let e = build(MapParams::new().float("gain", 0.0)).unwrap_err();
        assert!(e.0.contains("\"gain\""), "{e}");
    }
}
