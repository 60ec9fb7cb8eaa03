//! Shapes, with Mitsuba 3's definitions and parameterizations.
//!
//! Every shape implements the same contract (the [`ShapeModel`] trait):
//! primitive count and bounds for the BVH, ray intersection returning a
//! small [`PrimHit`], the full [`SurfaceInteraction`] computed afterwards
//! only for the closest hit, and area sampling for emitters. [`Shape`] is
//! the closed enum stored in the scene; triangle data lives in scene-owned
//! [`TriangleMesh`]es referenced by index.
//!
//! `cube` is analytic ([`Cube`], one slab test where its mesh would test
//! twelve triangles) with the geometry of Mitsuba's 12-triangle cube
//! mesh, which an emitting cube stays ([`cube::cube_mesh`]).

#[cfg(all(target_arch = "x86_64", not(target_feature = "avx2")))]
mod avx2;
pub mod bsplinecurve;
pub mod cube;
mod cylinder;
mod disk;
pub mod ellipsoids;
pub mod ellipsoidsmesh;
pub mod linearcurve;
pub mod mandelbox;
mod mesh;
mod rectangle;
pub mod sdf;
pub mod sdf_tree;
pub mod sdfgrid;
mod sphere;
mod triangle;

#[cfg(all(target_arch = "x86_64", not(target_feature = "avx2")))]
pub(crate) use avx2::{shape_blocks_avx2, shape_packet_avx2};
pub use bsplinecurve::BSplineCurve;
pub use cube::Cube;
pub use cylinder::Cylinder;
pub use disk::Disk;
pub use ellipsoids::{Ellipsoids, PropertyTable};
pub use ellipsoidsmesh::EllipsoidsMesh;
pub use linearcurve::LinearCurve;
#[cfg(test)]
pub(crate) use mesh::tests as mesh_tests;
pub use mesh::{MeshData, MeshShape, TriangleMesh};
pub(crate) use rectangle::NearZone;
pub use rectangle::Rectangle;
pub use sdf::SdfShape;
pub use sdfgrid::SdfGrid;
pub use sphere::Sphere;
pub(crate) use triangle::lane_tests_avx2;
pub use triangle::{TrianglePackets, WatertightRay, PACKET};

use crate::interaction::SurfaceInteraction;
use crate::math::{Bounds3, Ray, RayPacket, Transform};
use crate::params::{plugin_of, ParamError, Params};
use glam::{Vec2, Vec3};
use wide::{f32x8, CmpGt, CmpLt};

/// What a shape plugin builds: an analytic shape, or a triangle mesh for
/// the scene to add to its meshes (and refer to by index).
// A value passed once from a plugin to the scene as it loads: its size
// (a `cube`'s per-face frames) costs nothing there.
#[allow(clippy::large_enum_variant)]
#[derive(Debug)]
pub enum BuiltShape {
    /// A shape that needs nothing more.
    Analytic(Shape),
    /// A mesh, in world (or shape-group) space.
    Mesh(TriangleMesh),
}

/// Builds a shape plugin from its parameters.
pub type ShapeFromParams = fn(&mut dyn Params) -> Result<BuiltShape, ParamError>;

/// Every shape plugin: its scene type string and constructor. (`shapegroup`
/// and `instance` arrange other shapes and are the front end's.)
pub const PLUGINS: &[(&str, ShapeFromParams)] = &[
    ("obj", |p| {
        Ok(BuiltShape::Mesh(TriangleMesh::from_params(p)?))
    }),
    ("ply", |p| {
        Ok(BuiltShape::Mesh(TriangleMesh::from_params(p)?))
    }),
    ("serialized", |p| {
        Ok(BuiltShape::Mesh(TriangleMesh::from_params(p)?))
    }),
    ("cube", |p| {
        Ok(BuiltShape::Analytic(Shape::Cube(Cube::from_params(p)?)))
    }),
    ("sphere", |p| {
        Ok(BuiltShape::Analytic(Shape::Sphere(Sphere::from_params(p)?)))
    }),
    ("rectangle", |p| {
        Ok(BuiltShape::Analytic(Shape::Rectangle(
            Rectangle::from_params(p)?,
        )))
    }),
    ("disk", |p| {
        Ok(BuiltShape::Analytic(Shape::Disk(Disk::from_params(p)?)))
    }),
    ("cylinder", |p| {
        Ok(BuiltShape::Analytic(Shape::Cylinder(
            Cylinder::from_params(p)?,
        )))
    }),
    ("sdf", |p| {
        Ok(BuiltShape::Analytic(Shape::Sdf(SdfShape::from_params(p)?)))
    }),
    ("sdfgrid", |p| {
        Ok(BuiltShape::Analytic(Shape::SdfGrid(SdfGrid::from_params(
            p,
        )?)))
    }),
    ("mandelbox", |p| {
        Ok(BuiltShape::Analytic(Shape::Sdf(
            SdfShape::mandelbox_from_params(p)?,
        )))
    }),
    ("ellipsoids", |p| {
        Ok(BuiltShape::Analytic(Shape::Ellipsoids(
            Ellipsoids::from_params(p)?,
        )))
    }),
    ("ellipsoidsmesh", |p| {
        Ok(BuiltShape::Analytic(Shape::EllipsoidsMesh(
            EllipsoidsMesh::from_params(p)?,
        )))
    }),
    ("linearcurve", |p| {
        Ok(BuiltShape::Analytic(Shape::LinearCurve(
            LinearCurve::from_params(p)?,
        )))
    }),
    ("bsplinecurve", |p| {
        Ok(BuiltShape::Analytic(Shape::BSplineCurve(
            BSplineCurve::from_params(p)?,
        )))
    }),
];

/// The `to_world` and `flip_normals` of a shape placed by a transform
/// (`rectangle`, `disk`, `cube`).
pub(crate) fn placement(p: &mut dyn Params) -> Result<(Transform, bool), ParamError> {
    let flip_normals = p.boolean_or("flip_normals", false)?;
    Ok((p.transform_or_identity("to_world")?, flip_normals))
}

/// Builds the shape `p` describes, by its plugin type.
pub fn from_params(p: &mut dyn Params) -> Result<BuiltShape, ParamError> {
    let known =
        "obj, ply, serialized, cube, sphere, rectangle, disk, cylinder, sdf, sdfgrid, mandelbox, \
                 ellipsoids, ellipsoidsmesh, linearcurve, bsplinecurve, shapegroup, instance";
    plugin_of(p, "shape", PLUGINS, Some(known))?(p)
}

/// `value` stored for the program's life in `store`, once per content:
/// what a shape refers to as `&'static` so that it stays a `Copy` value
/// (`sdf` trees, `sdfgrid` samples).
pub(crate) fn interned<T: PartialEq>(
    store: &'static std::sync::Mutex<Vec<&'static T>>,
    value: T,
) -> &'static T {
    let mut all = store.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(t) = all.iter().find(|t| ***t == value) {
        return t;
    }
    let t: &'static T = Box::leak(Box::new(value));
    all.push(t);
    t
}

/// The result of intersecting one primitive: the distance and whatever
/// the shape needs to finish the interaction (barycentrics, local uv).
// Not padded to 16 bytes: it is returned from the triangle tests in the
// traversal's inner loop, where a 32-byte `Option` made single-ray
// closest hits measurably slower; the hit record pads it instead
// (`scene::WholeHit`), once per hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrimHit {
    /// Ray parameter.
    pub t: f32,
    /// Shape-specific coordinates of the hit.
    pub uv: Vec2,
}

/// A point sampled on a shape's surface.
#[derive(Clone, Copy, Debug)]
pub struct PositionSample {
    /// The point.
    pub p: Vec3,
    /// Unit (shading) normal there, after `flip_normals`.
    pub n: Vec3,
    /// Density per unit area.
    pub pdf: f32,
    /// Surface coordinates there, as a hit at `p` would have them.
    pub uv: Vec2,
}

impl PositionSample {
    /// No sample (density 0): what shapes without area sampling (the
    /// ray-marched ones, which carry no emitter) answer.
    pub const NONE: Self = Self {
        p: Vec3::ZERO,
        n: Vec3::Z,
        pdf: 0.0,
        uv: Vec2::ZERO,
    };
}

/// A point sampled on a shape as seen from a reference point, with the
/// density per solid angle at the reference point.
#[derive(Clone, Copy, Debug)]
pub struct ShapeDirectionSample {
    /// The point on the shape.
    pub p: Vec3,
    /// Unit normal there.
    pub n: Vec3,
    /// Density per solid angle (0 when the sample is unusable).
    pub pdf: f32,
    /// Surface coordinates there, as a hit at `p` would have them.
    pub uv: Vec2,
}

impl ShapeDirectionSample {
    /// The area sample `ps` as seen from `ref_p`: its density converted
    /// to solid angle there.
    #[inline]
    pub fn from_area(ps: PositionSample, ref_p: Vec3) -> Self {
        Self {
            p: ps.p,
            n: ps.n,
            pdf: area_to_solid_angle(ps.pdf, ref_p, ps.p, ps.n),
            uv: ps.uv,
        }
    }
}

/// The contract every shape variant implements.
pub trait ShapeModel {
    /// Number of primitives the BVH sees.
    fn prim_count(&self, meshes: &[TriangleMesh]) -> u32;
    /// Bounds of one primitive.
    fn prim_bounds(&self, meshes: &[TriangleMesh], prim: u32) -> Bounds3;
    /// Nearest hit of `ray` with primitive `prim` in `(ray.t_min, ray.t_max)`.
    fn intersect(&self, meshes: &[TriangleMesh], prim: u32, ray: &Ray) -> Option<PrimHit>;
    /// The full interaction for a hit found by [`ShapeModel::intersect`].
    fn interaction(
        &self,
        meshes: &[TriangleMesh],
        prim: u32,
        ray: &Ray,
        hit: PrimHit,
    ) -> SurfaceInteraction;
    /// The hit point and its geometric normal as [`ShapeModel::interaction`]
    /// gives them, for callers that need nothing else (shadow rays
    /// crossing `null` surfaces); by default from the interaction.
    fn point_and_normal(
        &self,
        meshes: &[TriangleMesh],
        prim: u32,
        ray: &Ray,
        hit: PrimHit,
    ) -> (Vec3, Vec3) {
        let si = self.interaction(meshes, prim, ray, hit);
        (si.p, si.n)
    }
    /// Total surface area.
    fn surface_area(&self, meshes: &[TriangleMesh]) -> f32;
    /// A point uniformly distributed by area.
    fn sample_position(&self, meshes: &[TriangleMesh], u: Vec2) -> PositionSample;

    /// A point on the shape seen from `ref_p`, with solid-angle density.
    /// The default converts area sampling; shapes with better strategies
    /// (spheres: the cone they subtend) override it.
    fn sample_direction(
        &self,
        meshes: &[TriangleMesh],
        ref_p: Vec3,
        u: Vec2,
    ) -> ShapeDirectionSample {
        ShapeDirectionSample::from_area(self.sample_position(meshes, u), ref_p)
    }

    /// Density of [`ShapeModel::sample_direction`] for the point `p` with
    /// normal `n` on this shape, seen from `ref_p`.
    fn pdf_direction(&self, meshes: &[TriangleMesh], ref_p: Vec3, p: Vec3, n: Vec3) -> f32 {
        area_to_solid_angle(1.0 / self.surface_area(meshes), ref_p, p, n)
    }
}

/// Spherical sampling of a light (rectangles, triangles) costs more per
/// sample than area sampling; it pays where the light is near, its area
/// above this fraction of its squared distance. There area sampling's
/// density varies most over the light (by distance and angle), so a
/// higher threshold loses much of the error reduction near large lights;
/// farther away the two samplings' errors are close and the extra cost
/// is not repaid.
pub(crate) const NEAR_AREA_PER_DISTANCE2: f32 = 0.5;

/// Converts a density per area at `p` (normal `n`) into one per solid
/// angle at `ref_p`: pdf · d² / |cos θ|.
#[inline]
pub fn area_to_solid_angle(pdf_area: f32, ref_p: Vec3, p: Vec3, n: Vec3) -> f32 {
    let d = p - ref_p;
    let dist2 = d.length_squared();
    let dist = dist2.sqrt();
    // pdf · d² / |cos θ| with cos θ = n·d / d: one division, not two (a
    // light sample's divisions and square roots share one divider).
    let n_dot_d = n.dot(d).abs();
    if n_dot_d <= 1e-7 * dist || dist2 == 0.0 {
        0.0
    } else {
        pdf_area * dist2 * dist / n_dot_d
    }
}

/// A shape (closed enum; see the module docs).
#[derive(Clone, Copy, Debug)]
pub enum Shape {
    /// A triangle mesh (`obj`, `ply`, `cube`, …).
    Mesh(MeshShape),
    /// `sphere`.
    Sphere(Sphere),
    /// `rectangle`.
    Rectangle(Rectangle),
    /// `disk`.
    Disk(Disk),
    /// `cylinder`.
    Cylinder(Cylinder),
    /// `cube`.
    Cube(Cube),
    /// `sdf` and `mandelbox`: ray marched.
    Sdf(SdfShape),
    /// `sdfgrid`: a sampled distance grid, one primitive per voxel.
    SdfGrid(SdfGrid),
    /// `ellipsoids`: one primitive per Gaussian.
    Ellipsoids(Ellipsoids),
    /// `ellipsoidsmesh`: one primitive (a convex shell) per Gaussian.
    EllipsoidsMesh(EllipsoidsMesh),
    /// `linearcurve`: one primitive per segment.
    LinearCurve(LinearCurve),
    /// `bsplinecurve`: one primitive per segment.
    BSplineCurve(BSplineCurve),
}

const BSPLINE_COST: f32 = 2.0;

impl Shape {
    /// What [`ShapeModel::intersect`] costs for the BVH's surface-area
    /// heuristic, relative to a node visit: a B-spline piece's rounded
    /// cone and Newton's method cost more (on the docs hair scenes with
    /// `scripts/hair-standin.py`'s model, 2 rendered fastest of 1, 2, 3
    /// and 5, 13 % faster than 1).
    pub(crate) fn intersect_cost(&self) -> f32 {
        match self {
            Shape::BSplineCurve(_) => BSPLINE_COST,
            _ => 1.0,
        }
    }

    /// [`ShapeModel::intersect`] for the eight rays of `rays` at once, each
    /// within its lane of `t_max`, for the shapes that have such a test
    /// (spheres, rectangles, disks, cubes; `None` for the others): the lanes
    /// that hit, their distances and their [`PrimHit::uv`], the
    /// single-ray test's values bit for bit.
    #[inline(always)]
    pub(crate) fn intersect_packet(
        &self,
        rays: &RayPacket,
        t_max: f32x8,
    ) -> Option<(u32, f32x8, [f32x8; 2])> {
        match self {
            Shape::Sphere(s) => {
                let (hit, t) = s.intersect_packet(rays, t_max);
                Some((hit, t, [f32x8::ZERO; 2]))
            }
            Shape::Rectangle(r) => Some(r.intersect_packet(rays, t_max)),
            Shape::Disk(d) => Some(d.intersect_packet(rays, t_max)),
            Shape::Cube(c) => Some(c.intersect_packet(rays, t_max)),
            Shape::Mesh(_)
            | Shape::Cylinder(_)
            | Shape::Sdf(_)
            | Shape::SdfGrid(_)
            | Shape::Ellipsoids(_)
            | Shape::EllipsoidsMesh(_)
            | Shape::LinearCurve(_)
            | Shape::BSplineCurve(_) => None,
        }
    }

    /// The shape as an instance placed by `t` shows it, in world space
    /// (for sampling instanced area lights); a mesh is copied into
    /// `meshes`. `None` for a sphere that `t` would make an ellipsoid.
    pub fn placed(
        &self,
        t: &crate::math::Transform,
        meshes: &mut Vec<TriangleMesh>,
    ) -> Option<Shape> {
        Some(match *self {
            Shape::Mesh(m) => {
                let copy = meshes[m.mesh as usize].placed(t);
                meshes.push(copy);
                Shape::Mesh(MeshShape {
                    mesh: meshes.len() as u32 - 1,
                })
            }
            Shape::Sphere(s) => Shape::Sphere(s.placed(t)?),
            Shape::Rectangle(r) => {
                Shape::Rectangle(Rectangle::new(t.after(&r.to_world), r.flip_normals))
            }
            Shape::Disk(d) => Shape::Disk(Disk::new(t.after(&d.to_world), d.flip_normals)),
            Shape::Cylinder(c) => Shape::Cylinder(Cylinder {
                to_world: t.after(&c.to_world),
                ..c
            }),
            Shape::Cube(c) => Shape::Cube(Cube::new(t.after(&c.to_world), c.flip_normals)),
            // Never an emitter, so never placed for light sampling.
            Shape::Sdf(_)
            | Shape::SdfGrid(_)
            | Shape::Ellipsoids(_)
            | Shape::EllipsoidsMesh(_)
            | Shape::LinearCurve(_)
            | Shape::BSplineCurve(_) => return None,
        })
    }
}

macro_rules! dispatch {
    ($self:expr, $s:ident => $e:expr) => {
        match $self {
            Shape::Mesh($s) => $e,
            Shape::Sphere($s) => $e,
            Shape::Rectangle($s) => $e,
            Shape::Disk($s) => $e,
            Shape::Cylinder($s) => $e,
            Shape::Cube($s) => $e,
            Shape::Sdf($s) => $e,
            Shape::SdfGrid($s) => $e,
            Shape::Ellipsoids($s) => $e,
            Shape::EllipsoidsMesh($s) => $e,
            Shape::LinearCurve($s) => $e,
            Shape::BSplineCurve($s) => $e,
        }
    };
}

impl ShapeModel for Shape {
    #[inline]
    fn prim_count(&self, meshes: &[TriangleMesh]) -> u32 {
        dispatch!(self, s => s.prim_count(meshes))
    }
    #[inline]
    fn prim_bounds(&self, meshes: &[TriangleMesh], prim: u32) -> Bounds3 {
        dispatch!(self, s => s.prim_bounds(meshes, prim))
    }
    #[inline(always)]
    fn intersect(&self, meshes: &[TriangleMesh], prim: u32, ray: &Ray) -> Option<PrimHit> {
        dispatch!(self, s => s.intersect(meshes, prim, ray))
    }
    // Inline into `Scene::interaction_at`, so that the 160-byte
    // interaction is built where it is used, not returned through memory.
    #[inline(always)]
    fn interaction(
        &self,
        meshes: &[TriangleMesh],
        prim: u32,
        ray: &Ray,
        hit: PrimHit,
    ) -> SurfaceInteraction {
        dispatch!(self, s => s.interaction(meshes, prim, ray, hit))
    }
    #[inline]
    fn point_and_normal(
        &self,
        meshes: &[TriangleMesh],
        prim: u32,
        ray: &Ray,
        hit: PrimHit,
    ) -> (Vec3, Vec3) {
        dispatch!(self, s => s.point_and_normal(meshes, prim, ray, hit))
    }
    #[inline]
    fn surface_area(&self, meshes: &[TriangleMesh]) -> f32 {
        dispatch!(self, s => s.surface_area(meshes))
    }
    #[inline]
    fn sample_position(&self, meshes: &[TriangleMesh], u: Vec2) -> PositionSample {
        dispatch!(self, s => s.sample_position(meshes, u))
    }
    #[inline]
    fn sample_direction(
        &self,
        meshes: &[TriangleMesh],
        ref_p: Vec3,
        u: Vec2,
    ) -> ShapeDirectionSample {
        dispatch!(self, s => s.sample_direction(meshes, ref_p, u))
    }
    #[inline]
    fn pdf_direction(&self, meshes: &[TriangleMesh], ref_p: Vec3, p: Vec3, n: Vec3) -> f32 {
        dispatch!(self, s => s.pdf_direction(meshes, ref_p, p, n))
    }
}

/// The angle of (x, y) around +z in [0, 2π): the φ of Mitsuba's sphere,
/// disk and cylinder parameterizations.
#[inline]
pub(crate) fn azimuth(x: f32, y: f32) -> f32 {
    let phi = crate::math::atan2(y, x);
    if phi < 0.0 {
        phi + 2.0 * std::f32::consts::PI
    } else {
        phi
    }
}

/// sin φ and cos φ of the azimuth of (x, y), as the point's own direction
/// gives them (no trigonometric call); φ = 0 at the origin, as
/// [`azimuth`] has it.
#[inline]
pub(crate) fn azimuth_sin_cos(x: f32, y: f32) -> (f32, f32) {
    let rho = (x * x + y * y).sqrt();
    if rho > 0.0 {
        (y / rho, x / rho)
    } else {
        (0.0, 1.0)
    }
}

/// Where `ray` meets the z = 0 plane of the object space of `to_world`:
/// the ray parameter and the local (x, y), when inside the ray's interval.
/// Shared by the planar shapes (`rectangle`, `disk`).
#[inline]
pub(crate) fn intersect_local_plane(to_world: &Transform, ray: &Ray) -> Option<(f32, Vec2)> {
    let o = to_world.inv.transform_point3(ray.o);
    let d = to_world.inv.transform_vector3(ray.d);
    let t = -o.z / d.z;
    (t > ray.t_min && t < ray.t_max).then(|| (t, Vec2::new(o.x + t * d.x, o.y + t * d.y)))
}

/// [`intersect_local_plane`] for the eight rays of `rays`, each within its
/// lane of `t_max`: the lanes that meet the plane in their interval, the
/// distances and the object-space x and y, the single-ray values bit for
/// bit (the same operations in the same order, lane by lane).
#[inline(always)]
pub(crate) fn intersect_local_plane_packet(
    to_world: &Transform,
    rays: &RayPacket,
    t_max: f32x8,
) -> (u32, f32x8, [f32x8; 2]) {
    let m = &to_world.inv;
    let [cx, cy, cz] = [m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis];
    let linear = |v: &[f32x8; 3], i: usize| {
        let s = |c: glam::Vec3A| f32x8::splat(c[i]);
        s(cx) * v[0] + s(cy) * v[1] + s(cz) * v[2]
    };
    let o: [f32x8; 3] =
        std::array::from_fn(|i| linear(&rays.o, i) + f32x8::splat(m.translation[i]));
    let d: [f32x8; 3] = std::array::from_fn(|i| linear(&rays.d, i));
    let t = -o[2] / d[2];
    let hit = t.cmp_gt(rays.t_min) & t.cmp_lt(t_max);
    (
        hit.move_mask() as u32,
        t,
        [o[0] + t * d[0], o[1] + t * d[1]],
    )
}

/// The world normal of object-space `n` under `to_world`, unit length,
/// turned around for `flip_normals`.
#[inline]
pub(crate) fn world_normal(to_world: &Transform, n: Vec3, flip: bool) -> Vec3 {
    let n = to_world.normal(n).normalize();
    if flip {
        -n
    } else {
        n
    }
}

/// [`Shape::intersect_packet`] for packet traversal compiled for AVX2 (see
/// `avx2.rs`): in a build for AVX2, the portable test itself (`wide` is
/// AVX there).
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
#[inline(always)]
pub(crate) fn shape_packet_avx2(
    shape: &Shape,
    rays: &RayPacket,
    t_max: f32x8,
) -> Option<(u32, f32x8, [f32x8; 2])> {
    shape.intersect_packet(rays, t_max)
}

/// The hits of [`shape_packet_avx2`] alone, in a build for AVX2.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
#[inline(always)]
pub(crate) fn shape_blocks_avx2(shape: &Shape, rays: &RayPacket, t_max: f32x8) -> Option<u32> {
    shape.intersect_packet(rays, t_max).map(|(hit, _, _)| hit)
}

/// Bounds of the object-space square [-1, 1]² at z = 0 under `to_world`.
pub(crate) fn unit_square_bounds(to_world: &Transform) -> Bounds3 {
    Bounds3::from_points(
        [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .map(|(x, y)| to_world.point(Vec3::new(x, y, 0.0))),
    )
}

/// Builds the interaction of a hit on a surface given local geometry in
/// world space; shared by the analytic shapes.
#[inline]
pub(crate) fn make_interaction(
    ray: &Ray,
    t: f32,
    p: Vec3,
    n: Vec3,
    uv: Vec2,
    dpdu: Vec3,
    dpdv: Vec3,
) -> SurfaceInteraction {
    let frame = crate::math::Frame::from_normal_and_tangent(n, dpdu);
    make_interaction_in_frame(ray, t, p, frame, uv, dpdu, dpdv)
}

/// [`make_interaction`] with the shading frame already built (from the
/// normal and `dpdu`, as [`make_interaction`] builds it): a shape whose
/// frame is the same at every point keeps it.
#[inline]
pub(crate) fn make_interaction_in_frame(
    ray: &Ray,
    t: f32,
    p: Vec3,
    frame: crate::math::Frame,
    uv: Vec2,
    dpdu: Vec3,
    dpdv: Vec3,
) -> SurfaceInteraction {
    SurfaceInteraction {
        p,
        t,
        n: frame.n,
        sh_frame: frame,
        uv,
        dpdu,
        dpdv,
        wo: -ray.d.normalize(),
        shape: 0,
        prim: 0,
        bary: Vec2::ZERO,
        vertices: [0; 3],
        attributes: crate::texture::NO_ATTRIBUTES,
        tangent: glam::Vec4::ZERO,
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::sampler::Pcg32;
    use crate::testing::chi2::{chi2_directions, Chi2Config};

    /// Chi-square test of a shape's direction sampling from `ref_p`
    /// against its `pdf_direction`, plus a check that sampled points lie
    /// on the surface (a ray towards them hits the shape there).
    pub(crate) fn check_shape_sampling(shape: &Shape, meshes: &[TriangleMesh], ref_p: Vec3) {
        // Shapes have sharp silhouettes: integrate the pdf finely.
        let cfg = Chi2Config {
            integration_res: 24,
            ..Chi2Config::default()
        };
        chi2_directions(
            &cfg,
            |r: &mut Pcg32| {
                let s = shape.sample_direction(meshes, ref_p, r.next_2d());
                (s.pdf > 0.0).then(|| ((s.p - ref_p).normalize(), s.pdf))
            },
            |d| {
                let ray = Ray::new(ref_p, d);
                closest_hit(shape, meshes, &ray)
                    .map(|si| shape.pdf_direction(meshes, ref_p, si.p, si.n))
                    .unwrap_or(0.0)
            },
        )
        .unwrap();
        check_sample_uv(shape, meshes, ref_p);
    }

    /// Sampled points carry the uv a hit at the same point gets (what a
    /// textured emitter reads), up to the seam of periodic coordinates.
    fn check_sample_uv(shape: &Shape, meshes: &[TriangleMesh], ref_p: Vec3) {
        let mut rng = Pcg32::new(3, 5);
        let mut compared = 0;
        for _ in 0..500 {
            let s = shape.sample_direction(meshes, ref_p, rng.next_2d());
            if s.pdf <= 0.0 {
                continue;
            }
            let Some(hit) = closest_hit(shape, meshes, &Ray::new(ref_p, (s.p - ref_p).normalize()))
            else {
                continue;
            };
            if (hit.p - s.p).length() > 1e-3 * (1.0 + s.p.length()) {
                continue; // another part of the shape is in front
            }
            let d = hit.uv - s.uv;
            // Periodic coordinates wrap (u on spheres and cylinders, v on
            // disks); no other coordinate can be off by a whole 1.
            let d = d - d.round();
            assert!(
                d.length() < 2e-3,
                "sampled uv {} vs hit uv {} at {}",
                s.uv,
                hit.uv,
                s.p
            );
            compared += 1;
        }
        assert!(compared > 100, "only {compared} samples could be compared");
    }

    /// `free` (a hit's interaction with the frame built from the normal
    /// alone) for rays from random points of the box [−3, 3]³ towards
    /// random points of the unit box about the origin, against `full` (the
    /// shape's whole interaction): the same point, distance and normal,
    /// and an orthonormal right-handed frame about that normal.
    pub(crate) fn check_free_frame(
        shape: &Shape,
        free: impl Fn(&Ray, PrimHit) -> SurfaceInteraction,
    ) {
        let mut rng = crate::sampler::Pcg32::new(5, 3);
        let mut seen = 0;
        for _ in 0..2000 {
            let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 6.0 - 3.0;
            let target = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5;
            let ray = Ray::new(o, (target - o).normalize());
            let Some(hit) = shape.intersect(&[], 0, &ray) else {
                continue;
            };
            let (full, free) = (shape.interaction(&[], 0, &ray, hit), free(&ray, hit));
            assert_eq!((free.p, free.t, free.n), (full.p, full.t, full.n));
            let f = free.sh_frame;
            assert_eq!(f.n, full.sh_frame.n);
            for (a, b) in [(f.s, f.t), (f.t, f.n), (f.n, f.s)] {
                assert!(a.dot(b).abs() < 1e-5, "{f:?}");
            }
            for v in [f.s, f.t] {
                assert!((v.length() - 1.0).abs() < 1e-5, "{f:?}");
            }
            assert!(f.s.cross(f.t).dot(f.n) > 0.999, "right-handed: {f:?}");
            seen += 1;
        }
        assert!(seen > 200, "{seen} hits");
    }

    /// dp/du and dp/dv at hits seen from `origin` are the derivatives of
    /// the surface along its uv: for two nearby hits, p' − p matches
    /// dpdu Δu + dpdv Δv to first order (pairs across a uv seam skipped).
    pub(crate) fn check_uv_derivatives(shape: &Shape, origin: Vec3, towards: Vec3) {
        let mut rng = Pcg32::new(5, 9);
        let axis = (towards - origin).normalize();
        let frame = crate::math::Frame::from_normal(axis);
        let mut compared = 0;
        for _ in 0..400 {
            let u = rng.next_2d() * 2.0 - Vec2::ONE;
            let d = (axis + 0.3 * (u.x * frame.s + u.y * frame.t)).normalize();
            let e = 1e-4 * (rng.next_2d() * 2.0 - Vec2::ONE);
            let d2 = (d + e.x * frame.s + e.y * frame.t).normalize();
            let (Some(a), Some(b)) = (
                closest_hit(shape, &[], &Ray::new(origin, d)),
                closest_hit(shape, &[], &Ray::new(origin, d2)),
            ) else {
                continue;
            };
            let duv = b.uv - a.uv;
            let step = b.p - a.p;
            if duv.abs().max_element() > 0.25 || a.n.dot(b.n) < 0.99 || step.length() < 1e-5 {
                continue;
            }
            let predicted = a.dpdu * duv.x + a.dpdv * duv.y;
            assert!(
                (predicted - step).length() < 0.02 * step.length(),
                "at uv {}: dp {step} vs dpdu Δu + dpdv Δv {predicted}",
                a.uv
            );
            compared += 1;
        }
        assert!(compared > 100, "only {compared} hit pairs compared");
    }

    /// Brute-force closest hit over all primitives of one shape.
    pub(crate) fn closest_hit(
        shape: &Shape,
        meshes: &[TriangleMesh],
        ray: &Ray,
    ) -> Option<SurfaceInteraction> {
        let mut r = *ray;
        let mut best = None;
        for prim in 0..shape.prim_count(meshes) {
            if let Some(h) = shape.intersect(meshes, prim, &r) {
                r.t_max = h.t;
                best = Some((prim, h));
            }
        }
        best.map(|(prim, h)| shape.interaction(meshes, prim, &r, h))
    }
}
