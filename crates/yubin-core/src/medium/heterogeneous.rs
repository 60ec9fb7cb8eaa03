//! `heterogeneous`: a participating medium whose extinction varies through
//! space, read from a volume (Mitsuba 3's `heterogeneous`): smoke, clouds,
//! fire. Free flights are sampled by delta tracking and shadow rays
//! estimate transmittance by ratio tracking (Novák et al. 2014), both
//! against a majorant grid (a coarse grid of the largest extinction in each
//! cell, walked by a DDA; pbrt-v4, Mitsuba 3) so that thin and empty parts
//! cost little. A tentative collision is real with the path's hero
//! channel's probability σ_t,h / μ and null otherwise; in a chromatic
//! medium the other channels' probabilities enter the path's spectral MIS
//! (Miller et al. 2019's null-scattering formulation; see `volpath`).
//!
//! | parameter         | type             | default   | meaning                                                        |
//! |-------------------|------------------|-----------|----------------------------------------------------------------|
//! | `sigma_t`         | float/rgb/volume | 1         | extinction coefficient per unit length (before `scale`)        |
//! | `albedo`          | float/rgb/volume | 0.75      | single-scattering albedo σ_s / σ_t                             |
//! | `scale`           | float            | 1         | multiplies `sigma_t`                                           |
//! | `radiance`        | float/rgb/volume | none      | emitted radiance per unit σ_a (an emissive medium; yubin)      |
//! | `sample_emitters` | boolean          | true      | next-event estimation at scattering points                     |
//! | `majorant_resolution_factor` | integer | 4    | majorant grid cells are this many voxels of a `gridvolume` `sigma_t` wide; 0: one majorant for the whole volume |
//! | `majorant_factor` | float            | 1.01      | accepted (the majorants here are exact bounds)                 |
//! | `has_spectral_extinction` | boolean  | true      | accepted: extinction is always per channel here                |
//! | (child)           | phase            | isotropic | the phase function                                             |
//!
//! ```xml
//! <medium type="heterogeneous" id="smoke">
//!     <volume type="gridvolume" name="sigma_t"><string name="filename" value="smoke.vol"/></volume>
//!     <rgb name="albedo" value="0.9"/>
//!     <float name="scale" value="20"/>
//! </medium>
//! ```
//!
//! The medium is empty outside the bounding box of its `sigma_t` volume (as
//! in Mitsuba). A constant `sigma_t` (a number, a colour or a
//! `constvolume`) fills the unit cube [0, 1]³ through the `constvolume`'s
//! `to_world`, as Mitsuba 3.9.1's does (measured: σ_t = 1 in a cube
//! [−1, 1]³ transmits e^−1 along z through x = y = 0.5 and 1 through x =
//! y = −0.5): give the `constvolume` a `to_world` that covers the medium's
//! shapes. A `gridvolume` with `wrap_mode` other than `clamp` takes one
//! majorant for its whole box (its wrapped border voxels would cross cells).

use super::{common_params, Heterogeneous, MajorantGrid, Majorants, Medium};
use crate::math::{Bounds3, Transform};
use crate::params::{ColorKind, Family, ParamError, Params};
use crate::texture::WrapMode;
use crate::volume::{volume_param, Volume};
use crate::Rgb;
use std::sync::Arc;

/// Builds the medium from its scene parameters.
pub(super) fn from_params(p: &mut dyn Params) -> Result<Medium, ParamError> {
    let common = common_params(p)?;
    let const_to_world = match p.named_child(Family::Volume, "sigma_t")? {
        Some(mut c) if c.plugin_type() == "constvolume" => c.transform_or_identity("to_world")?,
        _ => Transform::IDENTITY,
    };
    let sigma_t = volume_param(p, "sigma_t", ColorKind::Unbounded, Rgb::ONE)?;
    if let Volume::Const(v) = sigma_t {
        if !(v.is_finite() && v.min_element() >= 0.0) {
            return Err(p.param_error("sigma_t", &format!("must be 0 or more, not {v}")));
        }
    }
    let factor = p.integer_or("majorant_resolution_factor", 4)?;
    let factor = u32::try_from(factor).map_err(|_| {
        p.param_error(
            "majorant_resolution_factor",
            &format!("must be 0 or more, not {factor}"),
        )
    })?;
    p.float_or("majorant_factor", 1.01)?;
    // An sggx phase function multiplies the extinction by up to its
    // largest projected area (see `sggx`: Mitsuba leaves the majorant).
    let along = common.phase.max_projected_area().max(1.0);
    let extent = match sigma_t {
        // Mitsuba's constvolume has the box of a volume: the unit cube.
        Volume::Const(_) => Some((
            const_to_world,
            Bounds3 {
                min: glam::Vec3::ZERO,
                max: glam::Vec3::ONE,
            },
        )),
        _ => sigma_t.extent(),
    };
    let majorants = majorants(&sigma_t, extent, common.scale * along, factor);
    Ok(Medium::Heterogeneous(Heterogeneous {
        sigma_t,
        majorants,
        common,
    }))
}

/// The majorants of extinction `sigma_t` × `scale`, empty outside
/// `extent`.
fn majorants(
    sigma_t: &Volume,
    extent: Option<(Transform, Bounds3)>,
    scale: f32,
    factor: u32,
) -> Majorants {
    match sigma_t {
        Volume::Grid(g) if factor > 0 && g.wrap == WrapMode::Clamp => {
            let res = g.grid.res.map(|r| r.div_ceil(factor));
            Majorants::Grid {
                grid: Arc::new(MajorantGrid::new(&g.grid, res)),
                to_world: g.to_world,
                scale,
            }
        }
        _ => Majorants::Uniform {
            value: sigma_t.max() * scale,
            extent,
        },
    }
}
