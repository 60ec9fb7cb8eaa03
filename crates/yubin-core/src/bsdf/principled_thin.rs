//! `principledthin`: the thin-surface variant of the principled BSDF
//! (Burley 2015, §4: leaves, paper, lamp shades, soap films): a surface
//! with no inside, which reflects and transmits without bending light and
//! behaves the same from both sides.
//!
//! | parameter         | type            | default | meaning |
//! |-------------------|-----------------|---------|---------|
//! | `base_color`      | texture / rgb   | 0.5     | colour of the diffuse and transmitted light |
//! | `roughness`       | float / texture | 0.5     | roughness of the specular lobes (GGX with α = roughness²) |
//! | `anisotropic`     | float / texture | 0       | stretches the highlights along the first tangent |
//! | `spec_trans`      | float / texture | 0       | blends the diffuse response towards the specular ones |
//! | `eta`             | float / texture | 1.5     | index ratio of the thin sheet |
//! | `spec_tint`       | float / texture | 0       | tints the specular reflection towards the hue of `base_color` |
//! | `sheen`           | float / texture | 0       | a grazing-angle sheen |
//! | `sheen_tint`      | float / texture | 0       | tints the sheen towards the hue of `base_color` |
//! | `flatness`        | float / texture | 0       | blends the diffuse towards the flat subsurface look |
//! | `diff_trans`      | float / texture | 0       | share of the diffuse light transmitted, in [0, 2] (2: all of it) |
//! | `diffuse_reflectance_sampling_rate`    | float | 1 | relative probability of sampling each lobe |
//! | `specular_reflectance_sampling_rate`   | float | 1 | ... |
//! | `specular_transmittance_sampling_rate` | float | 1 | ... |
//! | `diffuse_transmittance_sampling_rate`  | float | 1 | ... |
//!
//! ```xml
//! <bsdf type="principledthin">
//!     <rgb name="base_color" value="0.3, 0.6, 0.1"/>
//!     <float name="roughness" value="0.4"/>
//!     <float name="diff_trans" value="0.8"/>
//! </bsdf>
//! ```
//!
//! Directions are first mirrored to the side `wo` is on. With
//! t = `spec_trans`, d = `diff_trans`/2, h the half vector of wo and wi
//! mirrored above the surface, F the exact dielectric Fresnel reflectance
//! at wo·h and D, G GGX with Smith masking, f·|cos θi| is the sum of
//! - the specular reflection t F_t D G / (4 cos θo), F_t = F blended
//!   towards Schlick's approximation of the tinted R0(η) by `spec_tint`;
//! - the specular transmission t `base_color` (1 − F) D' G' / (4 cos θo),
//!   the straight-through reflection lobe mirrored below the surface, its
//!   roughness scaled by 0.65 η − 0.35 (Burley 2015, Figure 15);
//! - the Disney diffuse and sheen (as `principled`) times (1 − t)(1 − d);
//! - the diffuse transmission (1 − t) d `base_color`/π |cos θi|.
//!
//! As in Mitsuba 3, the specular reflection is part of the `spec_trans`
//! blend: a principledthin with `spec_trans` 0 has no highlight. Mitsuba's
//! definitions are followed throughout, so the same file gives the same
//! image. Sampling picks the four lobes in proportion to t/2, t/2,
//! (1 − t)(1 − d) and (1 − t) d, each scaled by its sampling rate; the
//! weight is f / pdf of the whole mixture.
//!
//! Ranges: constant weights outside [0, 1] (`diff_trans`: [0, 2]) are an
//! error, textured ones are clamped where read; `eta` must be positive.
//!
//! References: Burley 2015, "Extending the Disney BRDF to a BSDF with
//! Integrated Subsurface Scattering", §4 (thin surfaces); Burley 2012;
//! Mitsuba 3's `principledthin`.

use super::disney::{
    diffuse_term, facet_agrees, ggx, schlick_fresnel, schlick_r0, sheen_term, tint_color,
    weight_param, DisneyParams, DisneyValues,
};
use super::fresnel::{fresnel_dielectric, reflect_m};
use super::microfacet::Microfacet;
use super::{BsdfContext, BsdfFlags, BsdfSample, Scatter};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::sampling::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// The thin principled BSDF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrincipledThin {
    /// Parameters shared with `principled`.
    pub common: DisneyParams,
    /// Share of the diffuse light transmitted, in [0, 2].
    pub diff_trans: Tex,
    /// Relative index of refraction of the sheet.
    pub eta: Tex,
    /// Sampling rates of the specular reflection, specular transmission,
    /// diffuse reflection and diffuse transmission.
    pub rates: [f32; 4],
}

/// A [`PrincipledThin`] at one vertex.
#[derive(Clone, Copy, Debug)]
pub struct PrincipledThinLobe {
    v: DisneyValues,
    /// Sampling rates of the four lobes.
    rates: [f32; 4],
    /// d = `diff_trans` / 2.
    diff_trans: f32,
    eta: f32,
    reflection: Microfacet,
    transmission: Microfacet,
}

impl PrincipledThin {
    /// A thin principled BSDF with every parameter at its default.
    pub fn new(base_color: Rgb) -> Self {
        Self {
            common: DisneyParams::new(base_color),
            diff_trans: Tex::value(0.0),
            eta: Tex::value(1.5),
            rates: [1.0; 4],
        }
    }

    /// Builds the BSDF from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let common = DisneyParams::from_params(p)?;
        let diff_trans = weight_param(p, "diff_trans", 0.0, 2.0)?;
        let eta = p.texture_or("eta", ColorKind::Unbounded, Rgb::splat(1.5))?;
        if let Some(e) = eta.as_const().map(crate::spectrum::luminance) {
            if !(e > 0.0 && e.is_finite()) {
                return Err(p.param_error("eta", &format!("must be positive, not {e}")));
            }
        }
        let mut rates = [1.0; 4];
        for (r, name) in rates.iter_mut().zip([
            "specular_reflectance_sampling_rate",
            "specular_transmittance_sampling_rate",
            "diffuse_reflectance_sampling_rate",
            "diffuse_transmittance_sampling_rate",
        ]) {
            *r = p.float_or(name, 1.0)?;
            if !(*r >= 0.0 && r.is_finite()) {
                return Err(p.param_error(name, &format!("must not be negative, not {r}")));
            }
        }
        Ok(Self {
            common,
            diff_trans,
            eta,
            rates,
        })
    }

    /// The lobe at `si`.
    #[inline]
    pub fn lobe(&self, m: &Materials, si: &SurfaceInteraction) -> PrincipledThinLobe {
        let v = self.common.at(m, si);
        let eta = self.eta.eval_1(m, si).max(1e-3);
        PrincipledThinLobe {
            rates: self.rates,
            diff_trans: 0.5 * self.diff_trans.eval_1(m, si).clamp(0.0, 2.0),
            eta,
            reflection: ggx(v.roughness, v.anisotropic),
            transmission: ggx((0.65 * eta - 0.35) * v.roughness, v.anisotropic),
            v,
        }
    }
}

/// `wi` mirrored above the surface and the half vector of it and `wo`
/// (both on the +z side).
#[inline]
fn thin_half_vector(wo: Vec3, wi: Vec3) -> Vec3 {
    (wo + Vec3::new(wi.x, wi.y, wi.z.abs())).normalize()
}

/// (wo, wi) mirrored so that wo is above the surface.
#[inline]
fn to_front(wo: Vec3, wi: Vec3) -> (Vec3, Vec3) {
    if wo.z < 0.0 {
        (-wo, -wi)
    } else {
        (wo, wi)
    }
}

impl PrincipledThin {
    /// Lobes this material has.
    pub fn flags(&self, _: &Materials) -> BsdfFlags {
        BsdfFlags::DIFFUSE_REFLECTION
            | BsdfFlags::DIFFUSE_TRANSMISSION
            | BsdfFlags::GLOSSY_REFLECTION
            | BsdfFlags::GLOSSY_TRANSMISSION
            | BsdfFlags::FRONT_SIDE
            | BsdfFlags::BACK_SIDE
    }
}

impl PrincipledThinLobe {
    /// Probabilities of the specular reflection, specular transmission,
    /// diffuse reflection and diffuse transmission.
    #[inline]
    fn lobe_probabilities(&self) -> [f32; 4] {
        let t = self.v.spec_trans;
        let d = self.diff_trans;
        let probs = [
            0.5 * t * self.rates[0],
            0.5 * t * self.rates[1],
            (1.0 - t) * (1.0 - d) * self.rates[2],
            (1.0 - t) * d * self.rates[3],
        ];
        let total: f32 = probs.iter().sum();
        if total > 0.0 {
            probs.map(|x| x / total)
        } else {
            [0.0; 4]
        }
    }
}

impl Scatter for PrincipledThinLobe {
    fn sample(&self, ctx: &BsdfContext, wo: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let (up, _) = to_front(wo, Vec3::Z);
        let [psr, pst, pdr, _] = self.lobe_probabilities();
        // A facet lobe's direction must end up on its own side, through
        // the facet's proper side (else another lobe's density would
        // claim it).
        let (wi_up, sampled) = if u1 < psr {
            let h = self.reflection.sample_normal(up, u2).unwrap_or(Vec3::Z);
            let wi = reflect_m(up, h);
            if wi.z <= 0.0 || !facet_agrees(h, up, wi, true) {
                return None;
            }
            (wi, BsdfFlags::GLOSSY_REFLECTION)
        } else if u1 < psr + pst {
            let h = self.transmission.sample_normal(up, u2).unwrap_or(Vec3::Z);
            let r = reflect_m(up, h);
            let wi = Vec3::new(r.x, r.y, -r.z);
            if wi.z >= 0.0 || !facet_agrees(h, up, wi, false) {
                return None;
            }
            (wi, BsdfFlags::GLOSSY_TRANSMISSION)
        } else if u1 < psr + pst + pdr {
            (
                square_to_cosine_hemisphere(u2),
                BsdfFlags::DIFFUSE_REFLECTION,
            )
        } else {
            (
                -square_to_cosine_hemisphere(u2),
                BsdfFlags::DIFFUSE_TRANSMISSION,
            )
        };
        let wi = if wo.z < 0.0 { -wi_up } else { wi_up };
        let pdf = self.pdf_at(wo, wi);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            pdf,
            eta: 1.0,
            sampled,
            weight: self.eval_at(ctx, wo, wi) / pdf,
        })
    }

    fn eval(&self, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> Rgb {
        self.eval_at(ctx, wo, wi)
    }

    fn pdf(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> f32 {
        self.pdf_at(wo, wi)
    }
}

impl PrincipledThinLobe {
    #[inline]
    fn eval_at(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z == 0.0 || wi.z == 0.0 {
            return Rgb::ZERO;
        }
        let (wo, wi) = to_front(wo, wi);
        let (co, ci) = (wo.z, wi.z);
        let reflect = ci > 0.0;
        let h = thin_half_vector(wo, wi);
        let (t, d) = (self.v.spec_trans, self.diff_trans);
        let mut value = Rgb::ZERO;
        if t > 0.0 && facet_agrees(h, wo, wi, reflect) {
            let (f, ..) = fresnel_dielectric(wo.dot(h), self.eta);
            if reflect {
                let mut fr = Rgb::splat(f);
                if self.v.spec_tint > 0.0 {
                    let r0 = tint_color(self.v.base_color) * schlick_r0(self.eta);
                    let s = schlick_fresnel(r0, wo.dot(h), self.eta);
                    fr += (s - fr) * self.v.spec_tint;
                }
                let dg = self.reflection.d(h) * self.reflection.g(wo, wi, h);
                value += fr * (t * dg / (4.0 * co));
            } else {
                let dg = self.transmission.d(h) * self.transmission.g(wo, wi, h);
                value += self.v.base_color * (t * (1.0 - f) * dg / (4.0 * co));
            }
        }
        if t < 1.0 {
            if reflect && d < 1.0 {
                let w = (1.0 - t) * (1.0 - d);
                let cos_d = h.dot(wi);
                value += diffuse_term(&self.v, w, co, ci, cos_d);
                value += sheen_term(&self.v, w, ci, cos_d);
            } else if !reflect && d > 0.0 {
                value += self.v.base_color * ((1.0 - t) * d * FRAC_1_PI * ci.abs());
            }
        }
        value
    }

    #[inline]
    fn pdf_at(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z == 0.0 || wi.z == 0.0 {
            return 0.0;
        }
        let (wo, wi) = to_front(wo, wi);
        let reflect = wi.z > 0.0;
        let [psr, pst, pdr, pdt] = self.lobe_probabilities();
        let h = thin_half_vector(wo, wi);
        let mut pdf = 0.0;
        if facet_agrees(h, wo, wi, reflect) {
            let dh_dwi = 1.0 / (4.0 * Vec3::new(wi.x, wi.y, wi.z.abs()).dot(h).abs());
            pdf += dh_dwi
                * if reflect {
                    psr * self.reflection.pdf(wo, h)
                } else {
                    pst * self.transmission.pdf(wo, h)
                };
        }
        pdf + if reflect {
            pdr * cosine_hemisphere_pdf(wi)
        } else {
            pdt * cosine_hemisphere_pdf(-wi)
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::tests::{albedo, Variant};
    use crate::bsdf::BsdfModel;
    use crate::bsdf::{Diffuse, Material};

    fn thin(f: impl FnOnce(&mut PrincipledThin)) -> PrincipledThin {
        let mut b = PrincipledThin::new(Rgb::new(0.3, 0.7, 0.5));
        f(&mut b);
        b
    }

    /// Configurations for the table-driven tests in `bsdf/mod.rs`.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let v =
            |name: &str, b: PrincipledThin| Variant::last(name, vec![Material::PrincipledThin(b)]);
        let mut out = vec![
            v("principledthin (defaults)", thin(|_| ())),
            v(
                "principledthin (diff_trans 1.2, sheen, flatness)",
                thin(|b| {
                    b.diff_trans = Tex::value(1.2);
                    b.common.sheen = Tex::value(0.7);
                    b.common.flatness = Tex::value(0.5);
                }),
            ),
            v(
                "principledthin (spec_trans 1, rough 0.3, anisotropic 0.6)",
                thin(|b| {
                    b.common.spec_trans = Tex::value(1.0);
                    b.common.roughness = Tex::value(0.3);
                    b.common.anisotropic = Tex::value(0.6);
                }),
            ),
            v(
                "principledthin (spec_trans 0.6, diff_trans 0.8, spec_tint, eta 1.33)",
                thin(|b| {
                    b.common.spec_trans = Tex::value(0.6);
                    b.diff_trans = Tex::value(0.8);
                    b.common.spec_tint = Tex::value(0.5);
                    b.eta = Tex::value(1.33);
                }),
            ),
        ];
        for x in &mut out {
            // Schlick's Fresnel and the unequal lobes are not reciprocal.
            x.reciprocal = false;
        }
        out
    }

    /// `diff_trans` 2 with no specular part is a pure diffuse transmitter
    /// of the base colour: what goes through is exactly `base_color`.
    #[test]
    fn full_diffuse_transmission_transmits_base_color() {
        let base = Rgb::new(0.3, 0.6, 0.9);
        let b = PrincipledThin {
            diff_trans: Tex::value(2.0),
            ..PrincipledThin::new(base)
        };
        let t = Materials::with_bsdfs(vec![Material::PrincipledThin(b)]);
        for wo in [Vec3::new(0.2, 0.1, 0.9), Vec3::new(0.5, -0.3, -0.4)] {
            let a = albedo(&t, 0, wo.normalize());
            assert!((a - base).abs().max_element() < 1e-4, "{a} vs {base}");
        }
    }

    /// With zero roughness the diffuse lobe at normal incidence is the
    /// Lambertian base_color/π, as `diffuse`.
    #[test]
    fn diffuse_part_matches_lambert_at_normal_incidence() {
        let base = Rgb::new(0.3, 0.6, 0.9);
        let b = PrincipledThin {
            common: DisneyParams {
                roughness: Tex::value(0.0),
                ..DisneyParams::new(base)
            },
            ..PrincipledThin::new(base)
        };
        let t = Materials::with_bsdfs(vec![
            Material::PrincipledThin(b),
            Material::Diffuse(Diffuse::new(base)),
        ]);
        let ctx = BsdfContext::default();
        let si = crate::bsdf::tests::flat_si();
        let a = t.bsdfs[0].eval(&t, &ctx, &si, Vec3::Z, Vec3::Z);
        let b = t.bsdfs[1].eval(&t, &ctx, &si, Vec3::Z, Vec3::Z);
        assert!((a - b).abs().max_element() < 1e-6, "{a} vs {b}");
    }
}
