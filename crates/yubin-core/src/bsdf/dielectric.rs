//! `dielectric`: a smooth interface between two dielectrics (glass,
//! water): mirror reflection and refraction by Snell's law, weighted by the
//! exact unpolarized Fresnel reflectance.
//!
//! | parameter                | type                     | default | meaning |
//! |--------------------------|--------------------------|---------|---------|
//! | `int_ior`                | float or material name   | `bk7`   | index of refraction inside (the side the normal points away from) |
//! | `ext_ior`                | float or material name   | `air`   | index of refraction outside |
//! | `specular_reflectance`   | texture / rgb / spectrum | 1       | scales reflection (not physical; for artists) |
//! | `specular_transmittance` | texture / rgb / spectrum | 1       | scales transmission (not physical) |
//!
//! Names are those of [`crate::spectrum::ior::DIELECTRIC_NAMES`] (`water`,
//! `diamond`, ...); an IOR must be positive.
//!
//! ```xml
//! <bsdf type="dielectric">
//!     <string name="int_ior" value="water"/>
//!     <float name="ext_ior" value="1.0"/>
//! </bsdf>
//! ```
//!
//! Both lobes are delta: sampling picks reflection with the
//! probability F (the Fresnel reflectance), so the weight is the
//! reflectance or transmittance parameter alone, and `pdf` the lobe's
//! probability. Radiance carried through the interface is scaled by
//! 1/η² (the change of solid angle compresses it: Veach 1997, §5.2), in
//! Radiance mode only; importance is not. Two-sided: a ray from inside sees
//! the inverse relative index. Mitsuba 3's `dielectric`; pbrt-v4 §9.5.

use super::fresnel::{fresnel_dielectric, reflect, refract};
use super::{BsdfContext, BsdfFlags, BsdfSample, Scatter, TransportMode};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::spectrum::ior::ior_from_params;
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};

/// A smooth dielectric interface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dielectric {
    /// Relative index of refraction, interior over exterior.
    pub eta: f32,
    /// Scales the reflected part.
    pub specular_reflectance: Tex,
    /// Scales the transmitted part.
    pub specular_transmittance: Tex,
}

impl Dielectric {
    /// An interface of relative index `eta` with unit reflectance and
    /// transmittance.
    pub fn new(eta: f32) -> Self {
        Self {
            eta,
            specular_reflectance: Tex::value(1.0),
            specular_transmittance: Tex::value(1.0),
        }
    }

    /// Builds the BSDF from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let int_ior = ior_from_params(p, "int_ior", "bk7")?;
        let ext_ior = ior_from_params(p, "ext_ior", "air")?;
        Ok(Self {
            eta: int_ior / ext_ior,
            specular_reflectance: p.texture_or(
                "specular_reflectance",
                ColorKind::Reflectance,
                Rgb::ONE,
            )?,
            specular_transmittance: p.texture_or(
                "specular_transmittance",
                ColorKind::Reflectance,
                Rgb::ONE,
            )?,
        })
    }
}

/// The factor by which a refracted path's throughput is scaled when it
/// crosses into a medium `eta_it` = η_t/η_i times denser: 1/η² for
/// radiance, 1 for importance (Veach 1997, §5.2). Shared with the other
/// refracting BSDFs.
#[inline]
pub(crate) fn refraction_scale(mode: TransportMode, eta_it: f32) -> f32 {
    match mode {
        TransportMode::Radiance => 1.0 / (eta_it * eta_it),
        TransportMode::Importance => 1.0,
    }
}

impl Dielectric {
    /// Lobes this material has.
    pub fn flags(&self, _: &Materials) -> BsdfFlags {
        BsdfFlags::DELTA_REFLECTION
            | BsdfFlags::DELTA_TRANSMISSION
            | BsdfFlags::FRONT_SIDE
            | BsdfFlags::BACK_SIDE
    }

    /// The lobe at `si`.
    #[inline]
    pub fn lobe(&self, m: &Materials, si: &SurfaceInteraction) -> DielectricLobe {
        DielectricLobe {
            eta: self.eta,
            specular_reflectance: self.specular_reflectance.eval(m, si),
            specular_transmittance: self.specular_transmittance.eval(m, si),
        }
    }
}

/// [`Dielectric`] at a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DielectricLobe {
    /// Relative index of refraction, interior over exterior.
    pub eta: f32,
    /// Scales the reflected part.
    pub specular_reflectance: Rgb,
    /// Scales the transmitted part.
    pub specular_transmittance: Rgb,
}

impl Scatter for DielectricLobe {
    #[inline]
    fn sample(&self, ctx: &BsdfContext, wo: Vec3, u1: f32, _: Vec2) -> Option<BsdfSample> {
        let (f, cos_theta_t, eta_it, eta_ti) = fresnel_dielectric(wo.z, self.eta);
        Some(if u1 < f {
            BsdfSample {
                wi: reflect(wo),
                pdf: f,
                eta: 1.0,
                sampled: BsdfFlags::DELTA_REFLECTION,
                weight: self.specular_reflectance,
            }
        } else {
            BsdfSample {
                wi: refract(wo, cos_theta_t, eta_ti),
                pdf: 1.0 - f,
                eta: eta_it,
                sampled: BsdfFlags::DELTA_TRANSMISSION,
                weight: self.specular_transmittance * refraction_scale(ctx.mode, eta_it),
            }
        })
    }

    #[inline]
    fn eval(&self, _: &BsdfContext, _: Vec3, _: Vec3) -> Rgb {
        Rgb::ZERO
    }

    #[inline]
    fn pdf(&self, _: &BsdfContext, _: Vec3, _: Vec3) -> f32 {
        0.0
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::tests::{flat_si, Variant};
    use crate::bsdf::BsdfModel;
    use crate::bsdf::Material;
    use crate::testing::params::{MapParams, Value};

    /// Sample weights, lobe probabilities, directions and η printed by
    /// Mitsuba 3.9.1 (`scalar_rgb`): `bsdf.sample(mi.BSDFContext(mode), si,
    /// u1, [0.5, 0.5])` with `si.wi` = wo, for the default dielectric (bk7
    /// in air) and for `int_ior` 1.33 inside `ext_ior` "diamond", with
    /// `specular_reflectance` 0.5 and `specular_transmittance` 0.8 where
    /// noted.
    #[test]
    fn matches_mitsuba() {
        let bk7 = 1.5046 / 1.000_277;
        let water_in_diamond = 1.33 / 2.419;
        // (eta, wo, u1, wi, pdf, eta out, radiance weight, importance weight)
        #[allow(clippy::type_complexity)]
        let cases: [(f32, [f32; 3], f32, [f32; 3], f32, f32, f32, f32); 8] = [
            (
                bk7,
                [0.309426, 0.206284, 0.928279],
                0.01,
                [-0.309426, -0.206284, 0.928279],
                0.040924,
                1.0,
                1.0,
                1.0,
            ),
            (
                bk7,
                [0.309426, 0.206284, 0.928279],
                0.99,
                [-0.205711, -0.13714, -0.968956],
                0.959076,
                1.504183,
                0.441_975_83,
                1.0,
            ),
            (
                bk7,
                [0.963087, 0.120386, 0.240772],
                0.99,
                [-0.640272, -0.080034, -0.763967],
                0.722786,
                1.504183,
                0.441_975_83,
                1.0,
            ),
            (
                bk7,
                [0.227921, -0.341882, -0.911685],
                0.99,
                [-0.342835, 0.514253, 0.786135],
                0.954852,
                0.664813,
                2.262_567_3,
                1.0,
            ),
            // Total internal reflection from inside.
            (
                bk7,
                [0.894427, 0.0, -0.447214],
                0.99,
                [-0.894427, 0.0, -0.447214],
                1.0,
                1.0,
                1.0,
                1.0,
            ),
            (
                water_in_diamond,
                [0.309426, 0.206284, 0.928279],
                0.99,
                [-0.562784, -0.375189, -0.736551],
                0.906518,
                0.549814,
                3.308_022_5,
                1.0,
            ),
            (
                water_in_diamond,
                [0.963087, 0.120386, 0.240772],
                0.99,
                [-0.963087, -0.120386, 0.240772],
                1.0,
                1.0,
                1.0,
                1.0,
            ),
            (
                water_in_diamond,
                [0.894427, 0.0, -0.447214],
                0.99,
                [-0.491769, 0.0, 0.870726],
                0.842851,
                1.818797,
                0.302_295_4,
                1.0,
            ),
        ];
        let si = flat_si();
        for (eta, wo, u1, wi, pdf, eta_out, w_rad, w_imp) in cases {
            let t = Materials::with_bsdfs(vec![Material::Dielectric(Dielectric::new(eta))]);
            let b = &t.bsdfs[0];
            for (mode, w) in [
                (TransportMode::Radiance, w_rad),
                (TransportMode::Importance, w_imp),
            ] {
                let ctx = BsdfContext {
                    mode,
                    ..BsdfContext::default()
                };
                let wo = Vec3::from_array(wo);
                let s = b.sample(&t, &ctx, &si, wo, u1, Vec2::splat(0.5)).unwrap();
                let msg = format!("η {eta} wo {wo} u1 {u1} {mode:?}: {s:?}");
                assert!(
                    (s.wi - Vec3::from_array(wi)).abs().max_element() < 2e-5,
                    "{msg}"
                );
                assert!((s.pdf - pdf).abs() < 2e-5, "{msg}");
                assert!((s.eta - eta_out).abs() < 2e-5, "{msg}");
                assert!(
                    (s.weight - Rgb::splat(w)).abs().max_element() < 2e-5,
                    "{msg}"
                );
            }
        }
        // The artist's scales multiply the weights (Mitsuba: 0.5 for the
        // reflection; 0.353 581 = 0.8 / 1.504 183² for the transmission).
        let tinted = Dielectric {
            specular_reflectance: Tex::value(0.5),
            specular_transmittance: Tex::value(0.8),
            ..Dielectric::new(bk7)
        };
        let t = Materials::with_bsdfs(vec![Material::Dielectric(tinted)]);
        let wo = Vec3::new(0.309426, 0.206284, 0.928279);
        let ctx = BsdfContext::default();
        let r = t.bsdfs[0]
            .sample(&t, &ctx, &si, wo, 0.01, Vec2::ZERO)
            .unwrap();
        let tr = t.bsdfs[0]
            .sample(&t, &ctx, &si, wo, 0.99, Vec2::ZERO)
            .unwrap();
        assert!((r.weight.x - 0.5).abs() < 1e-6 && (tr.weight.x - 0.353_580_7).abs() < 1e-5);
    }

    #[test]
    fn from_params_defaults_and_errors() {
        let mut p = MapParams::new();
        let d = Dielectric::from_params(&mut p).unwrap();
        assert!((d.eta - 1.504_183).abs() < 1e-6);
        let mut p = MapParams::new()
            .with("int_ior", Value::String("water".into()))
            .with("ext_ior", Value::Float(1.0))
            .with(
                "specular_transmittance",
                Value::Rgb(Rgb::new(0.9, 0.8, 0.7)),
            );
        let d = Dielectric::from_params(&mut p).unwrap();
        assert_eq!(d.eta, 1.333);
        assert_eq!(
            d.specular_transmittance,
            Tex::Const(Rgb::new(0.9, 0.8, 0.7))
        );
        assert!(p.unread().is_empty());
        let mut p = MapParams::new().with("int_ior", Value::String("unobtainium".into()));
        let e = Dielectric::from_params(&mut p).unwrap_err().0;
        assert!(e.contains("known: vacuum, helium"), "{e}");
        let mut p = MapParams::new().with("ext_ior", Value::Float(-1.0));
        assert!(Dielectric::from_params(&mut p).is_err());
    }

    /// Configurations for the table-driven tests in `bsdf/mod.rs`.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let mut v: Vec<Variant> = [
            1.5046 / 1.000_277,
            1.333,
            2.419,
            1.0 / 1.5,
            1.33 / 2.419,
            1.0,
        ]
        .into_iter()
        .map(|eta| {
            let mut v = Variant::last(
                format!("dielectric (η {eta})"),
                vec![Material::Dielectric(Dielectric::new(eta))],
            );
            v.lossless = true;
            v
        })
        .collect();
        v.push(Variant::last(
            "dielectric (tinted)",
            vec![Material::Dielectric(Dielectric {
                specular_reflectance: Tex::Const(Rgb::new(0.9, 0.5, 0.2)),
                specular_transmittance: Tex::Const(Rgb::new(0.3, 0.8, 1.0)),
                ..Dielectric::new(1.5)
            })],
        ));
        v
    }
}
