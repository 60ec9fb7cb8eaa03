//! Emitters: the contract every light implements and the closed enum the
//! scene stores.
//!
//! Conventions: [`EmitterModel::sample_direction`] picks a point on (or a
//! direction to) the light as seen from a reference point and returns the
//! incident radiance *unweighted* together with the solid-angle density
//! (1 for delta lights, flagged by `is_delta`). [`EmitterModel::pdf_direction`]
//! returns the same density for a point found by tracing a ray, so that
//! integrators can weight both strategies with MIS.

mod area;
mod constant;
mod directional;
mod point;

pub use area::AreaLight;
pub use constant::ConstantLight;
pub use directional::DirectionalLight;
pub use point::PointLight;

use crate::shape::{Shape, TriangleMesh};
use crate::Rgb;
use glam::{Vec2, Vec3};

/// What an emitter needs to know about the scene: shapes for area lights.
#[derive(Clone, Copy, Debug)]
pub struct EmitterContext<'a> {
    /// The scene's shapes.
    pub shapes: &'a [Shape],
    /// The scene's meshes.
    pub meshes: &'a [TriangleMesh],
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
}

macro_rules! dispatch {
    ($self:expr, $l:ident => $e:expr) => {
        match $self {
            Emitter::Area($l) => $e,
            Emitter::Point($l) => $e,
            Emitter::Directional($l) => $e,
            Emitter::Constant($l) => $e,
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
    /// Radiance leaving an emitting surface towards `wo` (world), where
    /// `n` is the surface's shading normal. Zero for non-surface lights.
    #[inline]
    pub fn surface_radiance(&self, n: Vec3, wo: Vec3) -> Rgb {
        match self {
            Emitter::Area(a) if n.dot(wo) > 0.0 => a.radiance,
            _ => Rgb::ZERO,
        }
    }

    /// Radiance arriving along a ray with direction `d` that escaped the
    /// scene. Zero for lights that are not at infinity or are delta.
    #[inline]
    pub fn environment_radiance(&self, _d: Vec3) -> Rgb {
        match self {
            Emitter::Constant(c) => c.radiance,
            _ => Rgb::ZERO,
        }
    }

    /// True for lights that surround the scene (hit by escaping rays).
    pub fn is_environment(&self) -> bool {
        matches!(self, Emitter::Constant(_))
    }
}
