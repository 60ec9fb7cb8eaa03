//! Which emitter next-event estimation samples: the settings every emitter
//! has besides its own parameters ([`EmitterOptions`]), and the
//! [`LightSampler`] that a render builds over the scene's emitters.
//!
//! Three strategies, chosen per render ([`LightSelection`], the `path` and
//! `direct` integrators' `light_sampler` parameter):
//!
//! - `uniform`: each emitter with probability proportional to its
//!   `sampling_weight` (1 unless given): Mitsuba 3's rule.
//! - `power`: proportional to emitted power × `sampling_weight`, so a dim
//!   fill light does not get as many samples as the sun.
//! - `bvh`: a light BVH (Conty Estevez & Kulla 2018; pbrt-v4 §12.6.3) that
//!   picks lights by their estimated contribution at the shading point;
//!   emissive meshes enter triangle by triangle. See [`super::bvh`].
//!
//! Whatever the strategy, the probability of the light a BSDF-sampled ray
//! happened to hit is available for MIS ([`LightSampler::pmf`]).
//!
//! Under MIS compensation (the `mis_compensation` of `path`, `volpath`
//! and `direct` with BSDF samples, which a render's state takes from its
//! integrator) every strategy
//! leaves `constant` emitters out (unless hidden from indirect rays):
//! their probability is 0, BSDF sampling alone finds them, and the other
//! emitters share their light samples.
//!
//! **Parameters of every emitter** (`area` included):
//!
//! | parameter          | type    | default | meaning                                                   |
//! |--------------------|---------|---------|-----------------------------------------------------------|
//! | `visible`          | boolean | true    | camera rays see the emitter (yubin; per light, where Mitsuba's `hide_emitters` hides all) |
//! | `visible_indirect` | boolean | true    | rays that left a surface see it (yubin); false: it lights the scene through light sampling only |
//! | `sampling_weight`  | float   | 1       | Mitsuba's relative probability of being chosen (`uniform` and `power`; the BVH ignores it) |
//!
//! ```xml
//! <emitter type="point">
//!     <boolean name="visible" value="false"/>
//!     <float name="sampling_weight" value="2"/>
//! </emitter>
//! <integrator type="path"><string name="light_sampler" value="power"/></integrator>
//! ```
//!
//! An invisible light still lights the scene and shows in mirrors unless
//! `visible_indirect` is false too. Hiding a light from indirect rays
//! drops its BSDF-sampling strategy, so its light samples get the full MIS
//! weight and the image stays unbiased.

use super::bvh::LightBvh;
use super::{Emitter, EmitterContext};
use crate::params::{ParamError, Params};
use crate::sampling::AliasTable;
use glam::Vec3;

/// How next-event estimation chooses an emitter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightSelection {
    /// By `sampling_weight` alone (Mitsuba's rule).
    Uniform,
    /// By emitted power × `sampling_weight`.
    Power,
    /// By a light BVH's estimate of each light's contribution.
    #[default]
    Bvh,
}

impl LightSelection {
    /// Every strategy by its parameter value.
    pub const NAMES: [(&'static str, LightSelection); 3] = [
        ("uniform", LightSelection::Uniform),
        ("power", LightSelection::Power),
        ("bvh", LightSelection::Bvh),
    ];

    /// Reads the integrator parameter `light_sampler` (`None` when absent).
    pub fn from_params(p: &mut dyn Params) -> Result<Option<Self>, ParamError> {
        let Some(name) = p.string("light_sampler")? else {
            return Ok(None);
        };
        Self::NAMES
            .iter()
            .find(|(n, _)| *n == name)
            .map(|&(_, s)| Some(s))
            .ok_or_else(|| {
                p.param_error(
                    "light_sampler",
                    &format!("unknown light sampler \"{name}\" (known: uniform, power, bvh)"),
                )
            })
    }
}

/// Settings common to every emitter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmitterOptions {
    /// Seen by camera rays (yubin's `visible`).
    pub visible: bool,
    /// Seen by rays that left a surface (yubin's `visible_indirect`); when
    /// false the emitter still lights the scene through light sampling.
    pub visible_indirect: bool,
    /// Mitsuba's `sampling_weight`: relative probability of being chosen.
    pub sampling_weight: f32,
}

impl Default for EmitterOptions {
    fn default() -> Self {
        Self {
            visible: true,
            visible_indirect: true,
            sampling_weight: 1.0,
        }
    }
}

impl EmitterOptions {
    /// Reads `visible`, `visible_indirect` and `sampling_weight`.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let sampling_weight = p.float_or("sampling_weight", 1.0)?;
        if !(sampling_weight >= 0.0 && sampling_weight.is_finite()) {
            return Err(p.param_error(
                "sampling_weight",
                &format!("must be a finite number ≥ 0, not {sampling_weight}"),
            ));
        }
        Ok(Self {
            visible: p.boolean_or("visible", true)?,
            visible_indirect: p.boolean_or("visible_indirect", true)?,
            sampling_weight,
        })
    }
}

/// A light as the sampler chooses it: an emitter, or one triangle of an
/// emissive mesh (`prim`), which the light BVH holds one by one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LightChoice {
    /// Index into the scene's emitters.
    pub emitter: u32,
    /// The triangle of the emitter's mesh, or [`LightChoice::WHOLE`].
    pub prim: u32,
}

impl LightChoice {
    /// `prim` of a choice of the whole emitter.
    pub const WHOLE: u32 = u32::MAX;
}

/// A render's emitter chooser (see the module docs).
#[derive(Clone, Debug, Default)]
pub struct LightSampler {
    /// The strategy in use.
    pub selection: LightSelection,
    /// Uniform and power: the table over emitters.
    table: Option<AliasTable>,
    /// BVH: the tree (it also holds the lights at infinity).
    bvh: Option<LightBvh>,
    /// Per emitter, whether it is left to BSDF sampling (never chosen).
    left_out: Vec<bool>,
}

impl LightSampler {
    /// Builds the sampler for `emitters` with their `options`; `ctx` sees
    /// the scene, whose geometry has bounding-sphere radius `radius`;
    /// `compensated[i]`: emitter `i` may leave to BSDF sampling what it
    /// finds well (`left_to_bsdf_sampling`).
    pub fn new(
        selection: LightSelection,
        emitters: &[Emitter],
        options: &[EmitterOptions],
        compensated: &[bool],
        ctx: &EmitterContext,
        radius: f32,
    ) -> Self {
        let left_out = (emitters.iter().enumerate())
            .map(|(i, e)| left_to_bsdf_sampling(e, compensated.get(i).copied().unwrap_or(false)))
            .collect();
        Self::leaving_out(selection, emitters, options, left_out, ctx, radius)
    }

    /// [`LightSampler::new`] with the emitters it never chooses given:
    /// `left_out[i]` for emitter `i` (those left to BSDF sampling, or
    /// those of other worlds than a portal scene's sampler serves).
    pub fn leaving_out(
        selection: LightSelection,
        emitters: &[Emitter],
        options: &[EmitterOptions],
        left_out: Vec<bool>,
        ctx: &EmitterContext,
        radius: f32,
    ) -> Self {
        if emitters.is_empty() {
            return Self {
                selection,
                ..Self::default()
            };
        }
        let sampler = |table, bvh| Self {
            selection,
            table,
            bvh,
            left_out: left_out.clone(),
        };
        match selection {
            LightSelection::Uniform | LightSelection::Power => {
                let weights: Vec<f32> = emitters
                    .iter()
                    .zip(options)
                    .map(|(e, o)| match selection {
                        LightSelection::Power => e.power(ctx, radius) * o.sampling_weight,
                        _ => o.sampling_weight,
                    })
                    .map(|w| if w.is_finite() { w.max(0.0) } else { 0.0 })
                    .collect();
                let kept: Vec<f32> = (weights.iter().zip(&left_out))
                    .map(|(&w, &out)| if out { 0.0 } else { w })
                    .collect();
                // All weights zero: fall back to uniform rather than never
                // sampling lights at all (but never those left out). Only
                // then: a light of weight 0 beside a left-out one stays
                // unsampled, as it is without compensation.
                let table = match AliasTable::new(&weights) {
                    Some(_) => AliasTable::new(&kept),
                    None => {
                        let uniform: Vec<f32> = left_out
                            .iter()
                            .map(|&out| f32::from(u8::from(!out)))
                            .collect();
                        AliasTable::new(&uniform)
                    }
                };
                sampler(table, None)
            }
            LightSelection::Bvh => {
                sampler(None, Some(LightBvh::new(emitters, &left_out, ctx, radius)))
            }
        }
    }

    /// Whether the sampler never chooses `emitter` (left to BSDF
    /// sampling): its [`LightSampler::pmf`] is 0 everywhere.
    #[inline]
    pub fn never_chooses(&self, emitter: u32) -> bool {
        self.left_out
            .get(emitter as usize)
            .copied()
            .unwrap_or(false)
    }

    /// Chooses a light for the shading point `p` with normal `n` (zero when
    /// there is no surface); returns it and its probability.
    #[inline]
    pub fn sample(&self, u: f32, p: Vec3, n: Vec3) -> Option<(LightChoice, f32)> {
        if let Some(t) = &self.table {
            let (i, _) = t.sample(u);
            return Some((
                LightChoice {
                    emitter: i as u32,
                    prim: LightChoice::WHOLE,
                },
                t.pmf(i),
            ));
        }
        self.bvh.as_ref()?.sample(u, p, n)
    }

    /// Whether the sampler chooses no light at all.
    pub fn is_empty(&self) -> bool {
        self.table.is_none() && self.bvh.as_ref().is_none_or(LightBvh::is_empty)
    }

    /// Number of lights in the light BVH (0 without one).
    pub fn bvh_light_count(&self) -> usize {
        self.bvh.as_ref().map_or(0, LightBvh::light_count)
    }

    /// Probability that [`LightSampler::sample`] at (`p`, `n`) chooses
    /// `light`.
    #[inline]
    pub fn pmf(&self, light: LightChoice, p: Vec3, n: Vec3) -> f32 {
        if let Some(t) = &self.table {
            return t.pmf(light.emitter as usize);
        }
        self.bvh.as_ref().map_or(0.0, |b| b.pmf(light, p, n))
    }

    /// Whether the sampler chooses triangles of `emitter`'s mesh one by one
    /// (then a hit on it must be looked up by triangle).
    #[inline]
    pub fn splits(&self, emitter: u32) -> bool {
        self.bvh.as_ref().is_some_and(|b| b.splits(emitter))
    }
}

/// Whether light sampling leaves emitter `e` to BSDF sampling alone when
/// it may leave what BSDF sampling finds well (`compensated`): a
/// `constant` emitter, whose excess over its mean is nothing.
pub(crate) fn left_to_bsdf_sampling(e: &Emitter, compensated: bool) -> bool {
    compensated && matches!(e, Emitter::Constant(_))
}
