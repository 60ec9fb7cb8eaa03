//! Closest hits of eight rays at once ([`Scene::closest_packet`]).
//!
//! In a small scene (a room of a few walls, spheres and boxes) a ray
//! meets most of the few boxes of the BVH whatever its direction, and a
//! single ray pays the whole traversal and every shape test alone. Eight
//! rays traversing together share each box test (eight lanes, one child
//! box) and each sphere or rectangle test (one shape, eight lanes), the
//! way packet tracers trace coherent rays (Wald et al. 2001, "Interactive
//! Rendering with Coherent Ray Tracing"); here it pays even for
//! incoherent ones because the tree is small. Large trees, where the
//! rays' paths part, are traversed ray by ray.
//!
//! A lane's hit is the one [`Scene::closest`] finds for its ray: the box
//! tests are conservative, and spheres and rectangles are tested with the
//! single-ray arithmetic lane by lane, bit for bit; other shapes,
//! triangles and instances are tested ray by ray.

use super::traversal::{to_local_ray, Group, Item};
use super::{HitRecord, Scene, WholeHit};
use crate::accel::{Node, PacketLanes, PACKET_RAYS};
use crate::math::{Ray, RayPacket};
use crate::shape::{PrimHit, Shape, ShapeModel, TrianglePackets, WatertightRay};
use glam::Vec2;
use multiversion::{inherit_target, multiversion, target::target_cfg};
use wide::f32x8;

/// The lanes set in `mask`, lowest first.
fn lanes_of(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let lane = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            lane
        })
    })
}

/// The closest hits found so far, per lane.
struct PacketHits<'r> {
    rays: &'r [Ray; PACKET_RAYS],
    /// Per lane, the distance to its closest hit so far (its ray's end
    /// before one). Kept in a register and updated by blends: written
    /// lane by lane to memory and read back whole for the next box or
    /// shape test, it could not be forwarded, and every leaf ended in a
    /// stall.
    t_max: f32x8,
    best: &'r mut [Option<HitRecord>; PACKET_RAYS],
}

/// `new` in the lanes set in `mask`, `old` in the others (the portable
/// blend; see [`blend_lanes_avx2`]).
#[inline(always)]
fn blend_lanes(mask: u32, new: f32x8, old: f32x8) -> f32x8 {
    use wide::{i32x8, CmpEq};
    let bits = i32x8::new([1, 2, 4, 8, 16, 32, 64, 128]);
    let set = (bits & i32x8::splat(mask as i32)).cmp_eq(bits);
    bytemuck::cast::<_, f32x8>(set).blend(new, old)
}

/// [`blend_lanes`] in one AVX register: in traversal compiled for AVX2,
/// whose box tests read `t_max` whole, a value blended in two SSE halves
/// was spilled in halves and reloaded whole, which the CPU cannot
/// forward. In a build for AVX2, the portable blend itself.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
#[inline(always)]
pub(crate) fn blend_lanes_avx2(mask: u32, new: f32x8, old: f32x8) -> f32x8 {
    blend_lanes(mask, new, old)
}

/// [`blend_lanes`] in one AVX register (see the AVX2 build's version).
#[cfg(all(target_arch = "x86_64", not(target_feature = "avx2")))]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn blend_lanes_avx2(mask: u32, new: f32x8, old: f32x8) -> f32x8 {
    use std::arch::x86_64::{
        __m256, _mm256_and_si256, _mm256_blendv_ps, _mm256_castsi256_ps, _mm256_cmpeq_epi32,
        _mm256_set1_epi32, _mm256_setr_epi32,
    };
    let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    let set = _mm256_cmpeq_epi32(_mm256_and_si256(bits, _mm256_set1_epi32(mask as i32)), bits);
    let (new, old): (__m256, __m256) = (bytemuck::cast(new), bytemuck::cast(old));
    bytemuck::cast(_mm256_blendv_ps(old, new, _mm256_castsi256_ps(set)))
}

impl PacketHits<'_> {
    /// Records `rec` as the closest hit of `lane` so far, its distance
    /// blended into `t_max` by `blend`.
    #[inline(always)]
    fn record(&mut self, lane: usize, rec: HitRecord, blend: impl Fn(u32, f32x8, f32x8) -> f32x8) {
        self.t_max = blend(1 << lane, f32x8::splat(rec.hit.t), self.t_max);
        self.best[lane] = Some(rec);
    }

    /// Records `hit` on primitive `prim` of shape `shape` (not through an
    /// instance) as the closest hit of `lane` so far, its distance left
    /// to the caller.
    #[inline(always)]
    fn record_prim(&mut self, lane: usize, shape: u32, prim: u32, hit: PrimHit) {
        let instance = None;
        self.best[lane] = Some(HitRecord {
            shape,
            prim,
            hit: WholeHit(hit),
            instance,
        });
    }

    /// Lane `lane`'s closest hit so far.
    #[inline(always)]
    fn t_max_of(&self, lane: usize) -> f32 {
        self.t_max.as_array_ref()[lane]
    }

    /// Lane `lane`'s ray, cut at its closest hit so far.
    fn ray(&self, lane: usize) -> Ray {
        Ray {
            t_max: self.t_max_of(lane),
            ..self.rays[lane]
        }
    }
}

/// The closest hits of a packet in a small tree ([`Scene::closest_packet`]),
/// compiled twice, for baseline x86-64 and for AVX2 with FMA, and chosen
/// by the CPU at run time, as single-ray traversal is (`traversal.rs`): with
/// AVX2 the box, triangle and shape tests take one instruction per step
/// instead of two, and give the same hits bit for bit.
// A build for AVX2 calls that version directly, leaving the dispatcher's
// copy unused.
#[allow(dead_code)]
#[multiversion(targets("x86_64+avx2+fma"))]
fn small_tree_packet(
    scene: &Scene,
    rays: &[Ray; PACKET_RAYS],
    active: u32,
    out: &mut [Option<HitRecord>; PACKET_RAYS],
) {
    #[target_cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    #[inherit_target]
    #[inline]
    fn traverse(
        scene: &Scene,
        rays: &[Ray; PACKET_RAYS],
        active: u32,
        out: &mut [Option<HitRecord>; PACKET_RAYS],
    ) {
        let kernels = PacketKernels {
            boxes: |l: &PacketLanes, n: &Node, c, t| crate::accel::hit_child_avx2(l, n, c, t),
            triangles: |r: &WatertightRay, p: &TrianglePackets, s, c, t| {
                r.intersect_packet_by(p, s, c, t, |r, v, t| crate::shape::lane_tests_avx2(r, v, t))
            },
            shapes: |s: &Shape, p: &RayPacket, t| crate::shape::shape_packet_avx2(s, p, t),
            blend: |m, new, old| blend_lanes_avx2(m, new, old),
        };
        scene.small_tree_packet_by(rays, active, &kernels, out)
    }
    #[target_cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
    #[inline(always)]
    fn traverse(
        scene: &Scene,
        rays: &[Ray; PACKET_RAYS],
        active: u32,
        out: &mut [Option<HitRecord>; PACKET_RAYS],
    ) {
        let kernels = PacketKernels {
            boxes: PacketLanes::hit_child,
            triangles: WatertightRay::intersect_packet,
            shapes: Shape::intersect_packet,
            blend: blend_lanes,
        };
        scene.small_tree_packet_by(rays, active, &kernels, out)
    }
    traverse(scene, rays, active, out)
}

/// Which rays of a packet something blocks, in a small tree
/// ([`Scene::occluded_packet`]), compiled as [`small_tree_packet`] is.
#[allow(dead_code)]
#[multiversion(targets("x86_64+avx2+fma"))]
fn small_tree_occluded(scene: &Scene, rays: &[Ray; PACKET_RAYS], active: u32) -> u32 {
    #[target_cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    #[inherit_target]
    #[inline]
    fn traverse(scene: &Scene, rays: &[Ray; PACKET_RAYS], active: u32) -> u32 {
        let kernels = PacketKernels {
            boxes: |l: &PacketLanes, n: &Node, c, t| crate::accel::hit_child_avx2(l, n, c, t),
            triangles: |r: &WatertightRay, p: &TrianglePackets, s, c, t| {
                r.intersect_packet_by(p, s, c, t, |r, v, t| crate::shape::lane_tests_avx2(r, v, t))
            },
            shapes: |s: &Shape, p: &RayPacket, t| crate::shape::shape_blocks_avx2(s, p, t),
            blend: (),
        };
        scene.small_tree_occluded_by(rays, active, &kernels)
    }
    #[target_cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
    #[inline(always)]
    fn traverse(scene: &Scene, rays: &[Ray; PACKET_RAYS], active: u32) -> u32 {
        let kernels = PacketKernels {
            boxes: PacketLanes::hit_child,
            triangles: WatertightRay::intersect_packet,
            shapes: |s: &Shape, p: &RayPacket, t| s.intersect_packet(p, t).map(|(hit, _, _)| hit),
            blend: (),
        };
        scene.small_tree_occluded_by(rays, active, &kernels)
    }
    traverse(scene, rays, active)
}

/// The tests packet traversal runs: a child box against the packet's
/// lanes, a leaf's triangles against one lane's ray, and a shape against
/// the packet (`None` for shapes without an eight-lane test).
struct PacketKernels<B, T, S, L> {
    boxes: B,
    triangles: T,
    shapes: S,
    /// [`blend_lanes`] or [`blend_lanes_avx2`] for closest hits; any-hit
    /// traversal needs none (`()`): its emptied intervals are built
    /// directly, which is cheaper than blending them in.
    blend: L,
}

impl Scene {
    /// The closest hits of the rays of `rays` whose bit is set in
    /// `active` (the others get `None`), each the hit [`Scene::closest`]
    /// finds for it, written to `out` (in place: the caller reads them
    /// field by field soon after, which a copy's wide stores would
    /// hold up).
    pub fn closest_packet(
        &self,
        rays: &[Ray; PACKET_RAYS],
        active: u32,
        out: &mut [Option<HitRecord>; PACKET_RAYS],
    ) {
        let g = &self.groups[0];
        if !g.bvh.takes_packets() {
            for (l, hit) in out.iter_mut().enumerate() {
                *hit = (active >> l & 1 != 0)
                    .then(|| self.closest(&rays[l]))
                    .flatten();
            }
            return;
        }
        small_tree_packet(self, rays, active, out)
    }

    /// The rays of `rays` whose bit is set in `active` that something
    /// blocks (a bit each): for each the answer [`Scene::occluded`] gives.
    /// In a small tree the eight shadow rays traverse it together, as
    /// [`Scene::closest_packet`]'s rays do, a lane leaving the traversal
    /// once it is blocked.
    pub fn occluded_packet(&self, rays: &[Ray; PACKET_RAYS], active: u32) -> u32 {
        if !self.groups[0].bvh.takes_packets() {
            return lanes_of(active)
                .filter(|&l| self.occluded(&rays[l]))
                .fold(0, |m, l| m | 1 << l);
        }
        small_tree_occluded(self, rays, active)
    }

    /// [`Scene::occluded_packet`] in a small tree, with these tests.
    #[inline(always)]
    fn small_tree_occluded_by<B, T, S, L>(
        &self,
        rays: &[Ray; PACKET_RAYS],
        active: u32,
        kernels: &PacketKernels<B, T, S, L>,
    ) -> u32
    where
        B: Fn(&PacketLanes, &Node, usize, f32x8) -> u32,
        T: Fn(&WatertightRay, &TrianglePackets, usize, usize, f32) -> Option<(usize, PrimHit)>,
        S: Fn(&Shape, &RayPacket, f32x8) -> Option<u32>,
    {
        let g = &self.groups[0];
        let packet = RayPacket::new(rays);
        let lanes = PacketLanes::new(&packet);
        let t_max = rays.map(|r| r.t_max);
        let ray_t_max = f32x8::new(t_max);
        let mut blocked = 0u32;
        let mut sheared: [Option<WatertightRay>; PACKET_RAYS] = [None; PACKET_RAYS];
        g.bvh.packet_leaves(
            &lanes,
            active,
            ray_t_max,
            &kernels.boxes,
            #[inline(always)]
            |start, count, mask| {
                let mut open = mask & !blocked;
                if open != 0 && g.tris.has_triangles(start) {
                    for lane in lanes_of(open) {
                        let r = &rays[lane];
                        let wr = sheared[lane].get_or_insert_with(|| {
                            WatertightRay::from_vectors(&r.vectors(), r.t_min)
                        });
                        if (kernels.triangles)(wr, &g.tris, start, count, t_max[lane]).is_some() {
                            blocked |= 1 << lane;
                        }
                    }
                    open &= !blocked;
                }
                if !g.only_triangles && g.leaf_has_items(start) {
                    for item in &g.items[start..start + count] {
                        if open == 0 {
                            break;
                        }
                        let shapes = &kernels.shapes;
                        blocked |= self.item_blocks_packet(*item, &packet, rays, open, shapes);
                        open &= !blocked;
                    }
                }
                // A blocked lane's interval is emptied: its box tests fail.
                let cut: [f32; PACKET_RAYS] = std::array::from_fn(|l| {
                    if blocked >> l & 1 != 0 {
                        f32::NEG_INFINITY
                    } else {
                        t_max[l]
                    }
                });
                f32x8::new(cut)
            },
        );
        blocked
    }

    /// The lanes `mask` of `packet` (whose rays are `rays`) that `item`
    /// (not a triangle) blocks.
    #[inline(always)]
    fn item_blocks_packet(
        &self,
        item: Item,
        packet: &RayPacket,
        rays: &[Ray; PACKET_RAYS],
        mask: u32,
        shape_test: impl Fn(&Shape, &RayPacket, f32x8) -> Option<u32>,
    ) -> u32 {
        let each = |blocks: &dyn Fn(&Ray) -> bool| {
            lanes_of(mask)
                .filter(|&l| blocks(&rays[l]))
                .fold(0, |m, l| m | 1 << l)
        };
        match item {
            Item::Triangle { .. } | Item::Empty => 0,
            Item::Prim { shape, prim } => {
                let shape_ref = &self.shapes[shape as usize];
                match shape_test(shape_ref, packet, f32x8::new(rays.map(|r| r.t_max))) {
                    Some(hit) => hit & mask,
                    None => each(&|r| shape_ref.intersect(&self.meshes, prim, r).is_some()),
                }
            }
            Item::Instance(inst) => each(&|r| self.instance_occludes(inst, r)),
        }
    }

    /// [`Scene::closest_packet`] in a small tree, with these tests.
    #[inline(always)]
    fn small_tree_packet_by<B, T, S, L>(
        &self,
        rays: &[Ray; PACKET_RAYS],
        active: u32,
        kernels: &PacketKernels<B, T, S, L>,
        out: &mut [Option<HitRecord>; PACKET_RAYS],
    ) where
        B: Fn(&PacketLanes, &Node, usize, f32x8) -> u32,
        T: Fn(&WatertightRay, &TrianglePackets, usize, usize, f32) -> Option<(usize, PrimHit)>,
        S: Fn(&Shape, &RayPacket, f32x8) -> Option<(u32, f32x8, [f32x8; 2])>,
        L: Fn(u32, f32x8, f32x8) -> f32x8,
    {
        let g = &self.groups[0];
        let packet = RayPacket::new(rays);
        let lanes = PacketLanes::new(&packet);
        let t_max = f32x8::new(rays.map(|r| r.t_max));
        let mut hits = PacketHits {
            rays,
            t_max,
            best: out,
        };
        hits.best.fill(None);
        // Per lane, its ray prepared for triangle tests, when it meets one.
        let mut sheared: [Option<WatertightRay>; PACKET_RAYS] = [None; PACKET_RAYS];
        g.bvh.packet_leaves(
            &lanes,
            active,
            t_max,
            &kernels.boxes,
            |start, count, mask| {
                if g.tris.has_triangles(start) {
                    for lane in lanes_of(mask) {
                        let r = &rays[lane];
                        let wr = sheared[lane].get_or_insert_with(|| {
                            WatertightRay::from_vectors(&r.vectors(), r.t_min)
                        });
                        let t_max = hits.t_max_of(lane);
                        if let Some((i, hit)) =
                            (kernels.triangles)(wr, &g.tris, start, count, t_max)
                        {
                            let (shape, prim) = g.triangle(g.tris.id(start + i));
                            hits.record_prim(lane, shape, prim, hit);
                            let t = f32x8::splat(hit.t);
                            hits.t_max = (kernels.blend)(1 << lane, t, hits.t_max);
                        }
                    }
                }
                if !g.only_triangles && g.leaf_has_items(start) {
                    for item in &g.items[start..start + count] {
                        let (shapes, blend) = (&kernels.shapes, &kernels.blend);
                        self.item_packet(*item, &packet, mask, &mut hits, shapes, blend);
                    }
                }
                hits.t_max
            },
        );
    }

    /// Tests `item` (not a triangle) against the lanes `mask` of `packet`.
    #[inline(always)]
    fn item_packet(
        &self,
        item: Item,
        packet: &RayPacket,
        mask: u32,
        hits: &mut PacketHits,
        shape_test: impl Fn(&Shape, &RayPacket, f32x8) -> Option<(u32, f32x8, [f32x8; 2])>,
        blend: impl Fn(u32, f32x8, f32x8) -> f32x8,
    ) {
        match item {
            Item::Triangle { .. } | Item::Empty => {}
            Item::Prim { shape, prim } => {
                let shape_ref = &self.shapes[shape as usize];
                match shape_test(shape_ref, packet, hits.t_max) {
                    Some((hit, t_hit, [u, v])) => {
                        let (t, u, v) = (t_hit.to_array(), u.to_array(), v.to_array());
                        let hit = hit & mask;
                        for lane in lanes_of(hit) {
                            let uv = Vec2::new(u[lane], v[lane]);
                            hits.record_prim(lane, shape, prim, PrimHit { t: t[lane], uv });
                        }
                        hits.t_max = blend(hit, t_hit, hits.t_max);
                    }
                    None => {
                        for lane in lanes_of(mask) {
                            let ray = hits.ray(lane);
                            if let Some(hit) = shape_ref.intersect(&self.meshes, prim, &ray) {
                                hits.record_prim(lane, shape, prim, hit);
                                hits.t_max = blend(1 << lane, f32x8::splat(hit.t), hits.t_max);
                            }
                        }
                    }
                }
            }
            Item::Instance(inst) => {
                let placed = &self.instances[inst as usize];
                let group: &Group = &self.groups[placed.group as usize];
                for lane in lanes_of(mask) {
                    let local = to_local_ray(&hits.ray(lane), &placed.to_world);
                    if let Some(h) = self.closest_in_group(group, &local, Some(inst)) {
                        hits.record(lane, h, &blend);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;
    use crate::scene::traversal::tests::{mixed_scene, random_ray};

    /// Rays with intervals that start late or end early, now and then.
    fn random_rays(rng: &mut Pcg32) -> [Ray; PACKET_RAYS] {
        std::array::from_fn(|_| {
            let mut r = random_ray(rng);
            if rng.next_f32() < 0.25 {
                r.t_min = 4.0 * rng.next_f32();
            }
            if rng.next_f32() < 0.25 {
                r.t_max = 8.0 * rng.next_f32();
            }
            r
        })
    }

    /// The eight-lane sphere, rectangle and disk tests give the single-ray
    /// tests' hits bit for bit, BVH aside (its boxes would hide a test
    /// that hits beyond a shape's bounds).
    #[test]
    fn packet_shape_tests_equal_single_ray_tests() {
        let scene = mixed_scene();
        let mut rng = Pcg32::new(5, 0);
        let mut tested = 0;
        let mut kinds = std::collections::HashSet::new();
        for shape in &scene.shapes {
            for _ in 0..4000 {
                let rays = random_rays(&mut rng);
                let packet = RayPacket::new(&rays);
                let t_max = f32x8::new(rays.map(|r| r.t_max));
                let Some((hit, t, [u, v])) = shape.intersect_packet(&packet, t_max) else {
                    continue;
                };
                let (t, u, v) = (t.to_array(), u.to_array(), v.to_array());
                let lanes: [Option<PrimHit>; PACKET_RAYS] = std::array::from_fn(|l| {
                    let uv = Vec2::new(u[l], v[l]);
                    (hit >> l & 1 != 0).then_some(PrimHit { t: t[l], uv })
                });
                kinds.insert(std::mem::discriminant(shape));
                for (ray, got) in rays.iter().zip(lanes) {
                    let key = |h: Option<PrimHit>| {
                        h.map(|h| (h.t.to_bits(), h.uv.to_array().map(f32::to_bits)))
                    };
                    let expected = shape.intersect(&scene.meshes, 0, ray);
                    assert_eq!(key(got), key(expected), "{shape:?} {ray:?}");
                    tested += usize::from(expected.is_some());
                }
            }
        }
        assert!(tested > 2000, "{tested} hits");
        // Spheres, rectangles, disks and cubes.
        assert_eq!(kinds.len(), 4);
    }

    /// A shape's packet test as bits: the mask, then per lane the
    /// distance and uv of the lanes it hits.
    type ShapeAnswer = Option<(u32, [[u32; 3]; PACKET_RAYS])>;

    fn shape_answer(found: Option<(u32, f32x8, [f32x8; 2])>) -> ShapeAnswer {
        found.map(|(hit, t, [u, v])| {
            let (t, u, v) = (t.to_array(), u.to_array(), v.to_array());
            let lane = |l: usize| {
                let on = hit >> l & 1 != 0;
                [t[l], u[l], v[l]].map(|x| if on { x.to_bits() } else { 0 })
            };
            (hit, std::array::from_fn(lane))
        })
    }

    /// The AVX2 shape tests on this CPU (`None` where it has no AVX2).
    #[multiversion(targets("x86_64+avx2+fma"))]
    fn avx2_shape_tests(cases: &[(Shape, RayPacket, f32x8)]) -> Option<Vec<ShapeAnswer>> {
        #[target_cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        #[inherit_target]
        fn run(cases: &[(Shape, RayPacket, f32x8)]) -> Option<Vec<ShapeAnswer>> {
            let test = |(s, p, t): &(Shape, RayPacket, f32x8)| {
                shape_answer(crate::shape::shape_packet_avx2(s, p, *t))
            };
            Some(cases.iter().map(test).collect())
        }
        #[target_cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
        fn run(_: &[(Shape, RayPacket, f32x8)]) -> Option<Vec<ShapeAnswer>> {
            None
        }
        run(cases)
    }

    /// The AVX2 sphere, rectangle, disk and cube tests give the portable ones'
    /// hits bit for bit (which equal the single-ray tests', above).
    #[test]
    fn avx2_shape_tests_equal_portable_ones() {
        let scene = mixed_scene();
        let mut rng = Pcg32::new(6, 1);
        let mut cases = Vec::new();
        for shape in &scene.shapes {
            for _ in 0..3000 {
                let rays = random_rays(&mut rng);
                let t_max = f32x8::new(rays.map(|r| r.t_max));
                cases.push((*shape, RayPacket::new(&rays), t_max));
            }
        }
        let Some(avx2) = avx2_shape_tests(&cases) else {
            eprintln!("skipped: this CPU has no AVX2");
            return;
        };
        let mut hits = 0;
        for ((shape, packet, t_max), got) in cases.iter().zip(avx2) {
            let want = shape_answer(shape.intersect_packet(packet, *t_max));
            assert_eq!(want, got, "{shape:?}");
            hits += want.map_or(0, |(hit, _)| hit.count_ones());
        }
        assert!(hits > 2000, "{hits} hits");
    }

    /// The AVX2 blend on this CPU, for every mask (`None` where it has no
    /// AVX2).
    #[multiversion(targets("x86_64+avx2+fma"))]
    fn avx2_blends(new: f32x8, old: f32x8) -> Option<Vec<[u32; PACKET_RAYS]>> {
        #[target_cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        #[inherit_target]
        fn run(new: f32x8, old: f32x8) -> Option<Vec<[u32; PACKET_RAYS]>> {
            let blend = |m| blend_lanes_avx2(m, new, old).to_array().map(f32::to_bits);
            Some((0..256).map(blend).collect())
        }
        #[target_cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
        fn run(_: f32x8, _: f32x8) -> Option<Vec<[u32; PACKET_RAYS]>> {
            None
        }
        run(new, old)
    }

    /// Both blends take `new` exactly in the lanes of the mask.
    #[test]
    fn blends_take_the_masks_lanes() {
        let new = f32x8::new([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, f32::NAN]);
        let old = f32x8::new([-1.0, -2.0, -3.0, -4.0, -5.0, -6.0, f32::INFINITY, -0.0]);
        let (n, o) = (new.to_array(), old.to_array());
        let want: Vec<[u32; PACKET_RAYS]> = (0..256u32)
            .map(|m| std::array::from_fn(|l| if m >> l & 1 != 0 { n[l] } else { o[l] }.to_bits()))
            .collect();
        let portable: Vec<[u32; PACKET_RAYS]> = (0..256)
            .map(|m| blend_lanes(m, new, old).to_array().map(f32::to_bits))
            .collect();
        assert_eq!(portable, want);
        match avx2_blends(new, old) {
            Some(avx2) => assert_eq!(avx2, want),
            None => eprintln!("AVX2 blend skipped: this CPU has no AVX2"),
        }
    }

    /// Packet occlusion answers as single rays do, lane by lane, in a
    /// small tree (spheres, rectangles, disks, cubes, triangles and an
    /// instanced group) and through the large-tree fallback.
    #[test]
    fn packets_find_the_single_rays_blockers() {
        let scene = mixed_scene();
        assert!(scene.groups[0].bvh.takes_packets());
        let mut rng = Pcg32::new(4, 0);
        let (mut blocked, mut open) = (0, 0);
        for _ in 0..3000 {
            let rays = random_rays(&mut rng);
            let active = rng.next_u32() & 0xff;
            let got = scene.occluded_packet(&rays, active);
            for (lane, ray) in rays.iter().enumerate() {
                let expected = active >> lane & 1 != 0 && scene.occluded(ray);
                assert_eq!(got >> lane & 1 != 0, expected, "lane {lane} of {rays:?}");
                if active >> lane & 1 != 0 {
                    *if expected { &mut blocked } else { &mut open } += 1;
                }
            }
        }
        assert!(
            blocked > 1000 && open > 1000,
            "{blocked} blocked, {open} open"
        );
    }

    #[test]
    fn packets_find_the_single_rays_hits() {
        let scene = mixed_scene();
        assert!(scene.groups[0].bvh.takes_packets());
        let mut rng = Pcg32::new(3, 0);
        let mut hit_shapes = std::collections::BTreeSet::new();
        for _ in 0..3000 {
            let rays = random_rays(&mut rng);
            let active = rng.next_u32() & 0xff;
            let mut hits = [None; PACKET_RAYS];
            scene.closest_packet(&rays, active, &mut hits);
            for (lane, (ray, hit)) in rays.iter().zip(hits).enumerate() {
                let expected = (active >> lane & 1 != 0)
                    .then(|| scene.closest(ray))
                    .flatten();
                let key = |h: Option<HitRecord>| {
                    h.map(|h| {
                        let uv = h.hit.uv.to_array().map(f32::to_bits);
                        (h.shape, h.prim, h.instance, h.hit.t.to_bits(), uv)
                    })
                };
                assert_eq!(key(hit), key(expected), "lane {lane} of {rays:?}");
                hit_shapes.extend(hit.map(|h| h.shape));
            }
        }
        // Every shape of the world and of the instanced group.
        assert_eq!(hit_shapes.len(), scene.shapes.len(), "{hit_shapes:?}");
    }
}
