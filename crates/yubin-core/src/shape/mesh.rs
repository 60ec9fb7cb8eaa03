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
//!
//! Meshes whose BSDF has a `normalmap` with `tangent_space="mikktspace"`
//! get MikkTSpace tangents (Mikkelsen 2008, "Simulation of wrinkled
//! surfaces revisited"; the `mikktspace` crate), the tangent frame that
//! baking tools and glTF assume: one tangent and bitangent sign per
//! triangle corner ([`TriangleMesh::tangents`], 48 bytes per triangle,
//! nothing for other meshes), interpolated at the hit.

use super::{
    area_to_solid_angle, PositionSample, PrimHit, ShapeDirectionSample, ShapeModel, WatertightRay,
    NEAR_AREA_PER_DISTANCE2,
};
use crate::interaction::SurfaceInteraction;
use crate::math::{Bounds3, Frame, Ray};
use crate::params::{ParamError, Params};
use crate::sampling::{square_to_uniform_triangle, AliasTable, SphericalTriangle};
use crate::texture::{NamedAttribute, NO_ATTRIBUTES};
use glam::{Vec2, Vec3, Vec4};

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
    /// MikkTSpace tangents, three per triangle (its corners), with the
    /// bitangent sign in `w`; empty unless [`TriangleMesh::compute_tangents`]
    /// ran.
    pub tangents: Vec<[Vec4; 3]>,
    area: Option<AliasTable>,
}

/// A triangle mesh as read from a file, before any transform is applied.
/// Indexed: `normals` and `uvs`, when present, have one entry per position.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshData {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals, if the file has them.
    pub normals: Option<Vec<Vec3>>,
    /// Per-vertex texture coordinates, if the file has them.
    pub uvs: Option<Vec<Vec2>>,
    /// Triangles as three vertex indices each; polygons are fan-triangulated.
    pub indices: Vec<[u32; 3]>,
    /// Named attributes (PLY colours and the like): `vertex_…` ones follow
    /// `positions`, `face_…` ones `indices` (a polygon's value repeated for
    /// each of its triangles).
    pub attributes: Vec<NamedAttribute>,
}

impl TriangleMesh {
    /// Builds a mesh plugin (`obj`, `ply`, `serialized`): the front end
    /// reads the file (`Params::mesh_file`), this applies the parameters
    /// every mesh has.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let data = p.mesh_file()?;
        let face_normals = p.boolean_or("face_normals", false)?;
        let flip = p.boolean_or("flip_normals", false)?;
        let to_world = p.transform_or_identity("to_world")?;
        let mut mesh = TriangleMesh::new(
            data.positions,
            data.normals.unwrap_or_default(),
            data.uvs.unwrap_or_default(),
            data.indices,
            face_normals,
            flip,
        )
        .and_then(|m| m.with_attributes(data.attributes))
        .map_err(|e| p.error(&e.to_string()))?;
        mesh.transform(&to_world);
        Ok(mesh)
    }
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
            tangents: Vec::new(),
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

    /// A copy placed by the instance transform `t`, as an instance of it
    /// shows it: the same triangles in the same order, with normals that
    /// keep their side under a mirroring `t` (its winding is reversed
    /// there), ready for area sampling.
    pub fn placed(&self, t: &crate::math::Transform) -> TriangleMesh {
        let mut m = self.clone();
        m.transform(t);
        for corners in &mut m.tangents {
            for c in corners.iter_mut() {
                *c = t.vector(c.truncate()).normalize_or_zero().extend(c.w);
            }
        }
        if t.swaps_handedness() {
            for tri in &mut m.indices {
                tri.swap(1, 2);
            }
            for corners in &mut m.tangents {
                corners.swap(1, 2);
            }
        }
        m.area = None;
        m.prepare_area_sampling();
        m
    }

    /// Computes MikkTSpace tangents from the vertices as they are now (call
    /// it after [`TriangleMesh::transform`]). Returns false, computing
    /// nothing, for a mesh without uvs.
    pub fn compute_tangents(&mut self) -> bool {
        if self.uvs.is_empty() {
            return false;
        }
        let mut geometry = TangentGeometry {
            mesh: self,
            tangents: vec![[Vec4::ZERO; 3]; self.indices.len()],
        };
        mikktspace::generate_tangents(&mut geometry);
        self.tangents = geometry.tangents;
        true
    }

    /// The interpolated tangent of triangle `tri` at barycentrics `b`,
    /// with the sign of its first corner (a triangle's corners share one
    /// unless the mapping is degenerate).
    #[inline]
    fn tangent_at(&self, tri: usize, b: Vec2) -> Vec4 {
        match self.tangents.get(tri) {
            Some([t0, t1, t2]) => {
                let t = (*t0 * (1.0 - b.x - b.y) + *t1 * b.x + *t2 * b.y).truncate();
                t.extend(t0.w)
            }
            None => Vec4::ZERO,
        }
    }

    /// The shading normal at corner `k` of triangle `tri`, as hits see it.
    fn corner_normal(&self, tri: usize, k: usize) -> Vec3 {
        let idx = self.indices[tri];
        let n = if self.normals.is_empty() {
            let [p0, p1, p2] = idx.map(|i| self.positions[i as usize]);
            (p1 - p0).cross(p2 - p0).normalize_or_zero()
        } else {
            self.normals[idx[k] as usize]
        };
        if self.flip_normals {
            -n
        } else {
            n
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

    /// Area of triangle `tri`.
    pub fn triangle_area(&self, tri: usize) -> f32 {
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

    /// A point uniformly distributed on triangle `tri` (density 1/area),
    /// with its shading normal and uv.
    pub fn sample_triangle(&self, tri: usize, u: Vec2) -> PositionSample {
        let (p, _, ns, uv, ..) = self.surface_at(tri, square_to_uniform_triangle(u));
        PositionSample {
            p,
            n: ns,
            pdf: 1.0 / self.triangle_area(tri),
            uv,
        }
    }

    /// A point on triangle `tri` seen from `ref_p`, with solid-angle
    /// density: uniform in solid angle (Arvo 1995) where the triangle is
    /// near (see [`NEAR_AREA_PER_DISTANCE2`]), else uniform by area.
    pub fn sample_triangle_direction(
        &self,
        tri: usize,
        ref_p: Vec3,
        u: Vec2,
    ) -> ShapeDirectionSample {
        let Some(st) = self.spherical_triangle(tri, ref_p) else {
            return ShapeDirectionSample::from_area(self.sample_triangle(tri, u), ref_p);
        };
        let d = st.sample(u);
        let (p, _, ns, uv, ..) = self.surface_at(tri, self.barycentrics_along(tri, ref_p, d));
        ShapeDirectionSample {
            p,
            n: ns,
            pdf: 1.0 / st.solid_angle(),
            uv,
        }
    }

    /// Density of [`TriangleMesh::sample_triangle_direction`] for the point
    /// `p` (normal `n`) of triangle `tri`.
    pub fn pdf_triangle_direction(&self, tri: usize, ref_p: Vec3, p: Vec3, n: Vec3) -> f32 {
        match self.spherical_triangle(tri, ref_p) {
            Some(st) => 1.0 / st.solid_angle(),
            None => area_to_solid_angle(1.0 / self.triangle_area(tri), ref_p, p, n),
        }
    }

    /// Triangle `tri` as seen from `p`, where spherical sampling applies.
    #[inline]
    fn spherical_triangle(&self, tri: usize, p: Vec3) -> Option<SphericalTriangle> {
        let v = self.vertices(tri);
        let centroid = (v[0] + v[1] + v[2]) / 3.0;
        // area ≥ k d², squared: |e1 × e2|² / 4 ≥ k² d⁴.
        let twice_area2 = (v[1] - v[0]).cross(v[2] - v[0]).length_squared();
        let k_d2 = NEAR_AREA_PER_DISTANCE2 * centroid.distance_squared(p);
        (0.25 * twice_area2 >= k_d2 * k_d2)
            .then(|| SphericalTriangle::new(p, v))
            .flatten()
    }

    /// Barycentrics (b1, b2) where the ray from `o` along `d` meets the
    /// plane of triangle `tri` (Möller and Trumbore 1997), kept inside it.
    fn barycentrics_along(&self, tri: usize, o: Vec3, d: Vec3) -> Vec2 {
        let [p0, p1, p2] = self.vertices(tri);
        let (e1, e2) = (p1 - p0, p2 - p0);
        let pvec = d.cross(e2);
        let inv_det = 1.0 / e1.dot(pvec);
        let tvec = o - p0;
        let b1 = (tvec.dot(pvec) * inv_det).max(0.0);
        let b2 = (d.dot(tvec.cross(e1)) * inv_det).max(0.0);
        let excess = (b1 + b2 - 1.0).max(0.0) * 0.5;
        let b = Vec2::new(b1 - excess, b2 - excess).max(Vec2::ZERO);
        if b.is_finite() {
            b
        } else {
            Vec2::splat(1.0 / 3.0)
        }
    }

    /// The cone of shading normals over triangle `tri`: its axis and the
    /// cosine of its half-angle (1 for a flat-shaded triangle). Normals
    /// interpolated between the vertices' stay inside the cone of those.
    pub fn triangle_normal_cone(&self, tri: usize) -> (Vec3, f32) {
        let (_, n, ..) = self.surface_at(tri, Vec2::splat(1.0 / 3.0));
        if self.normals.is_empty() {
            return (n, 1.0);
        }
        let sign = if self.flip_normals { -1.0 } else { 1.0 };
        let vertex_normals =
            self.indices[tri].map(|i| sign * self.normals[i as usize].normalize_or_zero());
        let axis = (vertex_normals[0] + vertex_normals[1] + vertex_normals[2]).normalize_or(n);
        let cos = vertex_normals
            .iter()
            .map(|v| axis.dot(*v))
            .fold(1.0f32, f32::min);
        (axis, cos)
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
        let n = e1.cross(e2).normalize_or_zero();
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
        let (n, ns) = self.oriented_normals(idx, b, n);
        (p, n, ns, uv, dpdu, dpdv)
    }

    /// Point and unit geometric normal (as [`TriangleMesh::surface_at`]
    /// orients it) at barycentrics (b1, b2) of triangle `tri`.
    fn point_and_normal(&self, tri: usize, b: Vec2) -> (Vec3, Vec3) {
        let idx = self.indices[tri].map(|i| i as usize);
        let [p0, p1, p2] = idx.map(|i| self.positions[i]);
        let p = p0 * (1.0 - b.x - b.y) + p1 * b.x + p2 * b.y;
        let n = (p1 - p0).cross(p2 - p0).normalize_or_zero();
        (p, self.oriented_normals(idx, b, n).0)
    }

    /// The geometric normal `n` of the triangle with vertices `idx` and the
    /// shading normal at barycentrics `b`, both flipped by `flip_normals`,
    /// the geometric one then turned to the shading normal's side (so that
    /// "front" means the same thing to emitters, BSDFs and ray offsets).
    fn oriented_normals(&self, idx: [usize; 3], b: Vec2, n: Vec3) -> (Vec3, Vec3) {
        let mut n = n;
        let mut ns = if self.normals.is_empty() {
            n
        } else {
            let [n0, n1, n2] = idx.map(|i| self.normals[i]);
            (n0 * (1.0 - b.x - b.y) + n1 * b.x + n2 * b.y)
                .try_normalize()
                .unwrap_or(n)
        };
        if self.flip_normals {
            n = -n;
            ns = -ns;
        }
        if n.dot(ns) < 0.0 {
            n = -n;
        }
        (n, ns)
    }
}

/// The mesh as the `mikktspace` crate sees it, and the tangents it returns.
struct TangentGeometry<'a> {
    mesh: &'a TriangleMesh,
    tangents: Vec<[Vec4; 3]>,
}

impl mikktspace::Geometry for TangentGeometry<'_> {
    fn num_faces(&self) -> usize {
        self.mesh.indices.len()
    }

    fn num_vertices_of_face(&self, _: usize) -> usize {
        3
    }

    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.mesh.positions[self.mesh.indices[face][vert] as usize].to_array()
    }

    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        self.mesh.corner_normal(face, vert).to_array()
    }

    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.mesh.uvs[self.mesh.indices[face][vert] as usize].to_array()
    }

    fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
        self.tangents[face][vert] = Vec4::from_array(tangent);
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

    #[inline]
    fn point_and_normal(
        &self,
        meshes: &[TriangleMesh],
        prim: u32,
        _: &Ray,
        hit: PrimHit,
    ) -> (Vec3, Vec3) {
        meshes[self.mesh as usize].point_and_normal(prim as usize, hit.uv)
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
            tangent: mesh.tangent_at(prim as usize, hit.uv),
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
                uv: Vec2::ZERO,
            };
        };
        let (tri, u_reused) = table.sample(u.x);
        let b = square_to_uniform_triangle(Vec2::new(u_reused, u.y));
        let (p, _, ns, uv, ..) = mesh.surface_at(tri, b);
        PositionSample {
            p,
            n: ns,
            pdf: 1.0 / table.total(),
            uv,
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::shape::tests::check_shape_sampling;
    use crate::shape::Shape;

    /// A planar fan of triangles of very different sizes, tilted.
    pub(crate) fn uneven_planar_mesh() -> TriangleMesh {
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

    /// `point_and_normal` (what shadow rays crossing `null` surfaces read)
    /// gives the interaction's point and geometric normal, with and
    /// without vertex normals (one set against the winding), flipped or
    /// not.
    #[test]
    fn point_and_normal_is_the_interactions() {
        let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        let against = vec![Vec3::new(0.1, 0.0, -1.0).normalize(); 3];
        for normals in [vec![], against] {
            for flip in [false, true] {
                let m = TriangleMesh::new(
                    positions.clone(),
                    normals.clone(),
                    vec![],
                    vec![[0, 1, 2]],
                    false,
                    flip,
                )
                .unwrap();
                let meshes = [m];
                let shape = MeshShape { mesh: 0 };
                let ray = Ray::new(Vec3::new(0.2, 0.3, 1.0), Vec3::new(0.1, -0.2, -1.0));
                let hit = shape.intersect(&meshes, 0, &ray).expect("the ray hits");
                let si = shape.interaction(&meshes, 0, &ray, hit);
                let (p, n) = shape.point_and_normal(&meshes, 0, &ray, hit);
                assert!((p - si.p).length() < 1e-6, "{p} vs {}", si.p);
                assert_eq!(n, si.n, "normals {}, flip {flip}", normals.len());
            }
        }
    }

    /// A placed copy shows what an instance with that transform shows:
    /// moved points, and normals that keep their side (the transformed
    /// normal), a mirror included; its areas are the placed ones.
    #[test]
    fn placed_mesh_is_what_an_instance_shows() {
        // Flat-shaded: its normals come from the winding alone.
        let smooth = uneven_planar_mesh();
        let mesh = TriangleMesh::new(
            smooth.positions,
            vec![],
            vec![],
            smooth.indices,
            true,
            false,
        )
        .unwrap();
        let mirror = crate::math::Transform::new(
            glam::Affine3A::from_translation(Vec3::new(1.0, 2.0, 0.0))
                * glam::Affine3A::from_scale(Vec3::new(-1.0, 2.0, 1.0)),
        )
        .unwrap();
        let placed = mesh.placed(&mirror);
        let u = Vec2::new(0.3, 0.6);
        for tri in 0..mesh.triangle_count() {
            let (a, b) = (mesh.sample_triangle(tri, u), placed.sample_triangle(tri, u));
            let n = mirror.normal(a.n).normalize();
            assert!((b.n - n).length() < 1e-5, "triangle {tri}: {} vs {n}", b.n);
            let [p0, p1, p2] = mesh.triangle(tri).map(|p| mirror.point(p));
            let area = 0.5 * (p1 - p0).cross(p2 - p0).length();
            assert!(
                (area * b.pdf - 1.0).abs() < 1e-4,
                "triangle {tri}: pdf {}",
                b.pdf
            );
        }
    }

    /// One triangle's direction sampling against its density, from points
    /// near it (by solid angle, in front, behind and nearly edge-on) and
    /// farther (by area).
    #[test]
    fn chi2_triangle_direction_sampling() {
        use crate::testing::chi2::{chi2_directions, Chi2Config};
        let mesh = uneven_planar_mesh();
        let cfg = Chi2Config {
            integration_res: 24,
            ..Chi2Config::default()
        };
        for tri in [2usize, 5] {
            let [p0, p1, p2] = mesh.vertices(tri);
            let centroid = (p0 + p1 + p2) / 3.0;
            let n = (p1 - p0).cross(p2 - p0).normalize();
            let edge = (p1 - p0).normalize();
            for (offset, spherical) in [
                (0.3 * n + 0.1 * edge, true),
                (-0.4 * n - 0.2 * edge, true),
                (0.05 * n + 0.6 * edge, true),
                (3.0 * n + 1.0 * edge, false),
            ] {
                let ref_p = centroid + offset;
                assert_eq!(mesh.spherical_triangle(tri, ref_p).is_some(), spherical);
                chi2_directions(
                    &cfg,
                    |r: &mut crate::sampler::Pcg32| {
                        let s = mesh.sample_triangle_direction(tri, ref_p, r.next_2d());
                        (s.pdf > 0.0).then(|| ((s.p - ref_p).normalize(), s.pdf))
                    },
                    |d| {
                        let ray = Ray::new(ref_p, d);
                        mesh.intersect_triangle(tri, &ray)
                            .map(|h| {
                                let (p, n, ..) = mesh.surface_at(tri, h.uv);
                                mesh.pdf_triangle_direction(tri, ref_p, p, n)
                            })
                            .unwrap_or(0.0)
                    },
                )
                .unwrap();
            }
        }
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

    /// A unit quad in the z = 0 plane, normal +z, with uvs (u(x), v(y)).
    fn quad(uv: impl Fn(Vec2) -> Vec2) -> TriangleMesh {
        let corners = [Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y];
        TriangleMesh::new(
            corners.iter().map(|c| c.extend(0.0)).collect(),
            vec![Vec3::Z; 4],
            corners.iter().map(|&c| uv(c)).collect(),
            vec![[0, 1, 2], [0, 2, 3]],
            false,
            false,
        )
        .unwrap()
    }

    #[test]
    fn mikktspace_tangents_follow_u_with_the_bitangent_sign() {
        // u along +x, v along +y: tangent +x, bitangent n × t = +y = ∂p/∂v.
        let mut m = quad(|c| c);
        assert!(m.compute_tangents());
        for t in m.tangents.iter().flatten() {
            assert!((*t - Vec4::new(1.0, 0.0, 0.0, 1.0)).length() < 1e-5, "{t}");
        }
        // v mirrored: the bitangent points against n × t.
        let mut m = quad(|c| Vec2::new(c.x, 1.0 - c.y));
        m.compute_tangents();
        for t in m.tangents.iter().flatten() {
            assert!((*t - Vec4::new(1.0, 0.0, 0.0, -1.0)).length() < 1e-5, "{t}");
        }
        // u mirrored: tangent −x, sign −1 (∂p/∂v is still +y).
        let mut m = quad(|c| Vec2::new(1.0 - c.x, c.y));
        m.compute_tangents();
        for t in m.tangents.iter().flatten() {
            assert!(
                (*t - Vec4::new(-1.0, 0.0, 0.0, -1.0)).length() < 1e-5,
                "{t}"
            );
        }
        // Hits carry the interpolated tangent; meshes without uvs have none.
        let hit = PrimHit {
            t: 1.0,
            uv: Vec2::new(0.2, 0.3),
        };
        let ray = Ray::new(Vec3::new(0.5, 0.4, 1.0), -Vec3::Z);
        let shape = MeshShape { mesh: 0 };
        let si = shape.interaction(std::slice::from_ref(&m), 1, &ray, hit);
        assert!((si.tangent - Vec4::new(-1.0, 0.0, 0.0, -1.0)).length() < 1e-5);
        let mut bare = quad(|c| c);
        bare.uvs.clear();
        assert!(!bare.compute_tangents() && bare.tangents.is_empty());
    }

    #[test]
    fn mikktspace_tangents_on_a_sphere_are_smooth_and_along_u() {
        // A uv sphere: u = φ / 2π around z, v = θ / π from +z.
        let (nu, nv) = (32, 16);
        let mut positions = Vec::new();
        let mut uvs = Vec::new();
        for j in 0..=nv {
            for i in 0..=nu {
                let (u, v) = (i as f32 / nu as f32, j as f32 / nv as f32);
                let (phi, theta) = (u * std::f32::consts::TAU, v * std::f32::consts::PI);
                positions.push(Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                ));
                uvs.push(Vec2::new(u, v));
            }
        }
        let mut indices = Vec::new();
        for j in 0..nv {
            for i in 0..nu {
                let a = j * (nu + 1) + i;
                let (b, c, d) = (a + 1, a + nu + 2, a + nu + 1);
                indices.push([a, d, c]);
                indices.push([a, c, b]);
            }
        }
        let normals = positions.clone();
        let mut m = TriangleMesh::new(positions, normals, uvs, indices, false, false).unwrap();
        assert!(m.compute_tangents());
        for (tri, corners) in m.indices.iter().zip(&m.tangents) {
            for (k, t) in corners.iter().enumerate() {
                let p = m.positions[tri[k] as usize];
                if p.z.abs() > 0.95 {
                    continue; // the poles' tangents are arbitrary
                }
                let along_u = Vec3::new(-p.y, p.x, 0.0).normalize();
                assert!(
                    t.truncate().dot(p).abs() < 1e-3,
                    "tangent not ⟂ normal at {p}"
                );
                assert!(t.truncate().dot(along_u) > 0.99, "{t} at {p}");
                // v grows towards −z, and n × ∂p/∂u points to +z there.
                assert_eq!(t.w, -1.0);
            }
        }
    }
}
