//! `plastic`: a diffuse base under a smooth dielectric coating, as Mitsuba
//! 3 models plastic.
//!
//! | parameter              | type                     | default                  | meaning                                                         |
//! |------------------------|--------------------------|--------------------------|-----------------------------------------------------------------|
//! | `int_ior`              | float or IOR name        | `polypropylene` (1.49)   | index of refraction of the coating                              |
//! | `ext_ior`              | float or IOR name        | `air` (1.000277)         | index of refraction outside                                     |
//! | `specular_reflectance` | texture / rgb / spectrum | 1                        | scales the specular reflection (physically: leave it at 1)      |
//! | `diffuse_reflectance`  | texture / rgb / spectrum | 0.5                      | albedo ρ of the base                                            |
//! | `nonlinear`            | boolean                  | false                    | account for the colour shift of light bouncing inside the coat  |
//!
//! ```xml
//! <bsdf type="plastic">
//!     <rgb name="diffuse_reflectance" value="0.1, 0.27, 0.36"/>
//!     <float name="int_ior" value="1.9"/>
//! </bsdf>
//! ```
//!
//! Light is either reflected specularly at the interface, with the
//! dielectric Fresnel reflectance F, or refracted into the coating, where
//! the base scatters it diffusely, bounces between base and interface, and
//! leaves through the interface again:
//!
//! f(ωo, ωi) cos θi = (1 − F(θo)) (1 − F(θi)) / η² · ρ' / π · cos θi,
//!
//! with ρ' = ρ / (1 − F_dr) (`nonlinear` = false: the multiple bounces
//! scale the base uniformly, so the result keeps the base's hue) or
//! ρ' = ρ / (1 − ρ F_dr) (`nonlinear` = true: each bounce is tinted by ρ
//! again, so colours saturate, as in wet or varnished materials). F_dr is
//! the interface's reflectance of diffuse light from inside, from the
//! published fits of Egan & Hilgeman (1973, η < 1) and d'Eon & Irving
//! (2011, η > 1) that Mitsuba uses. The model is Weidlich & Wilkie 2007,
//! "Arbitrarily layered micro-facet surfaces", in the form of Mitsuba 3's
//! `plastic` plugin documentation; pbrt-v4 §14.3 discusses layered BSDFs.
//!
//! The specular lobe is sampled with probability proportional to
//! F(θo)·s̄ against (1 − F(θo))·(1 − s̄), where s̄ = mean(specular) /
//! (mean(specular) + mean(diffuse)), the channel average for a constant
//! colour, as Mitsuba 3 does. One-sided.

use super::fresnel::{fresnel_dielectric, reflect};
use super::{BsdfContext, BsdfFlags, BsdfSample, Scatter};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::sampling::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use crate::spectrum::ior::ior_from_params;
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// A smooth dielectric coating over a Lambertian base.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plastic {
    /// Scales the specular reflection.
    pub specular_reflectance: Tex,
    /// Albedo of the base.
    pub diffuse_reflectance: Tex,
    /// Interior over exterior index of refraction.
    pub eta: f32,
    /// Reflectance of the interface for diffuse light from inside.
    pub fdr_int: f32,
    /// Bounces inside the coating are tinted by the base each time.
    pub nonlinear: bool,
    /// [`specular_sampling_weight`] of the two reflectances, set when the
    /// BSDF is added to a [`Materials`] (a constant of the BSDF, asked at
    /// every sample).
    pub specular_weight: f32,
}

impl Plastic {
    /// A constant-coloured plastic with relative index `eta`.
    pub fn new(diffuse: Rgb, eta: f32, nonlinear: bool) -> Self {
        Self {
            specular_reflectance: Tex::value(1.0),
            diffuse_reflectance: Tex::Const(diffuse),
            eta,
            fdr_int: fresnel_diffuse_reflectance(1.0 / eta),
            nonlinear,
            specular_weight: specular_sampling_weight(None, Tex::value(1.0), Tex::Const(diffuse)),
        }
    }

    /// Builds the BSDF from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let eta = relative_ior(p)?;
        Ok(Self {
            specular_reflectance: p.texture_or(
                "specular_reflectance",
                ColorKind::Reflectance,
                Rgb::ONE,
            )?,
            diffuse_reflectance: p.texture_or(
                "diffuse_reflectance",
                ColorKind::Reflectance,
                Rgb::splat(0.5),
            )?,
            eta,
            fdr_int: fresnel_diffuse_reflectance(1.0 / eta),
            nonlinear: p.boolean_or("nonlinear", false)?,
            specular_weight: f32::NAN,
        }
        .with_constant_weight())
    }

    /// With the specular sampling weight set where it needs no texture.
    fn with_constant_weight(mut self) -> Self {
        self.specular_weight =
            specular_sampling_weight(None, self.specular_reflectance, self.diffuse_reflectance);
        self
    }

    /// Computes the specular sampling weight from the reflectances in `m`
    /// ([`Materials::add_bsdf`]).
    pub(crate) fn prepare(&mut self, m: &Materials) {
        self.specular_weight =
            specular_sampling_weight(Some(m), self.specular_reflectance, self.diffuse_reflectance);
    }

    /// The diffuse lobe without Fresnel transmittances and cosine:
    /// ρ' / (π η²).
    #[inline]
    fn diffuse(&self, m: &Materials, si: &SurfaceInteraction) -> Rgb {
        let rho = self.diffuse_reflectance.eval(m, si);
        let denom = if self.nonlinear {
            Rgb::ONE - rho * self.fdr_int
        } else {
            Rgb::splat(1.0 - self.fdr_int)
        };
        rho / denom * (FRAC_1_PI / (self.eta * self.eta))
    }
}

/// Mitsuba's split between specular and diffuse samples: s̄ / (s̄ + d̄) of
/// the textures' means (a constant colour's mean is its channel average,
/// as in Mitsuba's RGB mode; a texture's is [`Tex::mean`], read from `m`).
/// NaN where a texture's mean is asked without `m` (a BSDF not yet added
/// to its materials).
pub(super) fn specular_sampling_weight(m: Option<&Materials>, specular: Tex, diffuse: Tex) -> f32 {
    let mean = |t: Tex| match t {
        Tex::Const(c) => Some((c.x + c.y + c.z) / 3.0),
        Tex::Texture(_) => m.map(|m| t.mean(m)),
    };
    match (mean(specular), mean(diffuse)) {
        (Some(s), Some(d)) if s + d > 0.0 => s / (s + d),
        (Some(_), Some(_)) => 0.5,
        _ => f32::NAN,
    }
}

/// Hemispherical average of the Fresnel reflectance of an interface with
/// relative index `eta` for diffuse (cosine-distributed) light: the
/// published fits of Egan & Hilgeman 1973 (η < 1, within 0.1 % for
/// 1/η ≤ 1.5) and d'Eon & Irving 2011, "A quantized-diffusion model for
/// rendering translucent materials", eq. 26 (η ≥ 1), the same pair
/// Mitsuba uses, so that `plastic` matches it.
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    if eta < 1.0 {
        -1.4399 * eta * eta + 0.7099 * eta + 0.6681 + 0.0636 / eta
    } else {
        let x = 1.0 / eta;
        // Horner form of 0.919317 − 3.4793 x + 6.75335 x² − 7.80989 x³
        // + 4.98554 x⁴ − 1.36881 x⁵.
        0.919317 + x * (-3.4793 + x * (6.75335 + x * (-7.80989 + x * (4.98554 - 1.36881 * x))))
    }
}

/// Reads `int_ior` and `ext_ior` (numbers or IOR names; defaults
/// polypropylene and air) and returns their ratio.
pub(super) fn relative_ior(p: &mut dyn Params) -> Result<f32, ParamError> {
    let int_ior = ior_from_params(p, "int_ior", "polypropylene")?;
    let ext_ior = ior_from_params(p, "ext_ior", "air")?;
    if !(int_ior > 0.0 && ext_ior > 0.0) || int_ior == ext_ior {
        return Err(p.error(&format!(
            "int_ior ({int_ior}) and ext_ior ({ext_ior}) must be positive and differ"
        )));
    }
    Ok(int_ior / ext_ior)
}

impl Plastic {
    /// Lobes this material has.
    pub fn flags(&self, _: &Materials) -> BsdfFlags {
        BsdfFlags::DELTA_REFLECTION | BsdfFlags::DIFFUSE_REFLECTION | BsdfFlags::FRONT_SIDE
    }

    /// The lobe at `si`.
    #[inline]
    pub fn lobe(&self, m: &Materials, si: &SurfaceInteraction) -> PlasticLobe {
        PlasticLobe {
            specular_reflectance: self.specular_reflectance.eval(m, si),
            diffuse: self.diffuse(m, si),
            eta: self.eta,
            specular_weight: self.specular_weight,
        }
    }
}

/// [`Plastic`] at a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlasticLobe {
    /// Scales the specular reflection.
    pub specular_reflectance: Rgb,
    /// The diffuse lobe without Fresnel transmittances and cosine.
    pub diffuse: Rgb,
    /// Interior over exterior index of refraction.
    pub eta: f32,
    /// The specular sampling weight.
    pub specular_weight: f32,
}

impl PlasticLobe {
    /// Probability of sampling the specular lobe when F(θo) = `f`.
    #[inline]
    fn prob_specular(&self, f: f32) -> f32 {
        let w = self.specular_weight;
        let (ps, pd) = (f * w, (1.0 - f) * (1.0 - w));
        ps / (ps + pd)
    }
}

impl Scatter for PlasticLobe {
    #[inline]
    fn sample(&self, _: &BsdfContext, wo: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let f_o = fresnel_dielectric(wo.z, self.eta).0;
        let p_spec = self.prob_specular(f_o);
        if u1 < p_spec {
            return Some(BsdfSample {
                wi: reflect(wo),
                pdf: p_spec,
                eta: 1.0,
                sampled: BsdfFlags::DELTA_REFLECTION,
                weight: self.specular_reflectance * (f_o / p_spec),
            });
        }
        let wi = square_to_cosine_hemisphere(u2);
        let p_diff = 1.0 - p_spec;
        let pdf = p_diff * cosine_hemisphere_pdf(wi);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        let f_i = fresnel_dielectric(wi.z, self.eta).0;
        // eval / pdf: the cosine and 1/π cancel against the cosine density.
        let weight = self.diffuse * (std::f32::consts::PI * (1.0 - f_o) * (1.0 - f_i) / p_diff);
        Some(BsdfSample {
            wi,
            pdf,
            eta: 1.0,
            sampled: BsdfFlags::DIFFUSE_REFLECTION,
            weight,
        })
    }

    #[inline]
    fn eval(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        let t_o = 1.0 - fresnel_dielectric(wo.z, self.eta).0;
        let t_i = 1.0 - fresnel_dielectric(wi.z, self.eta).0;
        self.diffuse * (t_o * t_i * wi.z)
    }

    #[inline]
    fn pdf(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let f_o = fresnel_dielectric(wo.z, self.eta).0;
        (1.0 - self.prob_specular(f_o)) * cosine_hemisphere_pdf(wi)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::tests::{flat_si, Variant};
    use crate::bsdf::BsdfModel;
    use crate::bsdf::Material;

    /// Relative IOR of bk7 in air, as Mitsuba computes it.
    const BK7_AIR: f32 = 1.5046 / 1.000277;

    fn close(a: f32, b: f32) -> bool {
        (a - b).abs() <= 1e-3 * b.abs().max(1e-4)
    }

    #[test]
    fn diffuse_fresnel_matches_mitsuba() {
        // mi.fresnel_diffuse_reflectance(1/1.49), (1.49) in Mitsuba 3.9.1.
        assert!(close(fresnel_diffuse_reflectance(1.0 / 1.49), 0.5907325));
        assert!(close(fresnel_diffuse_reflectance(1.49), 0.09029996));
    }

    #[test]
    fn parameters() {
        use crate::bsdf::microfacet::tests::MapParams;
        let mut p = MapParams::new()
            .string("int_ior", "bk7")
            .float("ext_ior", 1.0)
            .boolean("nonlinear", true)
            .color("diffuse_reflectance", Rgb::new(0.1, 0.2, 0.3));
        let b = Plastic::from_params(&mut p).unwrap();
        assert!(p.unread().is_empty(), "{:?}", p.unread());
        assert_eq!(b.eta, crate::spectrum::ior::dielectric_ior("bk7").unwrap());
        assert!(b.nonlinear);
        assert_eq!(b.diffuse_reflectance, Tex::Const(Rgb::new(0.1, 0.2, 0.3)));

        let d = Plastic::from_params(&mut MapParams::new()).unwrap();
        assert_eq!(d, Plastic::new(Rgb::splat(0.5), 1.49 / 1.000277, false));

        let unknown = Plastic::from_params(&mut MapParams::new().string("int_ior", "bk8"));
        assert!(unknown.unwrap_err().0.contains("bk8"));
        let same = Plastic::from_params(&mut MapParams::new().float("int_ior", 1.000277));
        assert!(same.unwrap_err().0.contains("differ"));
    }

    /// Configurations for the table-driven tests in `bsdf/mod.rs`.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let textured = {
            let mut p = Plastic::new(Rgb::ZERO, BK7_AIR, true);
            p.diffuse_reflectance = Tex::Texture(0);
            // Textures first: the BSDF's sampling weight reads their mean.
            let mut m = Materials::default();
            m.textures.push(crate::texture::Texture::Checkerboard(
                crate::texture::Checkerboard {
                    color0: Tex::Const(Rgb::new(0.9, 0.5, 0.1)),
                    color1: Tex::value(0.2),
                    to_uv: glam::Affine2::IDENTITY,
                    float_swapped: false,
                },
            ));
            let id = m.add_bsdf(Material::Plastic(p)) as usize;
            Variant {
                name: "plastic (checkerboard texture)".into(),
                m,
                id,
                lossless: false,
                reciprocal: true,
                energy_conserving: true,
            }
        };
        vec![
            Variant::last(
                "plastic (polypropylene)",
                vec![Material::Plastic(Plastic::new(
                    Rgb::new(0.2, 0.5, 0.9),
                    1.49 / 1.000277,
                    false,
                ))],
            ),
            Variant::last(
                "plastic (bk7, nonlinear, white)",
                vec![Material::Plastic(Plastic::new(Rgb::ONE, BK7_AIR, true))],
            ),
            Variant::last(
                "plastic (η = 2.4)",
                vec![Material::Plastic(Plastic::new(Rgb::splat(0.7), 2.4, false))],
            ),
            textured,
        ]
    }

    /// Configuration, wo, wi, eval, pdf, specular sample's pdf and weight.
    type Case = (char, [f32; 3], [f32; 3], [f32; 3], f32, f32, f32);

    /// eval, pdf and the specular sample (u1 = 0) against Mitsuba 3.9.1
    /// (`scalar_rgb`; `mi.load_dict` of the same plastic, `si.wi` = our
    /// `wo`, `bsdf.eval/pdf(ctx, si, wi)`, `bsdf.sample(ctx, si, 0, ...)`).
    /// A: diffuse (0.2, 0.5, 0.9), polypropylene/air, linear.
    /// B: the same diffuse, bk7/air, nonlinear.
    #[test]
    #[allow(clippy::excessive_precision)] // Mitsuba's printed values, verbatim
    fn values_match_mitsuba() {
        #[rustfmt::skip]
        let cases: [Case; 6] = [
            ('A', [0.3, 0.2, 0.9], [-0.4, 0.1, 0.5], [4.9656134e-02, 1.2414034e-01, 2.2345258e-01], 2.2819354e-01, 7.0802875e-02, 5.5155742e-01),
            ('A', [0.95, -0.1, 0.08], [0.1, 0.3, 0.9], [2.3878265e-02, 5.9695661e-02, 1.0745218e-01], 7.3008314e-02, 7.5689137e-01, 8.2459259e-01),
            ('A', [0.0, 0.0, 1.0], [0.99, 0.0, 0.02], [1.4997285e-04, 3.7493213e-04, 6.7487778e-04], 5.9782593e-03, 7.0138119e-02, 5.5138057e-01),
            ('B', [0.3, 0.2, 0.9], [-0.4, 0.1, 0.5], [2.2567822e-02, 7.0903808e-02, 1.9404985e-01], 2.2738886e-01, 7.4079446e-02, 5.5243105e-01),
            ('B', [0.95, -0.1, 0.08], [0.1, 0.3, 0.9], [1.0828258e-02, 3.4020331e-02, 9.3106985e-02], 7.2631203e-02, 7.5814712e-01, 8.2534039e-01),
            ('B', [0.0, 0.0, 1.0], [0.99, 0.0, 0.02], [6.8014226e-05, 2.1368777e-04, 5.8482162e-04], 5.9572742e-03, 7.3402144e-02, 5.5225027e-01),
        ];
        let rho = Rgb::new(0.2, 0.5, 0.9);
        let (si, ctx) = (flat_si(), BsdfContext::default());
        for (cfg, wo, wi, eval, pdf, spec_pdf, spec_weight) in cases {
            let b = match cfg {
                'A' => Plastic::new(rho, 1.49 / 1.000277, false),
                _ => Plastic::new(rho, BK7_AIR, true),
            };
            let m = Materials::with_bsdfs(vec![Material::Plastic(b)]);
            let (wo, wi) = (Vec3::from(wo).normalize(), Vec3::from(wi).normalize());
            let e = m.bsdfs[0].eval(&m, &ctx, &si, wo, wi);
            for c in 0..3 {
                assert!(
                    close(e[c], eval[c]),
                    "{cfg} {wo} {wi}: eval {e} vs {eval:?}"
                );
            }
            let p = m.bsdfs[0].pdf(&m, &ctx, &si, wo, wi);
            assert!(close(p, pdf), "{cfg} {wo} {wi}: pdf {p} vs {pdf}");
            let s = m.bsdfs[0]
                .sample(&m, &ctx, &si, wo, 0.0, Vec2::splat(0.5))
                .unwrap();
            assert_eq!(s.sampled, BsdfFlags::DELTA_REFLECTION);
            assert_eq!(s.wi, reflect(wo));
            assert!(
                close(s.pdf, spec_pdf),
                "{cfg} {wo}: {} vs {spec_pdf}",
                s.pdf
            );
            assert!(
                close(s.weight.x, spec_weight),
                "{cfg} {wo}: {} vs {spec_weight}",
                s.weight
            );
        }
    }
}
