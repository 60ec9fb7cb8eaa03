//! `normalmap`: replaces the shading normal with one read from a tangent-
//! space normal map, then evaluates a nested BSDF in that frame.
//!
//! | parameter   | type    | default    | meaning                                              |
//! |-------------|---------|------------|------------------------------------------------------|
//! | `normalmap` | texture | (required) | tangent-space normals encoded as rgb = (n + 1) / 2 (load it with `raw`) |
//! | (nested)    | bsdf    | (required) | the material whose frame is perturbed                |
//!
//! ```xml
//! <bsdf type="normalmap">
//!     <texture name="normalmap" type="bitmap">
//!         <boolean name="raw" value="true"/>
//!         <string name="filename" value="textures/normalmap.jpg"/>
//!     </texture>
//!     <bsdf type="roughplastic"/>
//! </bsdf>
//! ```
//!
//! The map's x, y and z are the shading frame's tangent (along ∂p/∂u,
//! made orthogonal to the normal), bitangent and normal; the perturbed
//! tangent is ∂p/∂u made orthogonal to the new normal. Light on opposite
//! sides of the original and the perturbed surface is rejected. Mitsuba 3's
//! `normalmap`; the tangent-space convention is the common one of normal
//! maps baked for ∂p/∂u-aligned tangents (Cohen et al. 1998, "Appearance-
//! preserving simplification").

use super::perturbed;
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::math::Frame;
use crate::params::{ColorKind, ParamError, Params};
use crate::texture::Tex;
use glam::Vec3;

/// A normal-mapped BSDF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalMap {
    /// Encoded tangent-space normals.
    pub normalmap: Tex,
    /// The nested BSDF, by index.
    pub nested: u32,
}

impl NormalMap {
    /// Builds the BSDF from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let normalmap = p
            .texture("normalmap", ColorKind::Unbounded)?
            .ok_or_else(|| p.error("needs a \"normalmap\" texture"))?;
        match p.bsdfs()?.as_slice() {
            [(nested, _)] => Ok(Self {
                normalmap,
                nested: *nested,
            }),
            kids => Err(p.error(&format!(
                "needs exactly one nested BSDF, found {}",
                kids.len()
            ))),
        }
    }

    /// The perturbed frame in the coordinates of the shading frame.
    #[inline]
    fn frame(&self, m: &Materials, si: &SurfaceInteraction) -> Frame {
        let n = (self.normalmap.eval(m, si) * 2.0 - Vec3::ONE)
            .try_normalize()
            .unwrap_or(Vec3::Z);
        Frame::from_normal_and_tangent(n, si.to_local(si.dpdu))
    }
}

perturbed::perturbed_bsdf!(NormalMap);

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::tests::{flat_si, Variant};
    use crate::bsdf::Diffuse;
    use crate::bsdf::{Bsdf, BsdfContext, BsdfModel};
    use crate::Rgb;

    fn tilted(n: Vec3) -> Vec<Bsdf> {
        vec![
            Bsdf::Diffuse(Diffuse::new(Rgb::new(0.7, 0.5, 0.3))),
            Bsdf::NormalMap(NormalMap {
                normalmap: Tex::Const((n.normalize() + Vec3::ONE) * 0.5),
                nested: 0,
            }),
        ]
    }

    /// Configurations for the table-driven tests in `bsdf/mod.rs`.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let mut tilt = Variant::last("normalmap (tilted)", tilted(Vec3::new(0.4, -0.2, 0.9)));
        tilt.reciprocal = false;
        vec![Variant::last("normalmap (flat)", tilted(Vec3::Z)), tilt]
    }

    #[test]
    fn flat_map_is_the_nested_bsdf() {
        let m = Materials::with_bsdfs(tilted(Vec3::Z));
        let (si, ctx) = (flat_si(), BsdfContext::default());
        let (wo, wi) = (
            Vec3::new(0.3, 0.1, 0.9).normalize(),
            Vec3::new(-0.5, 0.2, 0.7).normalize(),
        );
        let a = m.bsdfs[1].eval(&m, &ctx, &si, wo, wi);
        let b = m.bsdfs[0].eval(&m, &ctx, &si, wo, wi);
        assert!((a - b).abs().max_element() < 1e-5, "{a} vs {b}");
    }

    #[test]
    fn tilted_normal_follows_the_map() {
        // A map tilted towards +x: light from +x is brighter than from -x.
        let m = Materials::with_bsdfs(tilted(Vec3::new(0.5, 0.0, 0.8)));
        let (si, ctx) = (flat_si(), BsdfContext::default());
        let wo = Vec3::Z;
        let from = |x: f32| m.bsdfs[1].eval(&m, &ctx, &si, wo, Vec3::new(x, 0.0, 0.6).normalize());
        assert!(from(0.8).x > 1.5 * from(-0.8).x);
    }
}
