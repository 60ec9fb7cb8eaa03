//! `perspective`: the pinhole camera.
//!
//! | parameter   | type      | default | meaning                                                |
//! |-------------|-----------|---------|--------------------------------------------------------|
//! | `fov`       | float     | —       | field of view in degrees, along `fov_axis`             |
//! | `fov_axis`  | string    | `x`     | `x`, `y`, `diagonal`, `smaller` or `larger`            |
//! | `focal_length` | string | `50mm` | instead of `fov`: a 35 mm-equivalent focal length (diagonal field of view) |
//! | `near_clip` | float     | 0.01    | nothing closer than this (along the view axis) is seen |
//! | `far_clip`  | float     | 10000   | nothing farther                                        |
//! | `to_world`  | transform | identity| camera to world; the camera looks down +z, +y is up     |
//! | `focus_distance` | float | —     | accepted as Mitsuba does; a pinhole has no focus, so it has no effect |
//!
//! ```xml
//! <sensor type="perspective">
//!     <float name="fov" value="45"/>
//!     <transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
//! </sensor>
//! ```
//!
//! Mitsuba's convention: in camera space +z is forward, +y up and +x to
//! the *left*, so the image's left edge is camera +x and `lookat`
//! matrices (columns left, up, forward, origin) produce unmirrored images.

use crate::math::Ray;
use crate::params::{ParamError, Params};
use glam::{Affine3A, Vec2, Vec3};

/// The axis along which `fov` is measured.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FovAxis {
    /// Horizontal.
    #[default]
    X,
    /// Vertical.
    Y,
    /// The image diagonal.
    Diagonal,
    /// The shorter image side.
    Smaller,
    /// The longer image side.
    Larger,
}

/// A pinhole camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Perspective {
    to_world: Affine3A,
    /// tan(fov_x / 2) and tan(fov_y / 2).
    tan_half: Vec2,
    resolution: Vec2,
    near_clip: f32,
    far_clip: f32,
}

impl Perspective {
    /// Builds the camera from its scene parameters, for a film of
    /// `size` pixels.
    pub fn from_params(p: &mut dyn Params, size: [u32; 2]) -> Result<Self, ParamError> {
        let (fov, fov_axis) = field_of_view(p)?;
        let near = p.float_or("near_clip", 0.01)?;
        let far = p.float_or("far_clip", 10_000.0)?;
        if !(near > 0.0 && far > near) {
            return Err(p.param_error(
                "near_clip",
                &format!("clip planes must satisfy 0 < near < far (near {near}, far {far})"),
            ));
        }
        // Every projective camera of Mitsuba reads `focus_distance`; a
        // pinhole has no focus, so it only has to be a valid distance.
        if let Some(d) = p.float("focus_distance")? {
            if d.is_nan() || d <= 0.0 {
                return Err(p.param_error("focus_distance", "must be positive"));
            }
        }
        // Mitsuba's to_world may carry a scale; the camera uses its rigid part.
        let m = p.transform_or_identity("to_world")?.m;
        let rigid = Affine3A::from_cols(
            m.matrix3.x_axis.normalize(),
            m.matrix3.y_axis.normalize(),
            m.matrix3.z_axis.normalize(),
            m.translation,
        );
        p.warn_ignored(&["shutter_open", "shutter_close"], "no motion blur yet");
        Ok(Self::new(rigid, fov, fov_axis, size[0], size[1], near, far))
    }

    /// A camera for a `width`×`height` film.
    pub fn new(
        to_world: Affine3A,
        fov_degrees: f32,
        axis: FovAxis,
        width: u32,
        height: u32,
        near_clip: f32,
        far_clip: f32,
    ) -> Self {
        let (w, h) = (width as f32, height as f32);
        let t = (fov_degrees.to_radians() * 0.5).tan();
        // The film plane at distance 1 spans [-tx, tx] × [-ty, ty].
        let (tx, ty) = match axis {
            FovAxis::X => (t, t * h / w),
            FovAxis::Y => (t * w / h, t),
            FovAxis::Diagonal => {
                let d = (w * w + h * h).sqrt();
                (t * w / d, t * h / d)
            }
            FovAxis::Smaller if w <= h => (t, t * h / w),
            FovAxis::Smaller => (t * w / h, t),
            FovAxis::Larger if w >= h => (t, t * h / w),
            FovAxis::Larger => (t * w / h, t),
        };
        Self {
            to_world,
            tan_half: Vec2::new(tx, ty),
            resolution: Vec2::new(w, h),
            near_clip,
            far_clip,
        }
    }

    /// The ray through `film_p` (pixels, top-left origin).
    #[inline]
    pub fn generate_ray(&self, film_p: Vec2) -> Ray {
        let ndc = film_p / self.resolution;
        // Left edge of the image is camera +x; top is camera +y.
        let local = Vec3::new(
            (1.0 - 2.0 * ndc.x) * self.tan_half.x,
            (1.0 - 2.0 * ndc.y) * self.tan_half.y,
            1.0,
        );
        let inv_len = local.length().recip();
        let d = self.to_world.transform_vector3(local * inv_len).normalize();
        Ray {
            o: self.to_world.translation.into(),
            d,
            // Clip planes are perpendicular to the view axis.
            t_min: self.near_clip / (local.z * inv_len),
            t_max: self.far_clip / (local.z * inv_len),
        }
    }
}

/// `fov` along `fov_axis`, or, without `fov`, the diagonal field of view
/// of a 35 mm-equivalent `focal_length` (default "50mm"), as Mitsuba does.
fn field_of_view(p: &mut dyn Params) -> Result<(f32, FovAxis), ParamError> {
    let axis = match p.string_or("fov_axis", "x")?.as_str() {
        "x" => FovAxis::X,
        "y" => FovAxis::Y,
        "diagonal" => FovAxis::Diagonal,
        "smaller" => FovAxis::Smaller,
        "larger" => FovAxis::Larger,
        other => {
            return Err(p.param_error(
                "fov_axis",
                &format!("must be x, y, diagonal, smaller or larger, not \"{other}\""),
            ))
        }
    };
    let (fov, axis) = match p.float("fov")? {
        Some(fov) => {
            if p.has("focal_length") {
                return Err(
                    p.param_error("focal_length", "give either fov or focal_length, not both")
                );
            }
            (fov, axis)
        }
        None => (focal_length_fov(p)?, FovAxis::Diagonal),
    };
    if !(fov > 0.0 && fov < 180.0) {
        return Err(p.param_error(
            "fov",
            &format!("must be between 0 and 180 degrees, not {fov}"),
        ));
    }
    Ok((fov, axis))
}

/// The diagonal field of view (degrees) of `focal_length` on 35 mm film.
fn focal_length_fov(p: &mut dyn Params) -> Result<f32, ParamError> {
    let text = p.string_or("focal_length", "50mm")?;
    let mm: f32 = text
        .trim()
        .trim_end_matches("mm")
        .trim()
        .parse()
        .ok()
        .filter(|f: &f32| *f > 0.0)
        .ok_or_else(|| {
            p.param_error(
                "focal_length",
                &format!("must be a length like \"50mm\", not \"{text}\""),
            )
        })?;
    let diagonal_mm = (36.0f32 * 36.0 + 24.0 * 24.0).sqrt();
    Ok((2.0 * (diagonal_mm / (2.0 * mm)).atan()).to_degrees())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_corners_follow_mitsuba_convention() {
        // Camera at the origin looking down +z with identity to_world.
        let c = Perspective::new(Affine3A::IDENTITY, 90.0, FovAxis::X, 200, 100, 0.01, 1e4);
        let center = c.generate_ray(Vec2::new(100.0, 50.0));
        assert!((center.d - Vec3::Z).length() < 1e-6);
        // The left edge of the image is camera +x, at 45° for a 90° fov.
        let left = c.generate_ray(Vec2::new(0.0, 50.0));
        assert!((left.d - Vec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-6);
        // The top edge is +y, with the aspect ratio applied.
        let top = c.generate_ray(Vec2::new(100.0, 0.0));
        assert!((top.d - Vec3::new(0.0, 0.5, 1.0).normalize()).length() < 1e-6);
    }

    #[test]
    fn fov_axis_y_and_clip_planes() {
        let c = Perspective::new(Affine3A::IDENTITY, 90.0, FovAxis::Y, 200, 100, 2.0, 10.0);
        let r = c.generate_ray(Vec2::new(0.0, 50.0));
        assert!((r.d - Vec3::new(2.0, 0.0, 1.0).normalize()).length() < 1e-6);
        assert!((r.at(r.t_min).z - 2.0).abs() < 1e-5 && (r.at(r.t_max).z - 10.0).abs() < 1e-4);
    }
}
