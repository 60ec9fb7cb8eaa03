//! `normalmap`: replaces the shading normal with one read from a tangent-
//! space normal map, then evaluates a nested BSDF in that frame.
//!
//! | parameter   | type    | default    | meaning                                              |
//! |-------------|---------|------------|------------------------------------------------------|
//! | `normalmap` | texture | (required) | tangent-space normals encoded as rgb = (n + 1) / 2 (load it with `raw`) |
//! | `tangent_space` | string | `dpdu` | `dpdu` (Mitsuba 3) or `mikktspace` (maps baked by Blender, Substance, glTF) |
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
//! sides of the original and the perturbed surface is rejected; a view
//! below the perturbed surface mirrors the perturbation (see
//! `perturbed.rs`). Mitsuba 3's
//! `normalmap`; the tangent-space convention is the common one of normal
//! maps baked for ∂p/∂u-aligned tangents (Cohen et al. 1998, "Appearance-
//! preserving simplification").
//!
//! `tangent_space="mikktspace"` reads the map in MikkTSpace (Mikkelsen
//! 2008) instead, the frame that baking tools and glTF use: x along the
//! mesh's interpolated per-vertex tangent made orthogonal to the shading
//! normal, y along sign · n × tangent. Meshes under such a BSDF get their
//! tangents computed at load (`shape/mesh.rs`); a mesh without uvs has
//! none and is an error. On analytic shapes ∂p/∂u is already a smooth
//! tangent and is used as with `dpdu`. On a mesh with a uniform uv mapping
//! the two agree.

use super::perturbed::Perturbation;
use super::BsdfFlags;
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
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
    /// Read the map in MikkTSpace (else in the ∂p/∂u frame).
    pub mikktspace: bool,
}

impl NormalMap {
    /// Builds the BSDF from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let normalmap = p
            .texture("normalmap", ColorKind::Unbounded)?
            .ok_or_else(|| p.error("needs a \"normalmap\" texture"))?;
        let mikktspace = p.choice("tangent_space", &["dpdu", "mikktspace"])? == 1;
        match p.bsdfs()?.as_slice() {
            [(nested, _)] => Ok(Self {
                normalmap,
                nested: *nested,
                mikktspace,
            }),
            kids => Err(p.error(&format!(
                "needs exactly one nested BSDF, found {}",
                kids.len()
            ))),
        }
    }

    /// The perturbed normal in the coordinates of the shading frame.
    #[inline]
    pub(super) fn perturbation(&self, m: &Materials, si: &SurfaceInteraction) -> Perturbation {
        let n = (self.normalmap.eval(m, si) * 2.0 - Vec3::ONE)
            .try_normalize()
            .unwrap_or(Vec3::Z);
        if self.mikktspace && si.tangent.w != 0.0 {
            return mikktspace_perturbation(n, si);
        }
        Perturbation {
            n,
            dpdu: si.to_local(si.dpdu),
        }
    }
}

/// The map's normal `n` read in the MikkTSpace frame of the hit: tangent
/// made orthogonal to the shading normal, bitangent sign · normal ×
/// tangent (both in shading-frame coordinates).
fn mikktspace_perturbation(n: Vec3, si: &SurfaceInteraction) -> Perturbation {
    let t = si.to_local(si.tangent.truncate());
    let Some(t) = Vec3::new(t.x, t.y, 0.0).try_normalize() else {
        return Perturbation {
            n,
            dpdu: si.to_local(si.dpdu),
        };
    };
    let b = Vec3::Z.cross(t) * si.tangent.w.signum();
    Perturbation {
        n: (t * n.x + b * n.y + Vec3::Z * n.z).normalize(),
        dpdu: t,
    }
}

impl NormalMap {
    /// Lobes this material has: the nested BSDF's.
    pub fn flags(&self, m: &Materials) -> BsdfFlags {
        m.bsdfs[self.nested as usize].flags(m)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::tests::{flat_si, Variant};
    use crate::bsdf::Diffuse;
    use crate::bsdf::{BsdfContext, BsdfModel, Material};
    use crate::Rgb;

    fn tilted(n: Vec3) -> Vec<Material> {
        vec![
            Material::Diffuse(Diffuse::new(Rgb::new(0.7, 0.5, 0.3))),
            Material::NormalMap(NormalMap {
                normalmap: Tex::Const((n.normalize() + Vec3::ONE) * 0.5),
                nested: 0,
                mikktspace: false,
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
    fn back_facing_view_mirrors_the_normal() {
        // Map normal (0.6, 0, 0.8) on a flat interaction, diffuse
        // reflectance (0.7, 0.5, 0.3). From wo ∝ (-0.9, 0, 0.436) the view
        // is below the perturbed surface, so the normal is mirrored to
        // (-0.6, 0, 0.8); from wo ∝ (0.5, 0, 0.5) it is kept. Expected
        // values from Mitsuba 3.9.1 (scalar_rgb): `normalmap` over
        // `diffuse`, the map a 2×2 `raw` float bitmap, `eval` and `pdf` on
        // a SurfaceInteraction3f with n = z, sh_frame = identity,
        // dp_du = x, dp_dv = y.
        let m = Materials::with_bsdfs(tilted(Vec3::new(0.6, 0.0, 0.8)));
        let (si, ctx) = (flat_si(), BsdfContext::default());
        let d = |x: f32, y: f32, z: f32| Vec3::new(x, y, z).normalize();
        let (wo_back, wo_front) = (d(-0.9, 0.0, 0.436), d(0.5, 0.0, 0.5));
        let (left, right, grazing) = (d(-0.5, 0.2, 0.7), d(0.5, 0.2, 0.7), d(0.9, 0.0, 0.1));
        let bright = (Rgb::new(0.214758, 0.153399, 0.0920393), 0.309_956_9);
        let dim = (Rgb::new(0.064927, 0.0463764, 0.0278258), 0.093_707_89);
        let cases = [
            (wo_back, left, bright),
            (wo_back, right, dim),
            (wo_back, grazing, (Rgb::ZERO, 0.0)),
            (wo_front, left, dim),
            (wo_front, right, bright),
            (
                wo_front,
                grazing,
                (Rgb::new(0.0850487, 0.060749, 0.0364494), 0.217_939),
            ),
        ];
        for (wo, wi, (f, pdf)) in cases {
            let got = m.bsdfs[1].eval(&m, &ctx, &si, wo, wi);
            assert!(
                (got - f).abs().max_element() < 1e-5,
                "{wo} {wi}: {got} vs {f}"
            );
            let got = m.bsdfs[1].pdf(&m, &ctx, &si, wo, wi);
            assert!((got - pdf).abs() < 1e-5, "{wo} {wi}: pdf {got} vs {pdf}");
        }
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

    #[test]
    fn mikktspace_frame_follows_the_tangent_and_its_sign() {
        let map = Vec3::new(0.5, 0.3, 0.8);
        let dpdu_mode = Materials::with_bsdfs(tilted(map));
        let mirrored = Materials::with_bsdfs(tilted(map * Vec3::new(1.0, -1.0, 1.0)));
        let mut mikk = tilted(map);
        if let Material::NormalMap(n) = &mut mikk[1] {
            n.mikktspace = true;
        }
        let mikk = Materials::with_bsdfs(mikk);
        let ctx = BsdfContext::default();
        let (wo, wi) = (
            Vec3::new(0.3, 0.1, 0.9).normalize(),
            Vec3::new(-0.5, 0.4, 0.7).normalize(),
        );
        let eval = |m: &Materials, si: &SurfaceInteraction| m.bsdfs[1].eval(m, &ctx, si, wo, wi);
        let close = |a: crate::Rgb, b: crate::Rgb| (a - b).abs().max_element() < 1e-5;
        // Tangent along ∂p/∂u (x; not unit, not quite in the plane), sign
        // +1: the same frame as `dpdu`; sign −1 flips the map's y.
        let along = |w: f32| SurfaceInteraction {
            tangent: glam::Vec4::new(2.0, 0.0, 0.3, w),
            ..flat_si()
        };
        assert!(close(
            eval(&mikk, &along(1.0)),
            eval(&dpdu_mode, &flat_si())
        ));
        assert!(close(
            eval(&mikk, &along(-1.0)),
            eval(&mirrored, &flat_si())
        ));
        assert!(!close(eval(&mikk, &along(1.0)), eval(&mikk, &along(-1.0))));
        // Without a tangent (analytic shapes), ∂p/∂u.
        assert!(close(eval(&mikk, &flat_si()), eval(&dpdu_mode, &flat_si())));
    }
}
