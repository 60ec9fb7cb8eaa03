//! `bumpmap`: perturbs the shading normal by the gradient of a height
//! texture, then evaluates a nested BSDF in that frame.
//!
//! | parameter | type    | default    | meaning                                         |
//! |-----------|---------|------------|-------------------------------------------------|
//! | (texture) | texture | (required) | height h(u, v), any name (load bitmaps `raw`)    |
//! | `scale`   | float   | 1          | multiplies the height gradient                  |
//! | (nested)  | bsdf    | (required) | the material whose frame is perturbed           |
//!
//! ```xml
//! <bsdf type="bumpmap">
//!     <texture name="height" type="bitmap">
//!         <boolean name="raw" value="true"/>
//!         <string name="filename" value="textures/bumps.png"/>
//!     </texture>
//!     <float name="scale" value="0.02"/>
//!     <bsdf type="diffuse"/>
//! </bsdf>
//! ```
//!
//! The displaced surface p + h·n has tangents whose components along the
//! shading normal n are replaced by the height's derivatives,
//! ∂p'/∂u = ∂p/∂u − n (n·∂p/∂u) + n ∂h/∂u (and the same for v); the new
//! normal is their cross product, turned to the side of the geometric
//! normal (Blinn 1978, "Simulation of wrinkled surfaces"; pbrt-v4 §10.5.2
//! with the dn/du terms dropped). Light on opposite sides of the original
//! and the perturbed surface is rejected; a view below the perturbed
//! surface mirrors the perturbation (see `perturbed.rs`). Mitsuba 3's
//! `bumpmap`.

use super::perturbed::Perturbation;
use super::BsdfFlags;
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ParamError, Params};
use crate::texture::Tex;
use glam::Vec3;

/// A bump-mapped BSDF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BumpMap {
    /// The height texture (by index).
    pub height: u32,
    /// Gradient scale.
    pub scale: f32,
    /// The nested BSDF, by index.
    pub nested: u32,
}

impl BumpMap {
    /// Builds the BSDF from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let scale = p.float_or("scale", 1.0)?;
        if !scale.is_finite() {
            return Err(p.param_error("scale", "must be a finite number"));
        }
        let height = match p.nested_textures()?.as_slice() {
            [Tex::Texture(t)] => *t,
            kids => {
                return Err(p.error(&format!(
                    "needs exactly one nested height texture, found {}",
                    kids.len()
                )))
            }
        };
        match p.bsdfs()?.as_slice() {
            [(nested, _)] => Ok(Self {
                height,
                scale,
                nested: *nested,
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
        let (_, grad) = Tex::Texture(self.height).eval_1_grad(m, si);
        let grad = grad * self.scale;
        let n = si.sh_frame.n;
        let dpdu = si.dpdu + n * (grad.x - n.dot(si.dpdu));
        let dpdv = si.dpdv + n * (grad.y - n.dot(si.dpdv));
        let Some(mut np) = dpdu.cross(dpdv).try_normalize() else {
            return Perturbation {
                n: Vec3::Z,
                dpdu: si.to_local(si.dpdu),
            };
        };
        if np.dot(si.n) < 0.0 {
            np = -np;
        }
        Perturbation {
            n: si.to_local(np),
            dpdu: si.to_local(dpdu),
        }
    }
}

impl BumpMap {
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
    use crate::bsdf::Material;
    use crate::texture::image::ImageData;
    use crate::texture::{Bitmap, FilterType, TexImage, Texture, WrapMode};
    use crate::Rgb;

    /// A diffuse surface bumped by a ramp h = slope · u (over one tile).
    fn ramp(slope: f32) -> Variant {
        let mut v = Variant::last(
            format!("bumpmap (ramp {slope})"),
            vec![
                Material::Diffuse(Diffuse::new(Rgb::new(0.6, 0.6, 0.6))),
                Material::BumpMap(BumpMap {
                    height: 0,
                    scale: slope,
                    nested: 0,
                }),
            ],
        );
        push_ramp_height(&mut v.m);
        v
    }

    /// Adds texture 0 (the first image): the height h = u over one tile.
    pub(crate) fn push_ramp_height(m: &mut Materials) {
        m.images.push(
            TexImage::new(4, 1, 1, ImageData::F32(vec![0.0, 0.25, 0.5, 0.75]), false).unwrap(),
        );
        m.textures.push(Texture::Bitmap(Bitmap {
            image: 0,
            filter: FilterType::Bilinear,
            wrap: [WrapMode::Clamp; 2],
            raw: true,
            to_uv: glam::Affine2::IDENTITY,
        }));
    }

    /// Configurations for the table-driven tests in `bsdf/mod.rs`.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let mut tilted = ramp(0.5);
        tilted.reciprocal = false;
        vec![ramp(0.0), tilted]
    }

    #[test]
    fn ramp_tilts_the_normal_against_the_slope() {
        // h = u (gradient 1 per unit u, dp/du = x): the surface rises
        // towards +x, so its normal leans towards -x.
        let v = ramp(1.0);
        let b = match v.m.bsdfs[1] {
            Material::BumpMap(b) => b,
            _ => unreachable!(),
        };
        let f = b.perturbation(&v.m, &flat_si());
        assert!(
            (f.n - Vec3::new(-1.0, 0.0, 1.0).normalize()).length() < 1e-4,
            "{}",
            f.n
        );
    }
}
