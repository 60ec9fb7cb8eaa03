//! Triangle mesh loaders (OBJ, PLY, Mitsuba serialized) producing plain [`MeshData`].

pub mod obj;
pub mod ply;
pub mod serialized;

use glam::{Vec2, Vec3};
use yubin_core::texture::NamedAttribute;

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
