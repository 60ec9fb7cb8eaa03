//! `roughdielectric`: a rough interface between two dielectrics (frosted or
//! etched glass): the microfacet model of Walter et al. 2007, reflection
//! and refraction through facets distributed by Beckmann, GGX or Phong.
//!
//! | parameter                | type                     | default    | meaning |
//! |--------------------------|--------------------------|------------|---------|
//! | `int_ior`                | float or material name   | `bk7`      | index of refraction inside |
//! | `ext_ior`                | float or material name   | `air`      | index of refraction outside |
//! | `specular_reflectance`   | texture / rgb / spectrum | 1          | scales reflection (not physical) |
//! | `specular_transmittance` | texture / rgb / spectrum | 1          | scales transmission (not physical) |
//! | `distribution`           | string                   | `beckmann` | `beckmann`, `ggx` or `phong` (isotropic only) |
//! | `alpha`, or `alpha_u` and `alpha_v` | float / texture | 0.1    | roughness (see [`Roughness`]) |
//! | `sample_visible`         | boolean                  | true       | sample the visible normals |
//!
//! ```xml
//! <bsdf type="roughdielectric">
//!     <string name="distribution" value="ggx"/>
//!     <float name="alpha" value="0.3"/>
//!     <string name="int_ior" value="bk7"/>
//! </bsdf>
//! ```
//!
//! With h the half vector (wo + wi for reflection, wo + η wi for
//! refraction, η the relative index seen from wo's side, flipped to the
//! outside), F the Fresnel reflectance at wo·h, D the distribution and G
//! Smith's shadowing-masking, f·|cos θi| is
//! F D G / (4 |cos θo|) for reflection and
//! (1 − F) D G η² |wo·h| |wi·h| / (|cos θo| (wo·h + η wi·h)²) for
//! refraction (Walter et al. 2007, eqs. 20 and 21), the latter divided by
//! η² in Radiance mode (as for the smooth `dielectric`).
//!
//! Sampling follows Mitsuba 3: a facet normal from D (or its visible
//! part), then reflection with probability F, else refraction; the weight
//! is D G |wo·h| / (p(h) |cos θo|), which for visible-normal sampling is
//! just G1(wi). Not lossless (energy lost to masking grows with α; at
//! α ≤ 0.1 at least 90 % comes back). Two-sided. Mitsuba 3's
//! `roughdielectric`; pbrt-v4 §9.7.
//!
//! References: Walter, Marschner, Li and Torrance 2007, "Microfacet Models
//! for Refraction through Rough Surfaces" (EGSR); Heitz 2014, "Understanding
//! the Masking-Shadowing Function in Microfacet-Based BRDFs".

use super::dielectric::refraction_scale;
use super::fresnel::{fresnel_dielectric, reflect_m, refract_m};
use super::microfacet::{Microfacet, Roughness};
use super::{BsdfContext, BsdfFlags, BsdfSample, Scatter};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::spectrum::ior::ior_from_params;
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};

/// A rough dielectric interface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughDielectric {
    /// Relative index of refraction, interior over exterior (not 1).
    pub eta: f32,
    /// The facet distribution's parameters.
    pub roughness: Roughness,
    /// Scales the reflected part.
    pub specular_reflectance: Tex,
    /// Scales the transmitted part.
    pub specular_transmittance: Tex,
}

/// The half vector of a (wo, wi) pair and what it takes to use it.
struct Half {
    /// Facet normal, on the outside (z ≥ 0).
    m: Vec3,
    /// Whether wi is on wo's side.
    reflect: bool,
    /// Relative index seen from wo's side (η_t/η_i).
    eta: f32,
}

impl RoughDielectric {
    /// Untinted, with a given relative index and roughness.
    pub fn new(eta: f32, roughness: Roughness) -> Self {
        Self {
            eta,
            roughness,
            specular_reflectance: Tex::value(1.0),
            specular_transmittance: Tex::value(1.0),
        }
    }

    /// Builds the BSDF from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let int_ior = ior_from_params(p, "int_ior", "bk7")?;
        let ext_ior = ior_from_params(p, "ext_ior", "air")?;
        if int_ior == ext_ior {
            // The refraction half vector wo + η wi vanishes for η = 1.
            return Err(p.param_error(
                "int_ior",
                "the interior and exterior indices of refraction must differ",
            ));
        }
        Ok(Self {
            eta: int_ior / ext_ior,
            roughness: Roughness::from_params(p)?,
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

impl RoughDielectric {
    /// Lobes this material has.
    pub fn flags(&self, _: &Materials) -> BsdfFlags {
        BsdfFlags::GLOSSY_REFLECTION
            | BsdfFlags::GLOSSY_TRANSMISSION
            | BsdfFlags::FRONT_SIDE
            | BsdfFlags::BACK_SIDE
    }

    /// The lobe at `si`.
    #[inline]
    pub fn lobe(&self, m: &Materials, si: &SurfaceInteraction) -> RoughDielectricLobe {
        RoughDielectricLobe {
            eta: self.eta,
            distr: self.roughness.at(m, si),
            specular_reflectance: self.specular_reflectance.eval(m, si),
            specular_transmittance: self.specular_transmittance.eval(m, si),
        }
    }
}

/// [`RoughDielectric`] at a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughDielectricLobe {
    /// Relative index of refraction, interior over exterior (not 1).
    pub eta: f32,
    /// The facet distribution.
    pub distr: Microfacet,
    /// Scales the reflected part.
    pub specular_reflectance: Rgb,
    /// Scales the transmitted part.
    pub specular_transmittance: Rgb,
}

impl RoughDielectricLobe {
    #[inline]
    fn half(&self, wo: Vec3, wi: Vec3) -> Option<Half> {
        if wo.z == 0.0 || wi.z == 0.0 {
            return None;
        }
        let reflect = wo.z * wi.z > 0.0;
        let eta = if wo.z > 0.0 { self.eta } else { 1.0 / self.eta };
        let h = if reflect { wo + wi } else { wo + wi * eta };
        let len = h.length();
        // wo + η wi vanishes only for η = 1, which from_params refuses.
        if len <= 0.0 || len.is_nan() {
            return None;
        }
        let m = h / len;
        Some(Half {
            m: if m.z < 0.0 { -m } else { m },
            reflect,
            eta,
        })
    }

    /// The Jacobian |dh/dwi| of the half-vector map.
    #[inline]
    fn dh_dwi(h: &Half, wo: Vec3, wi: Vec3) -> f32 {
        if h.reflect {
            1.0 / (4.0 * wi.dot(h.m).abs())
        } else {
            let denom = wo.dot(h.m) + h.eta * wi.dot(h.m);
            h.eta * h.eta * wi.dot(h.m).abs() / (denom * denom)
        }
    }

    /// The facet distribution sees wo mirrored to the outside.
    #[inline]
    fn facing(wo: Vec3) -> Vec3 {
        if wo.z < 0.0 {
            -wo
        } else {
            wo
        }
    }
}

impl Scatter for RoughDielectricLobe {
    #[inline]
    fn sample(&self, ctx: &BsdfContext, wo: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let distr = self.distr;
        let (h, pdf_h) = distr.sample(Self::facing(wo), u2);
        // Sampling D cos θ (not the visible normals) can draw a facet that
        // faces away from wo: it neither reflects nor refracts wo.
        if pdf_h.is_nan() || pdf_h <= 0.0 || wo.dot(h) * wo.z <= 0.0 {
            return None;
        }
        let (f, cos_theta_t, eta_it, eta_ti) = fresnel_dielectric(wo.dot(h), self.eta);
        let reflect = u1 < f;
        let (wi, eta, tint, sampled) = if reflect {
            let wi = reflect_m(wo, h);
            let tint = self.specular_reflectance;
            (wi, 1.0, tint, BsdfFlags::GLOSSY_REFLECTION)
        } else {
            let wi = refract_m(wo, h, cos_theta_t, eta_ti);
            let tint = self.specular_transmittance * refraction_scale(ctx.mode, eta_it);
            (wi, eta_it, tint, BsdfFlags::GLOSSY_TRANSMISSION)
        };
        // The facet may send the path to the wrong side of the macro-surface
        // (a reflection below it, a refraction back out): no such path.
        if (wi.z * wo.z > 0.0) != reflect || wi.z == 0.0 {
            return None;
        }
        // The half vector of (wo, wi) is h again, up to rounding; taking
        // that one keeps the claimed pdf and weight exactly consistent with
        // pdf() and eval() where they are ill-conditioned (grazing angles).
        let half = self.half(wo, wi)?;
        let h = half.m;
        let pdf_h = distr.pdf(Self::facing(wo), h);
        // Near the critical angle 1 − F is small and sensitive to h.
        let f = fresnel_dielectric(wo.dot(h), self.eta).0;
        let lobe_pdf = if reflect { f } else { 1.0 - f };
        let pdf = pdf_h * lobe_pdf * Self::dh_dwi(&half, wo, wi);
        // eval / pdf with F (or 1 − F) and the Jacobian cancelled.
        let w = distr.d(h) * distr.g(wi, wo, h) * wo.dot(h).abs() / (pdf_h * wo.z.abs());
        if !(pdf > 0.0 && pdf.is_finite() && w.is_finite()) {
            return None;
        }
        Some(BsdfSample {
            wi,
            pdf,
            eta,
            sampled,
            weight: tint * w,
        })
    }

    #[inline]
    fn eval(&self, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> Rgb {
        let Some(h) = self.half(wo, wi) else {
            return Rgb::ZERO;
        };
        let distr = self.distr;
        // G is zero unless h faces both directions from their own sides.
        let dg = distr.d(h.m) * distr.g(wi, wo, h.m);
        if dg == 0.0 {
            return Rgb::ZERO;
        }
        let (f, ..) = fresnel_dielectric(wo.dot(h.m), self.eta);
        if h.reflect {
            self.specular_reflectance * (f * dg / (4.0 * wo.z.abs()))
        } else {
            let (wo_h, wi_h) = (wo.dot(h.m), wi.dot(h.m));
            let denom = wo_h + h.eta * wi_h;
            let v =
                (1.0 - f) * dg * h.eta * h.eta * (wo_h * wi_h).abs() / (wo.z.abs() * denom * denom);
            self.specular_transmittance * (v * refraction_scale(ctx.mode, h.eta))
        }
    }

    #[inline]
    fn pdf(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> f32 {
        let Some(h) = self.half(wo, wi) else {
            return 0.0;
        };
        // Only facets that send wo to wi's side from their front count,
        // as in sampling.
        if wo.dot(h.m) * wo.z <= 0.0 || wi.dot(h.m) * wi.z <= 0.0 {
            return 0.0;
        }
        let distr = self.distr;
        let (f, ..) = fresnel_dielectric(wo.dot(h.m), self.eta);
        let lobe = if h.reflect { f } else { 1.0 - f };
        distr.pdf(Self::facing(wo), h.m) * lobe * Self::dh_dwi(&h, wo, wi)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::microfacet::MicrofacetType;
    use crate::bsdf::tests::{albedo, flat_si, Variant};
    use crate::bsdf::BsdfModel;
    use crate::bsdf::{Material, TransportMode};
    use crate::testing::params::{MapParams, Value};

    const BK7_AIR: f32 = 1.5046 / 1.000_277;

    fn rough(kind: MicrofacetType, alpha: f32, visible: bool, eta: f32) -> Material {
        Material::RoughDielectric(RoughDielectric::new(
            eta,
            Roughness::isotropic(kind, alpha, visible),
        ))
    }

    /// eval and pdf printed by Mitsuba 3.9.1 (`scalar_rgb`) for
    /// `{"type": "roughdielectric", "distribution": "ggx", "alpha": 0.3,
    /// "int_ior": "bk7", "ext_ior": "air"}`: `bsdf.eval(mi.BSDFContext(mode),
    /// si, wi)` and `bsdf.pdf(...)` with `si.wi` = wo (normalised).
    #[test]
    fn matches_mitsuba() {
        // (wo, wi, eval radiance, eval importance, pdf)
        #[allow(clippy::type_complexity)]
        let cases: [([f32; 3], [f32; 3], f32, f32, f32); 9] = [
            // From outside: reflection, then refraction into the glass.
            (
                [0.3, 0.2, 0.9],
                [-0.2, -0.1, 0.8],
                0.036_095_6,
                0.036_095_6,
                0.036_158_9,
            ),
            (
                [0.3, 0.2, 0.9],
                [0.5, -0.3, 0.6],
                0.003_266_07,
                0.003_266_07,
                0.003_334_06,
            ),
            (
                [0.3, 0.2, 0.9],
                [-0.25, -0.1, -0.9],
                6.409_911,
                14.502_852,
                14.532_001,
            ),
            (
                [0.3, 0.2, 0.9],
                [-0.6, 0.1, -0.5],
                0.003_971_61,
                0.008_986_04,
                0.009_275_92,
            ),
            (
                [-0.5, 0.1, 0.4],
                [0.3, 0.0, 0.9],
                0.017_199_8,
                0.017_199_8,
                0.017_242_7,
            ),
            // From inside: internal reflection, then refraction out.
            (
                [0.2, -0.3, -0.8],
                [-0.2, 0.3, -0.7],
                0.044_389_4,
                0.044_389_4,
                0.044_652_8,
            ),
            (
                [0.2, -0.3, -0.8],
                [-0.3, 0.4, 0.8],
                15.168_056,
                6.703_913,
                6.762_326,
            ),
            (
                [0.2, -0.3, -0.8],
                [-0.5, 0.5, 0.5],
                0.782_577_5,
                0.345_880_3,
                0.360_801_2,
            ),
            // Beyond the critical angle no facet refracts this pair.
            ([0.6, 0.0, -0.3], [-0.2, 0.0, 0.9], 0.0, 0.0, 0.0),
        ];
        let t = Materials::with_bsdfs(vec![rough(MicrofacetType::Ggx, 0.3, true, BK7_AIR)]);
        let (b, si) = (&t.bsdfs[0], flat_si());
        for (wo, wi, rad, imp, pdf) in cases {
            let (wo, wi) = (
                Vec3::from_array(wo).normalize(),
                Vec3::from_array(wi).normalize(),
            );
            for (mode, want) in [
                (TransportMode::Radiance, rad),
                (TransportMode::Importance, imp),
            ] {
                let ctx = BsdfContext {
                    mode,
                    ..BsdfContext::default()
                };
                let got = b.eval(&t, &ctx, &si, wo, wi);
                assert!(
                    (got - Rgb::splat(want)).abs().max_element() <= 1e-4 * want.max(1e-3),
                    "eval {mode:?} wo {wo} wi {wi}: {got} vs Mitsuba {want}"
                );
            }
            let got = b.pdf(&t, &BsdfContext::default(), &si, wo, wi);
            assert!(
                (got - pdf).abs() <= 1e-4 * pdf.max(1e-3),
                "pdf wo {wo} wi {wi}: {got} vs Mitsuba {pdf}"
            );
        }
    }

    /// Nearly lossless at low roughness: masking takes a little, so the
    /// albedo (in Importance mode, where refraction does not rescale) is
    /// between 0.9 and 1.
    #[test]
    fn low_roughness_albedo() {
        for kind in [MicrofacetType::Beckmann, MicrofacetType::Ggx] {
            for alpha in [0.01, 0.05, 0.1] {
                for eta in [BK7_AIR, 1.0 / BK7_AIR, 2.419] {
                    let t = Materials::with_bsdfs(vec![rough(kind, alpha, true, eta)]);
                    for wo in [
                        Vec3::new(0.3, 0.2, 0.9).normalize(),
                        Vec3::new(0.8, 0.1, 0.3).normalize(),
                        Vec3::new(0.2, -0.3, -0.8).normalize(),
                    ] {
                        let a = albedo(&t, 0, wo).x;
                        assert!(
                            (0.9..=1.0 + 2e-3).contains(&a),
                            "{kind:?} α {alpha} η {eta} wo {wo}: albedo {a}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn from_params() {
        let mut p = MapParams::new()
            .with("distribution", Value::String("ggx".into()))
            .with("alpha", Value::Float(0.3))
            .with("int_ior", Value::String("diamond".into()))
            .with("specular_reflectance", Value::Float(0.5));
        let r = RoughDielectric::from_params(&mut p).unwrap();
        assert!((r.eta - 2.419 / 1.000_277).abs() < 1e-6);
        assert_eq!(
            r.roughness,
            Roughness::isotropic(MicrofacetType::Ggx, 0.3, true)
        );
        assert_eq!(r.specular_reflectance, Tex::value(0.5));
        assert!(p.unread().is_empty());
        let mut p = MapParams::new()
            .with("int_ior", Value::Float(1.3))
            .with("ext_ior", Value::Float(1.3));
        let e = RoughDielectric::from_params(&mut p).unwrap_err().0;
        assert!(e.contains("must differ"), "{e}");
    }

    /// Narrow lobes, which the table-driven test (α ≥ 0.05) cannot
    /// resolve near the pole of its (cos θ, φ) grid: α = 0.01 seen from
    /// 53° off the normal, where the lobes fall in cells its adaptive
    /// integration resolves.
    #[test]
    fn chi2_narrow_lobes() {
        use crate::sampler::Pcg32;
        use crate::testing::chi2::{chi2_directions, Chi2Config};
        let wo = Vec3::new(-0.6, 0.3, 0.5).normalize();
        for kind in [MicrofacetType::Beckmann, MicrofacetType::Ggx] {
            for wo in [wo, -wo] {
                let t = Materials::with_bsdfs(vec![rough(kind, 0.01, true, BK7_AIR)]);
                let (b, si, ctx) = (t.bsdfs[0], flat_si(), BsdfContext::default());
                let cfg = Chi2Config {
                    samples: 400_000,
                    alpha: 0.01 / 4.0,
                    ..Default::default()
                };
                chi2_directions(
                    &cfg,
                    |r: &mut Pcg32| {
                        let u1 = r.next_f32();
                        let s = b.sample(&t, &ctx, &si, wo, u1, r.next_2d())?;
                        Some((s.wi, s.pdf))
                    },
                    |wi| b.pdf(&t, &ctx, &si, wo, wi),
                )
                .unwrap_or_else(|e| panic!("{kind:?} wo {wo}: {e}"));
            }
        }
    }

    /// Configurations for the table-driven tests in `bsdf/mod.rs`.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let mut v = Vec::new();
        for kind in [MicrofacetType::Beckmann, MicrofacetType::Ggx] {
            for visible in [true, false] {
                for (alpha, eta) in [
                    (0.05, BK7_AIR),
                    (0.1, 1.33),
                    (0.3, BK7_AIR),
                    (0.6, 1.0 / 1.5),
                    (1.0, 2.419),
                ] {
                    v.push(Variant::last(
                        format!(
                            "roughdielectric ({kind:?}, α {alpha}, η {eta}, visible {visible})"
                        ),
                        vec![rough(kind, alpha, visible, eta)],
                    ));
                }
            }
            v.push(Variant::last(
                format!("roughdielectric ({kind:?}, anisotropic 0.05 × 0.4, η 1.5, tinted)"),
                vec![Material::RoughDielectric(RoughDielectric {
                    eta: 1.5,
                    roughness: Roughness {
                        kind,
                        alpha_u: Tex::value(0.05),
                        alpha_v: Tex::value(0.4),
                        sample_visible: true,
                    },
                    specular_reflectance: Tex::Const(Rgb::new(0.9, 0.6, 0.3)),
                    specular_transmittance: Tex::Const(Rgb::new(0.4, 0.7, 1.0)),
                })],
            ));
        }
        // Phong, smooth to very rough.
        for (alpha, eta) in [
            (0.05, BK7_AIR),
            (0.1, 1.33),
            (0.2, 1.0 / 1.5),
            (0.6, BK7_AIR),
            (1.0, 1.33),
        ] {
            v.push(Variant::last(
                format!("roughdielectric (Phong, α {alpha}, η {eta})"),
                vec![rough(MicrofacetType::Phong, alpha, true, eta)],
            ));
        }
        v
    }
}
