//! `irradiancemeter`: the irradiance over a shape's surface (Mitsuba 3's
//! `irradiancemeter`), a sensor written inside the shape it measures.
//!
//! It has no parameters (its place is its shape's; a `to_world` is
//! refused).
//!
//! ```xml
//! <shape type="rectangle">
//!     <sensor type="irradiancemeter">
//!         <film type="hdrfilm">
//!             <integer name="width" value="1"/>
//!             <integer name="height" value="1"/>
//!             <rfilter type="box"/>
//!         </film>
//!     </sensor>
//! </shape>
//! ```
//!
//! A ray leaves a point of the shape, uniform by area, on the side its
//! normal faces, in a cosine-distributed direction, and its radiance
//! counts π times: a pixel is the mean irradiance E = ∫ L cos θ dω over
//! the surface (W/m²). As in Mitsuba 3.9.1 the film position chooses the
//! point: pixel (i, j) of a W × H film measures the part of the surface
//! whose sampling coordinates lie in [i/W, (i+1)/W) × [j/H, (j+1)/H) (for
//! a `rectangle`, the matching sub-rectangle), so a 1 × 1 film measures
//! the whole surface; use a `box` filter for more pixels. The shape stays
//! in the scene as any other. Paths traced from the lights cannot reach it
//! (`ptracer` refuses it), and it cannot be written outside a shape or in
//! a `shapegroup`.
//!
//! Reference: Mitsuba 3 documentation, "Irradiance meter
//! (irradiancemeter)".

use crate::math::{Frame, Ray};
use crate::params::{ParamError, Params};
use crate::sampling::square_to_cosine_hemisphere;
use crate::shape::{Shape, ShapeModel, TriangleMesh};
use glam::Vec2;

/// Mitsuba 3's ray epsilon in single precision.
const RAY_EPSILON: f32 = 8.940_697e-5;

/// A sensor of the irradiance over a shape.
#[derive(Clone, Copy, Debug)]
pub struct Irradiancemeter {
    /// The shape it measures (set by the scene builder).
    shape: Option<Shape>,
    /// The film's size, which film positions are divided by.
    film: Vec2,
}

impl PartialEq for Irradiancemeter {
    /// Shapes have no equality of their own: two meters are equal when
    /// their films are and their shapes print the same.
    fn eq(&self, other: &Self) -> bool {
        self.film == other.film && format!("{:?}", self.shape) == format!("{:?}", other.shape)
    }
}

impl Irradiancemeter {
    /// Builds the sensor from its scene parameters, for a film of `size`;
    /// its shape is given later ([`Irradiancemeter::with_shape`]).
    pub fn from_params(p: &mut dyn Params, size: [u32; 2]) -> Result<Self, ParamError> {
        if p.has("to_world") {
            return Err(p.param_error(
                "to_world",
                "an irradiancemeter has no transform: it measures the shape it is written in",
            ));
        }
        Ok(Self {
            shape: None,
            film: Vec2::new(size[0] as f32, size[1] as f32),
        })
    }

    /// The sensor measuring `shape`.
    pub fn with_shape(self, shape: Shape) -> Self {
        Self {
            shape: Some(shape),
            ..self
        }
    }

    /// Whether it has its shape.
    pub fn has_shape(&self) -> bool {
        self.shape.is_some()
    }

    /// The ray for film position `film_p` (the point) and `u_dir` (the
    /// direction); `meshes` are the scene's, for a mesh shape.
    pub fn generate_ray(&self, meshes: &[TriangleMesh], film_p: Vec2, u_dir: Vec2) -> Option<Ray> {
        let shape = self.shape?;
        let u = (film_p / self.film).clamp(Vec2::ZERO, Vec2::splat(1.0 - f32::EPSILON));
        let ps = shape.sample_position(meshes, u);
        if ps.pdf <= 0.0 {
            return None;
        }
        let d = Frame::from_normal(ps.n).to_world(square_to_cosine_hemisphere(u_dir));
        Some(Ray::new(ps.p + d * RAY_EPSILON, d))
    }
}
