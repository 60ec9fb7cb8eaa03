//! `distant`: the radiance leaving a target in one direction, averaged
//! over the target (Mitsuba 3's `distant`).
//!
//! | parameter   | type            | default   | meaning |
//! |-------------|-----------------|-----------|---------|
//! | `direction` | vector          | (0, 0, 1) | the direction rays travel (into the scene): the sensor sees light leaving along its opposite |
//! | `to_world`  | transform       | —         | instead of `direction`: rays travel along to_world·(0, 0, 1) |
//! | `target`    | point or shape  | —         | where rays land: a point, or a nested shape (`<shape type="rectangle" name="target">`, a mesh too), sampled uniformly by area; without one, a disk through the scene's bounding sphere |
//!
//! ```xml
//! <sensor type="distant">
//!     <vector name="direction" value="0, 0.6, -0.8"/>
//!     <shape type="rectangle" name="target"/>
//!     <film type="hdrfilm">
//!         <integer name="width" value="1"/>
//!         <integer name="height" value="1"/>
//!         <rfilter type="box"/>
//!     </film>
//! </sensor>
//! ```
//!
//! With R the radius of the scene's bounding sphere (its box's, centre C),
//! a ray aimed at target point T starts at T − 2R·d; without a target it
//! starts at C + R·(x, y) − R·d, (x, y) uniform on the unit disk across d.
//! A pixel is the mean radiance the target sends back along −d (misses
//! count what the sky gives). As in Mitsuba 3.9.1 the film must be 1 pixel
//! wide or tall, `direction` and `to_world` exclude each other, and the
//! target shape is not part of the scene (its bounding sphere leaves it
//! out). A mesh target picks a triangle by area, then a point uniformly in
//! it.
//!
//! Reference: Mitsuba 3 documentation, "Distant radiancemeter sensor
//! (distant)".

use crate::math::{Frame, Ray};
use crate::params::{Family, ParamError, Params};
use crate::sampling::{
    square_to_uniform_disk_concentric, square_to_uniform_triangle, Distribution1D,
};
use crate::shape::{BuiltShape, Shape, ShapeModel};
use glam::{Vec2, Vec3};

/// Mitsuba 3's ray epsilon in single precision.
const RAY_EPSILON: f32 = 8.940_697e-5;

/// Where a distant sensor's rays land.
// The shape is held by value, as an irradiancemeter's is: one per scene.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
enum Target {
    /// A disk through the scene's bounding sphere.
    Scene,
    /// One point.
    Point(Vec3),
    /// Points of a shape, uniform by area.
    Shape(Shape),
    /// Points of a mesh, uniform by area (interned).
    Mesh(&'static MeshTarget),
}

/// A mesh's triangles (world space) and their areas, for sampling.
#[derive(Debug)]
pub struct MeshTarget {
    triangles: Vec<[Vec3; 3]>,
    areas: Distribution1D,
}

impl PartialEq for MeshTarget {
    fn eq(&self, other: &Self) -> bool {
        self.triangles == other.triangles
    }
}

impl MeshTarget {
    /// The target of `mesh`'s triangles; `None` when they have no area.
    fn new(mesh: &crate::shape::TriangleMesh) -> Option<&'static MeshTarget> {
        let triangles: Vec<[Vec3; 3]> = (0..mesh.triangle_count())
            .map(|t| mesh.triangle(t))
            .collect();
        let areas: Vec<f32> = (0..mesh.triangle_count())
            .map(|t| mesh.triangle_area(t))
            .collect();
        let total: f32 = areas.iter().sum();
        if total.is_nan() || total <= 0.0 {
            return None;
        }
        static INTERNED: std::sync::Mutex<Vec<&'static MeshTarget>> =
            std::sync::Mutex::new(Vec::new());
        let target = MeshTarget {
            triangles,
            areas: Distribution1D::new(&areas),
        };
        Some(crate::shape::interned(&INTERNED, target))
    }

    /// A point uniform by area, from the uniform `u`.
    fn sample(&self, u: Vec2) -> Vec3 {
        // The position within the chosen triangle's step is uniform: reused.
        let (x, _, tri) = self.areas.sample(u.x);
        let within = (x * self.triangles.len() as f32 - tri as f32).clamp(0.0, 1.0);
        let b = square_to_uniform_triangle(Vec2::new(within, u.y));
        let [a, p1, p2] = self.triangles[tri];
        a * (1.0 - b.x - b.y) + p1 * b.x + p2 * b.y
    }
}

/// A sensor of the radiance leaving a target in one direction.
#[derive(Clone, Copy, Debug)]
pub struct Distant {
    /// The direction rays travel (unit).
    d: Vec3,
    target: Target,
    /// The scene's bounding sphere (centre, radius), set once the scene
    /// is built.
    sphere: (Vec3, f32),
}

impl PartialEq for Distant {
    /// Shapes have no equality of their own: compared as they print.
    fn eq(&self, other: &Self) -> bool {
        format!("{self:?}") == format!("{other:?}")
    }
}

impl Distant {
    /// Builds the sensor from its scene parameters, for a film of `size`.
    pub fn from_params(p: &mut dyn Params, size: [u32; 2]) -> Result<Self, ParamError> {
        if size[0] != 1 && size[1] != 1 {
            return Err(p.error(&format!(
                "a distant sensor measures one direction: its film must be 1 pixel wide or tall, not {}x{}",
                size[0], size[1]
            )));
        }
        if p.has("direction") && p.has("to_world") {
            return Err(p.error("give \"direction\" or \"to_world\", not both"));
        }
        let d = match p.transform("to_world")? {
            Some(m) => glam::Affine3A::from_mat4(m.as_mat4()).transform_vector3(Vec3::Z),
            None => p.vector("direction")?.unwrap_or(Vec3::Z),
        };
        let d = d
            .try_normalize()
            .ok_or_else(|| p.param_error("direction", "must not be zero"))?;
        let shape_target = match p.named_child(Family::Shape, "target")? {
            Some(mut shape) => Some(match crate::shape::from_params(&mut *shape)? {
                BuiltShape::Analytic(s) => Target::Shape(s),
                BuiltShape::Mesh(m) => Target::Mesh(
                    MeshTarget::new(&m)
                        .ok_or_else(|| shape.error("the target mesh has no area"))?,
                ),
            }),
            None => None,
        };
        let target = match shape_target {
            Some(t) => t,
            None => match p.point("target")? {
                Some(t) => Target::Point(t),
                None => Target::Scene,
            },
        };
        Ok(Self {
            d,
            target,
            sphere: (Vec3::ZERO, 1.0),
        })
    }

    /// The sensor for a scene whose geometry lies in `bounds`.
    pub fn with_scene_bounds(self, bounds: crate::math::Bounds3) -> Self {
        let (center, radius) = if bounds.min.x <= bounds.max.x {
            let c = (bounds.min + bounds.max) * 0.5;
            (c, (bounds.max - c).length())
        } else {
            (Vec3::ZERO, 0.0)
        };
        Self {
            sphere: (center, (radius * (1.0 + RAY_EPSILON)).max(RAY_EPSILON)),
            ..self
        }
    }

    /// Whether rays take a sample (all but a point target's).
    pub fn needs_sample(&self) -> bool {
        !matches!(self.target, Target::Point(_))
    }

    /// The ray for the uniform sample `u`.
    pub fn generate_ray(&self, u: Vec2) -> Option<Ray> {
        let (center, r) = self.sphere;
        let o = match self.target {
            Target::Point(t) => t - 2.0 * r * self.d,
            Target::Shape(s) => {
                let ps = s.sample_position(&[], u);
                if ps.pdf <= 0.0 {
                    return None;
                }
                ps.p - 2.0 * r * self.d
            }
            Target::Mesh(m) => m.sample(u) - 2.0 * r * self.d,
            Target::Scene => {
                let disk = square_to_uniform_disk_concentric(u);
                let across = Frame::from_normal(self.d).to_world(disk.extend(0.0));
                center + r * across - r * self.d
            }
        };
        Some(Ray::new(o, self.d))
    }

    /// A point rays start from.
    pub fn origin(&self) -> Vec3 {
        self.generate_ray(Vec2::splat(0.5))
            .map_or(Vec3::ZERO, |r| r.o)
    }
}
