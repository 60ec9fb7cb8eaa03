//! `principled`: the Disney principled BSDF (Burley 2012 and 2015), one
//! material for plastics, metals, glass, fabric and lacquered surfaces,
//! driven by artist-friendly weights.
//!
//! | parameter         | type          | default | meaning |
//! |-------------------|---------------|---------|---------|
//! | `base_color`      | texture / rgb | 0.5     | colour of the diffuse, metallic and transmission lobes |
//! | `roughness`       | float / texture | 0.5   | roughness of the main specular lobes (GGX with α = roughness²) |
//! | `anisotropic`     | float / texture | 0     | stretches the highlight along the first tangent (aspect √(1 − 0.9 a)) |
//! | `metallic`        | float / texture | 0     | blends the dielectric towards a metal whose Fresnel is Schlick's with R0 = `base_color` |
//! | `spec_trans`      | float / texture | 0     | blends the opaque response towards rough glass (tinted by √`base_color`) |
//! | `specular`        | float / texture | 0.5   | dielectric reflectance: R0 = 0.08 `specular`, i.e. η = 2/(1 − √R0) − 1 |
//! | `eta`             | float / texture | —     | the index ratio itself, instead of `specular` (not both) |
//! | `spec_tint`       | float / texture | 0     | tints the dielectric reflection towards the hue of `base_color` |
//! | `sheen`           | float / texture | 0     | a grazing-angle sheen for cloth |
//! | `sheen_tint`      | float / texture | 0     | tints the sheen towards the hue of `base_color` |
//! | `flatness`        | float / texture | 0     | blends the diffuse towards Hanrahan–Krueger's flat subsurface look |
//! | `clearcoat`       | float / texture | 0     | a second, white, isotropic specular layer (GTR1, η = 1.5) |
//! | `clearcoat_gloss` | float / texture | 0     | the clearcoat's glossiness: α from 0.1 (0) to 0.001 (1) |
//! | `diffuse_reflectance_sampling_rate` | float | 1 | relative probability of sampling the diffuse lobe |
//! | `main_specular_sampling_rate`       | float | 1 | ... the main specular lobes |
//! | `clearcoat_sampling_rate`           | float | 1 | ... the clearcoat |
//!
//! ```xml
//! <bsdf type="principled">
//!     <rgb name="base_color" value="0.8, 0.2, 0.1"/>
//!     <float name="metallic" value="0.3"/>
//!     <float name="roughness" value="0.25"/>
//!     <float name="clearcoat" value="0.6"/>
//!     <float name="clearcoat_gloss" value="0.8"/>
//! </bsdf>
//! ```
//!
//! With m = `metallic`, t = `spec_trans`, h the half vector and F the
//! exact dielectric Fresnel reflectance at wo·h, f·|cos θi| is the sum of
//! - the main specular reflection F_p D G / (4 |cos θo|), GGX D and
//!   separable Smith G, where seen from outside
//!   F_p = (1 − m)(1 − `spec_tint`) F + m S(`base_color`) +
//!   (1 − m) `spec_tint` S(tint · R0(η)), S(R0) Schlick's approximation
//!   and tint the base colour over its luminance, and seen from inside
//!   F_p = (1 − m) t F;
//! - the specular transmission (1 − m) t √`base_color` times Walter et
//!   al.'s rough refraction with (1 − F) (as `roughdielectric`, divided
//!   by η² for radiance);
//! - from outside only: (1 − m)(1 − t) `base_color`/π |cos θi| times
//!   the Disney diffuse (Burley 2015's Fresnel-darkened Lambert plus
//!   retro-reflection, blended by `flatness` with Burley 2012's
//!   Hanrahan–Krueger term), the sheen (1 − m) `sheen` (1 − cos θd)⁵
//!   |cos θi| (tinted by `sheen_tint`), and the clearcoat
//!   ¼ `clearcoat` S₀.₀₄ D_GTR1 G_GGX(0.25) |cos θi|.
//!
//! These are Mitsuba 3's definitions, so the same file gives the same
//! image; two of them differ from Burley's notes: the clearcoat lacks
//! the 1/(4 cos θo cos θi) of a microfacet BRDF (it is 4 cos θo cos θi
//! times brighter than Burley's), and Schlick's Fresnel of the metallic
//! and tinted parts picks its angle as for a dielectric of index η.
//! The sheen is present only where the diffuse lobe is (t < 1, as in
//! Mitsuba's scalar variants; its vectorized variants add it wherever
//! m < 1).
//!
//! Sampling picks the diffuse lobe (cosine-weighted), the clearcoat (GTR1
//! normals) or the main specular lobe (visible GGX normals, then
//! reflection or refraction with probability F), in proportion to
//! (1 − m)(1 − t), ¼ `clearcoat` and 1, each scaled by its sampling rate;
//! the weight is f / pdf of the whole mixture. From inside only the
//! specular lobes remain (the material is a one-sided opaque surface
//! unless `spec_trans` is above zero somewhere).
//!
//! Ranges: constant weights outside [0, 1] are an error; textured ones
//! are clamped to [0, 1] where read (Mitsuba takes them as they come).
//! `eta` must be positive and `specular` in [0, 12.4] (R0 < 1); with
//! transmission, η = 1 is replaced by 1.001 (a transmissive interface
//! needs η ≠ 1), as Mitsuba does. Mitsuba reads `eta` and `specular` as
//! floats only; yubin also takes textures for them.
//!
//! References: Burley 2012, "Physically Based Shading at Disney";
//! Burley 2015, "Extending the Disney BRDF to a BSDF with Integrated
//! Subsurface Scattering"; Walter et al. 2007 (rough refraction);
//! Schlick 1994 (Fresnel approximation); Mitsuba 3's `principled`.

use super::dielectric::refraction_scale;
use super::disney::{
    diffuse_term, facet_agrees, ggx, schlick_fresnel, schlick_r0, sheen_term, tint_color,
    weight_param, DisneyParams, DisneyValues, Gtr1,
};
use super::fresnel::{fresnel_dielectric, reflect_m, refract_m};
use super::microfacet::{Microfacet, MicrofacetType};
use super::{BsdfContext, BsdfFlags, BsdfSample, Scatter};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::sampling::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use crate::spectrum::luminance;
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};

/// The principled BSDF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Principled {
    /// Parameters shared with `principledthin`.
    pub common: DisneyParams,
    /// Metallic weight.
    pub metallic: Tex,
    /// Clearcoat weight.
    pub clearcoat: Tex,
    /// Clearcoat glossiness.
    pub clearcoat_gloss: Tex,
    /// Index of refraction of the dielectric part.
    pub ior: PrincipledIor,
    /// Sampling rates of the diffuse, main specular and clearcoat lobes.
    pub rates: [f32; 3],
}

impl Principled {
    /// A principled BSDF with every parameter at its default.
    pub fn new(base_color: Rgb) -> Self {
        Self {
            common: DisneyParams::new(base_color),
            metallic: Tex::value(0.0),
            clearcoat: Tex::value(0.0),
            clearcoat_gloss: Tex::value(0.0),
            ior: PrincipledIor::Specular(Tex::value(0.5)),
            rates: [1.0; 3],
        }
    }

    /// Builds the BSDF from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let common = DisneyParams::from_params(p)?;
        let ior = match (p.texture("eta", ColorKind::Unbounded)?, p.has("specular")) {
            (Some(_), true) => {
                return Err(p.param_error("specular", "give \"eta\" or \"specular\", not both"))
            }
            (Some(eta), false) => {
                if let Some(e) = eta.as_const().map(luminance) {
                    if !(e > 0.0 && e.is_finite()) {
                        return Err(p.param_error("eta", &format!("must be positive, not {e}")));
                    }
                }
                PrincipledIor::Eta(eta)
            }
            (None, _) => PrincipledIor::Specular(weight_param(p, "specular", 0.5, MAX_SPECULAR)?),
        };
        let mut rates = [1.0; 3];
        for (r, name) in rates.iter_mut().zip([
            "diffuse_reflectance_sampling_rate",
            "main_specular_sampling_rate",
            "clearcoat_sampling_rate",
        ]) {
            *r = p.float_or(name, 1.0)?;
            if !(*r >= 0.0 && r.is_finite()) {
                return Err(p.param_error(name, &format!("must not be negative, not {r}")));
            }
        }
        Ok(Self {
            common,
            metallic: weight_param(p, "metallic", 0.0, 1.0)?,
            clearcoat: weight_param(p, "clearcoat", 0.0, 1.0)?,
            clearcoat_gloss: weight_param(p, "clearcoat_gloss", 0.0, 1.0)?,
            ior,
            rates,
        })
    }

    /// The relative index at `si`. As in Mitsuba, a transmissive
    /// principled gets 1.001 for η = 1 (specular 0 gives 1e-3), since a
    /// refracting interface needs η ≠ 1.
    #[inline]
    fn eta_at(&self, m: &Materials, si: &SurfaceInteraction) -> f32 {
        let transmits = self.common.may_transmit();
        match self.ior {
            PrincipledIor::Eta(t) => {
                let e = t.eval_1(m, si).max(1e-3);
                if transmits && e == 1.0 {
                    1.001
                } else {
                    e
                }
            }
            PrincipledIor::Specular(t) => {
                let mut s = t.eval_1(m, si).clamp(0.0, MAX_SPECULAR);
                if transmits && s == 0.0 {
                    s = 1e-3;
                }
                2.0 / (1.0 - (0.08 * s).sqrt()) - 1.0
            }
        }
    }

    /// The lobe at `si`.
    #[inline]
    pub fn lobe(&self, m: &Materials, si: &SurfaceInteraction) -> PrincipledLobe {
        let v = self.common.at(m, si);
        let unit = |t: &Tex| t.eval_1(m, si).clamp(0.0, 1.0);
        let metallic = unit(&self.metallic);
        let clearcoat = unit(&self.clearcoat);
        let gloss = if clearcoat > 0.0 {
            unit(&self.clearcoat_gloss)
        } else {
            0.0
        };
        PrincipledLobe {
            rates: self.rates,
            eta: self.eta_at(m, si),
            dist: ggx(v.roughness, v.anisotropic),
            opaque: (1.0 - metallic) * (1.0 - v.spec_trans),
            glass: (1.0 - metallic) * v.spec_trans,
            metallic,
            clearcoat,
            coat: Gtr1 {
                alpha: 0.1 + (0.001 - 0.1) * gloss,
            },
            v,
        }
    }
}

/// A [`Principled`] at one vertex.
#[derive(Clone, Copy, Debug)]
pub struct PrincipledLobe {
    v: DisneyValues,
    /// Sampling rates of the diffuse, main specular and clearcoat lobes.
    rates: [f32; 3],
    /// Relative index of refraction.
    eta: f32,
    dist: Microfacet,
    /// (1 − metallic)(1 − spec_trans): weight of the diffuse and sheen.
    opaque: f32,
    /// (1 − metallic) spec_trans: weight of the transmission.
    glass: f32,
    metallic: f32,
    clearcoat: f32,
    coat: Gtr1,
}

/// How the principled BSDF's dielectric index is given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PrincipledIor {
    /// `eta`: the relative index itself.
    Eta(Tex),
    /// `specular`: the reflectance at normal incidence is 0.08 `specular`.
    Specular(Tex),
}

/// Largest `specular` read: R0 = 0.08 × 12.4 < 1 keeps η finite.
const MAX_SPECULAR: f32 = 12.4;

/// The clearcoat's fixed Smith masking: GGX with α = 0.25.
const COAT_MASKING: Microfacet = Microfacet {
    kind: MicrofacetType::Ggx,
    alpha_u: 0.25,
    alpha_v: 0.25,
    sample_visible: false,
};

impl Principled {
    /// Lobes this material has.
    pub fn flags(&self, _: &Materials) -> BsdfFlags {
        let mut f =
            BsdfFlags::DIFFUSE_REFLECTION | BsdfFlags::GLOSSY_REFLECTION | BsdfFlags::FRONT_SIDE;
        if self.common.may_transmit() {
            f = f | BsdfFlags::GLOSSY_TRANSMISSION | BsdfFlags::BACK_SIDE;
        }
        f
    }
}

impl PrincipledLobe {
    /// Lobe selection probabilities (diffuse, clearcoat, specular
    /// reflection, specular transmission) given the Fresnel reflectance
    /// `f` of the facet the specular lobes use.
    #[inline]
    fn lobe_probabilities(&self, front: bool, f: f32) -> [f32; 4] {
        let [rd, rs, rc] = self.rates;
        let probs = if front {
            [
                rd * self.opaque,
                0.25 * self.clearcoat * rc,
                rs * (1.0 - self.glass * (1.0 - f)),
                rs * self.glass * (1.0 - f),
            ]
        } else {
            [0.0, 0.0, f, if self.glass > 0.0 { 1.0 - f } else { 0.0 }]
        };
        let total: f32 = probs.iter().sum();
        if total > 0.0 {
            probs.map(|x| x / total)
        } else {
            [0.0; 4]
        }
    }

    /// The half vector of (wo, wi), pointing out of the surface, and the
    /// relative index along the path (η seen from wo's side).
    #[inline]
    fn half_vector(eta: f32, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        let eta_path = if wo.z > 0.0 { eta } else { 1.0 / eta };
        let reflect = wo.z * wi.z > 0.0;
        let h = (wo + wi * if reflect { 1.0 } else { eta_path }).normalize();
        (if h.z < 0.0 { -h } else { h }, eta_path)
    }

    /// The main specular reflection's Fresnel term (see the module docs).
    #[inline]
    fn principled_fresnel(&self, f: f32, cos_oh: f32, front: bool) -> Rgb {
        if !front {
            return Rgb::splat(self.glass * f);
        }
        let v = &self.v;
        let mut fr = Rgb::splat((1.0 - self.metallic) * (1.0 - v.spec_tint) * f);
        if self.metallic > 0.0 {
            fr += self.metallic * schlick_fresnel(v.base_color, cos_oh, self.eta);
        }
        if v.spec_tint > 0.0 {
            let eta_it = if cos_oh >= 0.0 {
                self.eta
            } else {
                1.0 / self.eta
            };
            let r0 = tint_color(v.base_color) * schlick_r0(eta_it);
            fr += (1.0 - self.metallic) * v.spec_tint * schlick_fresnel(r0, cos_oh, self.eta);
        }
        fr
    }
}

impl Scatter for PrincipledLobe {
    fn sample(&self, ctx: &BsdfContext, wo: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let front = wo.z > 0.0;
        if !front && self.glass <= 0.0 {
            return None;
        }
        let up = if front { wo } else { -wo };
        let h = self.dist.sample_normal(up, u2).unwrap_or(Vec3::Z);
        let (f, cos_t, eta_it, eta_ti) = fresnel_dielectric(wo.dot(h), self.eta);
        let [pd, pc, pr, _] = self.lobe_probabilities(front, f);
        // A facet lobe's direction must leave on the side its lobe scatters
        // to, through the facet's proper side (else the lobe missed, and
        // another lobe's density must not claim the direction).
        let (wi, sampled, eta) = if u1 < pd {
            let wi = square_to_cosine_hemisphere(u2);
            (wi, BsdfFlags::DIFFUSE_REFLECTION, 1.0)
        } else if u1 < pd + pc {
            let c = self.coat.sample(u2);
            let wi = reflect_m(wo, c);
            if wi.z <= 0.0 || !facet_agrees(c, wo, wi, true) {
                return None;
            }
            (wi, BsdfFlags::GLOSSY_REFLECTION, 1.0)
        } else if u1 < pd + pc + pr {
            let wi = reflect_m(wo, h);
            if wi.z * wo.z <= 0.0 || !facet_agrees(h, wo, wi, true) {
                return None;
            }
            (wi, BsdfFlags::GLOSSY_REFLECTION, 1.0)
        } else {
            let wi = refract_m(wo, h, cos_t, eta_ti);
            if wi.z * wo.z >= 0.0 || !facet_agrees(h, wo, wi, false) {
                return None;
            }
            (wi, BsdfFlags::GLOSSY_TRANSMISSION, eta_it)
        };
        let pdf = self.pdf_at(wo, wi);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        let value = self.eval_at(ctx, wo, wi);
        Some(BsdfSample {
            wi,
            pdf,
            eta,
            sampled,
            weight: value / pdf,
        })
    }

    fn eval(&self, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> Rgb {
        self.eval_at(ctx, wo, wi)
    }

    fn pdf(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> f32 {
        self.pdf_at(wo, wi)
    }
}

/// The three methods at an evaluated point (so that `sample` reads the
/// textures once).
impl PrincipledLobe {
    #[inline]
    fn eval_at(&self, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> Rgb {
        let (co, ci) = (wo.z, wi.z);
        if co == 0.0 || co * ci == 0.0 {
            return Rgb::ZERO;
        }
        let front = co > 0.0;
        let reflect = co * ci > 0.0;
        let (h, eta_path) = Self::half_vector(self.eta, wo, wi);
        let (oh, ih) = (wo.dot(h), wi.dot(h));
        let (f, ..) = fresnel_dielectric(oh, self.eta);
        let mut value = Rgb::ZERO;
        let specular_d_g = || self.dist.d(h) * self.dist.g(wo, wi, h);
        if reflect && facet_agrees(h, wo, wi, true) {
            if f > 0.0 {
                let fr = self.principled_fresnel(f, oh, front);
                value += fr * (specular_d_g() / (4.0 * co.abs()));
            }
            if front && self.clearcoat > 0.0 {
                let fc = schlick_fresnel(Rgb::splat(0.04), oh, self.eta).x;
                let dc = self.coat.d(h) * COAT_MASKING.g(wo, wi, h);
                value += Rgb::splat(0.25 * self.clearcoat * fc * dc * ci.abs());
            }
        } else if !reflect && self.glass > 0.0 && f < 1.0 && facet_agrees(h, wo, wi, false) {
            let scale = refraction_scale(ctx.mode, eta_path);
            let t = scale * (1.0 - f) * specular_d_g() * eta_path * eta_path * oh * ih
                / (co * (oh + eta_path * ih) * (oh + eta_path * ih));
            value += sqrt_rgb(self.v.base_color) * (self.glass * t.abs());
        }
        if reflect && front && self.opaque > 0.0 {
            let cos_d = h.dot(wi);
            value += diffuse_term(&self.v, self.opaque, co.abs(), ci.abs(), cos_d);
            value += sheen_term(&self.v, 1.0 - self.metallic, ci.abs(), cos_d);
        }
        value
    }

    #[inline]
    fn pdf_at(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (co, ci) = (wo.z, wi.z);
        if co == 0.0 || co * ci == 0.0 {
            return 0.0;
        }
        let front = co > 0.0;
        if !front && self.glass <= 0.0 {
            return 0.0;
        }
        let reflect = co * ci > 0.0;
        let (h, eta_path) = Self::half_vector(self.eta, wo, wi);
        let (oh, ih) = (wo.dot(h), wi.dot(h));
        let (f, ..) = fresnel_dielectric(oh, self.eta);
        let [pd, pc, pr, pt] = self.lobe_probabilities(front, f);
        let up = if front { wo } else { -wo };
        let mut pdf = 0.0;
        if reflect {
            if facet_agrees(h, wo, wi, true) {
                let dh_dwi = 1.0 / (4.0 * ih.abs());
                pdf += (pr * self.dist.pdf(up, h) + pc * self.coat.pdf(h)) * dh_dwi;
            }
            pdf += pd * cosine_hemisphere_pdf(wi);
        } else if pt > 0.0 && facet_agrees(h, wo, wi, false) {
            let denom = oh + eta_path * ih;
            let dh_dwi = (eta_path * eta_path * ih / (denom * denom)).abs();
            pdf += pt * self.dist.pdf(up, h) * dh_dwi;
        }
        pdf
    }
}

/// Component-wise square root (the transmission tint √`base_color`).
#[inline]
pub(crate) fn sqrt_rgb(c: Rgb) -> Rgb {
    Rgb::new(
        c.x.max(0.0).sqrt(),
        c.y.max(0.0).sqrt(),
        c.z.max(0.0).sqrt(),
    )
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::tests::{albedo, flat_si, Variant};
    use crate::bsdf::BsdfModel;
    use crate::bsdf::{Conductor, Material};

    fn principled(f: impl FnOnce(&mut Principled)) -> Principled {
        let mut b = Principled::new(Rgb::new(0.8, 0.4, 0.2));
        f(&mut b);
        b
    }

    /// Configurations for the table-driven tests in `bsdf/mod.rs`.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let v = |name: &str, b: Principled| Variant::last(name, vec![Material::Principled(b)]);
        let mut textured = v(
            "principled (textured base_color and roughness)",
            principled(|b| {
                b.common.base_color = Tex::Texture(0);
                b.common.roughness = Tex::Texture(0);
                b.metallic = Tex::value(0.3);
            }),
        );
        textured
            .m
            .textures
            .push(crate::texture::Texture::Checkerboard(
                crate::texture::Checkerboard {
                    color0: Tex::Const(Rgb::new(0.9, 0.5, 0.1)),
                    color1: Tex::value(0.2),
                    to_uv: glam::Affine2::IDENTITY,
                    float_swapped: false,
                },
            ));
        let mut out = vec![
            v("principled (defaults)", principled(|_| ())),
            v(
                "principled (rough 0.1)",
                principled(|b| b.common.roughness = Tex::value(0.1)),
            ),
            v(
                "principled (rough 0.9, sheen, flatness)",
                principled(|b| {
                    b.common.roughness = Tex::value(0.9);
                    b.common.sheen = Tex::value(0.8);
                    b.common.sheen_tint = Tex::value(0.5);
                    b.common.flatness = Tex::value(0.6);
                }),
            ),
            v(
                "principled (metallic 1, anisotropic 0.8)",
                principled(|b| {
                    b.metallic = Tex::value(1.0);
                    b.common.roughness = Tex::value(0.3);
                    b.common.anisotropic = Tex::value(0.8);
                }),
            ),
            v(
                "principled (metallic 0.5, spec_tint, clearcoat)",
                principled(|b| {
                    b.metallic = Tex::value(0.5);
                    b.common.spec_tint = Tex::value(0.7);
                    b.clearcoat = Tex::value(1.0);
                    b.clearcoat_gloss = Tex::value(0.5);
                }),
            ),
            v(
                "principled (spec_trans 1, rough 0.2)",
                principled(|b| {
                    b.common.spec_trans = Tex::value(1.0);
                    b.common.roughness = Tex::value(0.2);
                }),
            ),
            v(
                "principled (spec_trans 0.5, anisotropic 0.5, eta 1.33)",
                principled(|b| {
                    b.common.spec_trans = Tex::value(0.5);
                    b.common.anisotropic = Tex::value(0.5);
                    b.common.roughness = Tex::value(0.6);
                    b.ior = PrincipledIor::Eta(Tex::value(1.33));
                }),
            ),
            textured,
        ];
        for x in &mut out {
            // The transmission divides radiance by η² on entering, and
            // the specular lobe uses Schlick: not reciprocal.
            x.reciprocal = false;
            // Diffuse and specular are added without coupling (Burley
            // 2012, §5.3): their sum exceeds one at grazing angles. The
            // specular lobes alone do conserve energy (tested below).
            x.energy_conserving = !x.name.contains("rough 0.1") && !x.name.contains("sheen");
        }
        out
    }

    /// Without the diffuse lobe (black base colour) the remaining
    /// specular and clearcoat lobes reflect at most what arrives, from
    /// every direction.
    #[test]
    fn specular_lobes_conserve_energy() {
        let b = Principled {
            clearcoat: Tex::value(1.0),
            common: DisneyParams {
                roughness: Tex::value(0.1),
                ..DisneyParams::new(Rgb::ZERO)
            },
            ..Principled::new(Rgb::ZERO)
        };
        let t = Materials::with_bsdfs(vec![Material::Principled(b)]);
        for z in [1.0f32, 0.5, 0.2, 0.05] {
            let wo = Vec3::new((1.0 - z * z).sqrt(), 0.0, z);
            let a = albedo(&t, 0, wo);
            assert!(a.max_element() <= 1.0, "albedo {a} at cos {z}");
        }
    }

    /// A textured `specular` (a yubin extension) gives on each square of a
    /// checkerboard what the constant of that square gives, and `eta`
    /// equals the `specular` it corresponds to.
    #[test]
    fn textured_specular_and_eta_match_constants() {
        let checker = crate::texture::Texture::Checkerboard(crate::texture::Checkerboard {
            color0: Tex::value(0.2),
            color1: Tex::value(0.9),
            to_uv: glam::Affine2::IDENTITY,
            float_swapped: false,
        });
        let with = |ior| {
            let mut m = Materials::with_bsdfs(vec![Material::Principled(Principled {
                ior,
                ..Principled::new(Rgb::new(0.5, 0.4, 0.3))
            })]);
            m.textures.push(checker);
            m
        };
        let eta_of = |s: f32| 2.0 / (1.0 - (0.08 * s).sqrt()) - 1.0;
        let textured = with(PrincipledIor::Specular(Tex::Texture(0)));
        let ctx = BsdfContext::default();
        let (wo, wi) = (
            Vec3::new(0.3, 0.1, 0.9).normalize(),
            Vec3::new(-0.4, 0.0, 0.8).normalize(),
        );
        for (u, s) in [(0.25, 0.2), (0.75, 0.9)] {
            let si = SurfaceInteraction {
                uv: Vec2::new(u, 0.25),
                ..flat_si()
            };
            let got = textured.bsdfs[0].eval(&textured, &ctx, &si, wo, wi);
            for ior in [
                PrincipledIor::Specular(Tex::value(s)),
                PrincipledIor::Eta(Tex::value(eta_of(s))),
            ] {
                let c = with(ior);
                let want = c.bsdfs[0].eval(&c, &ctx, &si, wo, wi);
                assert!((got - want).abs().max_element() < 1e-5, "{got} vs {want}");
            }
        }
    }

    /// Metallic 1 at vanishing roughness is a mirror whose reflectance is
    /// Schlick's with R0 = base colour: it approaches `conductor` with
    /// that reflectance (at normal incidence, where Schlick is exact).
    #[test]
    fn metallic_smooth_limit_is_a_conductor() {
        let base = Rgb::new(0.9, 0.6, 0.3);
        let b = Principled {
            metallic: Tex::value(1.0),
            common: DisneyParams {
                roughness: Tex::value(0.0),
                ..DisneyParams::new(base)
            },
            ..Principled::new(base)
        };
        let t = Materials::with_bsdfs(vec![Material::Principled(b)]);
        let wo = Vec3::new(0.0, 0.01, 1.0).normalize();
        let a = albedo(&t, 0, wo);
        // A conductor whose Fresnel at normal incidence is the base
        // colour: η from R0 with k = 0.
        let eta = base.map(|r0| (1.0 + r0.sqrt()) / (1.0 - r0.sqrt()));
        let c = Materials::with_bsdfs(vec![Material::Conductor(Conductor::new(eta, Rgb::ZERO))]);
        let reference = albedo(&c, 0, wo);
        assert!(
            (a - reference).abs().max_element() < 0.01,
            "principled metallic {a} vs conductor {reference}"
        );
        // Nearly all of it comes back towards the mirror direction.
        let ctx = BsdfContext::default();
        let s = t.bsdfs[0]
            .sample(&t, &ctx, &flat_si(), wo, 0.5, Vec2::new(0.3, 0.7))
            .unwrap();
        assert!(s.wi.dot(Vec3::new(-wo.x, -wo.y, wo.z)) > 0.999, "{}", s.wi);
    }

    /// Known values of the terms at normal incidence, where every Schlick
    /// weight vanishes: the diffuse is base/π (plus the retro-reflection
    /// 2 roughness (0 + 0 + 0)), the dielectric reflection uses F(η).
    #[test]
    fn diffuse_at_normal_incidence_is_lambert() {
        let base = Rgb::new(0.5, 0.25, 0.125);
        let t = Materials::with_bsdfs(vec![Material::Principled(Principled::new(base))]);
        let ctx = BsdfContext::default();
        // A direction pair far from the specular peak at roughness 0.5
        // still sees some highlight: compare against the lobes' sum.
        let (wo, wi) = (Vec3::Z, Vec3::Z);
        let got = t.bsdfs[0].eval(&t, &ctx, &flat_si(), wo, wi);
        let d = ggx(0.5, 0.0);
        let spec = 0.04 * d.d(Vec3::Z) * d.g(wo, wi, Vec3::Z) / 4.0;
        let want = base * std::f32::consts::FRAC_1_PI + Rgb::splat(spec);
        assert!((got - want).abs().max_element() < 1e-5, "{got} vs {want}");
    }
}
