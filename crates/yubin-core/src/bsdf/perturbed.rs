//! Shared by the BSDFs that replace the shading frame (`normalmap`,
//! `bumpmap`): the nested BSDF is evaluated in a perturbed frame given in
//! the coordinates of the original shading frame.
//!
//! A viewing direction above the original surface but below the perturbed
//! one (common at grazing views, along a silhouette) would see a black
//! surface. Instead the perturbation is mirrored about the original
//! normal, (x, y, z) → (−x, −y, z), which always turns it towards the
//! viewer: Mitsuba 3 does so (measured in 3.9.1: its `normalmap` and
//! `bumpmap` evaluate and sample the nested BSDF around the mirrored
//! normal there; see `back_facing_view_mirrors_the_normal`). Rejecting
//! such views instead left Mitsuba's bsdf_spheres scenes darker along the
//! sphere's silhouette.
//!
//! A light direction on one side of the perturbed surface but the other
//! side of the original one is rejected (it would leak light through the
//! surface), as in Mitsuba 3. Viewing directions below the original
//! surface are rejected too, so a one-sided material stays black from
//! behind.
//!
//! Light is also shadowed as in Conty Estevez et al. 2019, "Taming the
//! Shadow Terminator" (and as Mitsuba 3 does): the perturbed normal is
//! treated as the mean of a GGX distribution of roughness α² =
//! min(1, tan²θ_d / 8), θ_d the angle between the perturbed and the
//! original normal, and the light's value is scaled by that distribution's
//! Smith term G1 for the light direction against the original normal. It
//! darkens grazing light smoothly instead of cutting it off at the
//! terminator.

use super::value::Tree;
use super::{BsdfContext, BsdfSample};
use crate::math::Frame;
use crate::Rgb;
use glam::{Vec2, Vec3};

/// A perturbed normal and the direction its frame's first tangent
/// follows, both in the coordinates of the original shading frame.
#[derive(Clone, Copy, Debug)]
pub(super) struct Perturbation {
    /// The perturbed unit normal.
    pub n: Vec3,
    /// Made orthogonal to the normal for the frame's first tangent.
    pub dpdu: Vec3,
}

impl Perturbation {
    /// The frame the nested BSDF is evaluated in for viewing direction
    /// `wo`: the perturbation's, mirrored about the original normal when
    /// `wo` is above the original surface but not above the perturbed one
    /// (see the module notes).
    #[inline]
    pub(super) fn frame(&self, wo: Vec3) -> Frame {
        let n = if wo.z > 0.0 && wo.dot(self.n) <= 0.0 {
            Vec3::new(-self.n.x, -self.n.y, self.n.z)
        } else {
            self.n
        };
        Frame::from_normal_and_tangent(n, self.dpdu)
    }
}

/// A direction on consistent sides of both frames.
#[inline]
fn consistent(wi: Vec3, wi_perturbed: Vec3) -> bool {
    wi.z * wi_perturbed.z > 0.0
}

/// The shadowing term of the perturbation `n` (local) for light from `wi`.
#[inline]
fn terminator_shadowing(n: Vec3, wi: Vec3) -> f32 {
    let tan2 = |c: f32| ((1.0 - c * c) / (c * c)).max(0.0);
    let alpha2 = (0.125 * tan2(n.z)).min(1.0);
    if alpha2 <= 0.0 {
        return 1.0;
    }
    let g = 2.0 / (1.0 + (1.0 + alpha2 * tan2(wi.z)).sqrt());
    if g.is_finite() {
        g
    } else {
        0.0
    }
}

/// A bump or normal map at a vertex: the perturbed frame chosen for the
/// vertex's `wo` (which sees its front) and the nested BSDF's node.
#[derive(Clone, Copy, Debug)]
pub(super) struct PerturbedNode {
    frame: Frame,
    nested: u8,
}

impl PerturbedNode {
    /// The node for the perturbation `p` seen from `wo`, and `wo` in its
    /// frame; `None` where `wo` cannot see the perturbed surface (nothing
    /// scatters).
    #[inline]
    pub(super) fn for_view(p: &Perturbation, wo: Vec3) -> Option<(Self, Vec3)> {
        let frame = p.frame(wo);
        let wo_p = frame.to_local(wo);
        consistent(wo, wo_p).then_some((Self { frame, nested: 0 }, wo_p))
    }

    /// With the nested BSDF's node.
    pub(super) fn with_child(self, nested: u8) -> Self {
        Self { nested, ..self }
    }

    /// `wo` and `wi` in the perturbed frame, where both stay on the sides
    /// of the surface they were on (else no light passes).
    #[inline]
    fn pair(&self, wo: Vec3, wi: Vec3) -> Option<(Vec3, Vec3)> {
        let (wo_p, wi_p) = (self.frame.to_local(wo), self.frame.to_local(wi));
        (consistent(wi, wi_p) && consistent(wo, wo_p)).then_some((wo_p, wi_p))
    }

    /// The nested BSDF's value in the perturbed frame, shadowed.
    pub(super) fn eval(&self, t: &Tree, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> Rgb {
        let Some((wo_p, wi_p)) = self.pair(wo, wi) else {
            return Rgb::ZERO;
        };
        t.eval(self.nested, ctx, wo_p, wi_p) * terminator_shadowing(self.frame.n, wi)
    }

    /// The nested BSDF's density in the perturbed frame.
    pub(super) fn pdf(&self, t: &Tree, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> f32 {
        let Some((wo_p, wi_p)) = self.pair(wo, wi) else {
            return 0.0;
        };
        t.pdf(self.nested, ctx, wo_p, wi_p)
    }

    /// [`PerturbedNode::eval`] and [`PerturbedNode::pdf`] at once.
    pub(super) fn eval_pdf(&self, t: &Tree, ctx: &BsdfContext, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        let Some((wo_p, wi_p)) = self.pair(wo, wi) else {
            return (Rgb::ZERO, 0.0);
        };
        let (f, pdf) = t.eval_pdf(self.nested, ctx, wo_p, wi_p);
        (f * terminator_shadowing(self.frame.n, wi), pdf)
    }

    /// A sample of the nested BSDF in the perturbed frame, returned in the
    /// original frame.
    pub(super) fn sample(
        &self,
        t: &Tree,
        ctx: &BsdfContext,
        wo: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        let frame = self.frame;
        let s = t.sample(self.nested, ctx, frame.to_local(wo), u1, u2)?;
        let wi = frame.to_world(s.wi);
        consistent(wi, s.wi).then(|| BsdfSample {
            wi,
            weight: s.weight * terminator_shadowing(frame.n, wi),
            ..s
        })
    }
}
