//! `conductor`: a smooth metal, a perfect mirror weighted by the Fresnel
//! reflectance of a complex index of refraction η + ik.
//!
//! | parameter              | type                     | default  | meaning |
//! |------------------------|--------------------------|----------|---------|
//! | `material`             | string                   | `none`   | a measured metal (`Au`, `Cu`, ...); `none` is a perfect mirror (η = 0, k = 1) |
//! | `eta`                  | texture / rgb / spectrum | 0        | real part of the IOR relative to the exterior (only with `material="none"`) |
//! | `k`                    | texture / rgb / spectrum | 1        | imaginary part, the absorption coefficient (only with `material="none"`) |
//! | `specular_reflectance` | texture / rgb / spectrum | 1        | multiplies the reflectance (not physical; for artistic control) |
//!
//! ```xml
//! <bsdf type="conductor"><string name="material" value="Au"/></bsdf>
//! <bsdf type="conductor">
//!     <rgb name="eta" value="0.2, 0.9, 1.1"/>
//!     <rgb name="k" value="3.9, 2.4, 1.6"/>
//! </bsdf>
//! ```
//!
//! One-sided: black when `wo` is below the surface (wrap it in `twosided`
//! for both sides). The only lobe is a delta reflection, so `eval` and
//! `pdf` are zero and the sample weight is the Fresnel reflectance at
//! cos θo. Radiance and importance are transported alike.
//! Mitsuba 3's `conductor`; pbrt-v4 §9.3.6 (the Fresnel equations of
//! conductors) and §9.4 (`ConductorBxDF` with zero roughness).

use super::fresnel::{fresnel_conductor, reflect};
use super::{BsdfContext, BsdfFlags, BsdfSample, Scatter};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::spectrum::ior::{conductor_ior, CONDUCTOR_NAMES};
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};

/// The complex index of refraction η + ik of a metal, relative to the
/// exterior (shared by `conductor` and `roughconductor`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConductorIor {
    /// Real part η.
    pub eta: Tex,
    /// Imaginary part k.
    pub k: Tex,
}

impl ConductorIor {
    /// The perfect mirror of `material="none"`: η = 0, k = 1 reflect
    /// everything at every angle.
    pub const MIRROR: Self = Self {
        eta: Tex::Const(Rgb::ZERO),
        k: Tex::Const(Rgb::ONE),
    };

    /// Reads `material`, or `eta` and `k` (Mitsuba 3's rule: the explicit
    /// values go with `material="none"`, whose defaults are η = 0, k = 1).
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let material = p.string_or("material", "none")?;
        if material == "none" {
            return Ok(Self {
                eta: p.texture_or("eta", ColorKind::Unbounded, Rgb::ZERO)?,
                k: p.texture_or("k", ColorKind::Unbounded, Rgb::ONE)?,
            });
        }
        if let Some(given) = ["eta", "k"].into_iter().find(|n| p.has(n)) {
            return Err(p.param_error(
                given,
                &format!("give either \"material\" or \"eta\" and \"k\", not both (material is \"{material}\")"),
            ));
        }
        let Some((eta, k)) = conductor_ior(&material) else {
            return Err(p.param_error(
                "material",
                &format!(
                    "unknown conductor \"{material}\"; known: {}",
                    CONDUCTOR_NAMES.join(", ")
                ),
            ));
        };
        Ok(Self {
            eta: Tex::Const(eta),
            k: Tex::Const(k),
        })
    }

    /// (η, k) at `si`.
    #[inline]
    pub fn eval(&self, m: &Materials, si: &SurfaceInteraction) -> (Rgb, Rgb) {
        (self.eta.eval(m, si), self.k.eval(m, si))
    }
}

/// A smooth conductor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conductor {
    /// Complex index of refraction.
    pub ior: ConductorIor,
    /// Factor on the reflectance.
    pub specular_reflectance: Tex,
}

impl Default for Conductor {
    fn default() -> Self {
        Self {
            ior: ConductorIor::MIRROR,
            specular_reflectance: Tex::value(1.0),
        }
    }
}

impl Conductor {
    /// A constant complex IOR η + ik.
    pub fn new(eta: Rgb, k: Rgb) -> Self {
        Self {
            ior: ConductorIor {
                eta: Tex::Const(eta),
                k: Tex::Const(k),
            },
            ..Self::default()
        }
    }

    /// Builds the BSDF from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        Ok(Self {
            ior: ConductorIor::from_params(p)?,
            specular_reflectance: p.texture_or(
                "specular_reflectance",
                ColorKind::Reflectance,
                Rgb::ONE,
            )?,
        })
    }
}

impl Conductor {
    /// Lobes this material has.
    pub fn flags(&self, _: &Materials) -> BsdfFlags {
        BsdfFlags::DELTA_REFLECTION | BsdfFlags::FRONT_SIDE
    }

    /// The lobe at `si`.
    #[inline]
    pub fn lobe(&self, m: &Materials, si: &SurfaceInteraction) -> ConductorLobe {
        ConductorLobe {
            ior: self.ior.eval(m, si),
            specular_reflectance: self.specular_reflectance.eval(m, si),
        }
    }
}

/// [`Conductor`] at a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConductorLobe {
    /// (η, k) of the complex index.
    pub ior: (Rgb, Rgb),
    /// Factor on the reflectance.
    pub specular_reflectance: Rgb,
}

impl Scatter for ConductorLobe {
    #[inline]
    fn sample(&self, _: &BsdfContext, wo: Vec3, _: f32, _: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let (eta, k) = self.ior;
        Some(BsdfSample {
            wi: reflect(wo),
            pdf: 1.0,
            eta: 1.0,
            sampled: BsdfFlags::DELTA_REFLECTION,
            weight: self.specular_reflectance * fresnel_conductor(wo.z, eta, k),
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
    use crate::bsdf::microfacet::tests::MapParams;
    use crate::bsdf::tests::{albedo, flat_si, Variant};
    use crate::bsdf::BsdfModel;
    use crate::bsdf::Material;

    const AU_ETA: Rgb = Rgb::new(0.143, 0.374, 1.442);
    const AU_K: Rgb = Rgb::new(3.983, 2.385, 1.603);

    /// Sample weights of Mitsuba 3.9.1 `scalar_rgb`, from
    /// `mi.load_dict({'type': 'conductor', 'eta': {'type': 'rgb', 'value':
    /// [0.143, 0.374, 1.442]}, 'k': {'type': 'rgb', 'value': [3.983, 2.385,
    /// 1.603]}}).sample(mi.BSDFContext(), si, 0.5, [0.5, 0.5])` with `si.wi`
    /// = `wo` (normalized), `si.sh_frame` around +z.
    #[test]
    fn matches_mitsuba() {
        let cases = [
            (
                Vec3::new(0.3, 0.2, 0.9),
                Rgb::new(0.966_614_8, 0.802_417_16, 0.324_587_7),
            ),
            (
                Vec3::new(-0.6, 0.3, 0.5),
                Rgb::new(0.963_905_3, 0.802_001_24, 0.350_048_8),
            ),
            (
                Vec3::new(0.1, 0.0, 1.0),
                Rgb::new(0.966_687_1, 0.802_536_4, 0.324_036_4),
            ),
            (
                Vec3::new(0.9, -0.1, 0.15),
                Rgb::new(0.964_172_7, 0.881_190_7, 0.606_459_1),
            ),
        ];
        let t = Materials::with_bsdfs(vec![Material::Conductor(Conductor::new(AU_ETA, AU_K))]);
        for (wo, expected) in cases {
            let wo = wo.normalize();
            let s = t.bsdfs[0]
                .sample(
                    &t,
                    &BsdfContext::default(),
                    &flat_si(),
                    wo,
                    0.5,
                    Vec2::splat(0.5),
                )
                .unwrap();
            assert!(
                ((s.weight - expected).abs() / expected).max_element() < 1e-4,
                "wo={wo}: {} vs Mitsuba {expected}",
                s.weight
            );
            assert_eq!(s.wi, Vec3::new(-wo.x, -wo.y, wo.z));
            assert_eq!(
                (s.pdf, s.eta, s.sampled),
                (1.0, 1.0, BsdfFlags::DELTA_REFLECTION)
            );
        }
    }

    #[test]
    fn mirror_reflects_everything_from_the_front_only() {
        let t = Materials::with_bsdfs(vec![Material::Conductor(Conductor::default())]);
        let a = albedo(&t, 0, Vec3::new(0.7, 0.1, 0.2).normalize());
        assert_eq!(a, Rgb::ONE);
        let ctx = BsdfContext::default();
        let wo = Vec3::new(0.1, 0.2, -0.9).normalize();
        assert!(t.bsdfs[0]
            .sample(&t, &ctx, &flat_si(), wo, 0.5, Vec2::splat(0.5))
            .is_none());
        assert_eq!(
            t.bsdfs[0].eval(&t, &ctx, &flat_si(), Vec3::Z, Vec3::Z),
            Rgb::ZERO
        );
    }

    #[test]
    fn params() {
        let mut p = MapParams::new();
        assert_eq!(
            Conductor::from_params(&mut p).unwrap(),
            Conductor::default()
        );

        let mut p = MapParams::new()
            .color("eta", AU_ETA)
            .color("k", AU_K)
            .float("specular_reflectance", 0.5);
        let c = Conductor::from_params(&mut p).unwrap();
        assert!(p.unread().is_empty());
        assert_eq!(c.ior.eta, Tex::Const(AU_ETA));
        assert_eq!(c.specular_reflectance, Tex::value(0.5));

        // `eta` alone keeps the default k = 1, as in Mitsuba.
        let c = Conductor::from_params(&mut MapParams::new().float("eta", 1.5)).unwrap();
        assert_eq!(c.ior.k, Tex::value(1.0));

        let e = Conductor::from_params(&mut MapParams::new().string("material", "Xx"))
            .unwrap_err()
            .0;
        assert!(e.contains("\"Xx\"") && e.contains("none"), "{e}");
        let e =
            Conductor::from_params(&mut MapParams::new().string("material", "Au").float("k", 2.0))
                .unwrap_err()
                .0;
        assert!(e.contains("\"k\"") && e.contains("material"), "{e}");
    }

    /// Configurations for the table-driven tests in `bsdf/mod.rs`.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let mut mirror = Variant::last(
            "conductor (material none)",
            vec![Material::Conductor(Conductor::default())],
        );
        mirror.lossless = true;
        let textured = {
            let mut v = Variant::last(
                "conductor (gold, checkerboard specular_reflectance)",
                vec![Material::Conductor(Conductor {
                    specular_reflectance: Tex::Texture(0),
                    ..Conductor::new(AU_ETA, AU_K)
                })],
            );
            v.m.textures.push(crate::texture::Texture::Checkerboard(
                crate::texture::Checkerboard {
                    color0: Tex::Const(Rgb::new(0.9, 0.5, 0.1)),
                    color1: Tex::value(0.2),
                    to_uv: glam::Affine2::IDENTITY,
                    float_swapped: false,
                },
            ));
            v
        };
        vec![
            mirror,
            Variant::last(
                "conductor (gold)",
                vec![Material::Conductor(Conductor::new(AU_ETA, AU_K))],
            ),
            textured,
        ]
    }
}
