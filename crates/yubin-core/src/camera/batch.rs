//! `batch`: several sensors side by side on one film (Mitsuba 3's
//! `batch`).
//!
//! | parameter | type   | default | meaning |
//! |-----------|--------|---------|---------|
//! | (nested)  | sensor | —       | one or more sensors, left to right in the order written |
//!
//! ```xml
//! <sensor type="batch">
//!     <sensor type="perspective">
//!         <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
//!     </sensor>
//!     <sensor type="perspective">
//!         <transform name="to_world"><lookat origin="5, 0, 0" target="0, 0, 0" up="0, 1, 0"/></transform>
//!     </sensor>
//!     <film type="hdrfilm">
//!         <integer name="width" value="512"/>
//!         <integer name="height" value="256"/>
//!     </film>
//! </sensor>
//! ```
//!
//! The batch's film (W × H), filter and sampler are the render's; the
//! width must be a multiple of the number of sensors N, and sensor k
//! renders columns k·W/N to (k + 1)·W/N − 1 as it would alone with a
//! W/N × H film (its aspect ratio and field of view follow that film; its
//! own film and sampler are read and set aside, as in Mitsuba). A
//! `radiancemeter` is still held to its own film's size (1 pixel wide or
//! tall), as Mitsuba checks it before the resize. Rays cross from one
//! sensor's columns to the next only through a pixel filter wider than a
//! pixel: give the batch a `box` filter to keep the sensors apart. Paths
//! traced from the lights cannot reach a batch (`ptracer` refuses it).
//!
//! Reference: Mitsuba 3 documentation, "Batch sensor (batch)".

use super::{Camera, PLUGINS};
use crate::film::Film;
use crate::math::Ray;
use crate::params::{plugin_of, Family, ParamError, Params};
use glam::Vec2;

/// Sensors side by side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Batch {
    /// The sensors, left to right (interned, so that a camera stays a
    /// `Copy` value).
    cameras: &'static Vec<Camera>,
    /// The width of each one's columns, in pixels.
    width: f32,
}

impl Batch {
    /// Builds the batch from its scene parameters, for a film of `size`.
    pub fn from_params(p: &mut dyn Params, size: [u32; 2]) -> Result<Self, ParamError> {
        let mut n = 0;
        while n <= 64 && p.nth_child(Family::Sensor, n)?.is_some() {
            n += 1;
        }
        if n == 0 {
            return Err(p.error("needs at least one nested sensor"));
        }
        if !size[0].is_multiple_of(n as u32) {
            return Err(p.error(&format!(
                "its film's width ({}) must be a multiple of its number of sensors ({n})",
                size[0]
            )));
        }
        let sub = [size[0] / n as u32, size[1]];
        let mut built = Vec::with_capacity(n);
        for k in 0..n {
            let Some((_, mut c)) = p.nth_child(Family::Sensor, k)? else {
                break;
            };
            let kind = c.plugin_type();
            if kind == "batch" {
                return Err(c.error("a batch sensor cannot hold another batch"));
            }
            let build = plugin_of(&*c, "sensor", PLUGINS, None)?;
            let own = match c.child(Family::Film)? {
                Some(mut f) => Film::from_params(f.as_mut())?,
                None => Film::default(),
            };
            // Its sampler is the batch's: read, set aside.
            if let Some(mut s) = c.child(Family::Sampler)? {
                crate::sampler::Sampler::from_params(s.as_mut())?;
            }
            let size = if kind == "radiancemeter" {
                [own.width, own.height]
            } else {
                sub
            };
            built.push(build(&mut *c, size)?);
        }
        static INTERNED: std::sync::Mutex<Vec<&'static Vec<Camera>>> =
            std::sync::Mutex::new(Vec::new());
        Ok(Self {
            cameras: crate::shape::interned(&INTERNED, built),
            width: sub[0] as f32,
        })
    }

    /// The sensor whose columns hold film position `film_p`, and the
    /// position on its own film.
    fn locate(&self, film_p: Vec2) -> (&Camera, Vec2) {
        let last = self.cameras.len() - 1;
        let k = ((film_p.x / self.width).max(0.0) as usize).min(last);
        (
            &self.cameras[k],
            Vec2::new(film_p.x - k as f32 * self.width, film_p.y),
        )
    }

    /// The ray of the sensor whose columns hold `film_p`.
    pub fn generate_ray(&self, film_p: Vec2, u_lens: Vec2) -> Option<Ray> {
        let (camera, local) = self.locate(film_p);
        camera.generate_ray(local, u_lens)
    }

    /// Whether any of its sensors takes a lens sample.
    pub fn needs_lens_sample(&self) -> bool {
        self.cameras.iter().any(Camera::needs_lens_sample)
    }

    /// The first sensor's point that rays leave from.
    pub fn sample_lens(&self, u: Vec2) -> glam::Vec3 {
        self.cameras[0].sample_lens(u)
    }
}
