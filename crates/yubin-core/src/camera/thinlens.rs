//! `thinlens`: a perspective camera with a thin lens, for depth of field
//! (Mitsuba 3's).
//!
//! | parameter         | type      | default | meaning                                              |
//! |-------------------|-----------|---------|------------------------------------------------------|
//! | `aperture_radius` | float     | —       | radius of the lens (scene units); required, as in Mitsuba |
//! | `focus_distance`  | float     | —       | distance from the lens to the plane in focus (scene units); default: the `lookat` target's distance |
//! | `fov`, `fov_axis`, `focal_length` | | | as `perspective`                                   |
//! | `near_clip`, `far_clip`, `to_world` | | | as `perspective`                                 |
//!
//! ```xml
//! <sensor type="thinlens">
//!     <float name="fov" value="40"/>
//!     <float name="aperture_radius" value="0.1"/>
//!     <float name="focus_distance" value="5"/>
//!     <transform name="to_world"><lookat origin="0,1,6" target="0,0,0" up="0,1,0"/></transform>
//! </sensor>
//! ```
//!
//! Rays start at a point of the lens disk (Shirley and Chiu's concentric
//! mapping of the aperture sample, as Mitsuba's) and pass through the
//! point that the film position's pinhole ray reaches on the plane in
//! focus (Pharr et al., *Physically Based Rendering*, §5.2.3); with
//! `aperture_radius` 0 the camera is `perspective`. Mitsuba 3 defaults
//! `focus_distance` to 0, which blurs everything; yubin focuses on the
//! `lookat` target instead and asks for the distance when there is none.
//! `ptracer` connects to the lens as the camera samples it.

use super::{focus_or_target, rigid_to_world, Aperture, Perspective};
use crate::params::{ParamError, Params};

/// Builds the camera (a [`Perspective`] with a round lens).
pub fn from_params(p: &mut dyn Params, size: [u32; 2]) -> Result<Perspective, ParamError> {
    let pinhole = Perspective::from_params(p, size)?;
    let radius = p
        .float("aperture_radius")?
        .ok_or_else(|| p.error("needs \"aperture_radius\""))?;
    if !(radius >= 0.0 && radius.is_finite()) {
        return Err(p.param_error("aperture_radius", &format!("must be >= 0, not {radius}")));
    }
    let rigid = rigid_to_world(p)?;
    let focus = focus_or_target(p, rigid)?;
    Ok(pinhole.with_lens(Aperture::disk(radius, focus)))
}
