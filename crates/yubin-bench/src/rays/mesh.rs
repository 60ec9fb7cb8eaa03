//! The benchmark meshes: raybench's displaced cube-sphere and the Stanford
//! dragon.
//!
//! The cube-sphere follows the definition in
//! `../shared/tools/raybench/README.md` (its `src/mesh.rs`), so that our
//! numbers sit beside raybench's: each cube face is an `n × n` grid of
//! quads, two triangles each (`12 n²` triangles); grid points have exact
//! integer coordinates in `[-n, n]³` (step 2 on a face) and are shared
//! between faces through a map keyed on those integers, so the mesh is
//! closed and watertight. Points are projected to the unit sphere and
//! their radius is displaced by a smooth sum of three sine products, at
//! most ±0.16. Faces come in the order +x, −x, +y, −y, +z, −z, quads row
//! by row, so triangle indices equal raybench's.

use anyhow::{bail, Context, Result};
use std::collections::HashMap;
use std::path::Path;

/// An indexed triangle mesh, as the benchmark hands it to every backend.
#[derive(Debug, Clone)]
pub struct Mesh {
    /// Display name (`cubesphere-n289`, `dragon`).
    pub name: String,
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Three vertex indices per triangle.
    pub indices: Vec<[u32; 3]>,
}

impl Mesh {
    /// Axis-aligned bounds `(lo, hi)` of the vertices.
    pub fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in &self.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        (lo, hi)
    }

    /// The corners of triangle `i`.
    pub fn triangle(&self, i: u32) -> [[f32; 3]; 3] {
        self.indices[i as usize].map(|v| self.positions[v as usize])
    }

    /// Edge statistics: (edges used by one triangle only, directed edges
    /// used more than once). Both are 0 for a closed, consistently wound
    /// manifold mesh.
    pub fn edge_report(&self) -> (usize, usize) {
        let mut directed: HashMap<(u32, u32), u32> = HashMap::with_capacity(self.indices.len() * 3);
        for t in &self.indices {
            for k in 0..3 {
                *directed.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        let mut open = 0;
        let mut repeated = 0;
        for (&(a, b), &n) in &directed {
            if n > 1 {
                repeated += 1;
            }
            if !directed.contains_key(&(b, a)) {
                open += 1;
            }
        }
        (open, repeated)
    }
}

/// The radial displacement, evaluated on the unit sphere in f64.
fn displaced(p: [f64; 3]) -> [f32; 3] {
    let len = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
    let [x, y, z] = p.map(|c| c / len);
    let low = 0.10 * (5.0 * x + 1.0).sin() * (6.0 * y + 2.0).sin() * (7.0 * z + 3.0).sin();
    let mid = 0.04 * (17.0 * x + 11.0 * y).sin() * (13.0 * z + 0.5).cos();
    let high = 0.02 * (41.0 * y + 3.0 * z).sin() * (37.0 * x + 1.3).sin();
    let r = 1.0 + low + mid + high;
    [(x * r) as f32, (y * r) as f32, (z * r) as f32]
}

/// The displaced cube-sphere with `12 n²` triangles (see the module docs).
pub fn cube_sphere(n: u32) -> Mesh {
    let n = i64::from(n);
    let mut ids: HashMap<[i64; 3], u32> = HashMap::new();
    let mut positions: Vec<[f32; 3]> = Vec::new();
    let mut indices: Vec<[u32; 3]> = Vec::with_capacity((12 * n * n) as usize);
    let mut vertex = |c: [i64; 3]| -> u32 {
        *ids.entry(c).or_insert_with(|| {
            positions.push(displaced(c.map(|v| v as f64 / n as f64)));
            positions.len() as u32 - 1
        })
    };
    // (normal axis, sign); the two in-face axes are ordered so that
    // (u, v, normal) is right-handed and the +sign faces wind outward.
    for (axis, sign) in [(0, 1), (0, -1), (1, 1), (1, -1), (2, 1), (2, -1)] {
        let (u, v) = [(1, 2), (2, 0), (0, 1)][axis];
        let corner = |i: i64, j: i64| {
            let mut c = [0i64; 3];
            c[axis] = sign * n;
            c[u] = 2 * i - n;
            c[v] = 2 * j - n;
            c
        };
        for j in 0..n {
            for i in 0..n {
                let a = vertex(corner(i, j));
                let b = vertex(corner(i + 1, j));
                let c = vertex(corner(i + 1, j + 1));
                let d = vertex(corner(i, j + 1));
                if sign > 0 {
                    indices.extend([[a, b, c], [a, c, d]]);
                } else {
                    indices.extend([[a, c, b], [a, d, c]]);
                }
            }
        }
    }
    Mesh {
        name: format!("cubesphere-n{n}"),
        positions,
        indices,
    }
}

/// Loads the Stanford dragon that `setup.sh` unpacks (ASCII PLY).
pub fn dragon(path: &Path) -> Result<Mesh> {
    if !path.exists() {
        bail!(
            "{} is missing: run crates/yubin-bench/setup.sh first",
            path.display()
        );
    }
    let data = yubin_scene::mesh::ply::load_ply(path)
        .with_context(|| format!("loading {}", path.display()))?;
    Ok(Mesh {
        name: "dragon".into(),
        positions: data.positions.iter().map(|p| p.to_array()).collect(),
        indices: data.indices,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_sphere_counts_match_raybench() {
        // raybench README: n=92 gives 101,568 triangles, n=289 1,002,252.
        let m = cube_sphere(92);
        assert_eq!(m.indices.len(), 101_568);
        // 6 n² + 2 distinct grid points on a closed cube surface.
        assert_eq!(m.positions.len(), 6 * 92 * 92 + 2);
        assert_eq!(12 * 289 * 289, 1_002_252);
    }

    #[test]
    fn cube_sphere_is_closed_and_consistently_wound() {
        let m = cube_sphere(7);
        assert_eq!(m.edge_report(), (0, 0));
        // Outward winding: the signed volume is positive.
        let mut volume = 0.0f64;
        for i in 0..m.indices.len() as u32 {
            let [a, b, c] = m.triangle(i).map(|p| p.map(f64::from));
            volume += (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0]))
                / 6.0;
        }
        assert!(volume > 3.0 && volume < 5.5, "volume {volume}");
    }

    #[test]
    fn displacement_stays_within_bounds() {
        let m = cube_sphere(16);
        for p in &m.positions {
            let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            assert!((r - 1.0).abs() <= 0.16 + 1e-6, "radius {r}");
        }
    }
}
