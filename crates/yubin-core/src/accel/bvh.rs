//! An 8-wide bounding volume hierarchy.
//!
//! Built top-down with binned SAH (Wald 2007, "On fast Construction of
//! SAH-based Bounding Volume Hierarchies"; pbrt-v4 §7.3), subtrees in
//! parallel with rayon; the binary tree is then collapsed into 8-wide nodes
//! by repeatedly opening the child with the largest surface area (Wald et
//! al. 2008, "Getting Rid of Packets"; Dammertz et al. 2008, "Shallow
//! Bounding Volume Hierarchies"). A node stores its eight children's boxes
//! in structure-of-arrays form, so one ray meets all eight with a handful
//! of SIMD instructions (`wide::f32x8`: AVX when the build targets it, two
//! SSE halves on baseline x86-64, NEON on ARM, scalar
//! elsewhere; no `unsafe`). A portable x86-64 build also has an AVX2 node
//! test ([`hit_children_avx2`]) for traversal that `scene.rs` compiles for
//! AVX2 and chooses at run time; both tests give the same bits.

use super::HugeArray;
use crate::math::{Bounds3, Ray, RayPacket, RayVectors};
use arrayvec::ArrayVec;
use bytemuck::{Pod, Zeroable};
use glam::{Vec3A, Vec4};
use rayon::prelude::*;
use wide::{f32x4, f32x8, CmpLe};

/// Children per node.
const WIDTH: usize = 8;

const BINS: usize = 16;
/// Primitives per leaf at most: one packet of triangles (see
/// [`Bvh::take_leaf_order_packed`]).
pub const MAX_LEAF: usize = 8;
/// Primitives per leaf at most when one of them is tested on its own
/// ([`PrimCost::Alone`]): such tests cost more than the SAH's estimate
/// when several large shapes overlap (the walls of a room), and a leaf of
/// eight of them measured slower than two leaves of four.
const MAX_LEAF_ALONE: usize = 4;
/// Default cost of a primitive test relative to a node visit, for
/// [`Bvh::build`]; [`Bvh::build_with_costs`] takes one per primitive.
const INTERSECT_COST: f32 = 1.0;
/// Cost of one packet test relative to a node visit: a leaf of
/// [`PrimCost::Packed`] primitives pays it once per started group of
/// [`MAX_LEAF`] (the block-aware SAH of Wald et al. 2014, "Embree: A Kernel Framework
/// for Efficient CPU Ray Tracing", §4.2), so the build favours full
/// packets.
const PACKET_COST: f32 = 1.0;
const TRAVERSAL_COST: f32 = 1.0;
const PARALLEL_THRESHOLD: usize = 4096;
/// Traversal stack entries: an 8-wide node pushes at most 7 siblings per
/// level, and the tree is at most `MAX_SAH_DEPTH` + log2(n) binary levels.
const STACK: usize = 256;
/// Below this depth, splits are forced to the median so that no tree is
/// deeper than the traversal stack allows (SAH can make long chains of
/// lopsided splits on adversarial input).
const MAX_SAH_DEPTH: usize = 60;

/// Child slot encoding: `EMPTY`, an inner node index, or a leaf with
/// `LEAF_BIT`, the primitive count − 1 in bits 28–30 and the first
/// position in bits 0–27 (so at most [`MAX_POSITIONS`] positions).
const EMPTY: u32 = u32::MAX;
const LEAF_BIT: u32 = 1 << 31;
const START_MASK: u32 = (1 << 28) - 1;

/// Leaf positions one BVH can address: at most this many primitives, and
/// a packed leaf order (see [`Bvh::take_leaf_order_packed`]) of at most
/// this many slots.
pub const MAX_POSITIONS: usize = START_MASK as usize + 1;

#[inline]
fn leaf_code(start: usize, count: usize) -> u32 {
    LEAF_BIT | (((count - 1) as u32) << 28) | (start as u32 & START_MASK)
}

/// Whether a child code is a leaf (`EMPTY` has the leaf bit too).
#[inline]
fn is_leaf(code: u32) -> bool {
    code != EMPTY && code & LEAF_BIT != 0
}

/// First position and primitive count of a leaf's code.
#[inline(always)]
fn leaf_span(code: u32) -> (usize, usize) {
    (
        (code & START_MASK) as usize,
        ((code >> 28) & 7) as usize + 1,
    )
}

/// Aligned to a cache line: the 224 bytes then span four lines, never
/// five. Plain data (`Pod`), so that it can live in a [`HugeArray`].
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
#[repr(C, align(64))]
pub(crate) struct Node {
    /// First, so that the child codes share a cache line with the first
    /// planes: the child to visit is read right after the box test, and
    /// on a line of its own that read would wait for memory a second time.
    child: [u32; WIDTH],
    /// The eight children's lower and upper x bounds, then y, then z: one
    /// array, so that a ray picks its near and far planes by index (see
    /// [`RayLanes`]) instead of by a per-node choice; pairing an axis's
    /// two planes makes the far index the near one with its low bit
    /// flipped.
    planes: [f32x8; 6],
    /// The rest of the fourth line, unused (the alignment would leave it
    /// as padding, which plain data may not have).
    spare: [u32; WIDTH],
}

impl Node {
    const EMPTY: Self = Self {
        child: [EMPTY; WIDTH],
        spare: [0; WIDTH],
        planes: [
            f32x8::new([f32::INFINITY; WIDTH]),
            f32x8::new([f32::NEG_INFINITY; WIDTH]),
            f32x8::new([f32::INFINITY; WIDTH]),
            f32x8::new([f32::NEG_INFINITY; WIDTH]),
            f32x8::new([f32::INFINITY; WIDTH]),
            f32x8::new([f32::NEG_INFINITY; WIDTH]),
        ],
    };

    /// The box of child `slot`.
    fn child_box(&self, slot: usize) -> Bounds3 {
        let p = self.planes.map(|v| v.to_array()[slot]);
        Bounds3 {
            min: glam::Vec3::new(p[0], p[2], p[4]),
            max: glam::Vec3::new(p[1], p[3], p[5]),
        }
    }

    /// A node over children with these boxes (the rest empty); the child
    /// codes are filled in afterwards.
    fn with_boxes(boxes: impl Iterator<Item = Bounds3>) -> Self {
        let (mut min, mut max) = ([[f32::INFINITY; WIDTH]; 3], [[f32::NEG_INFINITY; WIDTH]; 3]);
        for (slot, b) in boxes.enumerate() {
            for a in 0..3 {
                min[a][slot] = b.min[a];
                max[a][slot] = b.max[a];
            }
        }
        let mut node = Self::EMPTY;
        for a in 0..3 {
            node.planes[2 * a] = f32x8::new(min[a]);
            node.planes[2 * a + 1] = f32x8::new(max[a]);
        }
        node
    }
}

/// A BVH over primitives identified by their index in the bounds slice
/// given to [`Bvh::build`].
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    nodes: HugeArray<Node>,
    /// The primitive at each leaf position, until [`Bvh::take_leaf_order`]
    /// hands it over; then empty, and position `i` is primitive `i` (an
    /// identity list would be 4 bytes per primitive for nothing).
    prims: Vec<u32>,
    /// Child code of the root: a node index or a leaf.
    root: u32,
    bounds: Bounds3,
}

/// Counts describing a built [`Bvh`] (see [`Bvh::stats`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BvhStats {
    /// Inner (8-wide) nodes.
    pub nodes: usize,
    /// Leaves.
    pub leaves: usize,
    /// Primitives over all leaves.
    pub leaf_prims: usize,
    /// Used child slots over all nodes (at most 8 per node).
    pub child_slots: usize,
    /// Nodes by number of children (index 0 and 1 stay empty).
    pub children_histogram: [usize; WIDTH + 1],
    /// Surface area heuristic of the nodes: the sum of their boxes'
    /// areas over the root's, the expected node visits of a ray that
    /// crosses the root box (Embree prints the same measure).
    pub node_sah: f64,
    /// The same sum over the leaves' boxes: expected leaf visits.
    pub leaf_sah: f64,
    /// Wide nodes on the longest path from the root to a leaf (the root
    /// counts; Embree prints the same as "depth").
    pub depth: usize,
    /// Wide nodes above a leaf, averaged over leaves weighted by their
    /// boxes' areas: the length of the chain of dependent node fetches a
    /// ray makes to reach a leaf.
    pub leaf_depth: f64,
}

/// What testing one primitive costs, for the SAH.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PrimCost {
    /// Tested [`MAX_LEAF`] at a time with others of its kind (a triangle
    /// in a SIMD packet).
    Packed,
    /// Tested on its own, at this cost relative to a node visit.
    Alone(f32),
}

/// A primitive during the build: 32 bytes, so that the passes over
/// millions of them move as little memory as possible. The bounds' fourth
/// lanes carry the index (lower corner, as bits) and the SAH cost (upper
/// corner: negative for [`PrimCost::Packed`]).
#[derive(Clone, Copy)]
struct BuildPrim {
    min: Vec4,
    max: Vec4,
}

impl BuildPrim {
    fn new(bounds: &Bounds3, index: u32, cost: PrimCost) -> Self {
        let cost = match cost {
            PrimCost::Packed => -1.0,
            PrimCost::Alone(c) => c.max(0.0),
        };
        Self {
            min: bounds.min.extend(f32::from_bits(index)),
            max: bounds.max.extend(cost),
        }
    }

    #[inline]
    fn bounds(&self) -> Box3A {
        Box3A {
            min: Vec3A::from_vec4(self.min),
            max: Vec3A::from_vec4(self.max),
        }
    }

    #[inline]
    fn index(&self) -> u32 {
        self.min.w.to_bits()
    }

    #[inline]
    fn cost(&self) -> PrimCost {
        if self.max.w < 0.0 {
            PrimCost::Packed
        } else {
            PrimCost::Alone(self.max.w)
        }
    }

    /// Twice the centroid (`min + max`): the builder bins and splits on it
    /// throughout, which saves the halving.
    #[inline]
    fn centroid2(&self) -> Vec3A {
        Vec3A::from_vec4(self.min + self.max)
    }
}

/// A box with 16-byte corners, for the builder's many unions (one SIMD
/// min and max each, where [`Bounds3`] takes three of each).
#[derive(Clone, Copy, Debug)]
struct Box3A {
    min: Vec3A,
    max: Vec3A,
}

impl Box3A {
    const EMPTY: Self = Self {
        min: Vec3A::INFINITY,
        max: Vec3A::NEG_INFINITY,
    };

    #[inline]
    fn union(self, o: Self) -> Self {
        Self {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    #[inline]
    fn union_point(self, p: Vec3A) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// Surface area; 0 for an empty box.
    #[inline]
    fn area(self) -> f32 {
        let e = (self.max - self.min).max(Vec3A::ZERO);
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    fn to_bounds(self) -> Bounds3 {
        Bounds3 {
            min: self.min.into(),
            max: self.max.into(),
        }
    }
}

/// The summed test cost of a set of primitives.
#[derive(Clone, Copy, Debug, Default)]
struct Load {
    alone: f32,
    packed: u32,
}

impl Load {
    #[inline]
    fn add(self, cost: PrimCost) -> Self {
        match cost {
            PrimCost::Packed => Self {
                packed: self.packed + 1,
                ..self
            },
            PrimCost::Alone(c) => Self {
                alone: self.alone + c,
                ..self
            },
        }
    }

    #[inline]
    fn union(self, o: Self) -> Self {
        Self {
            alone: self.alone + o.alone,
            packed: self.packed + o.packed,
        }
    }

    #[inline]
    fn cost(self) -> f32 {
        self.alone + self.packed.div_ceil(MAX_LEAF as u32) as f32 * PACKET_COST
    }
}

/// A node of the binary SAH tree, which [`collapse`] turns into 8-wide
/// nodes.
enum BuildNode {
    Leaf {
        bounds: Bounds3,
        start: usize,
        count: usize,
        /// Surface area times the cost of testing the leaf.
        cost: f32,
    },
    Inner {
        bounds: Bounds3,
        /// Primitives below, to decide what is worth doing in parallel.
        prims: usize,
        children: Box<[BuildNode; 2]>,
        /// For `i` = 1..=8: the least SAH cost of this subtree when it may
        /// fill at most `i` child slots of a wide node (index `i` − 1).
        slot_cost: [f32; WIDTH],
        /// How that least cost is reached: 0 when this node becomes a wide
        /// node of its own (one slot), else how many of the `i` slots go to
        /// the left child (the rest to the right).
        slots_left: [u8; WIDTH],
    },
}

impl BuildNode {
    fn bounds(&self) -> Bounds3 {
        match self {
            BuildNode::Leaf { bounds, .. } | BuildNode::Inner { bounds, .. } => *bounds,
        }
    }

    fn prims(&self) -> usize {
        match self {
            BuildNode::Leaf { count, .. } => *count,
            BuildNode::Inner { prims, .. } => *prims,
        }
    }

    /// Least SAH cost of the subtree in at most `slots` (1..=8) slots.
    fn cost_in(&self, slots: usize) -> f32 {
        match self {
            BuildNode::Leaf { cost, .. } => *cost,
            BuildNode::Inner { slot_cost, .. } => slot_cost[slots - 1],
        }
    }

    /// An inner node over `children`, with the dynamic program of Ylitie,
    /// Karras and Laine 2017 ("Efficient Incoherent Ray Traversal on GPUs
    /// Through Compressed Wide BVHs", §3.1) that decides which binary
    /// nodes become 8-wide nodes and which are opened into their parent:
    /// the wide tree of least SAH cost, instead of a greedy grouping that
    /// leaves many nodes with two children.
    fn inner(bounds: Bounds3, children: [BuildNode; 2]) -> Self {
        let [left, right] = &children;
        // spread[j]: least cost of the two children in at most j slots.
        let mut spread = [(f32::INFINITY, 0u8); WIDTH + 1];
        for (j, entry) in spread.iter_mut().enumerate().skip(2) {
            for k in 1..j {
                let c = left.cost_in(k) + right.cost_in(j - k);
                if c < entry.0 {
                    *entry = (c, k as u8);
                }
            }
        }
        let as_node = bounds.surface_area() * TRAVERSAL_COST + spread[WIDTH].0;
        let mut slot_cost = [as_node; WIDTH];
        let mut slots_left = [0u8; WIDTH];
        for i in 2..=WIDTH {
            if spread[i].0 < as_node {
                slot_cost[i - 1] = spread[i].0;
                slots_left[i - 1] = spread[i].1;
            }
        }
        BuildNode::Inner {
            bounds,
            prims: left.prims() + right.prims(),
            children: Box::new(children),
            slot_cost,
            slots_left,
        }
    }

    /// The subtrees that fill at most `slots` child slots of a wide node,
    /// as the dynamic program chose them. Takes the tree apart: the binary
    /// nodes opened here are freed.
    fn fill(self, slots: usize, out: &mut ArrayVec<BuildNode, WIDTH>) {
        match self {
            BuildNode::Inner {
                children,
                slots_left,
                ..
            } if slots_left[slots - 1] != 0 => {
                let k = slots_left[slots - 1] as usize;
                let [left, right] = *children;
                left.fill(k, out);
                right.fill(slots - k, out);
            }
            node => out.push(node),
        }
    }
}

/// Turns a binary subtree into 8-wide nodes appended to `nodes` (depth
/// first: a node, then its children's subtrees in slot order), freeing the
/// binary tree on the way; returns the subtree's child code. The children
/// of a large subtree are collapsed in parallel, each into a list of its
/// own that is then appended in slot order, so the layout is the same as
/// a serial collapse's.
fn collapse(node: BuildNode, nodes: &mut Vec<Node>) -> u32 {
    let (children, slots_left, prims) = match node {
        BuildNode::Leaf { start, count, .. } => return leaf_code(start, count),
        BuildNode::Inner {
            children,
            slots_left,
            prims,
            ..
        } => (children, slots_left, prims),
    };
    // A wide node's slots: the eight-slot choice of the dynamic program
    // (never "one slot", which is this node itself).
    let k = (slots_left[WIDTH - 1] as usize).clamp(1, WIDTH - 1);
    let mut kids: ArrayVec<BuildNode, WIDTH> = ArrayVec::new();
    let [left, right] = *children;
    left.fill(k, &mut kids);
    right.fill(WIDTH - k, &mut kids);
    let index = nodes.len();
    nodes.push(Node::with_boxes(kids.iter().map(BuildNode::bounds)));
    let codes: ArrayVec<u32, WIDTH> = if prims > PARALLEL_THRESHOLD {
        let subtrees: Vec<(u32, Vec<Node>)> = kids
            .into_iter()
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|kid| {
                let mut sub = Vec::new();
                (collapse(kid, &mut sub), sub)
            })
            .collect();
        subtrees
            .into_iter()
            .map(|(code, sub)| append_subtree(nodes, code, sub))
            .collect()
    } else {
        kids.into_iter().map(|kid| collapse(kid, nodes)).collect()
    };
    nodes[index].child[..codes.len()].copy_from_slice(&codes);
    index as u32
}

/// Appends the nodes of a subtree collapsed on its own (its node codes
/// count from its first node); returns its code, now an index in `nodes`.
fn append_subtree(nodes: &mut Vec<Node>, code: u32, mut sub: Vec<Node>) -> u32 {
    let offset = nodes.len() as u32;
    let shift = |c: u32| {
        if c == EMPTY || c & LEAF_BIT != 0 {
            c
        } else {
            c + offset
        }
    };
    for node in &mut sub {
        for c in &mut node.child {
            *c = shift(*c);
        }
    }
    nodes.append(&mut sub);
    shift(code)
}

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
/// for AVX2 and chosen at run time (see `scene.rs`). Multiply then add,
/// and the same min/max operand order: the same distances and masks bit
/// for bit, so the traversal order, and every image, is the same on
/// either path. A build for AVX2 (`target-cpu`) needs no second test:
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
    /// Builds over the given primitive bounds. Empty bounds (degenerate or
    /// absent primitives) are left out.
    pub fn build(bounds: &[Bounds3]) -> Self {
        Self::build_with_costs(bounds, |_| PrimCost::Alone(INTERSECT_COST))
    }

    /// Like [`Bvh::build`], with `cost(i)` the expected cost of testing
    /// primitive `i` relative to visiting a node, for the SAH.
    pub fn build_with_costs(bounds: &[Bounds3], cost: impl Fn(usize) -> PrimCost + Sync) -> Self {
        let usable = |b: &Bounds3| !b.is_empty() && b.min.is_finite() && b.max.is_finite();
        // Collected at full length and then filtered: a filtered parallel
        // collect has no length to write to and gathers per-thread lists
        // first, which cost a tenth of the build.
        let mut prims: Vec<BuildPrim> = bounds
            .par_iter()
            .enumerate()
            .map(|(i, b)| BuildPrim::new(b, i as u32, cost(i)))
            .collect();
        if !bounds.par_iter().all(usable) {
            prims.retain(|p| usable(&bounds[p.index() as usize]));
        }
        debug_assert!(
            prims.len() <= MAX_POSITIONS,
            "too many primitives for one BVH"
        );
        if prims.is_empty() {
            return Self {
                root: EMPTY,
                ..Self::default()
            };
        }
        let extent = Extent::of(&prims);
        let root = if one_node_of_singletons(&prims) {
            singletons(&mut prims, 0, extent)
        } else {
            build_recursive(&mut prims, 0, 0, extent, &mut [[Bin::EMPTY; BINS]; 3])
        };
        let bounds = root.bounds();
        let mut nodes = Vec::new();
        let root = collapse(root, &mut nodes);
        Self {
            nodes: HugeArray::from_slice(&nodes),
            prims: prims.par_iter().map(BuildPrim::index).collect(),
            root,
            bounds,
        }
    }

    /// Bounds of everything (empty for an empty BVH).
    pub fn bounds(&self) -> Bounds3 {
        if self.root == EMPTY {
            Bounds3::EMPTY
        } else {
            self.bounds
        }
    }

    /// Hands over the primitive order of the leaves and renumbers the
    /// primitives to match: afterwards primitive `i` in a callback means
    /// position `i` of the returned order. Callers that permute their own
    /// arrays by it get leaves whose primitives sit next to each other.
    /// The order can be taken once (a second call returns it empty).
    pub fn take_leaf_order(&mut self) -> Vec<u32> {
        std::mem::take(&mut self.prims)
    }

    /// Like [`Bvh::take_leaf_order`], but every leaf starts at a multiple
    /// of [`MAX_LEAF`] positions: slot `i` of the result is the primitive
    /// at position `i`, `None` for padding. Callers then store each leaf
    /// as one aligned packet of that many lanes (after
    /// [`Bvh::take_leaf_order`], positions stand for the primitives).
    /// `None`, leaving the BVH as it was, when the padded order would need
    /// more than [`MAX_POSITIONS`] positions.
    pub fn take_leaf_order_packed(&mut self) -> Option<Vec<Option<u32>>> {
        let len = self.leaf_codes().count().saturating_mul(MAX_LEAF);
        if len > MAX_POSITIONS {
            return None;
        }
        let order = std::mem::take(&mut self.prims);
        let mut slots: Vec<Option<u32>> = Vec::with_capacity(len);
        let mut repack = |code: u32| {
            if !is_leaf(code) {
                return code;
            }
            let (start, count) = leaf_span(code);
            let new_start = slots.len();
            slots.extend((start..start + count).map(|i| Some(prim_at(&order, i))));
            slots.resize(new_start + MAX_LEAF, None);
            leaf_code(new_start, count)
        };
        self.root = repack(self.root);
        self.nodes.modify(|nodes| {
            for c in nodes.iter_mut().flat_map(|n| &mut n.child) {
                *c = repack(*c);
            }
        });
        Some(slots)
    }

    /// The codes of all leaves.
    fn leaf_codes(&self) -> impl Iterator<Item = u32> + '_ {
        let children = self.nodes.iter().flat_map(|n| n.child);
        std::iter::once(self.root)
            .chain(children)
            .filter(|&c| is_leaf(c))
    }

    /// Shape of the tree, for benchmarks and tuning.
    pub fn stats(&self) -> BvhStats {
        let mut st = BvhStats {
            nodes: self.nodes.len(),
            ..BvhStats::default()
        };
        for code in self.leaf_codes() {
            st.leaves += 1;
            st.leaf_prims += leaf_span(code).1;
        }
        for n in self.nodes.iter() {
            let used = n.child.iter().filter(|&&c| c != EMPTY).count();
            st.child_slots += used;
            st.children_histogram[used] += 1;
        }
        let root_area = f64::from(self.bounds().surface_area());
        if self.root & LEAF_BIT == 0 && self.root != EMPTY {
            // Depth-first: (node, wide nodes from the root down to it).
            let mut todo = vec![(self.root, 1)];
            let mut weighted = (0.0, 0.0);
            while let Some((code, depth)) = todo.pop() {
                let n = &self.nodes[code as usize];
                st.depth = st.depth.max(depth);
                for (slot, &c) in n.child.iter().enumerate().filter(|(_, &c)| c != EMPTY) {
                    if c & LEAF_BIT == 0 {
                        todo.push((c, depth + 1));
                    } else {
                        let area = f64::from(n.child_box(slot).surface_area());
                        weighted = (weighted.0 + area * depth as f64, weighted.1 + area);
                    }
                }
            }
            st.leaf_depth = weighted.0 / weighted.1.max(f64::MIN_POSITIVE);
        }
        if root_area > 0.0 {
            // The root box is crossed by definition.
            let root_is_leaf = self.root & LEAF_BIT != 0;
            st.node_sah = if root_is_leaf { 0.0 } else { 1.0 };
            st.leaf_sah = if root_is_leaf { 1.0 } else { 0.0 };
            for n in self.nodes.iter() {
                for (slot, &c) in n.child.iter().enumerate().filter(|(_, &c)| c != EMPTY) {
                    let area = f64::from(n.child_box(slot).surface_area()) / root_area;
                    if c & LEAF_BIT != 0 {
                        st.leaf_sah += area;
                    } else {
                        st.node_sah += area;
                    }
                }
            }
        }
        st
    }

    /// Memory held by the structure (nodes and primitive indices).
    pub fn memory_bytes(&self) -> usize {
        self.nodes.resident_bytes() + self.prims.capacity() * 4
    }

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

/// The primitive at leaf position `i` of `prims`, a leaf order that is
/// empty once handed over (position `i` is then primitive `i`).
#[inline]
fn prim_at(prims: &[u32], i: usize) -> u32 {
    prims.get(i).copied().unwrap_or(i as u32)
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

/// The boxes around a set of primitives and around their (doubled)
/// centroids.
#[derive(Clone, Copy)]
struct Extent {
    bounds: Box3A,
    centroids: Box3A,
}

impl Extent {
    const EMPTY: Self = Self {
        bounds: Box3A::EMPTY,
        centroids: Box3A::EMPTY,
    };

    fn of(prims: &[BuildPrim]) -> Self {
        if prims.len() > PARALLEL_BINNING {
            return prims
                .par_chunks(BINNING_CHUNK)
                .map(Self::of)
                .reduce(|| Self::EMPTY, Self::union);
        }
        prims.iter().fold(Self::EMPTY, |e, p| e.add(p))
    }

    #[inline]
    fn add(self, p: &BuildPrim) -> Self {
        Self {
            bounds: self.bounds.union(p.bounds()),
            centroids: self.centroids.union_point(p.centroid2()),
        }
    }

    #[inline]
    fn union(self, o: Self) -> Self {
        Self {
            bounds: self.bounds.union(o.bounds),
            centroids: self.centroids.union(o.centroids),
        }
    }
}

/// Nodes with more primitives than this bin in parallel chunks.
const PARALLEL_BINNING: usize = 1 << 16;
const BINNING_CHUNK: usize = 1 << 14;

/// `extent` is that of `prims`, computed by the parent's binning, so each
/// level reads the primitives twice (bin, partition) instead of four times.
/// `bins` is scratch space, reused down the recursion (a fresh 2 KB array
/// per node cost a copy of it per node).
fn build_recursive(
    prims: &mut [BuildPrim],
    start: usize,
    depth: usize,
    extent: Extent,
    bins: &mut Bins,
) -> BuildNode {
    // Only built when it is the answer: summing the costs is a pass over
    // the primitives, which large nodes must not pay at every level.
    let leaf = |prims: &[BuildPrim]| leaf_node(prims, start, &extent);
    if prims.len() <= 1 {
        return leaf(prims);
    }
    let split = if depth < MAX_SAH_DEPTH {
        choose_split(prims, &extent, bins)
    } else {
        split_in_middle(prims, extent.centroids.to_bounds().max_axis())
    };
    let Some((mid, left_extent, right_extent)) = split else {
        return leaf(prims);
    };
    let (left, right) = prims.split_at_mut(mid);
    let children = if left.len() + right.len() > PARALLEL_THRESHOLD {
        rayon::join(
            || build_recursive(left, start, depth + 1, left_extent, bins),
            || {
                let bins = &mut [[Bin::EMPTY; BINS]; 3];
                build_recursive(right, start + mid, depth + 1, right_extent, bins)
            },
        )
    } else {
        (
            build_recursive(left, start, depth + 1, left_extent, bins),
            build_recursive(right, start + mid, depth + 1, right_extent, bins),
        )
    };
    BuildNode::inner(extent.bounds.to_bounds(), [children.0, children.1])
}

/// Whether the primitives fit one wide node as leaves of one each: at
/// most [`WIDTH`] of them, none a packed triangle. Such a tree costs one
/// node test, after which a ray tests only the primitives whose own boxes
/// it meets; shared leaves, which the SAH prefers when it prices a split
/// as a further node visit, made every ray inside a room test its walls
/// in pairs.
fn one_node_of_singletons(prims: &[BuildPrim]) -> bool {
    prims.len() <= WIDTH && prims.iter().all(|p| p.cost() != PrimCost::Packed)
}

/// A leaf of `prims` (at `start` of the leaf order, within `extent`),
/// with its SAH cost.
fn leaf_node(prims: &[BuildPrim], start: usize, extent: &Extent) -> BuildNode {
    BuildNode::Leaf {
        bounds: extent.bounds.to_bounds(),
        start,
        count: prims.len(),
        cost: extent.bounds.area()
            * prims
                .iter()
                .fold(Load::default(), |l, p| l.add(p.cost()))
                .cost(),
    }
}

/// A binary tree with one primitive per leaf, halving along the widest
/// axis of the centroids (for [`one_node_of_singletons`]).
fn singletons(prims: &mut [BuildPrim], start: usize, extent: Extent) -> BuildNode {
    if prims.len() <= 1 {
        return leaf_node(prims, start, &extent);
    }
    let (mid, left_extent, right_extent) = halve(prims, extent.centroids.to_bounds().max_axis());
    let (left, right) = prims.split_at_mut(mid);
    BuildNode::inner(
        extent.bounds.to_bounds(),
        [
            singletons(left, start, left_extent),
            singletons(right, start + mid, right_extent),
        ],
    )
}

/// The box around a bin's primitives and the sum of their costs. (Their
/// centroids' box is not needed: partitioning gathers both sides' extents
/// as it moves the primitives.)
#[derive(Clone, Copy)]
struct Bin {
    bounds: Box3A,
    load: Load,
}

impl Bin {
    const EMPTY: Self = Self {
        bounds: Box3A::EMPTY,
        load: Load {
            alone: 0.0,
            packed: 0,
        },
    };

    #[inline]
    fn union(self, o: Self) -> Self {
        Self {
            bounds: self.bounds.union(o.bounds),
            load: self.load.union(o.load),
        }
    }

    /// The SAH term: area times cost.
    #[inline]
    fn cost(&self) -> f32 {
        self.bounds.area() * self.load.cost()
    }
}

/// Per axis, the bins.
type Bins = [[Bin; BINS]; 3];

/// Where a (doubled) centroid falls among the bins of each axis. Axes
/// along which all centroids coincide put everything in bin 0.
#[derive(Clone, Copy)]
struct Binning {
    lo: Vec3A,
    scale: Vec3A,
    /// Bins in use, fewer for small nodes (see [`Binning::new`]).
    count: usize,
}

impl Binning {
    /// Binning for `n` primitives. Small nodes get fewer bins, `4 + n/20`
    /// up to [`BINS`] (the rule of Wald 2007 §4.2 as Embree applies it):
    /// the sweep over the bins is a fixed cost per node, which dominates
    /// for the half million small nodes of a million-triangle mesh, while a
    /// few primitives gain little from fine bins.
    fn new(centroids: &Box3A, n: usize) -> Self {
        let count = (4 + n / 20).min(BINS);
        let extent = centroids.max - centroids.min;
        let positive = extent.cmpgt(Vec3A::ZERO);
        Self {
            lo: centroids.min,
            scale: Vec3A::select(positive, count as f32 / extent, Vec3A::ZERO),
            count,
        }
    }

    /// Whether `c` falls in a bin below `split` on `axis`: exactly when
    /// [`Binning::bins`] says so (the same rounded product; for it, which
    /// is never negative, truncating below the integer `split` is being
    /// below it, and NaN, put in the top bin there, compares false here),
    /// with one axis's arithmetic instead of three.
    #[inline]
    fn below(&self, c: Vec3A, axis: usize, split: usize) -> bool {
        let a = axis.min(2);
        (c.to_array()[a] - self.lo.to_array()[a]) * self.scale.to_array()[a] < split as f32
    }

    /// The bin on each axis, all three at once, as partitioning sees it
    /// (see [`Binning::below`]).
    #[inline]
    fn bins(&self, c: Vec3A) -> [usize; 3] {
        let f = ((c - self.lo) * self.scale).min(Vec3A::splat((self.count - 1) as f32));
        // One vector truncation without Rust's saturating `as` (which
        // compiled to two branches per axis): the value is in
        // `0..count` (the centroid is never below `lo`, and `min` maps NaN
        // to the top bin), and the final minimum lets the compiler drop
        // the bounds checks.
        let i = f32x4::new([f.x, f.y, f.z, 0.0]).fast_trunc_int().to_array();
        [0, 1, 2].map(|a| (i[a] as usize).min(BINS - 1))
    }
}

/// Bins `prims` into `bins`, whose first `binning.count` bins per axis
/// must be empty. Filled in place: returning the 2 KB array by value made
/// a copy per node.
fn bin(prims: &[BuildPrim], binning: &Binning, bins: &mut Bins) {
    if prims.len() > PARALLEL_BINNING {
        let sum = prims
            .par_chunks(BINNING_CHUNK)
            .map(|c| {
                let mut b = [[Bin::EMPTY; BINS]; 3];
                bin(c, binning, &mut b);
                b
            })
            .reduce(
                || [[Bin::EMPTY; BINS]; 3],
                |mut a, b| {
                    for (x, y) in a.iter_mut().flatten().zip(b.iter().flatten()) {
                        *x = x.union(*y);
                    }
                    a
                },
            );
        *bins = sum;
        return;
    }
    for p in prims {
        for (axis, i) in binning.bins(p.centroid2()).into_iter().enumerate() {
            let b = &mut bins[axis][i];
            b.bounds = b.bounds.union(p.bounds());
            b.load = b.load.add(p.cost());
        }
    }
}

/// The best split of one axis's bins: its SAH cost (unnormalised) and the
/// first bin of the right side.
fn best_split_of(bins: &[Bin]) -> (f32, usize) {
    // Sweep from the right for the suffix costs, then from the left.
    let mut right_cost = [0.0; BINS];
    let mut acc = Bin::EMPTY;
    for i in (1..bins.len()).rev() {
        acc = acc.union(bins[i]);
        right_cost[i] = acc.cost();
    }
    let mut best = (f32::INFINITY, 0);
    let mut left = Bin::EMPTY;
    for i in 0..bins.len() - 1 {
        left = left.union(bins[i]);
        let cost = left.cost() + right_cost[i + 1];
        if cost < best.0 {
            best = (cost, i + 1);
        }
    }
    best
}

/// Picks the SAH-best binned split over all three axes (Wald 2007, "On
/// fast construction of SAH-based bounding volume hierarchies") and
/// partitions `prims` around it: the split position and both sides'
/// extents; `None` means "make a leaf".
fn choose_split(
    prims: &mut [BuildPrim],
    extent: &Extent,
    bins: &mut Bins,
) -> Option<(usize, Extent, Extent)> {
    let binning = Binning::new(&extent.centroids, prims.len());
    for axis in bins.iter_mut() {
        axis[..binning.count].fill(Bin::EMPTY);
    }
    bin(prims, &binning, bins);
    // An axis whose centroids all coincide has every primitive in bin 0
    // and offers no split.
    let axes = (0..3).filter(|&a| binning.scale[a] > 0.0);
    let Some((axis, (best_cost, split))) = axes
        .map(|a| (a, best_split_of(&bins[a][..binning.count])))
        .min_by(|x, y| x.1 .0.total_cmp(&y.1 .0))
    else {
        return split_in_middle(prims, 0);
    };
    let parent_area = extent.bounds.area().max(f32::MIN_POSITIVE);
    let split_cost = TRAVERSAL_COST + best_cost / parent_area;
    let leaf_cost = bins[axis][..binning.count]
        .iter()
        .fold(Load::default(), |l, b| l.union(b.load))
        .cost();
    if fits_in_leaf(prims) && split_cost >= leaf_cost {
        return None;
    }
    let (mid, left, right) = partition(prims, &|p| binning.below(p.centroid2(), axis, split));
    if mid == 0 || mid == prims.len() {
        return split_in_middle(prims, axis);
    }
    Some((mid, left, right))
}

/// Whether one leaf may hold all of these primitives.
fn fits_in_leaf(prims: &[BuildPrim]) -> bool {
    let packed = |p: &BuildPrim| p.cost() == PrimCost::Packed;
    prims.len() <= MAX_LEAF_ALONE || (prims.len() <= MAX_LEAF && prims.iter().all(packed))
}

fn split_in_middle(prims: &mut [BuildPrim], axis: usize) -> Option<(usize, Extent, Extent)> {
    if fits_in_leaf(prims) {
        return None;
    }
    Some(halve(prims, axis))
}

/// Splits `prims` at the median of their centroids along `axis`.
fn halve(prims: &mut [BuildPrim], axis: usize) -> (usize, Extent, Extent) {
    let mid = prims.len() / 2;
    prims.select_nth_unstable_by(mid, |a, b| {
        a.centroid2()[axis].total_cmp(&b.centroid2()[axis])
    });
    (mid, Extent::of(&prims[..mid]), Extent::of(&prims[mid..]))
}

/// Moves the primitives for which `pred` holds to the front; returns
/// their count and the extents of both sides, gathered on the way. Large
/// slices are split in halves partitioned in parallel, and then only the
/// misplaced middle is exchanged: `[L1 R1 | L2 R2]` becomes `[L1 L2 R1 R2]`
/// up to order within each side, by swapping the first `k` of `R1` with
/// the last `k` of `L2`, `k = min(|R1|, |L2|)`.
fn partition(
    prims: &mut [BuildPrim],
    pred: &(impl Fn(&BuildPrim) -> bool + Sync),
) -> (usize, Extent, Extent) {
    if prims.len() > PARALLEL_BINNING {
        let half = prims.len() / 2;
        let (a, b) = prims.split_at_mut(half);
        let ((na, la, ra), (nb, lb, rb)) =
            rayon::join(|| partition(a, pred), || partition(b, pred));
        let k = (half - na).min(nb);
        a[na..na + k].swap_with_slice(&mut b[nb - k..nb]);
        return (na + nb, la.union(lb), ra.union(rb));
    }
    // Hoare's scheme: only misplaced pairs move.
    let (mut left, mut right) = (Extent::EMPTY, Extent::EMPTY);
    let (mut i, mut j) = (0, prims.len());
    loop {
        while i < j && pred(&prims[i]) {
            left = left.add(&prims[i]);
            i += 1;
        }
        while i < j && !pred(&prims[j - 1]) {
            right = right.add(&prims[j - 1]);
            j -= 1;
        }
        if i >= j {
            return (i, left, right);
        }
        prims.swap(i, j - 1);
        left = left.add(&prims[i]);
        right = right.add(&prims[j - 1]);
        i += 1;
        j -= 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;
    use crate::sampling::square_to_uniform_sphere;
    use glam::Vec3;

    /// Up to eight shapes tested alone (a room's walls, its light and two
    /// boxes) get one node with a leaf each; nine, or one packed
    /// triangle among them, go to the SAH, which pairs the walls.
    #[test]
    fn eight_lone_shapes_are_one_node_of_single_leaves() {
        let wall = |axis: usize, side: f32| {
            let mut min = Vec3::splat(-1.0);
            let mut max = Vec3::splat(1.0);
            min[axis] = side;
            max[axis] = side;
            Bounds3 { min, max }
        };
        let mut room: Vec<Bounds3> = (0..3).flat_map(|a| [wall(a, -1.0), wall(a, 1.0)]).collect();
        room.push(Bounds3 {
            min: Vec3::new(-0.5, -1.0, -0.5),
            max: Vec3::new(0.0, 0.2, 0.0),
        });
        room.push(Bounds3 {
            min: Vec3::new(0.1, -1.0, 0.1),
            max: Vec3::new(0.6, -0.4, 0.6),
        });
        let stats = Bvh::build(&room).stats();
        assert_eq!((stats.nodes, stats.leaves, stats.leaf_prims), (1, 8, 8));
        let with_triangle = Bvh::build_with_costs(&room, |i| {
            if i == 7 {
                PrimCost::Packed
            } else {
                PrimCost::Alone(1.0)
            }
        });
        assert!(with_triangle.stats().leaves < 8);
        room.push(wall(0, 0.0));
        assert!(Bvh::build(&room).stats().leaves < 9);
    }

    /// The AVX2 node test on this CPU, or `None` where it has no AVX2:
    /// (entry distances' bits, mask) per (ray, node) pair. Compiled for
    /// the targets of single-ray traversal (`scene.rs`), so that the test
    /// runs in the code this CPU's traversal runs.
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

    /// Random spheres as primitives (simple exact intersection).
    fn sphere_bounds(spheres: &[(Vec3, f32)]) -> Vec<Bounds3> {
        spheres
            .iter()
            .map(|&(c, r)| Bounds3 {
                min: c - Vec3::splat(r),
                max: c + Vec3::splat(r),
            })
            .collect()
    }

    fn spheres(n: usize, rng: &mut Pcg32) -> Vec<(Vec3, f32)> {
        (0..n)
            .map(|_| {
                (
                    Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 10.0,
                    0.05 + 0.3 * rng.next_f32(),
                )
            })
            .collect()
    }

    fn hit_sphere(s: (Vec3, f32), ray: &Ray) -> Option<f32> {
        let oc = ray.o - s.0;
        let b = oc.dot(ray.d);
        let c = oc.length_squared() - s.1 * s.1;
        let disc = b * b - c;
        if disc < 0.0 {
            return None;
        }
        let t = -b - disc.sqrt();
        (t > ray.t_min && t < ray.t_max).then_some(t)
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

    /// Partitioning must put every primitive on the side binning counted
    /// it on, or the SAH's bin counts would not describe the children.
    #[test]
    fn partition_side_matches_binning() {
        // Binning `cs` as a node of `n` primitives would.
        fn check(cs: &[Vec3A], n: usize) {
            let bounds = cs.iter().fold(Box3A::EMPTY, |b, &c| b.union_point(c));
            let binning = Binning::new(&bounds, n);
            for &c in cs {
                let bins = binning.bins(c);
                for (axis, &bin) in bins.iter().enumerate() {
                    assert!(bin < binning.count);
                    for split in 1..binning.count {
                        assert_eq!(
                            binning.below(c, axis, split),
                            bin < split,
                            "{c} {axis} {split}"
                        );
                    }
                }
            }
        }
        let mut rng = Pcg32::new(3, 1);
        for n in [2, 9, 60, 400, 5000] {
            // Half the sets on the integer lattice 0..=bins, where the
            // scale is 1 and every centroid falls exactly on a bin edge.
            let count = (4 + n / 20).min(BINS);
            let lattice = |rng: &mut Pcg32| (rng.next_f32() * (count + 1) as f32).floor();
            for on_lattice in [false, true] {
                let mut cs: Vec<Vec3A> = (0..n)
                    .map(|_| {
                        if on_lattice {
                            Vec3A::new(lattice(&mut rng), lattice(&mut rng), lattice(&mut rng))
                        } else {
                            Vec3A::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 8.0
                        }
                    })
                    .collect();
                if on_lattice {
                    cs.extend([Vec3A::ZERO, Vec3A::splat(count as f32)]);
                }
                check(&cs, n);
            }
        }
    }

    #[test]
    fn stats_describe_the_tree() {
        let mut rng = Pcg32::new(5, 2);
        let bounds = sphere_bounds(&spheres(3000, &mut rng));
        let st = Bvh::build(&bounds).stats();
        assert_eq!(st.leaf_prims, 3000);
        assert_eq!(st.children_histogram.iter().sum::<usize>(), st.nodes);
        // The root counts once; every further node's box lies inside it.
        assert!(st.node_sah >= 1.0 && st.node_sah < st.nodes as f64);
        assert!(st.leaf_sah > 0.0 && st.leaf_sah < st.leaves as f64);
        assert!(st.leaf_depth >= 1.0 && st.leaf_depth <= st.depth as f64);
        // 3000 spheres in leaves of at most 4 under 8-wide nodes need at
        // least four levels.
        assert!(st.depth >= 4, "{st:?}");
    }

    /// After the order is taken, callbacks see leaf positions, and the
    /// order maps them back to the primitives.
    #[test]
    fn leaf_order_renumbers_the_primitives() {
        let mut rng = Pcg32::new(9, 3);
        let prims = spheres(500, &mut rng);
        let bounds = sphere_bounds(&prims);
        let mut bvh = Bvh::build(&bounds);
        // From a corner, aimed at random points of the spheres' box.
        let rays: Vec<Ray> = (0..300)
            .map(|_| {
                let target = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 10.0;
                Ray::new(Vec3::splat(-1.0), (target + 1.0).normalize())
            })
            .collect();
        // The closest sphere of each ray, through `to_prim` from what the
        // callback is given.
        let closest = |bvh: &Bvh, ray: &Ray, to_prim: &dyn Fn(u32) -> u32| {
            let mut ray = *ray;
            let mut found = None;
            bvh.closest(&mut ray, |i, r| {
                let t = hit_sphere(prims[to_prim(i) as usize], r)?;
                found = Some(to_prim(i));
                Some(t)
            });
            found
        };
        let before: Vec<Option<u32>> = rays.iter().map(|r| closest(&bvh, r, &|i| i)).collect();
        assert!(before.iter().flatten().count() > 50);
        let order = bvh.take_leaf_order();
        assert_eq!(order.len(), 500);
        let after: Vec<Option<u32>> = rays
            .iter()
            .map(|r| closest(&bvh, r, &|pos| order[pos as usize]))
            .collect();
        assert_eq!(before, after);
        assert_eq!(bvh.memory_bytes(), bvh.nodes.resident_bytes());
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
