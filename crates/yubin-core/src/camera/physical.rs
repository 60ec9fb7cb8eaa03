//! `physical`: a camera described as a photographer would (yubin's;
//! seed 003's "physical camera"): sensor size, focal length and f-stop,
//! with a bladed aperture for shaped bokeh, aperture bias and cat's-eye
//! vignetting.
//!
//! | parameter        | type      | default | meaning                                                         |
//! |------------------|-----------|---------|-----------------------------------------------------------------|
//! | `sensor_width`   | float     | 36      | sensor width (mm)                                               |
//! | `sensor_height`  | float     | 24      | sensor height (mm)                                              |
//! | `focal_length`   | float     | 50      | focal length f (mm)                                             |
//! | `f_stop`         | float     | 5.6     | f-number N (> 0)                                                |
//! | `focus_distance` | float     | —       | distance to the plane in focus (scene units); default: the `lookat` target's |
//! | `blades`         | integer   | 0       | 0: a round aperture; n ≥ 3: a regular n-gon                     |
//! | `blade_rotation` | float     | 0       | rotation of the n-gon (degrees)                                 |
//! | `aperture_bias`  | float     | 0       | in (−1, 1): > 0 moves aperture samples to the rim, < 0 to the centre |
//! | `cats_eye`       | float     | 0       | distance (mm) of a virtual aperture in front of the lens; 0: none |
//! | `scene_unit`     | float     | 1       | metres per scene unit (converts the millimetres)                |
//! | `near_clip`, `far_clip`, `to_world` | | | as `perspective`                                         |
//!
//! ```xml
//! <sensor type="physical">
//!     <float name="focal_length" value="85"/>
//!     <float name="f_stop" value="1.8"/>
//!     <integer name="blades" value="5"/>
//!     <transform name="to_world"><lookat origin="0,1,6" target="0,0.5,0" up="0,1,0"/></transform>
//! </sensor>
//! ```
//!
//! Formulas (seed 003): the field of view across a sensor side s is
//! fov = 2 atan(s / (2 f)), and the aperture radius is f / (2 N)
//! (its diameter is the focal length over the f-number), converted from
//! millimetres to scene units by `scene_unit`. The image is the largest
//! part of the sensor with the film's aspect ratio: when the film is wider
//! than the sensor, its width spans `sensor_width`, else its height spans
//! `sensor_height`. Focus: the plane at `focus_distance` along the view
//! axis, or through the `lookat` target (seed 000 focuses there).
//!
//! Aperture: the lens disk, or an n-gon inscribed in it (`blades`), sampled
//! uniformly and then biased radially: a point at fraction t of the way to
//! the rim moves to t^(1 − `aperture_bias`). Cat's eye: a second aperture,
//! as large as the first, `cats_eye` in front of the lens on the axis; a
//! ray that misses it is lost, so out-of-focus highlights near the image's
//! edges take the shape of two overlapping disks and the edges darken
//! (optical vignetting). With `f_stop` large the camera tends to a
//! pinhole. `ptracer` connects to the lens as the camera samples it.

use super::{clip_planes, focus_or_target, rigid_to_world, Aperture, FovAxis, Perspective};
use crate::params::{ParamError, Params};

/// Builds the camera (a [`Perspective`] with a lens).
pub fn from_params(p: &mut dyn Params, size: [u32; 2]) -> Result<Perspective, ParamError> {
    let sensor_w = p.positive_float_or("sensor_width", 36.0)?;
    let sensor_h = p.positive_float_or("sensor_height", 24.0)?;
    let focal = p.positive_float_or("focal_length", 50.0)?;
    let f_stop = p.positive_float_or("f_stop", 5.6)?;
    let scene_unit = p.positive_float_or("scene_unit", 1.0)?;
    let blades = match p.integer_or("blades", 0)? {
        0 => 0,
        n @ 3..=64 => n as u32,
        n => {
            return Err(p.param_error(
                "blades",
                &format!("must be 0 (a round aperture) or 3 to 64, not {n}"),
            ))
        }
    };
    let rotation = p.float_or("blade_rotation", 0.0)?.to_radians();
    let bias = p.float_or("aperture_bias", 0.0)?;
    if !(bias > -1.0 && bias < 1.0) {
        return Err(p.param_error(
            "aperture_bias",
            &format!("must be between -1 and 1 (exclusive), not {bias}"),
        ));
    }
    let cats_eye_mm = p.float_or("cats_eye", 0.0)?;
    if !(cats_eye_mm >= 0.0 && cats_eye_mm.is_finite()) {
        return Err(p.param_error(
            "cats_eye",
            &format!("must be a distance >= 0 (mm), not {cats_eye_mm}"),
        ));
    }
    let (near, far) = clip_planes(p)?;
    let rigid = rigid_to_world(p)?;
    let focus = focus_or_target(p, rigid)?;
    let mm = 0.001 / scene_unit;
    let (fov, axis) = fov_of_sensor(sensor_w, sensor_h, focal, size);
    let lens = Aperture {
        radius: aperture_radius(focal, f_stop) * mm,
        focus_distance: focus,
        blades,
        rotation,
        bias,
        cats_eye: cats_eye_mm * mm,
    };
    Ok(Perspective::new(rigid, fov, axis, size[0], size[1], near, far).with_lens(lens))
}

/// Field of view (degrees) across a sensor side of `side` mm behind a lens
/// of focal length `focal` mm: 2 atan(side / 2f).
pub fn fov_degrees(side: f32, focal: f32) -> f32 {
    (2.0 * (side / (2.0 * focal)).atan()).to_degrees()
}

/// Aperture radius (mm) of focal length `focal` mm at f-number `f_stop`:
/// f / (2 N).
pub fn aperture_radius(focal: f32, f_stop: f32) -> f32 {
    focal / (2.0 * f_stop)
}

/// The field of view and its axis for a film of `size` pixels cut from
/// the sensor: the film's wider side relative to the sensor spans it.
fn fov_of_sensor(sensor_w: f32, sensor_h: f32, focal: f32, size: [u32; 2]) -> (f32, FovAxis) {
    let film_aspect = size[0] as f32 / size[1] as f32;
    if film_aspect >= sensor_w / sensor_h {
        (fov_degrees(sensor_w, focal), FovAxis::X)
    } else {
        (fov_degrees(sensor_h, focal), FovAxis::Y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 50 mm lens on a 36 × 24 mm sensor sees 39.6° across and 27.0°
    /// up; at f/2 its aperture is 12.5 mm across.
    #[test]
    fn fov_and_aperture_follow_the_formulas() {
        assert!((fov_degrees(36.0, 50.0) - 39.5978).abs() < 1e-3);
        assert!((fov_degrees(24.0, 50.0) - 26.9915).abs() < 1e-3);
        assert_eq!(aperture_radius(50.0, 2.0), 12.5);
        // A 3:2 film fits the 3:2 sensor by its width, a square one by its
        // height.
        assert_eq!(fov_of_sensor(36.0, 24.0, 50.0, [300, 200]).1, FovAxis::X);
        let (fov, axis) = fov_of_sensor(36.0, 24.0, 50.0, [200, 200]);
        assert_eq!(axis, FovAxis::Y);
        assert!((fov - 26.9915).abs() < 1e-3);
    }
}
