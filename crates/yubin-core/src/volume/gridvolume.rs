//! `gridvolume`: a voxel grid of one or three channels read from
//! Mitsuba's binary `.vol` file (Mitsuba 3's `gridvolume`): values sit at
//! voxel centres and are interpolated trilinearly (or taken from the
//! nearest voxel); beyond the outermost centres the voxel indices wrap by
//! `wrap_mode`.
//!
//! | parameter       | type      | default   | meaning                                                   |
//! |-----------------|-----------|-----------|-----------------------------------------------------------|
//! | `filename`      | string    | —         | the `.vol` file (format version 3, float32, 1 or 3 channels; 6 for an `sggx` phase function's `S`) |
//! | `to_world`      | transform | identity  | places the grid's box in the world                        |
//! | `use_grid_bbox` | boolean   | false     | the box is the one in the file (else the unit cube [0, 1]³) |
//! | `filter_type`   | string    | trilinear | `trilinear` or `nearest`                                  |
//! | `wrap_mode`     | string    | clamp     | `clamp`, `repeat` or `mirror`                             |
//! | `raw`           | boolean   | false     | accepted (values are never colour-converted here)         |
//!
//! ```xml
//! <volume type="gridvolume" name="sigma_t">
//!     <string name="filename" value="smoke.vol"/>
//!     <transform name="to_world"><scale value="2"/></transform>
//! </volume>
//! ```
//!
//! Every value must be finite and non-negative: a negative density is a
//! load error naming the file and the voxel.

use super::{to_local, Volume};
use crate::math::{Bounds3, Transform};
use crate::medium::Grid;
use crate::params::{ParamError, Params};
use crate::texture::WrapMode;
use crate::Rgb;
use glam::Vec3;
use std::sync::Arc;

/// A grid placed in the world.
#[derive(Clone, Debug, PartialEq)]
pub struct GridVolume {
    /// The voxels (shared between the volumes that read one file).
    pub grid: Arc<Grid>,
    /// Grid space → world.
    pub to_world: Transform,
    /// How voxel indices outside the grid wrap.
    pub wrap: WrapMode,
    /// Nearest-voxel lookup instead of trilinear.
    pub nearest: bool,
}

impl GridVolume {
    /// The value at world point `p`.
    #[inline]
    pub fn eval(&self, p: Vec3) -> Rgb {
        self.grid
            .lookup(to_local(&self.to_world, p), self.wrap, self.nearest)
    }

    /// The six channels at world point `p` (a six-channel grid).
    #[inline]
    pub fn eval6(&self, p: Vec3) -> [f32; 6] {
        self.grid
            .lookup6(to_local(&self.to_world, p), self.wrap, self.nearest)
    }
}

/// Builds the volume from its scene parameters.
pub(super) fn from_params(p: &mut dyn Params) -> Result<Volume, ParamError> {
    let g = placed_grid(p)?;
    if g.grid.channels == 6 {
        return Err(p.param_error(
            "filename",
            "has 6 channels: only an sggx phase function's S takes a 6-channel grid",
        ));
    }
    if let Err(e) = g.grid.check_non_negative() {
        let file = p.string("filename")?.unwrap_or_default();
        return Err(p.param_error("filename", &format!("{file}: {e}")));
    }
    Ok(Volume::Grid(g))
}

/// The grid of a `gridvolume`'s parameters, placed in the world, of any
/// channel count and sign.
pub fn placed_grid(p: &mut dyn Params) -> Result<GridVolume, ParamError> {
    let Some(grid) = p.grid_file("filename")? else {
        return Err(p.error("needs a \"filename\""));
    };
    let use_grid_bbox = p.boolean_or("use_grid_bbox", false)?;
    let nearest = p.choice("filter_type", &["trilinear", "nearest"])? == 1;
    let wrap = match p.choice("wrap_mode", &["clamp", "repeat", "mirror"])? {
        0 => WrapMode::Clamp,
        1 => WrapMode::Repeat,
        _ => WrapMode::Mirror,
    };
    p.boolean_or("raw", false)?;
    p.mark_ignored("accel");
    let to_world = p.transform_or_identity("to_world")?;
    let grid = if use_grid_bbox || grid.bounds == unit_cube() {
        grid
    } else {
        let mut g = (*grid).clone();
        g.bounds = unit_cube();
        Arc::new(g)
    };
    Ok(GridVolume {
        grid,
        to_world,
        wrap,
        nearest,
    })
}

fn unit_cube() -> Bounds3 {
    Bounds3 {
        min: Vec3::ZERO,
        max: Vec3::ONE,
    }
}
