//! `volume`: a volume read as a surface texture (Mitsuba 3's `volume`
//! texture): the volume's value at the world-space point of the hit.
//!
//! | parameter | type   | default | meaning |
//! |-----------|--------|---------|---------|
//! | `volume`  | volume | —       | a nested `constvolume`, `gridvolume` (or yubin's `pyroclastic`), placed by its own `to_world` |
//!
//! ```xml
//! <texture type="volume" name="reflectance">
//!     <volume type="gridvolume" name="volume">
//!         <string name="filename" value="ramp.vol"/>
//!         <transform name="to_world"><scale value="2"/><translate value="-1, -1, -1"/></transform>
//!     </volume>
//! </texture>
//! ```
//!
//! The uv coordinates play no part. Read as one value, a colour volume
//! gives its luminance (Mitsuba's `eval_1`). As in Mitsuba 3.9.1 the
//! volume must be a nested volume: a float or colour is refused (a
//! constant texture says that better). A grid is read as everywhere else
//! (trilinear, clamped to its edge values outside its box). Bump mapping
//! takes the texture's derivative along the surface by finite differences.
//!
//! Reference: Mitsuba 3 documentation, "Volumetric texture (volume)".

use super::TextureModel;
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{Family, ParamError, Params};
use crate::spectrum::luminance;
use crate::volume::Volume;
use crate::Rgb;
use glam::Vec2;

/// A volume read at the hit point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeTexture {
    /// The volume, interned (so that a texture stays a `Copy` value).
    volume: &'static Volume,
}

impl VolumeTexture {
    /// Builds the texture from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        if let Some(mut child) = p.named_child(Family::Volume, "volume")? {
            return Ok(Self {
                volume: interned(crate::volume::from_params(&mut *child)?),
            });
        }
        Err(p.error(
            "needs a nested volume named \"volume\" (<volume type=\"gridvolume\" name=\"volume\">)",
        ))
    }
}

/// `volume` stored for the program's life, once per content.
fn interned(volume: Volume) -> &'static Volume {
    static INTERNED: std::sync::Mutex<Vec<&'static Volume>> = std::sync::Mutex::new(Vec::new());
    crate::shape::interned(&INTERNED, volume)
}

impl TextureModel for VolumeTexture {
    fn eval(&self, _m: &Materials, si: &SurfaceInteraction) -> Rgb {
        self.volume.eval(si.p)
    }

    fn eval_1_grad(&self, m: &Materials, si: &SurfaceInteraction) -> (f32, Vec2) {
        let f = self.eval_1(m, si);
        // A step of a thousandth of the hit's scale along each tangent.
        let h = 1e-3 * (1.0 + si.p.abs().max_element());
        let along = |dp: glam::Vec3| {
            let len = dp.length();
            if len == 0.0 {
                return 0.0;
            }
            let step = h / len;
            (luminance(self.volume.eval(si.p + dp * step)) - f) / step
        };
        (f, Vec2::new(along(si.dpdu), along(si.dpdv)))
    }

    fn mean(&self, _m: &Materials) -> f32 {
        self.volume.mean_luminance()
    }
}
