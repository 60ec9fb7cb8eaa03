//! Two-level traversal: the groups of a [`Scene`] (each a BVH over
//! items: triangles in packets, analytic shapes, instances of other
//! groups) and the single-ray closest-hit and any-hit queries over them.
//! The kernels are compiled for several instruction sets and chosen at
//! run time (`with_node_test!`); a hit's interaction is computed here
//! too, through the instance's transform.

use super::{HitRecord, Scene, WholeHit};
use crate::accel::{Bvh, Node, RayLanes};
use crate::interaction::SurfaceInteraction;
use crate::math::{Frame, Ray, Transform};
use crate::shape::{PrimHit, Shape, ShapeModel, TrianglePackets, WatertightRay};
use multiversion::{inherit_target, multiversion, target::target_cfg};
use wide::f32x8;

// A leaf is tested as one triangle packet.
const _: () = assert!(crate::accel::MAX_LEAF == crate::shape::PACKET);

/// What a position of a group's BVH leaf order holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Item {
    /// A mesh triangle; its vertices are copied into the group's `tris`
    /// (in BVH leaf order) so the hot loop reads them without indirection.
    Triangle { shape: u32, prim: u32 },
    /// Padding that keeps every BVH leaf in one triangle packet.
    Empty,
    /// A primitive of a shape that is not a mesh, tested on its own.
    Prim { shape: u32, prim: u32 },
    /// An instance of another group (index into `Scene::instances`).
    Instance(u32),
}

/// A group of the two-level hierarchy: group 0 is the world, the others
/// are shape groups that instances place.
#[derive(Clone, Debug, Default)]
pub(super) struct Group {
    /// Items in BVH leaf order; empty when `only_triangles` (the packets
    /// then say everything).
    pub(super) items: Vec<Item>,
    /// Per mesh shape, the first triangle id its triangles take in the
    /// packets and their count: triangle id `first + prim` is `prim` of
    /// `shape`. Sorted by `first`.
    pub(super) tri_runs: Vec<TriangleRun>,
    /// Vertices of `Item::Triangle` items, parallel to `items` (NaN for
    /// other items), packed for [`crate::shape::PACKET`]-wide tests.
    pub(super) tris: TrianglePackets,
    /// No analytic shapes or instances: leaves need only the packet test.
    pub(super) only_triangles: bool,
    /// Per leaf (one packet of `items`), whether it holds an analytic
    /// shape or an instance: the leaves of a mesh beside a floor
    /// rectangle then skip the item loop and its out-of-line call, which
    /// would otherwise be paid at nearly every leaf a ray meets. Empty
    /// when `only_triangles`.
    pub(super) leaf_has_items: Vec<bool>,
    pub(super) bvh: Bvh,
}

/// The triangles of one mesh shape within a group.
#[derive(Clone, Copy, Debug)]
pub(super) struct TriangleRun {
    pub(super) first: u32,
    pub(super) count: u32,
    pub(super) shape: u32,
}

impl Group {
    /// Whether the leaf starting at position `start` holds an analytic
    /// shape or an instance.
    #[inline(always)]
    pub(super) fn leaf_has_items(&self, start: usize) -> bool {
        self.leaf_has_items[start / crate::shape::PACKET]
    }

    /// Shape and primitive of the triangle with packet id `id`.
    pub(super) fn triangle(&self, id: u32) -> (u32, u32) {
        triangle_of_id(&self.tri_runs, id)
    }

    /// Every (shape, primitive) of the group's triangles and analytic
    /// shapes (not its instances).
    #[cfg(test)]
    fn primitives(&self) -> Vec<(u32, u32)> {
        let tris = self
            .tri_runs
            .iter()
            .flat_map(|r| (0..r.count).map(move |p| (r.shape, p)));
        let prims = self.items.iter().filter_map(|item| match *item {
            Item::Prim { shape, prim } => Some((shape, prim)),
            _ => None,
        });
        tris.chain(prims).collect()
    }
}

/// Defines `$name`, which calls `$by` with its arguments, a BVH node test
/// and a triangle packet test, compiled for baseline x86-64, for AVX2
/// with FMA and for AVX-512 (the Ice Lake set `multiversion` asks for),
/// and chosen by the CPU at run time (`multiversion`; Embree does the
/// same). With AVX2 the 8-wide box and triangle tests take one
/// instruction per step instead of two, and `$by`, inlined, is compiled
/// for AVX2 whole; AVX-512's 32 vector registers then hold the ray's
/// twelve slab vectors without spilling them to the stack at every node.
/// All give the same hits bit for bit (see
/// [`crate::accel::hit_children_avx2`]), so images do not depend on the
/// CPU.
macro_rules! with_node_test {
    ($(#[$doc:meta])* fn $name:ident($($arg:ident: $ty:ty),*) -> $ret:ty = $by:path;) => {
        $(#[$doc])*
        // A build for AVX2 calls that version directly, leaving the
        // dispatcher's copy unused.
        #[allow(dead_code)]
        #[multiversion(targets(
            "x86_64+avx512f+avx512vl+avx512bw+avx512dq+avx2+fma",
            "x86_64+avx2+fma"
        ))]
        fn $name($($arg: $ty),*) -> $ret {
            #[target_cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
            #[inherit_target]
            #[inline]
            fn traverse($($arg: $ty),*) -> $ret {
                $by(
                    $($arg,)*
                    |l, n, lo, hi| crate::accel::hit_children_avx2(l, n, lo, hi),
                    |r: &WatertightRay, p, s, c, t| {
                        r.intersect_packet_by(p, s, c, t, |r, v, t| {
                            crate::shape::lane_tests_avx2(r, v, t)
                        })
                    },
                )
            }
            #[target_cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
            #[inline(always)]
            fn traverse($($arg: $ty),*) -> $ret {
                $by($($arg,)* RayLanes::hit_children, WatertightRay::intersect_packet)
            }
            traverse($($arg),*)
        }
    };
}

with_node_test! {
    /// The closest triangle hit in a group of triangles only: packet id
    /// and hit.
    fn closest_triangle(g: &Group, ray: &Ray) -> Option<(u32, PrimHit)> = closest_triangle_by;
}

with_node_test! {
    /// Whether a triangle of a group of triangles only blocks `ray`.
    fn triangle_occludes(g: &Group, ray: &Ray) -> bool = triangle_occludes_by;
}

with_node_test! {
    /// The closest hit in a group with analytic shapes or instances.
    fn closest_item_or_triangle(
        scene: &Scene,
        g: &Group,
        ray: &Ray,
        instance: Option<u32>
    ) -> Option<Closest> = Scene::closest_item_or_triangle_by;
}

with_node_test! {
    /// Whether an item of a group with analytic shapes or instances blocks
    /// `ray`.
    fn item_or_triangle_occludes(scene: &Scene, g: &Group, ray: &Ray) -> bool =
        Scene::item_or_triangle_occludes_by;
}

/// [`closest_triangle`] with the node test `test`. The shear is set up
/// before traversal, so that its values can stay in registers through it
/// (every leaf has triangles).
#[inline(always)]
fn closest_triangle_by(
    g: &Group,
    ray: &Ray,
    test: impl Fn(&RayLanes, &Node, f32, f32) -> (f32x8, u32),
    tris: impl Fn(&WatertightRay, &TrianglePackets, usize, usize, f32) -> Option<(usize, PrimHit)>,
) -> Option<(u32, PrimHit)> {
    let vectors = ray.vectors();
    let wr = WatertightRay::from_vectors(&vectors, ray.t_min);
    let mut closest = None;
    let prefetch = |start| g.tris.prefetch(start);
    g.bvh
        .closest_leaves_by(ray, &vectors, &prefetch, test, |start, count, t_max| {
            let (lane, hit) = tris(&wr, &g.tris, start, count, t_max)?;
            closest = Some((lane + start, hit));
            Some(hit.t)
        });
    closest.map(|(i, hit)| (g.tris.id(i), hit))
}

/// [`triangle_occludes`] with the node test `test`.
#[inline(always)]
fn triangle_occludes_by(
    g: &Group,
    ray: &Ray,
    test: impl Fn(&RayLanes, &Node, f32, f32) -> (f32x8, u32),
    tris: impl Fn(&WatertightRay, &TrianglePackets, usize, usize, f32) -> Option<(usize, PrimHit)>,
) -> bool {
    let vectors = ray.vectors();
    let wr = WatertightRay::from_vectors(&vectors, ray.t_min);
    let prefetch = |start| g.tris.prefetch(start);
    g.bvh
        .any_leaves_by(ray, &vectors, &prefetch, test, |start, count| {
            tris(&wr, &g.tris, start, count, ray.t_max).is_some()
        })
}

/// The closest hit so far within one group.
#[derive(Clone, Copy)]
enum Closest {
    /// A triangle: its packet id.
    Triangle(u32, PrimHit),
    Other(HitRecord),
}

/// One placement of a shape group.
#[derive(Clone, Copy, Debug)]
pub(super) struct Instance {
    pub(super) group: u32,
    pub(super) to_world: Transform,
    /// Where its emitting shapes' world copies are listed in
    /// `Scene::placed_emitters` (start, count).
    pub(super) placed_emitters: (u32, u32),
}

impl Scene {
    /// Closest hit along `ray` within its interval.
    pub fn intersect(&self, ray: &Ray) -> Option<SurfaceInteraction> {
        let h = self.closest(ray)?;
        Some(self.interaction_at(ray, &h))
    }

    /// The interaction at `hit`, the closest hit along `ray`.
    #[inline]
    pub fn interaction_at(&self, ray: &Ray, hit: &HitRecord) -> SurfaceInteraction {
        self.interaction(ray, hit)
    }

    /// The closest hit along `ray`, with its interaction computed only when
    /// `wanted(shape)`: `Some(Ok(si))`, or `Some(Err(shape))` for a hit on
    /// a shape not wanted (a shadow ray's opaque blocker costs no
    /// interaction).
    pub fn intersect_if(
        &self,
        ray: &Ray,
        wanted: impl FnOnce(u32) -> bool,
    ) -> Option<Result<SurfaceInteraction, u32>> {
        let h = self.closest(ray)?;
        if !wanted(h.shape) {
            return Some(Err(h.shape));
        }
        Some(Ok(self.interaction_at(ray, &h)))
    }

    /// Distance, shape and primitive of the closest hit, without computing
    /// the surface interaction (for ray-throughput benchmarks and tests).
    #[inline]
    pub fn intersect_distance(&self, ray: &Ray) -> Option<(f32, u32, u32)> {
        self.closest(ray).map(|h| (h.hit.t, h.shape, h.prim))
    }

    /// The closest hit, a small record ([`HitRecord::t`] is its distance):
    /// [`Scene::intersect`] in two steps for the per-bounce loops, which
    /// then build the interaction with [`Scene::interaction_at`] in place
    /// (through an `Option` the 160-byte interaction would be copied once
    /// more). The ray is passed on as it is, not copied (see
    /// [`Bvh::closest_leaves`]).
    #[inline]
    pub fn closest(&self, ray: &Ray) -> Option<HitRecord> {
        self.closest_in_group(&self.groups[0], ray, None)
    }

    /// Closest hit among a group's items within `ray`'s interval; its
    /// `hit.t` is the distance. `instance` is the instance the group is
    /// seen through, if any.
    pub(super) fn closest_in_group(
        &self,
        g: &Group,
        ray: &Ray,
        instance: Option<u32>,
    ) -> Option<HitRecord> {
        let closest = if g.only_triangles {
            closest_triangle(g, ray).map(|(id, hit)| Closest::Triangle(id, hit))
        } else {
            closest_item_or_triangle(self, g, ray, instance)
        };
        match closest? {
            Closest::Other(rec) => Some(rec),
            Closest::Triangle(id, hit) => {
                let (shape, prim) = g.triangle(id);
                Some(HitRecord {
                    shape,
                    prim,
                    hit: WholeHit(hit),
                    instance,
                })
            }
        }
    }

    /// [`Scene::closest_in_group`] in a group with analytic shapes or
    /// instances, with the node test `test` (see
    /// [`closest_item_or_triangle`]). The shear is set up by the first
    /// leaf with triangles: in a room of analytic walls most rays never
    /// meet one.
    #[inline(always)]
    fn closest_item_or_triangle_by(
        &self,
        g: &Group,
        ray: &Ray,
        instance: Option<u32>,
        test: impl Fn(&RayLanes, &Node, f32, f32) -> (f32x8, u32),
        tris: impl Fn(&WatertightRay, &TrianglePackets, usize, usize, f32) -> Option<(usize, PrimHit)>,
    ) -> Option<Closest> {
        let mut shear = None;
        // A triangle hit keeps only its packet id: its shape and primitive
        // are looked up once, after traversal.
        let mut closest = None;
        let prefetch = |start| g.tris.prefetch(start);
        let vectors = ray.vectors();
        g.bvh
            .closest_leaves_by(ray, &vectors, &prefetch, test, |start, count, t_max| {
                let mut best = None;
                // The leaf's triangles, all at once; other items are NaN lanes.
                if g.tris.has_triangles(start) {
                    let wr = shear
                        .get_or_insert_with(|| WatertightRay::from_vectors(&vectors, ray.t_min));
                    if let Some((lane, hit)) = tris(wr, &g.tris, start, count, t_max) {
                        closest = Some(Closest::Triangle(g.tris.id(start + lane), hit));
                        best = Some(hit.t);
                    }
                }
                if !g.leaf_has_items(start) {
                    return best;
                }
                let t_max = best.unwrap_or(t_max);
                match self.closest_item(g, start..start + count, ray, t_max, instance) {
                    Some(h) => {
                        closest = Some(Closest::Other(h));
                        Some(h.hit.t)
                    }
                    None => best,
                }
            });
        closest
    }

    /// Closest hit among the items (not triangles) at `range` of a group's
    /// leaf order, within `ray`'s interval cut at `t_max`. Out of line:
    /// groups of triangles only never call it, and its size would crowd
    /// the registers of their traversal loop. Shapes are tested against
    /// `ray` itself and their hits cut at `t_max` after (every shape
    /// returns the nearest root past `t_min`, which a shorter interval
    /// keeps or drops whole): a copy of the ray with the cut, built here,
    /// was stored field by field and read back in wider pieces, which the
    /// CPU cannot forward, so every shape test waited for the stores.
    #[inline(never)]
    fn closest_item(
        &self,
        g: &Group,
        range: std::ops::Range<usize>,
        ray: &Ray,
        mut t_max: f32,
        instance: Option<u32>,
    ) -> Option<HitRecord> {
        // The best shape hit as scalars, its record made once at the end:
        // a record rebuilt per hit went through memory in pieces.
        let (mut uv_best, mut item_best) = (glam::Vec2::ZERO, None);
        let mut instance_best = None;
        for (i, item) in g.items[range.clone()].iter().enumerate() {
            match *item {
                Item::Triangle { .. } | Item::Empty => {}
                Item::Prim { shape, prim } => {
                    let hit = self.shapes[shape as usize].intersect(&self.meshes, prim, ray);
                    if let Some(hit) = hit.filter(|hit| hit.t < t_max) {
                        (t_max, uv_best) = (hit.t, hit.uv);
                        item_best = Some(i);
                    }
                }
                Item::Instance(inst) => {
                    let placed = &self.instances[inst as usize];
                    let local = to_local_ray(&Ray { t_max, ..*ray }, &placed.to_world);
                    let group = &self.groups[placed.group as usize];
                    if let Some(h) = self.closest_in_group(group, &local, Some(inst)) {
                        t_max = h.hit.t;
                        (instance_best, item_best) = (Some(h), Some(i));
                    }
                }
            }
        }
        // The best hit's distance is where the interval ends now.
        let i = item_best?;
        match g.items[range.start + i] {
            Item::Prim { shape, prim } => Some(HitRecord {
                shape,
                prim,
                hit: WholeHit(PrimHit {
                    t: t_max,
                    uv: uv_best,
                }),
                instance,
            }),
            _ => instance_best,
        }
    }

    /// True when any item of the group blocks the ray.
    pub(super) fn occluded_in_group(&self, g: &Group, ray: &Ray) -> bool {
        if g.only_triangles {
            triangle_occludes(g, ray)
        } else {
            item_or_triangle_occludes(self, g, ray)
        }
    }

    /// [`Scene::occluded_in_group`] in a group with analytic shapes or
    /// instances, with the node test `test`. The shear is set up lazily,
    /// as in [`Scene::closest_item_or_triangle_by`].
    #[inline(always)]
    fn item_or_triangle_occludes_by(
        &self,
        g: &Group,
        ray: &Ray,
        test: impl Fn(&RayLanes, &Node, f32, f32) -> (f32x8, u32),
        tris: impl Fn(&WatertightRay, &TrianglePackets, usize, usize, f32) -> Option<(usize, PrimHit)>,
    ) -> bool {
        let mut shear = None;
        let prefetch = |start| g.tris.prefetch(start);
        let vectors = ray.vectors();
        g.bvh
            .any_leaves_by(ray, &vectors, &prefetch, test, |start, count| {
                if g.tris.has_triangles(start) {
                    let wr = shear
                        .get_or_insert_with(|| WatertightRay::from_vectors(&vectors, ray.t_min));
                    if tris(wr, &g.tris, start, count, ray.t_max).is_some() {
                        return true;
                    }
                }
                g.leaf_has_items(start)
                    && g.items[start..start + count]
                        .iter()
                        .any(|item| self.item_blocks(item, ray))
            })
    }

    /// Whether `item` (not a triangle) blocks the ray: a shape's test
    /// inline, in the caller's instruction set; an instance out of line.
    #[inline(always)]
    fn item_blocks(&self, item: &Item, r: &Ray) -> bool {
        match *item {
            Item::Triangle { .. } | Item::Empty => false,
            Item::Prim { shape, prim } => self.shapes[shape as usize]
                .intersect(&self.meshes, prim, r)
                .is_some(),
            Item::Instance(inst) => self.instance_occludes(inst, r),
        }
    }

    /// Whether instance `inst` blocks the ray; out of line like
    /// [`Scene::closest_item`].
    #[inline(never)]
    pub(super) fn instance_occludes(&self, inst: u32, r: &Ray) -> bool {
        let placed = &self.instances[inst as usize];
        self.occluded_in_group(
            &self.groups[placed.group as usize],
            &to_local_ray(r, &placed.to_world),
        )
    }

    /// The interaction at `h`, a hit of `ray`. The shapes read the ray's
    /// origin and direction only (the hit brings the distance), so `ray`
    /// is passed on as it is, not a copy cut at the hit.
    #[inline]
    pub(super) fn interaction(&self, ray: &Ray, h: &HitRecord) -> SurfaceInteraction {
        let shape = &self.shapes[h.shape as usize];
        let mut si = match h.instance {
            // The shape's interaction already looks back along the ray.
            None => match shape {
                Shape::Sphere(s) if self.free_frame[h.shape as usize] => {
                    s.interaction_free_frame(ray, *h.hit)
                }
                Shape::Disk(d) if self.free_frame[h.shape as usize] => {
                    d.interaction_free_frame(ray, *h.hit)
                }
                Shape::Sphere(s) if self.uv_unread => s.interaction_without_uv(ray, *h.hit),
                _ => shape.interaction(&self.meshes, h.prim, ray, *h.hit),
            },
            Some(inst) => {
                let t = &self.instances[inst as usize].to_world;
                let local_ray = to_local_ray(ray, t);
                let local = shape.interaction(&self.meshes, h.prim, &local_ray, *h.hit);
                let mut si = instance_to_world(&local, t);
                si.wo = -ray.d.normalize();
                si
            }
        };
        si.shape = match h.instance {
            Some(inst) => self.placed_shape(inst, h.shape),
            None => h.shape,
        };
        si.prim = h.prim;
        si
    }

    /// True when anything blocks `ray` within its interval.
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_in_group(&self.groups[0], ray)
    }
}

/// The ray in an instance's object space; the direction is not
/// normalized, so distances along it equal world distances.
#[inline]
pub(super) fn to_local_ray(r: &Ray, t: &Transform) -> Ray {
    Ray {
        o: t.inv.transform_point3(r.o),
        d: t.inv.transform_vector3(r.d),
        t_min: r.t_min,
        t_max: r.t_max,
    }
}

fn instance_to_world(local: &SurfaceInteraction, t: &Transform) -> SurfaceInteraction {
    let n = t.normal(local.n).normalize();
    let ns = t.normal(local.sh_frame.n).normalize();
    let dpdu = t.vector(local.dpdu);
    SurfaceInteraction {
        p: t.point(local.p),
        n,
        sh_frame: Frame::from_normal_and_tangent(ns, dpdu),
        dpdu,
        dpdv: t.vector(local.dpdv),
        // A mirroring instance turns n × tangent around, and so the sign.
        tangent: t
            .vector(local.tangent.truncate())
            .extend(if t.swaps_handedness() {
                -local.tangent.w
            } else {
                local.tangent.w
            }),
        ..*local
    }
}

/// Shape and primitive of the triangle with packet id `id`.
pub(super) fn triangle_of_id(runs: &[TriangleRun], id: u32) -> (u32, u32) {
    let run = &runs[runs.partition_point(|r| r.first <= id) - 1];
    (run.shape, id - run.first)
}

/// Closest hits and any hits against brute force, over every shape kind,
/// instances and groups of triangles only; the scenes and rays are shared
/// with the packet tests (`packet.rs`).
#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::sampler::Pcg32;
    use crate::sampling::square_to_uniform_sphere;
    use crate::scene::SceneBuilder;
    use crate::shape::{cube::cube_mesh, Cylinder, Disk, MeshShape, Rectangle, Sphere};
    use glam::{Affine3A, Vec3};

    fn t(m: Affine3A) -> Transform {
        Transform::new(m).unwrap()
    }

    /// Every shape kind, in the world and in two instances of a group.
    pub(in crate::scene) fn mixed_scene() -> Scene {
        let mut b = SceneBuilder::new();
        let mut cube = cube_mesh();
        cube.transform(&t(
            Affine3A::from_translation(Vec3::new(2.0, 0.0, 0.0)) * Affine3A::from_rotation_z(0.3)
        ));
        let cube = b.add_mesh(cube);
        b.add_shape(Shape::Mesh(MeshShape { mesh: cube }), None, None)
            .unwrap();
        b.add_shape(
            Shape::Sphere(Sphere::new(Vec3::new(-2.0, 0.5, 0.0), 0.8, false)),
            None,
            None,
        )
        .unwrap();
        b.add_shape(
            Shape::Rectangle(Rectangle::new(
                t(Affine3A::from_translation(Vec3::new(0.0, -2.0, 0.0))
                    * Affine3A::from_rotation_x(1.2)),
                false,
            )),
            None,
            None,
        )
        .unwrap();
        b.add_shape(
            Shape::Disk(Disk::new(
                t(Affine3A::from_translation(Vec3::new(0.0, 2.0, 1.0))),
                true,
            )),
            None,
            None,
        )
        .unwrap();
        let cyl =
            Cylinder::object_to_world(Vec3::new(0.0, 0.0, -1.0), Vec3::new(0.5, 0.0, 1.0), 0.4);
        b.add_shape(
            Shape::Cylinder(Cylinder {
                to_world: t(cyl),
                flip_normals: false,
            }),
            None,
            None,
        )
        .unwrap();
        b.add_shape(
            Shape::Cube(crate::shape::Cube::new(
                t(Affine3A::from_translation(Vec3::new(-2.0, -2.0, -2.0))
                    * Affine3A::from_rotation_y(0.7)
                    * Affine3A::from_scale(Vec3::new(0.6, 0.4, 0.5))),
                false,
            )),
            None,
            None,
        )
        .unwrap();
        let g = b.add_group();
        let mut small = cube_mesh();
        small.transform(&t(Affine3A::from_scale(Vec3::splat(0.3))));
        let small = b.add_mesh(small);
        b.add_shape_to(g, Shape::Mesh(MeshShape { mesh: small }), None, None)
            .unwrap();
        b.add_shape_to(
            g,
            Shape::Sphere(Sphere::new(Vec3::new(0.0, 0.0, 0.6), 0.25, false)),
            None,
            None,
        )
        .unwrap();
        b.add_instance(g, t(Affine3A::from_translation(Vec3::new(0.0, 0.0, 2.5))))
            .unwrap();
        b.add_instance(
            g,
            t(Affine3A::from_translation(Vec3::new(1.0, 1.0, -2.5))
                * Affine3A::from_scale(Vec3::new(1.5, 0.7, 1.0))),
        )
        .unwrap();
        b.build().unwrap()
    }

    /// Closest hit by testing every primitive of every item.
    fn brute_force(scene: &Scene, ray: &Ray) -> Option<(u32, u32, f32)> {
        let mut best: Option<(u32, u32, f32)> = None;
        let mut consider = |shape: u32, prim: u32, r: &Ray| {
            if let Some(h) = scene.shapes[shape as usize].intersect(&scene.meshes, prim, r) {
                if best.is_none_or(|b| h.t < b.2) {
                    best = Some((shape, prim, h.t));
                }
            }
        };
        for (shape, prim) in scene.groups[0].primitives() {
            consider(shape, prim, ray);
        }
        for item in &scene.groups[0].items {
            if let Item::Instance(i) = *item {
                let inst = &scene.instances[i as usize];
                let local = to_local_ray(ray, &inst.to_world);
                for (shape, prim) in scene.groups[inst.group as usize].primitives() {
                    consider(shape, prim, &local);
                }
            }
        }
        best
    }

    /// Two meshes in the world and, with `instanced`, two in an instanced
    /// group: groups of triangles only (the world's when nothing is
    /// instanced), which keep no item list and whose packets are gathered
    /// by triangle id, over several runs.
    fn triangles_only_scene(instanced: bool) -> Scene {
        let mut b = SceneBuilder::new();
        let g = b.add_group();
        for (group, place) in [
            (0, Affine3A::from_rotation_z(0.3)),
            (0, Affine3A::from_translation(Vec3::new(-2.0, 1.0, 0.5))),
            (g, Affine3A::from_scale(Vec3::splat(0.4))),
            (g, Affine3A::from_translation(Vec3::new(0.0, 0.0, 0.9))),
        ] {
            let mut cube = cube_mesh();
            cube.transform(&t(place));
            let mesh = b.add_mesh(cube);
            b.add_shape_to(group, Shape::Mesh(MeshShape { mesh }), None, None)
                .unwrap();
        }
        if instanced {
            b.add_instance(g, t(Affine3A::from_translation(Vec3::new(1.5, -1.5, 2.0))))
                .unwrap();
        }
        b.build().unwrap()
    }

    #[test]
    fn bvh_closest_hit_equals_brute_force_for_every_shape_kind_and_instances() {
        assert_closest_hit_is_brute_force(&mixed_scene(), 42);
    }

    #[test]
    fn bvh_closest_hit_equals_brute_force_in_groups_of_triangles_only() {
        let world = triangles_only_scene(false);
        assert!(world.groups[0].only_triangles);
        assert_closest_hit_is_brute_force(&world, 7);
        let instanced = triangles_only_scene(true);
        assert!(instanced.groups[1].only_triangles);
        assert_closest_hit_is_brute_force(&instanced, 8);
    }

    /// A ray from within a few units of the origin: half aim at the
    /// geometry, half go anywhere.
    pub(in crate::scene) fn random_ray(rng: &mut Pcg32) -> Ray {
        let o = (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * 10.0;
        let d = if rng.next_f32() < 0.5 {
            square_to_uniform_sphere(rng.next_2d())
        } else {
            ((Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * 5.0 - o)
                .normalize()
        };
        Ray::new(o, d)
    }

    fn assert_closest_hit_is_brute_force(scene: &Scene, seed: u64) {
        let mut rng = Pcg32::new(seed, 0);
        let mut hits = 0;
        for _ in 0..20_000 {
            let ray = random_ray(&mut rng);
            let expected = brute_force(scene, &ray);
            let got = scene.intersect(&ray);
            match (expected, got) {
                (None, None) => {}
                (Some((shape, prim, t)), Some(si)) => {
                    hits += 1;
                    assert_eq!((si.shape, si.prim), (shape, prim));
                    assert!((si.t - t).abs() <= 1e-5 * t.max(1.0), "{} vs {t}", si.t);
                    assert!(
                        (si.p - ray.at(t)).length() < 1e-3 * t.max(1.0),
                        "hit point off the ray"
                    );
                }
                (e, g) => panic!(
                    "brute force {e:?}, BVH {:?}",
                    g.map(|s| (s.shape, s.prim, s.t))
                ),
            }
            assert_eq!(
                scene.occluded(&ray),
                expected.is_some(),
                "any-hit disagrees with closest hit"
            );
        }
        assert!(hits > 2000, "too few hits ({hits}) to mean anything");
    }
}
