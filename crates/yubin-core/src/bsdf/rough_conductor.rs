//! `roughconductor`: a rough metal, the Torrance–Sparrow microfacet model
//! with a Beckmann, GGX or Phong distribution and the Fresnel reflectance
//! of a complex index of refraction η + ik.
//!
//! | parameter              | type                     | default    | meaning |
//! |------------------------|--------------------------|------------|---------|
//! | `material`             | string                   | `none`     | a measured metal (`Au`, `Cu`, ...); `none` is a perfect mirror (η = 0, k = 1) |
//! | `eta`, `k`             | texture / rgb / spectrum | 0, 1       | complex IOR relative to the exterior (only with `material="none"`) |
//! | `specular_reflectance` | texture / rgb / spectrum | 1          | multiplies the reflectance (not physical) |
//! | `distribution`         | string                   | `beckmann` | `beckmann`, `ggx` or `phong` (isotropic only) |
//! | `alpha`                | float / texture          | 0.1        | isotropic roughness |
//! | `alpha_u`, `alpha_v`   | float / texture          | —          | anisotropic roughness along the tangents (instead of `alpha`) |
//! | `sample_visible`       | boolean                  | true       | sample the normals visible from `wo` |
//!
//! ```xml
//! <bsdf type="roughconductor">
//!     <string name="material" value="Al"/>
//!     <string name="distribution" value="ggx"/>
//!     <float name="alpha" value="0.2"/>
//! </bsdf>
//! ```
//!
//! f(wo, wi) = F(wi·h) D(h) G(wo, wi, h) / (4 cos θo cos θi), h the
//! half vector (Walter et al. 2007, eq. 20; pbrt-v4 §9.6). Samples draw a
//! microfacet normal from [`super::microfacet::Microfacet::sample`] and
//! reflect `wo` about it; the density of `wi` is that of the normal times
//! the Jacobian 1 / (4 wo·h) of reflection. One-sided: black when `wo` or
//! `wi` is below the surface. This single-scattering model loses energy
//! at high roughness (light that would bounce between facets is dropped),
//! as Mitsuba 3's does. Radiance and importance are transported alike.

use super::conductor::ConductorIor;
use super::fresnel::{fresnel_conductor, reflect_m};
use super::microfacet::{Microfacet, Roughness};
use super::{BsdfContext, BsdfFlags, BsdfSample, Scatter};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};

/// A rough conductor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughConductor {
    /// Microfacet distribution parameters.
    pub roughness: Roughness,
    /// Complex index of refraction.
    pub ior: ConductorIor,
    /// Factor on the reflectance.
    pub specular_reflectance: Tex,
}

impl RoughConductor {
    /// Builds the BSDF from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        Ok(Self {
            roughness: Roughness::from_params(p)?,
            ior: ConductorIor::from_params(p)?,
            specular_reflectance: p.texture_or(
                "specular_reflectance",
                ColorKind::Reflectance,
                Rgb::ONE,
            )?,
        })
    }
}

impl RoughConductor {
    /// Lobes this material has.
    pub fn flags(&self, _: &Materials) -> BsdfFlags {
        BsdfFlags::GLOSSY_REFLECTION | BsdfFlags::FRONT_SIDE
    }

    /// The lobe at `si`.
    #[inline]
    pub fn lobe(&self, m: &Materials, si: &SurfaceInteraction) -> RoughConductorLobe {
        RoughConductorLobe {
            distr: self.roughness.at(m, si),
            ior: self.ior.eval(m, si),
            specular_reflectance: self.specular_reflectance.eval(m, si),
        }
    }
}

/// [`RoughConductor`] at a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughConductorLobe {
    /// The facet distribution.
    pub distr: Microfacet,
    /// (η, k) of the complex index.
    pub ior: (Rgb, Rgb),
    /// Factor on the reflectance.
    pub specular_reflectance: Rgb,
}

impl RoughConductorLobe {
    /// F(cos θ) times the reflectance factor.
    #[inline]
    fn fresnel(&self, cos_theta: f32) -> Rgb {
        let (eta, k) = self.ior;
        self.specular_reflectance * fresnel_conductor(cos_theta, eta, k)
    }
}

impl Scatter for RoughConductorLobe {
    #[inline]
    fn sample(&self, _: &BsdfContext, wo: Vec3, _: f32, u2: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let d = self.distr;
        let (h, pdf_h) = d.sample(wo, u2);
        let wi = reflect_m(wo, h);
        let wo_h = wo.dot(h);
        if pdf_h <= 0.0 || wi.z <= 0.0 || wo_h <= 0.0 {
            return None;
        }
        let pdf = pdf_h / (4.0 * wo_h);
        let f = self.fresnel(wo_h);
        // eval / pdf, with the factors that cancel left out: F G1(wi) for
        // visible normals, F G wo·h / (cos θo cos θh) otherwise.
        let weight = if d.samples_visible() {
            f * d.g1(wi, h)
        } else {
            f * (d.g(wo, wi, h) * wo_h / (wo.z * h.z))
        };
        (pdf > 0.0 && pdf.is_finite()).then_some(BsdfSample {
            wi,
            pdf,
            eta: 1.0,
            sampled: BsdfFlags::GLOSSY_REFLECTION,
            weight,
        })
    }

    #[inline]
    fn eval(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        let h = (wo + wi).normalize();
        let d = self.distr;
        let dh = d.d(h);
        if dh == 0.0 || !h.is_finite() {
            return Rgb::ZERO;
        }
        // f cos θi = F D G / (4 cos θo).
        self.fresnel(wi.dot(h)) * (dh * d.g(wo, wi, h) / (4.0 * wo.z))
    }

    #[inline]
    fn pdf(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize();
        let wo_h = wo.dot(h);
        if wo_h <= 0.0 {
            return 0.0;
        }
        self.distr.pdf(wo, h) / (4.0 * wo_h)
    }

    /// [`Scatter::eval`] and [`Scatter::pdf`] sharing the half vector,
    /// D and G1(wo): the same values bit for bit.
    #[inline]
    fn eval_pdf(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (Rgb::ZERO, 0.0);
        }
        let h = (wo + wi).normalize();
        let d = self.distr;
        let (dg, pdf_h) = d.dg_and_pdf(wo, wi, h);
        let value = if dg == 0.0 || !h.is_finite() {
            Rgb::ZERO
        } else {
            self.fresnel(wi.dot(h)) * (dg / (4.0 * wo.z))
        };
        let wo_h = wo.dot(h);
        let pdf = if wo_h <= 0.0 {
            0.0
        } else {
            pdf_h / (4.0 * wo_h)
        };
        (value, pdf)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::microfacet::tests::MapParams;
    use crate::bsdf::microfacet::MicrofacetType;
    use crate::bsdf::tests::{albedo, check_bsdf, check_reciprocity, flat_si, Variant};
    use crate::bsdf::BsdfModel;
    use crate::bsdf::Material;

    const AU_ETA: Rgb = Rgb::new(0.143, 0.374, 1.442);
    const AU_K: Rgb = Rgb::new(3.983, 2.385, 1.603);

    fn rough(kind: MicrofacetType, au: f32, av: f32, visible: bool, eta: Rgb, k: Rgb) -> Material {
        Material::RoughConductor(RoughConductor {
            roughness: Roughness {
                kind,
                alpha_u: Tex::value(au),
                alpha_v: Tex::value(av),
                sample_visible: visible,
            },
            ior: ConductorIor {
                eta: Tex::Const(eta),
                k: Tex::Const(k),
            },
            specular_reflectance: Tex::value(1.0),
        })
    }

    /// (wo, wi) pairs, normalized, at which the Mitsuba values were taken.
    fn pairs() -> [(Vec3, Vec3); 4] {
        [
            (Vec3::new(0.3, 0.2, 0.9), Vec3::new(-0.2, -0.3, 0.8)),
            (Vec3::new(-0.6, 0.3, 0.5), Vec3::new(0.5, -0.1, 0.7)),
            (Vec3::new(0.1, 0.0, 1.0), Vec3::new(0.0, 0.1, 1.0)),
            (Vec3::new(0.9, -0.1, 0.15), Vec3::new(-0.7, 0.2, 0.3)),
        ]
        .map(|(a, b)| (a.normalize(), b.normalize()))
    }

    fn compare(b: Material, expected: &[(Rgb, f32); 4], tol: f32) {
        let t = Materials::with_bsdfs(vec![b]);
        let (ctx, si) = (BsdfContext::default(), flat_si());
        for ((wo, wi), (f, pdf)) in pairs().into_iter().zip(expected) {
            let got_f = t.bsdfs[0].eval(&t, &ctx, &si, wo, wi);
            let got_pdf = t.bsdfs[0].pdf(&t, &ctx, &si, wo, wi);
            assert!(
                ((got_f - *f).abs() / *f).max_element() < tol && (got_pdf - pdf).abs() < tol * pdf,
                "{b:?} wo={wo} wi={wi}: eval {got_f} pdf {got_pdf}, Mitsuba {f} {pdf}"
            );
        }
    }

    /// Against Mitsuba 3.9.1 `scalar_rgb`: `bsdf.eval(mi.BSDFContext(), si,
    /// wi)` and `bsdf.pdf(...)` with `si.wi` = `wo`, `si.sh_frame` around +z,
    /// for `mi.load_dict({'type': 'roughconductor', ...})` with the
    /// parameters written beside each table (eta and k as `rgb` values).
    #[test]
    fn matches_mitsuba() {
        // distribution ggx, alpha 0.3, eta/k = AU_ETA/AU_K (Mitsuba's
        // material "Au" gives the same values to within 7e-4).
        compare(
            rough(MicrofacetType::Ggx, 0.3, 0.3, true, AU_ETA, AU_K),
            &[
                (Rgb::new(0.791_428_4, 0.656_983_1, 0.265_829_7), 0.822_496_5),
                (
                    Rgb::new(0.706_409_9, 0.586_445_03, 0.245_094_7),
                    0.740_361_3,
                ),
                (Rgb::new(0.778_339_4, 0.646_171_6, 0.260_900_1), 0.805_342_4),
                (
                    Rgb::new(0.826_278_5, 0.718_481_1, 0.408_024_2),
                    0.963_634_85,
                ),
            ],
            1e-3,
        );
        // distribution ggx, alpha_u 0.1, alpha_v 0.4, sample_visible false,
        // eta (0.2, 0.9, 1.5), k (3.0, 2.5, 1.2).
        compare(
            rough(
                MicrofacetType::Ggx,
                0.1,
                0.4,
                false,
                Rgb::new(0.2, 0.9, 1.5),
                Rgb::new(3.0, 2.5, 1.2),
            ),
            &[
                (
                    Rgb::new(1.316_335_1, 0.905_056_3, 0.314_598_08),
                    1.439_530_7,
                ),
                (Rgb::new(0.687_134_3, 0.472_848_1, 0.175_206_2), 0.621_787_7),
                (
                    Rgb::new(1.163_603_2, 0.800_065_9, 0.276_943_03),
                    1.254_431_2,
                ),
                (
                    Rgb::new(0.658_027_1, 0.485_085_1, 0.292_429_45),
                    0.440_681_13,
                ),
            ],
            1e-3,
        );
        // distribution beckmann, alpha 0.2, material none. Mitsuba's
        // Beckmann G1 is Walter's rational fit; ours is exact (erfc), which
        // differs here by under 1e-3 (at most 0.4 % in general).
        let v = [1.807_914_7f32, 1.331_185_3, 1.782_116_9, 1.169_850_3];
        compare(
            rough(
                MicrofacetType::Beckmann,
                0.2,
                0.2,
                true,
                Rgb::ZERO,
                Rgb::ONE,
            ),
            &v.map(|x| (Rgb::splat(x), x)),
            1e-3,
        );
    }

    #[test]
    fn chi2_and_reciprocity() {
        let t = Materials::with_bsdfs(vec![rough(
            MicrofacetType::Ggx,
            0.2,
            0.5,
            true,
            AU_ETA,
            AU_K,
        )]);
        check_bsdf(&t, 0, Vec3::new(0.3, 0.2, 0.9).normalize());
        check_reciprocity(&t, 0);
    }

    #[test]
    fn one_sided_and_lossy_when_rough() {
        let t = Materials::with_bsdfs(vec![rough(
            MicrofacetType::Beckmann,
            1.0,
            1.0,
            true,
            Rgb::ZERO,
            Rgb::ONE,
        )]);
        let (ctx, si) = (BsdfContext::default(), flat_si());
        let wo = Vec3::new(0.3, 0.1, -0.8).normalize();
        assert_eq!(t.bsdfs[0].eval(&t, &ctx, &si, wo, Vec3::Z), Rgb::ZERO);
        assert_eq!(t.bsdfs[0].eval(&t, &ctx, &si, Vec3::Z, wo), Rgb::ZERO);
        assert_eq!(t.bsdfs[0].pdf(&t, &ctx, &si, Vec3::Z, wo), 0.0);
        // A perfect mirror at α = 1 keeps only part of the light: single
        // scattering drops what bounces between facets. Mitsuba 3.9.1
        // (`scalar_rgb`, mean of 10⁵ sample weights, same wo) keeps 0.4851
        // (Beckmann) and 0.3126 (GGX).
        let wo = Vec3::new(0.2, 0.0, 0.7).normalize();
        let a = albedo(&t, 0, wo);
        assert!((a.x - 0.4851).abs() < 0.01, "{a}");
        let t = Materials::with_bsdfs(vec![rough(
            MicrofacetType::Ggx,
            1.0,
            1.0,
            true,
            Rgb::ZERO,
            Rgb::ONE,
        )]);
        let a = albedo(&t, 0, wo);
        assert!((a.x - 0.3126).abs() < 0.01, "{a}");
        // Nearly smooth, it keeps nearly everything.
        let t = Materials::with_bsdfs(vec![rough(
            MicrofacetType::Ggx,
            0.01,
            0.01,
            true,
            Rgb::ZERO,
            Rgb::ONE,
        )]);
        let a = albedo(&t, 0, Vec3::new(0.2, 0.0, 0.7).normalize());
        assert!(a.x > 0.999, "{a}");
    }

    #[test]
    fn params() {
        let mut p = MapParams::new()
            .string("distribution", "ggx")
            .float("alpha", 0.3)
            .color("eta", AU_ETA)
            .color("k", AU_K);
        let b = RoughConductor::from_params(&mut p).unwrap();
        assert!(p.unread().is_empty(), "{:?}", p.unread());
        assert_eq!(
            Material::RoughConductor(b),
            rough(MicrofacetType::Ggx, 0.3, 0.3, true, AU_ETA, AU_K)
        );
        let b = RoughConductor::from_params(&mut MapParams::new()).unwrap();
        assert_eq!(
            Material::RoughConductor(b),
            rough(
                MicrofacetType::Beckmann,
                0.1,
                0.1,
                true,
                Rgb::ZERO,
                Rgb::ONE
            )
        );
        assert!(RoughConductor::from_params(&mut MapParams::new().float("alpha", -0.1)).is_err());
    }

    /// Configurations for the table-driven tests in `bsdf/mod.rs`:
    /// Beckmann and GGX with visible sampling on and off, roughness from
    /// 0.01 to 1, anisotropic; Phong from 0.02 to 1.5; a textured
    /// roughness. None is lossless.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let mut out = Vec::new();
        for kind in [MicrofacetType::Beckmann, MicrofacetType::Ggx] {
            for visible in [true, false] {
                for (au, av) in [
                    (0.01, 0.01),
                    (0.1, 0.1),
                    (0.4, 0.4),
                    (1.0, 1.0),
                    (0.05, 0.5),
                ] {
                    out.push(Variant::last(
                        format!(
                            "roughconductor ({kind:?}, α=({au}, {av}), visible {visible}, gold)"
                        ),
                        vec![rough(kind, au, av, visible, AU_ETA, AU_K)],
                    ));
                }
            }
        }
        // Phong (always samples D cos θm; `sample_visible` is ignored).
        for alpha in [0.02, 0.1, 0.4, 1.0, 1.5] {
            out.push(Variant::last(
                format!("roughconductor (Phong, α={alpha}, gold)"),
                vec![rough(
                    MicrofacetType::Phong,
                    alpha,
                    alpha,
                    true,
                    AU_ETA,
                    AU_K,
                )],
            ));
        }
        out.push(Variant::last(
            "roughconductor (GGX, α=0.3, material none)",
            vec![rough(
                MicrofacetType::Ggx,
                0.3,
                0.3,
                true,
                Rgb::ZERO,
                Rgb::ONE,
            )],
        ));
        let mut textured = Variant::last(
            "roughconductor (Beckmann, checkerboard alpha_u, alpha_v 0.2)",
            vec![Material::RoughConductor(RoughConductor {
                roughness: Roughness {
                    kind: MicrofacetType::Beckmann,
                    alpha_u: Tex::Texture(0),
                    alpha_v: Tex::value(0.2),
                    sample_visible: true,
                },
                ior: ConductorIor {
                    eta: Tex::Const(AU_ETA),
                    k: Tex::Const(AU_K),
                },
                specular_reflectance: Tex::value(1.0),
            })],
        );
        textured
            .m
            .textures
            .push(crate::texture::Texture::Checkerboard(
                crate::texture::Checkerboard {
                    color0: Tex::value(0.05),
                    color1: Tex::value(0.6),
                    to_uv: glam::Affine2::IDENTITY,
                    float_swapped: false,
                },
            ));
        out.push(textured);
        out
    }
}
