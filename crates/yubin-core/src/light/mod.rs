//! Emitters: the contract every light implements and the closed enum the
//! scene stores.
//!
//! Conventions: [`EmitterModel::sample_direction`] picks a point on (or a
//! direction to) the light as seen from a reference point and returns the
//! incident radiance *unweighted* together with the solid-angle density
//! (1 for delta lights, flagged by `is_delta`). [`EmitterModel::pdf_direction`]
//! returns the same density for a point found by tracing a ray, so that
//! integrators can weight both strategies with MIS.
//!
//! Emitters at infinity ([`Emitter::is_environment`]) also give the
//! radiance of rays that escape the scene ([`Emitter::environment_radiance`]).
//! Scene front ends build emitters through [`PLUGINS`]; the scene's build
//! fits them to its data ([`prepare_emitters`]). An emitter that samples
//! by a table (an `envmap`'s or `preetham`'s sampling distribution, which
//! depends on the integrator's MIS compensation) gets it when a render
//! starts: the render's copy of the emitter refers to it by index
//! ([`build_distributions`]).

mod area;
pub mod bvh;
mod constant;
mod directional;
mod directional_area;
mod emission;
mod envmap;
mod latlong;
mod point;
mod preetham;
mod projector;
pub mod selection;
pub mod sky_sampling;
mod spot;
mod sunsky;
mod timed_sunsky;

pub use area::AreaLight;
pub use constant::ConstantLight;
pub use directional::DirectionalLight;
pub use directional_area::DirectionalAreaLight;
pub use emission::{EmissionSample, SceneSphere};
pub use envmap::EnvMapLight;
pub use point::PointLight;
pub use preetham::PreethamLight;
pub use projector::ProjectorLight;
pub use selection::{EmitterOptions, LightChoice, LightSampler, LightSelection};
pub use spot::SpotLight;
pub use sunsky::SunskyLight;
pub use timed_sunsky::TimedSunskyLight;

use crate::interaction::SurfaceInteraction;
use crate::params::{ParamError, Params};
use crate::sampling::Distribution2D;
use crate::shape::{Shape, ShapeModel, TriangleMesh};
use crate::texture::TexImage;
use crate::Rgb;
use glam::{Vec2, Vec3};

/// What an emitter needs to know about the scene: shapes for area lights,
/// images and sampling distributions for environment maps.
#[derive(Clone, Copy, Debug)]
pub struct EmitterContext<'a> {
    /// The scene's shapes.
    pub shapes: &'a [Shape],
    /// The scene's meshes.
    pub meshes: &'a [TriangleMesh],
    /// The scene's images ([`crate::material::Materials::images`]).
    pub images: &'a [TexImage],
    /// The scene's materials, for textured emission.
    pub materials: &'a crate::material::Materials,
    /// Sampling distributions of emitters, which the render's state holds
    /// ([`build_distributions`]).
    pub distributions: &'a [Distribution2D],
    /// The camera sample's time (what emitters that change with time
    /// show).
    pub time: f32,
}

impl EmitterContext<'static> {
    /// A context of an empty scene (for tests of lights that need none).
    pub const EMPTY: Self = Self {
        shapes: &[],
        meshes: &[],
        images: &[],
        materials: &crate::material::Materials::EMPTY,
        distributions: &[],
        time: 0.0,
    };
}

/// A light sample seen from a reference point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmitterSample {
    /// Unit direction from the reference point towards the light.
    pub wi: Vec3,
    /// Distance to the sampled point (infinite for lights at infinity).
    pub dist: f32,
    /// Solid-angle density (1 for delta lights).
    pub pdf: f32,
    /// Incident radiance along `wi` (for point lights, I/d²; not divided
    /// by `pdf`).
    pub radiance: Rgb,
    /// The light is a delta distribution (no MIS with BSDF sampling).
    pub is_delta: bool,
}

/// The contract of every emitter.
pub trait EmitterModel {
    /// Samples the light from `ref_p`; `None` when nothing can be sampled.
    fn sample_direction(&self, ctx: &EmitterContext, ref_p: Vec3, u: Vec2)
        -> Option<EmitterSample>;
    /// Density of sampling the surface point `p` (normal `n`) or, for
    /// lights at infinity, the direction `wi`, from `ref_p`.
    fn pdf_direction(&self, ctx: &EmitterContext, ref_p: Vec3, p: Vec3, n: Vec3, wi: Vec3) -> f32;
    /// True for point and directional lights.
    fn is_delta(&self) -> bool;
}

/// An emitter (closed enum; see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Emitter {
    /// `area`.
    Area(AreaLight),
    /// `point`.
    Point(PointLight),
    /// `directional`.
    Directional(DirectionalLight),
    /// `constant`.
    Constant(ConstantLight),
    /// `envmap`.
    EnvMap(EnvMapLight),
    /// `spot`.
    Spot(SpotLight),
    /// `preetham`.
    Preetham(PreethamLight),
    /// `projector`.
    Projector(ProjectorLight),
    /// `directionalarea`.
    DirectionalArea(DirectionalAreaLight),
    /// `sunsky`.
    Sunsky(SunskyLight),
    /// `timed_sunsky`.
    TimedSunsky(TimedSunskyLight),
}

/// Builds an emitter plugin from its parameters.
pub type EmitterFromParams = fn(&mut dyn Params) -> Result<Emitter, ParamError>;

/// Every emitter plugin built from parameters alone: its scene type string
/// and constructor. (`area` belongs to a shape and is added with it.)
pub const PLUGINS: &[(&str, EmitterFromParams)] = &[
    ("point", |p| Ok(Emitter::Point(PointLight::from_params(p)?))),
    ("directional", |p| {
        Ok(Emitter::Directional(DirectionalLight::from_params(p)?))
    }),
    ("constant", |p| {
        Ok(Emitter::Constant(ConstantLight::from_params(p)?))
    }),
    ("envmap", |p| {
        Ok(Emitter::EnvMap(EnvMapLight::from_params(p)?))
    }),
    ("spot", |p| Ok(Emitter::Spot(SpotLight::from_params(p)?))),
    ("preetham", |p| {
        Ok(Emitter::Preetham(PreethamLight::from_params(p)?))
    }),
    ("projector", |p| {
        Ok(Emitter::Projector(ProjectorLight::from_params(p)?))
    }),
    ("sunsky", |p| {
        Ok(Emitter::Sunsky(SunskyLight::from_params(p)?))
    }),
    ("timed_sunsky", |p| {
        Ok(Emitter::TimedSunsky(TimedSunskyLight::from_params(p)?))
    }),
];

/// What a texture needs of a point an emitter looks up: position, normal
/// and uv (no triangle, so no mesh attributes).
pub(crate) fn uv_interaction(p: Vec3, n: Vec3, uv: Vec2) -> SurfaceInteraction {
    // As if hit from straight in front, at distance 0.
    crate::shape::make_interaction(
        &crate::math::Ray::new(p + n, -n),
        0.0,
        p,
        n,
        uv,
        Vec3::ZERO,
        Vec3::ZERO,
    )
}

/// The light sample of a source at the single point `position` whose
/// intensity towards the unit direction d is `intensity(d)`: I / dist²,
/// density 1, delta; `None` when it sends nothing towards `ref_p`.
pub(crate) fn point_source_sample(
    position: Vec3,
    ref_p: Vec3,
    intensity: impl FnOnce(Vec3) -> Rgb,
) -> Option<EmitterSample> {
    let delta = position - ref_p;
    let dist2 = delta.length_squared();
    if dist2 == 0.0 {
        return None;
    }
    let dist = dist2.sqrt();
    let wi = delta / dist;
    let i = intensity(-wi);
    if i == Rgb::ZERO {
        return None;
    }
    Some(EmitterSample {
        wi,
        dist,
        pdf: 1.0,
        radiance: i / dist2,
        is_delta: true,
    })
}

/// The mean of an emission texture for light selection: a constant's
/// largest channel (as [`Emitter::power`] counts), a texture's mean.
pub(crate) fn power_mean(t: crate::texture::Tex, m: &crate::material::Materials) -> f32 {
    match t.as_const() {
        Some(c) => c.max_element(),
        None => t.mean(m),
    }
}

/// Fits projectors to their image's aspect ratio and checks that every
/// `envmap`'s image is in the image table; `SceneBuilder::build` calls it.
/// Fails with the index of an image that is not in `materials.images`.
pub fn prepare_emitters(
    emitters: &mut [Emitter],
    materials: &crate::material::Materials,
) -> Result<(), u32> {
    for e in emitters.iter_mut() {
        if let Emitter::Projector(l) = e {
            l.fit_image_plane(materials);
        }
        if let Emitter::EnvMap(env) = e {
            materials.images.get(env.image as usize).ok_or(env.image)?;
        }
    }
    Ok(())
}

/// Builds the sampling distributions that emitters read from a render's
/// state (`render::RenderState`, made when a render starts) and points
/// each of `emitters` (the render's copies of the scene's, which
/// [`prepare_emitters`] checked) at its own. `compensated[i]`: emitter `i`
/// may leave to BSDF sampling what it finds well (an `envmap` that does
/// not turn that off, and `preetham`'s sky, then sample their excess over
/// their mean). An emitter that changes with time samples what it shows
/// on average while the sensor's `shutter` is open.
pub fn build_distributions(
    emitters: &mut [Emitter],
    materials: &crate::material::Materials,
    compensated: &[bool],
    shutter: crate::camera::Shutter,
) -> Vec<Distribution2D> {
    let images = &materials.images;
    let mut distributions = Vec::new();
    for (i, e) in emitters.iter_mut().enumerate() {
        let allowed = compensated.get(i).copied().unwrap_or(false);
        if let Emitter::EnvMap(env) = e {
            // Checked when the scene was built (`prepare_emitters`).
            let image = &images[env.image as usize];
            // The map's own `false` turns it off; it is never on where the
            // render's integrator or the map's visibility does not allow it.
            env.mis_compensation = Some(allowed && env.mis_compensation != Some(false));
            env.distribution = distributions.len() as u32;
            distributions.push(env.sampling_distribution(image));
        }
        if let Emitter::Preetham(sky) = e {
            sky.distribution = distributions.len() as u32;
            distributions.push(sky.sampling_distribution(allowed));
        }
        if let Emitter::Sunsky(sky) = e {
            sky.distribution = distributions.len() as u32;
            distributions.push(sky.sampling_distribution(allowed));
        }
        if let Emitter::TimedSunsky(sky) = e {
            let table = sky.sampling_distribution(allowed, shutter);
            sky.set_distribution(distributions.len() as u32);
            distributions.push(table);
        }
    }
    distributions
}

macro_rules! dispatch {
    ($self:expr, $l:ident => $e:expr) => {
        match $self {
            Emitter::Area($l) => $e,
            Emitter::Point($l) => $e,
            Emitter::Directional($l) => $e,
            Emitter::Constant($l) => $e,
            Emitter::EnvMap($l) => $e,
            Emitter::Spot($l) => $e,
            Emitter::Preetham($l) => $e,
            Emitter::Projector($l) => $e,
            Emitter::DirectionalArea($l) => $e,
            Emitter::Sunsky($l) => $e,
            Emitter::TimedSunsky($l) => $e,
        }
    };
}

impl EmitterModel for Emitter {
    #[inline]
    fn sample_direction(
        &self,
        ctx: &EmitterContext,
        ref_p: Vec3,
        u: Vec2,
    ) -> Option<EmitterSample> {
        dispatch!(self, l => l.sample_direction(ctx, ref_p, u))
    }
    #[inline]
    fn pdf_direction(&self, ctx: &EmitterContext, ref_p: Vec3, p: Vec3, n: Vec3, wi: Vec3) -> f32 {
        dispatch!(self, l => l.pdf_direction(ctx, ref_p, p, n, wi))
    }
    #[inline]
    fn is_delta(&self) -> bool {
        dispatch!(self, l => l.is_delta())
    }
}

impl Emitter {
    /// Radiance leaving the emitting surface hit at `si` towards `si.wo`.
    /// Zero for non-surface lights.
    #[inline]
    pub fn surface_radiance(&self, m: &crate::material::Materials, si: &SurfaceInteraction) -> Rgb {
        match self {
            Emitter::Area(a) if si.sh_frame.n.dot(si.wo) > 0.0 => a.radiance.eval(m, si),
            _ => Rgb::ZERO,
        }
    }

    /// Radiance arriving along a ray with direction `d` that escaped the
    /// scene. Zero for lights that are not at infinity or are delta.
    #[inline]
    pub fn environment_radiance(&self, ctx: &EmitterContext, d: Vec3) -> Rgb {
        match self {
            Emitter::Constant(c) => c.radiance,
            Emitter::EnvMap(m) => m.radiance(ctx, d),
            Emitter::Preetham(s) => s.radiance(d),
            Emitter::Sunsky(s) => s.radiance(d),
            Emitter::TimedSunsky(s) => s.at(ctx.time).radiance(d),
            _ => Rgb::ZERO,
        }
    }

    /// [`Emitter::environment_radiance`] along `d` together with the
    /// density of light sampling it from `ref_p` (`pdf_direction`): one
    /// map lookup for both where the light is an environment map.
    #[inline]
    pub fn environment_radiance_and_pdf(
        &self,
        ctx: &EmitterContext,
        ref_p: Vec3,
        d: Vec3,
    ) -> (Rgb, f32) {
        match self {
            Emitter::EnvMap(m) => m.radiance_and_pdf(ctx, d),
            _ => (
                self.environment_radiance(ctx, d),
                self.pdf_direction(ctx, ref_p, ref_p + d, -d, d),
            ),
        }
    }

    /// Emitted power (its largest RGB channel: a light bright in one
    /// channel only is not rare there), for light selection; lights at infinity
    /// count what crosses a disk of the scene's bounding radius `radius`
    /// (pbrt-v4's convention).
    pub fn power(&self, ctx: &EmitterContext, radius: f32) -> f32 {
        use std::f32::consts::PI;
        let disk = PI * radius * radius;
        match self {
            Emitter::Area(a) => {
                let area = ctx.shapes[a.shape as usize].surface_area(ctx.meshes);
                PI * area * power_mean(a.radiance, ctx.materials)
            }
            Emitter::Point(p) => 4.0 * PI * p.intensity.max_element(),
            Emitter::Spot(s) => s.power(ctx),
            Emitter::Projector(l) => l.power(ctx),
            Emitter::DirectionalArea(a) => {
                let area = ctx.shapes[a.shape as usize].surface_area(ctx.meshes);
                area * power_mean(a.radiance, ctx.materials)
            }
            Emitter::Directional(d) => disk * d.irradiance.max_element(),
            Emitter::Constant(_) | Emitter::EnvMap(_) => disk * self.environment_integral(ctx),
            // The grid would miss the sun's disk: it is added in closed form.
            Emitter::Preetham(s) => {
                let sun = s.sun_radiance.max_element() * 2.0 * PI * (1.0 - s.cos_sun_radius);
                disk * (self.environment_integral(ctx) + sun)
            }
            Emitter::Sunsky(s) => {
                disk * (self.environment_integral(ctx) + s.sun_power_for_selection())
            }
            Emitter::TimedSunsky(s) => disk * s.mean_power(),
        }
    }

    /// ∫ max(L(ω)) dω (largest channel) over the sphere of an emitter at infinity, by
    /// the midpoint rule on an equal-area grid in (cos θ, φ).
    fn environment_integral(&self, ctx: &EmitterContext) -> f32 {
        const N_THETA: usize = 64;
        const N_PHI: usize = 128;
        let mut sum = 0.0f64;
        for i in 0..N_THETA {
            let cos_theta = 1.0 - 2.0 * (i as f32 + 0.5) / N_THETA as f32;
            let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
            for j in 0..N_PHI {
                let phi = 2.0 * std::f32::consts::PI * (j as f32 + 0.5) / N_PHI as f32;
                let d = Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta);
                sum += self.environment_radiance(ctx, d).max_element() as f64;
            }
        }
        (sum * 4.0 * std::f64::consts::PI / (N_THETA * N_PHI) as f64) as f32
    }

    /// True for lights that surround the scene (hit by escaping rays).
    pub fn is_environment(&self) -> bool {
        matches!(
            self,
            Emitter::Constant(_)
                | Emitter::EnvMap(_)
                | Emitter::Preetham(_)
                | Emitter::Sunsky(_)
                | Emitter::TimedSunsky(_)
        )
    }

    /// True for lights that show something else at another time of the
    /// shutter (`timed_sunsky`).
    pub fn changes_with_time(&self) -> bool {
        matches!(self, Emitter::TimedSunsky(_))
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::material::Materials;
    use crate::testing::chi2::{chi2_directions, Chi2Config};

    /// One configuration of an emitter for the table-driven test, with the
    /// scene data it reads.
    pub(crate) struct Variant {
        /// What is being tested, for messages.
        pub name: String,
        /// The emitter under test.
        pub emitter: Emitter,
        /// Shapes (an area light's).
        pub shapes: Vec<Shape>,
        /// Meshes of those shapes.
        pub meshes: Vec<TriangleMesh>,
        /// Textures and images it reads.
        pub materials: Materials,
        /// Points it is sampled from.
        pub refs: Vec<Vec3>,
        /// Points that see only its back: it gives them no samples.
        pub dark_refs: Vec<Vec3>,
        /// Settings of its direction chi-square tests (the table sets the
        /// significance level).
        pub chi2: Chi2Config,
        /// Density of the directions of the rays it emits, where that does
        /// not depend on where a ray starts (given the emitter as the
        /// scene built it).
        pub emission_pdf: Option<fn(&Emitter, Vec3) -> f32>,
        /// Its [`Emitter::power`] is exact (not a quadrature over an
        /// environment), so the mean emission weight must equal it.
        pub exact_power: bool,
        /// The sensor's shutter its sampling tables are made for.
        pub shutter: crate::camera::Shutter,
        /// The time it is sampled at.
        pub time: f32,
    }

    impl Variant {
        /// A variant of a light that needs no scene data, sampled from one
        /// point off the origin.
        pub(crate) fn new(name: impl Into<String>, emitter: Emitter) -> Self {
            Self {
                name: name.into(),
                emitter,
                shapes: Vec::new(),
                meshes: Vec::new(),
                materials: Materials::default(),
                refs: vec![Vec3::new(0.3, -0.2, 0.1)],
                dark_refs: Vec::new(),
                chi2: Chi2Config::default(),
                emission_pdf: None,
                exact_power: true,
                shutter: crate::camera::Shutter::INSTANT,
                time: 0.0,
            }
        }

        /// An area light on `shape`, sampled from `refs`.
        pub(crate) fn area(
            name: impl Into<String>,
            shape: Shape,
            meshes: Vec<TriangleMesh>,
            refs: Vec<Vec3>,
        ) -> Self {
            Self {
                shapes: vec![shape],
                meshes,
                refs,
                // Shapes have sharp silhouettes: integrate the pdf finely.
                chi2: Chi2Config {
                    integration_res: 24,
                    ..Chi2Config::default()
                },
                ..Self::new(
                    name,
                    Emitter::Area(AreaLight {
                        shape: 0,
                        radiance: crate::texture::Tex::Const(Rgb::new(1.0, 2.0, 0.5)),
                    }),
                )
            }
        }

        /// A light at infinity, sampled from the origin; its density steps
        /// inside bins, so it is integrated finely.
        pub(crate) fn environment(name: impl Into<String>, emitter: Emitter) -> Self {
            Self {
                refs: vec![Vec3::ZERO],
                chi2: Chi2Config {
                    cos_theta_bins: 30,
                    phi_bins: 60,
                    samples: 400_000,
                    integration_res: 32,
                    ..Chi2Config::default()
                },
                exact_power: false,
                ..Self::new(name, emitter)
            }
        }

        fn context<'a>(&'a self, distributions: &'a [Distribution2D]) -> EmitterContext<'a> {
            EmitterContext {
                shapes: &self.shapes,
                meshes: &self.meshes,
                images: &self.materials.images,
                materials: &self.materials,
                distributions,
                time: self.time,
            }
        }

        /// What a ray from `ref_p` along `wi` finds of the light: its
        /// radiance and the density `pdf_direction` gives it (zero for
        /// both where it misses the light or sees its back).
        fn seen_along(&self, ctx: &EmitterContext, ref_p: Vec3, wi: Vec3) -> (Rgb, f32) {
            if self.emitter.is_environment() {
                let pdf = self
                    .emitter
                    .pdf_direction(ctx, ref_p, Vec3::ZERO, Vec3::Z, wi);
                return (self.emitter.environment_radiance(ctx, wi), pdf);
            }
            let ray = crate::math::Ray::new(ref_p, wi);
            let mut closest: Option<SurfaceInteraction> = None;
            for shape in &self.shapes {
                let mut r = ray;
                if let Some(t) = closest.as_ref().map(|si| si.t) {
                    r.t_max = t;
                }
                if let Some(si) = crate::shape::tests::closest_hit(shape, &self.meshes, &r) {
                    closest = Some(si);
                }
            }
            match closest {
                Some(si) if si.n.dot(wi) < 0.0 => (
                    self.emitter.surface_radiance(ctx.materials, &si),
                    self.emitter.pdf_direction(ctx, ref_p, si.p, si.n, wi),
                ),
                _ => (Rgb::ZERO, 0.0),
            }
        }
    }

    /// Where rays from lights at infinity start in the emission test.
    const SPHERE: SceneSphere = SceneSphere {
        center: Vec3::ZERO,
        radius: 5.0,
    };

    /// The table-driven test: every variant of every emitter. Lights that
    /// are not deltas: the chi-square test of `sample_direction` against
    /// `pdf_direction` from each reference point, and samples carry the
    /// radiance and density a traced ray finds. Delta lights: their
    /// samples say so. Every light: the rays it emits carry on average
    /// its power, and follow their direction density where it has one
    /// (chi-square). All failures are collected and reported together.
    #[test]
    fn every_emitter_variant() {
        let mut variants: Vec<Variant> = [
            area::tests::test_variants(),
            directional_area::tests::test_variants(),
            point::tests::test_variants(),
            spot::tests::test_variants(),
            projector::tests::test_variants(),
            directional::tests::test_variants(),
            constant::tests::test_variants(),
            envmap::tests::test_variants(),
            preetham::tests::test_variants(),
            sunsky::tests::test_variants(),
            timed_sunsky::tests::test_variants(),
        ]
        .into_iter()
        .flatten()
        .collect();
        let distributions: Vec<Vec<Distribution2D>> = variants
            .iter_mut()
            .map(|v| {
                let emitters = std::slice::from_mut(&mut v.emitter);
                prepare_emitters(emitters, &v.materials).unwrap();
                build_distributions(emitters, &v.materials, &[true], v.shutter)
            })
            .collect();
        // Šidák's correction keeps the chance that any of the chi-square
        // tests rejects a correct sampler at 1 %.
        let tests: usize = variants
            .iter()
            .map(|v| {
                usize::from(v.emission_pdf.is_some())
                    + if v.emitter.is_delta() {
                        0
                    } else {
                        v.refs.len()
                    }
            })
            .sum();
        let alpha = 1.0 - 0.99f64.powf(1.0 / tests as f64);
        let mut failures = Vec::new();
        for (v, dists) in variants.iter().zip(&distributions) {
            let ctx = v.context(dists);
            let cfg = Chi2Config { alpha, ..v.chi2 };
            for &ref_p in &v.refs {
                let result = if v.emitter.is_delta() {
                    check_delta_samples(v, &ctx, ref_p)
                } else {
                    check_direction_samples(v, &ctx, ref_p, &cfg)
                };
                if let Err(e) = result {
                    failures.push(format!("{} from {ref_p}: {e}", v.name));
                }
            }
            for &ref_p in &v.dark_refs {
                let mut rng = crate::sampler::Pcg32::new(1, 1);
                if (0..1000).any(|_| {
                    v.emitter
                        .sample_direction(&ctx, ref_p, rng.next_2d())
                        .is_some()
                }) {
                    failures.push(format!(
                        "{}: {ref_p} sees its back but gets samples",
                        v.name
                    ));
                }
            }
            if let Err(e) = check_emission(v, &ctx, &cfg) {
                failures.push(format!("{}: emission: {e}", v.name));
            }
        }
        assert!(
            failures.is_empty(),
            "{} of {} emitter variants fail:\n{}",
            failures.len(),
            variants.len(),
            failures.join("\n")
        );
    }

    fn check_delta_samples(v: &Variant, ctx: &EmitterContext, ref_p: Vec3) -> Result<(), String> {
        let mut rng = crate::sampler::Pcg32::new(5, 1);
        for _ in 0..64 {
            if let Some(s) = v.emitter.sample_direction(ctx, ref_p, rng.next_2d()) {
                if !(s.is_delta && s.pdf == 1.0 && s.radiance.min_element() >= 0.0) {
                    return Err(format!("delta light gave {s:?}"));
                }
            }
        }
        Ok(())
    }

    fn check_direction_samples(
        v: &Variant,
        ctx: &EmitterContext,
        ref_p: Vec3,
        cfg: &Chi2Config,
    ) -> Result<(), String> {
        chi2_directions(
            cfg,
            |r| {
                v.emitter
                    .sample_direction(ctx, ref_p, r.next_2d())
                    .map(|s| (s.wi, s.pdf))
            },
            |wi| v.seen_along(ctx, ref_p, wi).1,
        )?;
        let mut rng = crate::sampler::Pcg32::new(9, 2);
        for _ in 0..2000 {
            let Some(s) = v.emitter.sample_direction(ctx, ref_p, rng.next_2d()) else {
                continue;
            };
            if s.is_delta {
                return Err("a delta sample from a light that is not delta".into());
            }
            let (radiance, _) = v.seen_along(ctx, ref_p, s.wi);
            if (radiance - s.radiance).abs().max_element() > 1e-3 * radiance.max_element().max(1.0)
            {
                return Err(format!(
                    "sample along {} carries {} but a ray finds {radiance}",
                    s.wi, s.radiance
                ));
            }
        }
        Ok(())
    }

    /// Rays the light emits: their mean weight is its power (within five
    /// standard errors, where the power is exact), and their directions
    /// follow `emission_pdf`.
    fn check_emission(v: &Variant, ctx: &EmitterContext, cfg: &Chi2Config) -> Result<(), String> {
        let mut rng = crate::sampler::Pcg32::new(3, 4);
        let n = 200_000;
        let (mut sum, mut sum2) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
        for _ in 0..n {
            if let Some(s) = v
                .emitter
                .sample_emission(ctx, SPHERE, rng.next_2d(), rng.next_2d())
            {
                if (s.ray.d.length() - 1.0).abs() > 1e-4 {
                    return Err(format!("direction {} is not a unit vector", s.ray.d));
                }
                let w = s.weight.as_dvec3();
                sum += w;
                sum2 += w * w;
            }
        }
        if v.exact_power {
            let mean = sum / n as f64;
            let std_error = ((sum2 / n as f64 - mean * mean) / n as f64)
                .max(glam::DVec3::ZERO)
                .powf(0.5);
            let channel = mean.max_position();
            let power = v.emitter.power(ctx, SPHERE.radius) as f64;
            if (mean[channel] - power).abs() > 5.0 * std_error[channel] + 1e-3 * power {
                return Err(format!(
                    "mean weight {mean} (± {std_error}) but power {power}"
                ));
            }
        }
        if let Some(pdf) = v.emission_pdf {
            // The weights are checked above; the draw claims no density.
            chi2_directions(
                cfg,
                |r| {
                    v.emitter
                        .sample_emission(ctx, SPHERE, r.next_2d(), r.next_2d())
                        .map(|s| (s.ray.d, f32::NAN))
                },
                |d| pdf(&v.emitter, d),
            )?;
        }
        Ok(())
    }
}
