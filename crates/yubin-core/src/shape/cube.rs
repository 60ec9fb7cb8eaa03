//! `cube`: the axis-aligned cube [-1, 1]³, built as a 12-triangle mesh
//! with per-face vertices (so normals are flat), as in Mitsuba 3.
//!
//! | parameter      | type      | default  | meaning                         |
//! |----------------|-----------|----------|---------------------------------|
//! | `to_world`     | transform | identity | placement                       |
//! | `flip_normals` | boolean   | false    | normals point inward            |
//!
//! ```xml
//! <shape type="cube"><transform name="to_world"><scale value="0.5"/></transform></shape>
//! ```
//!
//! Each face's uv spans [0, 1]².

use super::TriangleMesh;
use crate::params::{ParamError, Params};
use glam::{Vec2, Vec3};

/// The unit cube mesh in object space (call [`TriangleMesh::transform`]
/// to place it).
pub fn cube_mesh() -> TriangleMesh {
    cube_mesh_with(false)
}

/// The `cube` plugin.
#[derive(Debug)]
pub struct Cube;

impl Cube {
    /// Builds the cube's mesh from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<TriangleMesh, ParamError> {
        let mut mesh = cube_mesh_with(p.boolean_or("flip_normals", false)?);
        mesh.transform(&p.transform_or_identity("to_world")?);
        Ok(mesh)
    }
}

/// The cube, optionally with flipped normals.
pub fn cube_mesh_with(flip_normals: bool) -> TriangleMesh {
    let mut positions = Vec::with_capacity(24);
    let mut normals = Vec::with_capacity(24);
    let mut uvs = Vec::with_capacity(24);
    let mut indices = Vec::with_capacity(12);
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let n = Vec3::from_array(std::array::from_fn(|i| if i == axis { sign } else { 0.0 }));
            // Tangents chosen so that (s, t, n) is right-handed: faces wind
            // counter-clockwise seen from outside.
            let s = Vec3::from_array(std::array::from_fn(|i| {
                if i == (axis + 1) % 3 {
                    1.0
                } else {
                    0.0
                }
            }));
            let t = n.cross(s);
            let base = positions.len() as u32;
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                positions.push(n + s * a + t * b);
                normals.push(n);
                uvs.push(Vec2::new((a + 1.0) * 0.5, (b + 1.0) * 0.5));
            }
            indices.push([base, base + 1, base + 2]);
            indices.push([base, base + 2, base + 3]);
        }
    }
    // Infallible: the indices above are in range by construction.
    TriangleMesh::new(positions, normals, uvs, indices, false, flip_normals).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_is_closed_and_outward() {
        let m = cube_mesh();
        assert_eq!(m.triangle_count(), 12);
        assert!((m.area() - 24.0).abs() < 1e-4);
        for tri in &m.indices {
            let p = tri.map(|i| m.positions[i as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            let c = (p[0] + p[1] + p[2]) / 3.0;
            assert!(n.dot(c) > 0.0, "winding must face outward");
        }
    }
}
