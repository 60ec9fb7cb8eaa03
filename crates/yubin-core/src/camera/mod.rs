//! Cameras (closed enum). A camera maps a position on the film (in pixels
//! of the full image, (0, 0) the top-left corner) to a world-space ray.

mod aperture;
mod batch;
mod distant;
mod irradiancemeter;
mod orthographic;
mod perspective;
pub mod physical;
mod radiancemeter;
mod thinlens;

pub use aperture::Aperture;
pub use batch::Batch;
pub use distant::Distant;
pub use irradiancemeter::Irradiancemeter;
pub use orthographic::Orthographic;
pub(crate) use perspective::{
    clip_planes, field_of_view, focus_distance, image_plane_half_extent, rigid_to_world,
};
pub use perspective::{FovAxis, Perspective, SensorSample};
pub use radiancemeter::Radiancemeter;

use crate::film::Film;
use crate::math::Ray;
use crate::params::{plugin_of, Family, ParamError, Params};
use crate::sampler::Sampler;
use glam::Vec2;

/// Builds a camera plugin from its parameters and its film's size.
pub type CameraFromParams = fn(&mut dyn Params, [u32; 2]) -> Result<Camera, ParamError>;

/// Every sensor plugin: its scene type string and constructor.
pub const PLUGINS: &[(&str, CameraFromParams)] = &[
    ("perspective", |p, size| {
        Ok(Camera::Perspective(Perspective::from_params(p, size)?))
    }),
    ("thinlens", |p, size| {
        Ok(Camera::Perspective(thinlens::from_params(p, size)?))
    }),
    ("physical", |p, size| {
        Ok(Camera::Perspective(physical::from_params(p, size)?))
    }),
    ("orthographic", |p, size| {
        Ok(Camera::Orthographic(Orthographic::from_params(p, size)?))
    }),
    ("radiancemeter", |p, size| {
        Ok(Camera::Radiancemeter(Radiancemeter::from_params(p, size)?))
    }),
    ("batch", |p, size| {
        Ok(Camera::Batch(Batch::from_params(p, size)?))
    }),
    ("distant", |p, size| {
        Ok(Camera::Distant(Distant::from_params(p, size)?))
    }),
    ("irradiancemeter", |p, size| {
        Ok(Camera::Irradiancemeter(Irradiancemeter::from_params(
            p, size,
        )?))
    }),
];

/// `focus_distance`, or else the distance along the view axis of
/// `to_world`'s `lookat` target from the camera placed at `rigid`.
fn focus_or_target(p: &mut dyn Params, rigid: glam::Affine3A) -> Result<f32, ParamError> {
    if let Some(d) = focus_distance(p)? {
        return Ok(d);
    }
    let target = p
        .look_at_target("to_world")
        .map(|t| rigid.inverse().transform_point3(t).z);
    match target {
        Some(z) if z > 0.0 => Ok(z),
        _ => Err(p.error(
            "needs \"focus_distance\" (or a <lookat> in to_world, whose target it focuses on)",
        )),
    }
}

/// When a sensor's shutter is open (`shutter_open`, `shutter_close`; both
/// 0 by default, as in Mitsuba 3): each camera sample is taken at a time
/// drawn uniformly in between. Nothing in a scene moves yet; the time
/// reaches the emitters that change with it (`timed_sunsky`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shutter {
    /// Opening time.
    pub open: f32,
    /// Closing time (not before `open`).
    pub close: f32,
}

impl Shutter {
    /// A shutter open at time 0 only.
    pub const INSTANT: Self = Self {
        open: 0.0,
        close: 0.0,
    };

    /// From a sensor's `shutter_open` and `shutter_close`.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let open = p.float_or("shutter_open", 0.0)?;
        let close = p.float_or("shutter_close", 0.0)?;
        for (name, v) in [("shutter_open", open), ("shutter_close", close)] {
            if !v.is_finite() {
                return Err(p.param_error(name, &format!("must be a number, not {v}")));
            }
        }
        if close < open {
            return Err(p.param_error(
                "shutter_close",
                &format!("the shutter closes ({close}) before it opens ({open})"),
            ));
        }
        Ok(Self { open, close })
    }

    /// Whether samples are taken over an interval (not at one instant).
    #[inline]
    pub fn is_open(&self) -> bool {
        self.close > self.open
    }

    /// The time of the uniform sample `u` in [0, 1).
    #[inline]
    pub fn time(&self, u: f32) -> f32 {
        self.open + (self.close - self.open) * u
    }
}

impl Default for Shutter {
    fn default() -> Self {
        Self::INSTANT
    }
}

/// What a `<sensor>` holds: its camera, its shutter, its film and its
/// sampler, with the sampler's seed.
#[derive(Clone, Copy, Debug)]
pub struct Sensor {
    /// The camera.
    pub camera: Camera,
    /// When its samples are taken.
    pub shutter: Shutter,
    /// The film (its size, crop window and filter).
    pub film: Film,
    /// The sampler.
    pub sampler: Sampler,
    /// The sampler's `seed`.
    pub seed: u32,
}

impl Sensor {
    /// Builds the sensor `p` describes, with its nested film (default: a
    /// 768×576 `hdrfilm`) and sampler (default: 4 spp `independent`), as
    /// Mitsuba does.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let build = plugin_of(p, "sensor", PLUGINS, None)?;
        let film = match p.child(Family::Film)? {
            Some(mut f) => Film::from_params(f.as_mut())?,
            None => Film::default(),
        };
        let (sampler, seed) = match p.child(Family::Sampler)? {
            Some(mut s) => Sampler::from_params(s.as_mut())?,
            None => (Sampler::default(), 0),
        };
        let shutter = Shutter::from_params(p)?;
        let camera = build(p, [film.width, film.height])?;
        Ok(Self {
            camera,
            shutter,
            film,
            sampler,
            seed,
        })
    }
}

/// A camera.
// An irradiancemeter holds its shape by value: a scene has one camera,
// read in place, so its size costs nothing per ray.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Camera {
    /// `perspective`, and `thinlens` and `physical` (with a lens).
    Perspective(Perspective),
    /// `orthographic`.
    Orthographic(Orthographic),
    /// `radiancemeter`: one ray.
    Radiancemeter(Radiancemeter),
    /// `batch`: several side by side.
    Batch(Batch),
    /// `irradiancemeter`: the irradiance over a shape.
    Irradiancemeter(Irradiancemeter),
    /// `distant`: the radiance leaving a target in one direction.
    Distant(Distant),
}

impl Camera {
    /// True when paths from the lights can be connected to the camera
    /// (`ptracer` needs it): not for `orthographic`.
    pub fn can_connect(&self) -> bool {
        matches!(self, Camera::Perspective(_))
    }

    /// True when rays use a lens sample.
    #[inline]
    pub fn needs_lens_sample(&self) -> bool {
        match self {
            Camera::Perspective(c) => c.lens().is_some(),
            Camera::Batch(b) => b.needs_lens_sample(),
            Camera::Irradiancemeter(_) => true,
            Camera::Distant(c) => c.needs_sample(),
            _ => false,
        }
    }

    /// Connects the camera to the world point `p` through the lens point
    /// that `u_lens` picks (for paths traced from the lights); `None` when
    /// `p` is not seen or the camera cannot be connected.
    #[inline]
    pub fn sample_towards(&self, p: glam::Vec3, u_lens: Vec2) -> Option<SensorSample> {
        match self {
            Camera::Perspective(c) => c.sample_towards(p, u_lens),
            _ => None,
        }
    }

    /// A point of the camera that rays leave from, for the uniform sample
    /// `u` (a lens point, or the pinhole).
    pub fn sample_lens(&self, u: Vec2) -> glam::Vec3 {
        match self {
            Camera::Perspective(c) => c.sample_lens(u),
            Camera::Orthographic(c) => c.position(),
            Camera::Radiancemeter(c) => c.origin(),
            Camera::Batch(b) => b.sample_lens(u),
            Camera::Irradiancemeter(_) => glam::Vec3::ZERO,
            Camera::Distant(c) => c.origin(),
        }
    }

    /// The camera ray from `lens_p` (from [`Camera::sample_lens`]) along
    /// the world direction `d` (unit), its film position and importance;
    /// `None` outside the image or for cameras that cannot be connected.
    #[inline]
    pub fn ray_towards(&self, lens_p: glam::Vec3, d: glam::Vec3) -> Option<(Ray, Vec2, f32)> {
        match self {
            Camera::Perspective(c) => c.ray_towards(lens_p, d),
            _ => None,
        }
    }

    /// The primary ray through film position `film_p` with lens sample
    /// `u_lens`; `None` when the lens stops it (cat's eye): the sample
    /// then counts as black.
    #[inline]
    pub fn generate_ray(&self, film_p: Vec2, u_lens: Vec2) -> Option<Ray> {
        match self {
            Camera::Perspective(c) => c.generate_ray(film_p, u_lens),
            Camera::Orthographic(c) => Some(c.generate_ray(film_p)),
            Camera::Radiancemeter(c) => Some(c.ray()),
            Camera::Batch(b) => b.generate_ray(film_p, u_lens),
            Camera::Irradiancemeter(c) => c.generate_ray(&[], film_p, u_lens),
            Camera::Distant(c) => c.generate_ray(u_lens),
        }
    }

    /// [`Camera::generate_ray`], with the scene's `meshes`, which an
    /// `irradiancemeter` on a mesh samples.
    #[inline]
    pub fn generate_ray_in(
        &self,
        meshes: &[crate::shape::TriangleMesh],
        film_p: Vec2,
        u_lens: Vec2,
    ) -> Option<Ray> {
        match self {
            Camera::Irradiancemeter(c) => c.generate_ray(meshes, film_p, u_lens),
            _ => self.generate_ray(film_p, u_lens),
        }
    }

    /// What each sample's value is multiplied by: π for an
    /// `irradiancemeter` (its rays are cosine-distributed), else 1.
    #[inline]
    pub fn sample_weight(&self) -> f32 {
        match self {
            Camera::Irradiancemeter(_) => std::f32::consts::PI,
            _ => 1.0,
        }
    }

    /// The camera as a `perspective` without a lens, whose rays
    /// [`Perspective::generate_pinhole_rays`] makes eight at a time.
    pub fn pinhole(&self) -> Option<&Perspective> {
        match self {
            Camera::Perspective(c) if c.lens().is_none() => Some(c),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::params::MapParams;
    use glam::{Affine3A, Vec3};

    fn build(kind: &str, p: MapParams) -> Camera {
        let (_, build) = PLUGINS.iter().find(|(n, _)| *n == kind).unwrap();
        let mut p = p;
        build(&mut p, [64, 48]).unwrap()
    }

    fn rays(c: &Camera, u_lens: Vec2) -> Vec<Ray> {
        [
            Vec2::new(0.5, 0.5),
            Vec2::new(63.0, 2.0),
            Vec2::new(10.25, 40.75),
        ]
        .map(|f| c.generate_ray(f, u_lens).unwrap())
        .to_vec()
    }

    fn assert_same_rays(a: &[Ray], b: &[Ray]) {
        for (x, y) in a.iter().zip(b) {
            assert!((x.o - y.o).length() < 1e-5, "{} vs {}", x.o, y.o);
            assert!((x.d - y.d).length() < 1e-6, "{} vs {}", x.d, y.d);
            assert!((x.t_min / y.t_min - 1.0).abs() < 1e-5);
        }
    }

    /// A thin lens of radius 0, and a physical camera at f/10⁷, are the
    /// pinhole camera (up to float noise), whatever the lens sample.
    #[test]
    fn lenses_without_aperture_are_the_pinhole() {
        let pinhole = build("perspective", MapParams::new().float("fov", 40.0));
        let thin = build(
            "thinlens",
            MapParams::new()
                .float("fov", 40.0)
                .float("aperture_radius", 0.0)
                .float("focus_distance", 3.0),
        );
        let physical = build(
            "physical",
            MapParams::new()
                .float("f_stop", 1e7)
                .float("focus_distance", 3.0),
        );
        // A 4:3 film is narrower than the 3:2 sensor: its height spans it.
        let pinhole_50mm = build(
            "perspective",
            MapParams::new()
                .float("fov", physical::fov_degrees(24.0, 50.0))
                .string("fov_axis", "y"),
        );
        for u in [Vec2::new(0.1, 0.9), Vec2::new(0.7, 0.3)] {
            assert_same_rays(&rays(&thin, u), &rays(&pinhole, u));
            assert_same_rays(&rays(&physical, u), &rays(&pinhole_50mm, u));
        }
    }

    /// Values read from Mitsuba 3.9.1 `scalar_rgb` (`sample_ray` of a
    /// 200×100 `thinlens`, fov 90, aperture 0.5, focus 4, with aperture
    /// sample (0.9, 0.3)); Mitsuba's origins lie on the near plane, where
    /// yubin's rays start (t_min).
    #[test]
    fn thinlens_rays_match_mitsuba() {
        let c = Perspective::new(Affine3A::IDENTITY, 90.0, FovAxis::X, 200, 100, 0.01, 1e4)
            .with_lens(Aperture::disk(0.5, 4.0));
        for (ndc, o, d) in [
            (
                (0.5, 0.5),
                (0.36863, -0.15269),
                (-0.09193, 0.03808, 0.99504),
            ),
            ((0.0, 0.5), (0.37863, -0.15269), (0.6718, 0.02833, 0.74019)),
            (
                (0.5, 0.0),
                (0.36863, -0.14769),
                (-0.08108, 0.47241, 0.87764),
            ),
            (
                (0.25, 0.75),
                (0.37363, -0.15519),
                (0.37041, -0.19241, 0.90872),
            ),
        ] {
            let film_p = Vec2::new(ndc.0 * 200.0, ndc.1 * 100.0);
            let r = c.generate_ray(film_p, Vec2::new(0.9, 0.3)).unwrap();
            let start = r.at(r.t_min);
            assert!(
                (start - Vec3::new(o.0, o.1, 0.01)).length() < 2e-5,
                "{ndc:?}: {start}"
            );
            assert!(
                (r.d - Vec3::new(d.0, d.1, d.2)).length() < 2e-5,
                "{ndc:?}: {}",
                r.d
            );
        }
    }

    /// Mitsuba 3.9.1's `principal_point_offset_x` 0.1 and `_y` 0.2 on a
    /// 200×100, fov 90 image: the centre pixel looks along (−0.2, −0.2, 1).
    #[test]
    fn principal_point_offset_matches_mitsuba() {
        let c = Perspective::new(Affine3A::IDENTITY, 90.0, FovAxis::X, 200, 100, 0.01, 1e4)
            .with_principal_point(Vec2::new(0.1, 0.2));
        let r = c.generate_ray(Vec2::new(100.0, 50.0), Vec2::ZERO).unwrap();
        assert!((r.d - Vec3::new(-0.2, -0.2, 1.0).normalize()).length() < 1e-5);
        let s = c.sample_towards(r.at(3.0), Vec2::ZERO).unwrap();
        assert!((s.film_p - Vec2::new(100.0, 50.0)).length() < 1e-3);
    }

    /// Through a lens, connecting a point to the camera finds the film
    /// position whose ray from that lens point passes through it, with
    /// the pinhole importance of that ray's direction.
    #[test]
    fn lens_connection_inverts_generate_ray() {
        let to_world =
            Affine3A::from_translation(Vec3::new(0.5, 1.0, -2.0)) * Affine3A::from_rotation_y(0.3);
        let lens = Aperture {
            blades: 6,
            bias: 0.3,
            ..Aperture::disk(0.2, 3.0)
        };
        let c = Perspective::new(to_world, 50.0, FovAxis::X, 64, 48, 0.01, 1e4).with_lens(lens);
        for (film_p, u) in [
            (Vec2::new(10.5, 20.25), Vec2::new(0.3, 0.8)),
            (Vec2::new(50.0, 5.0), Vec2::new(0.9, 0.1)),
        ] {
            let r = c.generate_ray(film_p, u).unwrap();
            let s = c.sample_towards(r.at(5.0), u).unwrap();
            assert!(
                (s.film_p - film_p).length() < 1e-2,
                "{film_p} vs {}",
                s.film_p
            );
            assert!((s.origin - r.o).length() < 1e-5 && (s.wi + r.d).length() < 1e-4);
            let (_, f, importance) = c.ray_towards(s.origin, r.d).unwrap();
            assert!((f - film_p).length() < 1e-2 && (importance / s.importance - 1.0).abs() < 1e-4);
        }
    }

    /// A physical camera focuses on its lookat target when given no
    /// distance, and refuses impossible lenses.
    #[test]
    fn physical_focus_and_bad_parameters() {
        let bad = |p: MapParams| {
            let mut p = p;
            physical::from_params(&mut p, [64, 48])
                .unwrap_err()
                .to_string()
        };
        let with_focus = || MapParams::new().float("focus_distance", 2.0);
        assert!(bad(with_focus().float("f_stop", 0.0)).contains("f_stop"));
        for blades in [1, 2, -3] {
            let p = with_focus().with("blades", crate::testing::params::Value::Integer(blades));
            assert!(bad(p).contains("blades"));
        }
        assert!(bad(with_focus().float("aperture_bias", 1.0)).contains("aperture_bias"));
        assert!(bad(MapParams::new().float("focus_distance", -1.0)).contains("focus_distance"));
        assert!(bad(MapParams::new()).contains("focus_distance"));
    }
}
