//! Shared by the BSDFs that replace the shading frame (`normalmap`,
//! `bumpmap`): the nested BSDF is evaluated in a perturbed frame given in
//! the coordinates of the original shading frame. A direction on one side
//! of the perturbed surface but the other side of the original one is
//! rejected (it would leak light through the surface). Mitsuba 3 rejects
//! such light directions but not such viewing directions; yubin rejects
//! both, so a one-sided material stays black from behind.

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
    let (wo_p, wi_p) = (frame.to_local(wo), frame.to_local(wi));
    if !consistent(wi, wi_p) || !consistent(wo, wo_p) {
        return Rgb::ZERO;
    }
    nested.eval(m, ctx, si, wo_p, wi_p)
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
    let (wo_p, wi_p) = (frame.to_local(wo), frame.to_local(wi));
    if !consistent(wi, wi_p) || !consistent(wo, wo_p) {
        return 0.0;
    }
    nested.pdf(m, ctx, si, wo_p, wi_p)
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
    let wo_p = frame.to_local(wo);
    if !consistent(wo, wo_p) {
        return None;
    }
    let s = nested.sample(m, ctx, si, wo_p, u1, u2)?;
    let wi = frame.to_world(s.wi);
    consistent(wi, s.wi).then_some(BsdfSample { wi, ..s })
}
