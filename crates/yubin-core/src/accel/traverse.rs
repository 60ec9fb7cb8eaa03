//! Traversing a [`Bvh`]: the box tests of one ray against a node's
//! eight children ([`RayLanes`]) and of eight rays against one child
//! ([`PacketLanes`]), and the closest-hit and any-hit loops around them,
//! which hand whole leaves to the caller's primitive tests.
//!
//! The box tests are `wide::f32x8` arithmetic: AVX when the build targets
//! it, two SSE halves on baseline x86-64, NEON on ARM, scalar elsewhere;
//! no `unsafe`. A portable x86-64 build also has AVX2 box tests
//! ([`hit_children_avx2`], [`hit_child_avx2`]) for the traversal that
//! `scene/traversal.rs` and `scene/packet.rs` compile for AVX2 and choose
//! at run time; both give the same bits.

use super::bvh::{leaf_span, prim_at, Node, EMPTY, LEAF_BIT, WIDTH};
use super::Bvh;
use crate::math::{Ray, RayPacket, RayVectors};
use arrayvec::ArrayVec;
use glam::Vec3A;
use wide::{f32x8, CmpLe};

/// Traversal stack entries: an 8-wide node pushes at most 7 siblings per
/// level, and the tree is at most `MAX_SAH_DEPTH` + log2(n) binary levels.
const STACK: usize = 256;

/// A ray prepared for box tests: per axis, the reciprocal direction and
/// the offsets that turn a slab plane into a distance with one fused
/// multiply-add, `t = plane · (1/d) + offset` (Áfra et al. 2016, "Embree:
/// a kernel framework", §4.1), all splatted across the eight lanes.
///
/// That form is not exact near the origin: `o · (1/d)` is rounded before
/// the subtraction, an absolute error of about one ulp of `o · (1/d)`.
/// The near offset is lowered and the far one raised by 16 such ulps, and
/// the far distance is scaled by `1 + 8u`, so the test stays conservative
/// (in the spirit of pbrt-v4 §6.8.2): a box is never missed because of
/// round-off, with or without hardware FMA.
pub(crate) struct RayLanes {
    inv_d: [f32x8; 3],
    near_offset: [f32x8; 3],
    /// The far planes' reciprocal direction and offset, both scaled by
    /// `1 + 8u` so the far distance comes out enlarged for free.
    far_inv_d: [f32x8; 3],
    far_offset: [f32x8; 3],
    /// Per axis, the index in [`Node::planes`] of the near and of the far
    /// slab plane: the upper bound is near when the direction is negative.
    /// Choosing slabs by sign (instead of min/max of both) also rejects
    /// the empty boxes of unused child slots.
    near: [usize; 3],
    far: [usize; 3],
}

/// Unit round-off of `f32`.
const ROUND_OFF: f32 = f32::EPSILON * 0.5;

/// A ray's slab values per axis (see [`RayLanes`]): the reciprocal
/// direction and the near offset, and the far ones, scaled.
struct Slabs {
    inv_d: Vec3A,
    near_offset: Vec3A,
    far_inv_d: Vec3A,
    far_offset: Vec3A,
}

impl Slabs {
    #[inline]
    fn new(ray: &RayVectors) -> Self {
        // Reciprocals are clamped to ±1e20 (a zero direction component
        // gives ±infinity, signed like the zero), so that slabs never
        // produce NaN; 1e20 keeps `o · (1/d)` finite for any origin within
        // 1e18. All three axes at once: one division instead of three.
        let limit = Vec3A::splat(1e20);
        let inv = (Vec3A::ONE / ray.d).clamp(-limit, limit);
        let c = ray.o * inv;
        let slack = 16.0 * ROUND_OFF * c.abs();
        let grow = 1.0 + 8.0 * ROUND_OFF;
        let far = slack - c;
        // Rounding the product must not shrink the far distance.
        Self {
            inv_d: inv,
            near_offset: -c - slack,
            far_inv_d: inv * grow,
            far_offset: far * grow + ROUND_OFF * far.abs(),
        }
    }
}

impl RayLanes {
    #[inline]
    fn new(ray: &RayVectors) -> Self {
        let slabs = Slabs::new(ray);
        let splat = |v: Vec3A| v.to_array().map(f32x8::splat);
        // From the reciprocal, not the direction: -0.0 has a negative
        // reciprocal but does not compare below zero.
        let neg = slabs.inv_d.cmplt(Vec3A::ZERO).bitmask() as usize;
        let near = std::array::from_fn(|a| 2 * a + ((neg >> a) & 1));
        Self {
            inv_d: splat(slabs.inv_d),
            near_offset: splat(slabs.near_offset),
            far_inv_d: splat(slabs.far_inv_d),
            far_offset: splat(slabs.far_offset),
            near,
            far: near.map(|n| n ^ 1),
        }
    }

    /// Entry distances of the eight child boxes and a bit mask of those
    /// the ray meets within `[t_min, t_max]`.
    #[inline(always)]
    pub(crate) fn hit_children(&self, node: &Node, t_min: f32, t_max: f32) -> (f32x8, u32) {
        let mut near = [f32x8::ZERO; 3];
        let mut far = [f32x8::ZERO; 3];
        for a in 0..3 {
            // min(5): the indices are planes, and saying so spares bounds
            // checks (the minimum is hoisted out of traversal loops).
            let n = &node.planes[self.near[a].min(5)];
            let f = &node.planes[self.far[a].min(5)];
            near[a] = n.mul_add(self.inv_d[a], self.near_offset[a]);
            far[a] = f.mul_add(self.far_inv_d[a], self.far_offset[a]);
        }
        // No NaN can arise (finite reciprocals, finite offsets), so the
        // plain min/max instructions suffice; paired for a short chain.
        let t_near = near[0]
            .fast_max(near[1])
            .fast_max(near[2].fast_max(f32x8::splat(t_min)));
        let t_far = far[0]
            .fast_min(far[1])
            .fast_min(far[2].fast_min(f32x8::splat(t_max)));
        (t_near, t_near.cmp_le(t_far).move_mask() as u32)
    }
}

/// Eight rays prepared for box tests together, a lane per ray: each lane
/// holds what [`RayLanes`] holds for its ray (the same formulas, so the
/// test is as conservative).
#[derive(Clone, Copy)]
pub(crate) struct PacketLanes {
    inv_d: [f32x8; 3],
    near_offset: [f32x8; 3],
    far_inv_d: [f32x8; 3],
    far_offset: [f32x8; 3],
    t_min: f32x8,
}

impl PacketLanes {
    /// The lanes of `rays`: [`Slabs::new`] lane by lane.
    #[inline]
    pub(crate) fn new(rays: &RayPacket) -> Self {
        let limit = f32x8::splat(1e20);
        let inv = rays
            .d
            .map(|d| (f32x8::ONE / d).fast_max(-limit).fast_min(limit));
        let c: [f32x8; 3] = std::array::from_fn(|a| rays.o[a] * inv[a]);
        let slack = c.map(|c| f32x8::splat(16.0 * ROUND_OFF) * c.abs());
        let grow = f32x8::splat(1.0 + 8.0 * ROUND_OFF);
        let far: [f32x8; 3] = std::array::from_fn(|a| slack[a] - c[a]);
        Self {
            inv_d: inv,
            near_offset: std::array::from_fn(|a| -c[a] - slack[a]),
            far_inv_d: inv.map(|i| i * grow),
            far_offset: far.map(|f| f * grow + f32x8::splat(ROUND_OFF) * f.abs()),
            t_min: rays.t_min,
        }
    }

    /// The lanes whose ray meets child `c`'s box of `node` within
    /// `[t_min, t_max]`. The near plane of an axis is the one nearer along
    /// each lane's own direction: the lesser distance (and the greater
    /// for the far plane), which is the plane [`RayLanes`] picks by sign.
    #[inline(always)]
    pub(crate) fn hit_child(&self, node: &Node, c: usize, t_max: f32x8) -> u32 {
        let mut near = self.t_min;
        let mut far = t_max;
        for a in 0..3 {
            let lo = f32x8::splat(node.planes[2 * a].as_array_ref()[c]);
            let hi = f32x8::splat(node.planes[2 * a + 1].as_array_ref()[c]);
            let (inv, no) = (self.inv_d[a], self.near_offset[a]);
            let (finv, fo) = (self.far_inv_d[a], self.far_offset[a]);
            near = near.fast_max(lo.mul_add(inv, no).fast_min(hi.mul_add(inv, no)));
            far = far.fast_min(lo.mul_add(finv, fo).fast_max(hi.mul_add(finv, fo)));
        }
        near.cmp_le(far).move_mask() as u32
    }
}

/// [`PacketLanes::hit_child`] for packet traversal compiled for AVX2: in
/// a build for AVX2, the portable test itself (see [`hit_children_avx2`]).
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
#[inline(always)]
pub(crate) fn hit_child_avx2(lanes: &PacketLanes, node: &Node, c: usize, t_max: f32x8) -> u32 {
    lanes.hit_child(node, c, t_max)
}

/// [`PacketLanes::hit_child`] with each step one 8-wide AVX instruction
/// instead of two SSE halves, for packet traversal compiled for AVX2 and
/// chosen at run time (`scene/packet.rs`): the same operations in the
/// same order, so the same masks bit for bit
/// (`avx2_packet_box_test_equals_portable_one`).
#[cfg(all(target_arch = "x86_64", not(target_feature = "avx2")))]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn hit_child_avx2(lanes: &PacketLanes, node: &Node, c: usize, t_max: f32x8) -> u32 {
    use std::arch::x86_64::{
        __m256, _mm256_add_ps, _mm256_cmp_ps, _mm256_max_ps, _mm256_min_ps, _mm256_movemask_ps,
        _mm256_mul_ps, _mm256_set1_ps, _CMP_LE_OQ,
    };
    let wide = |v: f32x8| -> __m256 { bytemuck::cast(v) };
    let (mut near, mut far) = (wide(lanes.t_min), wide(t_max));
    for a in 0..3 {
        let lo = _mm256_set1_ps(node.planes[2 * a].as_array_ref()[c]);
        let hi = _mm256_set1_ps(node.planes[2 * a + 1].as_array_ref()[c]);
        let slab = |p: __m256, inv: f32x8, offset: f32x8| {
            _mm256_add_ps(_mm256_mul_ps(p, wide(inv)), wide(offset))
        };
        let (inv, no) = (lanes.inv_d[a], lanes.near_offset[a]);
        let (finv, fo) = (lanes.far_inv_d[a], lanes.far_offset[a]);
        near = _mm256_max_ps(near, _mm256_min_ps(slab(lo, inv, no), slab(hi, inv, no)));
        far = _mm256_min_ps(far, _mm256_max_ps(slab(lo, finv, fo), slab(hi, finv, fo)));
    }
    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32
}

/// Rays a packet holds.
pub const PACKET_RAYS: usize = 8;

/// Trees of at most this many nodes may be traversed by packets (see
/// [`Bvh::packet_leaves`]); its stack then never overflows.
pub const PACKET_NODES: usize = 16;

impl Bvh {
    /// Whether the tree is small enough for [`Bvh::packet_leaves`]: in a
    /// small tree the rays of a packet, however incoherent, meet mostly
    /// the same few boxes, so testing a box for eight rays at once does
    /// the work of eight single-ray tests.
    pub(crate) fn takes_packets(&self) -> bool {
        self.nodes.len() <= PACKET_NODES
    }

    /// Calls `leaf(start, count, lanes)` for every leaf whose box
    /// some lanes of `active` meet within their intervals (`lanes`: those
    /// lanes), depth first; `leaf` returns all lanes' `t_max` (their
    /// closest hits so far). Only for trees that [`Bvh::takes_packets`].
    /// Child boxes are tested by `test` (the portable
    /// [`PacketLanes::hit_child`] or [`hit_child_avx2`]); always inlined
    /// (see [`Bvh::closest_leaves_by`]).
    #[inline(always)]
    pub(crate) fn packet_leaves(
        &self,
        lanes: &PacketLanes,
        active: u32,
        mut t_max: f32x8,
        test: impl Fn(&PacketLanes, &Node, usize, f32x8) -> u32,
        mut leaf: impl FnMut(usize, usize, u32) -> f32x8,
    ) {
        debug_assert!(self.takes_packets());
        if self.root == EMPTY || active == 0 {
            return;
        }
        // Each node pushes at most WIDTH entries, and a tree that takes
        // packets has at most PACKET_NODES nodes.
        let mut stack: ArrayVec<(u32, u32), { PACKET_NODES * WIDTH }> = ArrayVec::new();
        let _ = stack.try_push((self.root, active));
        while let Some((code, mask)) = stack.pop() {
            if code & LEAF_BIT != 0 {
                let (start, count) = leaf_span(code);
                t_max = leaf(start, count, mask);
                continue;
            }
            let node = &self.nodes[code as usize];
            // Pushed last to first, so the first child is visited first.
            for c in (0..WIDTH).rev() {
                if node.child[c] == EMPTY {
                    continue;
                }
                let hit = test(lanes, node, c, t_max) & mask;
                if hit != 0 {
                    let _ = stack.try_push((node.child[c], hit));
                }
            }
        }
    }
}

/// In a build for AVX2 the portable test is already one AVX register per
/// plane (`wide::f32x8` is then `__m256`), and a `#[target_feature]`
/// function could not be called without `unsafe` from code that has the
/// features by the build's flags only.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
#[inline(always)]
pub(crate) fn hit_children_avx2(
    lanes: &RayLanes,
    node: &Node,
    t_min: f32,
    t_max: f32,
) -> (f32x8, u32) {
    lanes.hit_children(node, t_min, t_max)
}

/// A node's box test ([`RayLanes::hit_children`]) in one 8-wide AVX
/// register per plane instead of two SSE halves, for traversal compiled
/// for AVX2 and chosen at run time (see `scene/traversal.rs`). Multiply
/// then add, and the same min/max operand order: the same distances and
/// masks bit for bit, so the traversal order, and every image, is the
/// same on either path. A build for AVX2 (`target-cpu`) needs no second test:
/// `wide` is AVX there (see below).
#[cfg(all(target_arch = "x86_64", not(target_feature = "avx2")))]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn hit_children_avx2(
    lanes: &RayLanes,
    node: &Node,
    t_min: f32,
    t_max: f32,
) -> (f32x8, u32) {
    use std::arch::x86_64::{
        __m256, _mm256_add_ps, _mm256_cmp_ps, _mm256_max_ps, _mm256_min_ps, _mm256_movemask_ps,
        _mm256_mul_ps, _mm256_set1_ps, _CMP_LE_OQ,
    };
    let wide = |v: f32x8| -> __m256 { bytemuck::cast(v) };
    let plane = |a: usize, near: bool| {
        let i = if near { lanes.near[a] } else { lanes.far[a] };
        wide(node.planes[i.min(5)])
    };
    let slab = |a: usize, near: bool| {
        let (inv, offset) = if near {
            (lanes.inv_d[a], lanes.near_offset[a])
        } else {
            (lanes.far_inv_d[a], lanes.far_offset[a])
        };
        _mm256_add_ps(_mm256_mul_ps(plane(a, near), wide(inv)), wide(offset))
    };
    let t_near = _mm256_max_ps(
        _mm256_max_ps(slab(0, true), slab(1, true)),
        _mm256_max_ps(slab(2, true), _mm256_set1_ps(t_min)),
    );
    let t_far = _mm256_min_ps(
        _mm256_min_ps(slab(0, false), slab(1, false)),
        _mm256_min_ps(slab(2, false), _mm256_set1_ps(t_max)),
    );
    let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t_near, t_far)) as u32;
    (bytemuck::cast(t_near), mask)
}

impl Bvh {
    /// Finds the closest hit. `hit` tests primitive `i` against the ray
    /// (whose `t_max` shrinks as hits are found) and returns the distance
    /// of a hit closer than `t_max`; the caller records whatever else it
    /// needs. Returns whether anything was hit; `ray.t_max` is then the
    /// closest distance.
    #[inline]
    pub fn closest(&self, ray: &mut Ray, mut hit: impl FnMut(u32, &Ray) -> Option<f32>) -> bool {
        let no_prefetch = |_| {};
        let seen: &Ray = ray;
        let vectors = seen.vectors();
        let closest = self.closest_leaves(seen, &vectors, &no_prefetch, |start, count, t_max| {
            let mut r = Ray { t_max, ..*seen };
            let mut best = None;
            for p in (start..start + count).map(|i| prim_at(&self.prims, i)) {
                if let Some(t) = hit(p, &r) {
                    r.t_max = t;
                    best = Some(t);
                }
            }
            best
        });
        if let Some(t) = closest {
            ray.t_max = t;
        }
        closest.is_some()
    }

    /// Like [`Bvh::closest`], but hands over whole leaves: `leaf(start,
    /// count, t_max)` tests positions `start..start + count` of the leaf
    /// order (after [`Bvh::take_leaf_order`], the caller's own indices) and
    /// returns the nearest hit closer than `t_max`, the closest distance so
    /// far. This lets callers test a leaf's primitives together (SIMD
    /// triangle packets). `prefetch(start)` may ask the cache for a leaf
    /// that traversal will test later. Returns the closest distance, if
    /// anything was hit.
    ///
    /// `vectors` is `ray.vectors()`, taken by the caller, which usually
    /// needs them too (for the triangle shear): read once, not twice. The
    /// ray is never copied whole: see [`Ray::vectors`] for why loads of it
    /// must stay narrow.
    ///
    /// Traversal descends straight into the nearest child a node's ray
    /// test finds, pushing the others far-to-near (sorted branch-free by
    /// sorting networks), so a node with a single hit child costs no stack
    /// traffic.
    #[inline]
    pub fn closest_leaves(
        &self,
        ray: &Ray,
        vectors: &RayVectors,
        prefetch: &impl Fn(usize),
        leaf: impl FnMut(usize, usize, f32) -> Option<f32>,
    ) -> Option<f32> {
        self.closest_leaves_by(ray, vectors, prefetch, RayLanes::hit_children, leaf)
    }

    /// [`Bvh::closest_leaves`] with the node test `test` (the portable
    /// [`RayLanes::hit_children`] or [`hit_children_avx2`]). Always
    /// inlined, so that a caller compiled for more instruction sets
    /// compiles the whole loop for them.
    #[inline(always)]
    pub(crate) fn closest_leaves_by(
        &self,
        ray: &Ray,
        vectors: &RayVectors,
        prefetch: &impl Fn(usize),
        test: impl Fn(&RayLanes, &Node, f32, f32) -> (f32x8, u32),
        mut leaf: impl FnMut(usize, usize, f32) -> Option<f32>,
    ) -> Option<f32> {
        if self.root == EMPTY {
            return None;
        }
        let lanes = RayLanes::new(vectors);
        // ArrayVec: a fixed-capacity stack that is not zeroed per ray.
        let mut stack: ArrayVec<(u32, f32), STACK> = ArrayVec::new();
        let mut found = false;
        let mut t_max = ray.t_max;
        let mut code = self.root;
        'trace: loop {
            while code & LEAF_BIT == 0 {
                let node = &self.nodes[code as usize];
                let (t_near, mut mask) = test(&lanes, node, ray.t_min, t_max);
                if mask == 0 {
                    match pop_within(&mut stack, t_max) {
                        Some(next) => {
                            code = next;
                            continue;
                        }
                        None => break 'trace,
                    }
                }
                let first = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if mask == 0 {
                    code = node.child[first];
                    continue;
                }
                let t_near = t_near.to_array();
                let second = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                // Compared as integers, as distances are at least t_min ≥ 0
                // (a negative one would only order the visit worse): the
                // integer compare waits less for the spilled distances.
                let (near, far) = if t_near[second].to_bits() < t_near[first].to_bits() {
                    (second, first)
                } else {
                    (first, second)
                };
                if mask == 0 {
                    // Depth is bounded (see MAX_SAH_DEPTH), so pushes never fail.
                    let _ = stack.try_push((node.child[far], t_near[far]));
                    self.prefetch(node.child[far], prefetch);
                    code = node.child[near];
                    continue;
                }
                // Three or more: sorted by networks of compare-exchanges on
                // (distance bits, code) keys, which compile to conditional
                // moves (an insertion sort branches on the distances, which
                // incoherent rays make random); all but the nearest are
                // pushed far to near.
                let key =
                    |s: usize| (u64::from(t_near[s].to_bits()) << 32) | u64::from(node.child[s]);
                let mut push = |k: u64| {
                    let _ = stack.try_push((k as u32, f32::from_bits((k >> 32) as u32)));
                    self.prefetch(k as u32, prefetch);
                };
                let third = key(mask.trailing_zeros() as usize);
                let rest = mask & (mask - 1);
                let nearest = if rest == 0 {
                    let (b, c) = order(key(far), third);
                    let (a, b) = order(key(near), b);
                    push(c);
                    push(b);
                    a
                } else if rest & (rest - 1) == 0 {
                    let (c, d) = order(third, key(rest.trailing_zeros() as usize));
                    let (a, c) = order(key(near), c);
                    let (b, d) = order(key(far), d);
                    let (b, c) = order(b, c);
                    push(d);
                    push(c);
                    push(b);
                    a
                } else {
                    // Five or more: padded to eight with the greatest key,
                    // sorted by Knuth's 19-comparator network (TAOCP vol.
                    // 3, §5.3.4).
                    let mut keys = [u64::MAX; WIDTH];
                    let mut n = 0;
                    let mut all = mask | (1 << near) | (1 << far);
                    while all != 0 {
                        keys[n & (WIDTH - 1)] = key(all.trailing_zeros() as usize);
                        all &= all - 1;
                        n += 1;
                    }
                    for &(i, j) in &SORT8 {
                        (keys[i], keys[j]) = order(keys[i], keys[j]);
                    }
                    for &k in keys[1..n.min(WIDTH)].iter().rev() {
                        push(k);
                    }
                    keys[0]
                };
                code = nearest as u32;
            }
            let (start, count) = leaf_span(code);
            if let Some(t) = leaf(start, count, t_max) {
                t_max = t;
                found = true;
            }
            match pop_within(&mut stack, t_max) {
                Some(next) => code = next,
                None => break,
            }
        }
        found.then_some(t_max)
    }

    /// True when any primitive blocks the ray in its interval. `hit` tests
    /// primitive `i`; it is also where a per-primitive filter (alpha
    /// masks, null boundaries) goes: return false to let the ray pass.
    #[inline]
    pub fn any(&self, ray: &Ray, mut hit: impl FnMut(u32, &Ray) -> bool) -> bool {
        let no_prefetch = |_| {};
        self.any_leaves(ray, &ray.vectors(), &no_prefetch, |start, count| {
            (start..start + count).any(|i| hit(prim_at(&self.prims, i), ray))
        })
    }

    /// Like [`Bvh::any`], leaf by leaf (see [`Bvh::closest_leaves`]):
    /// `leaf(start, count)` says whether a primitive of the leaf blocks the
    /// ray.
    #[inline]
    pub fn any_leaves(
        &self,
        ray: &Ray,
        vectors: &RayVectors,
        prefetch: &impl Fn(usize),
        leaf: impl FnMut(usize, usize) -> bool,
    ) -> bool {
        self.any_leaves_by(ray, vectors, prefetch, RayLanes::hit_children, leaf)
    }

    /// [`Bvh::any_leaves`] with the node test `test`, always inlined (see
    /// [`Bvh::closest_leaves_by`]).
    #[inline(always)]
    pub(crate) fn any_leaves_by(
        &self,
        ray: &Ray,
        vectors: &RayVectors,
        prefetch: &impl Fn(usize),
        test: impl Fn(&RayLanes, &Node, f32, f32) -> (f32x8, u32),
        mut leaf: impl FnMut(usize, usize) -> bool,
    ) -> bool {
        if self.root == EMPTY {
            return false;
        }
        let lanes = RayLanes::new(vectors);
        let mut stack: ArrayVec<u32, STACK> = ArrayVec::new();
        let mut code = self.root;
        loop {
            while code & LEAF_BIT == 0 {
                let node = &self.nodes[code as usize];
                let (_, mut mask) = test(&lanes, node, ray.t_min, ray.t_max);
                if mask == 0 {
                    match stack.pop() {
                        Some(next) => {
                            code = next;
                            continue;
                        }
                        None => return false,
                    }
                }
                code = node.child[mask.trailing_zeros() as usize];
                mask &= mask - 1;
                while mask != 0 {
                    let child = node.child[mask.trailing_zeros() as usize];
                    let _ = stack.try_push(child);
                    self.prefetch(child, prefetch);
                    mask &= mask - 1;
                }
            }
            let (start, count) = leaf_span(code);
            if leaf(start, count) {
                return true;
            }
            match stack.pop() {
                Some(next) => code = next,
                None => return false,
            }
        }
    }
}

impl Bvh {
    /// Starts loading a child that traversal defers (a stack entry) into
    /// the cache, so that its memory latency overlaps the work done
    /// before it is popped: incoherent rays on a large mesh miss the cache
    /// at nearly every node. A leaf goes to `leaf(start)`, which knows
    /// where the caller keeps it. A hint only (a no-op off x86-64).
    #[inline(always)]
    fn prefetch(&self, code: u32, leaf: &impl Fn(usize)) {
        if code & LEAF_BIT != 0 {
            leaf(leaf_span(code).0);
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if let Some(node) = self.nodes.get(code as usize) {
            // All four lines (child codes and planes 0, 1-2, 3-4, 5).
            safe_arch::prefetch_t0(node);
            safe_arch::prefetch_t0(&node.planes[1]);
            safe_arch::prefetch_t0(&node.planes[3]);
            safe_arch::prefetch_t0(&node.planes[5]);
        }
    }
}

/// A sorting network for eight keys.
const SORT8: [(usize, usize); 19] = [
    (0, 2),
    (1, 3),
    (4, 6),
    (5, 7),
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 7),
    (0, 1),
    (2, 3),
    (4, 5),
    (6, 7),
    (2, 4),
    (3, 5),
    (1, 4),
    (3, 6),
    (1, 2),
    (3, 4),
    (5, 6),
];

/// Two keys, the smaller first.
#[inline(always)]
fn order(x: u64, y: u64) -> (u64, u64) {
    (x.min(y), x.max(y))
}

/// Pops entries until one starts before `t_max`; returns its child code.
#[inline(always)]
fn pop_within(stack: &mut ArrayVec<(u32, f32), STACK>, t_max: f32) -> Option<u32> {
    while let Some((code, t_enter)) = stack.pop() {
        if t_enter <= t_max {
            return Some(code);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::bvh::tests::{hit_sphere, sphere_bounds, spheres};
    use crate::math::Bounds3;
    use crate::sampler::Pcg32;
    use crate::sampling::square_to_uniform_sphere;
    use glam::Vec3;

    /// The AVX2 node test on this CPU, or `None` where it has no AVX2:
    /// (entry distances' bits, mask) per (ray, node) pair. Compiled for
    /// the targets of single-ray traversal (`scene/traversal.rs`), so that
    /// the test runs in the code this CPU's traversal runs.
    #[multiversion::multiversion(targets(
        "x86_64+avx512f+avx512vl+avx512bw+avx512dq+avx2+fma",
        "x86_64+avx2+fma"
    ))]
    fn avx2_box_tests(cases: &[(RayLanes, Node, f32, f32)]) -> Option<Vec<([u32; 8], u32)>> {
        #[multiversion::target::target_cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        #[multiversion::inherit_target]
        fn run(cases: &[(RayLanes, Node, f32, f32)]) -> Option<Vec<([u32; 8], u32)>> {
            let test = |(l, n, lo, hi): &(RayLanes, Node, f32, f32)| {
                let (t, mask) = hit_children_avx2(l, n, *lo, *hi);
                (t.to_array().map(f32::to_bits), mask)
            };
            Some(cases.iter().map(test).collect())
        }
        #[multiversion::target::target_cfg(not(all(
            target_arch = "x86_64",
            target_feature = "avx2"
        )))]
        fn run(_: &[(RayLanes, Node, f32, f32)]) -> Option<Vec<([u32; 8], u32)>> {
            None
        }
        run(cases)
    }

    /// The AVX2 box test gives the portable one's distances and masks bit
    /// for bit (so traversal order and images do not depend on the CPU):
    /// random boxes with empty slots, rays with zero direction components,
    /// intervals that cut boxes or are empty.
    #[test]
    fn avx2_box_test_equals_portable_one() {
        let mut rng = Pcg32::new(21, 4);
        let mut cases = Vec::new();
        for _ in 0..4000 {
            let used = 1 + (rng.next_f32() * 8.0) as usize;
            let boxes = (0..used.min(8)).map(|_| {
                let c = (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * 8.0;
                let h = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0;
                Bounds3 {
                    min: c - h,
                    max: c + h,
                }
            });
            let node = Node::with_boxes(boxes);
            let o = (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * 12.0;
            // Towards the middle of the boxes' region, some axis-parallel.
            let target = (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * 4.0;
            let mut d = (target - o).normalize();
            if rng.next_f32() < 0.2 {
                d.y = 0.0;
            }
            let ray = Ray::new(o, d);
            let t_min = rng.next_f32() * 2.0;
            // Some empty intervals: a box containing t_min is met (≤, not <).
            let t_max = if rng.next_f32() < 0.1 {
                t_min
            } else {
                t_min + rng.next_f32() * 10.0
            };
            cases.push((RayLanes::new(&ray.vectors()), node, t_min, t_max));
        }
        let Some(avx2) = avx2_box_tests(&cases) else {
            eprintln!("skipped: this CPU has no AVX2");
            return;
        };
        let mut hits = 0;
        for ((l, n, lo, hi), got) in cases.iter().zip(avx2) {
            let (t, mask) = l.hit_children(n, *lo, *hi);
            assert_eq!((t.to_array().map(f32::to_bits), mask), got);
            hits += mask.count_ones();
        }
        assert!(hits > 500, "too few boxes met ({hits}) to test anything");
    }

    /// A (packet, node, child, t_max) case of the packet box test.
    type PacketBoxCase = (PacketLanes, Node, usize, f32x8);

    /// The AVX2 packet box test on this CPU, or `None` where it has no
    /// AVX2: the mask per case.
    #[multiversion::multiversion(targets("x86_64+avx2+fma"))]
    fn avx2_packet_box_tests(cases: &[PacketBoxCase]) -> Option<Vec<u32>> {
        #[multiversion::target::target_cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        #[multiversion::inherit_target]
        fn run(cases: &[PacketBoxCase]) -> Option<Vec<u32>> {
            let test = |(l, n, c, t): &PacketBoxCase| hit_child_avx2(l, n, *c, *t);
            Some(cases.iter().map(test).collect())
        }
        #[multiversion::target::target_cfg(not(all(
            target_arch = "x86_64",
            target_feature = "avx2"
        )))]
        fn run(_: &[PacketBoxCase]) -> Option<Vec<u32>> {
            None
        }
        run(cases)
    }

    /// Per lane, the least non-negative `t_max` at which the portable
    /// packet test says the lane meets child `c` (by bisection on the
    /// floats' bits, which order non-negative floats); `f32::MAX` where
    /// it never does.
    fn least_t_max_meeting(lanes: &PacketLanes, node: &Node, c: usize) -> [f32; PACKET_RAYS] {
        let (mut lo, mut hi) = ([0u32; PACKET_RAYS], [f32::MAX.to_bits(); PACKET_RAYS]);
        for _ in 0..32 {
            let mid: [u32; PACKET_RAYS] = std::array::from_fn(|l| lo[l] + (hi[l] - lo[l]) / 2);
            let mask = lanes.hit_child(node, c, f32x8::new(mid.map(f32::from_bits)));
            for l in 0..PACKET_RAYS {
                if mask >> l & 1 != 0 {
                    hi[l] = mid[l];
                } else {
                    lo[l] = mid[l];
                }
            }
        }
        hi.map(f32::from_bits)
    }

    /// The AVX2 packet box test gives the portable one's masks bit for
    /// bit: random boxes, packets of rays from random origins with some
    /// zero direction components, intervals that cut boxes, end before
    /// them, or end just where a lane's mask flips.
    #[test]
    fn avx2_packet_box_test_equals_portable_one() {
        let mut rng = Pcg32::new(22, 5);
        let mut cases = Vec::new();
        for _ in 0..2000 {
            let boxes = (0..WIDTH).map(|_| {
                let c = (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * 8.0;
                let h = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0;
                Bounds3 {
                    min: c - h,
                    max: c + h,
                }
            });
            let node = Node::with_boxes(boxes.collect::<Vec<_>>().into_iter());
            let rays: [Ray; PACKET_RAYS] = std::array::from_fn(|_| {
                let o = (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * 12.0;
                // Towards the middle of the boxes' region, some axis-parallel.
                let target =
                    (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * 4.0;
                let mut d = (target - o).normalize();
                if rng.next_f32() < 0.2 {
                    d.x = 0.0;
                }
                let mut ray = Ray::new(o, d);
                ray.t_min = rng.next_f32();
                ray
            });
            let lanes = PacketLanes::new(&RayPacket::new(&rays));
            let t_max = f32x8::new(std::array::from_fn(|_| rng.next_f32() * 12.0));
            let c = (rng.next_f32() * WIDTH as f32) as usize % WIDTH;
            // Where a mask bit flips, any difference in the arithmetic
            // shows: each lane's least t_max that meets the box, and the
            // float below it.
            let least = least_t_max_meeting(&lanes, &node, c);
            let below = least.map(|t| f32::from_bits(t.to_bits().saturating_sub(1)));
            cases.push((lanes, node, c, f32x8::new(least)));
            cases.push((lanes, node, c, f32x8::new(below)));
            cases.push((lanes, node, c, t_max));
        }
        let Some(avx2) = avx2_packet_box_tests(&cases) else {
            eprintln!("skipped: this CPU has no AVX2");
            return;
        };
        let mut met = 0;
        for ((l, n, c, t), got) in cases.iter().zip(avx2) {
            let want = l.hit_child(n, *c, *t);
            assert_eq!(want, got);
            met += want.count_ones();
        }
        assert!(met > 500, "too few boxes met ({met}) to test anything");
    }

    #[test]
    fn bvh_equals_brute_force() {
        let mut rng = Pcg32::new(11, 0);
        for n in [1, 7, 100, 5000] {
            let prims = spheres(n, &mut rng);
            let bounds = sphere_bounds(&prims);
            let bvh = Bvh::build(&bounds);
            for _ in 0..2000 {
                let o =
                    Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 12.0 - Vec3::ONE;
                let d = square_to_uniform_sphere(rng.next_2d());
                let mut ray = Ray::new(o, d);
                let mut bvh_hit = None;
                bvh.closest(&mut ray, |i, r| {
                    let t = hit_sphere(prims[i as usize], r)?;
                    bvh_hit = Some(i);
                    Some(t)
                });
                let mut brute = Ray::new(o, d);
                let mut brute_hit = None;
                for (i, &s) in prims.iter().enumerate() {
                    if let Some(t) = hit_sphere(s, &brute) {
                        brute.t_max = t;
                        brute_hit = Some(i as u32);
                    }
                }
                assert_eq!(bvh_hit, brute_hit);
                assert_eq!(ray.t_max, brute.t_max);
                let occluded = bvh.any(&Ray::new(o, d), |i, r| {
                    hit_sphere(prims[i as usize], r).is_some()
                });
                assert_eq!(occluded, brute_hit.is_some());
            }
        }
    }

    #[test]
    fn axis_aligned_rays_with_signed_zero_components() {
        // A grid of unit boxes; rays along the axes with ±0 in the other
        // components must find the box straight ahead.
        let mut bounds = Vec::new();
        for i in 0..5 {
            for j in 0..5 {
                let c = Vec3::new(i as f32 * 2.0, j as f32 * 2.0, 0.0);
                bounds.push(Bounds3 {
                    min: c - Vec3::splat(0.5),
                    max: c + Vec3::splat(0.5),
                });
            }
        }
        let bvh = Bvh::build(&bounds);
        for zero in [0.0f32, -0.0] {
            for (o, d) in [
                (Vec3::new(4.0, 4.0, -5.0), Vec3::new(zero, zero, 1.0)),
                (Vec3::new(4.0, 4.0, 5.0), Vec3::new(zero, zero, -1.0)),
                (Vec3::new(-5.0, 2.0, 0.0), Vec3::new(1.0, zero, zero)),
                (Vec3::new(2.0, 15.0, 0.0), Vec3::new(zero, -1.0, zero)),
            ] {
                let mut ray = Ray::new(o, d);
                let hit = bvh.closest(&mut ray, |i, r| {
                    bounds[i as usize].hit(r.o, r.d.recip(), r.t_max)
                });
                assert!(hit, "ray {o} {d} missed");
                assert!(
                    bvh.any(&Ray::new(o, d), |_, _| true),
                    "any-hit: ray {o} {d} missed"
                );
            }
        }
    }

    #[test]
    fn sorting_network_sorts_every_input() {
        // The 0-1 principle (Knuth, TAOCP vol. 3, §5.3.4): a network that
        // sorts every sequence of zeros and ones sorts every sequence.
        for bits in 0u32..1 << WIDTH {
            let mut keys: [u64; WIDTH] = std::array::from_fn(|i| u64::from((bits >> i) & 1));
            for (i, j) in SORT8 {
                (keys[i], keys[j]) = order(keys[i], keys[j]);
            }
            assert!(keys.windows(2).all(|w| w[0] <= w[1]), "{bits:08b}");
        }
    }

    #[test]
    fn empty_bvh_hits_nothing() {
        let bvh = Bvh::build(&[]);
        let mut ray = Ray::new(Vec3::ZERO, Vec3::X);
        assert!(!bvh.closest(&mut ray, |_, _| Some(1.0)));
        assert!(!bvh.any(&ray, |_, _| true));
    }
}
