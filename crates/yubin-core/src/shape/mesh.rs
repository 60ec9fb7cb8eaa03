//! Triangle meshes (`obj`, `ply`, `serialized`, `cube`, and any mesh built
//! in code). The file formats are read by `yubin-scene` (`mesh/obj.rs`,
//! `mesh/ply.rs`, `mesh/serialized.rs`).
//!
//! | parameter         | type      | default  | meaning                                            |
//! |-------------------|-----------|----------|----------------------------------------------------|
//! | `filename`        | string    | —        | the mesh file (`obj`, `ply`, `serialized`)         |
//! | `to_world`        | transform | identity | applied to the vertices when the mesh is built     |
//! | `face_normals`    | boolean   | false    | flat shading: ignore/skip vertex normals           |
//! | `flip_normals`    | boolean   | false    | turn geometric and shading normals around          |
//! | `flip_tex_coords` | boolean   | true     | `obj` only: v ↦ 1 − v                              |
//! | `shape_index`     | integer   | 0        | `serialized` only: which mesh of the file (from 0) |
//!
//! ```xml
//! <shape type="ply"><string name="filename" value="bunny.ply"/></shape>
//! <shape type="serialized">
//!     <string name="filename" value="meshes/matpreview.serialized"/>
//!     <integer name="shape_index" value="2"/>
//! </shape>
//! ```
//!
//! `serialized` is Mitsuba's binary mesh format (zlib-compressed, several
//! meshes per file); like Mitsuba, its texture coordinates are used as
//! stored, and its face-normals hint is ignored.
//!
//! Vertices are stored in world (or shape-group) space. When a mesh has no
//! normals and `face_normals` is false, smooth vertex normals are computed
//! by weighting each face normal by the face's angle at the vertex
//! (Thürmer & Wüthrich 1998). Emitting meshes get an alias table over
//! triangle areas so that light sampling picks triangles by area.
//!
//! The ray–triangle test is watertight (Woop et al. 2013, `triangle.rs`).
//!
//! Named per-vertex and per-face attributes (PLY colours and the like, read
//! by the `mesh_attribute` texture) arrive in [`TriangleMesh::attributes`]
//! and move into the scene's attribute table when the mesh is added to a
//! scene ([`crate::scene::SceneBuilder::add_mesh`]); the mesh keeps the
//! index of its set there ([`TriangleMesh::attribute_set`]) and every hit
//! carries it, with the barycentrics and the triangle's vertex indices, in
//! its [`SurfaceInteraction`].

use super::{PositionSample, PrimHit, ShapeModel, WatertightRay};
use crate::interaction::SurfaceInteraction;
use crate::math::{Bounds3, Frame, Ray};
use crate::sampling::{square_to_uniform_triangle, AliasTable};
use crate::texture::{NamedAttribute, NO_ATTRIBUTES};
use glam::{Vec2, Vec3};

/// Triangle data, owned by the scene.
#[derive(Clone, Debug, Default)]
pub struct TriangleMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Unit vertex normals (empty for flat shading).
    pub normals: Vec<Vec3>,
    /// Vertex texture coordinates (empty when absent).
    pub uvs: Vec<Vec2>,
    /// Vertex indices, three per triangle.
    pub indices: Vec<[u32; 3]>,
    /// Turn all normals around.
    pub flip_normals: bool,
    /// Named attributes as loaded ([`TriangleMesh::with_attributes`]);
    /// emptied when the scene takes them over.
    pub attributes: Vec<NamedAttribute>,
    /// The mesh's set in the scene's attribute table
    /// ([`crate::material::Materials::attributes`]), or [`NO_ATTRIBUTES`].
    pub attribute_set: u32,
    area: Option<AliasTable>,
}

/// Errors in mesh data given to [`TriangleMesh::new`].
#[derive(Debug, PartialEq)]
pub enum MeshError {
    /// A triangle refers to a vertex that doesn't exist.
    IndexOutOfRange {
        /// Triangle number.
        triangle: usize,
        /// Offending index.
        index: u32,
        /// Vertex count.
        count: usize,
    },
    /// An attribute array's length differs from the vertex count (or, for
    /// a `face_` attribute, the triangle count) times its channels.
    AttributeLength {
        /// Which attribute.
        attribute: String,
        /// Its length.
        len: usize,
        /// Vertex count.
        count: usize,
    },
    /// The mesh has no triangles.
    Empty,
}

impl std::fmt::Display for MeshError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MeshError::IndexOutOfRange {
                triangle,
                index,
                count,
            } => {
                write!(
                    f,
                    "triangle {triangle} uses vertex {index}, but the mesh has {count} vertices"
                )
            }
            MeshError::AttributeLength {
                attribute,
                len,
                count,
            } => {
                write!(f, "{attribute} has {len} entries for {count} elements")
            }
            MeshError::Empty => write!(f, "the mesh has no triangles"),
        }
    }
}

impl std::error::Error for MeshError {}

impl TriangleMesh {
    /// Validates and assembles a mesh. `normals` may be empty: then smooth
    /// normals are computed unless `face_normals` asks for flat shading.
    pub fn new(
        positions: Vec<Vec3>,
        normals: Vec<Vec3>,
        uvs: Vec<Vec2>,
        indices: Vec<[u32; 3]>,
        face_normals: bool,
        flip_normals: bool,
    ) -> Result<Self, MeshError> {
        let count = positions.len();
        if indices.is_empty() {
            return Err(MeshError::Empty);
        }
        for (triangle, tri) in indices.iter().enumerate() {
            if let Some(&index) = tri.iter().find(|&&i| i as usize >= count) {
                return Err(MeshError::IndexOutOfRange {
                    triangle,
                    index,
                    count,
                });
            }
        }
        for (attribute, len) in [("normals", normals.len()), ("uvs", uvs.len())] {
            if len != 0 && len != count {
                return Err(MeshError::AttributeLength {
                    attribute: attribute.to_string(),
                    len,
                    count,
                });
            }
        }
        let mut mesh = Self {
            positions,
            normals: if face_normals { Vec::new() } else { normals },
            uvs,
            indices,
            flip_normals,
            attributes: Vec::new(),
            attribute_set: NO_ATTRIBUTES,
            area: None,
        };
        if !face_normals && mesh.normals.is_empty() {
            mesh.normals = mesh.angle_weighted_normals();
        }
        for n in &mut mesh.normals {
            *n = n.try_normalize().unwrap_or(Vec3::Z);
        }
        Ok(mesh)
    }

    /// Attaches named attributes, checking their lengths: a `face_`
    /// attribute has one value per triangle and channel, any other one per
    /// vertex and channel (vertex attributes follow `positions`' order).
    pub fn with_attributes(mut self, attributes: Vec<NamedAttribute>) -> Result<Self, MeshError> {
        for a in &attributes {
            let count = if a.per_face() {
                self.indices.len()
            } else {
                self.positions.len()
            };
            if a.values.len() != count * a.channels as usize {
                return Err(MeshError::AttributeLength {
                    attribute: a.name.clone(),
                    len: a.values.len() / (a.channels.max(1) as usize),
                    count,
                });
            }
        }
        self.attributes = attributes;
        Ok(self)
    }

    /// Applies an affine map to positions and normals.
    pub fn transform(&mut self, t: &crate::math::Transform) {
        for p in &mut self.positions {
            *p = t.point(*p);
        }
        for n in &mut self.normals {
            *n = t.normal(*n).try_normalize().unwrap_or(Vec3::Z);
        }
    }

    fn angle_weighted_normals(&self) -> Vec<Vec3> {
        let mut normals = vec![Vec3::ZERO; self.positions.len()];
        for tri in &self.indices {
            let p = tri.map(|i| self.positions[i as usize]);
            let Some(face_n) = (p[1] - p[0]).cross(p[2] - p[0]).try_normalize() else {
                continue;
            };
            for k in 0..3 {
                let e1 = (p[(k + 1) % 3] - p[k]).normalize_or_zero();
                let e2 = (p[(k + 2) % 3] - p[k]).normalize_or_zero();
                let angle = e1.dot(e2).clamp(-1.0, 1.0).acos();
                normals[tri[k] as usize] += face_n * angle;
            }
        }
        normals
    }

    /// Builds the area table used to sample points (emitting meshes).
    pub fn prepare_area_sampling(&mut self) {
        if self.area.is_none() {
            let areas: Vec<f32> = (0..self.indices.len())
                .map(|i| self.triangle_area(i))
                .collect();
            self.area = AliasTable::new(&areas);
        }
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    #[inline]
    fn vertices(&self, tri: usize) -> [Vec3; 3] {
        self.indices[tri].map(|i| self.positions[i as usize])
    }

    fn triangle_area(&self, tri: usize) -> f32 {
        let [p0, p1, p2] = self.vertices(tri);
        0.5 * (p1 - p0).cross(p2 - p0).length()
    }

    /// Total surface area.
    pub fn area(&self) -> f32 {
        match &self.area {
            Some(t) => t.total(),
            None => (0..self.indices.len()).map(|i| self.triangle_area(i)).sum(),
        }
    }

    /// The three vertices of triangle `tri`.
    #[inline]
    pub fn triangle(&self, tri: usize) -> [Vec3; 3] {
        self.vertices(tri)
    }

    /// Watertight intersection with triangle `tri`; returns t and the
    /// barycentrics (b1, b2) of vertices 1 and 2.
    #[inline]
    pub fn intersect_triangle(&self, tri: usize, ray: &Ray) -> Option<PrimHit> {
        WatertightRay::new(ray).intersect(&self.vertices(tri), ray.t_max)
    }

    /// Geometry at barycentrics (b1, b2) of triangle `tri`: point, unit
    /// geometric normal, shading normal, uv, dp/du, dp/dv.
    fn surface_at(&self, tri: usize, b: Vec2) -> (Vec3, Vec3, Vec3, Vec2, Vec3, Vec3) {
        let idx = self.indices[tri].map(|i| i as usize);
        let [p0, p1, p2] = idx.map(|i| self.positions[i]);
        let b0 = 1.0 - b.x - b.y;
        let p = p0 * b0 + p1 * b.x + p2 * b.y;
        let (e1, e2) = (p1 - p0, p2 - p0);
        let mut n = e1.cross(e2).normalize_or_zero();
        let [uv0, uv1, uv2] = if self.uvs.is_empty() {
            [Vec2::ZERO, Vec2::X, Vec2::Y]
        } else {
            idx.map(|i| self.uvs[i])
        };
        let uv = uv0 * b0 + uv1 * b.x + uv2 * b.y;
        let (duv1, duv2) = (uv1 - uv0, uv2 - uv0);
        let det = duv1.x * duv2.y - duv1.y * duv2.x;
        let (dpdu, dpdv) = if det.abs() > 1e-12 {
            let inv = 1.0 / det;
            (
                (e1 * duv2.y - e2 * duv1.y) * inv,
                (e2 * duv1.x - e1 * duv2.x) * inv,
            )
        } else {
            let f = Frame::from_normal(n);
            (f.s, f.t)
        };
        let mut ns = if self.normals.is_empty() {
            n
        } else {
            let [n0, n1, n2] = idx.map(|i| self.normals[i]);
            (n0 * b0 + n1 * b.x + n2 * b.y).try_normalize().unwrap_or(n)
        };
        if self.flip_normals {
            n = -n;
            ns = -ns;
        }
        // Keep the geometric normal on the shading normal's side, so that
        // "front" means the same thing to emitters, BSDFs and ray offsets.
        if n.dot(ns) < 0.0 {
            n = -n;
        }
        (p, n, ns, uv, dpdu, dpdv)
    }
}

/// A mesh shape: the index of its [`TriangleMesh`] in the scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MeshShape {
    /// Index into the scene's meshes.
    pub mesh: u32,
}

impl ShapeModel for MeshShape {
    fn prim_count(&self, meshes: &[TriangleMesh]) -> u32 {
        meshes[self.mesh as usize].indices.len() as u32
    }

    fn prim_bounds(&self, meshes: &[TriangleMesh], prim: u32) -> Bounds3 {
        Bounds3::from_points(meshes[self.mesh as usize].vertices(prim as usize))
    }

    #[inline]
    fn intersect(&self, meshes: &[TriangleMesh], prim: u32, ray: &Ray) -> Option<PrimHit> {
        meshes[self.mesh as usize].intersect_triangle(prim as usize, ray)
    }

    fn interaction(
        &self,
        meshes: &[TriangleMesh],
        prim: u32,
        ray: &Ray,
        hit: PrimHit,
    ) -> SurfaceInteraction {
        let mesh = &meshes[self.mesh as usize];
        let (p, n, ns, uv, dpdu, dpdv) = mesh.surface_at(prim as usize, hit.uv);
        SurfaceInteraction {
            p,
            t: hit.t,
            n,
            sh_frame: Frame::from_normal_and_tangent(ns, dpdu),
            uv,
            dpdu,
            dpdv,
            wo: -ray.d.normalize(),
            shape: 0,
            prim,
            bary: hit.uv,
            vertices: mesh.indices[prim as usize],
            attributes: mesh.attribute_set,
        }
    }

    fn surface_area(&self, meshes: &[TriangleMesh]) -> f32 {
        meshes[self.mesh as usize].area()
    }

    fn sample_position(&self, meshes: &[TriangleMesh], u: Vec2) -> PositionSample {
        let mesh = &meshes[self.mesh as usize];
        let Some(table) = &mesh.area else {
            // Only emitting meshes are sampled, and those have a table.
            return PositionSample {
                p: Vec3::ZERO,
                n: Vec3::Z,
                pdf: 0.0,
            };
        };
        let (tri, u_reused) = table.sample(u.x);
        let b = square_to_uniform_triangle(Vec2::new(u_reused, u.y));
        let (p, _, ns, ..) = mesh.surface_at(tri, b);
        PositionSample {
            p,
            n: ns,
            pdf: 1.0 / table.total(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::tests::check_shape_sampling;
    use crate::shape::Shape;

    /// A planar fan of triangles of very different sizes, tilted.
    fn uneven_planar_mesh() -> TriangleMesh {
        let mut positions = vec![Vec3::ZERO];
        let mut indices = Vec::new();
        let angles = [0.0f32, 0.3, 0.5, 1.6, 2.0, 4.0, 6.0];
        for (k, a) in angles.iter().enumerate() {
            let r = 0.5 + k as f32 * 0.3;
            positions.push(Vec3::new(r * a.cos(), r * a.sin(), 0.0));
        }
        for k in 1..angles.len() {
            indices.push([0, k as u32, k as u32 + 1]);
        }
        let mut m = TriangleMesh::new(positions, vec![], vec![], indices, false, false).unwrap();
        let tilt = crate::math::Transform::new(glam::Affine3A::from_rotation_x(0.4)).unwrap();
        m.transform(&tilt);
        m.prepare_area_sampling();
        m
    }

    #[test]
    fn chi2_mesh_area_sampling() {
        let meshes = vec![uneven_planar_mesh()];
        let shape = Shape::Mesh(MeshShape { mesh: 0 });
        check_shape_sampling(&shape, &meshes, Vec3::new(0.3, -0.2, 1.5));
        check_shape_sampling(&shape, &meshes, Vec3::new(-0.5, 0.4, -0.8));
    }

    #[test]
    fn rejects_bad_indices() {
        let e = TriangleMesh::new(
            vec![Vec3::ZERO; 3],
            vec![],
            vec![],
            vec![[0, 1, 3]],
            false,
            false,
        );
        assert_eq!(
            e.unwrap_err(),
            MeshError::IndexOutOfRange {
                triangle: 0,
                index: 3,
                count: 3
            }
        );
    }

    #[test]
    fn computed_normals_are_smooth_and_outward() {
        let m = crate::shape::cube::cube_mesh();
        for (p, n) in m.positions.iter().zip(&m.normals) {
            // Cube vertices are split per face in Mitsuba's cube, so vertex
            // normals equal face normals and point outward.
            assert!(p.dot(*n) > 0.0);
        }
    }
}
