//! Participating media (closed enum): `homogeneous` and `heterogeneous`,
//! one plugin per file, with the sampling routines the volumetric
//! integrator (`volpath`) is built from.
//!
//! A medium fills the inside or outside of shapes that name it
//! (`interior`, `exterior`) or surrounds the sensor; rays carry the medium
//! they travel in. Its extinction σ_t and albedo come from volumes
//! ([`crate::volume`]); its phase function from [`crate::phase`].
//!
//! - Chromatic media (σ_t differing between channels) are sampled by
//!   spectral MIS over whole paths (Miller et al. 2019, "A null-scattering
//!   path integral formulation of light transport", §5; pbrt-v4's
//!   `VolPathIntegrator`): a path picks a *hero* channel once, samples
//!   every free flight by it, and carries, besides its throughput
//!   f / p_hero, the ratios p_c / p_hero of the densities the other
//!   channels would have given it; a contribution is divided by their
//!   mean, so it is weighted by the balance heuristic over channels and
//!   stays bounded however many times the path scatters.
//! - [`HomogeneousCoefficients::sample_distance`]: exact free flights.
//! - [`Grid`]: voxel grids (Mitsuba's `.vol` data), trilinear lookup.
//! - [`MajorantGrid`]: per-cell majorants of a grid, walked by a DDA.
//! - [`Pyroclastic`]: seed 003's pyroclastic cloud density.
//! - [`ratio_tracking`]: unbiased transmittance through any medium below a
//!   majorant (Novák et al. 2014, "Residual ratio tracking for estimating
//!   attenuation in participating media").

mod grid;
mod heterogeneous;
mod homogeneous;
mod majorant;
mod pyroclastic;
mod tracking;

pub use grid::{Grid, GridError};
pub use majorant::MajorantGrid;
pub use pyroclastic::Pyroclastic;
pub use tracking::ratio_tracking;

use crate::math::{Bounds3, Transform};
use crate::params::{plugin_of, ColorKind, Family, ParamError, Params};
use crate::phase::PhaseFunction;
use crate::volume::{volume_param, Volume};
use crate::Rgb;
use glam::Vec3;
use std::sync::Arc;

/// Builds a medium plugin from its parameters.
pub type MediumFromParams = fn(&mut dyn Params) -> Result<Medium, ParamError>;

/// Every medium plugin: its scene type string and constructor.
pub const PLUGINS: &[(&str, MediumFromParams)] = &[
    ("homogeneous", homogeneous::from_params),
    ("heterogeneous", heterogeneous::from_params),
];

/// Builds the medium `p` describes, by its plugin type.
pub fn from_params(p: &mut dyn Params) -> Result<Medium, ParamError> {
    plugin_of(p, "medium", PLUGINS, None)?(p)
}

/// A participating medium.
// A scene holds a few media, looked up by index: boxing would only add an
// indirection.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum Medium {
    /// `homogeneous`.
    Homogeneous(Homogeneous),
    /// `heterogeneous`.
    Heterogeneous(Heterogeneous),
}

/// What every medium has besides its extinction.
#[derive(Clone, Debug, PartialEq)]
pub struct MediumCommon {
    /// Single-scattering albedo σ_s / σ_t.
    pub albedo: Volume,
    /// Multiplies the extinction.
    pub scale: f32,
    /// Emitted radiance per unit absorption, if the medium glows.
    pub radiance: Option<Volume>,
    /// The phase function.
    pub phase: PhaseFunction,
    /// Next-event estimation at scattering points.
    pub sample_emitters: bool,
}

/// A medium of constant extinction.
#[derive(Clone, Debug, PartialEq)]
pub struct Homogeneous {
    /// Extinction per unit length (scale applied).
    pub sigma_t: Rgb,
    /// Albedo, phase function, emission.
    pub common: MediumCommon,
}

/// A medium whose extinction is a volume.
#[derive(Clone, Debug, PartialEq)]
pub struct Heterogeneous {
    /// Extinction per unit length, before `common.scale`.
    pub sigma_t: Volume,
    /// Bounds of the scaled extinction along rays.
    pub majorants: Majorants,
    /// Albedo, phase function, emission.
    pub common: MediumCommon,
}

/// Upper bounds of a heterogeneous medium's extinction along a ray.
#[derive(Clone, Debug, PartialEq)]
pub enum Majorants {
    /// One bound, inside the volume's extent (everywhere when `None`).
    Uniform {
        /// The bound.
        value: f32,
        /// World → the volume's space, and its box there.
        extent: Option<(Transform, Bounds3)>,
    },
    /// Per-cell bounds of a grid volume.
    Grid {
        /// The cells.
        grid: Arc<MajorantGrid>,
        /// The grid's space → world.
        to_world: Transform,
        /// Multiplies the cells' values.
        scale: f32,
    },
}

/// How a free flight through a medium ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Flight {
    /// Distance travelled.
    pub t: f32,
    /// The flight ended in a real scattering event at `t` (otherwise it
    /// reached the end of the segment).
    pub scattered: bool,
    /// Radiance the medium emitted along the flight, as the path's
    /// estimate (throughput and channel ratios applied).
    pub emitted: Rgb,
}

/// A path's state through a medium: throughput f / p_hero and the channel
/// ratios p_c / p_hero (see the module docs), with the hero channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathWeight {
    /// Throughput f / p_hero.
    pub beta: Rgb,
    /// Density ratios p_c / p_hero (1 in the hero channel).
    pub ratio: Rgb,
    /// For `volpathmis`: the densities with which light sampling from the
    /// last scattering vertex would reach here, per channel, relative to
    /// p_hero and before the light's own density (pbrt-v4's r_l): set to
    /// `ratio` / the direction's density at each scattering event, then
    /// divided by what the path's own sampling adds that light sampling
    /// does not (the hero's probability of passing a homogeneous segment,
    /// null collisions' σ_n,h / μ, null lobes' probabilities).
    pub ratio_light: Rgb,
    /// The channel that samples distances (0, 1 or 2).
    pub hero: usize,
}

impl PathWeight {
    /// A path starting with throughput 1 and hero channel `hero`.
    pub fn new(hero: usize) -> Self {
        Self {
            beta: Rgb::ONE,
            ratio: Rgb::ONE,
            ratio_light: Rgb::ONE,
            hero,
        }
    }

    /// The path's estimate of what arrives with weight `x` here: β x /
    /// mean(ratio).
    #[inline]
    pub fn contribution(&self, x: Rgb) -> Rgb {
        self.beta * x / mean_ratio(self.ratio)
    }
}

/// Parameters every medium reads.
fn common_params(p: &mut dyn Params) -> Result<MediumCommon, ParamError> {
    let scale = p.float_or("scale", 1.0)?;
    if !(scale >= 0.0 && scale.is_finite()) {
        return Err(p.param_error("scale", &format!("must be 0 or more, not {scale}")));
    }
    let albedo = volume_param(p, "albedo", ColorKind::Reflectance, Rgb::splat(0.75))?;
    let radiance = if p.has("radiance") {
        Some(volume_param(
            p,
            "radiance",
            ColorKind::Illuminant,
            Rgb::ZERO,
        )?)
    } else {
        None
    };
    let phase = match p.child(Family::Phase)? {
        Some(mut c) => PhaseFunction::from_params(&mut *c)?,
        None => PhaseFunction::default(),
    };
    let sample_emitters = p.boolean_or("sample_emitters", true)?;
    p.boolean_or("has_spectral_extinction", true)?;
    Ok(MediumCommon {
        albedo,
        scale,
        radiance,
        phase,
        sample_emitters,
    })
}

impl Medium {
    fn common(&self) -> &MediumCommon {
        match self {
            Medium::Homogeneous(m) => &m.common,
            Medium::Heterogeneous(m) => &m.common,
        }
    }

    /// The phase function.
    #[inline]
    pub fn phase(&self) -> &PhaseFunction {
        &self.common().phase
    }

    /// Whether scattering points sample emitters.
    #[inline]
    pub fn sample_emitters(&self) -> bool {
        self.common().sample_emitters
    }

    /// Samples a free flight along `o + t d` (`d` unit length) that ends
    /// at a scattering event or at `t_max` (which may be infinite), by the
    /// path's hero channel, with uniform numbers from `next`; updates the
    /// path's weight (at a scattering event, the albedo included).
    pub fn sample_flight(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        path: &mut PathWeight,
        next: &mut impl FnMut() -> f32,
    ) -> Flight {
        match self {
            Medium::Homogeneous(m) => m.sample_flight(o, d, t_max, path, next),
            Medium::Heterogeneous(m) => m.sample_flight(o, d, t_max, path, next),
        }
    }

    /// The transmittance along `o + t d` over [0, `t_max`] (`d` unit
    /// length): exact in a homogeneous medium, an unbiased ratio-tracking
    /// estimate in a heterogeneous one.
    pub fn transmittance(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        next: &mut impl FnMut() -> f32,
    ) -> Rgb {
        match self {
            Medium::Homogeneous(m) => extinction(m.sigma_t_along(o, d), t_max),
            Medium::Heterogeneous(m) => m.transmittance(o, d, t_max, next),
        }
    }
}

impl MediumCommon {
    /// Radiance emitted at `p` per unit extinction, for albedo `albedo`:
    /// (1 − albedo) L_e.
    #[inline]
    fn emission(&self, p: Vec3, albedo: Rgb) -> Rgb {
        match &self.radiance {
            Some(r) => (Rgb::ONE - albedo).max(Rgb::ZERO) * r.eval(p),
            None => Rgb::ZERO,
        }
    }
}

impl Homogeneous {
    /// Extinction along `d` for a flight from `o`: σ_t times the phase
    /// function's projected area (1 but for `sggx`).
    #[inline]
    fn sigma_t_along(&self, o: Vec3, d: Vec3) -> Rgb {
        self.sigma_t * self.common.phase.projected_area(o, d)
    }

    fn coefficients(&self, o: Vec3, d: Vec3) -> HomogeneousCoefficients {
        HomogeneousCoefficients {
            sigma_t: self.sigma_t_along(o, d),
            albedo: Rgb::ONE,
        }
    }

    /// The distance a flight from `o` along `d` by the path's hero channel
    /// would go, from a uniform `u`: an integrator may look for surfaces
    /// only that far (then [`Homogeneous::end_flight`]).
    #[inline]
    pub fn free_distance(&self, o: Vec3, d: Vec3, path: &PathWeight, u: f32) -> f32 {
        self.coefficients(o, d).free_distance(path.hero, u)
    }

    fn sample_flight(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        path: &mut PathWeight,
        next: &mut impl FnMut() -> f32,
    ) -> Flight {
        let t = self.free_distance(o, d, path, next());
        self.end_flight(o, d, t, t_max, path)
    }

    /// Ends a flight along `o + t d` whose distance `t` was drawn by
    /// [`Homogeneous::free_distance`] and whose segment ends at `t_max`:
    /// a scattering event when `t < t_max`; updates the path's weight.
    pub fn end_flight(
        &self,
        o: Vec3,
        d: Vec3,
        t: f32,
        t_max: f32,
        path: &mut PathWeight,
    ) -> Flight {
        let coefficients = self.coefficients(o, d);
        let s = coefficients.flight_outcome(t, t_max, path.hero);
        path.ratio *= s.ratio;
        if !s.scattered {
            path.beta *= s.weight;
            // The hero's chance of passing, e^(−σ_h t_max) (1 where σ_h = 0).
            let sigma_hero = coefficients.sigma_t[path.hero];
            if sigma_hero > 0.0 {
                path.ratio_light /= (-sigma_hero * t_max).exp();
            }
            return Flight {
                t: t_max,
                scattered: false,
                emitted: Rgb::ZERO,
            };
        }
        // `s.weight` is T σ_t / p_hero here: the collision estimates both
        // what is scattered (× albedo) and what is emitted (× (1 − albedo)
        // L_e).
        let p = o + d * s.t;
        let albedo = self.common.albedo.eval(p);
        path.beta *= s.weight;
        let emitted = path.contribution(self.common.emission(p, albedo));
        path.beta *= albedo;
        Flight {
            t: s.t,
            scattered: true,
            emitted,
        }
    }
}

impl Heterogeneous {
    /// Extinction at `p` along `d`: the phase function's projected area
    /// (1 but for `sggx`) included.
    #[inline]
    fn sigma_t_at(&self, p: Vec3, d: Vec3) -> Rgb {
        self.sigma_t.eval(p) * (self.common.scale * self.common.phase.projected_area(p, d))
    }

    /// Delta tracking: tentative collisions at the majorant's rate, each
    /// real with the hero channel's probability σ_t,h / μ, else null; the
    /// majorant's transmittance is the same in every channel and cancels.
    fn sample_flight(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        path: &mut PathWeight,
        next: &mut impl FnMut() -> f32,
    ) -> Flight {
        let mut emitted = Rgb::ZERO;
        let mut hit = None;
        let hero = path.hero;
        self.majorants.walk(o, d, t_max, |t0, t1, mu| {
            if mu <= 0.0 {
                return true;
            }
            let mut t = t0;
            loop {
                t += -(1.0 - next()).ln() / mu;
                if t >= t1 {
                    return true;
                }
                let p = o + d * t;
                let sigma_t = self.sigma_t_at(p, d);
                let albedo = self.common.radiance.is_some().then(|| {
                    let albedo = self.common.albedo.eval(p);
                    emitted += path.contribution(sigma_t * self.common.emission(p, albedo) / mu);
                    albedo
                });
                if next() * mu < sigma_t[hero] {
                    let albedo = albedo.unwrap_or_else(|| self.common.albedo.eval(p));
                    path.beta *= sigma_t * albedo / sigma_t[hero];
                    path.ratio *= sigma_t / sigma_t[hero];
                    hit = Some(t);
                    return false;
                }
                let sigma_n = (Rgb::splat(mu) - sigma_t).max(Rgb::ZERO);
                path.beta *= sigma_n / sigma_n[hero];
                path.ratio *= sigma_n / sigma_n[hero];
                path.ratio_light *= mu / sigma_n[hero];
            }
        });
        Flight {
            t: hit.unwrap_or(t_max),
            scattered: hit.is_some(),
            emitted,
        }
    }

    /// Ratio tracking through the majorant segments.
    fn transmittance(&self, o: Vec3, d: Vec3, t_max: f32, next: &mut impl FnMut() -> f32) -> Rgb {
        let mut tr = Rgb::ONE;
        self.majorants.walk(o, d, t_max, |t0, t1, mu| {
            if mu > 0.0 {
                tr *= ratio_tracking(
                    |t| self.sigma_t_at(o + d * (t0 + t), d),
                    mu,
                    t1 - t0,
                    &mut *next,
                );
            }
            tr.max_element() > 0.0
        });
        tr
    }
}

impl Majorants {
    /// Calls `visit(t0, t1, μ)` for consecutive pieces of the ray
    /// `o + t d`, t in [0, `t_max`], outside which the medium is empty,
    /// with the extinction's bound μ over each; stops when `visit` returns
    /// false.
    pub fn walk(&self, o: Vec3, d: Vec3, t_max: f32, mut visit: impl FnMut(f32, f32, f32) -> bool) {
        match self {
            Majorants::Uniform {
                value,
                extent: None,
            } => {
                visit(0.0, t_max, *value);
            }
            Majorants::Uniform {
                value,
                extent: Some((to_world, bounds)),
            } => {
                let (lo, ld) = (
                    to_world.inv.transform_point3(o),
                    to_world.inv.transform_vector3(d),
                );
                if let Some((t0, t1)) = clip_to_box(lo, ld, bounds, t_max) {
                    visit(t0, t1, *value);
                }
            }
            Majorants::Grid {
                grid,
                to_world,
                scale,
            } => {
                let (lo, ld) = (
                    to_world.inv.transform_point3(o),
                    to_world.inv.transform_vector3(d),
                );
                grid.walk(lo, ld, 0.0, t_max, |t0, t1, m| visit(t0, t1, m * scale));
            }
        }
    }
}

/// The part of [0, `t_max`] of the ray `o + t d` inside `b`.
fn clip_to_box(o: Vec3, d: Vec3, b: &Bounds3, t_max: f32) -> Option<(f32, f32)> {
    let inv = d.recip();
    let (ta, tb) = ((b.min - o) * inv, (b.max - o) * inv);
    let t0 = ta.min(tb).max_element().max(0.0);
    let t1 = ta.max(tb).min_element().min(t_max);
    (t0 < t1).then_some((t0, t1))
}

/// A homogeneous medium's coefficients (per unit length).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HomogeneousCoefficients {
    /// Extinction σ_t per channel.
    pub sigma_t: Rgb,
    /// Single-scattering albedo σ_s / σ_t per channel.
    pub albedo: Rgb,
}

/// Where a free flight sampled by a hero channel ended, and what it
/// multiplies a path's throughput and channel ratios by.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DistanceSample {
    /// The distance travelled.
    pub t: f32,
    /// True when the flight ended inside the medium (a scattering event),
    /// false when it reached `t_max`.
    pub scattered: bool,
    /// f / p_hero: inside T(t) σ_s / (T_h(t) σ_t,h); at `t_max`
    /// T(t_max) / T_h(t_max).
    pub weight: Rgb,
    /// p_c / p_hero per channel: inside T(t) σ_t / (T_h(t) σ_t,h); at
    /// `t_max` T(t_max) / T_h(t_max).
    pub ratio: Rgb,
}

/// e^(−σ t) per channel, 1 where σ is 0 (also over an infinite `t`).
#[inline]
fn extinction(sigma: Rgb, t: f32) -> Rgb {
    Rgb::select(sigma.cmpeq(Rgb::ZERO), Rgb::ONE, (-sigma * t).exp())
}

impl HomogeneousCoefficients {
    /// Transmittance over a distance `t`: e^(−σ_t t) per channel.
    #[inline]
    pub fn transmittance(&self, t: f32) -> Rgb {
        extinction(self.sigma_t, t)
    }

    /// Samples how far a ray goes before it scatters, up to `t_max`
    /// (which may be infinite), by the exponential of channel `hero`, from
    /// a uniform `u`.
    pub fn sample_distance(&self, t_max: f32, hero: usize, u: f32) -> DistanceSample {
        self.flight_outcome(self.free_distance(hero, u), t_max, hero)
    }

    /// A free-flight distance by the exponential of channel `hero`
    /// (infinite where it has no extinction), from a uniform `u`.
    #[inline]
    pub fn free_distance(&self, hero: usize, u: f32) -> f32 {
        let sigma = self.sigma_t[hero];
        if sigma > 0.0 {
            -(1.0 - u).ln() / sigma
        } else {
            f32::INFINITY
        }
    }

    /// [`HomogeneousCoefficients::sample_distance`] for a distance `t`
    /// already drawn by [`HomogeneousCoefficients::free_distance`]: a
    /// scattering event when `t < t_max`.
    pub fn flight_outcome(&self, t: f32, t_max: f32, hero: usize) -> DistanceSample {
        if t < t_max {
            let density = self.sigma_t * self.transmittance(t);
            let ratio = density / density[hero];
            DistanceSample {
                t,
                scattered: true,
                weight: ratio * self.albedo,
                ratio,
            }
        } else {
            let tr = self.transmittance(t_max);
            let ratio = if tr[hero] > 0.0 {
                tr / tr[hero]
            } else {
                Rgb::ZERO
            };
            DistanceSample {
                t: t_max,
                scattered: false,
                weight: ratio,
                ratio,
            }
        }
    }

    /// The density of a flight sampled by channel `channel` ending at `t`
    /// inside the medium: σ_t,c e^(−σ_t,c t).
    pub fn pdf_distance(&self, t: f32, channel: usize) -> f32 {
        (self.sigma_t * self.transmittance(t))[channel]
    }
}

/// The mean of a path's channel ratios: what its contributions are divided
/// by (the balance heuristic over channels).
#[inline]
pub fn mean_ratio(r: Rgb) -> f32 {
    r.element_sum() / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;
    use crate::testing::chi2::chi2_discrete;

    /// Sums of per-channel estimates and of their squares.
    #[derive(Default)]
    struct Moments {
        sum: Rgb,
        sum2: Rgb,
    }

    impl Moments {
        fn add(&mut self, w: Rgb) {
            self.sum += w;
            self.sum2 += w * w;
        }

        /// Asserts that the mean of `n` estimates (zero where none was
        /// added) is `want` within 4 standard errors per channel.
        fn assert_mean(&self, n: usize, want: Rgb, what: &str) {
            let nf = n as f32;
            let mean = self.sum / nf;
            let se = ((self.sum2 / nf - mean * mean) / nf)
                .max(Rgb::ZERO)
                .powf(0.5);
            for c in 0..3 {
                assert!(
                    (mean[c] - want[c]).abs() < 4.0 * se[c] + 1e-4,
                    "{what}, channel {c}: {} vs {} (± {})",
                    mean[c],
                    want[c],
                    se[c]
                );
            }
        }
    }

    fn chromatic() -> HomogeneousCoefficients {
        HomogeneousCoefficients {
            sigma_t: Rgb::new(0.5, 1.5, 4.0),
            albedo: Rgb::new(0.9, 0.6, 0.3),
        }
    }

    /// Free-flight distances sampled by each hero channel follow that
    /// channel's exponential: 40 bins over [0, t_max] and one for passing
    /// through, against the analytic bin masses.
    #[test]
    fn chi2_free_flight_distances() {
        let m = chromatic();
        let t_max = 2.0;
        let bins = 40;
        let n = 200_000;
        for hero in 0..3 {
            let mut counts = vec![0u64; bins + 1];
            let mut rng = Pcg32::new(3, 9 + hero as u64);
            for _ in 0..n {
                let s = m.sample_distance(t_max, hero, rng.next_f32());
                let bin = if s.scattered {
                    ((s.t / t_max * bins as f32) as usize).min(bins - 1)
                } else {
                    bins
                };
                counts[bin] += 1;
            }
            let cdf = |t: f32| 1.0 - m.transmittance(t)[hero] as f64;
            let mut expected: Vec<f64> = (0..bins)
                .map(|k| {
                    let (a, b) = (
                        t_max * k as f32 / bins as f32,
                        t_max * (k + 1) as f32 / bins as f32,
                    );
                    (cdf(b) - cdf(a)) * n as f64
                })
                .collect();
            expected.push((1.0 - cdf(t_max)) * n as f64);
            chi2_discrete(&counts, &expected, 0.01).unwrap();
            // pdf_distance is the CDF's derivative.
            for t in [0.01, 0.3, 1.1, 1.9] {
                let h = 1e-3;
                let slope = (cdf(t + h) - cdf(t - h)) / (2.0 * h as f64);
                let pdf = m.pdf_distance(t, hero) as f64;
                assert!(
                    (pdf / slope - 1.0).abs() < 1e-3,
                    "hero {hero}, t {t}: pdf {pdf} vs slope {slope}"
                );
            }
        }
    }

    /// With the hero channel picked uniformly, weight / mean(ratio) is
    /// bounded and unbiased per channel: passing through estimates
    /// T(t_max); a scattering event, weighted by 1/σ_s, estimates
    /// ∫₀^t_max T(t) dt.
    #[test]
    fn spectral_mis_weights_are_unbiased_per_channel() {
        let m = chromatic();
        let t_max = 1.3;
        let n = 400_000;
        let mut rng = Pcg32::new(5, 2);
        let (mut pass, mut scat) = (Moments::default(), Moments::default());
        for _ in 0..n {
            let hero = ((rng.next_f32() * 3.0) as usize).min(2);
            let s = m.sample_distance(t_max, hero, rng.next_f32());
            let w = s.weight / mean_ratio(s.ratio);
            // The balance heuristic over channels bounds every channel's
            // weight: 3 × albedo inside, 3 passing through (the hero's
            // density alone would leave the others' unbounded).
            let bound = if s.scattered {
                3.0 * m.albedo
            } else {
                Rgb::splat(3.0)
            };
            assert!(w.cmple(bound * 1.0001).all(), "weight {w} above {bound}");
            if s.scattered {
                scat.add(w / (m.sigma_t * m.albedo));
            } else {
                pass.add(w);
            }
        }
        pass.assert_mean(n, m.transmittance(t_max), "passing");
        let integral = (Rgb::ONE - m.transmittance(t_max)) / m.sigma_t;
        scat.assert_mean(n, integral, "scattering");
    }

    /// Delta tracking in a chromatic heterogeneous medium under a loose
    /// majorant, hero channel picked per flight: what passes estimates
    /// T(L) per channel, scattering events (divided by σ_s) ∫₀^L T; the
    /// same medium's ratio-tracking transmittance is T(L) too.
    #[test]
    fn delta_tracking_is_unbiased_per_channel() {
        let sigma = Rgb::new(0.4, 1.0, 2.5);
        let albedo = Rgb::new(0.9, 0.5, 0.7);
        let medium = Medium::Heterogeneous(Heterogeneous {
            sigma_t: Volume::Const(sigma),
            majorants: Majorants::Uniform {
                value: 4.0,
                extent: None,
            },
            common: MediumCommon {
                albedo: Volume::Const(albedo),
                scale: 1.0,
                radiance: None,
                phase: PhaseFunction::Isotropic,
                sample_emitters: true,
            },
        });
        let length = 1.2;
        let n = 300_000;
        let mut rng = Pcg32::new(11, 4);
        let mut next = || rng.next_f32();
        let (mut pass, mut scat, mut tr) =
            (Moments::default(), Moments::default(), Moments::default());
        for i in 0..n {
            let mut path = PathWeight::new(i % 3);
            let f = medium.sample_flight(Vec3::ZERO, Vec3::X, length, &mut path, &mut next);
            let w = path.contribution(Rgb::ONE);
            if f.scattered {
                scat.add(w / (sigma * albedo));
            } else {
                pass.add(w);
            }
            tr.add(medium.transmittance(Vec3::ZERO, Vec3::X, length, &mut next));
        }
        let want_t = (-sigma * length).exp();
        pass.assert_mean(n, want_t, "passing");
        scat.assert_mean(n, (Rgb::ONE - want_t) / sigma, "scattering");
        tr.assert_mean(n, want_t, "ratio tracking");
    }
}
