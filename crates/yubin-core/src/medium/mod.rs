//! Participating media (closed enum): `homogeneous` and `heterogeneous`,
//! one plugin per file, with the sampling routines the volumetric
//! integrator (`volpath`) is built from.
//!
//! A medium fills the inside or outside of shapes that name it
//! (`interior`, `exterior`) or surrounds the sensor; rays carry the medium
//! they travel in. Its extinction σ_t and albedo come from volumes
//! ([`crate::volume`]); its phase function from [`crate::phase`].
//!
//! - [`HomogeneousCoefficients::sample_distance`]: free-flight distances
//!   in a chromatic homogeneous medium, by spectral MIS (Miller et al.
//!   2019, "A null-scattering path integral formulation of light
//!   transport", §5): a channel is picked uniformly and the distance
//!   sampled from its exponential; the density is the average of the three
//!   channels' densities, so every channel's estimate stays bounded.
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
    /// The factor for the path's throughput.
    pub weight: Rgb,
    /// Radiance the medium emitted along the flight, already weighted (add
    /// it times the throughput before `weight`).
    pub emitted: Rgb,
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
    pub fn phase(&self) -> PhaseFunction {
        self.common().phase
    }

    /// Whether scattering points sample emitters.
    #[inline]
    pub fn sample_emitters(&self) -> bool {
        self.common().sample_emitters
    }

    /// Samples a free flight along `o + t d` (`d` unit length) that ends
    /// at a scattering event or at `t_max` (which may be infinite), with
    /// uniform numbers from `next`.
    pub fn sample_flight(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        next: &mut impl FnMut() -> f32,
    ) -> Flight {
        match self {
            Medium::Homogeneous(m) => m.sample_flight(o, d, t_max, next),
            Medium::Heterogeneous(m) => m.sample_flight(o, d, t_max, next),
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
            Medium::Homogeneous(m) => extinction(m.sigma_t, t_max),
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
    fn sample_flight(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        next: &mut impl FnMut() -> f32,
    ) -> Flight {
        let coefficients = HomogeneousCoefficients {
            sigma_t: self.sigma_t,
            albedo: Rgb::ONE,
        };
        let s = coefficients.sample_distance(t_max, next(), next());
        if !s.scattered {
            return Flight {
                t: t_max,
                scattered: false,
                weight: s.weight,
                emitted: Rgb::ZERO,
            };
        }
        // `s.weight` is T σ_t / p here: the collision estimates both what
        // is scattered (× albedo) and what is emitted (× (1 − albedo) L_e).
        let p = o + d * s.t;
        let albedo = self.common.albedo.eval(p);
        Flight {
            t: s.t,
            scattered: true,
            weight: s.weight * albedo,
            emitted: s.weight * self.common.emission(p, albedo),
        }
    }
}

impl Heterogeneous {
    /// Extinction at `p`.
    #[inline]
    fn sigma_t_at(&self, p: Vec3) -> Rgb {
        self.sigma_t.eval(p) * self.common.scale
    }

    /// Delta tracking: tentative collisions at the majorant's rate, each
    /// real with probability mean(σ_t) / μ.
    fn sample_flight(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        next: &mut impl FnMut() -> f32,
    ) -> Flight {
        let mut weight = Rgb::ONE;
        let mut emitted = Rgb::ZERO;
        let mut hit = None;
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
                let sigma_t = self.sigma_t_at(p);
                let albedo = if self.common.radiance.is_some() {
                    let albedo = self.common.albedo.eval(p);
                    emitted += weight * sigma_t * self.common.emission(p, albedo) / mu;
                    Some(albedo)
                } else {
                    None
                };
                let p_real = (sigma_t.element_sum() / (3.0 * mu)).min(1.0);
                if next() < p_real {
                    let albedo = albedo.unwrap_or_else(|| self.common.albedo.eval(p));
                    weight *= sigma_t * albedo / (mu * p_real);
                    hit = Some(t);
                    return false;
                }
                weight *= (Rgb::splat(mu) - sigma_t).max(Rgb::ZERO) / (mu * (1.0 - p_real));
            }
        });
        Flight {
            t: hit.unwrap_or(t_max),
            scattered: hit.is_some(),
            weight,
            emitted,
        }
    }

    /// Ratio tracking through the majorant segments.
    fn transmittance(&self, o: Vec3, d: Vec3, t_max: f32, next: &mut impl FnMut() -> f32) -> Rgb {
        let mut tr = Rgb::ONE;
        self.majorants.walk(o, d, t_max, |t0, t1, mu| {
            if mu > 0.0 {
                tr *= ratio_tracking(
                    |t| self.sigma_t_at(o + d * (t0 + t)),
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

/// Where a free flight ended, and the factor it multiplies a path's
/// throughput by.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DistanceSample {
    /// The distance travelled.
    pub t: f32,
    /// True when the flight ended inside the medium (a scattering event),
    /// false when it reached `t_max`.
    pub scattered: bool,
    /// Inside: T(t) σ_s / p(t); at `t_max`: T(t_max) / P(t ≥ t_max).
    pub weight: Rgb,
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
    /// (which may be infinite), from a uniform channel choice `u_channel`
    /// and a uniform `u`.
    pub fn sample_distance(&self, t_max: f32, u_channel: f32, u: f32) -> DistanceSample {
        let channel = ((u_channel * 3.0) as usize).min(2);
        let sigma = self.sigma_t[channel];
        let t = if sigma > 0.0 {
            -(1.0 - u).ln() / sigma
        } else {
            f32::INFINITY
        };
        if t < t_max {
            let tr = self.transmittance(t);
            // The mixture's density: the average of the channels'.
            let pdf = (self.sigma_t * tr).element_sum() / 3.0;
            DistanceSample {
                t,
                scattered: true,
                weight: tr * self.sigma_t * self.albedo / pdf,
            }
        } else {
            let tr = self.transmittance(t_max);
            let p_pass = tr.element_sum() / 3.0;
            DistanceSample {
                t: t_max,
                scattered: false,
                weight: if p_pass > 0.0 { tr / p_pass } else { Rgb::ZERO },
            }
        }
    }

    /// The density of [`HomogeneousCoefficients::sample_distance`] ending
    /// at `t` inside the medium.
    pub fn pdf_distance(&self, t: f32) -> f32 {
        (self.sigma_t * self.transmittance(t)).element_sum() / 3.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;
    use crate::testing::chi2::chi2_discrete;

    fn chromatic() -> HomogeneousCoefficients {
        HomogeneousCoefficients {
            sigma_t: Rgb::new(0.5, 1.5, 4.0),
            albedo: Rgb::new(0.9, 0.6, 0.3),
        }
    }

    /// Free-flight distances in a chromatic medium follow the mixture
    /// density: 40 bins over [0, t_max] and one for passing through,
    /// against the analytic bin masses.
    #[test]
    fn chi2_free_flight_distances() {
        let m = chromatic();
        let t_max = 2.0;
        let bins = 40;
        let n = 400_000;
        let mut counts = vec![0u64; bins + 1];
        let mut rng = Pcg32::new(3, 9);
        for _ in 0..n {
            let s = m.sample_distance(t_max, rng.next_f32(), rng.next_f32());
            let bin = if s.scattered {
                ((s.t / t_max * bins as f32) as usize).min(bins - 1)
            } else {
                bins
            };
            counts[bin] += 1;
        }
        let cdf = |t: f32| 1.0 - m.transmittance(t).element_sum() as f64 / 3.0;
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
        // pdf_distance is the CDF's derivative (what MIS will weigh with).
        for t in [0.01, 0.3, 1.1, 1.9] {
            let h = 1e-3;
            let slope = (cdf(t + h) - cdf(t - h)) / (2.0 * h as f64);
            let pdf = m.pdf_distance(t) as f64;
            assert!(
                (pdf / slope - 1.0).abs() < 1e-3,
                "t {t}: pdf {pdf} vs slope {slope}"
            );
        }
    }

    /// The weights are bounded and make unbiased estimates per channel:
    /// passing through
    /// estimates T(t_max); a scattering event, weighted by 1/σ_s,
    /// estimates ∫₀^t_max T(t) dt.
    #[test]
    fn free_flight_weights_are_unbiased_per_channel() {
        let m = chromatic();
        let t_max = 1.3;
        let n = 400_000;
        let mut rng = Pcg32::new(5, 2);
        let (mut pass, mut pass2, mut scat, mut scat2) =
            (Rgb::ZERO, Rgb::ZERO, Rgb::ZERO, Rgb::ZERO);
        for _ in 0..n {
            let s = m.sample_distance(t_max, rng.next_f32(), rng.next_f32());
            // Spectral MIS keeps every channel's weight bounded: at most
            // 3 × albedo inside, 3 passing through (a single channel's
            // density would make the others' weights unbounded).
            let bound = if s.scattered {
                3.0 * m.albedo
            } else {
                Rgb::splat(3.0)
            };
            assert!(
                s.weight.cmple(bound * 1.0001).all(),
                "weight {} above {bound}",
                s.weight
            );
            if s.scattered {
                let w = s.weight / (m.sigma_t * m.albedo);
                scat += w;
                scat2 += w * w;
            } else {
                pass += s.weight;
                pass2 += s.weight * s.weight;
            }
        }
        let nf = n as f32;
        let check = |sum: Rgb, sum2: Rgb, want: Rgb, what: &str| {
            let mean = sum / nf;
            let se = ((sum2 / nf - mean * mean) / nf).max(Rgb::ZERO).powf(0.5);
            for c in 0..3 {
                assert!(
                    (mean[c] - want[c]).abs() < 4.0 * se[c] + 1e-4,
                    "{what}, channel {c}: {} vs {} (± {})",
                    mean[c],
                    want[c],
                    se[c]
                );
            }
        };
        check(pass, pass2, m.transmittance(t_max), "passing");
        let integral = (Rgb::ONE - m.transmittance(t_max)) / m.sigma_t;
        check(scat, scat2, integral, "scattering");
    }
}
