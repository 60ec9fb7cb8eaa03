//! `twosided`: makes a one-sided BSDF scatter on both sides.
//!
//! | child  | type | meaning                                               |
//! |--------|------|-------------------------------------------------------|
//! | first  | bsdf | used on the front side                                |
//! | second | bsdf | used on the back side (optional; defaults to the first)|
//!
//! ```xml
//! <bsdf type="twosided"><bsdf type="diffuse"/></bsdf>
//! ```
//!
//! When `wo` is below the surface, both directions are mirrored through
//! the tangent plane and the back BSDF is used.

use super::{BsdfFlags, Material};
use crate::material::Materials;
use crate::params::{ParamError, Params};
use glam::Vec3;

/// Front and back BSDFs, by index in the scene's BSDF table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TwoSided {
    /// Front-side BSDF.
    pub front: u32,
    /// Back-side BSDF.
    pub back: u32,
}

/// `w` mirrored about the surface.
#[inline]
pub(super) fn mirror(w: Vec3) -> Vec3 {
    Vec3::new(w.x, w.y, -w.z)
}

impl TwoSided {
    /// Builds the BSDF from its nested BSDFs (one for both sides, or front
    /// and back).
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let kids = p.bsdfs()?;
        if kids.iter().any(|(_, b)| matches!(b, Material::TwoSided(_))) {
            return Err(p.error("a twosided BSDF cannot contain another twosided BSDF"));
        }
        match kids.as_slice() {
            [(f, _)] => Ok(Self {
                front: *f,
                back: *f,
            }),
            [(f, _), (b, _)] => Ok(Self {
                front: *f,
                back: *b,
            }),
            _ => Err(p.error(&format!(
                "twosided needs one or two nested BSDFs, found {}",
                kids.len()
            ))),
        }
    }

    /// The BSDF for `wo`'s side, and whether it is the back.
    pub(super) fn side(&self, wo: Vec3) -> (u32, bool) {
        if wo.z >= 0.0 {
            (self.front, false)
        } else {
            (self.back, true)
        }
    }
}

impl TwoSided {
    /// Lobes this material has.
    pub fn flags(&self, m: &Materials) -> BsdfFlags {
        let f = m.bsdfs[self.front as usize].flags(m) | m.bsdfs[self.back as usize].flags(m);
        f | BsdfFlags::FRONT_SIDE | BsdfFlags::BACK_SIDE
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::tests::{albedo, check_bsdf, check_reciprocity, Variant};
    use crate::bsdf::Diffuse;
    use crate::Rgb;

    fn table() -> Materials {
        Materials::with_bsdfs(vec![
            Material::Diffuse(Diffuse::new(Rgb::new(0.8, 0.4, 0.2))),
            Material::Diffuse(Diffuse::new(Rgb::new(0.1, 0.9, 0.3))),
            Material::TwoSided(TwoSided { front: 0, back: 1 }),
        ])
    }

    #[test]
    fn chi2_twosided_both_sides() {
        let t = table();
        check_bsdf(&t, 2, Vec3::new(0.2, 0.1, 0.9).normalize());
        check_bsdf(&t, 2, Vec3::new(0.2, 0.1, -0.9).normalize());
        check_reciprocity(&t, 2);
    }

    #[test]
    fn back_side_uses_back_bsdf() {
        let t = table();
        let a = albedo(&t, 2, Vec3::new(0.0, 0.3, -0.8).normalize());
        assert!(
            (a - Rgb::new(0.1, 0.9, 0.3)).abs().max_element() < 1e-5,
            "{a}"
        );
    }

    /// Configurations for the table-driven tests in `bsdf/mod.rs`.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let mut white = Variant::last(
            "twosided (white diffuse)",
            vec![
                Material::Diffuse(Diffuse::new(Rgb::ONE)),
                Material::TwoSided(TwoSided { front: 0, back: 0 }),
            ],
        );
        white.lossless = true;
        let t = table();
        vec![
            Variant {
                name: "twosided (two diffuse)".into(),
                m: t,
                id: 2,
                lossless: false,
                reciprocal: true,
                energy_conserving: true,
            },
            white,
        ]
    }
}
