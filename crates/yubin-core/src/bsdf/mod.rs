//! Materials and the BSDFs they make at a surface vertex.
//!
//! A [`Material`] (closed enum, one variant per `<bsdf type>` plugin) is
//! what a scene file describes: parameters that may be textures, and
//! composites (`twosided`, `blendbsdf`, `mask`, `bumpmap`, `normalmap`)
//! that refer to other materials by index in the scene's [`Materials`].
//! At a vertex the integrator asks it once for a [`Bsdf`]
//! ([`Material::at`]): a plain `Copy` value, texture-free, made of the
//! models' [`Lobe`]s, that answers every query there (see `value.rs`).
//! [`BsdfModel`] asks a material one query at a time through the same
//! value, for tests and one-off queries.
//!
//! Conventions (shared with Mitsuba 3 and pbrt-v4):
//! - Directions are in the local shading frame, +z the shading normal,
//!   and both point away from the surface: `wo` towards the viewer (where
//!   the path came from), `wi` towards the light (where it goes next).
//! - `eval` returns f(wo, wi) · |cos θi| — the cosine foreshortening is
//!   included, as in Mitsuba 3.
//! - `sample` returns the *weight* eval/pdf, so delta lobes (pdf formally
//!   infinite) are handled without special cases.
//! - [`TransportMode`] says whether radiance (camera paths) or importance
//!   (light paths) is carried; non-symmetric BSDFs (refraction, shading
//!   normals) differ between the two.
//! - One-sided models are black when `wo` or `wi` is below the surface;
//!   `twosided` makes them work on both sides.
//!
//! Each plugin's file holds its material (parameters, `from_params`,
//! `flags`, `lobe`) and its lobe ([`Scatter`]), or, for a composite, its
//! node of the resolved tree.

mod blend_bsdf;
mod bump_map;
mod conductor;
mod dielectric;
mod difftrans;
mod diffuse;
mod disney;
pub mod fresnel;
mod hair;
mod mask;
mod measured;
pub mod microfacet;
mod normal_map;
mod null;
mod perturbed;
mod phong;
mod plastic;
mod principled;
mod principled_thin;
mod rough_conductor;
mod rough_dielectric;
mod rough_diffuse;
mod rough_plastic;
mod thin_dielectric;
mod twosided;
mod value;

pub use blend_bsdf::BlendBsdf;
pub use bump_map::BumpMap;
pub use conductor::{Conductor, ConductorIor};
pub use dielectric::Dielectric;
pub use difftrans::DiffTrans;
pub use diffuse::Diffuse;
pub use disney::DisneyParams;
pub use hair::Hair;
pub use mask::Mask;
pub use measured::{Measured, MeasuredData};
pub use normal_map::NormalMap;
pub use null::Null;
pub use phong::Phong;
pub use plastic::{fresnel_diffuse_reflectance, Plastic};
pub use principled::Principled;
pub use principled_thin::PrincipledThin;
pub use rough_conductor::RoughConductor;
pub use rough_dielectric::RoughDielectric;
pub use rough_diffuse::RoughDiffuse;
pub use rough_plastic::{RoughPlastic, RoughTransmittance};
pub use thin_dielectric::ThinDielectric;
pub use twosided::TwoSided;
pub use value::{Bsdf, Lobe, Scatter, MAX_LOBES, MAX_NODES};
pub use value::{
    ConductorLobe, DielectricLobe, DiffTransLobe, DiffuseLobe, PhongLobe, PlasticLobe,
    PrincipledLobe, PrincipledThinLobe, RoughConductorLobe, RoughDielectricLobe, RoughDiffuseLobe,
    RoughPlasticLobe, ThinDielectricLobe,
};

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
    /// Report `thindielectric` transmission as a null lobe (Mitsuba 3's
    /// convention, which `volpath` follows: it does not count as a
    /// bounce, and shadow rays cross the slab).
    pub null_slabs: bool,
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

/// A material asked one query at a time (each call makes the [`Bsdf`] at
/// the vertex and asks it once).
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
    /// [`BsdfModel::eval`] and [`BsdfModel::pdf`] at once, as a light
    /// sample weighed by MIS needs them; the same values, with the work
    /// they share (half vector, D, G1 of `wo`) done once where a model
    /// overrides it.
    #[inline]
    fn eval_pdf(
        &self,
        m: &Materials,
        ctx: &BsdfContext,
        si: &SurfaceInteraction,
        wo: Vec3,
        wi: Vec3,
    ) -> (Rgb, f32) {
        (self.eval(m, ctx, si, wo, wi), self.pdf(m, ctx, si, wo, wi))
    }
}

/// A BSDF (closed enum; see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Material {
    /// `diffuse`.
    Diffuse(Diffuse),
    /// `twosided`.
    TwoSided(TwoSided),
    /// `plastic`.
    Plastic(Plastic),
    /// `roughplastic`.
    RoughPlastic(RoughPlastic),
    /// `null`.
    Null(Null),
    /// `mask`.
    Mask(Mask),
    /// `blendbsdf`.
    BlendBsdf(BlendBsdf),
    /// `bumpmap`.
    BumpMap(BumpMap),
    /// `normalmap`.
    NormalMap(NormalMap),
    /// `dielectric`.
    Dielectric(Dielectric),
    /// `thindielectric`.
    ThinDielectric(ThinDielectric),
    /// `roughdielectric`.
    RoughDielectric(RoughDielectric),
    /// `conductor`.
    Conductor(Conductor),
    /// `roughconductor`.
    RoughConductor(RoughConductor),
    /// `principled`.
    Principled(Principled),
    /// `principledthin`.
    PrincipledThin(PrincipledThin),
    /// `roughdiffuse`.
    RoughDiffuse(RoughDiffuse),
    /// `phong`.
    Phong(Phong),
    /// `difftrans`.
    DiffTrans(DiffTrans),
    /// `measured`.
    Measured(Measured),
    /// `hair`.
    Hair(Hair),
}

impl Material {
    /// Whether the BSDF's values and the distribution of its samples stay
    /// the same when the shading frame turns about the normal (it reads
    /// no tangent direction): isotropic models without bump or normal
    /// maps. Conservative: `false` where unsure.
    pub fn turns_freely(&self, m: &Materials) -> bool {
        let isotropic = |r: &microfacet::Roughness| r.alpha_u == r.alpha_v;
        match self {
            Material::Diffuse(_)
            | Material::Plastic(_)
            | Material::RoughPlastic(_)
            | Material::Null(_)
            | Material::Dielectric(_)
            | Material::ThinDielectric(_)
            | Material::Conductor(_)
            | Material::RoughDiffuse(_)
            | Material::DiffTrans(_) => true,
            Material::RoughConductor(b) => isotropic(&b.roughness),
            Material::RoughDielectric(b) => isotropic(&b.roughness),
            Material::Measured(b) => b.data.is_isotropic(),
            Material::TwoSided(t) => [t.front, t.back]
                .iter()
                .all(|&b| m.bsdfs[b as usize].turns_freely(m)),
            Material::Mask(_)
            | Material::BlendBsdf(_)
            | Material::BumpMap(_)
            | Material::NormalMap(_)
            | Material::Principled(_)
            | Material::PrincipledThin(_)
            | Material::Phong(_)
            | Material::Hair(_) => false,
        }
    }
}

impl Material {
    /// The BSDFs nested in this one, by index (none for plain models).
    pub fn children(&self) -> Vec<u32> {
        match self {
            Material::TwoSided(t) => vec![t.front, t.back],
            Material::Mask(b) => vec![b.nested],
            Material::BumpMap(b) => vec![b.nested],
            Material::NormalMap(b) => vec![b.nested],
            Material::BlendBsdf(b) => b.bsdfs.to_vec(),
            _ => Vec::new(),
        }
    }

    /// True when this BSDF or one nested in it reads a normal map in
    /// MikkTSpace: the mesh under it needs tangents
    /// ([`crate::shape::TriangleMesh::compute_tangents`]).
    pub fn needs_mikktspace(&self, m: &Materials) -> bool {
        matches!(self, Material::NormalMap(n) if n.mikktspace)
            || self
                .children()
                .iter()
                .any(|&c| m.bsdfs[c as usize].needs_mikktspace(m))
    }

    /// The fraction of light that passes straight through the surface at
    /// `si` (for generalized shadow rays): 1 for `null`, 1 − α for `mask`,
    /// blended by `blendbsdf`, per side for `twosided`; 0 for surfaces that
    /// scatter or refract (`thindielectric`'s straight transmission is a
    /// lobe of a glass, not a hole, and stays opaque to shadow rays, as in
    /// Mitsuba).
    pub fn pass_through(&self, m: &Materials, si: &SurfaceInteraction) -> f32 {
        self.null_transmission(m, si, false).x
    }

    /// What the surface at `si` lets straight through along the ray
    /// (Mitsuba 3's `eval_null_transmission`): 1 for `null`, 1 − α for a
    /// `mask`, mixed through `blendbsdf` and `twosided`; with `slabs`, also
    /// a `thindielectric`'s transmittance (1 − R′) T, whose transmitted
    /// direction is the incident one (`volpath` crosses slabs so, as
    /// Mitsuba's does).
    pub fn null_transmission(&self, m: &Materials, si: &SurfaceInteraction, slabs: bool) -> Rgb {
        self.null_crossing(m, si, slabs).1
    }

    /// [`Material::null_transmission`] with the probability that
    /// [`BsdfModel::sample`] picks the null lobes (what `volpathmis`
    /// weighs shadow rays by): (probability, transmission).
    pub fn null_crossing(&self, m: &Materials, si: &SurfaceInteraction, slabs: bool) -> (f32, Rgb) {
        let nested = |i: u32| m.bsdfs[i as usize].null_crossing(m, si, slabs);
        match self {
            Material::Null(_) => (1.0, Rgb::ONE),
            Material::Mask(b) => {
                let alpha = b.alpha(m, si);
                let (p, t) = nested(b.nested);
                (
                    (1.0 - alpha) + alpha * p,
                    Rgb::splat(1.0 - alpha) + alpha * t,
                )
            }
            Material::BlendBsdf(b) => {
                let w = b.weight.eval_1(m, si).clamp(0.0, 1.0);
                let [(pa, ta), (pb, tb)] = b.bsdfs.map(nested);
                (pa * (1.0 - w) + pb * w, ta * (1.0 - w) + tb * w)
            }
            Material::TwoSided(t) => {
                let side = if si.wo.dot(si.n) >= 0.0 {
                    t.front
                } else {
                    t.back
                };
                nested(side)
            }
            Material::ThinDielectric(t) if slabs => t.null_crossing(m, si),
            _ => (0.0, Rgb::ZERO),
        }
    }

    /// Whether [`Material::null_transmission`] with `slabs` can be non-zero.
    pub fn lets_light_through(&self, m: &Materials) -> bool {
        let nested = |i: u32| m.bsdfs[i as usize].lets_light_through(m);
        match self {
            Material::Null(_) | Material::Mask(_) | Material::ThinDielectric(_) => true,
            Material::BlendBsdf(b) => b.bsdfs.iter().any(|&i| nested(i)),
            Material::TwoSided(t) => nested(t.front) || nested(t.back),
            _ => false,
        }
    }

    /// Computes what the BSDF needs from the scene's tables, once, as it
    /// is added to them ([`Materials::add_bsdf`]): `roughplastic`'s
    /// transmittance tables, the plastics' specular sampling weight.
    pub fn prepare(&mut self, m: &Materials) {
        match self {
            Material::RoughPlastic(b) => b.prepare(m),
            Material::Plastic(b) => b.prepare(m),
            _ => {}
        }
    }
}

/// Builds a BSDF plugin from its parameters.
pub type BsdfFromParams = fn(&mut dyn Params) -> Result<Material, ParamError>;

/// Every BSDF plugin: its scene type string and constructor. Adding a BSDF
/// adds one line here (and its variant and dispatch arm below).
pub const PLUGINS: &[(&str, BsdfFromParams)] = &[
    ("diffuse", |p| {
        Ok(Material::Diffuse(Diffuse::from_params(p)?))
    }),
    ("twosided", |p| {
        Ok(Material::TwoSided(TwoSided::from_params(p)?))
    }),
    ("plastic", |p| {
        Ok(Material::Plastic(Plastic::from_params(p)?))
    }),
    ("roughplastic", |p| {
        Ok(Material::RoughPlastic(RoughPlastic::from_params(p)?))
    }),
    ("null", |p| Ok(Material::Null(Null::from_params(p)?))),
    ("mask", |p| Ok(Material::Mask(Mask::from_params(p)?))),
    ("blendbsdf", |p| {
        Ok(Material::BlendBsdf(BlendBsdf::from_params(p)?))
    }),
    ("bumpmap", |p| {
        Ok(Material::BumpMap(BumpMap::from_params(p)?))
    }),
    ("normalmap", |p| {
        Ok(Material::NormalMap(NormalMap::from_params(p)?))
    }),
    ("dielectric", |p| {
        Ok(Material::Dielectric(Dielectric::from_params(p)?))
    }),
    ("thindielectric", |p| {
        Ok(Material::ThinDielectric(ThinDielectric::from_params(p)?))
    }),
    ("roughdielectric", |p| {
        Ok(Material::RoughDielectric(RoughDielectric::from_params(p)?))
    }),
    ("conductor", |p| {
        Ok(Material::Conductor(Conductor::from_params(p)?))
    }),
    ("roughconductor", |p| {
        Ok(Material::RoughConductor(RoughConductor::from_params(p)?))
    }),
    ("principled", |p| {
        Ok(Material::Principled(Principled::from_params(p)?))
    }),
    ("principledthin", |p| {
        Ok(Material::PrincipledThin(PrincipledThin::from_params(p)?))
    }),
    ("roughdiffuse", |p| {
        Ok(Material::RoughDiffuse(RoughDiffuse::from_params(p)?))
    }),
    ("phong", |p| Ok(Material::Phong(Phong::from_params(p)?))),
    ("difftrans", |p| {
        Ok(Material::DiffTrans(DiffTrans::from_params(p)?))
    }),
    ("measured", |p| {
        Ok(Material::Measured(Measured::from_params(p)?))
    }),
    ("hair", |p| Ok(Material::Hair(Hair::from_params(p)?))),
];

macro_rules! dispatch {
    ($self:expr, $b:ident => $e:expr) => {
        match $self {
            Material::Diffuse($b) => $e,
            Material::TwoSided($b) => $e,
            Material::Plastic($b) => $e,
            Material::RoughPlastic($b) => $e,
            Material::Null($b) => $e,
            Material::Mask($b) => $e,
            Material::BlendBsdf($b) => $e,
            Material::BumpMap($b) => $e,
            Material::NormalMap($b) => $e,
            Material::Dielectric($b) => $e,
            Material::ThinDielectric($b) => $e,
            Material::RoughDielectric($b) => $e,
            Material::Conductor($b) => $e,
            Material::RoughConductor($b) => $e,
            Material::Principled($b) => $e,
            Material::PrincipledThin($b) => $e,
            Material::RoughDiffuse($b) => $e,
            Material::Phong($b) => $e,
            Material::DiffTrans($b) => $e,
            Material::Measured($b) => $e,
            Material::Hair($b) => $e,
        }
    };
}

impl Material {
    /// Lobes this material has (at any vertex).
    #[inline]
    pub fn flags(&self, m: &Materials) -> BsdfFlags {
        dispatch!(self, b => b.flags(m))
    }

    /// The single model's lobe at `si` for `wo` ([`Lobe::Black`] for a
    /// composite, which [`Material::at`] resolves into a tree instead).
    #[inline]
    pub(crate) fn leaf_lobe(&self, m: &Materials, si: &SurfaceInteraction, wo: Vec3) -> Lobe {
        match self {
            Material::Diffuse(b) => Lobe::Diffuse(b.lobe(m, si)),
            Material::Plastic(b) => Lobe::Plastic(b.lobe(m, si)),
            Material::RoughPlastic(b) => b.lobe(m, si, wo).map_or(Lobe::Black, Lobe::RoughPlastic),
            Material::Null(_) => Lobe::Null,
            Material::Dielectric(b) => Lobe::Dielectric(b.lobe(m, si)),
            Material::ThinDielectric(b) => Lobe::ThinDielectric(b.lobe(m, si)),
            Material::RoughDielectric(b) => Lobe::RoughDielectric(b.lobe(m, si)),
            Material::Conductor(b) => Lobe::Conductor(b.lobe(m, si)),
            Material::RoughConductor(b) => Lobe::RoughConductor(b.lobe(m, si)),
            Material::Principled(b) => Lobe::Principled(b.lobe(m, si)),
            Material::PrincipledThin(b) => Lobe::PrincipledThin(b.lobe(m, si)),
            Material::RoughDiffuse(b) => Lobe::RoughDiffuse(b.lobe(m, si)),
            Material::Phong(b) => Lobe::Phong(b.lobe(m, si)),
            Material::DiffTrans(b) => Lobe::DiffTrans(b.lobe(m, si)),
            Material::Measured(b) => Lobe::Measured(b.lobe(m, si)),
            Material::Hair(b) => Lobe::Hair(b.lobe(m, si)),
            Material::TwoSided(_)
            | Material::Mask(_)
            | Material::BlendBsdf(_)
            | Material::BumpMap(_)
            | Material::NormalMap(_) => Lobe::Black,
        }
    }
}

/// One query at a time: each call makes the BSDF at the vertex
/// ([`Material::at`]) and asks it once. An integrator makes it once per
/// vertex instead; this serves tests and one-off queries.
impl BsdfModel for Material {
    #[inline]
    fn flags(&self, m: &Materials) -> BsdfFlags {
        Material::flags(self, m)
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
        self.at(m, si, wo).sample(ctx, u1, u2)
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
        self.at(m, si, wo).eval(ctx, wi)
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
        self.at(m, si, wo).pdf(ctx, wi)
    }
    #[inline]
    fn eval_pdf(
        &self,
        m: &Materials,
        ctx: &BsdfContext,
        si: &SurfaceInteraction,
        wo: Vec3,
        wi: Vec3,
    ) -> (Rgb, f32) {
        self.at(m, si, wo).eval_pdf(ctx, wi)
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
            bary: Vec2::ZERO,
            vertices: [0; 3],
            attributes: crate::texture::NO_ATTRIBUTES,
            tangent: glam::Vec4::ZERO,
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

    /// Whether sampling from `wo` ever yields a smooth lobe or the pdf is
    /// positive anywhere (else a histogram would be empty: the BSDF only
    /// passes light through or reflects nothing there).
    fn has_smooth_mass(m: &Materials, id: usize, wo: Vec3) -> bool {
        let (b, si, ctx) = (m.bsdfs[id], flat_si(), BsdfContext::default());
        let mut rng = Pcg32::new(11, 11);
        (0..2000).any(|_| {
            let u1 = rng.next_f32();
            let smooth = b
                .sample(m, &ctx, &si, wo, u1, rng.next_2d())
                .is_some_and(|s| !s.sampled.intersects(BsdfFlags::DELTA));
            let wi = crate::sampling::square_to_uniform_sphere(rng.next_2d());
            smooth || b.pdf(m, &ctx, &si, wo, wi) > 0.0
        })
    }

    /// [`check_bsdf`] returning the failure instead of panicking.
    pub(crate) fn check_bsdf_result(m: &Materials, id: usize, wo: Vec3) -> Result<(), String> {
        check_bsdf_with(m, id, wo, &Chi2Config::default())
    }

    /// [`check_bsdf_result`] with a given test configuration.
    pub(crate) fn check_bsdf_with(
        m: &Materials,
        id: usize,
        wo: Vec3,
        cfg: &Chi2Config,
    ) -> Result<(), String> {
        let (b, si, ctx) = (m.bsdfs[id], flat_si(), BsdfContext::default());
        if !has_smooth_mass(m, id, wo) {
            return Ok(());
        }
        let mut bad_weight = None;
        chi2_directions(
            cfg,
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
        if let Some(msg) = bad_weight {
            return Err(msg);
        }
        check_eval_pdf(m, id, wo)
    }

    /// The fused [`BsdfModel::eval_pdf`] gives what `eval` and `pdf` give
    /// apart (to rounding: the models may multiply in another order), and
    /// the density is positive wherever the value is: MIS compensation
    /// leaves to BSDF sampling alone the directions light sampling skips.
    fn check_eval_pdf(m: &Materials, id: usize, wo: Vec3) -> Result<(), String> {
        let (b, si, ctx) = (m.bsdfs[id], flat_si(), BsdfContext::default());
        let mut rng = Pcg32::new(17, 3);
        let close = |a: f32, b: f32| (a - b).abs() <= 1e-5 * a.abs().max(b.abs()).max(1e-3);
        for _ in 0..500 {
            let wi = crate::sampling::square_to_uniform_sphere(rng.next_2d());
            let (f, pdf) = b.eval_pdf(m, &ctx, &si, wo, wi);
            let (f_apart, pdf_apart) = (b.eval(m, &ctx, &si, wo, wi), b.pdf(m, &ctx, &si, wo, wi));
            let same_f = (0..3).all(|c| close(f[c], f_apart[c]));
            if !same_f || !close(pdf, pdf_apart) {
                return Err(format!(
                    "eval_pdf gives ({f}, {pdf}), eval and pdf ({f_apart}, {pdf_apart}) at wo {wo}, wi {wi}"
                ));
            }
            // (Denormal values are underflow, where the density underflows too.)
            if f.max_element() >= f32::MIN_POSITIVE && (pdf.is_nan() || pdf <= 0.0) {
                return Err(format!(
                    "eval is {f} where sampling never goes (pdf {pdf}) at wo {wo}, wi {wi}"
                ));
            }
        }
        Ok(())
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

    /// Albedo (∫ f cos dωi) estimated by sampling, for energy checks. In
    /// Importance mode: the 1/η² by which refraction scales *radiance* is a
    /// change of solid-angle density, not a gain or loss of energy, and
    /// would make a lossless dielectric's albedo R + T/η² (above one from
    /// inside glass); importance weights sum to R + T.
    pub(crate) fn albedo(m: &Materials, id: usize, wo: Vec3) -> Rgb {
        let (b, si) = (m.bsdfs[id], flat_si());
        let ctx = BsdfContext {
            mode: TransportMode::Importance,
            ..BsdfContext::default()
        };
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

    /// The part of [`albedo`] carried by null samples (the path continues
    /// straight on, keeping the previous vertex's density for MIS), and
    /// what shadow rays get through the surface ([`Material::pass_through`]),
    /// for light arriving along `-wo`. Light sampling reaches what null
    /// samples reach only if the two agree.
    /// With `slabs`, as `volpath` asks ([`BsdfContext::null_slabs`],
    /// [`Material::null_transmission`]).
    pub(crate) fn null_part(m: &Materials, id: usize, wo: Vec3, slabs: bool) -> (Rgb, Rgb) {
        let b = m.bsdfs[id];
        let si = SurfaceInteraction { wo, ..flat_si() };
        let ctx = BsdfContext {
            mode: TransportMode::Importance,
            null_slabs: slabs,
        };
        let mut rng = Pcg32::new(7, 7);
        let n = 100_000;
        let sum: glam::DVec3 = (0..n)
            .filter_map(|_| {
                let u1 = rng.next_f32();
                b.sample(m, &ctx, &si, wo, u1, rng.next_2d())
            })
            .filter(|s| s.sampled == BsdfFlags::NULL)
            .map(|s| s.weight.as_dvec3())
            .sum();
        let pass = if slabs {
            b.null_transmission(m, &si, true)
        } else {
            Rgb::splat(b.pass_through(m, &si))
        };
        ((sum / n as f64).as_vec3(), pass)
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
        /// f(wo, wi) = f(wi, wo) is expected of its reflection. Not of
        /// models that replace the shading normal, which breaks
        /// reciprocity (Veach 1996, "Non-symmetric scattering in light
        /// transport algorithms").
        pub reciprocal: bool,
        /// Albedo at most one is expected. Not of models that add a
        /// diffuse and a specular lobe without coupling them (Burley's
        /// principled BSDF: Fresnel-darkened diffuse plus retro-reflection
        /// plus specular exceeds one at grazing angles).
        pub energy_conserving: bool,
    }

    impl Variant {
        /// A variant whose BSDF is the last entry of `bsdfs`.
        pub(crate) fn last(name: impl Into<String>, bsdfs: Vec<Material>) -> Self {
            let id = bsdfs.len() - 1;
            Self {
                name: name.into(),
                m: Materials::with_bsdfs(bsdfs),
                id,
                lossless: false,
                reciprocal: true,
                energy_conserving: true,
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
    /// are collected and reported together.
    /// Every variant of every BSDF family.
    fn all_variants() -> Vec<Variant> {
        [
            diffuse::tests::test_variants(),
            twosided::tests::test_variants(),
            plastic::tests::test_variants(),
            rough_plastic::tests::test_variants(),
            null::tests::test_variants(),
            mask::tests::test_variants(),
            blend_bsdf::tests::test_variants(),
            bump_map::tests::test_variants(),
            normal_map::tests::test_variants(),
            dielectric::tests::test_variants(),
            thin_dielectric::tests::test_variants(),
            rough_dielectric::tests::test_variants(),
            conductor::tests::test_variants(),
            rough_conductor::tests::test_variants(),
            principled::tests::test_variants(),
            principled_thin::tests::test_variants(),
            rough_diffuse::tests::test_variants(),
            phong::tests::test_variants(),
            difftrans::tests::test_variants(),
            measured::tests::test_variants(),
            hair::tests::test_variants(),
            value::tests::test_variants(),
        ]
        .into_iter()
        .flatten()
        .collect()
    }

    /// The BSDFs that say they turn freely about the normal
    /// ([`Material::turns_freely`]) give the same values and densities for
    /// directions turned about it, and some of the others do not (so the
    /// check can tell).
    #[test]
    fn bsdfs_that_turn_freely_ignore_the_tangent() {
        let si = flat_si();
        let ctx = BsdfContext::default();
        let pairs = [
            (Vec3::new(0.3, 0.2, 0.9), Vec3::new(-0.5, 0.4, 0.6)),
            (Vec3::new(-0.6, 0.3, 0.5), Vec3::new(0.1, -0.7, 0.4)),
            (Vec3::new(0.8, -0.1, 0.3), Vec3::new(0.6, 0.3, -0.5)),
        ];
        let (mut free, mut varying) = (0, 0);
        for v in all_variants() {
            let b = v.m.bsdfs[v.id];
            let mut turns = true;
            for (wo, wi) in pairs {
                let (wo, wi) = (wo.normalize(), wi.normalize());
                let f = b.eval(&v.m, &ctx, &si, wo, wi);
                let pdf = b.pdf(&v.m, &ctx, &si, wo, wi);
                for angle in [0.7f32, 2.1, 4.0] {
                    let r = glam::Mat3::from_rotation_z(angle);
                    let (f_r, pdf_r) = (
                        b.eval(&v.m, &ctx, &si, r * wo, r * wi),
                        b.pdf(&v.m, &ctx, &si, r * wo, r * wi),
                    );
                    let close =
                        |a: f32, b: f32| (a - b).abs() <= 1e-3 * a.abs().max(b.abs()) + 1e-6;
                    turns &= (0..3).all(|c| close(f[c], f_r[c])) && close(pdf, pdf_r);
                }
            }
            if b.turns_freely(&v.m) {
                assert!(
                    turns,
                    "{} says it turns freely but depends on the tangent",
                    v.name
                );
                free += 1;
            } else if !turns {
                varying += 1;
            }
        }
        assert!(free > 10 && varying > 2, "{free} free, {varying} varying");
    }

    #[test]
    fn every_bsdf_variant() {
        let variants = all_variants();
        // Hundreds of chi-square tests run here: Šidák's correction keeps
        // the chance that any of them rejects a correct sampler at 1 %.
        let tests = variants
            .iter()
            .filter(|v| v.m.bsdfs[v.id].flags(&v.m).intersects(BsdfFlags::SMOOTH))
            .count()
            * test_directions().len();
        let chi2 = Chi2Config {
            alpha: 1.0 - 0.99f64.powf(1.0 / tests as f64),
            ..Chi2Config::default()
        };
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
                    if let Err(e) = check_bsdf_with(&v.m, v.id, wo, &chi2) {
                        failures.push(format!("{} wo={wo}: chi-square: {e}", v.name));
                    }
                }
                if v.energy_conserving && a.max_element() > 1.0 + 0.01 {
                    failures.push(format!("{} wo={wo}: albedo {a} > 1", v.name));
                }
                if v.lossless && (a - Rgb::ONE).abs().max_element() > 0.01 {
                    failures.push(format!("{} wo={wo}: lossless but albedo {a}", v.name));
                }
                for slabs in [false, true] {
                    let (null, pass) = null_part(&v.m, v.id, wo, slabs);
                    if (null - pass).abs().max_element() > 0.01 {
                        failures.push(format!(
                            "{} wo={wo} (slabs {slabs}): null samples carry {null}, \
                             shadow rays pass {pass}",
                            v.name
                        ));
                    }
                }
            }
            if !v.reciprocal {
                continue;
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
        println!("{} BSDF variants passed", variants.len());
    }
}
