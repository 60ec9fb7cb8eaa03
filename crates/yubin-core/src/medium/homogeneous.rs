//! `homogeneous`: a participating medium whose extinction is the same
//! everywhere (Mitsuba 3's `homogeneous`): fog, murky water, wax, milk.
//! Free flights are sampled exactly; in a chromatic medium (σ_t differing
//! between channels) a channel is picked for each flight and the
//! densities are combined by spectral MIS (Miller et al. 2019), so no
//! channel's weight grows without bound. Shadow rays take the exact
//! transmittance e^(−σ_t d).
//!
//! | parameter         | type             | default   | meaning                                                        |
//! |-------------------|------------------|-----------|----------------------------------------------------------------|
//! | `sigma_t`         | float/rgb        | 1         | extinction coefficient per unit length (before `scale`)        |
//! | `albedo`          | float/rgb/volume | 0.75      | single-scattering albedo σ_s / σ_t; a volume makes it vary     |
//! | `scale`           | float            | 1         | multiplies `sigma_t` (changes the units of length)             |
//! | `radiance`        | float/rgb/volume | none      | emitted radiance per unit σ_a (an emissive medium; yubin)      |
//! | `sample_emitters` | boolean          | true      | next-event estimation at scattering points                     |
//! | `has_spectral_extinction` | boolean  | true      | accepted: extinction is always per channel here                |
//! | (child)           | phase            | isotropic | the phase function                                             |
//!
//! ```xml
//! <medium type="homogeneous" id="fog">
//!     <rgb name="sigma_t" value="0.5, 0.8, 1.2"/>
//!     <rgb name="albedo" value="0.9"/>
//!     <float name="scale" value="2"/>
//!     <phase type="hg"><float name="g" value="0.5"/></phase>
//! </medium>
//! <shape type="sphere"><bsdf type="null"/><ref id="fog" name="interior"/></shape>
//! ```
//!
//! An emissive medium (`radiance` L_e) adds σ_a L_e per unit length along
//! every ray through it, σ_a = σ_t (1 − albedo); `volpath` finds it by
//! tracking, not by light sampling.
//!
//! With an `sggx` phase function the extinction along a ray is σ_t σ(ω)
//! (see `sggx`); where its S varies over space the medium is tracked as a
//! heterogeneous one of constant σ_t, so that S is read at every point.

use super::{common_params, Heterogeneous, Homogeneous, Majorants, Medium};
use crate::params::{ColorKind, ParamError, Params};
use crate::phase::PhaseFunction;
use crate::volume::{volume_param, Volume};
use crate::Rgb;

/// Builds the medium from its scene parameters.
pub(super) fn from_params(p: &mut dyn Params) -> Result<Medium, ParamError> {
    let common = common_params(p)?;
    let sigma_t = match volume_param(p, "sigma_t", ColorKind::Unbounded, Rgb::ONE)? {
        Volume::Const(v) => v,
        _ => return Err(p.param_error(
            "sigma_t",
            "must be a number or colour in a homogeneous medium (use heterogeneous for a volume)",
        )),
    };
    if !(sigma_t.is_finite() && sigma_t.min_element() >= 0.0) {
        return Err(p.param_error("sigma_t", &format!("must be 0 or more, not {sigma_t}")));
    }
    if let PhaseFunction::Sggx(field) = common.phase {
        return Ok(Medium::Heterogeneous(Heterogeneous {
            majorants: Majorants::Uniform {
                value: sigma_t.max_element() * common.scale * field.max_projected_area().max(1.0),
                extent: None,
            },
            sigma_t: Volume::Const(sigma_t),
            common,
        }));
    }
    Ok(Medium::Homogeneous(Homogeneous {
        sigma_t: sigma_t * common.scale,
        common,
    }))
}
