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

use super::{Bsdf, BsdfContext, BsdfFlags, BsdfModel, BsdfSample};
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

    #[inline]
    fn w(&self, m: &Materials, si: &SurfaceInteraction) -> f32 {
        self.weight.eval_1(m, si).clamp(0.0, 1.0)
    }

    fn part<'m>(&self, m: &'m Materials, i: usize) -> &'m Bsdf {
        &m.bsdfs[self.bsdfs[i] as usize]
    }
}

impl BsdfModel for BlendBsdf {
    fn flags(&self, m: &Materials) -> BsdfFlags {
        self.part(m, 0).flags(m) | self.part(m, 1).flags(m)
    }

    fn sample(
        &self,
        m: &Materials,
        ctx: &BsdfContext,
        si: &SurfaceInteraction,
        wo: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        let w = self.w(m, si);
        let (i, prob, u1) = if u1 < 1.0 - w {
            (0, 1.0 - w, u1 / (1.0 - w))
        } else {
            (1, w, ((u1 - (1.0 - w)) / w).min(1.0 - f32::EPSILON))
        };
        let s = self.part(m, i).sample(m, ctx, si, wo, u1, u2)?;
        if s.sampled.intersects(BsdfFlags::DELTA) {
            return Some(BsdfSample {
                pdf: s.pdf * prob,
                ..s
            });
        }
        let (value, pdf) = self.eval_pdf(m, ctx, si, wo, s.wi);
        (pdf > 0.0).then(|| BsdfSample {
            pdf,
            weight: value / pdf,
            ..s
        })
    }

    fn eval(
        &self,
        m: &Materials,
        ctx: &BsdfContext,
        si: &SurfaceInteraction,
        wo: Vec3,
        wi: Vec3,
    ) -> Rgb {
        let w = self.w(m, si);
        self.part(m, 0).eval(m, ctx, si, wo, wi) * (1.0 - w)
            + self.part(m, 1).eval(m, ctx, si, wo, wi) * w
    }

    fn pdf(
        &self,
        m: &Materials,
        ctx: &BsdfContext,
        si: &SurfaceInteraction,
        wo: Vec3,
        wi: Vec3,
    ) -> f32 {
        let w = self.w(m, si);
        self.part(m, 0).pdf(m, ctx, si, wo, wi) * (1.0 - w)
            + self.part(m, 1).pdf(m, ctx, si, wo, wi) * w
    }

    fn eval_pdf(
        &self,
        m: &Materials,
        ctx: &BsdfContext,
        si: &SurfaceInteraction,
        wo: Vec3,
        wi: Vec3,
    ) -> (Rgb, f32) {
        let w = self.w(m, si);
        let (f0, p0) = self.part(m, 0).eval_pdf(m, ctx, si, wo, wi);
        let (f1, p1) = self.part(m, 1).eval_pdf(m, ctx, si, wo, wi);
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
                    Bsdf::Diffuse(Diffuse::new(Rgb::new(0.9, 0.1, 0.1))),
                    Bsdf::Diffuse(Diffuse::new(Rgb::new(0.1, 0.1, 0.9))),
                    Bsdf::BlendBsdf(BlendBsdf {
                        weight: Tex::value(w),
                        bsdfs: [0, 1],
                    }),
                ],
            )
        };
        let mut with_null = Variant::last(
            "blendbsdf (white diffuse and null)",
            vec![
                Bsdf::Diffuse(Diffuse::new(Rgb::ONE)),
                Bsdf::Null(Null),
                Bsdf::BlendBsdf(BlendBsdf {
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
