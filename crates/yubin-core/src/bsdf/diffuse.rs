//! `diffuse`: the ideal Lambertian reflector, f = ρ/π.
//!
//! | parameter     | type                     | default | meaning  |
//! |---------------|--------------------------|---------|----------|
//! | `reflectance` | texture / rgb / spectrum | 0.5     | albedo ρ |
//!
//! ```xml
//! <bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.25, 0.7"/></bsdf>
//! ```
//!
//! One-sided (black from below; wrap it in `twosided` for both sides).
//! Samples the cosine-weighted hemisphere, so the sample weight is ρ.
//! Mitsuba 3's `diffuse`; pbrt-v4 §9.2.

use super::{BsdfContext, BsdfFlags, BsdfSample, Scatter};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::sampling::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Lambertian reflection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Diffuse {
    /// Albedo.
    pub reflectance: Tex,
}

impl Default for Diffuse {
    fn default() -> Self {
        Self {
            reflectance: Tex::value(0.5),
        }
    }
}

impl Diffuse {
    /// A constant albedo.
    pub fn new(reflectance: Rgb) -> Self {
        Self {
            reflectance: Tex::Const(reflectance),
        }
    }

    /// Builds the BSDF from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        Ok(Self {
            reflectance: p.texture_or("reflectance", ColorKind::Reflectance, Rgb::splat(0.5))?,
        })
    }
}

impl Diffuse {
    /// Lobes this material has.
    pub fn flags(&self, _: &Materials) -> BsdfFlags {
        BsdfFlags::DIFFUSE_REFLECTION | BsdfFlags::FRONT_SIDE
    }

    /// The lobe at `si`.
    #[inline]
    pub fn lobe(&self, m: &Materials, si: &SurfaceInteraction) -> DiffuseLobe {
        DiffuseLobe {
            reflectance: self.reflectance.eval(m, si),
        }
    }
}

/// [`Diffuse`] at a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiffuseLobe {
    /// Albedo.
    pub reflectance: Rgb,
}

impl Scatter for DiffuseLobe {
    #[inline]
    fn sample(&self, _: &BsdfContext, wo: Vec3, _: f32, u2: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = square_to_cosine_hemisphere(u2);
        let pdf = cosine_hemisphere_pdf(wi);
        (pdf > 0.0).then_some(BsdfSample {
            wi,
            pdf,
            eta: 1.0,
            sampled: BsdfFlags::DIFFUSE_REFLECTION,
            weight: self.reflectance,
        })
    }

    #[inline]
    fn eval(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        self.reflectance * (FRAC_1_PI * wi.z)
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
    use crate::bsdf::tests::{albedo, check_bsdf, check_reciprocity, Variant};
    use crate::bsdf::BsdfModel;
    use crate::bsdf::Material;

    #[test]
    fn chi2_diffuse() {
        let table = Materials::with_bsdfs(vec![Material::Diffuse(Diffuse::new(Rgb::new(
            0.2, 0.5, 0.9,
        )))]);
        check_bsdf(&table, 0, Vec3::new(0.3, 0.2, 0.9).normalize());
        check_bsdf(&table, 0, Vec3::new(-0.9, 0.1, 0.05).normalize());
    }

    #[test]
    fn diffuse_energy_and_reciprocity() {
        let table = Materials::with_bsdfs(vec![Material::Diffuse(Diffuse::new(Rgb::ONE))]);
        let a = albedo(&table, 0, Vec3::new(0.1, 0.2, 0.8).normalize());
        assert!(
            (a - Rgb::ONE).abs().max_element() < 1e-6,
            "white diffuse reflects everything: {a}"
        );
        check_reciprocity(&table, 0);
        let b = table.bsdfs[0];
        let si = crate::bsdf::tests::flat_si();
        let ctx = BsdfContext::default();
        assert_eq!(
            b.eval(&table, &ctx, &si, -Vec3::Z, Vec3::Z),
            Rgb::ZERO,
            "one-sided"
        );
    }

    /// Configurations for the table-driven tests in `bsdf/mod.rs`.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let textured = {
            let mut v = Variant::last(
                "diffuse (checkerboard texture)",
                vec![Material::Diffuse(Diffuse {
                    reflectance: Tex::Texture(0),
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
        let mut white = Variant::last(
            "diffuse (white)",
            vec![Material::Diffuse(Diffuse::new(Rgb::ONE))],
        );
        white.lossless = true;
        vec![
            Variant::last(
                "diffuse",
                vec![Material::Diffuse(Diffuse::new(Rgb::new(0.2, 0.5, 0.9)))],
            ),
            white,
            textured,
        ]
    }
}
