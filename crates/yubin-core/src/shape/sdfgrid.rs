//! `sdfgrid`: Mitsuba 3's signed distance grid: distances sampled on a
//! grid over the unit cube [0, 1]³, the surface where their trilinear
//! interpolant is zero.
//!
//! | parameter      | type      | default  | meaning |
//! |----------------|-----------|----------|---------|
//! | `filename`     | string    | required | a one-channel Mitsuba `.vol` grid (its bounding box is ignored, as Mitsuba does) |
//! | `normals`      | string    | `smooth` | shading normals: `analytic` (the interpolant's gradient, discontinuous across voxels) or `smooth` |
//! | `to_world`     | transform | identity | placement of the unit cube |
//! | `flip_normals` | boolean   | false    | normals point inward |
//!
//! ```xml
//! <shape type="sdfgrid">
//!     <string name="filename" value="sdfgrid/torus_sdfgrid.vol"/>
//!     <string name="normals" value="smooth"/>
//! </shape>
//! ```
//!
//! A grid of n samples along an axis has n − 1 voxels there, the samples
//! at i/(n − 1). Each voxel the surface passes through (its corners'
//! values not all of one sign) is a primitive in the BVH. Within a voxel
//! the interpolant along the ray is a cubic in t; its first root is
//! found by splitting the voxel's stretch of the ray at the roots of the
//! cubic's derivative, taking the first piece whose ends differ in sign,
//! and refining with Newton steps safeguarded by bisection (Hansson-
//! Söderlund, Evans and Akenine-Möller 2022, "Ray tracing of signed
//! distance function grids", JCGT 11(3)). The values where the ray
//! enters and leaves a voxel are taken with the crossed face's
//! coordinate exactly 0 or 1, so two voxels sharing a face agree on the
//! sign there and no ray slips between them.
//!
//! The geometric normal is the interpolant's gradient. `smooth` shading
//! normals blend the gradients of the eight voxels around the grid point
//! nearest the hit, each from differences of the interpolant across that
//! voxel along each axis, by the hit's trilinear weights relative to the
//! voxels' centres (the same paper, §5), continuous across voxels.
//!
//! As in Mitsuba, an `sdfgrid` has no texture coordinates (uv = 0) and
//! cannot carry an area emitter.
//!
//! The grid is stored once for the program's life (interned by content),
//! so that the shape stays a small `Copy` value in the scene's table.

use super::{PositionSample, PrimHit, ShapeModel, TriangleMesh};
use crate::interaction::SurfaceInteraction;
use crate::math::{Bounds3, Frame, Ray, Transform};
use crate::params::{ParamError, Params};
use glam::{IVec3, UVec3, Vec2, Vec3};
use std::sync::Mutex;

/// The samples of a distance grid and its voxels that hold surface.
#[derive(Debug, PartialEq)]
pub struct SdfGridData {
    /// Samples along x, y, z (each at least 2).
    res: UVec3,
    /// x fastest, then y, then z.
    values: Vec<f32>,
    /// Index of the lower corner sample of each voxel the surface crosses.
    voxels: Vec<u32>,
}

static INTERNED: Mutex<Vec<&'static SdfGridData>> = Mutex::new(Vec::new());

impl SdfGridData {
    /// The grid of `values` (x fastest) with `res` samples per axis;
    /// `None` when a side has fewer than 2 samples.
    pub fn new(res: [u32; 3], values: Vec<f32>) -> Option<Self> {
        let res = UVec3::from_array(res);
        if res.min_element() < 2 || values.len() != (res.x * res.y * res.z) as usize {
            return None;
        }
        let mut g = Self {
            res,
            values,
            voxels: Vec::new(),
        };
        for z in 0..res.z - 1 {
            for y in 0..res.y - 1 {
                for x in 0..res.x - 1 {
                    let base = g.index(UVec3::new(x, y, z));
                    let c = g.corners(base);
                    if c.iter().any(|v| *v >= 0.0) && c.iter().any(|v| *v <= 0.0) {
                        g.voxels.push(base);
                    }
                }
            }
        }
        Some(g)
    }

    /// The same grid stored for the program's life (once per content).
    pub fn interned(self) -> &'static SdfGridData {
        super::interned(&INTERNED, self)
    }

    /// Voxels the surface passes through.
    pub fn surface_voxels(&self) -> usize {
        self.voxels.len()
    }

    fn index(&self, v: UVec3) -> u32 {
        (v.z * self.res.y + v.y) * self.res.x + v.x
    }

    fn voxel_of(&self, base: u32) -> UVec3 {
        let (x, y) = (self.res.x, self.res.y);
        UVec3::new(base % x, base / x % y, base / (x * y))
    }

    /// The eight corner values of the voxel at `base`, indexed x + 2y + 4z.
    fn corners(&self, base: u32) -> [f32; 8] {
        let (x, xy) = (self.res.x, self.res.x * self.res.y);
        std::array::from_fn(|i| {
            let i = i as u32;
            self.values[(base + (i & 1) + ((i >> 1) & 1) * x + (i >> 2) * xy) as usize]
        })
    }

    /// The sample at `q`, clamped into the grid.
    fn sample(&self, q: IVec3) -> f32 {
        let q = q.clamp(IVec3::ZERO, self.res.as_ivec3() - 1).as_uvec3();
        self.values[self.index(q) as usize]
    }

    /// Voxels per unit along each axis.
    fn scale(&self) -> Vec3 {
        (self.res - 1).as_vec3()
    }
}

/// Linear interpolation that gives `a` and `b` exactly at 0 and 1.
#[inline]
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a * (1.0 - t) + b * t
}

#[inline]
fn bilerp(f: [f32; 4], u: f32, v: f32) -> f32 {
    lerp(lerp(f[0], f[1], u), lerp(f[2], f[3], u), v)
}

/// The trilinear interpolant of corner values `c` at `w` ∈ [0, 1]³.
#[inline]
fn trilerp(c: &[f32; 8], w: Vec3) -> f32 {
    lerp(
        bilerp([c[0], c[1], c[2], c[3]], w.x, w.y),
        bilerp([c[4], c[5], c[6], c[7]], w.x, w.y),
        w.z,
    )
}

/// The gradient of [`trilerp`] (per unit of `w`).
#[inline]
fn trilerp_gradient(c: &[f32; 8], w: Vec3) -> Vec3 {
    Vec3::new(
        bilerp(
            [c[1] - c[0], c[3] - c[2], c[5] - c[4], c[7] - c[6]],
            w.y,
            w.z,
        ),
        bilerp(
            [c[2] - c[0], c[3] - c[1], c[6] - c[4], c[7] - c[5]],
            w.x,
            w.z,
        ),
        bilerp(
            [c[4] - c[0], c[5] - c[1], c[6] - c[2], c[7] - c[3]],
            w.x,
            w.y,
        ),
    )
}

/// The coefficients (c0, c1, c2, c3) of the interpolant along o + t·d in
/// voxel coordinates: the sum over corners of the corner's value times
/// the product of its three linear weights.
fn cubic_along(c: &[f32; 8], o: Vec3, d: Vec3) -> [f32; 4] {
    let mut k = [0.0f32; 4];
    for (i, value) in c.iter().enumerate() {
        // Each weight is a + b·t: x for the upper corner, 1 − x for the lower.
        let w = |axis: usize, upper: bool| {
            if upper {
                (o[axis], d[axis])
            } else {
                (1.0 - o[axis], -d[axis])
            }
        };
        let (a, b, e) = (w(0, i & 1 != 0), w(1, i & 2 != 0), w(2, i & 4 != 0));
        k[0] += value * a.0 * b.0 * e.0;
        k[1] += value * (a.1 * b.0 * e.0 + a.0 * b.1 * e.0 + a.0 * b.0 * e.1);
        k[2] += value * (a.1 * b.1 * e.0 + a.1 * b.0 * e.1 + a.0 * b.1 * e.1);
        k[3] += value * a.1 * b.1 * e.1;
    }
    k
}

#[inline]
fn cubic(k: &[f32; 4], t: f32) -> f32 {
    ((k[3] * t + k[2]) * t + k[1]) * t + k[0]
}

/// Steps of the root refinement stop below this change in t.
const ROOT_EPSILON: f32 = 1e-5;

/// The first root of the cubic `k` in [0, len], where it takes the values
/// `f0` and `f1` at the ends.
fn first_root(k: &[f32; 4], len: f32, f0: f32, f1: f32) -> Option<f32> {
    // The derivative's roots split [0, len] into monotonic pieces.
    let (a, b, c) = (3.0 * k[3], 2.0 * k[2], k[1]);
    let mut cuts = [len; 2];
    if a != 0.0 {
        let disc = b * b - 4.0 * a * c;
        if disc >= 0.0 {
            let q = -0.5 * (b + disc.sqrt().copysign(b));
            let (r0, r1) = (q / a, if q != 0.0 { c / q } else { q / a });
            cuts = [r0.min(r1), r0.max(r1)];
        }
    } else if b != 0.0 {
        cuts[0] = -c / b;
    }
    let (mut t0, mut v0) = (0.0, f0);
    for cut in cuts.into_iter().filter(|t| *t > 0.0 && *t < len) {
        let v = cubic(k, cut);
        if v0 * v <= 0.0 {
            return Some(refine(k, t0, cut, v0));
        }
        (t0, v0) = (cut, v);
    }
    (v0 * f1 <= 0.0).then(|| refine(k, t0, len, v0))
}

/// Newton's method on the bracket [lo, hi] of a sign change, falling
/// back to bisection when a step leaves the bracket.
fn refine(k: &[f32; 4], mut lo: f32, mut hi: f32, f_lo: f32) -> f32 {
    let mut t = 0.5 * (lo + hi);
    for _ in 0..50 {
        let f = cubic(k, t);
        if f == 0.0 {
            return t;
        }
        if f * f_lo <= 0.0 {
            hi = t;
        } else {
            lo = t;
        }
        let slope = (3.0 * k[3] * t + 2.0 * k[2]) * t + k[1];
        let newton = t - f / slope;
        let next = if newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        let done = (next - t).abs() < ROOT_EPSILON;
        t = next;
        if done {
            break;
        }
    }
    t
}

/// An `sdfgrid` placed in the scene.
#[derive(Clone, Copy, Debug)]
pub struct SdfGrid {
    /// The samples.
    pub data: &'static SdfGridData,
    /// Unit cube to world.
    pub to_world: Transform,
    /// `smooth` shading normals (else `analytic`).
    pub smooth: bool,
    /// Normals point inward.
    pub flip_normals: bool,
}

impl SdfGrid {
    /// The shape from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let Some(grid) = p.grid_file("filename")? else {
            return Err(p.error("an sdfgrid needs a \"filename\""));
        };
        if grid.channels != 1 {
            return Err(p.param_error(
                "filename",
                &format!(
                    "an sdfgrid has one channel, this grid has {}",
                    grid.channels
                ),
            ));
        }
        let data = SdfGridData::new(grid.res, grid.values().to_vec()).ok_or_else(|| {
            p.param_error(
                "filename",
                &format!(
                    "an sdfgrid needs at least 2 samples per axis, not {:?}",
                    grid.res
                ),
            )
        })?;
        if data.voxels.is_empty() {
            return Err(p.param_error(
                "filename",
                "this grid holds no surface (no voxel has values of both signs)",
            ));
        }
        let smooth = p.choice("normals", &["smooth", "analytic"])? == 0;
        p.mark_ignored("watertight");
        Ok(Self {
            data: data.interned(),
            to_world: p.transform_or_identity("to_world")?,
            smooth,
            flip_normals: p.boolean_or("flip_normals", false)?,
        })
    }

    /// The voxel (lower corner) of primitive `prim` and its box in
    /// object space.
    fn voxel(&self, prim: u32) -> (UVec3, Bounds3) {
        let v = self.data.voxel_of(self.data.voxels[prim as usize]);
        let s = self.data.scale();
        let b = Bounds3 {
            min: v.as_vec3() / s,
            max: (v + 1).as_vec3() / s,
        };
        (v, b)
    }

    /// The smooth shading normal at `p` (object space, unnormalized).
    fn smooth_normal(&self, p: Vec3) -> Vec3 {
        let g = self.data;
        let res = g.res.as_ivec3();
        let scaled = p * g.scale();
        // The eight voxels around the sample nearest to p: `lower` is the
        // first, `uvw` p's place between their centres.
        let lower = scaled.round().as_ivec3() - 1;
        let mut uvw = scaled - lower.as_vec3() - 0.5;
        let cell = scaled.floor().as_ivec3().clamp(IVec3::ZERO, res - 2);
        let w = scaled - cell.as_vec3();
        // The interpolant on the sample plane `q` across `axis`, at p's
        // place along the other two axes.
        let plane = |axis: usize, q: i32| {
            let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
            let f = std::array::from_fn(|i| {
                let mut at = cell;
                at[axis] = q;
                at[b] += (i & 1) as i32;
                at[c] += (i >> 1) as i32;
                g.sample(at)
            });
            bilerp(f, w[b], w[c])
        };
        // Per axis, the differences across the lower and the upper voxel
        // of the pair: one is p's own cell, the other its neighbour (0
        // past the grid, where the clamped samples repeat).
        let (mut d_lower, mut d_upper) = (Vec3::ZERO, Vec3::ZERO);
        for axis in 0..3 {
            let in_upper = cell[axis] != lower[axis];
            let (g0, g1) = (plane(axis, cell[axis]), plane(axis, cell[axis] + 1));
            let own = g1 - g0;
            let neighbour = if in_upper {
                g0 - plane(axis, cell[axis] - 1)
            } else {
                plane(axis, cell[axis] + 2) - g1
            };
            let (lo, hi) = if in_upper {
                (neighbour, own)
            } else {
                (own, neighbour)
            };
            d_lower[axis] = lo * g.scale()[axis];
            d_upper[axis] = hi * g.scale()[axis];
        }
        // Voxels below the grid do not count: their weight is made 0.
        let inside = lower.cmpge(IVec3::ZERO);
        uvw = Vec3::select(inside, uvw, Vec3::ONE);
        let n: [Vec3; 8] = std::array::from_fn(|i| {
            let upper = glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0);
            if (upper | inside).all() {
                Vec3::select(upper, d_upper, d_lower).normalize_or_zero()
            } else {
                Vec3::ZERO
            }
        });
        let mix = |a: Vec3, b: Vec3, t: f32| a * (1.0 - t) + b * t;
        mix(
            mix(mix(n[0], n[1], uvw.x), mix(n[2], n[3], uvw.x), uvw.y),
            mix(mix(n[4], n[5], uvw.x), mix(n[6], n[7], uvw.x), uvw.y),
            uvw.z,
        )
    }
}

impl ShapeModel for SdfGrid {
    fn prim_count(&self, _: &[TriangleMesh]) -> u32 {
        self.data.voxels.len() as u32
    }

    fn prim_bounds(&self, _: &[TriangleMesh], prim: u32) -> Bounds3 {
        let (_, b) = self.voxel(prim);
        let w = Bounds3::from_points(b.corners().map(|c| self.to_world.point(c)));
        // Padded, so that rounding in the box tests loses no hit on a face.
        let pad = w.extent() * 1e-3 + w.min.abs().max(w.max.abs()) * 1e-6;
        Bounds3 {
            min: w.min - pad,
            max: w.max + pad,
        }
    }

    fn intersect(&self, _: &[TriangleMesh], prim: u32, ray: &Ray) -> Option<PrimHit> {
        let (v, b) = self.voxel(prim);
        let o = self.to_world.inv.transform_point3(ray.o);
        let d = self.to_world.inv.transform_vector3(ray.d);
        let inv = d.recip();
        let (ta, tb) = ((b.min - o) * inv, (b.max - o) * inv);
        // A ray in a face's plane (NaN) counts as inside that slab.
        let near = Vec3::select(ta.is_nan_mask(), Vec3::NEG_INFINITY, ta.min(tb));
        let far = Vec3::select(ta.is_nan_mask(), Vec3::INFINITY, ta.max(tb));
        let t_beg = near.max_element().max(0.0);
        let t_end = far.min_element();
        if !(t_beg < t_end && t_beg <= ray.t_max) {
            return None;
        }
        // Voxel coordinates: [0, 1]³ over this voxel, t unchanged.
        let s = self.data.scale();
        let (ov, dv) = (o * s - v.as_vec3(), d * s);
        let c = self.data.corners(self.data.voxels[prim as usize]);
        // The entry and exit values with the crossed face's coordinate
        // exactly 0 or 1, as the neighbouring voxel computes them.
        let on_face = |t: f32, faces: Vec3, entering: bool| {
            let p = (ov + dv * t).clamp(Vec3::ZERO, Vec3::ONE);
            let pos = dv.cmpge(Vec3::ZERO);
            let face = if entering {
                Vec3::select(pos, Vec3::ZERO, Vec3::ONE)
            } else {
                Vec3::select(pos, Vec3::ONE, Vec3::ZERO)
            };
            Vec3::select(faces.cmpeq(Vec3::splat(t)), face, p)
        };
        let f_beg = trilerp(&c, on_face(t_beg, near, true));
        let f_end = trilerp(&c, on_face(t_end, far, false));
        let k = cubic_along(&c, ov + dv * t_beg, dv);
        let t = t_beg + first_root(&k, t_end - t_beg, f_beg, f_end)?;
        (t > ray.t_min && t <= ray.t_max).then_some(PrimHit { t, uv: Vec2::ZERO })
    }

    fn interaction(
        &self,
        _: &[TriangleMesh],
        prim: u32,
        ray: &Ray,
        hit: PrimHit,
    ) -> SurfaceInteraction {
        let (v, _) = self.voxel(prim);
        let s = self.data.scale();
        let local = self.to_world.inv.transform_point3(ray.at(hit.t));
        let w = (local * s - v.as_vec3()).clamp(Vec3::ZERO, Vec3::ONE);
        let c = self.data.corners(self.data.voxels[prim as usize]);
        let gradient = trilerp_gradient(&c, w) * s;
        let sign = if self.flip_normals { -1.0 } else { 1.0 };
        let mut n = (self.to_world.normal(gradient).normalize_or_zero()) * sign;
        if n == Vec3::ZERO {
            n = Vec3::Z;
        }
        let ns = if self.smooth {
            (self
                .to_world
                .normal(self.smooth_normal(local))
                .normalize_or_zero()
                * sign)
                .try_normalize()
                .unwrap_or(n)
        } else {
            n
        };
        // The geometric normal on the shading normal's side, as for meshes.
        if n.dot(ns) < 0.0 {
            n = -n;
        }
        let frame = Frame::from_normal(ns);
        let mut si = super::make_interaction_in_frame(
            ray,
            hit.t,
            self.to_world.point(local),
            frame,
            Vec2::ZERO,
            frame.s,
            frame.t,
        );
        si.n = n;
        si
    }

    fn surface_area(&self, _: &[TriangleMesh]) -> f32 {
        0.0
    }

    fn sample_position(&self, _: &[TriangleMesh], _: Vec2) -> PositionSample {
        PositionSample::NONE
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid of a sphere's distance, `n` samples per axis.
    fn sphere_grid(n: u32, radius: f32) -> SdfGrid {
        let mut values = Vec::new();
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let p = UVec3::new(x, y, z).as_vec3() / (n - 1) as f32;
                    values.push((p - Vec3::splat(0.5)).length() - radius);
                }
            }
        }
        SdfGrid {
            data: SdfGridData::new([n; 3], values).unwrap().interned(),
            to_world: Transform::IDENTITY,
            smooth: true,
            flip_normals: false,
        }
    }

    fn closest(g: &SdfGrid, ray: &Ray) -> Option<(u32, PrimHit)> {
        (0..g.prim_count(&[]))
            .filter_map(|i| g.intersect(&[], i, ray).map(|h| (i, h)))
            .min_by(|a, b| a.1.t.total_cmp(&b.1.t))
    }

    #[test]
    fn cubic_coefficients_follow_the_interpolant() {
        let c = [0.3, -0.2, 0.5, 0.1, -0.4, 0.7, 0.2, -0.6];
        let (o, d) = (Vec3::new(0.1, 0.3, 0.2), Vec3::new(0.5, 0.2, 0.6));
        let k = cubic_along(&c, o, d);
        for t in [0.0, 0.3, 0.9, 1.2] {
            assert!((cubic(&k, t) - trilerp(&c, o + d * t)).abs() < 1e-6);
        }
    }

    /// Rays towards a sampled sphere hit where the sphere is, within the
    /// grid's interpolation error, through every voxel they may cross;
    /// no ray slips between voxels.
    #[test]
    fn rays_hit_a_sampled_sphere_without_gaps() {
        let g = sphere_grid(24, 0.3);
        let mut rng = crate::sampler::Pcg32::new(9, 0);
        for _ in 0..2000 {
            let o =
                Vec3::splat(0.5) + crate::sampling::square_to_uniform_sphere(rng.next_2d()) * 2.0;
            let target = Vec3::splat(0.5) + (rng.next_2d() - Vec2::splat(0.5)).extend(0.0) * 0.5;
            let ray = Ray::new(o, (target - o).normalize());
            let oc = ray.o - Vec3::splat(0.5);
            let b = oc.dot(ray.d);
            let disc = b * b - (oc.length_squared() - 0.09);
            if disc < 1e-3 {
                continue;
            }
            let expected = -b - disc.sqrt();
            let (prim, hit) = closest(&g, &ray).unwrap_or_else(|| panic!("missed {ray:?}"));
            // The interpolant is off the sphere by up to 3h²/8R ≈ 2.4·10⁻³
            // (h the voxel, R the radius: h²/8 times the Hessian's
            // trace), along the ray by that over the cosine of incidence.
            let normal = (ray.at(expected) - Vec3::splat(0.5)).normalize();
            let cos = normal.dot(-ray.d);
            assert!(
                (hit.t - expected).abs() < 2.5e-3 / cos.max(0.1),
                "{} for {expected}",
                hit.t
            );
            let si = g.interaction(&[], prim, &ray, hit);
            let exact = (si.p - Vec3::splat(0.5)).normalize();
            assert!(si.n.dot(exact) > 0.99 && si.sh_frame.n.dot(exact) > 0.999);
        }
    }

    #[test]
    fn smooth_normals_are_continuous_across_voxels() {
        let g = sphere_grid(10, 0.3);
        // Walk a ring of hits around the sphere: neighbouring shading
        // normals differ by about the step, never by a jump.
        let mut last: Option<Vec3> = None;
        for i in 0..2000 {
            let a = i as f32 / 2000.0 * std::f32::consts::TAU;
            let dir = Vec3::new(a.cos(), a.sin(), 0.3).normalize();
            let ray = Ray::new(Vec3::splat(0.5) + dir * 2.0, -dir);
            let (prim, hit) = closest(&g, &ray).unwrap();
            let n = g.interaction(&[], prim, &ray, hit).sh_frame.n;
            if let Some(l) = last {
                assert!(n.dot(l) > 0.9995, "jump at {i}: {l} to {n}");
            }
            last = Some(n);
        }
    }
}
