//! `pyroclastic`: seed 003's procedural cloud as a volume — a sphere
//! pushed outwards along each direction by the magnitude of fBm noise on
//! the unit sphere (Ebert et al., *Texturing and Modeling: A Procedural
//! Approach*; Wrenninge, *Production Volume Rendering*, 2012), full inside
//! and fading to zero over a soft shell. Usable wherever a volume is
//! (typically a `heterogeneous` medium's `sigma_t`, with `scale` setting
//! the density).
//!
//! | parameter   | type      | default  | meaning                                                   |
//! |-------------|-----------|----------|-----------------------------------------------------------|
//! | `center`    | point     | 0, 0, 0  | centre of the sphere                                      |
//! | `radius`    | float     | 1        | radius of the undisplaced sphere                          |
//! | `amplitude` | float     | 0.3      | displacement of one noise unit (the units of `radius`)    |
//! | `octaves`   | integer   | 4        | octaves of fBm (1–16)                                     |
//! | `frequency` | float     | 2        | frequency of the first octave on the unit sphere          |
//! | `edge`      | float     | 0.05     | thickness of the soft shell, as a fraction of `radius`    |
//! | `value`     | float     | 1        | the value inside the cloud                                |
//! | `seed`      | integer   | 0        | picks the noise                                           |
//! | `to_world`  | transform | identity | places the cloud                                          |
//!
//! ```xml
//! <volume type="pyroclastic" name="sigma_t">
//!     <float name="radius" value="0.6"/>
//!     <float name="amplitude" value="0.35"/>
//!     <integer name="octaves" value="5"/>
//!     <integer name="seed" value="7"/>
//! </volume>
//! ```

use super::{to_local, Volume};
use crate::math::{Bounds3, Transform};
use crate::medium::Pyroclastic;
use crate::params::{ParamError, Params};
use crate::Rgb;
use glam::Vec3;

/// A pyroclastic cloud placed in the world.
#[derive(Clone, Debug, PartialEq)]
pub struct PyroclasticVolume {
    /// The density in the cloud's own space.
    pub cloud: Pyroclastic,
    /// Cloud space → world.
    pub to_world: Transform,
}

impl PyroclasticVolume {
    /// The value at world point `p`.
    #[inline]
    pub fn eval(&self, p: Vec3) -> Rgb {
        Rgb::splat(self.cloud.eval(to_local(&self.to_world, p)))
    }

    /// The largest value.
    pub fn max(&self) -> f32 {
        self.cloud.density
    }

    /// The box around the cloud's bounding sphere, in its own space.
    pub fn local_bounds(&self) -> Bounds3 {
        let r = Vec3::splat(self.cloud.bounding_radius());
        Bounds3 {
            min: self.cloud.center - r,
            max: self.cloud.center + r,
        }
    }
}

/// Builds the volume from its scene parameters.
pub(super) fn from_params(p: &mut dyn Params) -> Result<Volume, ParamError> {
    let center = p.point("center")?.unwrap_or(Vec3::ZERO);
    let radius = p.positive_float_or("radius", 1.0)?;
    let amplitude = p.float_or("amplitude", 0.3)?;
    if !(amplitude >= 0.0 && amplitude.is_finite()) {
        return Err(p.param_error("amplitude", &format!("must be 0 or more, not {amplitude}")));
    }
    let octaves = p.positive_integer_or("octaves", 4)?;
    if octaves > 16 {
        return Err(p.param_error("octaves", &format!("must be 1 to 16, not {octaves}")));
    }
    let frequency = p.positive_float_or("frequency", 2.0)?;
    let edge = p.positive_float_or("edge", 0.05)?;
    let value = p.float_or("value", 1.0)?;
    if !(value >= 0.0 && value.is_finite()) {
        return Err(p.param_error("value", &format!("must be 0 or more, not {value}")));
    }
    let seed = p.integer_or("seed", 0)?;
    let seed = u32::try_from(seed)
        .map_err(|_| p.param_error("seed", &format!("must be 0 or more, not {seed}")))?;
    let to_world = p.transform_or_identity("to_world")?;
    Ok(Volume::Pyroclastic(PyroclasticVolume {
        cloud: Pyroclastic::new(
            center, radius, amplitude, octaves, frequency, value, edge, seed,
        ),
        to_world,
    }))
}
