//! `difftrans`: ideal diffuse transmission, f = T/π into the hemisphere
//! on the other side of the surface (paper, thin cloth, leaves).
//!
//! | parameter       | type                     | default | meaning |
//! |-----------------|--------------------------|---------|---------|
//! | `transmittance` | texture / rgb / spectrum | 0.5     | fraction T of the light that is transmitted |
//!
//! ```xml
//! <bsdf type="difftrans"><rgb name="transmittance" value="0.4, 0.6, 0.3"/></bsdf>
//! ```
//!
//! Light arriving from either side leaves on the other, cosine-distributed
//! and scaled by T; nothing is reflected (combine it with a reflecting
//! BSDF through `blendbsdf` for a translucent sheet). Works from both
//! sides alike, so its albedo is T for every direction. Samples draw the
//! cosine-weighted hemisphere opposite `wo`, so the sample weight is T.
//! There is no refraction: the relative index is 1 and radiance and
//! importance are transported alike. Mitsuba 0.6's `difftrans`; the
//! Lambertian transmission of pbrt-v3 §8.3 (`LambertianTransmission`).

use super::{BsdfContext, BsdfFlags, BsdfSample, Scatter};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::sampling::square_to_cosine_hemisphere;
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Ideal diffuse transmission.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiffTrans {
    /// Transmitted fraction.
    pub transmittance: Tex,
}

impl DiffTrans {
    /// A constant transmittance.
    pub fn new(transmittance: Rgb) -> Self {
        Self {
            transmittance: Tex::Const(transmittance),
        }
    }

    /// Builds the BSDF from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        Ok(Self {
            transmittance: p.texture_or(
                "transmittance",
                ColorKind::Reflectance,
                Rgb::splat(0.5),
            )?,
        })
    }
}

impl DiffTrans {
    /// Lobes this material has.
    pub fn flags(&self, _: &Materials) -> BsdfFlags {
        BsdfFlags::DIFFUSE_TRANSMISSION | BsdfFlags::FRONT_SIDE | BsdfFlags::BACK_SIDE
    }

    /// The lobe at `si`.
    #[inline]
    pub fn lobe(&self, m: &Materials, si: &SurfaceInteraction) -> DiffTransLobe {
        DiffTransLobe {
            transmittance: self.transmittance.eval(m, si),
        }
    }
}

/// [`DiffTrans`] at a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiffTransLobe {
    /// Transmitted fraction.
    pub transmittance: Rgb,
}

impl Scatter for DiffTransLobe {
    #[inline]
    fn sample(&self, _: &BsdfContext, wo: Vec3, _: f32, u2: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let mut wi = square_to_cosine_hemisphere(u2);
        if wo.z > 0.0 {
            wi.z = -wi.z;
        }
        let pdf = wi.z.abs() * FRAC_1_PI;
        (pdf > 0.0).then_some(BsdfSample {
            wi,
            pdf,
            eta: 1.0,
            sampled: BsdfFlags::DIFFUSE_TRANSMISSION,
            weight: self.transmittance,
        })
    }

    #[inline]
    fn eval(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z * wi.z >= 0.0 {
            return Rgb::ZERO;
        }
        self.transmittance * (FRAC_1_PI * wi.z.abs())
    }

    #[inline]
    fn pdf(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z * wi.z >= 0.0 {
            return 0.0;
        }
        wi.z.abs() * FRAC_1_PI
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::microfacet::tests::MapParams;
    use crate::bsdf::tests::{albedo, check_bsdf, flat_si, Variant};
    use crate::bsdf::BsdfModel;
    use crate::bsdf::Material;
    use crate::sampler::Pcg32;

    /// The albedo is exactly T from every direction on both sides, and
    /// nothing is reflected.
    #[test]
    fn transmits_exactly_the_transmittance() {
        let t = Rgb::new(0.2, 0.5, 0.9);
        let m = Materials::with_bsdfs(vec![Material::DiffTrans(DiffTrans::new(t))]);
        let (ctx, si) = (BsdfContext::default(), flat_si());
        let mut rng = Pcg32::new(1, 2);
        for _ in 0..20 {
            let wo = crate::sampling::square_to_uniform_sphere(rng.next_2d());
            let a = albedo(&m, 0, wo);
            assert!((a - t).abs().max_element() < 1e-4, "wo {wo}: {a}");
            for _ in 0..100 {
                let u = rng.next_2d();
                let s = m.bsdfs[0].sample(&m, &ctx, &si, wo, 0.5, u).unwrap();
                assert!(s.wi.z * wo.z < 0.0, "wo {wo} wi {}", s.wi);
                assert_eq!(s.sampled, BsdfFlags::DIFFUSE_TRANSMISSION);
                // Reflection is black, transmission reciprocal.
                let refl = Vec3::new(s.wi.x, s.wi.y, -s.wi.z);
                assert_eq!(m.bsdfs[0].eval(&m, &ctx, &si, wo, refl), Rgb::ZERO);
                assert_eq!(m.bsdfs[0].pdf(&m, &ctx, &si, wo, refl), 0.0);
                let f1 = m.bsdfs[0].eval(&m, &ctx, &si, wo, s.wi) / s.wi.z.abs();
                let f2 = m.bsdfs[0].eval(&m, &ctx, &si, s.wi, wo) / wo.z.abs();
                assert!((f1 - f2).abs().max_element() < 1e-6);
                assert!((f1 - t * FRAC_1_PI).abs().max_element() < 1e-6);
            }
        }
        for wo in [Vec3::new(0.3, 0.2, 0.9), Vec3::new(0.3, -0.2, -0.6)] {
            check_bsdf(&m, 0, wo.normalize());
        }
    }

    #[test]
    fn params() {
        let mut p = MapParams::new().color("transmittance", Rgb::new(0.1, 0.2, 0.3));
        let b = DiffTrans::from_params(&mut p).unwrap();
        assert!(p.unread().is_empty(), "{:?}", p.unread());
        assert_eq!(b, DiffTrans::new(Rgb::new(0.1, 0.2, 0.3)));
        let d = DiffTrans::from_params(&mut MapParams::new()).unwrap();
        assert_eq!(d, DiffTrans::new(Rgb::splat(0.5)));
    }

    /// Configurations for the table-driven tests in `bsdf/mod.rs`.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let mut white = Variant::last(
            "difftrans (white)",
            vec![Material::DiffTrans(DiffTrans::new(Rgb::ONE))],
        );
        white.lossless = true;
        let mut textured = Variant::last(
            "difftrans (checkerboard texture)",
            vec![Material::DiffTrans(DiffTrans {
                transmittance: Tex::Texture(0),
            })],
        );
        textured
            .m
            .textures
            .push(crate::texture::Texture::Checkerboard(
                crate::texture::Checkerboard {
                    color0: Tex::Const(Rgb::new(0.9, 0.5, 0.1)),
                    color1: Tex::value(0.2),
                    to_uv: glam::Affine2::IDENTITY,
                    float_swapped: false,
                },
            ));
        vec![
            Variant::last(
                "difftrans",
                vec![Material::DiffTrans(DiffTrans::new(Rgb::new(0.2, 0.5, 0.9)))],
            ),
            white,
            textured,
        ]
    }
}
