//! `tabphase`: a phase function tabulated over the cosine of the
//! scattering angle (Mitsuba 3's `tabphase`).
//!
//! | parameter | type   | default | meaning |
//! |-----------|--------|---------|---------|
//! | `values`  | string | —       | at least two non-negative numbers (commas or spaces between), not all 0: the phase function at cos θ = −1, …, +1, evenly spaced |
//!
//! ```xml
//! <phase type="tabphase">
//!     <string name="values" value="0.5, 1.0, 3.0"/>
//! </phase>
//! ```
//!
//! θ is the angle between the direction of travel and the new direction,
//! so the last value is forward scattering (cos θ = +1) and the first
//! backward, as Mitsuba 3 reads its table. Between nodes the table is
//! linear; it is normalized by its integral I over [−1, 1] (trapezoids),
//! so p = f(cos θ) / (2π I) integrates to 1 over the sphere. Sampled
//! exactly: cos θ by inverting the piecewise-linear distribution (a
//! quadratic within a segment), φ uniformly.
//!
//! Reference: Mitsuba 3 documentation, "Lookup table phase function
//! (tabphase)".

use super::{about_travel, PhaseFunction};
use crate::params::{ParamError, Params};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// A tabulated phase function, normalized.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    /// The values at evenly spaced cos θ from −1 to 1, divided by the
    /// table's integral.
    values: Vec<f32>,
    /// Per node, the integral of the normalized table from −1 to it.
    cdf: Vec<f32>,
}

/// Builds the phase function from its scene parameters.
pub(super) fn from_params(p: &mut dyn Params) -> Result<PhaseFunction, ParamError> {
    let text = p
        .string("values")?
        .ok_or_else(|| p.param_error("values", "is required (a string of numbers)"))?;
    let values: Vec<f32> = text
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(|t| {
            t.parse::<f32>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| p.param_error("values", &format!("\"{t}\" is not a number")))
        })
        .collect::<Result<_, _>>()?;
    Table::new(values)
        .map(|t| PhaseFunction::Tabulated(t.interned()))
        .map_err(|why| p.param_error("values", &why))
}

impl Table {
    /// The table of `values` (at cos θ = −1 … 1), or why it cannot be one.
    pub fn new(values: Vec<f32>) -> Result<Self, String> {
        if values.len() < 2 {
            return Err(format!("needs at least two values, not {}", values.len()));
        }
        if let Some(v) = values.iter().find(|v| **v < 0.0) {
            return Err(format!("must not be negative ({v})"));
        }
        let h = 2.0 / (values.len() - 1) as f64;
        let mut cdf = vec![0.0f64; values.len()];
        for k in 1..values.len() {
            cdf[k] = cdf[k - 1] + 0.5 * h * f64::from(values[k - 1] + values[k]);
        }
        let total = cdf[values.len() - 1];
        if total <= 0.0 {
            return Err("are all 0: the table has no mass".into());
        }
        Ok(Self {
            values: values
                .iter()
                .map(|v| (f64::from(*v) / total) as f32)
                .collect(),
            cdf: cdf.iter().map(|c| (c / total) as f32).collect(),
        })
    }

    /// The table stored for the program's life, once per content (so that
    /// a phase function stays a `Copy` value).
    pub fn interned(self) -> &'static Table {
        static INTERNED: std::sync::Mutex<Vec<&'static Table>> = std::sync::Mutex::new(Vec::new());
        crate::shape::interned(&INTERNED, self)
    }

    /// The normalized table at `mu` = cos θ, linear between nodes.
    fn density(&self, mu: f32) -> f32 {
        let last = self.values.len() - 1;
        let x = ((mu + 1.0) * 0.5 * last as f32).clamp(0.0, last as f32);
        let k = (x as usize).min(last - 1);
        let t = x - k as f32;
        self.values[k] * (1.0 - t) + self.values[k + 1] * t
    }

    /// p for `cos_wo_wi` = wo · wi (wo pointing back along the path).
    pub(super) fn eval(&self, cos_wo_wi: f32) -> f32 {
        self.density(-cos_wo_wi) / (2.0 * PI)
    }

    /// cos θ distributed as the table, for the uniform `u`.
    pub(super) fn sample_mu(&self, u: f32) -> f32 {
        let last = self.values.len() - 1;
        let k = self.cdf[1..last].partition_point(|&c| c <= u);
        let h = 2.0 / last as f32;
        let (v0, v1) = (self.values[k], self.values[k + 1]);
        let mass = (u - self.cdf[k]).max(0.0);
        // Solves v0 t + (v1 − v0) t² / 2h = mass for t in [0, h], in the
        // form that loses no precision when v1 ≈ v0.
        let root = (v0 * v0 + 2.0 * (v1 - v0) * mass / h).max(0.0).sqrt();
        let t = if v0 + root > 0.0 {
            2.0 * mass / (v0 + root)
        } else {
            0.0
        };
        (-1.0 + k as f32 * h + t.min(h)).clamp(-1.0, 1.0)
    }

    /// A direction distributed as p about the direction of travel −wo.
    pub(super) fn sample(&self, wo: Vec3, u: Vec2) -> Vec3 {
        about_travel(wo, self.sample_mu(u.x), 2.0 * PI * u.y)
    }
}
