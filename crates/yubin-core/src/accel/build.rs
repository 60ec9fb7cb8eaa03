//! Building a [`Bvh`]: top-down with binned SAH (Wald 2007, "On fast
//! Construction of SAH-based Bounding Volume Hierarchies"; pbrt-v4
//! §7.3), subtrees in parallel with rayon; the binary tree is then
//! collapsed into 8-wide nodes (Wald et al. 2008, "Getting Rid of
//! Packets"; Dammertz et al. 2008, "Shallow Bounding Volume
//! Hierarchies"), the binary nodes to open chosen by the dynamic program
//! of Ylitie, Karras and Laine 2017 (`BuildNode::inner`). Then the leaf
//! order, which callers take to lay their primitives out as the leaves
//! list them ([`Bvh::take_leaf_order`], [`Bvh::take_leaf_order_packed`]).

use super::bvh::{is_leaf, leaf_code, leaf_span, prim_at, Node, EMPTY, LEAF_BIT, WIDTH};
use super::{Bvh, HugeArray, MAX_LEAF, MAX_POSITIONS};
use crate::math::Bounds3;
use arrayvec::ArrayVec;
use glam::{Vec3A, Vec4};
use rayon::prelude::*;
use wide::f32x4;

const BINS: usize = 16;
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
/// Below this depth, splits are forced to the median so that no tree is
/// deeper than the traversal stack allows (SAH can make long chains of
/// lopsided splits on adversarial input).
const MAX_SAH_DEPTH: usize = 60;

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
        // first, a second copy of every primitive.
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
    use crate::accel::bvh::tests::{hit_sphere, sphere_bounds, spheres};
    use crate::math::Ray;
    use crate::sampler::Pcg32;
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
}
