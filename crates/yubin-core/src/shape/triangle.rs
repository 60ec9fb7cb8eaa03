//! Watertight ray–triangle intersection (Woop, Benthin and Wald 2013,
//! "Watertight Ray/Triangle Intersection", JCGT 2(1); pbrt-v4 §6.5.3).
//!
//! The ray is turned, once, into a shear that maps it onto the +z axis;
//! each triangle is then tested with 2D edge functions. Points exactly on
//! an edge or vertex give an edge function of exactly 0 for both triangles
//! that share it, and the sign rule treats 0 consistently, so a ray can
//! never slip between two triangles of a closed mesh. When an edge function
//! comes out exactly 0 in `f32`, it is recomputed in `f64` (the paper's
//! fallback) so that the tie is real and not round-off.

use super::PrimHit;
use crate::accel::HugeArray;
use crate::math::{Ray, RayVectors};
use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3, Vec3A};
use wide::{f32x8, CmpEq, CmpGt, CmpLt};

/// Triangles per packet: a BVH leaf holds at most this many, and one ray
/// tests them all at once (one AVX instruction per step; two SSE halves
/// on baseline x86-64).
pub const PACKET: usize = 8;

/// One lane per triangle of a packet.
type Lanes = f32x8;

/// A packet's vertices: per vertex, per axis, one lane per triangle.
pub(crate) type PacketVertices = [[Lanes; 3]; 3];

/// Triangles in packets of [`PACKET`], structure-of-arrays inside a packet
/// (per vertex, per axis, one lane per triangle), so that one 320-byte
/// packet holds a whole BVH leaf — vertices and the caller's triangle ids
/// — and loads as SIMD lanes. Entries that are not triangles hold NaN,
/// which no ray can hit. The packets of a large mesh sit on huge pages
/// (see [`HugeArray`]).
#[derive(Clone, Debug, Default)]
pub struct TrianglePackets {
    packets: HugeArray<Packet>,
    /// Per packet, whether any lane holds a triangle (so leaves of other
    /// primitives skip the test).
    any: Vec<bool>,
}

/// [`PACKET`] triangles and their ids. The ids sit beside the vertices so
/// that a hit needs no further memory access to say which triangle it
/// was. Aligned to a cache line, so that the 320 bytes span five lines.
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
#[repr(C, align(64))]
struct Packet {
    v: [[Lanes; 3]; 3],
    id: [u32; PACKET],
}

impl TrianglePackets {
    /// Packs entries `0..len`, where `tri(i)` gives entry `i`'s vertices
    /// and id, [`PACKET`] to a packet; `None` marks an entry that is not a
    /// triangle (or padding). In parallel, and straight from the caller's
    /// data into place: a million-triangle mesh has an eighth of a million
    /// packets, and an intermediate list of them would be 40 MB written
    /// and read again.
    pub fn new(len: usize, tri: impl Fn(usize) -> Option<([Vec3; 3], u32)> + Sync) -> Self {
        use rayon::prelude::*;
        let mut any = Vec::new();
        let packets = HugeArray::new(len.div_ceil(PACKET), |packets: &mut [Packet]| {
            any = packets
                .par_iter_mut()
                .enumerate()
                .map(|(q, packet)| {
                    let entry = |l: usize| {
                        let i = PACKET * q + l;
                        (i < len).then(|| tri(i)).flatten()
                    };
                    let group: [Option<([Vec3; 3], u32)>; PACKET] = std::array::from_fn(entry);
                    let has_triangle = group.iter().any(Option::is_some);
                    let group = group.map(|t| t.unwrap_or(([Vec3::NAN; 3], 0)));
                    *packet = Packet {
                        v: std::array::from_fn(|v| {
                            std::array::from_fn(|axis| {
                                Lanes::new(std::array::from_fn(|l| group[l].0[v][axis]))
                            })
                        }),
                        id: std::array::from_fn(|l| group[l].1),
                    };
                    has_triangle
                })
                .collect();
        });
        Self { packets, any }
    }

    /// Asks the cache for the packet holding position `start` (see
    /// `Bvh::prefetch`); a hint only.
    #[inline(always)]
    pub fn prefetch(&self, start: usize) {
        #[cfg(target_arch = "x86_64")]
        if let Some(p) = self.packets.get(start / PACKET) {
            // Offsets 0, 64, 128, 192 and 256: one in each line.
            safe_arch::prefetch_t0(&p.v[0][0]);
            safe_arch::prefetch_t0(&p.v[0][2]);
            safe_arch::prefetch_t0(&p.v[1][1]);
            safe_arch::prefetch_t0(&p.v[2][0]);
            safe_arch::prefetch_t0(&p.v[2][2]);
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = start;
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.packets.resident_bytes() + self.any.capacity()
    }

    /// The id given to [`TrianglePackets::new`] for entry `i`.
    #[inline]
    pub fn id(&self, i: usize) -> u32 {
        self.packets[i / PACKET].id[i % PACKET]
    }

    /// Whether the packet holding position `start` has any triangle (a
    /// leaf of analytic shapes only has none, and needs no packet test).
    #[inline]
    pub fn has_triangles(&self, start: usize) -> bool {
        self.any[start / PACKET]
    }
}

/// A ray prepared for watertight triangle tests. Its values are kept
/// broadcast to every lane and its axes as plain indices, so that a leaf
/// starts testing at once: built from scalars, they were rebuilt in every
/// leaf (five broadcasts, three index loads and their clamps), and a
/// primary ray tests about one leaf.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    /// Origin, in the permuted axis order `k`.
    o: [Lanes; 3],
    /// Shear constants, in the permuted order: `-d.x / d.z`, `-d.y / d.z`
    /// and `1 / d.z`.
    s: [Lanes; 3],
    t_min: Lanes,
    /// Axis permutation: the ray's dominant axis last. Each below 3.
    k: [usize; 3],
}

/// Per dominant axis (the row), the axes taken as x, y and z of the
/// sheared space. Cyclic, so the winding is kept; the test accepts both
/// windings anyway, and swapping x and y would only negate every edge
/// function, the determinant and the scaled distance exactly. The fourth
/// row is never chosen: it lets a masked index go unchecked.
const AXES: [[i32; 4]; 4] = [[1, 2, 0, 3], [2, 0, 1, 3], [0, 1, 2, 3], [0, 1, 2, 3]];

/// `v`'s components in the order `axes` (the first three of them).
#[inline(always)]
fn permuted(v: Vec3A, axes: [i32; 4]) -> Vec3A {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
    {
        // One variable shuffle instead of a trip through memory.
        use safe_arch::{m128, m128i, shuffle_av_f32_all_m128};
        Vec3A::from(shuffle_av_f32_all_m128(m128(v.into()), m128i::from(axes)).0)
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "avx")))]
    {
        let v = v.extend(0.0).to_array();
        Vec3A::from_array(std::array::from_fn(|i| v[axes[i] as usize & 3]))
    }
}

impl WatertightRay {
    /// Precomputes the shear of `ray`.
    #[inline(always)]
    pub fn new(ray: &Ray) -> Self {
        Self::from_vectors(&ray.vectors(), ray.t_min)
    }

    /// Precomputes the shear of the ray with these vectors (from
    /// [`Ray::vectors`]) and start `t_min`. Always inlined: it runs once
    /// per ray, before traversal, and its values then stay in registers.
    #[inline(always)]
    pub fn from_vectors(ray: &RayVectors, t_min: f32) -> Self {
        let a = ray.d.abs();
        // The dominant axis, without branches (rays are incoherent, so
        // branches on their direction mispredict).
        let kz = ((a.y > a.x && a.y >= a.z) as usize) + 2 * ((a.z > a.x && a.z > a.y) as usize);
        let axes = AXES[kz & 3];
        let d = permuted(ray.d, axes);
        let sz = 1.0 / d.z;
        let splat = |v: Vec3A| v.to_array().map(Lanes::splat);
        Self {
            o: splat(permuted(ray.o, axes)),
            s: splat((-d * sz).with_z(sz)),
            t_min: Lanes::splat(t_min),
            // The minimum spares bounds checks (the values are below 3
            // already); taken here, it is taken once per ray.
            k: [0, 1, 2].map(|i| (axes[i] as usize).min(2)),
        }
    }

    /// Intersects the triangle `v` within `(t_min, t_max)`; returns the
    /// distance and the barycentrics of vertices 1 and 2. A packet of one:
    /// the very arithmetic of [`WatertightRay::intersect_packet`], so that
    /// a triangle tested either way gives the same answer.
    pub fn intersect(&self, v: &[Vec3; 3], t_max: f32) -> Option<PrimHit> {
        let lanes = v.map(|p| p.to_array().map(Lanes::splat));
        self.intersect_lanes(&lanes, 1, t_max).map(|(_, hit)| hit)
    }

    /// The nearest hit among the first `count` lanes of the packet that
    /// holds entry `start` (a multiple of [`PACKET`]), closer than `t_max`:
    /// the lane and the hit.
    #[inline(always)]
    pub fn intersect_packet(
        &self,
        p: &TrianglePackets,
        start: usize,
        count: usize,
        t_max: f32,
    ) -> Option<(usize, PrimHit)> {
        debug_assert!(start.is_multiple_of(PACKET) && count <= PACKET);
        self.intersect_lanes(&p.packets[start / PACKET].v, count, t_max)
    }

    /// The vertices `v` (per vertex, per axis, a lane per triangle)
    /// translated to the ray origin and sheared. The shear is fused where
    /// the hardware has FMA; every test goes through here, so a vertex
    /// shared by two triangles lands on the same point for both, which
    /// is what makes the test watertight.
    #[inline(always)]
    fn shear(&self, v: &[[Lanes; 3]; 3]) -> Sheared {
        let [kx, ky, kz] = self.k;
        let [ox, oy, oz] = self.o;
        let [sx, sy, sz] = self.s;
        // Indexed, not mapped: mapping would copy the packet.
        let z: [Lanes; 3] = std::array::from_fn(|i| v[i][kz] - oz);
        Sheared {
            x: std::array::from_fn(|i| sx.mul_add(z[i], v[i][kx] - ox)),
            y: std::array::from_fn(|i| sy.mul_add(z[i], v[i][ky] - oy)),
            z: z.map(|z| sz * z),
        }
    }

    /// The nearest hit among the first `count` lanes of `vertices`.
    #[inline(always)]
    fn intersect_lanes(
        &self,
        vertices: &[[Lanes; 3]; 3],
        count: usize,
        t_max: f32,
    ) -> Option<(usize, PrimHit)> {
        self.nearest(vertices, &self.lane_tests(vertices, t_max), count, t_max)
    }

    /// [`WatertightRay::intersect_packet`] with the lanes' arithmetic done
    /// by `tests` (the portable [`WatertightRay::lane_tests`] or
    /// [`lane_tests_avx2`]).
    #[inline(always)]
    pub(crate) fn intersect_packet_by(
        &self,
        p: &TrianglePackets,
        start: usize,
        count: usize,
        t_max: f32,
        tests: impl Fn(&Self, &PacketVertices, f32) -> LaneTests,
    ) -> Option<(usize, PrimHit)> {
        debug_assert!(start.is_multiple_of(PACKET) && count <= PACKET);
        let vertices = &p.packets[start / PACKET].v;
        self.nearest(vertices, &tests(self, vertices, t_max), count, t_max)
    }

    /// The arithmetic of the packet test, lane by lane: edge functions,
    /// determinants and distances, as masks and lanes.
    #[inline(always)]
    pub(crate) fn lane_tests(&self, vertices: &PacketVertices, t_max: f32) -> LaneTests {
        let s = self.shear(vertices);
        let ([ax, bx, cx], [ay, by, cy], [az, bz, cz]) = (s.x, s.y, s.z);
        // Edge functions as two rounded products, never fused: see below.
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        let zero = Lanes::ZERO;
        let bits = |m: Lanes| m.move_mask() as u32;
        // An edge function that is not 0 in f32 has its exact sign (the
        // two products are rounded monotonically), so a lane with one
        // strictly negative and one strictly positive is a miss for sure.
        // The others have all three ≥ 0 or all ≤ 0; those with one of them
        // exactly 0 (then the least or the greatest) are redone in f64
        // (see `nearest`). Minimum and maximum say both with fewer
        // instructions than testing u, v, w one by one. (A NaN lane,
        // padding, has a NaN determinant and is never a hit; the plain
        // min/max suffice.)
        let (low, high) = (u.fast_min(v).fast_min(w), u.fast_max(v).fast_max(w));
        let mixed = bits(low.cmp_lt(zero) & high.cmp_gt(zero));
        let exact = bits(low.cmp_eq(zero) | high.cmp_eq(zero));
        let det = u + v + w;
        let t_scaled = u * az + v * bz + w * cz;
        // The distance is t_scaled / det. Dividing every lane, before
        // knowing which hit, costs a division per leaf but starts it at
        // once: a hit's distance is what the rest of traversal waits for,
        // and a division begun only after the hit mask is known added its
        // whole latency to that wait. A lane whose determinant is 0 is
        // exact (u = v = w = 0) or NaN, never a hit here.
        let inv = Lanes::ONE / det;
        let t = t_scaled * inv;
        let in_range = bits(t.cmp_gt(self.t_min) & t.cmp_lt(Lanes::splat(t_max)));
        LaneTests {
            mixed,
            exact,
            in_range,
            t,
            v,
            w,
            inv,
        }
    }

    /// The nearest hit among the first `count` lanes, from their tests.
    #[inline(always)]
    fn nearest(
        &self,
        vertices: &[[Lanes; 3]; 3],
        lanes: &LaneTests,
        count: usize,
        t_max: f32,
    ) -> Option<(usize, PrimHit)> {
        let counted = (1u32 << count) - 1;
        let exact = lanes.exact & counted & !lanes.mixed;
        let mut hit = counted & !exact & !lanes.mixed & lanes.in_range;
        let mut best: Option<(usize, PrimHit)> = None;
        if hit == 0 && exact == 0 {
            // Most leaves: nothing to finish, and nothing to store.
            return best;
        }
        let t = lanes.t.to_array();
        let (b1, b2) = (
            (lanes.v * lanes.inv).to_array(),
            (lanes.w * lanes.inv).to_array(),
        );
        while hit != 0 {
            let lane = hit.trailing_zeros() as usize;
            hit &= hit - 1;
            if best.is_none_or(|(_, b)| t[lane] < b.t) {
                let uv = Vec2::new(b1[lane], b2[lane]);
                best = Some((lane, PrimHit { t: t[lane], uv }));
            }
        }
        if exact != 0 {
            best = self.retest_exact_lanes(vertices, exact, t_max, best);
        }
        best
    }

    /// The hit of a lane with edge functions `v`, `w` (and `u`) of one
    /// sign, determinant `det` and scaled distance `t_scaled`, if within
    /// `(t_min, limit)`: the arithmetic of the packet test, lane by lane.
    #[inline(always)]
    fn finish(&self, t_scaled: f32, v: f32, w: f32, det: f32, limit: f32) -> Option<PrimHit> {
        let inv = 1.0 / det;
        let t = t_scaled * inv;
        (t > self.t_min.as_array_ref()[0] && t < limit).then(|| PrimHit {
            t,
            uv: Vec2::new(v * inv, w * inv),
        })
    }

    /// The lanes of `v` whose edge functions came out exactly 0, retested
    /// one by one with all three recomputed in `f64` (the paper's
    /// fallback) from the same sheared vertices (the shear is redone here,
    /// bit for bit, rather than kept: keeping it would cost every leaf
    /// nine stores). Rare, so kept out of line: the common path stays
    /// small enough to inline into traversal.
    #[cold]
    #[inline(never)]
    fn retest_exact_lanes(
        &self,
        v: &[[Lanes; 3]; 3],
        mut exact: u32,
        t_max: f32,
        mut best: Option<(usize, PrimHit)>,
    ) -> Option<(usize, PrimHit)> {
        let s = self.shear(v);
        let [x, y, z] = [s.x, s.y, s.z].map(|c| c.map(|l| l.to_array()));
        while exact != 0 {
            let lane = exact.trailing_zeros() as usize;
            exact &= exact - 1;
            // Products of two f32 are exact in f64, so the sign is.
            let edge = |p: usize, q: usize| {
                let (px, py, qx, qy) = (x[p][lane], y[p][lane], x[q][lane], y[q][lane]);
                (f64::from(px) * f64::from(qy) - f64::from(py) * f64::from(qx)) as f32
            };
            let (u, v, w) = (edge(2, 1), edge(0, 2), edge(1, 0));
            let mixed = (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0);
            let det = u + v + w;
            if mixed || det == 0.0 {
                continue;
            }
            let t_scaled = u * z[0][lane] + v * z[1][lane] + w * z[2][lane];
            let limit = best.map_or(t_max, |(_, b)| b.t);
            if let Some(h) = self.finish(t_scaled, v, w, det, limit) {
                best = Some((lane, h));
            }
        }
        best
    }
}

/// What a packet's test found, lane by lane, before the nearest hit is
/// picked: bit masks of the lanes whose edge functions have mixed signs,
/// that have one exactly 0, and whose distance is within the ray's
/// interval; the distances, the edge functions of vertices 1 and 2 and
/// the reciprocal determinants.
pub(crate) struct LaneTests {
    mixed: u32,
    exact: u32,
    in_range: u32,
    t: Lanes,
    v: Lanes,
    w: Lanes,
    inv: Lanes,
}

/// [`WatertightRay::lane_tests`] for traversal compiled for AVX2 (see
/// `scene/traversal.rs`): in a build for AVX2 that is the portable test itself
/// (`wide` is AVX there).
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
#[inline(always)]
pub(crate) fn lane_tests_avx2(
    ray: &WatertightRay,
    vertices: &PacketVertices,
    t_max: f32,
) -> LaneTests {
    ray.lane_tests(vertices, t_max)
}

/// [`WatertightRay::lane_tests`] with each step one 8-wide AVX
/// instruction instead of two SSE halves (`wide` picks its form by the
/// build's flags, so code compiled for AVX2 at run time still gets the
/// halves), for traversal compiled for AVX2 and chosen at run time (see
/// `scene/traversal.rs`). The same operations in the same order, multiplications
/// and additions never fused, as the portable test on baseline x86-64:
/// the same hits bit for bit (`avx2_triangle_test_equals_portable_one`).
/// Only the arithmetic, which is small enough to inline into traversal;
/// picking the nearest hit stays in the caller.
#[cfg(all(target_arch = "x86_64", not(target_feature = "avx2")))]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn lane_tests_avx2(
    ray: &WatertightRay,
    vertices: &PacketVertices,
    t_max: f32,
) -> LaneTests {
    use std::arch::x86_64::{
        __m256, _mm256_add_ps, _mm256_and_ps, _mm256_cmp_ps, _mm256_div_ps, _mm256_max_ps,
        _mm256_min_ps, _mm256_movemask_ps, _mm256_mul_ps, _mm256_or_ps, _mm256_set1_ps,
        _mm256_setzero_ps, _mm256_sub_ps, _CMP_EQ_OQ, _CMP_GT_OQ, _CMP_LT_OQ,
    };
    let m = |v: Lanes| -> __m256 { bytemuck::cast(v) };
    let [kx, ky, kz] = ray.k;
    let ([ox, oy, oz], [sx, sy, sz]) = (ray.o.map(m), ray.s.map(m));
    let sheared = |i: usize, k: usize, o: __m256, s: __m256, z: __m256| {
        _mm256_add_ps(_mm256_mul_ps(s, z), _mm256_sub_ps(m(vertices[i][k]), o))
    };
    let z: [__m256; 3] = std::array::from_fn(|i| _mm256_sub_ps(m(vertices[i][kz]), oz));
    let x: [__m256; 3] = std::array::from_fn(|i| sheared(i, kx, ox, sx, z[i]));
    let y: [__m256; 3] = std::array::from_fn(|i| sheared(i, ky, oy, sy, z[i]));
    let z = z.map(|z| _mm256_mul_ps(sz, z));
    let edge =
        |p: usize, q: usize| _mm256_sub_ps(_mm256_mul_ps(x[p], y[q]), _mm256_mul_ps(y[p], x[q]));
    let (u, v, w) = (edge(2, 1), edge(0, 2), edge(1, 0));
    let zero = _mm256_setzero_ps();
    let bits = |m: __m256| _mm256_movemask_ps(m) as u32;
    let low = _mm256_min_ps(_mm256_min_ps(u, v), w);
    let high = _mm256_max_ps(_mm256_max_ps(u, v), w);
    let mixed = bits(_mm256_and_ps(
        _mm256_cmp_ps::<_CMP_LT_OQ>(low, zero),
        _mm256_cmp_ps::<_CMP_GT_OQ>(high, zero),
    ));
    let exact = bits(_mm256_or_ps(
        _mm256_cmp_ps::<_CMP_EQ_OQ>(low, zero),
        _mm256_cmp_ps::<_CMP_EQ_OQ>(high, zero),
    ));
    let t_scaled = _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(u, z[0]), _mm256_mul_ps(v, z[1])),
        _mm256_mul_ps(w, z[2]),
    );
    let inv = _mm256_div_ps(_mm256_set1_ps(1.0), _mm256_add_ps(_mm256_add_ps(u, v), w));
    let t = _mm256_mul_ps(t_scaled, inv);
    let in_range = bits(_mm256_and_ps(
        _mm256_cmp_ps::<_CMP_GT_OQ>(t, m(ray.t_min)),
        _mm256_cmp_ps::<_CMP_LT_OQ>(t, _mm256_set1_ps(t_max)),
    ));
    let lane = |v: __m256| -> Lanes { bytemuck::cast(v) };
    LaneTests {
        mixed,
        exact,
        in_range,
        t: lane(t),
        v: lane(v),
        w: lane(w),
        inv: lane(inv),
    }
}

/// A packet's vertices in the sheared space of a ray: per vertex, one lane
/// per triangle.
struct Sheared {
    x: [Lanes; 3],
    y: [Lanes; 3],
    z: [Lanes; 3],
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;

    /// A closed, finely tessellated surface: an octahedron subdivided into
    /// a grid so there are many shared edges and vertices.
    fn octahedron_grid(n: usize) -> Vec<[Vec3; 3]> {
        let corners = [Vec3::X, Vec3::Y, -Vec3::X, -Vec3::Y];
        let mut tris = Vec::new();
        for pole in [Vec3::Z, -Vec3::Z] {
            for q in 0..4 {
                let (p1, p2) = (corners[q], corners[(q + 1) % 4]);
                let pt = |i: usize, j: usize| {
                    // Barycentric grid on (pole, p1, p2), projected to |x|+|y|+|z| = 1 (planar faces).
                    let (a, b) = (i as f32 / n as f32, j as f32 / n as f32);
                    pole * (1.0 - a - b) + p1 * a + p2 * b
                };
                for i in 0..n {
                    for j in 0..n - i {
                        let (v0, v1, v2) = (pt(i, j), pt(i + 1, j), pt(i, j + 1));
                        tris.push(if pole.z > 0.0 {
                            [v0, v1, v2]
                        } else {
                            [v0, v2, v1]
                        });
                        if i + j + 1 < n {
                            let v3 = pt(i + 1, j + 1);
                            tris.push(if pole.z > 0.0 {
                                [v1, v3, v2]
                            } else {
                                [v1, v2, v3]
                            });
                        }
                    }
                }
            }
        }
        tris
    }

    /// Möller and Trumbore's test in `f64` with every barycentric grown
    /// by `margin`: distance and barycentrics (b1, b2) of a hit beyond the
    /// origin. An independent reference (not watertight, hence the margin
    /// to tell rays near an edge).
    fn reference_hit_within(tri: &[Vec3; 3], ray: &Ray, margin: f64) -> Option<(f64, glam::DVec2)> {
        let [p0, p1, p2] = tri.map(|p| p.as_dvec3());
        let (o, d) = (ray.o.as_dvec3(), ray.d.as_dvec3());
        let (e1, e2) = (p1 - p0, p2 - p0);
        let pv = d.cross(e2);
        let det = e1.dot(pv);
        if det == 0.0 {
            return None;
        }
        let tv = o - p0;
        let b1 = tv.dot(pv) / det;
        let qv = tv.cross(e1);
        let b2 = d.dot(qv) / det;
        let t = e2.dot(qv) / det;
        let inside = b1 >= -margin && b2 >= -margin && 1.0 - b1 - b2 >= -margin;
        (inside && t > 0.0).then_some((t, glam::DVec2::new(b1, b2)))
    }

    /// [`reference_hit_within`] for rays clear of the edges by 1e-4.
    fn reference_hit(tri: &[Vec3; 3], ray: &Ray) -> Option<(f64, glam::DVec2)> {
        reference_hit_within(tri, ray, -1e-4)
    }

    /// Triangles the ray hits before `t_max`.
    fn hits(tris: &[[Vec3; 3]], ray: &Ray, t_max: f32) -> usize {
        let wr = WatertightRay::new(ray);
        tris.iter()
            .filter(|t| wr.intersect(t, t_max).is_some())
            .count()
    }

    #[test]
    fn rays_through_shared_edges_and_vertices_never_slip_through() {
        let tris = octahedron_grid(8);
        let mut rng = Pcg32::new(1, 2);
        let mut aimed = 0;
        for tri in &tris {
            // Aim at every vertex and at the midpoint of every edge, from
            // random points outside; each ray must hit the closed surface.
            let targets = [
                tri[0],
                tri[1],
                tri[2],
                (tri[0] + tri[1]) * 0.5,
                (tri[1] + tri[2]) * 0.5,
                (tri[2] + tri[0]) * 0.5,
            ];
            for target in targets {
                // Come from outside, roughly along the radius: the ray then
                // truly enters the convex surface at the target and passes
                // near its centre (not a tangent that merely touches it).
                let jitter = crate::sampling::square_to_uniform_sphere(rng.next_2d()) * 0.4;
                let o = target * 3.0 + jitter;
                let ray = Ray::new(o, (target - o).normalize());
                // Only hits at the target count (the exit point further on
                // must not mask a slip).
                let n = hits(&tris, &ray, (target - o).length() * (1.0 + 1e-5));
                assert!(
                    n >= 1,
                    "ray from {o} at {target} slipped through ({n} hits)"
                );
                aimed += 1;
            }
        }
        assert!(aimed > 1000);
    }

    /// A (ray, packet start, count, t_max) case of a packet test.
    type PacketCase = (WatertightRay, usize, usize, f32);

    /// A packet test's answer as bits: lane, distance and barycentrics.
    type AnswerBits = Option<(usize, [u32; 3])>;

    /// The packet test's answers as bits (lane, distance, barycentrics).
    fn answer_bits(hit: Option<(usize, PrimHit)>) -> AnswerBits {
        hit.map(|(lane, h)| (lane, [h.t, h.uv.x, h.uv.y].map(f32::to_bits)))
    }

    /// The AVX2 packet test on this CPU, or `None` where it has no AVX2,
    /// compiled for the targets of single-ray traversal (`scene/traversal.rs`).
    #[multiversion::multiversion(targets(
        "x86_64+avx512f+avx512vl+avx512bw+avx512dq+avx2+fma",
        "x86_64+avx2+fma"
    ))]
    fn avx2_packet_tests(
        packets: &TrianglePackets,
        cases: &[PacketCase],
    ) -> Option<Vec<AnswerBits>> {
        #[multiversion::target::target_cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        #[multiversion::inherit_target]
        fn run(packets: &TrianglePackets, cases: &[PacketCase]) -> Option<Vec<AnswerBits>> {
            let test = |(wr, start, count, t_max): &PacketCase| {
                let hit = wr.intersect_packet_by(packets, *start, *count, *t_max, |r, v, t| {
                    lane_tests_avx2(r, v, t)
                });
                answer_bits(hit)
            };
            Some(cases.iter().map(test).collect())
        }
        #[multiversion::target::target_cfg(not(all(
            target_arch = "x86_64",
            target_feature = "avx2"
        )))]
        fn run(_: &TrianglePackets, _: &[PacketCase]) -> Option<Vec<AnswerBits>> {
            None
        }
        run(packets, cases)
    }

    /// The AVX2 packet test gives the portable one's hits bit for bit (so
    /// images do not depend on the CPU): rays aimed at vertices and edge
    /// midpoints of a closed grid (edge functions exactly 0, redone in
    /// f64), random rays, short intervals, partly filled packets.
    #[test]
    fn avx2_triangle_test_equals_portable_one() {
        let tris = octahedron_grid(4);
        let packets = TrianglePackets::new(tris.len(), |i| Some((tris[i], i as u32)));
        let mut rng = Pcg32::new(5, 6);
        let mut cases = Vec::new();
        for (i, tri) in tris.iter().enumerate().cycle().take(8 * tris.len()) {
            for target in [
                tri[0],
                (tri[0] + tri[1]) * 0.5,
                (tri[0] + tri[1] + tri[2]) / 3.0,
            ] {
                let aimed = rng.next_f32() < 0.5;
                let o = if aimed {
                    target * 3.0
                } else {
                    crate::sampling::square_to_uniform_sphere(rng.next_2d()) * 2.5
                };
                let d = if aimed {
                    (target - o).normalize()
                } else {
                    crate::sampling::square_to_uniform_sphere(rng.next_2d())
                };
                let wr = WatertightRay::new(&Ray::new(o, d));
                // The packet of the triangle aimed at, sometimes cut short
                // before it.
                let start = i - i % PACKET;
                let count = (1 + (rng.next_f32() * PACKET as f32) as usize).min(PACKET);
                let t_max = if rng.next_f32() < 0.2 {
                    2.0
                } else {
                    f32::INFINITY
                };
                cases.push((wr, start, count, t_max));
            }
        }
        let Some(avx2) = avx2_packet_tests(&packets, &cases) else {
            eprintln!("skipped: this CPU has no AVX2");
            return;
        };
        let mut hits = 0;
        for ((wr, start, count, t_max), got) in cases.iter().zip(avx2) {
            let want = answer_bits(wr.intersect_packet(&packets, *start, *count, *t_max));
            assert_eq!(want, got);
            hits += usize::from(want.is_some());
        }
        assert!(hits > 100, "too few hits ({hits}) to test anything");
    }

    #[test]
    fn packet_test_agrees_with_an_f64_reference() {
        let tris = octahedron_grid(6);
        let packets = TrianglePackets::new(tris.len(), |i| Some((tris[i], 0)));
        let mut rng = Pcg32::new(3, 4);
        let (mut hits, mut misses) = (0, 0);
        for _ in 0..4000 {
            let o = crate::sampling::square_to_uniform_sphere(rng.next_2d()) * 2.5;
            let target =
                (crate::sampling::square_to_uniform_sphere(rng.next_2d()) * 0.6).with_z(0.0);
            let ray = Ray::new(o, (target - o).normalize());
            let wr = WatertightRay::new(&ray);
            // Every count from 1 to a full packet.
            for start in (0..tris.len()).step_by(PACKET) {
                let count = (tris.len() - start).min(1 + (start / PACKET) % PACKET);
                let reference = (start..start + count)
                    .filter_map(|i| reference_hit(&tris[i], &ray).map(|h| (i - start, h)))
                    .min_by(|a, b| a.1 .0.total_cmp(&b.1 .0));
                // Rays within round-off of an edge may go either way.
                let clear = (start..start + count).all(|i| {
                    reference_hit(&tris[i], &ray).is_some()
                        || reference_hit_within(&tris[i], &ray, 1e-4).is_none()
                });
                if !clear {
                    continue;
                }
                let simd = wr.intersect_packet(&packets, start, count, f32::INFINITY);
                assert_eq!(reference.map(|r| r.0), simd.map(|s| s.0));
                match (reference, simd) {
                    (Some((_, (t, uv))), Some((_, h))) => {
                        assert!((f64::from(h.t) - t).abs() <= 1e-5 * t);
                        assert!((h.uv.as_dvec2() - uv).length() < 1e-4);
                        // The one-triangle test is the same test.
                        let lane = simd.map(|s| s.0).unwrap();
                        let single = wr.intersect(&tris[start + lane], f32::INFINITY).unwrap();
                        assert_eq!((single.t, single.uv), (h.t, h.uv));
                        hits += 1;
                    }
                    _ => misses += 1,
                }
            }
        }
        assert!(hits > 1000 && misses > 1000, "{hits} hits, {misses} misses");
        // Non-triangle (NaN) entries are never hit.
        let mixed = TrianglePackets::new(3, |i| (i == 1).then_some((tris[0], 7)));
        let c = (tris[0][0] + tris[0][1] + tris[0][2]) / 3.0;
        let ray = Ray::new(c * 3.0, -c.normalize());
        assert_eq!(
            WatertightRay::new(&ray)
                .intersect_packet(&mixed, 0, 3, f32::INFINITY)
                .map(|h| h.0),
            Some(1)
        );
        assert_eq!(mixed.id(1), 7);
        assert!(mixed.has_triangles(0));
        assert!(!TrianglePackets::new(1, |_| None).has_triangles(0));
    }

    #[test]
    fn matches_expected_distance_and_barycentrics() {
        let tri = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        for d in [-Vec3::Z, Vec3::Z] {
            let o = Vec3::new(0.25, 0.5, -2.0 * d.z);
            let h = WatertightRay::new(&Ray::new(o, d))
                .intersect(&tri, f32::INFINITY)
                .unwrap();
            assert!((h.t - 2.0).abs() < 1e-6);
            assert!((h.uv - Vec2::new(0.25, 0.5)).length() < 1e-6);
        }
        let miss = WatertightRay::new(&Ray::new(Vec3::new(0.8, 0.8, 1.0), -Vec3::Z));
        assert!(miss.intersect(&tri, f32::INFINITY).is_none());
        let behind = WatertightRay::new(&Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::Z));
        assert!(behind.intersect(&tri, f32::INFINITY).is_none());
    }
}
