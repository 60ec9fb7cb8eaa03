//! Surface interactions: everything the integrator needs about a hit.

use crate::math::{shadow_ray_to, spawn_ray, spawn_ray_to, Frame, Ray};
use glam::{Vec2, Vec3, Vec4};

/// A ray–surface hit, in world space.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceInteraction {
    /// Hit point.
    pub p: Vec3,
    /// Ray parameter of the hit.
    pub t: f32,
    /// Geometric normal (unit). It lies on the same side as the shading
    /// normal; both flip together with `flip_normals`.
    pub n: Vec3,
    /// Shading frame; its `n` is the interpolated (shading) normal.
    pub sh_frame: Frame,
    /// Surface parameterization.
    pub uv: Vec2,
    /// ∂p/∂u.
    pub dpdu: Vec3,
    /// ∂p/∂v.
    pub dpdv: Vec3,
    /// Unit direction back towards the ray origin (world).
    pub wo: Vec3,
    /// Index of the shape (in [`crate::Scene::shapes`]).
    pub shape: u32,
    /// Primitive within the shape (triangle index for meshes).
    pub prim: u32,
    /// Triangle hits: the barycentric coordinates (b1, b2) of vertices 1
    /// and 2 (vertex 0 has 1 − b1 − b2). Zero on other shapes.
    pub bary: Vec2,
    /// Triangle hits: the vertex indices of triangle `prim`, for per-vertex
    /// mesh attributes. Zero on other shapes.
    pub vertices: [u32; 3],
    /// The hit mesh's attribute set in
    /// [`crate::material::Materials::attributes`], or
    /// [`crate::texture::NO_ATTRIBUTES`] (other shapes, meshes without
    /// attributes).
    pub attributes: u32,
    /// Meshes with MikkTSpace tangents ([`crate::shape::TriangleMesh::tangents`]):
    /// the interpolated tangent (world, not normalized) and, in `w`, the
    /// bitangent's sign (bitangent = w · n × tangent). Zero elsewhere.
    pub tangent: Vec4,
}

impl SurfaceInteraction {
    /// World direction → shading frame.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        self.sh_frame.to_local(v)
    }

    /// Shading frame → world direction.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.sh_frame.to_world(v)
    }

    /// A ray leaving the surface in world direction `d`.
    #[inline]
    pub fn spawn_ray(&self, d: Vec3) -> Ray {
        spawn_ray(self.p, self.n, d)
    }

    /// A shadow ray from the surface to `target`.
    #[inline]
    pub fn spawn_ray_to(&self, target: Vec3) -> Ray {
        spawn_ray_to(self.p, self.n, target)
    }

    /// A ray that tests the visibility of `target` from the surface alone
    /// (its direction not unit length: [`shadow_ray_to`]).
    #[inline]
    pub fn shadow_ray_to(&self, target: Vec3) -> Ray {
        shadow_ray_to(self.p, self.n, target)
    }
}
