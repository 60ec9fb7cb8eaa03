//! `blendbsdf`: a linear blend of two BSDFs, f = (1 − w) f₀ + w f₁, with a
//! (possibly textured) weight.
//!
//! | parameter | type            | default    | meaning                                   |
//! |-----------|-----------------|------------|-------------------------------------------|
//! | `weight`  | texture / float | (required) | w in [0, 1]: 0 is the first BSDF, 1 the second |
//! | (nested)  | two bsdfs       | (required) | the BSDFs blended, in order               |
//!
//! ```xml
//! <bsdf type="blendbsdf">
//!     <float name="weight" value="0.3"/>
//!     <bsdf type="conductor"/>
//!     <bsdf type="diffuse"/>
//! </bsdf>
//! ```
//!
//! Sampling picks a BSDF with probability (1 − w, w); for a smooth sample
//! the density and weight are those of the whole blend (so MIS sees one
//! BSDF), for a delta sample the lobe's own value over its choice
//! probability. Mitsuba 3's `blendbsdf`; pbrt-v4's `MixMaterial` picks one
//! material stochastically instead.
//!
//! Mitsuba 3.9.1 differs when one child is smooth (delta) and the other
//! not: its delta samples add the delta lobe's weight and density as if
//! they were values of the smooth lobe's, so its estimate is biased (a
//! blend of 0.7 × white-0.5 `diffuse` and 0.3 × a perfect mirror has
//! albedo 0.65; 10⁵ samples of Mitsuba's `sample` average 0.588). Its docs
//! scene `bsdf_blendbsdf.xml` (rough plastic and smooth gold) is 3.5 %
//! darker in Mitsuba than in yubin; with the gold given as a
//! `roughconductor` of α 0.001 Mitsuba's render and yubin's of the
//! original pass the Z-test (`mitsuba-ref ztest --yubin-scene`).

use super::value::Tree;
use super::{BsdfContext, BsdfFlags, BsdfSample, Material};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};

/// A blend of two BSDFs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlendBsdf {
    /// Weight of the second BSDF.
    pub weight: Tex,
    /// The two BSDFs, by index.
    pub bsdfs: [u32; 2],
}

impl BlendBsdf {
    /// Builds the BSDF from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let weight = p
            .texture("weight", ColorKind::Reflectance)?
            .ok_or_else(|| p.error("needs a \"weight\" (a float or a texture)"))?;
        if let Some(c) = weight.as_const() {
            if c.max_element() > 1.0 {
                return Err(p.param_error("weight", "must lie in [0, 1]"));
            }
        }
        match p.bsdfs()?.as_slice() {
            [(a, _), (b, _)] => Ok(Self {
                weight,
                bsdfs: [*a, *b],
            }),
            kids => Err(p.error(&format!(
                "needs exactly two nested BSDFs, found {}",
                kids.len()
            ))),
        }
    }

    /// The weight of the second BSDF at `si`.
    #[inline]
    pub(super) fn w(&self, m: &Materials, si: &SurfaceInteraction) -> f32 {
        self.weight.eval_1(m, si).clamp(0.0, 1.0)
    }

    fn part<'m>(&self, m: &'m Materials, i: usize) -> &'m Material {
        &m.bsdfs[self.bsdfs[i] as usize]
    }
}

impl BlendBsdf {
    /// Lobes this material has.
    pub fn flags(&self, m: &Materials) -> BsdfFlags {
        self.part(m, 0).flags(m) | self.part(m, 1).flags(m)
    }
}

/// A [`BlendBsdf`] at a vertex: its weight there and its two parts.
#[derive(Clone, Copy, Debug)]
pub(super) struct BlendNode {
    w: f32,
    parts: [u8; 2],
}

impl BlendNode {
    /// Weight `w` of the second of `parts`.
    pub(super) fn new(w: f32, parts: [u8; 2]) -> Self {
        Self { w, parts }
    }

    /// A sample of one part, picked with probability 1 − w or w, weighed
    /// by the whole blend (delta lobes by the part's density alone).
    pub(super) fn sample(
        &self,
        t: &Tree,
        ctx: &BsdfContext,
        wo: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        let w = self.w;
        let (i, prob, u1) = if u1 < 1.0 - w {
            (0, 1.0 - w, u1 / (1.0 - w))
        } else {
            (1, w, ((u1 - (1.0 - w)) / w).min(1.0 - f32::EPSILON))
        };
        let s = t.sample(self.parts[i], ctx, wo, u1, u2)?;
        if s.sampled.intersects(BsdfFlags::DELTA) {
            return Some(BsdfSample {
                pdf: s.pdf * prob,
                ..s
            });
        }
        let (value, pdf) = self.eval_pdf(t, ctx, wo, s.wi);
        (pdf > 0.0).then(|| BsdfSample {
            pdf,
            weight: value / pdf,
            ..s
        })
    }

    pub(super) fn eval(&self, t: &Tree, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> Rgb {
        let w = self.w;
        t.eval(self.parts[0], ctx, wo, wi) * (1.0 - w) + t.eval(self.parts[1], ctx, wo, wi) * w
    }

    pub(super) fn pdf(&self, t: &Tree, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> f32 {
        let w = self.w;
        t.pdf(self.parts[0], ctx, wo, wi) * (1.0 - w) + t.pdf(self.parts[1], ctx, wo, wi) * w
    }

    pub(super) fn eval_pdf(&self, t: &Tree, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        let w = self.w;
        let (f0, p0) = t.eval_pdf(self.parts[0], ctx, wo, wi);
        let (f1, p1) = t.eval_pdf(self.parts[1], ctx, wo, wi);
        (f0 * (1.0 - w) + f1 * w, p0 * (1.0 - w) + p1 * w)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::tests::{albedo, Variant};
    use crate::bsdf::{Diffuse, Null};

    /// Configurations for the table-driven tests in `bsdf/mod.rs`.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let two_diffuse = |w: f32| {
            Variant::last(
                format!("blendbsdf (two diffuse, w {w})"),
                vec![
                    Material::Diffuse(Diffuse::new(Rgb::new(0.9, 0.1, 0.1))),
                    Material::Diffuse(Diffuse::new(Rgb::new(0.1, 0.1, 0.9))),
                    Material::BlendBsdf(BlendBsdf {
                        weight: Tex::value(w),
                        bsdfs: [0, 1],
                    }),
                ],
            )
        };
        let mut with_null = Variant::last(
            "blendbsdf (white diffuse and null)",
            vec![
                Material::Diffuse(Diffuse::new(Rgb::ONE)),
                Material::Null(Null),
                Material::BlendBsdf(BlendBsdf {
                    weight: Tex::value(0.4),
                    bsdfs: [0, 1],
                }),
            ],
        );
        with_null.lossless = false; // lossless only from the front
        vec![
            two_diffuse(0.0),
            two_diffuse(0.3),
            two_diffuse(1.0),
            with_null,
        ]
    }

    #[test]
    fn albedo_is_the_blend() {
        let v = &test_variants()[1];
        let a = albedo(&v.m, v.id, Vec3::new(0.1, 0.2, 0.9).normalize());
        let expected = Rgb::new(0.9, 0.1, 0.1) * 0.7 + Rgb::new(0.1, 0.1, 0.9) * 0.3;
        assert!(
            (a - expected).abs().max_element() < 2e-3,
            "{a} vs {expected}"
        );
    }
}
