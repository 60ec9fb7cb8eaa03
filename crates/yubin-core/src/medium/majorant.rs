//! A majorant grid: a coarse grid whose cells hold the largest value the
//! fine grid's trilinear lookup can take inside them, walked along a ray
//! by a 3D DDA (Amanatides and Woo 1987, "A fast voxel traversal
//! algorithm for ray tracing"), so that tracking through a sparse medium
//! takes big steps through thin or empty regions instead of being bounded
//! by the densest voxel everywhere (pbrt-v4's `MajorantGrid`, Mitsuba 3's
//! DDA tracking).

use super::Grid;
use crate::math::Bounds3;
use glam::Vec3;

/// Per-cell majorants of a [`Grid`].
#[derive(Clone, Debug, PartialEq)]
pub struct MajorantGrid {
    res: [u32; 3],
    bounds: Bounds3,
    max: Vec<f32>,
}

impl MajorantGrid {
    /// Majorants of `grid` on a `res` grid over the same box: each cell
    /// takes the largest value (any channel) of every voxel whose
    /// interpolation footprint reaches into it.
    pub fn new(grid: &Grid, res: [u32; 3]) -> Self {
        let res = res.map(|r| r.max(1));
        // Voxel index range that influences [lo, hi) of majorant cells
        // along one axis (voxel centres at i + 1/2).
        let span = |axis: usize, c: u32| {
            let (vr, mr) = (grid.res[axis] as f32, res[axis] as f32);
            let lo = c as f32 * vr / mr - 0.5;
            let hi = (c + 1) as f32 * vr / mr - 0.5;
            let first = (crate::math::floor(lo) as i64).clamp(0, vr as i64 - 1);
            let last = (crate::math::floor(hi) as i64 + 1).clamp(0, vr as i64 - 1);
            first..=last
        };
        let mut max = Vec::with_capacity((res[0] * res[1] * res[2]) as usize);
        for z in 0..res[2] {
            for y in 0..res[1] {
                for x in 0..res[0] {
                    let mut m = 0.0f32;
                    for vz in span(2, z) {
                        for vy in span(1, y) {
                            for vx in span(0, x) {
                                m = m.max(grid.voxel_max([vx as u32, vy as u32, vz as u32]));
                            }
                        }
                    }
                    max.push(m);
                }
            }
        }
        Self {
            res,
            bounds: grid.bounds,
            max,
        }
    }

    /// The majorant of the cell holding `p` (zero outside the box).
    pub fn majorant_at(&self, p: Vec3) -> f32 {
        let b = &self.bounds;
        if !(p.cmpge(b.min).all() && p.cmplt(b.max).all()) {
            return 0.0;
        }
        let q = (p - b.min) / (b.max - b.min);
        let c =
            [0, 1, 2].map(|a| ((q[a] * self.res[a] as f32) as usize).min(self.res[a] as usize - 1));
        self.max[(c[2] * self.res[1] as usize + c[1]) * self.res[0] as usize + c[0]]
    }

    /// Walks the ray `o + t d` over [`t0`, `t1`] through the cells it
    /// crosses inside the box, calling `visit(t_start, t_end, majorant)`
    /// for each, in order, until `visit` returns false. Parts of the ray
    /// outside the box are not visited (their density is zero).
    pub fn walk(
        &self,
        o: Vec3,
        d: Vec3,
        t0: f32,
        t1: f32,
        mut visit: impl FnMut(f32, f32, f32) -> bool,
    ) {
        let b = &self.bounds;
        let inv = d.recip();
        let (ta, tb) = ((b.min - o) * inv, (b.max - o) * inv);
        let (near, far) = (ta.min(tb), ta.max(tb));
        let mut t = t0.max(near.max_element());
        let end = t1.min(far.min_element());
        // Also when a NaN (a ray that misses along a zero direction) got in.
        if t >= end || t.is_nan() || end.is_nan() {
            return;
        }
        let res = Vec3::new(self.res[0] as f32, self.res[1] as f32, self.res[2] as f32);
        let size = b.max - b.min;
        let cell_size = size / res;
        let p = (o + d * t - b.min) / cell_size;
        let mut cell = [0usize; 3];
        let mut next = [0f32; 3];
        let mut step = [0i64; 3];
        let mut delta = [0f32; 3];
        for a in 0..3 {
            let c = (crate::math::floor(p[a]) as i64).clamp(0, self.res[a] as i64 - 1);
            cell[a] = c as usize;
            if d[a] > 0.0 {
                step[a] = 1;
                next[a] =
                    t + ((c + 1) as f32 * cell_size[a] + b.min[a] - (o[a] + d[a] * t)) * inv[a];
                delta[a] = cell_size[a] * inv[a];
            } else if d[a] < 0.0 {
                step[a] = -1;
                next[a] = t + (c as f32 * cell_size[a] + b.min[a] - (o[a] + d[a] * t)) * inv[a];
                delta[a] = -cell_size[a] * inv[a];
            } else {
                next[a] = f32::INFINITY;
                delta[a] = f32::INFINITY;
            }
        }
        loop {
            let axis = if next[0] < next[1] {
                if next[0] < next[2] {
                    0
                } else {
                    2
                }
            } else if next[1] < next[2] {
                1
            } else {
                2
            };
            let exit = next[axis].min(end);
            let i = (cell[2] * self.res[1] as usize + cell[1]) * self.res[0] as usize + cell[0];
            if exit > t && !visit(t, exit, self.max[i]) {
                return;
            }
            if exit >= end {
                return;
            }
            t = exit;
            let c = cell[axis] as i64 + step[axis];
            if c < 0 || c >= self.res[axis] as i64 {
                return;
            }
            cell[axis] = c as usize;
            next[axis] += delta[axis];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;

    /// A sparse grid: zero except a small dense blob, and a smooth ramp.
    fn blob() -> Grid {
        let n = 12;
        let mut data = vec![0.0; n * n * n];
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let p = Vec3::new(x as f32, y as f32, z as f32) - Vec3::new(8.0, 3.0, 5.0);
                    if p.length() < 2.0 {
                        data[(z * n + y) * n + x] = 10.0 - p.length();
                    }
                }
            }
        }
        let bounds = Bounds3 {
            min: Vec3::new(-1.0, -2.0, 0.0),
            max: Vec3::new(2.0, 1.0, 1.5),
        };
        Grid::new([n as u32; 3], 1, bounds, data).unwrap()
    }

    /// Along random rays, every point the walk visits has a density at
    /// most its cell's majorant, the visited intervals tile the part of
    /// the ray inside the box, and the empty part of a sparse grid gets
    /// majorant zero.
    #[test]
    fn majorants_bound_the_density_along_any_ray() {
        let g = blob();
        let m = MajorantGrid::new(&g, [4, 5, 3]);
        let mut rng = Pcg32::new(4, 4);
        let mut zero_cells = 0;
        for _ in 0..500 {
            let o =
                Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 6.0 - Vec3::splat(3.0);
            let d = (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5).normalize();
            let mut last_end: Option<f32> = None;
            let mut covered = 0.0;
            m.walk(o, d, 0.0, 20.0, |a, b, maj| {
                if let Some(e) = last_end {
                    assert!((a - e).abs() < 1e-4, "gap from {e} to {a}");
                }
                last_end = Some(b);
                covered += b - a;
                if maj == 0.0 {
                    zero_cells += 1;
                }
                // The segment lies in the cell whose majorant it carries.
                let mid = o + d * (0.5 * (a + b));
                assert_eq!(maj, m.majorant_at(mid), "segment [{a}, {b}]");
                for k in 0..16 {
                    let t = a + (b - a) * (k as f32 + 0.5) / 16.0;
                    let v = g.eval(o + d * t).max_element();
                    assert!(
                        v <= maj + 1e-4,
                        "density {v} above majorant {maj} at t = {t}"
                    );
                }
                true
            });
            // The whole chord through the box is covered.
            let inv = d.recip();
            let (ta, tb) = ((g.bounds.min - o) * inv, (g.bounds.max - o) * inv);
            let (t_in, t_out) = (
                ta.min(tb).max_element().max(0.0),
                ta.max(tb).min_element().min(20.0),
            );
            let chord = (t_out - t_in).max(0.0);
            assert!(
                (covered - chord).abs() < 1e-3,
                "covered {covered} of {chord}"
            );
        }
        assert!(
            zero_cells > 100,
            "a sparse grid should have empty cells ({zero_cells})"
        );
    }
}
