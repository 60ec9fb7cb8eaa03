//! `phong`: the modified Phong BRDF, a Lambertian term plus a normalized
//! cosine-power lobe around the mirror direction.
//!
//! | parameter              | type                     | default | meaning |
//! |------------------------|--------------------------|---------|---------|
//! | `exponent`             | float / texture          | 30      | Phong exponent n ≥ 0 (sharper lobe for larger n) |
//! | `specular_reflectance` | texture / rgb / spectrum | 0.2     | weight ρs of the specular lobe |
//! | `diffuse_reflectance`  | texture / rgb / spectrum | 0.5     | albedo ρd of the diffuse term |
//!
//! ```xml
//! <bsdf type="phong">
//!     <float name="exponent" value="80"/>
//!     <rgb name="specular_reflectance" value="0.3"/>
//!     <rgb name="diffuse_reflectance" value="0.1, 0.2, 0.5"/>
//! </bsdf>
//! ```
//!
//! f(wo, wi) = ρd / π + ρs (n + 2) / (2π) · cosⁿ α, with α the angle
//! between wi and the mirror direction of wo (the lobe is 0 past 90°):
//! Lafortune & Willems 1994, "Using the modified Phong reflectance model
//! for physically based rendering" (KU Leuven report CW 197). f is
//! reciprocal. The lobe's factor (n + 2)/(2π) makes its albedo exactly ρs
//! at normal incidence and less elsewhere (part of it falls below the
//! horizon), so **ρd + ρs ≤ 1 (per channel) keeps the model
//! energy-conserving**. As Mitsuba 0.6 documents, constant reflectances
//! that add up to more are scaled down to a sum of one (with a warning);
//! textured ones are used as given.
//!
//! Sampling picks the specular lobe with probability s̄ / (s̄ + d̄), the
//! mean reflectances (Mitsuba 0.6's choice), and then draws wi with
//! density (n + 1)/(2π) cosⁿ α around the mirror direction (Lafortune &
//! Willems §4; samples below the surface are lost, a sample-less draw),
//! else the cosine-weighted hemisphere; the pdf is the mixture of both.
//! A textured exponent is read as a float (its luminance), clamped at 0.
//! At n = 0 the lobe is ρs / π on the half of the hemisphere within 90°
//! of the mirror direction, whose albedo is ρs (1 + cos θo)/2.
//! One-sided. Mitsuba 0.6's `phong`.
//!
//! References: Phong 1975, "Illumination for computer generated
//! pictures"; Lafortune & Willems 1994 (above); Mitsuba 0.6
//! documentation, `phong`.

use super::plastic::specular_sampling_weight;
use super::{BsdfContext, BsdfFlags, BsdfSample, Scatter};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::math::Frame;
use crate::params::{ColorKind, ParamError, Params};
use crate::sampling::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use crate::spectrum::luminance;
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// The modified Phong BRDF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Phong {
    /// Phong exponent n.
    pub exponent: Tex,
    /// Weight of the specular lobe.
    pub specular_reflectance: Tex,
    /// Albedo of the diffuse term.
    pub diffuse_reflectance: Tex,
}

impl Phong {
    /// Constant parameters.
    pub fn new(exponent: f32, specular: Rgb, diffuse: Rgb) -> Self {
        Self {
            exponent: Tex::value(exponent),
            specular_reflectance: Tex::Const(specular),
            diffuse_reflectance: Tex::Const(diffuse),
        }
    }

    /// Builds the BSDF from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let exponent = p.texture_or("exponent", ColorKind::Reflectance, Rgb::splat(30.0))?;
        if let Some(n) = exponent.as_const().map(luminance) {
            if !(n >= 0.0 && n.is_finite()) {
                return Err(p.param_error(
                    "exponent",
                    &format!("the Phong exponent must be zero or positive, not {n}"),
                ));
            }
        }
        let mut specular = p.texture_or(
            "specular_reflectance",
            ColorKind::Reflectance,
            Rgb::splat(0.2),
        )?;
        let mut diffuse = p.texture_or(
            "diffuse_reflectance",
            ColorKind::Reflectance,
            Rgb::splat(0.5),
        )?;
        if let (Tex::Const(s), Tex::Const(d)) = (specular, diffuse) {
            let sum = (s + d).max_element();
            if sum > 1.0 {
                p.warn(
                    None,
                    &format!(
                        "diffuse_reflectance + specular_reflectance reaches {sum} > 1, which \
                         creates energy; both are scaled by 1/{sum} (as Mitsuba 0.6 does)"
                    ),
                );
                specular = Tex::Const(s / sum);
                diffuse = Tex::Const(d / sum);
            }
        }
        Ok(Self {
            exponent,
            specular_reflectance: specular,
            diffuse_reflectance: diffuse,
        })
    }

    /// The exponent at `si`.
    #[inline]
    fn n(&self, m: &Materials, si: &SurfaceInteraction) -> f32 {
        self.exponent.eval_1(m, si).max(0.0)
    }

    /// Probability of sampling the specular lobe.
    #[inline]
    fn prob_specular(&self, m: &Materials) -> f32 {
        specular_sampling_weight(Some(m), self.specular_reflectance, self.diffuse_reflectance)
    }
}

/// cos α: wi against the mirror direction of wo about +z.
#[inline]
fn cos_alpha(wo: Vec3, wi: Vec3) -> f32 {
    wi.z * wo.z - wi.x * wo.x - wi.y * wo.y
}

/// The specular lobe's sampling density (n + 1)/(2π) cosⁿ α (0 past 90°).
#[inline]
fn lobe_pdf(n: f32, cos_a: f32) -> f32 {
    if cos_a <= 0.0 {
        return 0.0;
    }
    (n + 1.0) * (0.5 * FRAC_1_PI) * cos_a.powf(n)
}

impl Phong {
    /// Lobes this material has.
    pub fn flags(&self, _: &Materials) -> BsdfFlags {
        BsdfFlags::DIFFUSE_REFLECTION | BsdfFlags::GLOSSY_REFLECTION | BsdfFlags::FRONT_SIDE
    }

    /// The lobe at `si`.
    #[inline]
    pub fn lobe(&self, m: &Materials, si: &SurfaceInteraction) -> PhongLobe {
        PhongLobe {
            n: self.n(m, si),
            specular_reflectance: self.specular_reflectance.eval(m, si),
            diffuse_reflectance: self.diffuse_reflectance.eval(m, si),
            p_spec: self.prob_specular(m),
        }
    }
}

/// [`Phong`] at a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhongLobe {
    /// The exponent.
    pub n: f32,
    /// Scales the specular lobe.
    pub specular_reflectance: Rgb,
    /// Albedo of the diffuse lobe.
    pub diffuse_reflectance: Rgb,
    /// Probability of sampling the specular lobe.
    pub p_spec: f32,
}

impl Scatter for PhongLobe {
    #[inline]
    fn sample(&self, ctx: &BsdfContext, wo: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let (wi, sampled) = if u1 < self.p_spec {
            // cos α = u^{1/(n+1)}: the inverse CDF of (n + 1) cosⁿ α sin α;
            // sin² α = 1 − u^{2/(n+1)} through expm1, which stays accurate
            // for large n.
            let n = self.n;
            let l = u2.x.max(f32::MIN_POSITIVE).ln() / (n + 1.0);
            let cos_a = l.exp();
            let sin_a = (-(2.0 * l).exp_m1()).max(0.0).sqrt();
            let (sin_phi, cos_phi) = (2.0 * PI * u2.y).sin_cos();
            let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
            let local = Vec3::new(sin_a * cos_phi, sin_a * sin_phi, cos_a);
            let wi = Frame::from_normal(mirror).to_world(local).normalize();
            (wi, BsdfFlags::GLOSSY_REFLECTION)
        } else {
            (
                square_to_cosine_hemisphere(u2),
                BsdfFlags::DIFFUSE_REFLECTION,
            )
        };
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf(ctx, wo, wi);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        Some(BsdfSample {
            wi,
            pdf,
            eta: 1.0,
            sampled,
            weight: self.eval(ctx, wo, wi) / pdf,
        })
    }

    #[inline]
    fn eval(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        let cos_a = cos_alpha(wo, wi);
        let diffuse = self.diffuse_reflectance * FRAC_1_PI;
        let f = if cos_a > 0.0 {
            let n = self.n;
            diffuse + self.specular_reflectance * ((n + 2.0) * 0.5 * FRAC_1_PI * cos_a.powf(n))
        } else {
            diffuse
        };
        f * wi.z
    }

    #[inline]
    fn pdf(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let p_spec = self.p_spec;
        let spec = if p_spec > 0.0 {
            lobe_pdf(self.n, cos_alpha(wo, wi))
        } else {
            0.0
        };
        p_spec * spec + (1.0 - p_spec) * cosine_hemisphere_pdf(wi)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::microfacet::tests::MapParams;
    use crate::bsdf::tests::{albedo, check_bsdf, check_reciprocity, flat_si, Variant};
    use crate::bsdf::BsdfModel;
    use crate::bsdf::Material;

    fn phong(n: f32, s: Rgb, d: Rgb) -> Materials {
        Materials::with_bsdfs(vec![Material::Phong(Phong::new(n, s, d))])
    }

    /// ∫ eval dωi over the upper hemisphere by the midpoint rule in
    /// (cos θ, φ), in f64.
    fn quadrature_albedo(m: &Materials, wo: Vec3) -> f64 {
        let (ctx, si) = (BsdfContext::default(), flat_si());
        let (nt, np) = (800, 800);
        let mut sum = 0.0;
        for i in 0..nt {
            let z = (i as f64 + 0.5) / nt as f64;
            let r = (1.0 - z * z).sqrt();
            for j in 0..np {
                let phi = (j as f64 + 0.5) / np as f64 * std::f64::consts::TAU;
                let wi = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
                sum += m.bsdfs[0].eval(m, &ctx, &si, wo, wi).x as f64;
            }
        }
        sum * std::f64::consts::TAU / (nt * np) as f64
    }

    /// Exponent 0: the lobe is ρs/π on the half of the hemisphere within
    /// 90° of the mirror direction R. ∫ cos θi over that lune (dihedral
    /// angle π − θo, symmetric about the bisector b of n and R, n·b =
    /// cos(θo/2)) is π cos²(θo/2), so the albedo is
    /// ρd + ρs (1 + cos θo)/2. Checked by quadrature of eval and by the
    /// mean sample weight, and for an exponent near 0 (the limit).
    #[test]
    fn exponent_zero_albedo() {
        let (rho_s, rho_d) = (0.6f32, 0.3f32);
        for n in [0.0f32, 1e-4] {
            let m = phong(n, Rgb::splat(rho_s), Rgb::splat(rho_d));
            for wo in [
                Vec3::Z,
                Vec3::new(0.3, 0.2, 0.9).normalize(),
                Vec3::new(-0.6, 0.3, 0.5).normalize(),
                Vec3::new(0.95, -0.1, 0.08).normalize(),
            ] {
                let expected = rho_d + rho_s * (1.0 + wo.z) / 2.0;
                let q = quadrature_albedo(&m, wo) as f32;
                assert!(
                    (q - expected).abs() < 2e-3,
                    "n {n} wo {wo}: ∫ f cos = {q} vs {expected}"
                );
                let a = albedo(&m, 0, wo).x;
                assert!(
                    (a - expected).abs() < 5e-3,
                    "n {n} wo {wo}: albedo {a} vs {expected}"
                );
            }
        }
    }

    /// The lobe alone (ρd = 0, ρs = 1) reflects everything at normal
    /// incidence, for any exponent, and less towards grazing.
    #[test]
    fn lobe_is_normalized() {
        for n in [1.0f32, 10.0, 100.0] {
            let m = phong(n, Rgb::ONE, Rgb::ZERO);
            let a = quadrature_albedo(&m, Vec3::Z);
            assert!((a - 1.0).abs() < 2e-3, "n {n}: {a}");
            let g = quadrature_albedo(&m, Vec3::new(0.9, 0.0, 0.3).normalize());
            assert!(g < a, "n {n}: grazing {g} vs normal {a}");
        }
    }

    #[test]
    fn chi2_reciprocity_one_sided() {
        let m = phong(20.0, Rgb::new(0.3, 0.2, 0.1), Rgb::new(0.1, 0.3, 0.5));
        check_bsdf(&m, 0, Vec3::new(0.3, 0.2, 0.9).normalize());
        check_reciprocity(&m, 0);
        let (ctx, si) = (BsdfContext::default(), flat_si());
        let below = Vec3::new(0.1, 0.2, -0.9).normalize();
        assert_eq!(m.bsdfs[0].eval(&m, &ctx, &si, below, Vec3::Z), Rgb::ZERO);
        assert_eq!(m.bsdfs[0].eval(&m, &ctx, &si, Vec3::Z, below), Rgb::ZERO);
        assert!(m.bsdfs[0]
            .sample(&m, &ctx, &si, below, 0.1, Vec2::splat(0.3))
            .is_none());
    }

    #[test]
    fn params() {
        let mut p = MapParams::new()
            .float("exponent", 12.0)
            .color("specular_reflectance", Rgb::splat(0.3))
            .texture("diffuse_reflectance", 1);
        let b = Phong::from_params(&mut p).unwrap();
        assert!(p.unread().is_empty(), "{:?}", p.unread());
        assert_eq!(b.exponent, Tex::value(12.0));
        assert_eq!(b.diffuse_reflectance, Tex::Texture(1));
        let d = Phong::from_params(&mut MapParams::new()).unwrap();
        assert_eq!(d, Phong::new(30.0, Rgb::splat(0.2), Rgb::splat(0.5)));
        // More than one in total is scaled down to one.
        let s = Phong::from_params(
            &mut MapParams::new()
                .color("specular_reflectance", Rgb::new(0.5, 0.2, 0.2))
                .color("diffuse_reflectance", Rgb::new(0.75, 0.2, 0.2)),
        )
        .unwrap();
        let sum =
            s.specular_reflectance.as_const().unwrap() + s.diffuse_reflectance.as_const().unwrap();
        assert!((sum.x - 1.0).abs() < 1e-6 && sum.y < 0.4, "{sum}");

        let e = Phong::from_params(&mut MapParams::new().float("exponent", -1.0)).unwrap_err();
        assert!(e.0.contains("\"exponent\"") && e.0.contains("-1"), "{e}");
        assert!(Phong::from_params(&mut MapParams::new().float("exponent", f32::NAN)).is_err());
    }

    /// Configurations for the table-driven tests in `bsdf/mod.rs`:
    /// exponents from 0 to 1000, a lobe-only and a textured variant.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let mut out: Vec<Variant> = [0.0f32, 1.0, 10.0, 100.0, 1000.0]
            .into_iter()
            .map(|n| {
                Variant::last(
                    format!("phong (exponent {n})"),
                    vec![Material::Phong(Phong::new(
                        n,
                        Rgb::new(0.4, 0.3, 0.2),
                        Rgb::new(0.1, 0.3, 0.6),
                    ))],
                )
            })
            .collect();
        out.push(Variant::last(
            "phong (exponent 5, lobe only, ρs 1)",
            vec![Material::Phong(Phong::new(5.0, Rgb::ONE, Rgb::ZERO))],
        ));
        let mut textured = Variant::last(
            "phong (checkerboard diffuse and exponent 3 / 60)",
            vec![Material::Phong(Phong {
                exponent: Tex::Texture(1),
                specular_reflectance: Tex::value(0.3),
                diffuse_reflectance: Tex::Texture(0),
            })],
        );
        for (a, b) in [
            (Rgb::new(0.6, 0.5, 0.1), Rgb::splat(0.2)),
            (Rgb::splat(3.0), Rgb::splat(60.0)),
        ] {
            textured
                .m
                .textures
                .push(crate::texture::Texture::Checkerboard(
                    crate::texture::Checkerboard {
                        color0: Tex::Const(a),
                        color1: Tex::Const(b),
                        to_uv: glam::Affine2::IDENTITY,
                        float_swapped: false,
                    },
                ));
        }
        out.push(textured);
        out
    }
}
