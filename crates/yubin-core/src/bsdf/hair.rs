//! `hair`: the hair and fur model of Chiang et al. 2016 (Mitsuba 3's
//! `hair`): a rough dielectric cylinder whose light reflects (R), passes
//! through (TT), reflects once inside (TRT) or more (a residual lobe),
//! coloured by the melanin absorbed along its path. For `bsplinecurve`
//! (and `linearcurve`) fibres.
//!
//! | parameter                | type                  | default | meaning |
//! |--------------------------|-----------------------|---------|---------|
//! | `eumelanin`              | float                 | 1.3     | brown-black pigment (0 white … 8 black) |
//! | `pheomelanin`            | float                 | 0.2     | red-yellow pigment |
//! | `sigma_a`                | rgb / texture         | —       | absorption per unit of fibre radius, instead of the pigments |
//! | `scale`                  | float                 | 1       | multiplies `sigma_a` |
//! | `longitudinal_roughness` | float                 | 0.3     | β_m, 0 to 1 |
//! | `azimuthal_roughness`    | float                 | 0.3     | β_n, 0 to 1 |
//! | `scale_tilt`             | float                 | 2       | the cuticle scales' tilt α, degrees |
//! | `int_ior`                | float or material name | `amber` (1.55) | inside the fibre |
//! | `ext_ior`                | float or material name | `air`   | outside |
//!
//! ```xml
//! <bsdf type="hair">
//!     <float name="eumelanin" value="0.3"/>
//!     <float name="pheomelanin" value="0.2"/>
//! </bsdf>
//! ```
//!
//! **Frame** (Mitsuba's): in the shading frame x runs round the fibre, y
//! along it and z out of it, as `bsplinecurve` makes it. With the viewer
//! direction ωi = (x, y, z): sin θ = y (longitudinal), φ = atan2(z, x), and
//! the offset across the fibre is h = −x / √(x² + z²), taken from the
//! direction (not from the hit's v as pbrt does).
//!
//! **Model** (Chiang et al. 2016 §4, d'Eon et al. 2011). σ_a from melanin
//! is eumelanin × (0.419, 0.697, 1.37) + pheomelanin × (0.187, 0.4, 1.05);
//! η = int_ior / ext_ior; γ_i = asin h, γ_t = asin(h / η′) with
//! η′ = √(η² − sin²θ_i) / cos θ_i; one chord transmits
//! T = e^{−σ_a 2 cos γ_t / cos θ_t}; with Fresnel f at cos θ_i cos γ_i the
//! lobes carry A₀ = f, A₁ = (1 − f)² T, A₂ = A₁ T f, A₃ = A₂ T f / (1 − T f).
//! Each lobe p < 3 is M_p(θ_i′, θ_o) A_p N_p(Δφ): M the longitudinal
//! von Mises–Fisher-like lobe of d'Eon et al. of variance v_p (v₀ =
//! (0.726 β_m + 0.812 β_m² + 3.7 β_m²⁰)², v₁ = v₀/4, v₂ = 4v₀) about θ_i
//! tilted by −2α, α, 4α; N a logistic of scale s = √(π/8)(0.265 β_n +
//! 1.194 β_n² + 5.372 β_n²²) trimmed to [−π, π] about
//! Φ = 2pγ_t − 2γ_i + pπ. The residual is M₃(θ_i, θ_o; 4v₀) A₃ / 2π. The
//! value includes the cosine (as every yubin BSDF's) and has no side: light
//! passes through the fibre. Not reciprocal (h and the tilt are the
//! viewer's).
//!
//! **Sampling** picks a lobe in proportion to the luminance of A_p, then
//! θ_o by inverting M (d'Eon et al.) and Δφ by inverting the trimmed
//! logistic (uniform for the residual); the density is the mixture's.
//! Values, densities and samples equal Mitsuba 3.9.1's (its `scalar_rgb`
//! read at 64 direction pairs and 16 samples over four parameter sets).
//!
//! References: M. J.-Y. Chiang, B. Bitterli, C. Tappan, B. Burley, "A
//! practical and controllable hair and fur model for production path
//! tracing", CGF 35(4), 2016; E. d'Eon, G. Francois, M. Hill, J. Letteri,
//! J.-M. Aubry, "An energy-conserving hair reflectance model", EGSR 2011;
//! S. R. Marschner et al., "Light scattering from human hair fibers",
//! SIGGRAPH 2003; Mitsuba 3 documentation, "Hair (hair)".

use super::fresnel::fresnel_dielectric;
use super::{BsdfContext, BsdfFlags, BsdfSample, Scatter};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::spectrum::ior::ior_from_params;
use crate::spectrum::luminance;
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Absorption of one unit of each pigment (d'Eon et al. 2011).
const EUMELANIN: [f32; 3] = [0.419, 0.697, 1.37];
const PHEOMELANIN: [f32; 3] = [0.187, 0.4, 1.05];

/// The hair BSDF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hair {
    /// Absorption per unit of fibre radius (a texture, or the pigments').
    pub sigma_a: Tex,
    /// Multiplies `sigma_a`.
    pub scale: f32,
    /// Longitudinal variances of the lobes R, TT, TRT and the residual.
    pub v: [f32; 4],
    /// Azimuthal logistic scale.
    pub s: f32,
    /// sin and cos of α, 2α and 4α.
    pub tilt: [(f32, f32); 3],
    /// Interior / exterior index of refraction.
    pub eta: f32,
}

impl Hair {
    /// Builds the BSDF from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let pigments = p.has("eumelanin") || p.has("pheomelanin");
        let (sigma_a, scale) = if p.has("sigma_a") {
            if pigments {
                return Err(p.error(
                    "give the pigments (eumelanin, pheomelanin) or the absorption (sigma_a), not both",
                ));
            }
            let scale = p.float_or("scale", 1.0)?;
            (
                p.texture_or("sigma_a", ColorKind::Unbounded, Rgb::ZERO)?,
                scale,
            )
        } else {
            let eu = p.float_or("eumelanin", 1.3)?;
            let pheo = p.float_or("pheomelanin", 0.2)?;
            if !(eu >= 0.0 && pheo >= 0.0 && eu.is_finite() && pheo.is_finite()) {
                return Err(p.error(&format!("pigments must be 0 or more, not {eu} and {pheo}")));
            }
            p.mark_ignored("scale");
            let sigma = Rgb::from(EUMELANIN) * eu + Rgb::from(PHEOMELANIN) * pheo;
            (Tex::Const(sigma), 1.0)
        };
        let roughness = |p: &mut dyn Params, name: &str| -> Result<f32, ParamError> {
            let b = p.float_or(name, 0.3)?;
            if (0.0..=1.0).contains(&b) {
                Ok(b)
            } else {
                Err(p.param_error(name, &format!("must be in [0, 1], not {b}")))
            }
        };
        let beta_m = roughness(p, "longitudinal_roughness")?;
        let beta_n = roughness(p, "azimuthal_roughness")?;
        let alpha = p.float_or("scale_tilt", 2.0)?;
        let int_ior = ior_from_params(p, "int_ior", "amber")?;
        let ext_ior = ior_from_params(p, "ext_ior", "air")?;
        if !(int_ior > 0.0 && ext_ior > 0.0) || int_ior == ext_ior {
            return Err(p.param_error(
                "int_ior",
                "the interior and exterior indices must be positive and differ",
            ));
        }
        Ok(Self::new(
            sigma_a,
            scale,
            beta_m,
            beta_n,
            alpha,
            int_ior / ext_ior,
        ))
    }

    /// The BSDF of absorption `sigma_a` × `scale`, roughnesses β_m and β_n,
    /// tilt `alpha_deg` and relative index `eta`.
    pub fn new(
        sigma_a: Tex,
        scale: f32,
        beta_m: f32,
        beta_n: f32,
        alpha_deg: f32,
        eta: f32,
    ) -> Self {
        let v0 = (0.726 * beta_m + 0.812 * beta_m.powi(2) + 3.7 * beta_m.powi(20)).powi(2);
        let s =
            (PI / 8.0).sqrt() * (0.265 * beta_n + 1.194 * beta_n.powi(2) + 5.372 * beta_n.powi(22));
        let a = alpha_deg.to_radians();
        let mut tilt = [(a.sin(), a.cos()); 3];
        for i in 1..3 {
            let (sp, cp) = tilt[i - 1];
            tilt[i] = (2.0 * cp * sp, cp * cp - sp * sp);
        }
        Self {
            sigma_a,
            scale,
            v: [v0, 0.25 * v0, 4.0 * v0, 4.0 * v0],
            s,
            tilt,
            eta,
        }
    }

    /// Lobes this material has.
    pub fn flags(&self, _: &Materials) -> BsdfFlags {
        BsdfFlags::GLOSSY_REFLECTION
            | BsdfFlags::GLOSSY_TRANSMISSION
            | BsdfFlags::FRONT_SIDE
            | BsdfFlags::BACK_SIDE
    }

    /// The lobe at `si`.
    #[inline]
    pub fn lobe(&self, m: &Materials, si: &SurfaceInteraction) -> HairLobe {
        HairLobe {
            sigma_a: self.sigma_a.eval(m, si) * self.scale,
            v: self.v,
            s: self.s,
            tilt: self.tilt,
            eta: self.eta,
        }
    }
}

/// [`Hair`] at a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HairLobe {
    /// Absorption per unit of fibre radius.
    pub sigma_a: Rgb,
    /// Longitudinal variances.
    pub v: [f32; 4],
    /// Azimuthal logistic scale.
    pub s: f32,
    /// sin and cos of α, 2α, 4α.
    pub tilt: [(f32, f32); 3],
    /// Relative index of refraction.
    pub eta: f32,
}

/// What the viewer direction sets: its angles, the offset h and the lobes'
/// attenuations.
struct Incidence {
    sin_i: f32,
    cos_i: f32,
    phi_i: f32,
    gamma_i: f32,
    gamma_t: f32,
    attenuation: [Rgb; 4],
}

/// sin θ, cos θ, φ of a direction in the fibre's frame.
#[inline]
fn angles(w: Vec3) -> (f32, f32, f32) {
    let sin = w.y.clamp(-1.0, 1.0);
    (sin, (1.0 - sin * sin).max(0.0).sqrt(), w.z.atan2(w.x))
}

impl HairLobe {
    fn incidence(&self, wi: Vec3) -> Incidence {
        let (sin_i, cos_i, phi_i) = angles(wi);
        let across = (wi.x * wi.x + wi.z * wi.z).sqrt();
        let h = if across > 0.0 {
            (-wi.x / across).clamp(-1.0, 1.0)
        } else {
            0.0
        };
        let gamma_i = h.asin();
        let sin_t = sin_i / self.eta;
        let cos_t = (1.0 - sin_t * sin_t).max(0.0).sqrt();
        let eta_p = (self.eta * self.eta - sin_i * sin_i).max(0.0).sqrt() / cos_i;
        let sin_gamma_t = (h / eta_p).clamp(-1.0, 1.0);
        let gamma_t = sin_gamma_t.asin();
        let cos_gamma_t = (1.0 - sin_gamma_t * sin_gamma_t).max(0.0).sqrt();
        let transmittance = (-self.sigma_a * (2.0 * cos_gamma_t / cos_t)).exp();
        let f = fresnel_dielectric(cos_i * (1.0 - h * h).max(0.0).sqrt(), self.eta).0;
        let a0 = Rgb::splat(f);
        let a1 = transmittance * (1.0 - f) * (1.0 - f);
        let a2 = a1 * transmittance * f;
        let a3 = a2 * transmittance * f / (Rgb::ONE - transmittance * f);
        Incidence {
            sin_i,
            cos_i,
            phi_i,
            gamma_i,
            gamma_t,
            attenuation: [a0, a1, a2, a3],
        }
    }

    /// θ_i tilted for lobe `p` (sin, |cos|).
    #[inline]
    fn tilted(&self, inc: &Incidence, p: usize) -> (f32, f32) {
        let (s, c) = (inc.sin_i, inc.cos_i);
        let (sin, cos) = match p {
            0 => {
                let (s2, c2) = self.tilt[1];
                (s * c2 - c * s2, c * c2 + s * s2)
            }
            1 => {
                let (s1, c1) = self.tilt[0];
                (s * c1 + c * s1, c * c1 - s * s1)
            }
            2 => {
                let (s4, c4) = self.tilt[2];
                (s * c4 + c * s4, c * c4 - s * s4)
            }
            _ => (s, c),
        };
        (sin, cos.abs())
    }

    /// The lobes' sampling probabilities: their attenuations' luminance.
    fn lobe_pdfs(inc: &Incidence) -> [f32; 4] {
        let y = inc.attenuation.map(|a| luminance(a).max(0.0));
        let total: f32 = y.iter().sum();
        if total > 0.0 {
            y.map(|v| v / total)
        } else {
            [0.0; 4]
        }
    }

    /// Σ over lobes of M_p N_p × weight_p (the attenuations for the
    /// value, their probabilities for the density).
    fn sum(&self, inc: &Incidence, wo: Vec3, weight: impl Fn(usize) -> Rgb) -> Rgb {
        let (sin_o, cos_o, phi_o) = angles(wo);
        let dphi = phi_o - inc.phi_i;
        let mut total = Rgb::ZERO;
        for p in 0..3 {
            let (sin_ip, cos_ip) = self.tilted(inc, p);
            let m = longitudinal(cos_ip, cos_o, sin_ip, sin_o, self.v[p]);
            let phi = 2.0 * p as f32 * inc.gamma_t - 2.0 * inc.gamma_i + p as f32 * PI;
            let n = trimmed_logistic(wrap_pi(dphi - phi), self.s);
            total += weight(p) * (m * n);
        }
        let m3 = longitudinal(inc.cos_i, cos_o, inc.sin_i, sin_o, self.v[3]);
        total += weight(3) * (m3 / (2.0 * PI));
        if total.is_finite() {
            total
        } else {
            Rgb::ZERO
        }
    }
}

/// `x` wrapped into [−π, π].
#[inline]
fn wrap_pi(mut x: f32) -> f32 {
    while x > PI {
        x -= 2.0 * PI;
    }
    while x < -PI {
        x += 2.0 * PI;
    }
    x
}

/// The modified Bessel function I₀ (its series to eleven terms, as
/// Mitsuba sums it).
fn bessel_i0(x: f32) -> f32 {
    let x2 = x * x / 4.0;
    let (mut term, mut sum) = (1.0f32, 1.0f32);
    for k in 1..=10 {
        term *= x2 / (k * k) as f32;
        sum += term;
    }
    sum
}

/// ln I₀, by its asymptote for large arguments.
fn log_bessel_i0(x: f32) -> f32 {
    if x > 12.0 {
        x + 0.5 * (-(2.0 * PI).ln() + (1.0 / x).ln() + 1.0 / (8.0 * x))
    } else {
        bessel_i0(x).ln()
    }
}

/// ln 2 to four places, as Mitsuba (and pbrt-v3) write it in the lobe
/// below: its values are matched to 10⁻⁴.
#[allow(clippy::approx_constant)]
const LN_2_AS_MITSUBA: f32 = 0.6931;

/// d'Eon et al.'s longitudinal lobe of variance `v` (in logarithms for
/// small variances, where the terms overflow).
fn longitudinal(cos_i: f32, cos_o: f32, sin_i: f32, sin_o: f32, v: f32) -> f32 {
    let a = cos_i * cos_o / v;
    let b = sin_i * sin_o / v;
    if 1.0 / v > 10.0 {
        (log_bessel_i0(a) - b - 1.0 / v + LN_2_AS_MITSUBA + (1.0 / (2.0 * v)).ln()).exp()
    } else {
        (-b).exp() * bessel_i0(a) / ((1.0 / v).sinh() * 2.0 * v)
    }
}

#[inline]
fn logistic(x: f32, s: f32) -> f32 {
    let e = (-x.abs() / s).exp();
    e / (s * (1.0 + e) * (1.0 + e))
}

#[inline]
fn logistic_cdf(x: f32, s: f32) -> f32 {
    1.0 / (1.0 + (-x / s).exp())
}

/// The logistic of scale `s` on [−π, π], normalized there.
#[inline]
fn trimmed_logistic(x: f32, s: f32) -> f32 {
    logistic(x, s) / (logistic_cdf(PI, s) - logistic_cdf(-PI, s))
}

impl Scatter for HairLobe {
    fn sample(&self, ctx: &BsdfContext, wo: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
        // Mitsuba's names: the viewer's direction is ωi.
        let inc = self.incidence(wo);
        let pdfs = Self::lobe_pdfs(&inc);
        let mut u = u1;
        let mut p = 0;
        while p < 3 && u >= pdfs[p] {
            u -= pdfs[p];
            p += 1;
        }
        if pdfs[p] <= 0.0 {
            return None;
        }
        let u = (u / pdfs[p]).min(1.0 - f32::EPSILON / 2.0);
        let (sin_ip, cos_ip) = self.tilted(&inc, p);
        // The longitudinal angle (d'Eon et al.), then the azimuth.
        let v = self.v[p];
        let cos_theta = 1.0 + v * (u2.x + (1.0 - u2.x) * (-2.0 / v).exp()).ln();
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let cos_phi = (2.0 * PI * u2.y).cos();
        let sin_o = -cos_theta * sin_ip + sin_theta * cos_phi * cos_ip;
        let cos_o = (1.0 - sin_o * sin_o).max(0.0).sqrt();
        let dphi = if p < 3 {
            let phi = 2.0 * p as f32 * inc.gamma_t - 2.0 * inc.gamma_i + p as f32 * PI;
            let s = self.s;
            let (lo, hi) = (logistic_cdf(-PI, s), logistic_cdf(PI, s));
            let x = (-s * (1.0 / (u * (hi - lo) + lo) - 1.0).ln()).clamp(-PI, PI);
            phi + x
        } else {
            2.0 * PI * u
        };
        let phi_o = inc.phi_i + dphi;
        let wi = Vec3::new(cos_o * phi_o.cos(), sin_o, cos_o * phi_o.sin()).normalize();
        if !wi.is_finite() {
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
            sampled: if wi.z * wo.z >= 0.0 {
                BsdfFlags::GLOSSY_REFLECTION
            } else {
                BsdfFlags::GLOSSY_TRANSMISSION
            },
            weight: self.eval(ctx, wo, wi) / pdf,
        })
    }

    #[inline]
    fn eval(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> Rgb {
        let inc = self.incidence(wo);
        self.sum(&inc, wi, |p| inc.attenuation[p])
    }

    #[inline]
    fn pdf(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> f32 {
        let inc = self.incidence(wo);
        let pdfs = Self::lobe_pdfs(&inc);
        self.sum(&inc, wi, |p| Rgb::splat(pdfs[p])).x
    }
}

// Mitsuba's values are written with 9 digits, as printed.
#[allow(clippy::excessive_precision)]
#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::tests::Variant;
    use crate::bsdf::Material;

    /// (eumelanin, pheomelanin, sigma_a × scale or none, β_m, β_n, tilt,
    /// int_ior).
    type Set = (f32, f32, Option<[f32; 3]>, f32, f32, f32, f32);
    /// (set, viewer ωi, light ωo, value, pdf).
    type Eval = (usize, [f32; 3], [f32; 3], [f32; 3], f32);
    /// (set, ωi, sample1, sample2, ωo, pdf, weight).
    type Sample = (usize, [f32; 3], f32, [f32; 2], [f32; 3], f32, [f32; 3]);

    include!("hair_refs.rs");

    fn lobe(set: usize) -> HairLobe {
        let (eu, pheo, sigma, beta_m, beta_n, tilt, ior) = SETS[set];
        let sigma_a = sigma.map_or_else(
            || Rgb::from(EUMELANIN) * eu + Rgb::from(PHEOMELANIN) * pheo,
            Rgb::from,
        );
        let h = Hair::new(
            Tex::Const(sigma_a),
            1.0,
            beta_m,
            beta_n,
            tilt,
            ior / 1.000_277,
        );
        HairLobe {
            sigma_a,
            v: h.v,
            s: h.s,
            tilt: h.tilt,
            eta: h.eta,
        }
    }

    fn close(a: f32, b: f32) -> bool {
        (a - b).abs() <= 2e-4 * a.abs().max(b.abs()) + 1e-6
    }

    /// Values, densities and samples as Mitsuba 3.9.1's `hair` gives them
    /// (its ωi the viewer: yubin's wo).
    #[test]
    fn evaluates_and_samples_as_mitsuba() {
        let ctx = BsdfContext::default();
        let mut failures = Vec::new();
        for &(set, wi, wo, value, pdf) in EVALS {
            let l = lobe(set);
            let (view, light) = (Vec3::from(wi), Vec3::from(wo));
            let got = l.eval(&ctx, view, light);
            let got_pdf = l.pdf(&ctx, view, light);
            if !((0..3).all(|c| close(got[c], value[c])) && close(got_pdf, pdf)) {
                failures.push(format!(
                    "set {set} {wi:?} → {wo:?}: {got} / {got_pdf} vs {value:?} / {pdf}"
                ));
            }
        }
        // The sampled direction (to rounding: it goes through logarithms
        // and square roots), and the density and weight at Mitsuba's.
        for &(set, wi, u1, u2, wo, pdf, weight) in SAMPLES {
            let l = lobe(set);
            let (view, light) = (Vec3::from(wi), Vec3::from(wo));
            let s = l.sample(&ctx, view, u1, Vec2::from(u2));
            let at = l.eval(&ctx, view, light) / l.pdf(&ctx, view, light);
            let ok = s.is_some_and(|s| {
                (s.wi - light).length() < 1e-4
                    && close(l.pdf(&ctx, view, light), pdf)
                    && (0..3).all(|c| close(at[c], weight[c]))
            });
            if !ok {
                failures.push(format!(
                    "set {set} sample {wi:?} {u1} {u2:?}: {s:?} vs {wo:?} {pdf} {weight:?}"
                ));
            }
        }
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    }

    /// Blonde and brown hair, smooth and rough, in the table-driven test of
    /// every BSDF (not reciprocal: h and the tilt are the viewer's).
    pub(crate) fn test_variants() -> Vec<Variant> {
        [
            ("blonde", 0.3, 0.2, 0.3, 0.3),
            ("brown, smooth", 1.3, 0.2, 0.15, 0.25),
            ("red, rough", 0.01, 1.6, 0.6, 0.7),
        ]
        .into_iter()
        .map(|(name, eu, pheo, bm, bn)| {
            let sigma = Rgb::from(EUMELANIN) * eu + Rgb::from(PHEOMELANIN) * pheo;
            let mut v = Variant::last(
                format!("hair ({name})"),
                vec![Material::Hair(Hair::new(
                    Tex::Const(sigma),
                    1.0,
                    bm,
                    bn,
                    2.0,
                    1.55,
                ))],
            );
            v.reciprocal = false;
            v
        })
        .collect()
    }
}
