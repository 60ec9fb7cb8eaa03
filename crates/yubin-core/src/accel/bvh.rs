//! An 8-wide bounding volume hierarchy: the node layout, the [`Bvh`]
//! struct and what it says of itself (bounds, statistics, memory).
//!
//! A node stores its eight children's boxes in structure-of-arrays form,
//! so that one ray meets all eight with a handful of SIMD instructions,
//! and each child's code (a node index, a leaf's span of positions, or
//! empty) in one `u32`. The tree is built in `build.rs` and traversed in
//! `traverse.rs`.

use super::HugeArray;
use crate::math::Bounds3;
use bytemuck::{Pod, Zeroable};
use wide::f32x8;

/// Children per node.
pub(super) const WIDTH: usize = 8;
/// Primitives per leaf at most: one packet of triangles (see
/// [`Bvh::take_leaf_order_packed`]).
pub const MAX_LEAF: usize = 8;

/// Child slot encoding: `EMPTY`, an inner node index, or a leaf with
/// `LEAF_BIT`, the primitive count − 1 in bits 28–30 and the first
/// position in bits 0–27 (so at most [`MAX_POSITIONS`] positions).
pub(super) const EMPTY: u32 = u32::MAX;
pub(super) const LEAF_BIT: u32 = 1 << 31;
const START_MASK: u32 = (1 << 28) - 1;

/// Leaf positions one BVH can address: at most this many primitives, and
/// a packed leaf order (see [`Bvh::take_leaf_order_packed`]) of at most
/// this many slots.
pub const MAX_POSITIONS: usize = START_MASK as usize + 1;

#[inline]
pub(super) fn leaf_code(start: usize, count: usize) -> u32 {
    LEAF_BIT | (((count - 1) as u32) << 28) | (start as u32 & START_MASK)
}

/// Whether a child code is a leaf (`EMPTY` has the leaf bit too).
#[inline]
pub(super) fn is_leaf(code: u32) -> bool {
    code != EMPTY && code & LEAF_BIT != 0
}

/// First position and primitive count of a leaf's code.
#[inline(always)]
pub(super) fn leaf_span(code: u32) -> (usize, usize) {
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
    pub(super) child: [u32; WIDTH],
    /// The eight children's lower and upper x bounds, then y, then z: one
    /// array, so that a ray picks its near and far planes by index (see
    /// [`RayLanes`](super::RayLanes)) instead of by a per-node choice; pairing an axis's
    /// two planes makes the far index the near one with its low bit
    /// flipped.
    pub(super) planes: [f32x8; 6],
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
    pub(super) fn with_boxes(boxes: impl Iterator<Item = Bounds3>) -> Self {
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
    pub(super) nodes: HugeArray<Node>,
    /// The primitive at each leaf position, until [`Bvh::take_leaf_order`]
    /// hands it over; then empty, and position `i` is primitive `i` (an
    /// identity list would be 4 bytes per primitive for nothing).
    pub(super) prims: Vec<u32>,
    /// Child code of the root: a node index or a leaf.
    pub(super) root: u32,
    pub(super) bounds: Bounds3,
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

impl Bvh {
    /// Bounds of everything (empty for an empty BVH).
    pub fn bounds(&self) -> Bounds3 {
        if self.root == EMPTY {
            Bounds3::EMPTY
        } else {
            self.bounds
        }
    }

    /// The codes of all leaves.
    pub(super) fn leaf_codes(&self) -> impl Iterator<Item = u32> + '_ {
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
}

/// The primitive at leaf position `i` of `prims`, a leaf order that is
/// empty once handed over (position `i` is then primitive `i`).
#[inline]
pub(super) fn prim_at(prims: &[u32], i: usize) -> u32 {
    prims.get(i).copied().unwrap_or(i as u32)
}

/// Spheres as primitives, with their exact intersection: shared by the
/// build and traversal tests.
#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::math::Ray;
    use crate::sampler::Pcg32;
    use glam::Vec3;

    /// Random spheres as primitives (simple exact intersection).
    pub(in crate::accel) fn sphere_bounds(spheres: &[(Vec3, f32)]) -> Vec<Bounds3> {
        spheres
            .iter()
            .map(|&(c, r)| Bounds3 {
                min: c - Vec3::splat(r),
                max: c + Vec3::splat(r),
            })
            .collect()
    }

    pub(in crate::accel) fn spheres(n: usize, rng: &mut Pcg32) -> Vec<(Vec3, f32)> {
        (0..n)
            .map(|_| {
                (
                    Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 10.0,
                    0.05 + 0.3 * rng.next_f32(),
                )
            })
            .collect()
    }

    pub(in crate::accel) fn hit_sphere(s: (Vec3, f32), ray: &Ray) -> Option<f32> {
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
}
