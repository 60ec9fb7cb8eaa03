//! The pieces `principled` and `principledthin` share (not a plugin): the
//! parameters both read, Schlick's Fresnel approximation, Burley's
//! roughness remapping, the diffuse, retro-reflection, fake-subsurface and
//! sheen terms of the Disney BRDF, and the GTR1 distribution of the
//! clearcoat.
//!
//! Formulas from Burley 2012, "Physically Based Shading at Disney"
//! (SIGGRAPH course notes: GTR1 in Appendix B, the diffuse and sheen terms
//! in §5.3, the roughness remapping α = roughness², the anisotropic aspect
//! √(1 − 0.9 anisotropic)) and Burley 2015, "Extending the Disney BRDF to a
//! BSDF with Integrated Subsurface Scattering" (§3: the diffuse model split
//! into Lambert, retro-reflection and the Hanrahan–Krueger "flatness"
//! term), with Mitsuba 3's conventions where the papers leave a choice.

use super::microfacet::{Microfacet, MicrofacetType};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::spectrum::luminance;
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// The parameters both principled models read, as given in the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DisneyParams {
    /// Colour of the diffuse, metallic and transmission lobes.
    pub base_color: Tex,
    /// Roughness of the main specular lobes, in [0, 1].
    pub roughness: Tex,
    /// Anisotropy of the main specular lobes, in [0, 1].
    pub anisotropic: Tex,
    /// Blend of the opaque and transmissive responses, in [0, 1].
    pub spec_trans: Tex,
    /// Tint of the dielectric reflection towards the base colour.
    pub spec_tint: Tex,
    /// Weight of the sheen lobe.
    pub sheen: Tex,
    /// Tint of the sheen towards the base colour.
    pub sheen_tint: Tex,
    /// Blend of the diffuse and the fake-subsurface responses.
    pub flatness: Tex,
}

/// [`DisneyParams`] evaluated at one surface point (weights clamped to
/// their ranges).
#[derive(Clone, Copy, Debug)]
pub(crate) struct DisneyValues {
    pub base_color: Rgb,
    pub roughness: f32,
    pub anisotropic: f32,
    pub spec_trans: f32,
    pub spec_tint: f32,
    pub sheen: f32,
    pub sheen_tint: f32,
    pub flatness: f32,
}

impl DisneyParams {
    /// Reads the shared parameters (see the plugins' tables).
    pub(crate) fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        Ok(Self {
            base_color: p.texture_or("base_color", ColorKind::Reflectance, Rgb::splat(0.5))?,
            roughness: weight_param(p, "roughness", 0.5, 1.0)?,
            anisotropic: weight_param(p, "anisotropic", 0.0, 1.0)?,
            spec_trans: weight_param(p, "spec_trans", 0.0, 1.0)?,
            spec_tint: weight_param(p, "spec_tint", 0.0, 1.0)?,
            sheen: weight_param(p, "sheen", 0.0, 1.0)?,
            sheen_tint: weight_param(p, "sheen_tint", 0.0, 1.0)?,
            flatness: weight_param(p, "flatness", 0.0, 1.0)?,
        })
    }

    /// Defaults of every parameter (a grey, half-rough dielectric).
    pub fn new(base_color: Rgb) -> Self {
        Self {
            base_color: Tex::Const(base_color),
            roughness: Tex::value(0.5),
            anisotropic: Tex::value(0.0),
            spec_trans: Tex::value(0.0),
            spec_tint: Tex::value(0.0),
            sheen: Tex::value(0.0),
            sheen_tint: Tex::value(0.0),
            flatness: Tex::value(0.0),
        }
    }

    /// The values at `si`.
    #[inline]
    pub(crate) fn at(&self, m: &Materials, si: &SurfaceInteraction) -> DisneyValues {
        let unit = |t: &Tex| t.eval_1(m, si).clamp(0.0, 1.0);
        DisneyValues {
            base_color: self.base_color.eval(m, si),
            roughness: unit(&self.roughness),
            anisotropic: unit(&self.anisotropic),
            spec_trans: unit(&self.spec_trans),
            spec_tint: unit(&self.spec_tint),
            sheen: unit(&self.sheen),
            sheen_tint: unit(&self.sheen_tint),
            flatness: unit(&self.flatness),
        }
    }

    /// Whether the transmissive lobes can be non-zero anywhere.
    pub(crate) fn may_transmit(&self) -> bool {
        !is_zero(&self.spec_trans)
    }
}

/// True for a constant zero.
pub(crate) fn is_zero(t: &Tex) -> bool {
    t.as_const() == Some(Rgb::ZERO)
}

/// A float or texture parameter whose constant value must lie in
/// [0, `max`] (textures are clamped where they are read).
pub(crate) fn weight_param(
    p: &mut dyn Params,
    name: &str,
    default: f32,
    max: f32,
) -> Result<Tex, ParamError> {
    let t = p.texture_or(name, ColorKind::Unbounded, Rgb::splat(default))?;
    if let Some(c) = t.as_const() {
        let v = luminance(c);
        if !(0.0..=max).contains(&v) {
            return Err(p.param_error(name, &format!("must lie in [0, {max}], not {v}")));
        }
    }
    Ok(t)
}

/// Schlick's weight (1 − cos θ)⁵.
#[inline]
pub(crate) fn schlick_weight(cos_theta: f32) -> f32 {
    let m = (1.0 - cos_theta).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// Reflectance at normal incidence of an interface of relative index η.
#[inline]
pub(crate) fn schlick_r0(eta: f32) -> f32 {
    let r = (eta - 1.0) / (eta + 1.0);
    r * r
}

/// Schlick's approximation R0 + (1 − R0)(1 − cos θ)⁵ for light arriving
/// at `cos_theta` (negative from inside) on an interface of index ratio
/// `eta`: seen from the denser side, θ is the transmitted angle (1 past
/// total internal reflection).
#[inline]
pub(crate) fn schlick_fresnel(r0: Rgb, cos_theta: f32, eta: f32) -> Rgb {
    let eta_it = if cos_theta >= 0.0 { eta } else { 1.0 / eta };
    let c = if eta_it > 1.0 {
        cos_theta.abs()
    } else {
        let sin2_t = (1.0 - cos_theta * cos_theta) / (eta_it * eta_it);
        (1.0 - sin2_t).max(0.0).sqrt()
    };
    r0 + (Rgb::ONE - r0) * schlick_weight(c)
}

/// The base colour divided by its luminance: its hue at unit brightness
/// (white for black).
#[inline]
pub(crate) fn tint_color(base: Rgb) -> Rgb {
    let lum = luminance(base);
    if lum > 0.0 {
        base / lum
    } else {
        Rgb::ONE
    }
}

/// GGX with Burley's remapping: α = roughness², stretched by the aspect
/// √(1 − 0.9 anisotropic) (αx = α/aspect, αy = α·aspect), and at least
/// 0.001 so that D stays finite. Visible normals are sampled.
#[inline]
pub(crate) fn ggx(roughness: f32, anisotropic: f32) -> Microfacet {
    let a = roughness * roughness;
    let aspect = (1.0 - 0.9 * anisotropic).sqrt();
    Microfacet {
        kind: MicrofacetType::Ggx,
        alpha_u: (a / aspect).max(0.001),
        alpha_v: (a * aspect).max(0.001),
        sample_visible: true,
    }
}

/// Whether `wo` and `wi` lie on the sides of the facet `h` (oriented
/// towards `wo`'s side of the surface) that reflection or refraction
/// through it requires.
#[inline]
pub(crate) fn facet_agrees(h: Vec3, wo: Vec3, wi: Vec3, reflection: bool) -> bool {
    let h = if wo.z < 0.0 { -h } else { h };
    wo.dot(h) > 0.0
        && if reflection {
            wi.dot(h) > 0.0
        } else {
            wi.dot(h) < 0.0
        }
}

/// The Disney diffuse response at one pair of directions, without the
/// base colour and the 1/π: Lambert with Burley's Fresnel darkening
/// (1 − F_v/2)(1 − F_l/2), the retro-reflection
/// R_R (F_l + F_v + F_l F_v (R_R − 1)) with R_R = 2 roughness cos²θd
/// (Burley 2015, eqs. 4 and 5), and Hanrahan–Krueger's flat subsurface
/// 1.25 (F_ss (1/(cos θl + cos θv) − ½) + ½) with
/// F_ss = (1 + (F_ss90 − 1) F_l)(1 + (F_ss90 − 1) F_v), F_ss90 = R_R/2
/// (Burley 2012, §5.3), blended by `flatness`. `cos_o`, `cos_i` are the
/// absolute cosines of the two directions, `cos_d` the cosine between
/// `wi` and the half vector.
#[inline]
pub(crate) fn diffuse_shape(v: &DisneyValues, cos_o: f32, cos_i: f32, cos_d: f32) -> f32 {
    let (fo, fi) = (schlick_weight(cos_o), schlick_weight(cos_i));
    let lambert = (1.0 - 0.5 * fo) * (1.0 - 0.5 * fi);
    let rr = 2.0 * v.roughness * cos_d * cos_d;
    let retro = rr * (fo + fi + fo * fi * (rr - 1.0));
    if v.flatness == 0.0 {
        return lambert + retro;
    }
    let fss90 = 0.5 * rr;
    let fss = (1.0 + (fss90 - 1.0) * fo) * (1.0 + (fss90 - 1.0) * fi);
    let ss = 1.25 * (fss * (1.0 / (cos_o + cos_i) - 0.5) + 0.5);
    (lambert + retro) * (1.0 - v.flatness) + ss * v.flatness
}

/// Disney diffuse f·|cos θi| at weight `w`: base colour / π times
/// [`diffuse_shape`].
#[inline]
pub(crate) fn diffuse_term(v: &DisneyValues, w: f32, cos_o: f32, cos_i: f32, cos_d: f32) -> Rgb {
    v.base_color * (w * cos_i * FRAC_1_PI * diffuse_shape(v, cos_o, cos_i, cos_d))
}

/// The sheen f·|cos θi| at weight `w`: sheen (1 − cos θd)⁵ in white tinted
/// towards the base colour's hue by `sheen_tint` (Burley 2012, §5.3; no
/// 1/π, as in Burley's reference implementation).
#[inline]
pub(crate) fn sheen_term(v: &DisneyValues, w: f32, cos_i: f32, cos_d: f32) -> Rgb {
    if v.sheen <= 0.0 {
        return Rgb::ZERO;
    }
    let color = Rgb::ONE + (tint_color(v.base_color) - Rgb::ONE) * v.sheen_tint;
    color * (w * v.sheen * schlick_weight(cos_d.abs()) * cos_i)
}

/// Burley's "generalized Trowbridge–Reitz" distribution with γ = 1 (GTR1,
/// Burley 2012, Appendix B, eqs. 4 and 5 of the sampling section):
/// D(m) = (α² − 1) / (π ln α² (1 + (α² − 1) cos²θm)), normalized so that
/// ∫ D cos θm dω = 1; sampled exactly by
/// cos²θm = (1 − α^{2(1−u)}) / (1 − α²).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Gtr1 {
    pub alpha: f32,
}

impl Gtr1 {
    /// D(m); 0 below the surface.
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        (a2 - 1.0) / (PI * a2.ln() * (1.0 + (a2 - 1.0) * m.z * m.z))
    }

    /// Density of [`Gtr1::sample`]: D(m) cos θm.
    #[inline]
    pub fn pdf(&self, m: Vec3) -> f32 {
        self.d(m) * m.z.max(0.0)
    }

    /// A facet normal distributed as D(m) cos θm.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Vec3 {
        let a2 = self.alpha * self.alpha;
        let cos2 = ((1.0 - a2.powf(1.0 - u.y)) / (1.0 - a2)).clamp(0.0, 1.0);
        let sin = (1.0 - cos2).sqrt();
        let (sp, cp) = (2.0 * PI * u.x).sin_cos();
        Vec3::new(cp * sin, sp * sin, cos2.sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;
    use crate::testing::chi2::{chi2_directions, Chi2Config};

    #[test]
    fn gtr1_is_normalized_and_sampled_by_its_pdf() {
        // (At α = 0.001, clearcoat_gloss 1, the peak is narrower than the
        // test's bins.)
        for alpha in [0.01f32, 0.05, 0.3] {
            let d = Gtr1 { alpha };
            chi2_directions(
                &Chi2Config::default(),
                |r: &mut Pcg32| {
                    let m = d.sample(r.next_2d());
                    Some((m, d.pdf(m)))
                },
                |m| d.pdf(m),
            )
            .unwrap_or_else(|e| panic!("GTR1 alpha {alpha}: {e}"));
        }
    }

    #[test]
    fn schlick_limits() {
        let r0 = Rgb::splat(0.04);
        assert!((schlick_fresnel(r0, 1.0, 1.5) - r0).abs().max_element() < 1e-6);
        assert!(
            (schlick_fresnel(r0, 0.0, 1.5) - Rgb::ONE)
                .abs()
                .max_element()
                < 1e-6
        );
        // From inside past the critical angle: total internal reflection.
        assert_eq!(schlick_fresnel(r0, -0.2, 1.5), Rgb::ONE);
        assert!((schlick_r0(1.5) - 0.04).abs() < 1e-6);
    }

    #[test]
    fn burley_diffuse_is_lambert_at_normal_incidence_without_retro() {
        let mut v =
            DisneyParams::new(Rgb::ONE).at(&Materials::default(), &super::super::tests::flat_si());
        v.roughness = 0.0;
        // F(1) = 0 on both sides: (1 − 0)(1 − 0) = 1.
        assert!((diffuse_shape(&v, 1.0, 1.0, 1.0) - 1.0).abs() < 1e-6);
        // At grazing angles Fresnel darkens each side by half.
        assert!((diffuse_shape(&v, 0.0, 1.0, 1.0) - 0.5).abs() < 1e-6);
    }
}
