//! BSDFs: the contract every material model implements, and the closed
//! enum the scene stores.
//!
//! Conventions (shared with Mitsuba 3 and pbrt-v4):
//! - Directions are in the local shading frame, +z the shading normal,
//!   and both point away from the surface: `wo` towards the viewer (where
//!   the path came from), `wi` towards the light (where it goes next).
//! - [`BsdfModel::eval`] returns f(wo, wi) · |cos θi| — the cosine
//!   foreshortening is included, as in Mitsuba 3.
//! - [`BsdfModel::sample`] returns the *weight* eval/pdf, so delta lobes
//!   (pdf formally infinite) are handled without special cases.
//! - [`TransportMode`] says whether radiance (camera paths) or importance
//!   (light paths) is carried; non-symmetric BSDFs (refraction, shading
//!   normals) differ between the two.
//! - One-sided models are black when `wo` or `wi` is below the surface;
//!   `twosided` makes them work on both sides.
//!
//! Composite BSDFs (`twosided`, `blendbsdf`, `mask`, `bumpmap`, ...) refer
//! to their children by index in the scene's BSDF table, and texturable
//! parameters to textures by index, so each method takes the scene's
//! [`Materials`].

mod conductor;
mod diffuse;
pub mod fresnel;
pub mod microfacet;
mod rough_conductor;
mod twosided;

pub use conductor::{Conductor, ConductorIor};
pub use diffuse::Diffuse;
pub use rough_conductor::RoughConductor;
pub use twosided::TwoSided;

use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ParamError, Params};
use crate::Rgb;
use glam::{Vec2, Vec3};

/// Which quantity a path carries.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TransportMode {
    /// Paths from the camera carry radiance.
    #[default]
    Radiance,
    /// Paths from lights carry importance.
    Importance,
}

/// Per-query settings of a BSDF evaluation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BsdfContext {
    /// Radiance or importance.
    pub mode: TransportMode,
}

/// Lobe flags: what kinds of scattering a BSDF (or one sample) has.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct BsdfFlags(pub u32);

impl BsdfFlags {
    /// No scattering.
    pub const NONE: Self = Self(0);
    /// Index-matched pass-through (the path continues unchanged).
    pub const NULL: Self = Self(1);
    /// Ideal diffuse reflection.
    pub const DIFFUSE_REFLECTION: Self = Self(1 << 1);
    /// Ideal diffuse transmission.
    pub const DIFFUSE_TRANSMISSION: Self = Self(1 << 2);
    /// Glossy reflection.
    pub const GLOSSY_REFLECTION: Self = Self(1 << 3);
    /// Glossy transmission.
    pub const GLOSSY_TRANSMISSION: Self = Self(1 << 4);
    /// Perfectly specular reflection.
    pub const DELTA_REFLECTION: Self = Self(1 << 5);
    /// Perfectly specular transmission.
    pub const DELTA_TRANSMISSION: Self = Self(1 << 6);
    /// Scatters on the front side.
    pub const FRONT_SIDE: Self = Self(1 << 7);
    /// Scatters on the back side.
    pub const BACK_SIDE: Self = Self(1 << 8);
    /// Any delta lobe.
    pub const DELTA: Self =
        Self(Self::NULL.0 | Self::DELTA_REFLECTION.0 | Self::DELTA_TRANSMISSION.0);
    /// Any lobe that has a finite density (can be light-sampled).
    pub const SMOOTH: Self = Self(
        Self::DIFFUSE_REFLECTION.0
            | Self::DIFFUSE_TRANSMISSION.0
            | Self::GLOSSY_REFLECTION.0
            | Self::GLOSSY_TRANSMISSION.0,
    );

    /// True when any flag of `other` is set.
    #[inline]
    pub fn intersects(self, other: Self) -> bool {
        self.0 & other.0 != 0
    }
}

impl std::ops::BitOr for BsdfFlags {
    type Output = Self;
    fn bitor(self, o: Self) -> Self {
        Self(self.0 | o.0)
    }
}

/// A sampled direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// Sampled direction (local frame).
    pub wi: Vec3,
    /// Its density per solid angle (1 for delta lobes, by convention).
    pub pdf: f32,
    /// Relative index of refraction along the sampled direction (1 for
    /// reflection).
    pub eta: f32,
    /// The lobe that was sampled.
    pub sampled: BsdfFlags,
    /// eval / pdf.
    pub weight: Rgb,
}

/// The contract of every BSDF.
pub trait BsdfModel {
    /// Lobes this BSDF has.
    fn flags(&self, m: &Materials) -> BsdfFlags;
    /// Samples `wi` given `wo`; `u1` picks a lobe, `u2` the direction.
    fn sample(
        &self,
        m: &Materials,
        ctx: &BsdfContext,
        si: &SurfaceInteraction,
        wo: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample>;
    /// f · |cos θi| for the smooth lobes (delta lobes give 0).
    fn eval(
        &self,
        m: &Materials,
        ctx: &BsdfContext,
        si: &SurfaceInteraction,
        wo: Vec3,
        wi: Vec3,
    ) -> Rgb;
    /// Density with which [`BsdfModel::sample`] picks `wi` (smooth lobes).
    fn pdf(
        &self,
        m: &Materials,
        ctx: &BsdfContext,
        si: &SurfaceInteraction,
        wo: Vec3,
        wi: Vec3,
    ) -> f32;
}

/// A BSDF (closed enum; see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bsdf {
    /// `conductor`.
    Conductor(Conductor),
    /// `diffuse`.
    Diffuse(Diffuse),
    /// `roughconductor`.
    RoughConductor(RoughConductor),
    /// `twosided`.
    TwoSided(TwoSided),
}

/// Builds a BSDF plugin from its parameters.
pub type BsdfFromParams = fn(&mut dyn Params) -> Result<Bsdf, ParamError>;

/// Every BSDF plugin: its scene type string and constructor. Adding a BSDF
/// adds one line here (and its variant and dispatch arm below).
pub const PLUGINS: &[(&str, BsdfFromParams)] = &[
    ("conductor", |p| {
        Ok(Bsdf::Conductor(Conductor::from_params(p)?))
    }),
    ("diffuse", |p| Ok(Bsdf::Diffuse(Diffuse::from_params(p)?))),
    ("roughconductor", |p| {
        Ok(Bsdf::RoughConductor(RoughConductor::from_params(p)?))
    }),
    ("twosided", |p| {
        Ok(Bsdf::TwoSided(TwoSided::from_params(p)?))
    }),
];

macro_rules! dispatch {
    ($self:expr, $b:ident => $e:expr) => {
        match $self {
            Bsdf::Conductor($b) => $e,
            Bsdf::Diffuse($b) => $e,
            Bsdf::RoughConductor($b) => $e,
            Bsdf::TwoSided($b) => $e,
        }
    };
}

impl BsdfModel for Bsdf {
    #[inline]
    fn flags(&self, m: &Materials) -> BsdfFlags {
        dispatch!(self, b => b.flags(m))
    }
    #[inline]
    fn sample(
        &self,
        m: &Materials,
        ctx: &BsdfContext,
        si: &SurfaceInteraction,
        wo: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        dispatch!(self, b => b.sample(m, ctx, si, wo, u1, u2))
    }
    #[inline]
    fn eval(
        &self,
        m: &Materials,
        ctx: &BsdfContext,
        si: &SurfaceInteraction,
        wo: Vec3,
        wi: Vec3,
    ) -> Rgb {
        dispatch!(self, b => b.eval(m, ctx, si, wo, wi))
    }
    #[inline]
    fn pdf(
        &self,
        m: &Materials,
        ctx: &BsdfContext,
        si: &SurfaceInteraction,
        wo: Vec3,
        wi: Vec3,
    ) -> f32 {
        dispatch!(self, b => b.pdf(m, ctx, si, wo, wi))
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::math::Frame;
    use crate::sampler::Pcg32;
    use crate::testing::chi2::{chi2_directions, Chi2Config};

    /// A surface interaction at the origin facing +z.
    pub(crate) fn flat_si() -> SurfaceInteraction {
        SurfaceInteraction {
            p: Vec3::ZERO,
            t: 1.0,
            n: Vec3::Z,
            sh_frame: Frame::from_normal(Vec3::Z),
            uv: Vec2::splat(0.5),
            dpdu: Vec3::X,
            dpdv: Vec3::Y,
            wo: Vec3::Z,
            shape: 0,
            prim: 0,
        }
    }

    /// Chi-square test of `m.bsdfs[id]`'s sampling of its smooth lobes
    /// against its pdf for `wo`, plus consistency of sample weights with
    /// eval/pdf. Samples of delta lobes are left out of the histogram (the
    /// pdf of the smooth lobes then integrates to less than one, and the
    /// test expects exactly that much mass).
    pub(crate) fn check_bsdf(m: &Materials, id: usize, wo: Vec3) {
        check_bsdf_result(m, id, wo).unwrap();
    }

    /// [`check_bsdf`] returning the failure instead of panicking.
    pub(crate) fn check_bsdf_result(m: &Materials, id: usize, wo: Vec3) -> Result<(), String> {
        check_bsdf_at(m, id, wo, Chi2Config::default().alpha)
    }

    /// [`check_bsdf_result`] at significance level `alpha` (for a family
    /// of tests, each gets the Šidák-corrected level).
    pub(crate) fn check_bsdf_at(
        m: &Materials,
        id: usize,
        wo: Vec3,
        alpha: f64,
    ) -> Result<(), String> {
        let (b, si, ctx) = (m.bsdfs[id], flat_si(), BsdfContext::default());
        let mut bad_weight = None;
        chi2_directions(
            &Chi2Config {
                alpha,
                ..Chi2Config::default()
            },
            |r: &mut Pcg32| {
                let u1 = r.next_f32();
                let s = b.sample(m, &ctx, &si, wo, u1, r.next_2d())?;
                if s.sampled.intersects(BsdfFlags::DELTA) {
                    return None;
                }
                let expected = b.eval(m, &ctx, &si, wo, s.wi) / s.pdf;
                if (expected - s.weight).abs().max_element()
                    > 1e-3 * expected.max_element().max(1.0)
                {
                    bad_weight.get_or_insert(format!(
                        "weight {} vs eval/pdf {} at wi {}",
                        s.weight, expected, s.wi
                    ));
                }
                Some((s.wi, s.pdf))
            },
            |wi| b.pdf(m, &ctx, &si, wo, wi),
        )?;
        match bad_weight {
            Some(msg) => Err(msg),
            None => Ok(()),
        }
    }

    /// Helmholtz reciprocity f(wo, wi)/|cos wi| = f(wi, wo)/|cos wo|.
    pub(crate) fn check_reciprocity(m: &Materials, id: usize) {
        check_reciprocity_result(m, id).unwrap();
    }

    /// [`check_reciprocity`] returning the failure instead of panicking.
    pub(crate) fn check_reciprocity_result(m: &Materials, id: usize) -> Result<(), String> {
        let (b, si, ctx) = (m.bsdfs[id], flat_si(), BsdfContext::default());
        let mut rng = Pcg32::new(5, 5);
        for _ in 0..1000 {
            let wo = crate::sampling::square_to_uniform_sphere(rng.next_2d());
            let mut wi = crate::sampling::square_to_uniform_sphere(rng.next_2d());
            // Reflection only: refraction scales radiance by η².
            if wi.z * wo.z < 0.0 {
                wi.z = -wi.z;
            }
            let f1 = b.eval(m, &ctx, &si, wo, wi) / wi.z.abs();
            let f2 = b.eval(m, &ctx, &si, wi, wo) / wo.z.abs();
            if (f1 - f2).abs().max_element() >= 1e-3 * f1.max_element().max(1.0) {
                return Err(format!(
                    "f(wo, wi) = {f1} but f(wi, wo) = {f2} (wo {wo}, wi {wi})"
                ));
            }
        }
        Ok(())
    }

    /// Albedo (∫ f cos dωi) estimated by sampling, for energy checks.
    pub(crate) fn albedo(m: &Materials, id: usize, wo: Vec3) -> Rgb {
        let (b, si, ctx) = (m.bsdfs[id], flat_si(), BsdfContext::default());
        let mut rng = Pcg32::new(9, 9);
        let n = 100_000;
        let sum: glam::DVec3 = (0..n)
            .filter_map(|_| {
                let u1 = rng.next_f32();
                b.sample(m, &ctx, &si, wo, u1, rng.next_2d())
            })
            .map(|s| s.weight.as_dvec3())
            .sum();
        (sum / n as f64).as_vec3()
    }

    /// One configuration of a BSDF for the table-driven tests: the tables
    /// and the index of the BSDF under test.
    pub(crate) struct Variant {
        /// What is being tested, for messages.
        pub name: String,
        /// The tables (with its children and textures).
        pub m: Materials,
        /// The BSDF under test.
        pub id: usize,
        /// Expected albedo is 1 for every `wo` (lossless models).
        pub lossless: bool,
    }

    impl Variant {
        /// A variant whose BSDF is the last entry of `bsdfs`.
        pub(crate) fn last(name: impl Into<String>, bsdfs: Vec<Bsdf>) -> Self {
            let id = bsdfs.len() - 1;
            Self {
                name: name.into(),
                m: Materials::with_bsdfs(bsdfs),
                id,
                lossless: false,
            }
        }
    }

    /// Directions `wo` every variant is tested from: grazing to normal, and
    /// below the surface (one-sided models must return nothing there).
    fn test_directions() -> [Vec3; 5] {
        [
            Vec3::new(0.3, 0.2, 0.9).normalize(),
            Vec3::new(-0.6, 0.3, 0.5).normalize(),
            Vec3::new(0.95, -0.1, 0.08).normalize(),
            Vec3::new(0.2, 0.1, -0.9).normalize(),
            Vec3::new(-0.5, -0.6, -0.2).normalize(),
        ]
    }

    /// The table-driven test: every variant of every BSDF, from every test
    /// direction: the chi-square test of its sampling against its pdf and
    /// of its weights against eval/pdf, energy (albedo at most one, exactly
    /// one when lossless), and reciprocity of its reflection. All failures
    /// are collected and reported together. The chi-square tests share a
    /// family-wise significance of 1 %, Šidák-corrected: at 0.01 each, a
    /// table of a hundred correct samplers would fail one on average.
    #[test]
    fn every_bsdf_variant() {
        let variants: Vec<Variant> = [
            conductor::tests::test_variants(),
            diffuse::tests::test_variants(),
            rough_conductor::tests::test_variants(),
            twosided::tests::test_variants(),
        ]
        .into_iter()
        .flatten()
        .collect();
        let chi2_tests = variants
            .iter()
            .map(|v| {
                let flags = v.m.bsdfs[v.id].flags(&v.m);
                if !flags.intersects(BsdfFlags::SMOOTH) {
                    return 0;
                }
                let back = flags.intersects(BsdfFlags::BACK_SIDE);
                test_directions()
                    .iter()
                    .filter(|wo| wo.z > 0.0 || back)
                    .count()
            })
            .sum::<usize>();
        let alpha = 1.0 - (1.0 - Chi2Config::default().alpha).powf(1.0 / chi2_tests as f64);
        let mut failures = Vec::new();
        for v in &variants {
            let flags = v.m.bsdfs[v.id].flags(&v.m);
            for wo in test_directions() {
                let facing = wo.z > 0.0 || flags.intersects(BsdfFlags::BACK_SIDE);
                let a = albedo(&v.m, v.id, wo);
                if !facing {
                    if a != Rgb::ZERO {
                        failures.push(format!(
                            "{} wo={wo}: one-sided but reflects {a} from below",
                            v.name
                        ));
                    }
                    continue;
                }
                if flags.intersects(BsdfFlags::SMOOTH) {
                    if let Err(e) = check_bsdf_at(&v.m, v.id, wo, alpha) {
                        failures.push(format!("{} wo={wo}: chi-square: {e}", v.name));
                    }
                }
                if a.max_element() > 1.0 + 0.01 {
                    failures.push(format!("{} wo={wo}: albedo {a} > 1", v.name));
                }
                if v.lossless && (a - Rgb::ONE).abs().max_element() > 0.01 {
                    failures.push(format!("{} wo={wo}: lossless but albedo {a}", v.name));
                }
            }
            if let Err(e) = check_reciprocity_result(&v.m, v.id) {
                failures.push(format!("{}: reciprocity: {e}", v.name));
            }
        }
        assert!(
            failures.is_empty(),
            "{} failures:\n{}",
            failures.len(),
            failures.join("\n")
        );
        println!(
            "{} BSDF variants passed ({chi2_tests} chi-square tests at α = {alpha:.2e} each)",
            variants.len()
        );
    }
}
