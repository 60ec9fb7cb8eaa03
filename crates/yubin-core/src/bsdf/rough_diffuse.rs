//! `roughdiffuse`: a rough diffuse surface (plaster, clay, concrete,
//! sand): the Oren–Nayar model of V-shaped grooves whose facets are ideal
//! Lambertian reflectors, with shadowing, masking and interreflection.
//!
//! | parameter         | type                     | default | meaning |
//! |-------------------|--------------------------|---------|---------|
//! | `reflectance`     | texture / rgb / spectrum | 0.5     | albedo ρ of the facets (`diffuse_reflectance` is accepted too, as in Mitsuba 0.6) |
//! | `alpha`           | float / texture          | 0.2     | roughness: the RMS slope of the facets, as in the microfacet BSDFs (0 is `diffuse`) |
//! | `use_fast_approx` | boolean                  | false   | the two-term approximation instead of the full qualitative model |
//!
//! ```xml
//! <bsdf type="roughdiffuse">
//!     <rgb name="reflectance" value="0.6, 0.5, 0.4"/>
//!     <float name="alpha" value="0.5"/>
//! </bsdf>
//! ```
//!
//! Mitsuba 0.6's `roughdiffuse`. Its `alpha` is a Beckmann-style RMS
//! slope, so that it means what it means for `roughconductor` and the
//! other rough models; the paper's roughness, the standard deviation σ of
//! the facet slope angle, is σ = α / √2 (Mitsuba 0.6's documented
//! conversion, "a perfect fit up to extreme roughness values (> .5)").
//! With θi, θo the polar angles, φ = φi − φo, α = max(θi, θo) and
//! β = min(θi, θo) (here α is the paper's angle, not the parameter),
//! the full *qualitative* model of Oren & Nayar 1994 (§4) is f = f₁ + f₂
//! with the single-bounce part
//!
//! f₁ = ρ/π [C₁ + cos φ · C₂ · tan β + (1 − |cos φ|) · C₃ · tan((α + β)/2)],
//!
//! - C₁ = 1 − 0.5 σ² / (σ² + 0.33),
//! - C₂ = 0.45 σ² / (σ² + 0.09) · sin α when cos φ ≥ 0, else
//!   0.45 σ² / (σ² + 0.09) · (sin α − (2β/π)³),
//! - C₃ = 0.125 σ² / (σ² + 0.09) · (4αβ/π²)²,
//!
//! and the interreflection part
//!
//! f₂ = 0.17 ρ²/π · σ² / (σ² + 0.13) · [1 − cos φ · (2β/π)²].
//!
//! With `use_fast_approx` it is the paper's simplified qualitative model
//! (interreflection and C₃ dropped, C₂ kept only for cos φ > 0),
//! f = ρ/π [A + B · max(0, cos φ) · sin α · tan β] with
//! A = 1 − 0.5 σ² / (σ² + 0.33) and B = 0.45 σ² / (σ² + 0.09).
//! At α = 0 both are exactly `diffuse`. Either form is symmetric in
//! (θi, θo), hence reciprocal. It is not energy-conserving in general
//! (the fitted coefficients are not normalized); for ρ ≤ 0.9 it reflects
//! less than it receives. A textured `alpha` is read as a float (the
//! luminance; Mitsuba 0.6 averages the channels, the same for grey).
//!
//! Sampling draws the cosine-weighted hemisphere, as for `diffuse`.
//! One-sided (black from below; wrap it in `twosided`). Flagged glossy
//! rather than diffuse (its f is not constant), as in Mitsuba 0.6.
//!
//! References: Oren & Nayar 1994, "Generalization of Lambert's
//! Reflectance Model" (SIGGRAPH '94); Mitsuba 0.6 documentation,
//! `roughdiffuse`; pbrt-v3 §8.4.2 (the simplified model).

use super::{BsdfContext, BsdfFlags, BsdfSample, Scatter};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::sampling::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use crate::spectrum::luminance;
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_1_SQRT_2};

/// The Oren–Nayar rough diffuse reflector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughDiffuse {
    /// Albedo of the facets.
    pub reflectance: Tex,
    /// RMS slope (Beckmann-style roughness); σ = alpha / √2.
    pub alpha: Tex,
    /// The two-term approximation instead of the full model.
    pub fast_approx: bool,
}

impl RoughDiffuse {
    /// A constant albedo and roughness.
    pub fn new(reflectance: Rgb, alpha: f32, fast_approx: bool) -> Self {
        Self {
            reflectance: Tex::Const(reflectance),
            alpha: Tex::value(alpha),
            fast_approx,
        }
    }

    /// Builds the BSDF from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let name = if p.has("diffuse_reflectance") {
            if p.has("reflectance") {
                return Err(p.param_error(
                    "diffuse_reflectance",
                    "give \"reflectance\" or \"diffuse_reflectance\" (its Mitsuba 0.6 \
                     alias), not both",
                ));
            }
            "diffuse_reflectance"
        } else {
            "reflectance"
        };
        let reflectance = p.texture_or(name, ColorKind::Reflectance, Rgb::splat(0.5))?;
        let alpha = p.texture_or("alpha", ColorKind::Reflectance, Rgb::splat(0.2))?;
        if let Some(a) = alpha.as_const().map(luminance) {
            if !(a >= 0.0 && a.is_finite()) {
                return Err(p.param_error(
                    "alpha",
                    &format!("roughness must be zero or positive, not {a}"),
                ));
            }
        }
        Ok(Self {
            reflectance,
            alpha,
            fast_approx: p.boolean_or("use_fast_approx", false)?,
        })
    }
}

impl RoughDiffuse {
    /// Lobes this material has.
    pub fn flags(&self, _: &Materials) -> BsdfFlags {
        BsdfFlags::GLOSSY_REFLECTION | BsdfFlags::FRONT_SIDE
    }

    /// The lobe at `si`.
    #[inline]
    pub fn lobe(&self, m: &Materials, si: &SurfaceInteraction) -> RoughDiffuseLobe {
        RoughDiffuseLobe {
            reflectance: self.reflectance.eval(m, si),
            alpha: self.alpha.eval_1(m, si),
            fast_approx: self.fast_approx,
        }
    }
}

/// [`RoughDiffuse`] at a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughDiffuseLobe {
    /// Albedo.
    pub reflectance: Rgb,
    /// Roughness (the standard deviation of the facet angle, times √2).
    pub alpha: f32,
    /// Only the first term of the Oren–Nayar model.
    pub fast_approx: bool,
}

impl RoughDiffuseLobe {
    /// π f / ρ-weighted factor: f(wo, wi) = g / π with g returned here
    /// (both directions above the surface). The sample weight is g itself.
    #[inline]
    fn g(&self, wo: Vec3, wi: Vec3) -> Rgb {
        let rho = self.reflectance;
        let sigma = self.alpha.max(0.0) * FRAC_1_SQRT_2;
        let s2 = sigma * sigma;
        let sin_i = (1.0 - wi.z * wi.z).max(0.0).sqrt();
        let sin_o = (1.0 - wo.z * wo.z).max(0.0).sqrt();
        // cos(φi − φo) from the projections onto the tangent plane.
        let cos_phi = if sin_i > 1e-4 && sin_o > 1e-4 {
            ((wi.x * wo.x + wi.y * wo.y) / (sin_i * sin_o)).clamp(-1.0, 1.0)
        } else {
            0.0
        };
        // α is the larger polar angle, β the smaller (the larger cosine).
        let (sin_a, cos_a, sin_b, cos_b) = if wi.z > wo.z {
            (sin_o, wo.z, sin_i, wi.z)
        } else {
            (sin_i, wi.z, sin_o, wo.z)
        };
        let tan_b = sin_b / cos_b;
        let c1 = 1.0 - 0.5 * s2 / (s2 + 0.33);
        let k = s2 / (s2 + 0.09);
        if self.fast_approx {
            return rho * (c1 + 0.45 * k * cos_phi.max(0.0) * sin_a * tan_b);
        }
        let (alpha, beta) = (cos_a.clamp(-1.0, 1.0).acos(), cos_b.clamp(-1.0, 1.0).acos());
        let two_beta_pi = 2.0 * beta * FRAC_1_PI;
        let c2 = if cos_phi >= 0.0 {
            0.45 * k * sin_a
        } else {
            0.45 * k * (sin_a - two_beta_pi * two_beta_pi * two_beta_pi)
        };
        let four_ab = 4.0 * alpha * beta * FRAC_1_PI * FRAC_1_PI;
        let c3 = 0.125 * k * four_ab * four_ab;
        // tan((α + β)/2) = (sin α + sin β) / (cos α + cos β).
        let tan_half = (sin_a + sin_b) / (cos_a + cos_b);
        let single = c1 + cos_phi * c2 * tan_b + (1.0 - cos_phi.abs()) * c3 * tan_half;
        let double = 0.17 * s2 / (s2 + 0.13) * (1.0 - cos_phi * two_beta_pi * two_beta_pi);
        rho * single + rho * rho * double
    }
}

impl Scatter for RoughDiffuseLobe {
    #[inline]
    fn sample(&self, _: &BsdfContext, wo: Vec3, _: f32, u2: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = square_to_cosine_hemisphere(u2);
        let pdf = cosine_hemisphere_pdf(wi);
        (pdf > 0.0).then(|| BsdfSample {
            wi,
            pdf,
            eta: 1.0,
            sampled: BsdfFlags::GLOSSY_REFLECTION,
            weight: self.g(wo, wi),
        })
    }

    #[inline]
    fn eval(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        self.g(wo, wi) * (FRAC_1_PI * wi.z)
    }

    #[inline]
    fn pdf(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        cosine_hemisphere_pdf(wi)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::microfacet::tests::MapParams;
    use crate::bsdf::tests::{albedo, flat_si, Variant};
    use crate::bsdf::BsdfModel;
    use crate::bsdf::{Diffuse, Material};
    use crate::sampler::Pcg32;
    use std::f32::consts::PI;

    /// α = 0 (σ = 0) is Lambert, bit for bit, in both modes: eval, pdf
    /// and sample weights.
    #[test]
    fn zero_roughness_is_diffuse() {
        let rho = Rgb::new(0.2, 0.5, 0.9);
        for fast in [false, true] {
            let m = Materials::with_bsdfs(vec![
                Material::RoughDiffuse(RoughDiffuse::new(rho, 0.0, fast)),
                Material::Diffuse(Diffuse::new(rho)),
            ]);
            let (on, lambert) = (m.bsdfs[0], m.bsdfs[1]);
            let (ctx, si) = (BsdfContext::default(), flat_si());
            let mut rng = Pcg32::new(3, 3);
            for _ in 0..2000 {
                let wo = crate::sampling::square_to_uniform_sphere(rng.next_2d());
                let wi = crate::sampling::square_to_uniform_sphere(rng.next_2d());
                assert_eq!(
                    on.eval(&m, &ctx, &si, wo, wi),
                    lambert.eval(&m, &ctx, &si, wo, wi),
                    "fast {fast} wo {wo} wi {wi}"
                );
                assert_eq!(
                    on.pdf(&m, &ctx, &si, wo, wi),
                    lambert.pdf(&m, &ctx, &si, wo, wi)
                );
                let (u1, u2) = (rng.next_f32(), rng.next_2d());
                let a = on.sample(&m, &ctx, &si, wo, u1, u2);
                let b = lambert.sample(&m, &ctx, &si, wo, u1, u2);
                assert_eq!(
                    a.map(|s| (s.wi, s.pdf, s.weight)),
                    b.map(|s| (s.wi, s.pdf, s.weight))
                );
            }
        }
    }

    /// The formulas at hand-computed points: normal incidence and exit
    /// (θi = θo = 0) leaves only C₁ (and the interreflection term), and
    /// the fast approximation agrees with the full model's first two
    /// terms in the plane of incidence.
    #[test]
    fn known_values() {
        let rho = 0.5f32;
        let alpha = 0.6f32;
        let s2 = alpha * alpha / 2.0;
        let c1 = 1.0 - 0.5 * s2 / (s2 + 0.33);
        let c4 = 0.17 * s2 / (s2 + 0.13);
        let (ctx, si) = (BsdfContext::default(), flat_si());
        let full = Materials::with_bsdfs(vec![Material::RoughDiffuse(RoughDiffuse::new(
            Rgb::splat(rho),
            alpha,
            false,
        ))]);
        let f = full.bsdfs[0].eval(&full, &ctx, &si, Vec3::Z, Vec3::Z).x;
        let expected = (rho * c1 + rho * rho * c4) / PI;
        assert!((f - expected).abs() < 1e-6, "{f} vs {expected}");

        // θo = 60°, θi = 30°, same azimuth (cos φ = 1): the fast model is
        // ρ/π (A + B sin 60° tan 30°); the full model adds
        // C₃'s term × 0 and the interreflection ρ² C₄ (1 − (2β/π)²)/π.
        let (to, ti) = (60f32.to_radians(), 30f32.to_radians());
        let wo = Vec3::new(to.sin(), 0.0, to.cos());
        let wi = Vec3::new(ti.sin(), 0.0, ti.cos());
        let b = 0.45 * s2 / (s2 + 0.09);
        let fast_expected = rho / PI * (c1 + b * to.sin() * ti.tan()) * wi.z;
        let fast = Materials::with_bsdfs(vec![Material::RoughDiffuse(RoughDiffuse::new(
            Rgb::splat(rho),
            alpha,
            true,
        ))]);
        let got = fast.bsdfs[0].eval(&fast, &ctx, &si, wo, wi).x;
        assert!(
            (got - fast_expected).abs() < 1e-6,
            "{got} vs {fast_expected}"
        );
        let two_beta_pi = 2.0 * ti / PI;
        let full_expected =
            fast_expected + rho * rho * c4 * (1.0 - two_beta_pi * two_beta_pi) / PI * wi.z;
        let got = full.bsdfs[0].eval(&full, &ctx, &si, wo, wi).x;
        assert!(
            (got - full_expected).abs() < 1e-6,
            "{got} vs {full_expected}"
        );

        // Opposite azimuths (cos φ = −1): C₂ uses sin α − (2β/π)³ and the
        // C₃ term vanishes again.
        let wi = Vec3::new(-ti.sin(), 0.0, ti.cos());
        let c2 = b * (to.sin() - two_beta_pi.powi(3));
        let expected =
            (rho * (c1 - c2 * ti.tan()) + rho * rho * c4 * (1.0 + two_beta_pi * two_beta_pi)) / PI
                * wi.z;
        let got = full.bsdfs[0].eval(&full, &ctx, &si, wo, wi).x;
        assert!((got - expected).abs() < 1e-6, "{got} vs {expected}");
        // Perpendicular azimuths (cos φ = 0): only C₁, C₃ and f₂.
        let wi = Vec3::new(0.0, ti.sin(), ti.cos());
        let c3 = 0.125 * s2 / (s2 + 0.09) * (4.0 * to * ti / (PI * PI)).powi(2);
        let expected = (rho * (c1 + c3 * ((to + ti) / 2.0).tan()) + rho * rho * c4) / PI * wi.z;
        let got = full.bsdfs[0].eval(&full, &ctx, &si, wo, wi).x;
        assert!((got - expected).abs() < 1e-6, "{got} vs {expected}");
    }

    /// Rougher surfaces look flatter: at α = 1 the retro-reflection at a
    /// grazing view is stronger than Lambert's, and the albedo stays
    /// below one for ρ = 0.9.
    #[test]
    fn rough_is_retroreflective_and_bounded() {
        let (ctx, si) = (BsdfContext::default(), flat_si());
        for fast in [false, true] {
            let m = Materials::with_bsdfs(vec![Material::RoughDiffuse(RoughDiffuse::new(
                Rgb::splat(0.9),
                1.0,
                fast,
            ))]);
            let w = Vec3::new(0.8, 0.0, 0.6);
            let f = m.bsdfs[0].eval(&m, &ctx, &si, w, w).x / w.z;
            assert!(f > 0.9 / PI, "fast {fast}: {f}");
            for wo in [Vec3::Z, w, Vec3::new(0.99, 0.0, 0.141)] {
                let a = albedo(&m, 0, wo.normalize());
                assert!(a.x < 1.0, "fast {fast} wo {wo}: {a}");
            }
        }
    }

    #[test]
    fn params() {
        let mut p = MapParams::new()
            .color("diffuse_reflectance", Rgb::new(0.1, 0.2, 0.3))
            .float("alpha", 0.4)
            .boolean("use_fast_approx", true);
        let b = RoughDiffuse::from_params(&mut p).unwrap();
        assert!(p.unread().is_empty(), "{:?}", p.unread());
        assert_eq!(b, RoughDiffuse::new(Rgb::new(0.1, 0.2, 0.3), 0.4, true));
        let d = RoughDiffuse::from_params(&mut MapParams::new()).unwrap();
        assert_eq!(d, RoughDiffuse::new(Rgb::splat(0.5), 0.2, false));
        let mut p = MapParams::new().texture("alpha", 2);
        assert_eq!(
            RoughDiffuse::from_params(&mut p).unwrap().alpha,
            Tex::Texture(2)
        );

        let err = |p: MapParams| RoughDiffuse::from_params(&mut { p }).unwrap_err().0;
        let e = err(MapParams::new().float("alpha", -0.1));
        assert!(e.contains("\"alpha\"") && e.contains("-0.1"), "{e}");
        let e = err(MapParams::new()
            .float("reflectance", 0.5)
            .float("diffuse_reflectance", 0.5));
        assert!(e.contains("not both"), "{e}");
    }

    /// Configurations for the table-driven tests in `bsdf/mod.rs`: both
    /// modes, α from 0 to 1, a textured albedo and a textured α.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let checker = |a: Tex, b: Tex| {
            crate::texture::Texture::Checkerboard(crate::texture::Checkerboard {
                color0: a,
                color1: b,
                to_uv: glam::Affine2::IDENTITY,
                float_swapped: false,
            })
        };
        let mut out = Vec::new();
        for fast in [false, true] {
            for alpha in [0.0, 0.1, 0.3, 0.7, 1.0] {
                out.push(Variant::last(
                    format!("roughdiffuse (α {alpha}, fast {fast})"),
                    vec![Material::RoughDiffuse(RoughDiffuse::new(
                        Rgb::new(0.2, 0.5, 0.9),
                        alpha,
                        fast,
                    ))],
                ));
            }
        }
        let mut textured = Variant::last(
            "roughdiffuse (checkerboard reflectance, α 0.5)",
            vec![Material::RoughDiffuse(RoughDiffuse {
                reflectance: Tex::Texture(0),
                alpha: Tex::value(0.5),
                fast_approx: false,
            })],
        );
        textured.m.textures.push(checker(
            Tex::Const(Rgb::new(0.9, 0.5, 0.1)),
            Tex::value(0.2),
        ));
        out.push(textured);
        let mut rough_tex = Variant::last(
            "roughdiffuse (checkerboard α 0.1 / 0.8)",
            vec![Material::RoughDiffuse(RoughDiffuse {
                reflectance: Tex::value(0.7),
                alpha: Tex::Texture(0),
                fast_approx: false,
            })],
        );
        rough_tex
            .m
            .textures
            .push(checker(Tex::value(0.1), Tex::value(0.8)));
        out.push(rough_tex);
        out
    }
}
