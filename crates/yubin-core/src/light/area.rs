//! `area`: a shape that emits radiance from its front side.
//!
//! | parameter  | type                     | default | meaning            |
//! |------------|--------------------------|---------|--------------------|
//! | `radiance` | rgb / spectrum / texture | 1       | emitted radiance L |
//!
//! ```xml
//! <shape type="rectangle">
//!     <emitter type="area"><rgb name="radiance" value="10"/></emitter>
//! </shape>
//! <shape type="rectangle">
//!     <emitter type="area">
//!         <texture type="bitmap" name="radiance">
//!             <string name="filename" value="textures/sign.png"/>
//!         </texture>
//!     </emitter>
//! </shape>
//! ```
//!
//! A textured radiance is read at the surface's uv, both where a path hits
//! the light and at points light sampling picks; sampling stays by area,
//! as in Mitsuba 3 (not by the texture's brightness). `mesh_attribute`
//! cannot drive a radiance (light samples carry no triangle attributes):
//! that is a load error.
//!
//! Inside a `shapegroup`, an area emitter makes every `instance` of the
//! group a light of its own (so does `directionalarea`): each instance
//! gets a world-space copy of the shape for light sampling, and a hit
//! through the instance counts as that light. Instances may rotate,
//! mirror and scale the group, unevenly too, except that an emitting
//! `sphere` must keep its shape (an uneven scale is a load error at the
//! instance). Mitsuba 3 refuses emitters in shape groups ("Instancing of
//! emitters is not supported"); the copies cost one mesh per instance of
//! an emitting mesh, so instance emissive meshes sparingly.
//!
//! A shape with an area emitter and no BSDF gets a black `diffuse`, as in
//! Mitsuba 3 (other shapes without one get a grey `diffuse`).
//!
//! The front side is the one the shading normal points to (so
//! `flip_normals` turns a light around). Sampling is delegated to the
//! shape: spheres sample the cone they subtend; rectangles, and the
//! triangles of a mesh that the light BVH picks one by one, are sampled
//! uniformly in the solid angle they subtend (Ureña et al. 2013; Arvo
//! 1995) from points about as near as they are large, by area from
//! farther ones; a whole mesh picks its triangles by area with an alias
//! table; other shapes sample uniformly by area.

use super::{uv_interaction, EmitterContext, EmitterModel, EmitterSample};
use crate::shape::{Shape, ShapeDirectionSample, ShapeModel};
use crate::texture::Tex;
use glam::{Vec2, Vec3};

/// A diffuse area light on shape `shape`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AreaLight {
    /// Index of the emitting shape.
    pub shape: u32,
    /// Emitted radiance.
    pub radiance: Tex,
}

impl AreaLight {
    /// Samples triangle `prim` of the light's mesh from `ref_p` (by solid
    /// angle when near, else by area: [`TriangleMesh::sample_triangle_direction`]):
    /// the light BVH's choice of one triangle.
    ///
    /// [`TriangleMesh::sample_triangle_direction`]: crate::shape::TriangleMesh::sample_triangle_direction
    pub fn sample_triangle_direction(
        &self,
        ctx: &EmitterContext,
        prim: u32,
        ref_p: Vec3,
        u: Vec2,
    ) -> Option<EmitterSample> {
        let Shape::Mesh(m) = ctx.shapes[self.shape as usize] else {
            return self.sample_direction(ctx, ref_p, u);
        };
        let s = ctx.meshes[m.mesh as usize].sample_triangle_direction(prim as usize, ref_p, u);
        self.emitted_towards(ctx, ref_p, s)
    }

    /// Density of [`AreaLight::sample_triangle_direction`] for the point
    /// `p` (normal `n`) on triangle `prim`.
    pub fn pdf_triangle_direction(
        &self,
        ctx: &EmitterContext,
        prim: u32,
        ref_p: Vec3,
        p: Vec3,
        n: Vec3,
    ) -> f32 {
        let Shape::Mesh(m) = ctx.shapes[self.shape as usize] else {
            return self.pdf_direction(ctx, ref_p, p, n, Vec3::ZERO);
        };
        ctx.meshes[m.mesh as usize].pdf_triangle_direction(prim as usize, ref_p, p, n)
    }

    /// The light sample for the point `s` found on the shape.
    #[inline]
    fn emitted_towards(
        &self,
        ctx: &EmitterContext,
        ref_p: Vec3,
        s: ShapeDirectionSample,
    ) -> Option<EmitterSample> {
        let delta = s.p - ref_p;
        let dist = delta.length();
        if s.pdf.is_nan() || s.pdf <= 0.0 || dist == 0.0 || !s.pdf.is_finite() {
            return None;
        }
        // One division for the three components.
        let wi = delta * (1.0 / dist);
        // Only the front side emits.
        if s.n.dot(wi) >= 0.0 {
            return None;
        }
        Some(EmitterSample {
            wi,
            dist,
            pdf: s.pdf,
            radiance: match self.radiance {
                Tex::Const(c) => c,
                tex => tex.eval(ctx.materials, &uv_interaction(s.p, s.n, s.uv)),
            },
            is_delta: false,
        })
    }
}

impl EmitterModel for AreaLight {
    fn sample_direction(
        &self,
        ctx: &EmitterContext,
        ref_p: Vec3,
        u: Vec2,
    ) -> Option<EmitterSample> {
        let shape = &ctx.shapes[self.shape as usize];
        self.emitted_towards(ctx, ref_p, shape.sample_direction(ctx.meshes, ref_p, u))
    }

    fn pdf_direction(&self, ctx: &EmitterContext, ref_p: Vec3, p: Vec3, n: Vec3, _wi: Vec3) -> f32 {
        ctx.shapes[self.shape as usize].pdf_direction(ctx.meshes, ref_p, p, n)
    }

    fn is_delta(&self) -> bool {
        false
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use crate::light::tests::Variant;
    use crate::light::Emitter;
    use crate::math::Transform;
    use crate::shape::{Cylinder, Disk, MeshShape, Rectangle, Shape, Sphere};
    use glam::{Affine3A, Vec3};
    use std::f32::consts::PI;

    /// The flat lights' rotation about x.
    const TURN: f32 = 2.5;

    /// Cosine-weighted about the flat lights' normal.
    fn cosine_about_normal(_: &Emitter, d: Vec3) -> f32 {
        let normal = Affine3A::from_rotation_x(TURN).transform_vector3(Vec3::Z);
        d.dot(normal).max(0.0) / PI
    }

    fn placed(m: Affine3A) -> Transform {
        Transform::new(m).unwrap()
    }

    /// Flat lights (with their normal, so the emitted directions have the
    /// density cos/π about it), curved ones, a sphere from outside and
    /// from inside, and a mesh of uneven triangles.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let turned = Affine3A::from_rotation_x(TURN);
        let front = Vec3::new(0.2, -1.5, -1.0);
        let mut rectangle = Variant::area(
            "area on a rectangle",
            Shape::Rectangle(Rectangle::new(placed(turned), false)),
            vec![],
            vec![front],
        );
        rectangle.dark_refs = vec![Vec3::new(1.5, 0.3, 0.6)];
        rectangle.emission_pdf = Some(cosine_about_normal);
        let mut disk = Variant::area(
            "area on a scaled disk",
            Shape::Disk(Disk::new(
                placed(turned * Affine3A::from_scale(Vec3::new(2.0, 0.5, 1.0))),
                false,
            )),
            vec![],
            vec![front],
        );
        disk.emission_pdf = Some(cosine_about_normal);
        let mut mesh = Variant::area(
            "area on a mesh of uneven triangles",
            Shape::Mesh(MeshShape { mesh: 0 }),
            vec![crate::shape::mesh_tests::uneven_planar_mesh()],
            vec![Vec3::new(0.3, -0.8, 1.5)],
        );
        mesh.dark_refs = vec![Vec3::new(-0.2, 0.4, -2.0)];
        vec![
            rectangle,
            disk,
            Variant::area(
                "area on a sphere, outside",
                Shape::Sphere(Sphere::new(Vec3::new(0.5, 1.0, 0.0), 0.7, false)),
                vec![],
                vec![Vec3::new(0.0, -1.5, 0.5), Vec3::new(0.5, 1.0, 4.0)],
            ),
            Variant::area(
                "area on a sphere with flipped normals, inside",
                Shape::Sphere(Sphere::new(Vec3::ZERO, 2.0, true)),
                vec![],
                vec![Vec3::new(0.3, 0.5, -1.2)],
            ),
            // From inside, where every ray meets the surface once (a ray
            // from outside could meet a hidden point first, by area).
            Variant::area(
                "area on a cylinder with flipped normals, inside",
                Shape::Cylinder(Cylinder {
                    to_world: placed(Cylinder::object_to_world(
                        Vec3::new(-1.0, 0.0, 0.0),
                        Vec3::new(1.0, 0.5, 0.0),
                        0.4,
                    )),
                    flip_normals: true,
                }),
                vec![],
                vec![Vec3::new(0.1, 0.3, 0.1)],
            ),
            mesh,
        ]
    }
}
