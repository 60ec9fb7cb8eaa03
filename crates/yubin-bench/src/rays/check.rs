//! Do yubin and Embree agree? Closest hits are compared ray by ray, like
//! raybench's correctness section, and every disagreement is then looked
//! at with an f64 ray–triangle test to tell edge cases from errors.
//!
//! | count | meaning |
//! |---|---|
//! | `hit≠` | one backend hits, the other misses |
//! | `t≠` | both hit, distances differ by more than [`REL_T`] |
//! | `prim≠` | same distance, different triangle (a near-tie) |
//! | unexplained | a disagreement that is *not* a ray through an edge or vertex, a grazing ray, or a genuine tie |
//!
//! A `hit≠` or `t≠` is explained when the nearer reported hit really is
//! on its triangle (f64 distance agrees) within [`EDGE`] of an edge in
//! barycentric terms, or the ray grazes it: a non-watertight test (Embree's
//! default) can slip through there. A `prim≠` is explained when both
//! triangles are really hit at that distance (shared edges, vertices and
//! duplicate triangles).

use super::mesh::Mesh;
use super::raygen::BenchRay;
use super::Hit;

/// Relative distance tolerance, on distances in the canonical frame
/// (divided by the frame scale) and relative to max(t, 1), as raybench.
pub const REL_T: f64 = 1e-4;
/// How near an edge (smallest barycentric coordinate) counts as on it.
pub const EDGE: f64 = 1e-4;
/// |cos| between ray and triangle plane below which a ray grazes it.
const GRAZING: f64 = 1e-4;

/// Counts of disagreements between two closest-hit result sets.
#[derive(Clone, Debug, Default)]
pub struct Agreement {
    /// Rays the reference hits.
    pub ref_hits: usize,
    /// Hit versus miss.
    pub hit_mismatch: usize,
    /// Both hit at different distances.
    pub t_mismatch: usize,
    /// Same distance, different triangle.
    pub prim_mismatch: usize,
    /// Disagreements that are not edge, grazing or tie cases.
    pub unexplained: usize,
    /// Largest relative distance difference among rays that agree.
    pub max_rel_dt: f64,
    /// The first few unexplained rays: (ray index, reference hit, test hit).
    pub examples: Vec<(usize, Hit, Hit)>,
}

/// How many unexplained rays [`compare`] keeps as examples.
const EXAMPLES: usize = 5;

/// Where the f64 test puts a ray against a triangle: distance, smallest
/// barycentric coordinate (negative outside), and |cos| to the plane.
fn exact_hit(mesh: &Mesh, prim: u32, r: &BenchRay) -> Option<(f64, f64, f64)> {
    let [a, b, c] = mesh.triangle(prim).map(|p| p.map(f64::from));
    let o = r.o.map(f64::from);
    let d = r.d.map(f64::from);
    let sub = |x: [f64; 3], y: [f64; 3]| [x[0] - y[0], x[1] - y[1], x[2] - y[2]];
    let dot = |x: [f64; 3], y: [f64; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
    let cross = |x: [f64; 3], y: [f64; 3]| {
        [
            x[1] * y[2] - x[2] * y[1],
            x[2] * y[0] - x[0] * y[2],
            x[0] * y[1] - x[1] * y[0],
        ]
    };
    let (e1, e2) = (sub(b, a), sub(c, a));
    let n = cross(e1, e2);
    let n_len = dot(n, n).sqrt();
    let p = cross(d, e2);
    let det = dot(e1, p);
    if det == 0.0 || n_len == 0.0 {
        return None;
    }
    let s = sub(o, a);
    let q = cross(s, e1);
    let u = dot(s, p) / det;
    let v = dot(d, q) / det;
    let t = dot(e2, q) / det;
    let cos = dot(d, n).abs() / n_len;
    Some((t, u.min(v).min(1.0 - u - v), cos))
}

fn rel_dt(a: f64, b: f64, scale: f64) -> f64 {
    let (a, b) = (a / scale, b / scale);
    (a - b).abs() / a.abs().max(1.0)
}

/// The hit is real and at an edge or grazing.
fn edge_hit(mesh: &Mesh, r: &BenchRay, h: Hit, scale: f64) -> bool {
    exact_hit(mesh, h.prim, r).is_some_and(|(t, bary, cos)| {
        rel_dt(t, f64::from(h.t), scale) <= REL_T && (bary.abs() <= EDGE || cos <= GRAZING)
    })
}

/// The hit is real: the f64 test puts it on its triangle (up to the edge
/// tolerance) at the same distance. `scale` as in [`compare`].
pub fn on_triangle(mesh: &Mesh, r: &BenchRay, h: Hit, scale: f32) -> bool {
    real_hit(mesh, r, h, f64::from(scale))
}

fn real_hit(mesh: &Mesh, r: &BenchRay, h: Hit, scale: f64) -> bool {
    exact_hit(mesh, h.prim, r)
        .is_some_and(|(t, bary, _)| rel_dt(t, f64::from(h.t), scale) <= REL_T && bary >= -EDGE)
}

/// Compares `test` against `reference` (closest hits on the same rays).
/// `scale` is the ray frame's scale, so that distances compare in
/// canonical units.
pub fn compare(
    mesh: &Mesh,
    rays: &[BenchRay],
    reference: &[Hit],
    test: &[Hit],
    scale: f32,
) -> Agreement {
    let scale = f64::from(scale);
    let mut a = Agreement::default();
    for (i, ((r, &x), &y)) in rays.iter().zip(reference).zip(test).enumerate() {
        let before = a.unexplained;
        a.ref_hits += usize::from(x.is_hit());
        match (x.is_hit(), y.is_hit()) {
            (false, false) => {}
            (true, false) | (false, true) => {
                a.hit_mismatch += 1;
                let h = if x.is_hit() { x } else { y };
                if !edge_hit(mesh, r, h, scale) {
                    a.unexplained += 1;
                }
            }
            (true, true) => {
                let rel = rel_dt(f64::from(x.t), f64::from(y.t), scale);
                if rel > REL_T {
                    a.t_mismatch += 1;
                    let nearer = if x.t < y.t { x } else { y };
                    if !edge_hit(mesh, r, nearer, scale) {
                        a.unexplained += 1;
                    }
                } else {
                    a.max_rel_dt = a.max_rel_dt.max(rel);
                    if x.prim != y.prim {
                        a.prim_mismatch += 1;
                        if !(real_hit(mesh, r, x, scale) && real_hit(mesh, r, y, scale)) {
                            a.unexplained += 1;
                        }
                    }
                }
            }
        }
        if a.unexplained > before && a.examples.len() < EXAMPLES {
            a.examples.push((i, x, y));
        }
    }
    a
}

/// What the f64 test says about `h` on ray `r`, for the log.
pub fn describe(mesh: &Mesh, r: &BenchRay, h: Hit) -> String {
    if !h.is_hit() {
        return "miss".into();
    }
    match exact_hit(mesh, h.prim, r) {
        Some((t, bary, cos)) => format!(
            "prim {} t {} (f64: t {t:.7}, min barycentric {bary:.2e}, |cos| {cos:.2e})",
            h.prim, h.t
        ),
        None => format!("prim {} t {} (f64: parallel or degenerate)", h.prim, h.t),
    }
}

/// Closest hits by testing every triangle in f64 (hits with t > 0 and all
/// barycentric coordinates ≥ 0), for short ray lists.
pub fn brute_force(mesh: &Mesh, rays: &[BenchRay]) -> Vec<Hit> {
    use rayon::prelude::*;
    rays.par_iter()
        .map(|r| {
            let mut best = (f64::INFINITY, u32::MAX);
            for prim in 0..mesh.indices.len() as u32 {
                if let Some((t, bary, _)) = exact_hit(mesh, prim, r) {
                    if t > 0.0 && bary >= 0.0 && t < best.0 {
                        best = (t, prim);
                    }
                }
            }
            if best.1 == u32::MAX {
                Hit::MISS
            } else {
                Hit {
                    t: best.0 as f32,
                    prim: best.1,
                }
            }
        })
        .collect()
}

/// Rays whose any-hit answer differs from "the closest hit exists".
pub fn occluded_vs_closest(closest: &[Hit], occluded: &[bool]) -> usize {
    closest
        .iter()
        .zip(occluded)
        .filter(|(h, &o)| h.is_hit() != o)
        .count()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> Mesh {
        Mesh {
            name: "quad".into(),
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
            indices: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    fn down(x: f32, y: f32) -> BenchRay {
        BenchRay {
            o: [x, y, 1.0],
            d: [0.0, 0.0, -1.0],
        }
    }

    #[test]
    fn classifies_disagreements() {
        let mesh = quad();
        let rays = [
            down(0.7, 0.2),
            down(0.5, 0.5),
            down(0.5, 0.5),
            down(0.2, 0.7),
            down(2.0, 2.0),
        ];
        let reference = [
            Hit { t: 1.0, prim: 0 },
            Hit { t: 1.0, prim: 0 },
            Hit { t: 1.0, prim: 1 },
            Hit { t: 1.0, prim: 1 },
            Hit::MISS,
        ];
        let test = [
            Hit { t: 1.0, prim: 0 }, // agrees
            Hit { t: 1.0, prim: 1 }, // tie on the shared diagonal: explained
            Hit::MISS,               // slipped through the diagonal: explained
            Hit { t: 1.0, prim: 0 }, // wrong triangle: unexplained
            Hit { t: 3.0, prim: 0 }, // hit out of nowhere: unexplained
        ];
        let a = compare(&mesh, &rays, &reference, &test, 1.0);
        assert_eq!(a.hit_mismatch, 2);
        assert_eq!(a.prim_mismatch, 2);
        assert_eq!(a.t_mismatch, 0);
        assert_eq!(a.unexplained, 2);
        assert_eq!(a.ref_hits, 4);
    }

    #[test]
    fn any_hit_must_match_closest_hit() {
        let closest = [Hit { t: 1.0, prim: 0 }, Hit::MISS, Hit::MISS];
        assert_eq!(occluded_vs_closest(&closest, &[true, false, true]), 1);
    }
}
