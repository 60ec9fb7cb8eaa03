//! Microfacet distributions: the normal distribution D(m), Smith's
//! masking function, and sampling of either D(m) cos θm or the normals
//! visible from a direction. Shared by the rough BSDFs (`roughconductor`,
//! `roughdielectric`, `roughplastic`); not a plugin itself, but
//! [`Roughness`] reads the parameters those plugins have in common:
//!
//! | parameter        | type          | default    | meaning                                  |
//! |------------------|---------------|------------|------------------------------------------|
//! | `distribution`   | string        | `beckmann` | `beckmann`, `ggx` or `phong`             |
//! | `alpha`          | float/texture | 0.1        | isotropic roughness (for Beckmann, √2 × the RMS slope) |
//! | `alpha_u`, `alpha_v` | float/texture | —      | anisotropic roughness along the tangents (both or neither; not with `alpha`; not for `phong`) |
//! | `sample_visible` | boolean       | true       | sample only the normals visible from `wo` (ignored by `phong`) |
//!
//! ```xml
//! <bsdf type="roughconductor">
//!     <string name="distribution" value="ggx"/>
//!     <float name="alpha_u" value="0.05"/>
//!     <float name="alpha_v" value="0.3"/>
//! </bsdf>
//! ```
//!
//! `phong` is Mitsuba 0.6's third distribution (Walter et al. 2007, §5.2):
//! D(m) = (αp + 2)/(2π) cos^αp θm with the exponent αp = 2/α² − 2 (clamped
//! at 0), which matches it to the Beckmann distribution of the same α, so
//! `alpha` keeps its meaning. Its Smith Λ is exact for Phong's own slope
//! distribution (a bivariate Student t; closed form through the incomplete
//! beta function, see `phong_lambda`), where Walter et al. and Mitsuba 0.6
//! use the rational fit of Beckmann's G1 with a = √(0.5 αp + 1)/tan θ: the
//! two converge as α → 0 (Phong tends to Beckmann), but the fit
//! under-masks Phong's heavier tails as α grows, so that Mitsuba 0.6's rough Phong mirror
//! reflects 5 % more than it receives at α = 0.6 near grazing; yubin's
//! conserves energy at every roughness (images of very rough Phong
//! surfaces differ from Mitsuba 0.6's at grazing angles for that reason).
//! Phong samples D(m) cos θm, whatever `sample_visible` says (as Mitsuba
//! 0.6 does: there is no closed-form visible-normal sampler). Only
//! isotropic: Mitsuba 0.6's anisotropic Ashikhmin–Shirley variant is not
//! implemented, and different `alpha_u`, `alpha_v` are an error.
//!
//! Conventions (Mitsuba 3's): directions in the local frame, +z the
//! macro-surface normal; `alpha_u` scales slopes along x, `alpha_v` along
//! y; G is the separable Smith form G1(wi) G1(wo) (not the height-
//! correlated one). Beckmann's Λ is evaluated exactly with erfc (Mitsuba
//! uses Walter's rational fit of G1 instead, which differs by up to about
//! 0.4 %), so that the visible-normal density is exactly what the sampler
//! draws.
//!
//! References: Walter et al. 2007, "Microfacet Models for Refraction
//! through Rough Surfaces" (D, Λ, sampling D cos θ); Heitz 2014,
//! "Understanding the Masking-Shadowing Function in Microfacet-Based
//! BRDFs" (Smith Λ, stretching for anisotropy); Heitz & d'Eon 2014,
//! "Importance Sampling Microfacet-Based BSDFs using the Distribution of
//! Visible Normals" (Beckmann visible slopes); Heitz 2018, "Sampling the
//! GGX Distribution of Visible Normals" (JCGT 7(4)); pbrt-v4 §9.6.

use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::spectrum::luminance;
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// The shape of the microfacet normal distribution; every `match` on it
/// is in this file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MicrofacetType {
    /// Beckmann–Spizzichino: Gaussian slopes.
    Beckmann,
    /// GGX / Trowbridge–Reitz: long-tailed slopes.
    Ggx,
    /// Phong: cosine-power normals, exponent 2/α² − 2 (isotropic only;
    /// never samples visible normals).
    Phong,
}

/// A microfacet distribution at one point of a surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    /// Shape of the distribution.
    pub kind: MicrofacetType,
    /// Roughness along the x tangent.
    pub alpha_u: f32,
    /// Roughness along the y tangent.
    pub alpha_v: f32,
    /// Whether [`Microfacet::sample`] draws visible normals.
    pub sample_visible: bool,
}

impl Microfacet {
    /// An isotropic distribution.
    pub fn isotropic(kind: MicrofacetType, alpha: f32, sample_visible: bool) -> Self {
        Self {
            kind,
            alpha_u: alpha,
            alpha_v: alpha,
            sample_visible,
        }
    }

    /// Whether [`Microfacet::sample`] draws visible normals: when asked
    /// to, except for Phong, which has no closed-form visible-normal
    /// sampler and draws D(m) cos θm, as in Mitsuba 0.6.
    #[inline]
    pub fn samples_visible(&self) -> bool {
        self.sample_visible && self.kind != MicrofacetType::Phong
    }

    /// The Phong exponent αp = 2/α² − 2 of the Beckmann-equivalent
    /// roughness α = `alpha_u` (Walter et al. 2007, §5.2), clamped at 0
    /// (α > 1 gives the uniform D = 1/π).
    #[inline]
    pub fn phong_exponent(&self) -> f32 {
        (2.0 / (self.alpha_u * self.alpha_u) - 2.0).max(0.0)
    }

    /// The normal distribution D(m), normalized so that
    /// ∫ D(m) cos θm dωm = 1 (Walter et al. 2007: eqs. 25 and 33 for
    /// Beckmann and GGX, with the slopes stretched by (αu, αv); §5.2 for
    /// Phong). Zero below the surface.
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        if self.kind == MicrofacetType::Phong {
            // (αp + 2)/(2π) cos^αp θm (Walter et al. 2007, §5.2).
            let e = self.phong_exponent();
            let d = (e + 2.0) * (0.5 / PI) * m.z.powf(e);
            return if d.is_finite() { d } else { 0.0 };
        }
        let cos2 = m.z * m.z;
        // tan²θm (cos²φ/αu² + sin²φ/αv²): the squared slope of the
        // facet in the distribution's unit-roughness space.
        let e = (sq(m.x / self.alpha_u) + sq(m.y / self.alpha_v)) / cos2;
        let norm = PI * self.alpha_u * self.alpha_v * cos2 * cos2;
        let d = match self.kind {
            MicrofacetType::Beckmann => crate::math::exp_or_zero(-e) / norm,
            MicrofacetType::Ggx => 1.0 / (norm * sq(1.0 + e)),
            MicrofacetType::Phong => unreachable!("handled above"),
        };
        if d.is_finite() {
            d
        } else {
            0.0
        }
    }

    /// Smith's Λ(v) (Heitz 2014, §5): the masking of the facets seen from
    /// `v`, G1 = 1 / (1 + Λ). Depends on v only through
    /// a = 1 / (α(φ) tan θ), α(φ) the roughness in v's azimuth.
    #[inline]
    pub fn lambda(&self, v: Vec3) -> f32 {
        let xy = sq(self.alpha_u * v.x) + sq(self.alpha_v * v.y);
        if xy == 0.0 {
            return 0.0;
        }
        match self.kind {
            MicrofacetType::Beckmann => {
                let a = v.z.abs() / xy.sqrt();
                // Λ = (e^{-a²} / (a√π) − erfc(a)) / 2 (Walter et al. 2007,
                // eq. 27), with the one exponential both terms share; past
                // a ≈ 9 it underflows and Λ = 0.
                let l = 0.5 * crate::math::exp_or_zero(-a * a) * (1.0 / (a * PI.sqrt()) - erfcx(a));
                l.max(0.0)
            }
            MicrofacetType::Ggx => {
                // Λ = (√(1 + α² tan²θ) − 1) / 2, written without the
                // cancellation near normal incidence.
                let t2 = xy / (v.z * v.z);
                0.5 * t2 / (1.0 + (1.0 + t2).sqrt())
            }
            MicrofacetType::Phong => {
                // The exact Smith Λ of the Phong distribution itself (see
                // `phong_lambda`), not Walter's Beckmann fit.
                let cot = f64::from(v.z.abs()) / f64::from(xy).sqrt() * f64::from(self.alpha_u);
                phong_lambda(f64::from(self.phong_exponent()), cot) as f32
            }
        }
    }

    /// Smith's masking function G1(v, m) = χ⁺(v·m / v·n) / (1 + Λ(v)).
    #[inline]
    pub fn g1(&self, v: Vec3, m: Vec3) -> f32 {
        if v.dot(m) * v.z <= 0.0 {
            return 0.0;
        }
        1.0 / (1.0 + self.lambda(v))
    }

    /// Masking-shadowing G(wi, wo, m) = G1(wi, m) G1(wo, m), the separable
    /// form Mitsuba 3 uses.
    #[inline]
    pub fn g(&self, wi: Vec3, wo: Vec3, m: Vec3) -> f32 {
        self.g1(wi, m) * self.g1(wo, m)
    }

    /// Samples a microfacet normal `m` for `wo` (which must be above the
    /// surface; callers flip it otherwise) and returns it with its density
    /// [`Microfacet::pdf`]: the visible normals
    /// D_wo(m) = G1(wo, m) max(0, wo·m) D(m) / cos θo when
    /// [`Microfacet::samples_visible`], otherwise D(m) cos θm. A density
    /// of 0 means no usable sample.
    #[inline]
    pub fn sample(&self, wo: Vec3, u: Vec2) -> (Vec3, f32) {
        match self.sample_normal(wo, u) {
            Some(m) => (m, self.pdf(wo, m)),
            None => (Vec3::Z, 0.0),
        }
    }

    /// [`Microfacet::sample`]'s normal without its density; `None` for no
    /// usable sample.
    #[inline]
    pub(crate) fn sample_normal(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        let m = if self.samples_visible() {
            match self.kind {
                MicrofacetType::Ggx => self.sample_visible_ggx(wo, u),
                MicrofacetType::Beckmann => self.sample_visible_beckmann(wo, u),
                MicrofacetType::Phong => unreachable!("never samples visible normals"),
            }
        } else {
            self.sample_all(u)
        };
        m.is_finite().then_some(m)
    }

    /// Density of [`Microfacet::sample`] per solid angle of `m`.
    #[inline]
    pub fn pdf(&self, wo: Vec3, m: Vec3) -> f32 {
        if self.samples_visible() {
            self.visible_pdf(wo, m)
        } else {
            self.d(m) * m.z
        }
    }

    /// The density of the normals visible from `wo`,
    /// D_wo(m) = G1(wo, m) |wo·m| D(m) / |cos θo| (Heitz 2014, eq. 38),
    /// whichever way [`Microfacet::sample`] draws them.
    #[inline]
    pub fn visible_pdf(&self, wo: Vec3, m: Vec3) -> f32 {
        if wo.z == 0.0 {
            return 0.0;
        }
        self.d(m) * self.g1(wo, m) * wo.dot(m).abs() / wo.z.abs()
    }

    /// D(m) G(wi, wo, m) and the density [`Microfacet::pdf`]`(wo, m)`,
    /// sharing D(m) and G1(wo, m): the same values as computed apart.
    #[inline]
    pub fn dg_and_pdf(&self, wo: Vec3, wi: Vec3, m: Vec3) -> (f32, f32) {
        let dm = self.d(m);
        let g1_wo = self.g1(wo, m);
        let dg = dm * (self.g1(wi, m) * g1_wo);
        let pdf = if !self.samples_visible() {
            dm * m.z
        } else if wo.z == 0.0 {
            0.0
        } else {
            dm * g1_wo * wo.dot(m).abs() / wo.z.abs()
        };
        (dg, pdf)
    }

    /// D(m) cos θm: the slope distribution at unit roughness, whose radial
    /// CDF inverts in closed form, stretched by (αu, αv).
    fn sample_all(&self, u: Vec2) -> Vec3 {
        // Below 1 so that the slope stays finite.
        let u0 = u.x.min(1.0 - f32::EPSILON);
        let r2 = match self.kind {
            // P(r < R) = 1 − e^{−R²}.
            MicrofacetType::Beckmann => -(1.0 - u0).ln(),
            // P(r < R) = R² / (1 + R²).
            MicrofacetType::Ggx => u0 / (1.0 - u0),
            MicrofacetType::Phong => return self.sample_phong(u),
        };
        let (sin_phi, cos_phi) = (2.0 * PI * u.y).sin_cos();
        let r = r2.sqrt();
        Vec3::new(
            -r * cos_phi * self.alpha_u,
            -r * sin_phi * self.alpha_v,
            1.0,
        )
        .normalize()
    }

    /// D(m) cos θm for Phong: cos θm = u^{1/(αp + 2)} inverts the CDF of
    /// (αp + 2) cos^{αp+1} θ sin θ (Walter et al. 2007, §5.2), φ uniform;
    /// sin² θm = −expm1(2 ln u / (αp + 2)) stays accurate for large αp.
    /// A normal within 10⁻⁶ of the horizon (probability at most 10⁻¹²)
    /// is no sample: its density rounds to 0 there.
    fn sample_phong(&self, u: Vec2) -> Vec3 {
        let l = u.x.max(f32::MIN_POSITIVE).ln() / (self.phong_exponent() + 2.0);
        let cos_theta = l.exp();
        if cos_theta < 1e-6 {
            return Vec3::NAN;
        }
        let sin_theta = (-(2.0 * l).exp_m1()).max(0.0).sqrt();
        let (sin_phi, cos_phi) = (2.0 * PI * u.y).sin_cos();
        Vec3::new(sin_theta * cos_phi, sin_theta * sin_phi, cos_theta)
    }

    /// Heitz 2018: in the configuration stretched to unit roughness, the
    /// visible normals of a GGX surface are the normals of a hemisphere
    /// seen from `wo`, i.e. uniform points on the projected disk (a half
    /// disk and a half ellipse), lifted back onto the hemisphere.
    fn sample_visible_ggx(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let vh = Vec3::new(self.alpha_u * wo.x, self.alpha_v * wo.y, wo.z).normalize();
        let len2 = vh.x * vh.x + vh.y * vh.y;
        let t1 = if len2 > 0.0 {
            Vec3::new(-vh.y, vh.x, 0.0) / len2.sqrt()
        } else {
            Vec3::X
        };
        let t2 = vh.cross(t1);
        let r = u.x.sqrt();
        let (sin_phi, cos_phi) = (2.0 * PI * u.y).sin_cos();
        let p1 = r * cos_phi;
        // The half of the disk behind the hemisphere's silhouette shrinks
        // to a half ellipse of height cos θ: blend towards it.
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * sin_phi;
        let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
        Vec3::new(self.alpha_u * nh.x, self.alpha_v * nh.y, nh.z.max(0.0)).normalize()
    }

    /// Heitz & d'Eon 2014: stretch `wo` to unit roughness, sample the
    /// visible slopes for incidence in the x-z plane, rotate them to `wo`'s
    /// azimuth and unstretch.
    fn sample_visible_beckmann(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let frame = BeckmannVisibleFrame::new(self, wo);
        let x = beckmann_visible_slope_x(frame.cos_theta, frame.sin_theta, u.x);
        frame.normal(self, Vec2::new(x, erfinv(2.0 * u.y - 1.0)))
    }

    /// [`Microfacet::sample`] at every node of the tensor grid
    /// `ux` × `uy` (`ux` outer), the same values as node by node.
    pub fn sample_grid(&self, wo: Vec3, ux: &[f32], uy: &[f32]) -> Vec<(Vec3, f32)> {
        (self.sample_grid_normals(wo, ux, uy).into_iter())
            .map(|m| match m {
                Some(m) => (m, self.pdf(wo, m)),
                None => (Vec3::Z, 0.0),
            })
            .collect()
    }

    /// The normals of [`Microfacet::sample_grid`] without their densities
    /// (`None`: no usable sample); for visible Beckmann normals the slope
    /// solve of each `ux` is shared by its whole row (quadratures over the
    /// sampler's square, such as `roughplastic`'s tables, call this).
    pub fn sample_grid_normals(&self, wo: Vec3, ux: &[f32], uy: &[f32]) -> Vec<Option<Vec3>> {
        if !(self.samples_visible() && self.kind == MicrofacetType::Beckmann) {
            return ux
                .iter()
                .flat_map(|&x| {
                    uy.iter()
                        .map(move |&y| self.sample_normal(wo, Vec2::new(x, y)))
                })
                .collect();
        }
        let frame = BeckmannVisibleFrame::new(self, wo);
        let ys: Vec<f32> = uy.iter().map(|&y| erfinv(2.0 * y - 1.0)).collect();
        let mut out = Vec::with_capacity(ux.len() * uy.len());
        for &x in ux {
            let sx = beckmann_visible_slope_x(frame.cos_theta, frame.sin_theta, x);
            for &sy in &ys {
                let m = frame.normal(self, Vec2::new(sx, sy));
                out.push(m.is_finite().then_some(m));
            }
        }
        out
    }
}

/// The direction a visible Beckmann normal is sampled for, stretched to
/// unit roughness: its polar angle and azimuth.
struct BeckmannVisibleFrame {
    cos_theta: f32,
    sin_theta: f32,
    cos_phi: f32,
    sin_phi: f32,
}

impl BeckmannVisibleFrame {
    fn new(distr: &Microfacet, wo: Vec3) -> Self {
        let w = Vec3::new(distr.alpha_u * wo.x, distr.alpha_v * wo.y, wo.z).normalize();
        let sin_theta = (w.x * w.x + w.y * w.y).sqrt();
        let (cos_phi, sin_phi) = if sin_theta > 0.0 {
            (w.x / sin_theta, w.y / sin_theta)
        } else {
            (1.0, 0.0)
        };
        Self {
            cos_theta: w.z,
            sin_theta,
            cos_phi,
            sin_phi,
        }
    }

    /// The normal of unit-roughness slope `s` (in the frame of θ = 0 azimuth),
    /// rotated to the direction's azimuth and stretched back.
    fn normal(&self, distr: &Microfacet, s: Vec2) -> Vec3 {
        let sx = (self.cos_phi * s.x - self.sin_phi * s.y) * distr.alpha_u;
        let sy = (self.sin_phi * s.x + self.cos_phi * s.y) * distr.alpha_v;
        Vec3::new(-sx, -sy, 1.0).normalize()
    }
}

/// The slope x̃ of a slope (x̃, ỹ) of the unit-roughness Beckmann surface,
/// visible from a direction at polar angle θ in the x-z plane, with facet
/// normal (−x̃, −ỹ, 1). Its density is ∝ max(0, 1 − x̃ tan θ) e^{−x̃² − ỹ²}:
/// ỹ is Gaussian (variance ½, drawn as erfinv(2u − 1)) and x̃ has density ∝ (cot θ − x̃) e^{−x̃²} on
/// x̃ < cot θ, whose CDF ∝ (√π/2) erfc(−x̃) + (tan θ / 2) e^{−x̃²} is
/// inverted by safeguarded Halley iteration (Heitz & d'Eon 2014, §4, who
/// take Newton steps).
fn beckmann_visible_slope_x(cos_theta: f32, sin_theta: f32, ux: f32) -> f32 {
    let sqrt_pi = PI.sqrt();
    // Both terms of the CDF are positive (no cancellation at any angle);
    // at normal incidence the second vanishes and x̃ is Gaussian too.
    let half_tan = 0.5 * sin_theta / cos_theta.max(1e-12);
    // The CDF and e^{−x̃²}, which its derivative needs too: one
    // exponential per Newton step (erfc(z) = e^{−z²} erfcx(z)).
    let cdf_and_gauss = |x: f32| {
        let gauss = (-x * x).exp();
        let cdf = if x <= 0.0 {
            gauss * (0.5 * sqrt_pi * erfcx(-x) + half_tan)
        } else {
            sqrt_pi - gauss * (0.5 * sqrt_pi * erfcx(x) - half_tan)
        };
        (cdf, gauss)
    };
    let cot = if sin_theta > 0.0 {
        cos_theta / sin_theta
    } else {
        f32::INFINITY
    };
    // Past |x̃| = 6 the remaining mass (< e^{-36}) is below what a 32-bit
    // uniform resolves; cot θ ≥ 0 above the surface.
    let (mut lo, mut hi) = (-6.0f32, cot.min(6.0));
    let total = cdf_and_gauss(hi).0;
    let target = ux * total;
    // Done once the CDF is within a few of its f32 roundings (2⁻²⁴ of the
    // total) of the target: in the tails, where the density is small,
    // rounding noise in the CDF would keep the steps from ever getting
    // below a fixed tolerance on x.
    let resolution = 2.0 * f32::EPSILON * total;
    let mut x = erfinv(2.0 * ux - 1.0).clamp(lo, hi);
    for _ in 0..40 {
        let (cdf, gauss) = cdf_and_gauss(x);
        let fx = cdf - target;
        if fx.abs() <= resolution {
            break;
        }
        if fx > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        // CDF'(x̃) = (1 − x̃ tan θ) e^{−x̃²} and
        // CDF''(x̃) = −(tan θ + 2x̃ (1 − x̃ tan θ)) e^{−x̃²}. Newton's step,
        // shortened or lengthened by Halley's correction 1 − f f'' / (2 f'²)
        // where that is moderate (near the root; it converges in fewer
        // steps), bare where it is not (far away, in the tails).
        let slope = 1.0 - 2.0 * half_tan * x;
        let newton = fx / (slope * gauss);
        let halley = 1.0 + newton * (half_tan + x * slope) / slope;
        let step = if (0.5..2.0).contains(&halley) {
            newton / halley
        } else {
            newton
        };
        let mut next = x - step;
        if !(next > lo && next < hi) {
            next = 0.5 * (lo + hi);
        }
        if (next - x).abs() <= 1e-6 * x.abs().max(1.0) {
            x = next;
            break;
        }
        x = next;
    }
    x
}

/// Smith's Λ for the Phong distribution D(m) = (n + 2)/(2π) cos^n θm,
/// exact, at a direction with cot θ = `mu` (Heitz 2014, eq. 72:
/// Λ(μ) = (1/μ) ∫_μ^∞ (x − μ) P2(x) dx over the marginal slope density
/// P2). Phong's slopes have P22(x, y) = (n + 2)/(2π) (1 + x² + y²)^{−(n+4)/2},
/// a bivariate Student t, whose marginal is
/// P2(x) = c (1 + x²)^{−(n+3)/2} with c = (n + 2)/(2√π) Γ((n+3)/2)/Γ((n+4)/2).
/// Then ∫_μ^∞ x P2 = c (1 + μ²)^{−(n+1)/2}/(n + 1), and
/// ∫_μ^∞ P2 = (c/2) B(1/(1 + μ²); (n+2)/2, ½) with B the incomplete beta
/// function (x = tan φ turns it into ∫ cos^{n+1} φ dφ). Computed in f64:
/// the two terms cancel to about 1/(n + 2) of their size.
fn phong_lambda(n: f64, mu: f64) -> f64 {
    if mu.is_nan() || mu <= 0.0 {
        return if mu == 0.0 { f64::INFINITY } else { 0.0 };
    }
    if mu.is_infinite() {
        return 0.0;
    }
    let ln_c = (n + 2.0).ln() - (2.0 * std::f64::consts::PI.sqrt()).ln()
        + ln_gamma(0.5 * (n + 3.0))
        - ln_gamma(0.5 * (n + 4.0));
    let q = 1.0 + mu * mu;
    let first = (ln_c - 0.5 * (n + 1.0) * q.ln()).exp() / (n + 1.0);
    let (a, b) = (0.5 * (n + 2.0), 0.5);
    let tail = 0.5 * (ln_c + ln_beta(a, b)).exp() * regularized_beta(1.0 / q, a, b);
    ((first - mu * tail) / mu).max(0.0)
}

/// ln Γ(x) for x > 0: shifted to x ≥ 10 by Γ(x + 1) = x Γ(x), then
/// Stirling's series to the x⁻⁷ term (error below 10⁻¹⁵ there).
fn ln_gamma(mut x: f64) -> f64 {
    let mut shift = 0.0;
    while x < 10.0 {
        shift -= x.ln();
        x += 1.0;
    }
    let r = 1.0 / (x * x);
    let series = (1.0 / 12.0 - r * (1.0 / 360.0 - r * (1.0 / 1260.0 - r / 1680.0))) / x;
    shift + (x - 0.5) * x.ln() - x + 0.5 * (2.0 * std::f64::consts::PI).ln() + series
}

/// ln B(a, b) = ln Γ(a) + ln Γ(b) − ln Γ(a + b).
fn ln_beta(a: f64, b: f64) -> f64 {
    ln_gamma(a) + ln_gamma(b) - ln_gamma(a + b)
}

/// The regularized incomplete beta function I_x(a, b), by its continued
/// fraction (evaluated with Lentz's method) on the side where it converges
/// quickly, x < (a + 1)/(a + b + 2), and I_x(a, b) = 1 − I_{1−x}(b, a)
/// otherwise (Abramowitz & Stegun 26.5.8).
fn regularized_beta(x: f64, a: f64, b: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let front = |x: f64, a: f64, b: f64| (a * x.ln() + b * (1.0 - x).ln() - ln_beta(a, b)).exp();
    if x < (a + 1.0) / (a + b + 2.0) {
        front(x, a, b) * beta_fraction(x, a, b) / a
    } else {
        1.0 - front(1.0 - x, b, a) * beta_fraction(1.0 - x, b, a) / b
    }
}

/// The continued fraction 1/(1 + d₁/(1 + d₂/(1 + ...))) of the incomplete
/// beta function, d₂ₘ₊₁ = −(a + m)(a + b + m) x / ((a + 2m)(a + 2m + 1)),
/// d₂ₘ = m (b − m) x / ((a + 2m − 1)(a + 2m)) (A&S 26.5.8), by the
/// modified Lentz algorithm.
fn beta_fraction(x: f64, a: f64, b: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let guard = |v: f64| if v.abs() < TINY { TINY } else { v };
    let mut c = 1.0;
    let mut d = 1.0 / guard(1.0 - (a + b) * x / (a + 1.0));
    let mut f = d;
    for m in 1..300 {
        let m = f64::from(m);
        let even = m * (b - m) * x / ((a + 2.0 * m - 1.0) * (a + 2.0 * m));
        d = 1.0 / guard(1.0 + even * d);
        c = guard(1.0 + even / c);
        f *= c * d;
        let odd = -(a + m) * (a + b + m) * x / ((a + 2.0 * m) * (a + 2.0 * m + 1.0));
        d = 1.0 / guard(1.0 + odd * d);
        c = guard(1.0 + odd / c);
        let step = c * d;
        f *= step;
        if (step - 1.0).abs() < 1e-15 {
            break;
        }
    }
    f
}

#[inline]
fn sq(x: f32) -> f32 {
    x * x
}

/// Complementary error function by the Chebyshev fit of Press et al.,
/// *Numerical Recipes*, 2nd ed., §6.2, whose relative error is below
/// 1.2·10⁻⁷ for every argument: tails keep their relative precision (in
/// f32, about 10⁻⁶ at erfc(5) ≈ 1.5·10⁻¹²); the tests' reference for
/// [`erfcx`] and [`erfinv`].
#[cfg(test)]
pub(crate) fn erfc(x: f32) -> f32 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -1.265_512_2
        + t * (1.000_023_7
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_204
                                + t * (1.488_515_9 + t * (-0.822_152_2 + t * 0.170_872_77))))))));
    let r = t * (-z * z + poly).exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

/// The scaled complementary error function e^{z²} erfc(z) for z ≥ 0, by
/// Abramowitz & Stegun 7.1.26 (erfc = this × e^{−z²} to 1.5·10⁻⁷
/// absolute): a rational function of t = 1/(1 + pz), no exponential, for
/// callers that have e^{−z²} at hand.
#[inline]
pub(crate) fn erfcx(z: f32) -> f32 {
    let t = 1.0 / (1.0 + 0.327_591_1 * z);
    t * (0.254_829_6
        + t * (-0.284_496_72 + t * (1.421_413_8 + t * (-1.453_152_1 + t * 1.061_405_4))))
}

/// Inverse error function on (−1, 1): Giles 2010, "Approximating the
/// erfinv function" (GPU Computing Gems Jade, ch. 10), single-precision
/// version, whose relative error is below 3·10⁻⁷ (Dr.Jit's `erfinv` is the
/// same approximation). Sampling a Gaussian through it deforms the
/// distribution by less than f32 rounding of its density does.
pub(crate) fn erfinv(x: f32) -> f32 {
    let x = x.clamp(-1.0 + f32::EPSILON, 1.0 - f32::EPSILON);
    let mut w = -((1.0 - x) * (1.0 + x)).ln();
    let p = if w < 5.0 {
        w -= 2.5;
        let mut p = 2.810_226_4e-8;
        p = 3.432_739_4e-7 + p * w;
        p = -3.523_387_7e-6 + p * w;
        p = -4.391_506_5e-6 + p * w;
        p = 0.000_218_580_87 + p * w;
        p = -0.001_253_725 + p * w;
        p = -0.004_177_682 + p * w;
        p = 0.246_640_73 + p * w;
        1.501_409_4 + p * w
    } else {
        w = w.sqrt() - 3.0;
        let mut p = -0.000_200_214_26;
        p = 0.000_100_950_56 + p * w;
        p = 0.001_349_343_2 + p * w;
        p = -0.003_673_428_4 + p * w;
        p = 0.005_739_507_7 + p * w;
        p = -0.007_622_461 + p * w;
        p = 0.009_438_870_5 + p * w;
        p = 1.001_674 + p * w;
        2.832_976_8 + p * w
    };
    p * x
}

/// The roughness parameters of a rough BSDF, as read from the scene;
/// [`Roughness::at`] gives the distribution at a surface point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Roughness {
    /// Shape of the distribution.
    pub kind: MicrofacetType,
    /// Roughness along the x tangent.
    pub alpha_u: Tex,
    /// Roughness along the y tangent.
    pub alpha_v: Tex,
    /// Sample visible normals.
    pub sample_visible: bool,
}

/// Smallest roughness a texture can produce: keeps D finite where a texel
/// is black.
const MIN_TEXTURED_ALPHA: f32 = 1e-4;

impl Roughness {
    /// A constant isotropic roughness.
    pub fn isotropic(kind: MicrofacetType, alpha: f32, sample_visible: bool) -> Self {
        Self {
            kind,
            alpha_u: Tex::value(alpha),
            alpha_v: Tex::value(alpha),
            sample_visible,
        }
    }

    /// Reads `distribution`, `alpha` or `alpha_u`/`alpha_v`, and
    /// `sample_visible` (see the module docs). A `phong` distribution
    /// must be isotropic.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let kind = match p.choice("distribution", &["beckmann", "ggx", "phong"])? {
            0 => MicrofacetType::Beckmann,
            1 => MicrofacetType::Ggx,
            _ => MicrofacetType::Phong,
        };
        let (alpha_u, alpha_v) = if p.has("alpha_u") || p.has("alpha_v") {
            if p.has("alpha") {
                return Err(p.param_error(
                    "alpha",
                    "give either \"alpha\" or \"alpha_u\" and \"alpha_v\", not both",
                ));
            }
            let u = alpha_param(p, "alpha_u", "alpha_v")?;
            let v = alpha_param(p, "alpha_v", "alpha_u")?;
            if kind == MicrofacetType::Phong && u != v {
                return Err(p.param_error(
                    "alpha_u",
                    "the \"phong\" distribution is isotropic here (no Ashikhmin–Shirley \
                     extension): give \"alpha\", or equal \"alpha_u\" and \"alpha_v\"",
                ));
            }
            (u, v)
        } else {
            let a = p.texture_or("alpha", ColorKind::Reflectance, Rgb::splat(0.1))?;
            check_alpha(p, "alpha", &a)?;
            (a, a)
        };
        Ok(Self {
            kind,
            alpha_u,
            alpha_v,
            sample_visible: p.boolean_or("sample_visible", true)?,
        })
    }

    /// The distribution at `si`.
    #[inline]
    pub fn at(&self, m: &Materials, si: &SurfaceInteraction) -> Microfacet {
        let alpha_u = self.alpha_u.eval_1(m, si).max(MIN_TEXTURED_ALPHA);
        let alpha_v = if self.alpha_v == self.alpha_u {
            alpha_u
        } else {
            self.alpha_v.eval_1(m, si).max(MIN_TEXTURED_ALPHA)
        };
        Microfacet {
            kind: self.kind,
            alpha_u,
            alpha_v,
            sample_visible: self.sample_visible,
        }
    }
}

/// One of `alpha_u`/`alpha_v`, which requires the `other`.
fn alpha_param(p: &mut dyn Params, name: &str, other: &str) -> Result<Tex, ParamError> {
    let Some(a) = p.texture(name, ColorKind::Reflectance)? else {
        return Err(p.param_error(
            other,
            &format!("\"{other}\" needs \"{name}\" too (or give \"alpha\" alone)"),
        ));
    };
    check_alpha(p, name, &a)?;
    Ok(a)
}

/// A constant roughness must be positive (textures are clamped when
/// evaluated instead).
fn check_alpha(p: &dyn Params, name: &str, a: &Tex) -> Result<(), ParamError> {
    match a.as_const().map(luminance) {
        Some(v) if !(v > 0.0 && v.is_finite()) => {
            Err(p.param_error(name, &format!("roughness must be positive, not {v}")))
        }
        _ => Ok(()),
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::sampler::Pcg32;
    use crate::testing::chi2::{chi2_directions, Chi2Config};

    pub(crate) use crate::testing::params::MapParams;

    const KINDS: [MicrofacetType; 2] = [MicrofacetType::Beckmann, MicrofacetType::Ggx];

    fn aniso(kind: MicrofacetType, au: f32, av: f32, visible: bool) -> Microfacet {
        Microfacet {
            kind,
            alpha_u: au,
            alpha_v: av,
            sample_visible: visible,
        }
    }

    /// ∫ f(m) dωm over the upper hemisphere, in f64, on a grid that
    /// follows the distribution's width: the azimuth is φ = atan2(αv sin ψ,
    /// αu cos ψ) with ψ on a midpoint grid (dφ/dψ = αu αv / (αu² cos²ψ +
    /// αv² sin²ψ)), and m's slope is s = α(φ) ξ/(1 − ξ) with ξ on a
    /// midpoint grid, so lobes from α = 0.01 to 1 and anisotropy ratios of
    /// 50 get the same resolution. dω = s ds dφ / (1 + s²)^{3/2}.
    fn integrate_hemisphere(d: &Microfacet, f: impl Fn(Vec3) -> f64) -> f64 {
        let (n_xi, n_psi) = (3000, 256);
        let (au, av) = (d.alpha_u as f64, d.alpha_v as f64);
        let mut sum = 0.0;
        for j in 0..n_psi {
            let psi = (j as f64 + 0.5) / n_psi as f64 * std::f64::consts::TAU;
            let (spsi, cpsi) = psi.sin_cos();
            let dphi = au * av / (sq64(au * cpsi) + sq64(av * spsi));
            let phi = (av * spsi).atan2(au * cpsi);
            let (sp, cp) = phi.sin_cos();
            let a = 1.0 / (sq64(cp / au) + sq64(sp / av)).sqrt();
            for i in 0..n_xi {
                let xi = (i as f64 + 0.5) / n_xi as f64;
                let s = a * xi / (1.0 - xi);
                let ds = a / sq64(1.0 - xi);
                let c = 1.0 / (1.0 + s * s).sqrt();
                let m = Vec3::new((s * c * cp) as f32, (s * c * sp) as f32, c as f32);
                sum += f(m) * s * c * c * c * ds * dphi;
            }
        }
        sum * std::f64::consts::TAU / (n_psi * n_xi) as f64
    }

    fn sq64(x: f64) -> f64 {
        x * x
    }

    fn alphas() -> Vec<(f32, f32)> {
        vec![
            (0.01, 0.01),
            (0.1, 0.1),
            (0.5, 0.5),
            (1.0, 1.0),
            (0.05, 0.4),
            (1.0, 0.02),
        ]
    }

    /// e^{−z²} erfcx(z) is erfc(z) to A&S's 1.5·10⁻⁷ plus f32 rounding
    /// (a few ulps of 1, 6·10⁻⁸ each) over the range the Beckmann slopes
    /// and Λ use.
    #[test]
    fn erfcx_times_gaussian_is_erfc() {
        for k in 0..=900 {
            let z = k as f32 / 100.0;
            let got = (-z * z).exp() * erfcx(z);
            assert!(
                (got - erfc(z)).abs() < 3e-7,
                "z = {z}: {got} vs {}",
                erfc(z)
            );
        }
    }

    #[test]
    fn erf_known_values() {
        let cases = [
            (0.0f32, 1.0f32),
            (0.5, 1.0 - 0.520_499_9),
            (1.0, 1.0 - 0.842_700_8),
            (-1.0, 1.842_700_8),
            (3.0, 2.209_049_7e-5),
            (5.0, 1.537_459_8e-12),
        ];
        for (x, expected) in cases {
            let got = erfc(x);
            assert!(
                (got - expected).abs() <= 2e-6 * expected,
                "erfc({x}) = {got}, expected {expected}"
            );
        }
        for x in [-0.999f32, -0.9, -0.3, 0.0, 0.1, 0.5, 0.95, 0.999_99] {
            let y = erfinv(x);
            assert!(
                ((1.0 - erfc(y)) - x).abs() < 3e-7,
                "erf(erfinv({x})) = {}",
                1.0 - erfc(y)
            );
        }
    }

    #[test]
    fn distributions_are_normalized() {
        for kind in KINDS {
            for (au, av) in alphas() {
                let d = aniso(kind, au, av, false);
                let total = integrate_hemisphere(&d, |m| (d.d(m) * m.z) as f64);
                assert!(
                    (total - 1.0).abs() < 2e-3,
                    "{kind:?} α=({au}, {av}): ∫ D cos θ = {total}"
                );
            }
        }
    }

    /// ∫ D cos θm dω = 1 for Phong, from sharp (α = 0.01, exponent
    /// ≈ 20 000) to the clamped uniform D at α > 1; and αp = 2/α² − 2.
    #[test]
    fn phong_is_normalized() {
        for alpha in [0.01f32, 0.05, 0.1, 0.3, 0.7, 1.0, 1.5] {
            let d = Microfacet::isotropic(MicrofacetType::Phong, alpha, true);
            let total = integrate_hemisphere(&d, |m| (d.d(m) * m.z) as f64);
            assert!(
                (total - 1.0).abs() < 2e-3,
                "Phong α={alpha}: ∫ D cos θ = {total}"
            );
            let e = (2.0 / (alpha * alpha) - 2.0).max(0.0);
            assert!((d.phong_exponent() - e).abs() <= 1e-6 * e.max(1.0));
            // Visible-normal sampling is never used for Phong.
            assert!(!d.samples_visible());
            let m = Vec3::new(0.1, 0.2, 0.9).normalize();
            assert_eq!(d.pdf(Vec3::new(0.5, 0.0, 0.8).normalize(), m), d.d(m) * m.z);
        }
        // αp = 0: the uniform distribution of cosines, D = 1/π.
        let d = Microfacet::isotropic(MicrofacetType::Phong, 1.0, false);
        assert!((d.d(Vec3::new(0.6, 0.0, 0.8)) - 1.0 / PI).abs() < 1e-7);
    }

    /// Phong's Λ is the exact Smith masking of its own slopes: it matches
    /// a direct quadrature of Λ(μ) = (1/μ) ∫_μ^∞ (x − μ) P2(x) dx (with
    /// x = tan φ, P2 ∝ cos^{n+3} φ), the visible normals integrate to one
    /// from every direction, and a rough Phong mirror reflects at most what
    /// it receives, however rough (Walter's Beckmann fit, which Mitsuba 0.6
    /// uses, gains 5 % at α 0.6 near grazing).
    #[test]
    fn phong_masking_is_exact() {
        let simpson = |f: &dyn Fn(f64) -> f64, a: f64, b: f64| {
            let n = 20_000;
            let h = (b - a) / n as f64;
            (0..=n)
                .map(|i| {
                    let w = if i == 0 || i == n {
                        1.0
                    } else if i % 2 == 1 {
                        4.0
                    } else {
                        2.0
                    };
                    w * f(a + i as f64 * h)
                })
                .sum::<f64>()
                * h
                / 3.0
        };
        let half_pi = std::f64::consts::FRAC_PI_2;
        for n in [0.0f64, 1.0, 3.5, 10.0, 48.0, 1000.0] {
            let norm = simpson(&|p: f64| p.cos().powf(n + 1.0), -half_pi, half_pi);
            for mu in [0.05f64, 0.3, 1.0, 3.0] {
                let tail = simpson(
                    &|p: f64| (p.tan() - mu) * p.cos().powf(n + 1.0),
                    mu.atan(),
                    half_pi,
                ) / norm
                    / mu;
                let got = phong_lambda(n, mu);
                assert!(
                    (got - tail).abs() <= 1e-6 * tail.max(1e-6),
                    "n {n} μ {mu}: Λ {got}, quadrature {tail}"
                );
            }
        }
        let mirror = |alpha: f32| {
            Materials::with_bsdfs(vec![crate::bsdf::Material::RoughConductor(
                crate::bsdf::RoughConductor {
                    roughness: Roughness::isotropic(MicrofacetType::Phong, alpha, false),
                    ior: crate::bsdf::ConductorIor {
                        eta: Tex::value(0.0),
                        k: Tex::value(1.0),
                    },
                    specular_reflectance: Tex::value(1.0),
                },
            )])
        };
        let dirs = [
            Vec3::new(0.3, 0.2, 0.9).normalize(),
            Vec3::new(-0.7, 0.3, 0.4).normalize(),
            Vec3::new(0.9, 0.0, 0.1).normalize(),
            Vec3::new(0.995, 0.0, 0.0999).normalize(),
        ];
        for alpha in [0.05f32, 0.2, 0.4, 0.6, 1.0, 1.5] {
            let p = Microfacet::isotropic(MicrofacetType::Phong, alpha, false);
            for v in dirs {
                let vis = integrate_hemisphere(&p, |m| p.visible_pdf(v, m) as f64);
                assert!((vis - 1.0).abs() < 2e-3, "α {alpha} v {v}: {vis}");
                let a = crate::bsdf::tests::albedo(&mirror(alpha), 0, v).x;
                assert!(a < 1.0 + 5e-3, "α {alpha} v {v}: mirror albedo {a}");
            }
        }
    }

    #[test]
    fn projected_area_identity() {
        // ∫ G1(v, m) max(0, v·m) D(m) dωm = cos θv (Heitz 2014, eq. 7):
        // the visible facets project onto the macro-surface's area.
        for kind in KINDS {
            for (au, av) in alphas() {
                let d = aniso(kind, au, av, true);
                for v in [
                    Vec3::Z,
                    Vec3::new(0.3, 0.2, 0.9),
                    Vec3::new(-0.7, 0.3, 0.4),
                    Vec3::new(0.2, -0.9, 0.1),
                    Vec3::new(0.99, 0.0, 0.05),
                ] {
                    let v = v.normalize();
                    let total = integrate_hemisphere(&d, |m| {
                        (d.g1(v, m) * v.dot(m).max(0.0) * d.d(m)) as f64
                    });
                    assert!(
                        (total - v.z as f64).abs() < 2e-3 * v.z as f64,
                        "{kind:?} α=({au}, {av}) v={v}: {total} vs {}",
                        v.z
                    );
                    // The visible-normal density integrates to one.
                    let vis = integrate_hemisphere(&d, |m| d.pdf(v, m) as f64);
                    assert!((vis - 1.0).abs() < 2e-3, "{kind:?} v={v}: {vis}");
                }
            }
        }
    }

    #[test]
    fn lambda_limits() {
        for kind in KINDS {
            let d = Microfacet::isotropic(kind, 0.5, true);
            assert_eq!(d.lambda(Vec3::Z), 0.0);
            assert!(d.lambda(Vec3::new(1.0, 0.0, 1e-4).normalize()) > 100.0);
            assert_eq!(d.g1(Vec3::Z, -Vec3::Z), 0.0);
        }
        // GGX: Λ = (√(1 + α² tan² θ) − 1) / 2 at θ = 45°, α = 0.5.
        let d = Microfacet::isotropic(MicrofacetType::Ggx, 0.5, true);
        let expected = 0.5 * ((1.0f32 + 0.25).sqrt() - 1.0);
        assert!((d.lambda(Vec3::new(1.0, 0.0, 1.0).normalize()) - expected).abs() < 1e-6);
        // Beckmann at a = 1: (e^{-1}/√π − erfc(1)) / 2.
        let d = Microfacet::isotropic(MicrofacetType::Beckmann, 1.0, true);
        let expected = 0.5 * ((-1.0f32).exp() / PI.sqrt() - 0.157_299_2);
        assert!((d.lambda(Vec3::new(1.0, 0.0, 1.0).normalize()) - expected).abs() < 1e-6);
    }

    /// Chi-square test of `sample` against `pdf` over every combination
    /// the brief of this module lists: 2 shapes × visible or not ×
    /// isotropic or not × 3 roughnesses × 4 directions, and isotropic
    /// Phong at 4 roughnesses (Šidák-corrected).
    ///
    /// The harness bins in (cos θ, φ) about +z, whose cells near the pole
    /// are too coarse in θ to integrate a lobe of width α = 0.05 sitting
    /// there; so the normals are tested in a frame rotated by a fixed
    /// rotation (z → x), which puts the lobe on the harness's equator where
    /// its cells are about 0.1 rad on a side. The test is invariant under
    /// such a rotation.
    #[test]
    fn chi2_microfacet_sampling() {
        let wos = [
            Vec3::Z,
            Vec3::new(0.3, 0.2, 0.9).normalize(),
            Vec3::new(-0.6, 0.3, 0.5).normalize(),
            Vec3::new(0.95, -0.1, 0.08).normalize(),
        ];
        let mut cases = Vec::new();
        for kind in KINDS {
            for visible in [false, true] {
                for (au, av) in [
                    (0.05, 0.05),
                    (0.3, 0.3),
                    (1.0, 1.0),
                    (0.05, 0.3),
                    (1.0, 0.3),
                ] {
                    for wo in wos {
                        cases.push((aniso(kind, au, av, visible), wo));
                    }
                }
            }
        }
        let n = cases.len() as f64;
        let cfg = Chi2Config {
            alpha: 1.0 - 0.99f64.powf(1.0 / n),
            samples: 100_000,
            integration_res: 16,
            ..Chi2Config::default()
        };
        // A proper rotation taking +z to +x, and its inverse.
        let rot = |v: Vec3| Vec3::new(v.z, v.x, v.y);
        let unrot = |v: Vec3| Vec3::new(v.y, v.z, v.x);
        // Phong (isotropic; always D cos θm), α from sharp to uniform.
        for alpha in [0.05, 0.3, 1.0, 1.5] {
            for wo in wos {
                cases.push((
                    Microfacet::isotropic(MicrofacetType::Phong, alpha, true),
                    wo,
                ));
            }
        }
        let mut failures = Vec::new();
        for (d, wo) in cases {
            let res = chi2_directions(
                &cfg,
                |r: &mut Pcg32| {
                    let (m, pdf) = d.sample(wo, r.next_2d());
                    (pdf > 0.0).then_some((rot(m), pdf))
                },
                |m| d.pdf(wo, unrot(m)),
            );
            if let Err(e) = res {
                failures.push(format!("{d:?} wo={wo}: {e}"));
            }
        }
        assert!(failures.is_empty(), "{}", failures.join("\n\n"));
    }

    #[test]
    fn roughness_params() {
        let r = Roughness::from_params(&mut MapParams::new()).unwrap();
        assert_eq!(r, Roughness::isotropic(MicrofacetType::Beckmann, 0.1, true));

        let mut p = MapParams::new()
            .string("distribution", "ggx")
            .float("alpha_u", 0.2)
            .float("alpha_v", 0.4)
            .boolean("sample_visible", false);
        let r = Roughness::from_params(&mut p).unwrap();
        assert!(p.unread().is_empty(), "{:?}", p.unread());
        let at = r.at(&Materials::default(), &crate::bsdf::tests::flat_si());
        assert_eq!(at, aniso(MicrofacetType::Ggx, 0.2, 0.4, false), "{r:?}");

        let err = |p: MapParams| Roughness::from_params(&mut { p }).unwrap_err().0;
        let e = err(MapParams::new().float("alpha_u", 0.2));
        assert!(e.contains("alpha_v"), "{e}");
        let e = err(MapParams::new()
            .float("alpha", 0.2)
            .float("alpha_u", 0.2)
            .float("alpha_v", 0.2));
        assert!(e.contains("\"alpha\""), "{e}");
        let e = err(MapParams::new().float("alpha", 0.0));
        assert!(e.contains("\"alpha\"") && e.contains("positive"), "{e}");
        let e = err(MapParams::new()
            .float("alpha_u", 0.1)
            .float("alpha_v", f32::NAN));
        assert!(e.contains("\"alpha_v\""), "{e}");
        let e = err(MapParams::new().string("distribution", "phong2"));
        assert!(
            e.contains("distribution") && e.contains("phong2") && e.contains("phong"),
            "{e}"
        );

        // Phong: isotropic only.
        let mut p = MapParams::new()
            .string("distribution", "phong")
            .float("alpha", 0.3);
        let r = Roughness::from_params(&mut p).unwrap();
        assert!(p.unread().is_empty(), "{:?}", p.unread());
        assert_eq!(r, Roughness::isotropic(MicrofacetType::Phong, 0.3, true));
        let r = Roughness::from_params(
            &mut MapParams::new()
                .string("distribution", "phong")
                .float("alpha_u", 0.2)
                .float("alpha_v", 0.2),
        )
        .unwrap();
        assert_eq!(r.kind, MicrofacetType::Phong);
        let e = err(MapParams::new()
            .string("distribution", "phong")
            .float("alpha_u", 0.1)
            .float("alpha_v", 0.3));
        assert!(e.contains("isotropic") && e.contains("alpha_u"), "{e}");
    }

    #[test]
    fn textured_roughness_is_clamped() {
        let mut m = Materials::default();
        m.textures.push(crate::texture::Texture::Checkerboard(
            crate::texture::Checkerboard {
                color0: Tex::value(0.0),
                color1: Tex::value(0.0),
                to_uv: glam::Affine2::IDENTITY,
                float_swapped: false,
            },
        ));
        let mut p = MapParams::new()
            .texture("alpha", 0)
            .string("distribution", "ggx");
        let r = Roughness::from_params(&mut p).unwrap();
        let d = r.at(&m, &crate::bsdf::tests::flat_si());
        assert_eq!(d.alpha_u, MIN_TEXTURED_ALPHA);
        let v = d.d(Vec3::Z);
        assert!(v.is_finite() && v > 0.0, "{v}");
    }
}

#[cfg(test)]
mod grid_tests {
    use super::*;

    /// `sample_grid` gives exactly what `sample` gives node by node, for
    /// every distribution, visible or not, at grazing and normal incidence.
    #[test]
    fn sample_grid_equals_sampling_node_by_node() {
        let ux = [0.013f32, 0.2, 0.5, 0.77, 0.999];
        let uy = [0.001f32, 0.31, 0.5, 0.93];
        for kind in [
            MicrofacetType::Beckmann,
            MicrofacetType::Ggx,
            MicrofacetType::Phong,
        ] {
            for visible in [true, false] {
                let d = Microfacet::isotropic(kind, 0.3, visible);
                for wo in [
                    Vec3::Z,
                    Vec3::new(0.6, 0.0, 0.8),
                    Vec3::new(0.999, 0.0, 0.0447).normalize(),
                ] {
                    let grid = d.sample_grid(wo, &ux, &uy);
                    for (i, &x) in ux.iter().enumerate() {
                        for (j, &y) in uy.iter().enumerate() {
                            let one = d.sample(wo, Vec2::new(x, y));
                            assert_eq!(
                                grid[i * uy.len() + j],
                                one,
                                "{kind:?} {visible} {wo} {x} {y}"
                            );
                        }
                    }
                }
            }
        }
    }
}
