//! `blendphase`: a mix of two phase functions (Mitsuba 3's
//! `blendphase`).
//!
//! | parameter | type  | default | meaning |
//! |-----------|-------|---------|---------|
//! | `weight`  | float | 0.5     | the second phase function's share, clamped to [0, 1]: 0 is the first alone, 1 the second |
//! | (nested)  | phase | —       | exactly two phase functions, in the order written |
//!
//! ```xml
//! <phase type="blendphase">
//!     <float name="weight" value="0.25"/>
//!     <phase type="isotropic"/>
//!     <phase type="hg"><float name="g" value="0.8"/></phase>
//! </phase>
//! ```
//!
//! p = (1 − w) p₀ + w p₁, p₀ the first phase function written (Mitsuba
//! 3.9.1 takes them in the order written, whatever its documentation says
//! of their names). Sampled by choosing p₁ with probability w (the first
//! sample number stretched to choose, then to sample), with the density
//! of the whole mix, so the weight is 1. Mitsuba's `weight` may also be a
//! volume varying over the medium; yubin takes a float.
//!
//! Reference: Mitsuba 3 documentation, "Blended phase function
//! (blendphase)".

use super::PhaseFunction;
use crate::params::{Family, ParamError, Params};
use glam::{Vec2, Vec3};

/// Builds the phase function from its scene parameters.
pub(super) fn from_params(p: &mut dyn Params) -> Result<PhaseFunction, ParamError> {
    if p.named_child(Family::Volume, "weight")?.is_some() {
        return Err(p.param_error(
            "weight",
            "a weight that varies over the medium (a nested volume) is not supported: give a float",
        ));
    }
    let weight = p.float_or("weight", 0.5)?;
    if weight.is_nan() {
        return Err(p.param_error("weight", "must be a number"));
    }
    let mut parts = Vec::new();
    while let Some((_, mut child)) = p.nth_child(Family::Phase, parts.len())? {
        parts.push(PhaseFunction::from_params(&mut *child)?);
    }
    let [first, second]: [PhaseFunction; 2] = parts.try_into().map_err(|parts: Vec<_>| {
        p.error_at(
            None,
            &format!(
                "needs exactly two nested phase functions, not {}",
                parts.len()
            ),
        )
    })?;
    if parts_are_sggx(&[first, second]) {
        return Err(
            p.error("cannot blend an sggx phase function (its medium's extinction depends on it)")
        );
    }
    Ok(PhaseFunction::Blend(
        Blend {
            weight: weight.clamp(0.0, 1.0),
            parts: [first, second],
        }
        .interned(),
    ))
}

fn parts_are_sggx(parts: &[PhaseFunction]) -> bool {
    parts
        .iter()
        .any(|f| matches!(f, PhaseFunction::Sggx(_) | PhaseFunction::SggxAt(_)))
}

/// Two phase functions and the second one's share.
#[derive(Clone, Debug, PartialEq)]
pub struct Blend {
    /// The second phase function's share, in [0, 1].
    pub weight: f32,
    /// The two phase functions, in the order written.
    pub parts: [PhaseFunction; 2],
}

impl Blend {
    /// The blend stored for the program's life, once per content (so that
    /// a phase function stays a `Copy` value).
    pub fn interned(self) -> &'static Blend {
        static INTERNED: std::sync::Mutex<Vec<&'static Blend>> = std::sync::Mutex::new(Vec::new());
        crate::shape::interned(&INTERNED, self)
    }

    /// p(wo, wi).
    pub(super) fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        let [a, b] = &self.parts;
        (1.0 - self.weight) * a.eval(wo, wi) + self.weight * b.eval(wo, wi)
    }

    /// A direction from one of the two, chosen by its share.
    pub(super) fn sample(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let w = self.weight;
        let [a, b] = &self.parts;
        if u.x < w {
            b.sample(wo, Vec2::new(u.x / w, u.y)).wi
        } else {
            a.sample(wo, Vec2::new(((u.x - w) / (1.0 - w)).min(1.0), u.y))
                .wi
        }
    }
}
