//! `thindielectric`: a thin, smooth dielectric slab (a window pane, a soap
//! film without interference) modelled as one surface: light is reflected
//! or passes straight through, without the sideways shift of refraction.
//!
//! | parameter                | type                     | default | meaning |
//! |--------------------------|--------------------------|---------|---------|
//! | `int_ior`                | float or material name   | `bk7`   | index of refraction of the slab |
//! | `ext_ior`                | float or material name   | `air`   | index of refraction around it |
//! | `specular_reflectance`   | texture / rgb / spectrum | 1       | scales reflection (not physical) |
//! | `specular_transmittance` | texture / rgb / spectrum | 1       | scales transmission (not physical) |
//!
//! ```xml
//! <bsdf type="thindielectric">
//!     <string name="int_ior" value="bk7"/>
//! </bsdf>
//! ```
//!
//! Summing the geometric series of internal reflections between the two
//! faces (each with Fresnel reflectance R at the angle of incidence; the
//! inner angle gives the same R) gives the slab's reflectance
//! R' = R + T²R/(1 − R²) = 2R/(1 + R), T = 1 − R, and transmittance
//! 1 − R' (the incoherent multiple-reflection sum of a plane-parallel
//! plate, Born & Wolf, *Principles of Optics*, §7.6; Mitsuba 3's
//! `thindielectric` and pbrt-v4's `ThinDielectricBxDF` use the same
//! model). The transmitted direction is
//! −wo: the two refractions cancel, so the path neither bends nor changes
//! its radiance scale (η = 1). Two-sided.
//!
//! Transmission is a delta transmission lobe. Mitsuba 3 flags it `Null`,
//! but its `path`'s shadow rays stop at the slab as yubin's do, and its `path`
//! treats a null sample like any delta one for MIS. yubin's `path` keeps
//! the previous vertex's density across null lobes because its shadow
//! rays cross null surfaces; flagged null, light through a slab would be
//! counted by neither strategy where the previous vertex is not smooth.
//! `volpath` (whose shadow rays cross slabs, as Mitsuba's `volpath`'s do)
//! asks for the null flag through [`BsdfContext::null_slabs`].

use super::dielectric::{Dielectric, DielectricLobe};
use super::fresnel::{fresnel_dielectric, reflect};
use super::{BsdfContext, BsdfFlags, BsdfSample, Scatter};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ParamError, Params};
use crate::Rgb;
use glam::{Vec2, Vec3};

/// A thin dielectric slab (the same parameters as [`Dielectric`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinDielectric(pub Dielectric);

impl ThinDielectric {
    /// A slab of relative index `eta` with unit reflectance and
    /// transmittance.
    pub fn new(eta: f32) -> Self {
        Self(Dielectric::new(eta))
    }

    /// Builds the BSDF from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        Dielectric::from_params(p).map(Self)
    }

    /// The probability of transmission along the ray at `si`, 1 − R′,
    /// and what passes: (1 − R′) T.
    pub fn null_crossing(&self, m: &Materials, si: &SurfaceInteraction) -> (f32, Rgb) {
        let p = 1.0 - self.reflectance(si.to_local(si.wo).z);
        (p, p * self.0.specular_transmittance.eval(m, si))
    }

    /// The slab's reflectance for a direction with cosine `cos_theta`.
    #[inline]
    pub fn reflectance(&self, cos_theta: f32) -> f32 {
        slab_reflectance(cos_theta, self.0.eta)
    }
}

/// The reflectance of a slab of relative index `eta` for a direction
/// with cosine `cos_theta`, its inner reflections summed.
#[inline]
fn slab_reflectance(cos_theta: f32, eta: f32) -> f32 {
    // The slab is symmetric, so the side does not matter.
    let r = fresnel_dielectric(cos_theta.abs(), eta).0;
    if r < 1.0 {
        2.0 * r / (1.0 + r)
    } else {
        1.0
    }
}

impl ThinDielectric {
    /// Lobes this material has.
    pub fn flags(&self, _: &Materials) -> BsdfFlags {
        BsdfFlags::DELTA_REFLECTION
            | BsdfFlags::DELTA_TRANSMISSION
            | BsdfFlags::FRONT_SIDE
            | BsdfFlags::BACK_SIDE
    }

    /// The lobe at `si`.
    #[inline]
    pub fn lobe(&self, m: &Materials, si: &SurfaceInteraction) -> ThinDielectricLobe {
        ThinDielectricLobe(self.0.lobe(m, si))
    }
}

/// [`ThinDielectric`] at a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinDielectricLobe(pub DielectricLobe);

impl Scatter for ThinDielectricLobe {
    #[inline]
    fn sample(&self, ctx: &BsdfContext, wo: Vec3, u1: f32, _: Vec2) -> Option<BsdfSample> {
        let r = slab_reflectance(wo.z, self.0.eta);
        Some(if u1 < r {
            BsdfSample {
                wi: reflect(wo),
                pdf: r,
                eta: 1.0,
                sampled: BsdfFlags::DELTA_REFLECTION,
                weight: self.0.specular_reflectance,
            }
        } else {
            BsdfSample {
                wi: -wo,
                pdf: 1.0 - r,
                eta: 1.0,
                sampled: if ctx.null_slabs {
                    BsdfFlags::NULL
                } else {
                    BsdfFlags::DELTA_TRANSMISSION
                },
                weight: self.0.specular_transmittance,
            }
        })
    }

    #[inline]
    fn eval(&self, _: &BsdfContext, _: Vec3, _: Vec3) -> Rgb {
        Rgb::ZERO
    }

    #[inline]
    fn pdf(&self, _: &BsdfContext, _: Vec3, _: Vec3) -> f32 {
        0.0
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::tests::{flat_si, Variant};
    use crate::bsdf::BsdfModel;
    use crate::bsdf::Material;
    use crate::texture::Tex;

    /// Lobe probabilities printed by Mitsuba 3.9.1 (`scalar_rgb`) for the
    /// default `thindielectric` (bk7 in air): `bsdf.sample(ctx, si, u1,
    /// [0.5, 0.5])`; the weights are 1 and η is 1 in both lobes and modes.
    #[test]
    fn matches_mitsuba() {
        let t = Materials::with_bsdfs(vec![Material::ThinDielectric(ThinDielectric::new(
            1.5046 / 1.000_277,
        ))]);
        let si = flat_si();
        let ctx = BsdfContext::default();
        for (wo, r) in [
            ([0.309426, 0.206284, 0.928279], 0.07863),
            ([0.963087, 0.120386, 0.240772], 0.434091),
            ([0.227921, -0.341882, -0.911685], 0.079035),
            ([0.894427, 0.0, -0.447214], 0.197855),
        ] {
            let wo = Vec3::from_array(wo);
            let b = &t.bsdfs[0];
            let s = b.sample(&t, &ctx, &si, wo, 0.01, Vec2::ZERO).unwrap();
            assert!((s.pdf - r).abs() < 2e-5, "{wo}: {s:?}");
            assert_eq!((s.wi, s.weight, s.eta), (reflect(wo), Rgb::ONE, 1.0));
            let s = b.sample(&t, &ctx, &si, wo, 0.99, Vec2::ZERO).unwrap();
            assert!((s.pdf - (1.0 - r)).abs() < 2e-5, "{wo}: {s:?}");
            assert_eq!((s.wi, s.weight, s.eta), (-wo, Rgb::ONE, 1.0));
            assert_eq!(s.sampled, BsdfFlags::DELTA_TRANSMISSION);
        }
    }

    #[test]
    fn series_sum() {
        // R + T²R/(1 − R²) with T = 1 − R equals 2R/(1 + R).
        let slab = ThinDielectric::new(1.5);
        for c in [1.0f32, 0.7, 0.3, 0.05] {
            let r = fresnel_dielectric(c, 1.5).0;
            let t = 1.0 - r;
            let series = r + t * t * r / (1.0 - r * r);
            assert!((slab.reflectance(c) - series).abs() < 1e-6);
            assert_eq!(slab.reflectance(c), slab.reflectance(-c));
        }
    }

    /// Configurations for the table-driven tests in `bsdf/mod.rs`.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let mut v: Vec<Variant> = [1.5046 / 1.000_277, 2.419, 1.0 / 1.33]
            .into_iter()
            .map(|eta| {
                let mut v = Variant::last(
                    format!("thindielectric (η {eta})"),
                    vec![Material::ThinDielectric(ThinDielectric::new(eta))],
                );
                v.lossless = true;
                v
            })
            .collect();
        v.push(Variant::last(
            "thindielectric (tinted)",
            vec![Material::ThinDielectric(ThinDielectric(Dielectric {
                specular_reflectance: Tex::value(0.3),
                specular_transmittance: Tex::Const(Rgb::new(0.2, 0.9, 0.5)),
                ..Dielectric::new(1.5)
            }))],
        ));
        v
    }
}
