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
//! | `principal_point_offset_x`, `_y` | float | 0 | shift of the image centre, in fractions of the film's width and height (Mitsuba's) |
//! | `shutter_open`, `shutter_close` | float | 0, 0 | (every sensor) each sample is taken at a time drawn uniformly in between; nothing in a scene moves, but emitters that change with time (`timed_sunsky`) show that time |
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

use super::Aperture;
use crate::math::Ray;
use crate::params::{ParamError, Params};
use glam::{Affine3A, Vec2, Vec3};
use wide::f32x8;

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
    to_local: Affine3A,
    /// tan(fov_x / 2) and tan(fov_y / 2).
    tan_half: Vec2,
    resolution: Vec2,
    near_clip: f32,
    far_clip: f32,
    /// Shift of the image centre in film fractions (Mitsuba's principal
    /// point offset).
    principal_point: Vec2,
    /// The lens; `None` for a pinhole.
    lens: Option<Aperture>,
}

impl Perspective {
    /// Builds the camera from its scene parameters, for a film of
    /// `size` pixels.
    pub fn from_params(p: &mut dyn Params, size: [u32; 2]) -> Result<Self, ParamError> {
        let (fov, fov_axis) = field_of_view(p)?;
        let (near, far) = clip_planes(p)?;
        // Every projective camera of Mitsuba reads `focus_distance`; a
        // pinhole has no focus, so it only has to be a valid distance.
        focus_distance(p)?;
        let principal_point = Vec2::new(
            p.float_or("principal_point_offset_x", 0.0)?,
            p.float_or("principal_point_offset_y", 0.0)?,
        );
        if !principal_point.is_finite() {
            return Err(p.error("principal_point_offset_x/_y must be finite"));
        }
        let rigid = rigid_to_world(p)?;
        Ok(Self::new(rigid, fov, fov_axis, size[0], size[1], near, far)
            .with_principal_point(principal_point))
    }

    /// The camera with the image centre shifted by `offset` (film
    /// fractions).
    pub fn with_principal_point(mut self, offset: Vec2) -> Self {
        self.principal_point = offset;
        self
    }

    /// The camera with a lens: rays start on `lens` and meet at its focus
    /// distance.
    pub fn with_lens(mut self, lens: Aperture) -> Self {
        self.lens = Some(lens);
        self
    }

    /// The lens, if the camera has one.
    pub fn lens(&self) -> Option<&Aperture> {
        self.lens.as_ref()
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
        Self {
            to_world,
            to_local: to_world.inverse(),
            tan_half: image_plane_half_extent(fov_degrees, axis, width, height),
            resolution: Vec2::new(width as f32, height as f32),
            near_clip,
            far_clip,
            principal_point: Vec2::ZERO,
            lens: None,
        }
    }

    /// The ray through `film_p` (pixels, top-left origin), starting on the
    /// lens at the point the uniform sample `u_lens` picks (unused by a
    /// pinhole); `None` when the cat's-eye aperture stops it.
    #[inline]
    pub fn generate_ray(&self, film_p: Vec2, u_lens: Vec2) -> Option<Ray> {
        let ndc = film_p / self.resolution + self.principal_point;
        // Left edge of the image is camera +x; top is camera +y.
        let local = Vec3::new(
            (1.0 - 2.0 * ndc.x) * self.tan_half.x,
            (1.0 - 2.0 * ndc.y) * self.tan_half.y,
            1.0,
        );
        let (origin, dir) = match &self.lens {
            None => (Vec3::ZERO, local.normalize()),
            Some(lens) => {
                let focus = local * lens.focus_distance;
                let a = lens.sample(u_lens);
                if !lens.passes(a, focus) {
                    return None;
                }
                let o = a.extend(0.0);
                (o, (focus - o).normalize())
            }
        };
        Some(Ray {
            o: self.to_world.transform_point3(origin),
            d: self.to_world.transform_vector3(dir).normalize(),
            // Clip planes are perpendicular to the view axis.
            t_min: self.near_clip / dir.z,
            t_max: self.far_clip / dir.z,
        })
    }
}

impl Perspective {
    /// [`Perspective::generate_ray`] of a pinhole camera for eight film
    /// positions (`x`, `y`) at once: lane by lane the same operations,
    /// bit for bit, eight rays' chains of square roots and divisions in
    /// one. For a camera without a lens ([`Camera::pinhole`]).
    ///
    /// [`Camera::pinhole`]: super::Camera::pinhole
    pub fn generate_pinhole_rays(&self, x: f32x8, y: f32x8) -> [Ray; 8] {
        debug_assert!(self.lens.is_none());
        let s = f32x8::splat;
        let one = f32x8::ONE;
        let ndc_x = x / s(self.resolution.x) + s(self.principal_point.x);
        let ndc_y = y / s(self.resolution.y) + s(self.principal_point.y);
        let lx = (one - s(2.0) * ndc_x) * s(self.tan_half.x);
        let ly = (one - s(2.0) * ndc_y) * s(self.tan_half.y);
        // `Vec3::normalize` of (lx, ly, 1): times the reciprocal length.
        let recip = one / ((lx * lx + ly * ly) + one).sqrt();
        let local = [lx * recip, ly * recip, recip];
        // `Affine3A::transform_vector3`, an axis at a time.
        let m = &self.to_world.matrix3;
        let axis = |c: usize| {
            (s(m.x_axis[c]) * local[0] + s(m.y_axis[c]) * local[1]) + s(m.z_axis[c]) * local[2]
        };
        let w = [axis(0), axis(1), axis(2)];
        let w_recip = one / ((w[0] * w[0] + w[1] * w[1]) + w[2] * w[2]).sqrt();
        let d = w.map(|c| (c * w_recip).to_array());
        let t_min = (s(self.near_clip) / local[2]).to_array();
        let t_max = (s(self.far_clip) / local[2]).to_array();
        let o = self.to_world.transform_point3(Vec3::ZERO);
        std::array::from_fn(|l| Ray {
            o,
            d: Vec3::new(d[0][l], d[1][l], d[2][l]),
            t_min: t_min[l],
            t_max: t_max[l],
        })
    }
}

/// `near_clip` and `far_clip`, checked: 0 < near < far.
pub(crate) fn clip_planes(p: &mut dyn Params) -> Result<(f32, f32), ParamError> {
    let near = p.float_or("near_clip", 0.01)?;
    let far = p.float_or("far_clip", 10_000.0)?;
    if !(near > 0.0 && far > near) {
        return Err(p.param_error(
            "near_clip",
            &format!("clip planes must satisfy 0 < near < far (near {near}, far {far})"),
        ));
    }
    Ok((near, far))
}

/// Validates `focus_distance` if given (positive); returns it.
pub(crate) fn focus_distance(p: &mut dyn Params) -> Result<Option<f32>, ParamError> {
    match p.float("focus_distance")? {
        Some(d) if d.is_nan() || d <= 0.0 => Err(p.param_error(
            "focus_distance",
            &format!("must be a positive distance, not {d}"),
        )),
        d => Ok(d),
    }
}

/// `to_world` without its scale: Mitsuba's projective cameras use only
/// its rigid part.
pub(crate) fn rigid_to_world(p: &mut dyn Params) -> Result<Affine3A, ParamError> {
    let m = p.transform_or_identity("to_world")?.m;
    Ok(Affine3A::from_cols(
        m.matrix3.x_axis.normalize(),
        m.matrix3.y_axis.normalize(),
        m.matrix3.z_axis.normalize(),
        m.translation,
    ))
}

impl Perspective {
    /// The camera's position.
    pub fn position(&self) -> Vec3 {
        self.to_world.translation.into()
    }

    /// Density per solid angle of the directions [`Perspective::generate_ray`]
    /// takes for film positions uniform over the image: 1 / (A cos³θ), with
    /// A = 4 tx ty the image plane's area at distance 1 and θ the angle
    /// from the view axis (dA = dω / cos³θ on that plane); 0 outside the
    /// frustum. Times the pixel count, it is the camera's importance: the
    /// weight that turns radiance arriving along `d` into its contribution
    /// per unit of film area (in pixels).
    pub fn pdf_direction(&self, d: Vec3) -> f32 {
        let local = self.to_local.transform_vector3(d).normalize_or_zero();
        match self.local_to_film(local) {
            Some(_) => 1.0 / (4.0 * self.tan_half.x * self.tan_half.y * local.z.powi(3)),
            None => 0.0,
        }
    }

    /// The film position (pixels of the full image) that sees the local
    /// direction `local` through the lens centre (the chief ray), if any.
    fn local_to_film(&self, local: Vec3) -> Option<Vec2> {
        if local.z <= 0.0 {
            return None;
        }
        let plane = Vec2::new(local.x, local.y) / (local.z * self.tan_half);
        let ndc = 0.5 * (Vec2::ONE - plane) - self.principal_point;
        (ndc.cmpge(Vec2::ZERO).all() && ndc.cmplt(Vec2::ONE).all()).then(|| ndc * self.resolution)
    }

    /// A point on the lens (world space) for the uniform sample `u`: where
    /// a path from the lights meets the camera. The pinhole for a camera
    /// without a lens.
    pub fn sample_lens(&self, u: Vec2) -> Vec3 {
        let a = self.lens.map_or(Vec2::ZERO, |l| l.sample(u));
        self.to_world.transform_point3(a.extend(0.0))
    }

    /// The film position that a ray leaving lens point `a` (camera space)
    /// along local direction `dir` comes from: where its focus point is
    /// seen through the lens centre; `None` outside the image or stopped by
    /// the cat's eye.
    fn film_through_lens(&self, a: Vec3, dir: Vec3) -> Option<Vec2> {
        match &self.lens {
            None => self.local_to_film(dir),
            Some(lens) => {
                if dir.z <= 0.0 {
                    return None;
                }
                let focus = a + dir * (lens.focus_distance / dir.z);
                if !lens.passes(a.truncate(), focus) {
                    return None;
                }
                self.local_to_film(focus)
            }
        }
    }

    /// The camera ray from lens point `lens_p` (from
    /// [`Perspective::sample_lens`]) in the world direction `d` (unit),
    /// with its clip interval, the film position it comes from and its
    /// importance (as in [`Perspective::sample_towards`]); `None` outside
    /// the image.
    pub fn ray_towards(&self, lens_p: Vec3, d: Vec3) -> Option<(Ray, Vec2, f32)> {
        let local = self.to_local.transform_vector3(d).normalize_or_zero();
        let a = self.to_local.transform_point3(lens_p);
        let film_p = self.film_through_lens(a, local)?;
        let ray = Ray {
            o: lens_p,
            d,
            t_min: self.near_clip / local.z,
            t_max: self.far_clip / local.z,
        };
        Some((ray, film_p, self.importance(local)))
    }

    /// Pixels of film area per steradian at the unit local direction
    /// `local`: the pixel count times [`Perspective::pdf_direction`].
    fn importance(&self, local: Vec3) -> f32 {
        self.resolution.x * self.resolution.y
            / (4.0 * self.tan_half.x * self.tan_half.y * local.z.powi(3))
    }

    /// Connects the camera to the world point `p` through the lens point
    /// the uniform sample `u_lens` picks: where `p` appears on the film and
    /// the importance of that direction (see [`Perspective::pdf_direction`]);
    /// `None` when `p` is outside the frustum or the clip range.
    ///
    /// With a lens, the lens point is sampled as camera rays sample it, so
    /// its density cancels: the ray through lens point a and film position
    /// x has, given a, the direction density 1 / (A cos³θ) of a pinhole at
    /// a, θ its own angle to the axis (both directions are central
    /// projections of the plane in focus), and the film position is where
    /// its focus point appears through the lens centre.
    pub fn sample_towards(&self, p: Vec3, u_lens: Vec2) -> Option<SensorSample> {
        let lens_p = self.sample_lens(u_lens);
        let local = self.to_local.transform_point3(p);
        if !(local.z >= self.near_clip && local.z <= self.far_clip) {
            return None;
        }
        let a = self.to_local.transform_point3(lens_p);
        let dir = (local - a).normalize();
        let film_p = self.film_through_lens(a, dir)?;
        let importance = self.importance(dir);
        let to_camera = lens_p - p;
        let dist = to_camera.length();
        Some(SensorSample {
            film_p,
            origin: lens_p,
            wi: to_camera / dist,
            dist,
            importance,
        })
    }
}

/// The camera seen from a point: where the point lands on the film and
/// with what weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorSample {
    /// Film position in pixels of the full image.
    pub film_p: Vec2,
    /// The point of the camera reached (the pinhole or a lens point).
    pub origin: Vec3,
    /// Unit direction from the point towards the camera.
    pub wi: Vec3,
    /// Distance from the point to the camera.
    pub dist: f32,
    /// Importance per unit solid angle at the camera, in pixels of film
    /// area per steradian: radiance along `wi` times it is the film
    /// density of the contribution.
    pub importance: f32,
}

/// Half the width and height (tan(fov_x / 2), tan(fov_y / 2)) of the
/// image plane at distance 1 of a `width`×`height` image whose field of
/// view is `fov_degrees` along `axis`.
pub(crate) fn image_plane_half_extent(
    fov_degrees: f32,
    axis: FovAxis,
    width: u32,
    height: u32,
) -> Vec2 {
    let (w, h) = (width as f32, height as f32);
    let t = (fov_degrees.to_radians() * 0.5).tan();
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
    Vec2::new(tx, ty)
}

/// `fov` along `fov_axis`, or, without `fov`, the diagonal field of view
/// of a 35 mm-equivalent `focal_length` (default "50mm"), as Mitsuba does.
pub(crate) fn field_of_view(p: &mut dyn Params) -> Result<(f32, FovAxis), ParamError> {
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

    /// Eight pinhole rays at a time are [`Perspective::generate_ray`]'s bit
    /// for bit: a rotated, scaled and moved camera with a principal point
    /// offset, film positions all over the image and beyond it.
    #[test]
    fn eight_pinhole_rays_equal_single_ones() {
        let to_world = Affine3A::from_scale_rotation_translation(
            Vec3::new(1.0, -1.3, 0.7),
            glam::Quat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.0),
            Vec3::new(0.5, -2.0, 3.25),
        );
        let mut c = Perspective::new(to_world, 37.0, FovAxis::Y, 333, 211, 0.05, 900.0);
        c.principal_point = Vec2::new(0.12, -0.07);
        let mut rng = crate::sampler::Pcg32::new(8, 3);
        for _ in 0..500 {
            let p: [Vec2; 8] = std::array::from_fn(|_| {
                Vec2::new(rng.next_f32() * 400.0 - 30.0, rng.next_f32() * 260.0 - 20.0)
            });
            let (x, y) = (p.map(|p| p.x), p.map(|p| p.y));
            let rays = c.generate_pinhole_rays(f32x8::new(x), f32x8::new(y));
            for (p, got) in p.iter().zip(rays) {
                let want = c.generate_ray(*p, Vec2::ZERO).unwrap();
                let bits = |r: Ray| {
                    let v = [r.o.to_array(), r.d.to_array(), [r.t_min, r.t_max, 0.0]];
                    v.map(|v| v.map(f32::to_bits))
                };
                assert_eq!(bits(got), bits(want), "at {p}");
            }
        }
    }

    #[test]
    fn image_corners_follow_mitsuba_convention() {
        // Camera at the origin looking down +z with identity to_world.
        let c = Perspective::new(Affine3A::IDENTITY, 90.0, FovAxis::X, 200, 100, 0.01, 1e4);
        let center = c
            .generate_ray(Vec2::new(100.0, 50.0), Vec2::splat(0.5))
            .unwrap();
        assert!((center.d - Vec3::Z).length() < 1e-6);
        // The left edge of the image is camera +x, at 45° for a 90° fov.
        let left = c
            .generate_ray(Vec2::new(0.0, 50.0), Vec2::splat(0.5))
            .unwrap();
        assert!((left.d - Vec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-6);
        // The top edge is +y, with the aspect ratio applied.
        let top = c
            .generate_ray(Vec2::new(100.0, 0.0), Vec2::splat(0.5))
            .unwrap();
        assert!((top.d - Vec3::new(0.0, 0.5, 1.0).normalize()).length() < 1e-6);
    }

    #[test]
    fn sample_towards_inverts_generate_ray() {
        let to_world = Affine3A::from_translation(Vec3::new(1.0, 2.0, 3.0))
            * Affine3A::from_rotation_y(0.4)
            * Affine3A::from_rotation_x(-0.2);
        let c = Perspective::new(to_world, 50.0, FovAxis::Y, 64, 48, 0.01, 1e4);
        for film_p in [
            Vec2::new(3.5, 40.25),
            Vec2::new(32.0, 24.0),
            Vec2::new(60.0, 1.0),
        ] {
            let r = c.generate_ray(film_p, Vec2::splat(0.5)).unwrap();
            let s = c.sample_towards(r.at(7.0), Vec2::ZERO).unwrap();
            assert!(
                (s.film_p - film_p).length() < 1e-3,
                "{film_p} vs {}",
                s.film_p
            );
            assert!((s.wi + r.d).length() < 1e-5 && (s.dist - 7.0).abs() < 1e-4);
            let expected = 64.0 * 48.0 * c.pdf_direction(r.d);
            assert!((s.importance / expected - 1.0).abs() < 1e-5);
        }
        // Behind the camera and beyond the image's edge: no connection.
        assert!(c
            .sample_towards(
                c.generate_ray(Vec2::new(3.0, 3.0), Vec2::splat(0.5))
                    .unwrap()
                    .at(-2.0),
                Vec2::ZERO
            )
            .is_none());
        let wide = c
            .generate_ray(Vec2::new(0.0, 24.0), Vec2::splat(0.5))
            .unwrap();
        let outside = to_world.transform_point3(Vec3::new(10.0, 0.0, 1.0));
        assert!(c.sample_towards(outside, Vec2::ZERO).is_none() && wide.d.is_finite());
    }

    /// The camera's importance, as a density of ray directions, is the
    /// density that uniform film positions give `generate_ray`'s rays.
    #[test]
    fn chi2_camera_ray_directions_follow_pdf_direction() {
        use crate::testing::chi2::{chi2_directions, Chi2Config};
        let to_world = Affine3A::from_rotation_y(0.9) * Affine3A::from_rotation_x(0.3);
        for (fov, axis, w, h) in [
            (70.0, FovAxis::X, 40, 30),
            (100.0, FovAxis::Diagonal, 20, 50),
        ] {
            let c = Perspective::new(to_world, fov, axis, w, h, 0.01, 1e4);
            let res = Vec2::new(w as f32, h as f32);
            chi2_directions(
                &Chi2Config {
                    integration_res: 16,
                    ..Chi2Config::default()
                },
                |r| {
                    let d = c
                        .generate_ray(r.next_2d() * res, Vec2::splat(0.5))
                        .unwrap()
                        .d;
                    Some((d, c.pdf_direction(d)))
                },
                |d| c.pdf_direction(d),
            )
            .unwrap();
        }
    }

    #[test]
    fn fov_axis_y_and_clip_planes() {
        let c = Perspective::new(Affine3A::IDENTITY, 90.0, FovAxis::Y, 200, 100, 2.0, 10.0);
        let r = c
            .generate_ray(Vec2::new(0.0, 50.0), Vec2::splat(0.5))
            .unwrap();
        assert!((r.d - Vec3::new(2.0, 0.0, 1.0).normalize()).length() < 1e-6);
        assert!((r.at(r.t_min).z - 2.0).abs() < 1e-5 && (r.at(r.t_max).z - 10.0).abs() < 1e-4);
    }
}
