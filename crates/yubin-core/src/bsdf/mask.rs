//! `mask`: a surface that is only partly there (leaves, fences, cut-outs):
//! with probability `opacity` the nested BSDF scatters, otherwise light
//! passes straight through.
//!
//! | parameter | type            | default    | meaning                                     |
//! |-----------|-----------------|------------|---------------------------------------------|
//! | `opacity` | texture / float | 0.5        | fraction of the surface that is there (α)   |
//! | (nested)  | bsdf            | (required) | the material where the surface is there     |
//!
//! ```xml
//! <bsdf type="mask">
//!     <texture name="opacity" type="bitmap">
//!         <string name="filename" value="textures/leaf_mask.png"/>
//!     </texture>
//!     <bsdf type="twosided"><bsdf type="diffuse"/></bsdf>
//! </bsdf>
//! ```
//!
//! f = α · f_nested, plus a null lobe of weight 1 − α that continues the
//! path in its own direction. A path that passes through counts as a
//! bounce (as in Mitsuba 3's integrators), and shadow rays pass through with
//! transmittance 1 − α (a generalized shadow ray). A colour texture's
//! luminance is its opacity. Mitsuba 3's `mask`.

use super::value::Tree;
use super::{BsdfContext, BsdfFlags, BsdfSample, Material};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};

/// An opacity-masked BSDF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mask {
    /// Opacity α in [0, 1].
    pub opacity: Tex,
    /// The nested BSDF, by index.
    pub nested: u32,
}

impl Mask {
    /// Builds the BSDF from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let opacity = p.texture_or("opacity", ColorKind::Reflectance, Rgb::splat(0.5))?;
        if let Some(c) = opacity.as_const() {
            if c.max_element() > 1.0 {
                return Err(p.param_error("opacity", "must lie in [0, 1]"));
            }
        }
        match p.bsdfs()?.as_slice() {
            [(nested, _)] => Ok(Self {
                opacity,
                nested: *nested,
            }),
            kids => Err(p.error(&format!(
                "needs exactly one nested BSDF, found {}",
                kids.len()
            ))),
        }
    }

    /// α at `si`.
    #[inline]
    pub fn alpha(&self, m: &Materials, si: &SurfaceInteraction) -> f32 {
        self.opacity.eval_1(m, si).clamp(0.0, 1.0)
    }

    fn nested<'m>(&self, m: &'m Materials) -> &'m Material {
        &m.bsdfs[self.nested as usize]
    }
}

impl Mask {
    /// Lobes this material has.
    pub fn flags(&self, m: &Materials) -> BsdfFlags {
        self.nested(m).flags(m) | BsdfFlags::NULL | BsdfFlags::FRONT_SIDE | BsdfFlags::BACK_SIDE
    }
}

/// A [`Mask`] at a vertex: its opacity α there and its nested BSDF.
#[derive(Clone, Copy, Debug)]
pub(super) struct MaskNode {
    alpha: f32,
    nested: u8,
}

impl MaskNode {
    /// Opacity `alpha` over node `nested`.
    pub(super) fn new(alpha: f32, nested: u8) -> Self {
        Self { alpha, nested }
    }

    /// The null lobe with probability 1 − α, else the nested BSDF.
    pub(super) fn sample(
        &self,
        t: &Tree,
        ctx: &BsdfContext,
        wo: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        let alpha = self.alpha;
        if u1 >= alpha {
            return Some(BsdfSample {
                wi: -wo,
                pdf: 1.0 - alpha,
                eta: 1.0,
                sampled: BsdfFlags::NULL,
                weight: Rgb::ONE,
            });
        }
        let s = t.sample(self.nested, ctx, wo, u1 / alpha, u2)?;
        // α·f / (α·pdf): the weight of either lobe kind is unchanged.
        Some(BsdfSample {
            pdf: s.pdf * alpha,
            ..s
        })
    }

    pub(super) fn eval(&self, t: &Tree, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> Rgb {
        t.eval(self.nested, ctx, wo, wi) * self.alpha
    }

    pub(super) fn pdf(&self, t: &Tree, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> f32 {
        t.pdf(self.nested, ctx, wo, wi) * self.alpha
    }

    pub(super) fn eval_pdf(&self, t: &Tree, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        let (f, pdf) = t.eval_pdf(self.nested, ctx, wo, wi);
        (f * self.alpha, pdf * self.alpha)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::tests::{albedo, Variant};
    use crate::bsdf::BsdfModel;
    use crate::bsdf::{Diffuse, TwoSided};

    fn masked(alpha: f32) -> Vec<Material> {
        vec![
            Material::Diffuse(Diffuse::new(Rgb::ONE)),
            Material::TwoSided(TwoSided { front: 0, back: 0 }),
            Material::Mask(Mask {
                opacity: Tex::value(alpha),
                nested: 1,
            }),
        ]
    }

    /// Configurations for the table-driven tests in `bsdf/mod.rs`.
    pub(crate) fn test_variants() -> Vec<Variant> {
        [0.0, 0.3, 1.0]
            .into_iter()
            .map(|a| {
                let mut v = Variant::last(format!("mask (α {a}, white twosided)"), masked(a));
                // Scattered plus passed through: nothing is lost.
                v.lossless = true;
                v
            })
            .collect()
    }

    #[test]
    fn scattered_fraction_is_the_opacity() {
        let m = Materials::with_bsdfs(masked(0.3));
        let a = albedo(&m, 2, Vec3::new(0.2, 0.1, 0.9).normalize());
        assert!((a - Rgb::ONE).abs().max_element() < 1e-4, "{a}");
        // Half of a 0.5 mask of white diffuse is diffuse.
        let m = Materials::with_bsdfs(masked(0.5));
        let (si, ctx) = (crate::bsdf::tests::flat_si(), BsdfContext::default());
        let wo = Vec3::Z;
        let mut rng = crate::sampler::Pcg32::new(3, 3);
        let n = 100_000;
        let passed = (0..n)
            .filter(|_| {
                let u = rng.next_f32();
                m.bsdfs[2]
                    .sample(&m, &ctx, &si, wo, u, rng.next_2d())
                    .is_some_and(|s| s.sampled == BsdfFlags::NULL)
            })
            .count();
        assert!((passed as f32 / n as f32 - 0.5).abs() < 0.01);
    }
}
