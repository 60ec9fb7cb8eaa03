//! Cameras (closed enum). A camera maps a position on the film (in pixels
//! of the full image, (0, 0) the top-left corner) to a world-space ray.

mod perspective;

pub(crate) use perspective::{field_of_view, image_plane_half_extent};
pub use perspective::{FovAxis, Perspective, SensorSample};

use crate::film::Film;
use crate::math::Ray;
use crate::params::{plugin_of, Family, ParamError, Params};
use crate::sampler::Sampler;
use glam::Vec2;

/// Builds a camera plugin from its parameters and its film's size.
pub type CameraFromParams = fn(&mut dyn Params, [u32; 2]) -> Result<Camera, ParamError>;

/// Every sensor plugin: its scene type string and constructor.
pub const PLUGINS: &[(&str, CameraFromParams)] = &[("perspective", |p, size| {
    Ok(Camera::Perspective(Perspective::from_params(p, size)?))
})];

/// What a `<sensor>` holds: its camera, its film and its sampler, with the
/// sampler's seed.
#[derive(Clone, Copy, Debug)]
pub struct Sensor {
    /// The camera.
    pub camera: Camera,
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
        let camera = build(p, [film.width, film.height])?;
        Ok(Self {
            camera,
            film,
            sampler,
            seed,
        })
    }
}

/// A camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Camera {
    /// `perspective`.
    Perspective(Perspective),
}

impl Camera {
    /// Connects the camera to the world point `p` (for paths traced from
    /// the lights); `None` when `p` is not seen.
    #[inline]
    pub fn sample_towards(&self, p: glam::Vec3) -> Option<SensorSample> {
        match self {
            Camera::Perspective(c) => c.sample_towards(p),
        }
    }

    /// The camera ray along the world direction `d` (unit), its film
    /// position and importance; `None` outside the image.
    #[inline]
    pub fn ray_towards(&self, d: glam::Vec3) -> Option<(Ray, Vec2, f32)> {
        match self {
            Camera::Perspective(c) => c.ray_towards(d),
        }
    }

    /// The camera's position (its pinhole).
    pub fn position(&self) -> glam::Vec3 {
        match self {
            Camera::Perspective(c) => c.position(),
        }
    }

    /// Ray directions' density for uniform film positions (see
    /// [`Perspective::pdf_direction`]).
    pub fn pdf_direction(&self, d: glam::Vec3) -> f32 {
        match self {
            Camera::Perspective(c) => c.pdf_direction(d),
        }
    }

    /// The primary ray through film position `film_p`; `_u_lens` is for
    /// cameras with an aperture.
    #[inline]
    pub fn generate_ray(&self, film_p: Vec2, _u_lens: Vec2) -> Ray {
        match self {
            Camera::Perspective(c) => c.generate_ray(film_p),
        }
    }
}
