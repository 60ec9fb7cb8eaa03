//! A binary bounding volume hierarchy built with binned SAH
//! (Wald 2007, "On fast Construction of SAH-based Bounding Volume
//! Hierarchies"; pbrt-v4 §7.3), subtrees built in parallel with rayon,
//! flattened depth-first so that the left child follows its parent.

use crate::math::{Bounds3, Ray};
use glam::Vec3;

const BINS: usize = 16;
const MAX_LEAF: usize = 4;
/// Cost of a ray–primitive test relative to a ray–box test.
const INTERSECT_COST: f32 = 1.0;
const TRAVERSAL_COST: f32 = 1.0;
const PARALLEL_THRESHOLD: usize = 4096;
const STACK: usize = 128;
/// Below this depth, splits are forced to the median so that no tree is
/// deeper than the traversal stack (SAH can make long chains of lopsided
/// splits on adversarial input).
const MAX_SAH_DEPTH: usize = 80;

#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: Bounds3,
    /// Leaves: first index into `prims`. Inner nodes: index of the second
    /// child (the first child is the next node).
    offset: u32,
    /// Leaves: primitive count (> 0). Inner nodes: 0.
    count: u16,
    /// Inner nodes: the split axis, for front-to-back traversal.
    axis: u16,
}

/// A BVH over primitives identified by their index in the bounds slice
/// given to [`Bvh::build`].
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    nodes: Vec<Node>,
    prims: Vec<u32>,
}

#[derive(Clone, Copy)]
struct BuildPrim {
    bounds: Bounds3,
    centroid: Vec3,
    index: u32,
}

enum BuildNode {
    Leaf {
        bounds: Bounds3,
        start: usize,
        count: usize,
    },
    Inner {
        bounds: Bounds3,
        axis: usize,
        children: Box<[BuildNode; 2]>,
    },
}

impl Bvh {
    /// Builds over the given primitive bounds. Empty bounds (degenerate or
    /// absent primitives) are left out.
    pub fn build(bounds: &[Bounds3]) -> Self {
        let mut prims: Vec<BuildPrim> = bounds
            .iter()
            .enumerate()
            .filter(|(_, b)| !b.is_empty() && b.min.is_finite() && b.max.is_finite())
            .map(|(i, b)| BuildPrim {
                bounds: *b,
                centroid: b.center(),
                index: i as u32,
            })
            .collect();
        if prims.is_empty() {
            return Self::default();
        }
        let root = build_recursive(&mut prims, 0, 0);
        let mut bvh = Self {
            nodes: Vec::with_capacity(2 * prims.len() / MAX_LEAF + 1),
            prims: prims.iter().map(|p| p.index).collect(),
        };
        bvh.flatten(&root);
        bvh
    }

    /// Bounds of everything (empty for an empty BVH).
    pub fn bounds(&self) -> Bounds3 {
        self.nodes.first().map_or(Bounds3::EMPTY, |n| n.bounds)
    }

    fn flatten(&mut self, node: &BuildNode) -> usize {
        let index = self.nodes.len();
        match node {
            BuildNode::Leaf {
                bounds,
                start,
                count,
            } => {
                self.nodes.push(Node {
                    bounds: *bounds,
                    offset: *start as u32,
                    count: *count as u16,
                    axis: 0,
                });
            }
            BuildNode::Inner {
                bounds,
                axis,
                children,
            } => {
                self.nodes.push(Node {
                    bounds: *bounds,
                    offset: 0,
                    count: 0,
                    axis: *axis as u16,
                });
                self.flatten(&children[0]);
                let second = self.flatten(&children[1]);
                self.nodes[index].offset = second as u32;
            }
        }
        index
    }

    /// Finds the closest hit. `hit` tests primitive `i` against the ray
    /// (whose `t_max` shrinks as hits are found) and returns the distance
    /// of a hit closer than `t_max`; the caller records whatever else it
    /// needs. Returns whether anything was hit; `ray.t_max` is then the
    /// closest distance.
    #[inline]
    pub fn closest(&self, ray: &mut Ray, mut hit: impl FnMut(u32, &Ray) -> Option<f32>) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let inv_d = ray.d.recip();
        let dir_neg = [inv_d.x < 0.0, inv_d.y < 0.0, inv_d.z < 0.0];
        let mut stack = [0u32; STACK];
        let mut sp = 0;
        let mut current = 0usize;
        let mut found = false;
        loop {
            let node = &self.nodes[current];
            if node.bounds.hit(ray.o, inv_d, ray.t_max).is_some() {
                if node.count > 0 {
                    let start = node.offset as usize;
                    for &p in &self.prims[start..start + node.count as usize] {
                        if let Some(t) = hit(p, ray) {
                            ray.t_max = t;
                            found = true;
                        }
                    }
                } else {
                    // Visit the child on the ray's near side first.
                    let (near, far) = if dir_neg[node.axis as usize] {
                        (node.offset as usize, current + 1)
                    } else {
                        (current + 1, node.offset as usize)
                    };
                    if sp < STACK {
                        stack[sp] = far as u32;
                        sp += 1;
                    }
                    current = near;
                    continue;
                }
            }
            if sp == 0 {
                break;
            }
            sp -= 1;
            current = stack[sp] as usize;
        }
        found
    }

    /// True when any primitive blocks the ray in its interval. `hit` tests
    /// primitive `i`; it is also where a per-primitive filter (alpha
    /// masks, null boundaries) goes: return false to let the ray pass.
    #[inline]
    pub fn any(&self, ray: &Ray, mut hit: impl FnMut(u32, &Ray) -> bool) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let inv_d = ray.d.recip();
        let mut stack = [0u32; STACK];
        let mut sp = 0;
        let mut current = 0usize;
        loop {
            let node = &self.nodes[current];
            if node.bounds.hit(ray.o, inv_d, ray.t_max).is_some() {
                if node.count > 0 {
                    let start = node.offset as usize;
                    if self.prims[start..start + node.count as usize]
                        .iter()
                        .any(|&p| hit(p, ray))
                    {
                        return true;
                    }
                } else {
                    if sp < STACK {
                        stack[sp] = node.offset;
                        sp += 1;
                    }
                    current += 1;
                    continue;
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            current = stack[sp] as usize;
        }
    }
}

fn build_recursive(prims: &mut [BuildPrim], start: usize, depth: usize) -> BuildNode {
    let bounds = prims.iter().fold(Bounds3::EMPTY, |b, p| b.union(p.bounds));
    let leaf = BuildNode::Leaf {
        bounds,
        start,
        count: prims.len(),
    };
    if prims.len() <= 1 {
        return leaf;
    }
    let centroids = prims
        .iter()
        .fold(Bounds3::EMPTY, |b, p| b.union_point(p.centroid));
    let split = if depth < MAX_SAH_DEPTH {
        choose_split(prims, &bounds, &centroids)
    } else {
        split_in_middle(prims, centroids.max_axis())
    };
    let Some((axis, mid)) = split else {
        return leaf;
    };
    let (left, right) = prims.split_at_mut(mid);
    let children = if left.len() + right.len() > PARALLEL_THRESHOLD {
        rayon::join(
            || build_recursive(left, start, depth + 1),
            || build_recursive(right, start + mid, depth + 1),
        )
    } else {
        (
            build_recursive(left, start, depth + 1),
            build_recursive(right, start + mid, depth + 1),
        )
    };
    BuildNode::Inner {
        bounds,
        axis,
        children: Box::new([children.0, children.1]),
    }
}

/// Picks the SAH-best binned split over the widest centroid axis and
/// partitions `prims` around it; `None` means "make a leaf".
fn choose_split(
    prims: &mut [BuildPrim],
    bounds: &Bounds3,
    centroids: &Bounds3,
) -> Option<(usize, usize)> {
    let axis = centroids.max_axis();
    let (lo, hi) = (centroids.min[axis], centroids.max[axis]);
    if hi <= lo {
        return split_in_middle(prims, axis);
    }
    let scale = BINS as f32 / (hi - lo);
    let bin_of = |c: f32| (((c - lo) * scale) as usize).min(BINS - 1);
    let mut bins = [(Bounds3::EMPTY, 0usize); BINS];
    for p in prims.iter() {
        let b = &mut bins[bin_of(p.centroid[axis])];
        b.0 = b.0.union(p.bounds);
        b.1 += 1;
    }
    // Sweep from the right to get suffix areas and counts, then from the left.
    let mut right_area = [0.0f32; BINS];
    let (mut acc, mut acc_n) = (Bounds3::EMPTY, 0);
    let mut right_count = [0usize; BINS];
    for i in (1..BINS).rev() {
        acc = acc.union(bins[i].0);
        acc_n += bins[i].1;
        right_area[i] = acc.surface_area();
        right_count[i] = acc_n;
    }
    let (mut best_cost, mut best_split) = (f32::INFINITY, 0);
    let (mut left, mut left_n) = (Bounds3::EMPTY, 0);
    for i in 0..BINS - 1 {
        left = left.union(bins[i].0);
        left_n += bins[i].1;
        let cost =
            left_n as f32 * left.surface_area() + right_count[i + 1] as f32 * right_area[i + 1];
        if cost < best_cost {
            best_cost = cost;
            best_split = i + 1;
        }
    }
    let parent_area = bounds.surface_area().max(f32::MIN_POSITIVE);
    let split_cost = TRAVERSAL_COST + INTERSECT_COST * best_cost / parent_area;
    let leaf_cost = INTERSECT_COST * prims.len() as f32;
    if prims.len() <= MAX_LEAF && split_cost >= leaf_cost {
        return None;
    }
    let mid = partition(prims, |p| bin_of(p.centroid[axis]) < best_split);
    if mid == 0 || mid == prims.len() {
        return split_in_middle(prims, axis);
    }
    Some((axis, mid))
}

fn split_in_middle(prims: &mut [BuildPrim], axis: usize) -> Option<(usize, usize)> {
    if prims.len() <= MAX_LEAF {
        return None;
    }
    let mid = prims.len() / 2;
    prims.select_nth_unstable_by(mid, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
    Some((axis, mid))
}

fn partition(prims: &mut [BuildPrim], pred: impl Fn(&BuildPrim) -> bool) -> usize {
    let mut first = 0;
    for i in 0..prims.len() {
        if pred(&prims[i]) {
            prims.swap(first, i);
            first += 1;
        }
    }
    first
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;
    use crate::sampling::square_to_uniform_sphere;

    /// Random spheres as primitives (simple exact intersection).
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
            let bounds: Vec<Bounds3> = prims
                .iter()
                .map(|&(c, r)| Bounds3 {
                    min: c - Vec3::splat(r),
                    max: c + Vec3::splat(r),
                })
                .collect();
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
    fn empty_bvh_hits_nothing() {
        let bvh = Bvh::build(&[]);
        let mut ray = Ray::new(Vec3::ZERO, Vec3::X);
        assert!(!bvh.closest(&mut ray, |_, _| Some(1.0)));
        assert!(!bvh.any(&ray, |_, _| true));
    }
}
