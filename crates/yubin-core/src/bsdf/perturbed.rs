//! Shared by the BSDFs that replace the shading frame (`normalmap`,
//! `bumpmap`): the nested BSDF is evaluated in a perturbed frame given in
//! the coordinates of the original shading frame. Light arriving from one
//! side of the perturbed surface but the other side of the original one is
//! rejected (it would leak light through the surface), as in Mitsuba 3.

use super::{Bsdf, BsdfContext, BsdfModel, BsdfSample};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::math::Frame;
use crate::Rgb;
use glam::{Vec2, Vec3};

/// Both directions on consistent sides of both frames.
#[inline]
fn consistent(wi: Vec3, wi_perturbed: Vec3) -> bool {
    wi.z * wi_perturbed.z > 0.0
}

/// `nested`'s value in `frame`.
#[inline]
pub(super) fn eval(
    frame: &Frame,
    nested: &Bsdf,
    m: &Materials,
    ctx: &BsdfContext,
    si: &SurfaceInteraction,
    wo: Vec3,
    wi: Vec3,
) -> Rgb {
    let wi_p = frame.to_local(wi);
    if !consistent(wi, wi_p) {
        return Rgb::ZERO;
    }
    nested.eval(m, ctx, si, frame.to_local(wo), wi_p)
}

/// `nested`'s density in `frame`.
#[inline]
pub(super) fn pdf(
    frame: &Frame,
    nested: &Bsdf,
    m: &Materials,
    ctx: &BsdfContext,
    si: &SurfaceInteraction,
    wo: Vec3,
    wi: Vec3,
) -> f32 {
    let wi_p = frame.to_local(wi);
    if !consistent(wi, wi_p) {
        return 0.0;
    }
    nested.pdf(m, ctx, si, frame.to_local(wo), wi_p)
}

/// A sample of `nested` in `frame`, returned in the original frame.
#[inline]
pub(super) fn sample(
    frame: &Frame,
    nested: &Bsdf,
    m: &Materials,
    ctx: &BsdfContext,
    si: &SurfaceInteraction,
    wo: Vec3,
    u1: f32,
    u2: Vec2,
) -> Option<BsdfSample> {
    let s = nested.sample(m, ctx, si, frame.to_local(wo), u1, u2)?;
    let wi = frame.to_world(s.wi);
    consistent(wi, s.wi).then_some(BsdfSample { wi, ..s })
}
