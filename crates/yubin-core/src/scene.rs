//! The scene: geometry in a two-level hierarchy, materials, emitters,
//! camera, film and sampler; and [`SceneBuilder`], the API for building
//! one in code (the scene-file front ends use it too).
//!
//! Geometry is a list of groups, each with its own BVH over *items*; an
//! item is a primitive of a shape or an instance of another group. Group
//! 0 is the world; `shapegroup`s are further groups, referenced by
//! instances (a transform and a group), so instanced geometry is stored
//! once. Instances nest one level, as in Mitsuba.

use crate::accel::{Bvh, Node, PrimCost, RayLanes};
use crate::bsdf::{Bsdf, BsdfModel, Diffuse};
use crate::camera::{Camera, FovAxis, Perspective};
use crate::film::Film;
use crate::integrator::wide::{DiffuseSides, RectangleLight};
use crate::interaction::SurfaceInteraction;
use crate::light::{
    AreaLight, Emitter, EmitterContext, EmitterOptions, LightChoice, LightSampler, LightSelection,
};
use crate::material::Materials;
use crate::math::{Bounds3, Frame, Ray, Transform};
use crate::sampler::Sampler;
use crate::sampling::Distribution2D;
use crate::shape::{PrimHit, Shape, ShapeModel, TriangleMesh, TrianglePackets, WatertightRay};
use crate::texture::{AttributeSlot, Tex, TexImage, Texture};
use multiversion::{inherit_target, multiversion, target::target_cfg};
use wide::f32x8;

use rayon::prelude::*;

mod packet;

// A leaf is tested as one triangle packet.
const _: () = assert!(crate::accel::MAX_LEAF == crate::shape::PACKET);

/// What a shape is made of and whether it emits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ShapeInfo {
    /// Index into the BSDF table ([`Materials::bsdfs`]).
    pub bsdf: u32,
    /// Index into [`Scene::emitters`] when the shape is an area light.
    pub emitter: Option<u32>,
    /// The medium inside the shape (index into [`Scene::media`]).
    pub interior: Option<u32>,
    /// The medium outside the shape.
    pub exterior: Option<u32>,
}

impl ShapeInfo {
    /// Rays crossing the shape change medium.
    #[inline]
    pub fn is_medium_transition(&self) -> bool {
        self.interior.is_some() || self.exterior.is_some()
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Item {
    /// A mesh triangle; its vertices are copied into the group's `tris`
    /// (in BVH leaf order) so the hot loop reads them without indirection.
    Triangle {
        shape: u32,
        prim: u32,
    },
    /// Padding that keeps every BVH leaf in one 4-wide packet.
    Empty,
    Prim {
        shape: u32,
        prim: u32,
    },
    Instance(u32),
}

#[derive(Clone, Debug, Default)]
struct Group {
    /// Items in BVH leaf order; empty when `only_triangles` (the packets
    /// then say everything).
    items: Vec<Item>,
    /// Per mesh shape, the first triangle id its triangles take in the
    /// packets and their count: triangle id `first + prim` is `prim` of
    /// `shape`. Sorted by `first`.
    tri_runs: Vec<TriangleRun>,
    /// Vertices of `Item::Triangle` items, parallel to `items` (NaN for
    /// other items), packed for 4-wide tests.
    tris: TrianglePackets,
    /// No analytic shapes or instances: leaves need only the packet test.
    only_triangles: bool,
    /// Per leaf (one packet of `items`), whether it holds an analytic
    /// shape or an instance: the leaves of a mesh beside a floor
    /// rectangle then skip the item loop and its out-of-line call (7 % of
    /// the suite's mesh scene). Empty when `only_triangles`.
    leaf_has_items: Vec<bool>,
    bvh: Bvh,
}

/// The triangles of one mesh shape within a group.
#[derive(Clone, Copy, Debug)]
struct TriangleRun {
    first: u32,
    count: u32,
    shape: u32,
}

impl Group {
    /// Whether the leaf starting at position `start` holds an analytic
    /// shape or an instance.
    #[inline(always)]
    fn leaf_has_items(&self, start: usize) -> bool {
        self.leaf_has_items[start / crate::shape::PACKET]
    }

    /// Shape and primitive of the triangle with packet id `id`.
    fn triangle(&self, id: u32) -> (u32, u32) {
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
/// twelve slab vectors without spilling them (primary rays +4 % in
/// `yubin-bench rays` on Zen 4; renders ±0). All give the same hits bit
/// for bit (see [`crate::accel::hit_children_avx2`]).
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
struct Instance {
    group: u32,
    to_world: Transform,
    /// Where its emitting shapes' world copies are listed in
    /// `Scene::placed_emitters` (start, count).
    placed_emitters: (u32, u32),
}

/// An emitter on a shape inside a shape group: each instance of the group
/// gets a world copy of the shape that carries its own light.
#[derive(Clone, Copy, Debug)]
struct GroupEmitter {
    group: u32,
    shape: u32,
    emitter: ShapeEmitter,
    options: EmitterOptions,
}

/// A closest hit before its interaction is computed.
#[derive(Clone, Copy, Debug)]
pub struct HitRecord {
    shape: u32,
    prim: u32,
    hit: WholeHit,
    instance: Option<u32>,
}

/// A [`PrimHit`] padded to sixteen bytes and aligned, so that it is stored
/// and loaded whole: a hit that packet traversal records and the
/// interaction reads soon after would otherwise be read in pieces
/// straddling the stores that wrote it, which the CPU cannot forward
/// (a third of the interaction's time in the Cornell box). Only here:
/// padded in the traversal's inner loop, it cost single-ray closest hits
/// 5 %.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub(crate) struct WholeHit(pub(crate) PrimHit);

impl std::ops::Deref for WholeHit {
    type Target = PrimHit;
    #[inline(always)]
    fn deref(&self) -> &PrimHit {
        &self.0
    }
}

impl HitRecord {
    /// The hit's distance along the ray.
    #[inline]
    pub fn t(&self) -> f32 {
        self.hit.t
    }
}

/// An emitter that covers a shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ShapeEmitter {
    /// `area`, with its radiance.
    Area(Tex),
    /// `directionalarea`, with its radiance.
    DirectionalArea(Tex),
}

impl ShapeEmitter {
    /// The emitter it makes of shape `shape`.
    fn on_shape(self, shape: u32) -> Emitter {
        match self {
            ShapeEmitter::Area(radiance) => Emitter::Area(AreaLight { shape, radiance }),
            ShapeEmitter::DirectionalArea(radiance) => {
                Emitter::DirectionalArea(crate::light::DirectionalAreaLight { shape, radiance })
            }
        }
    }
}

/// The first surface a shadow ray meets ([`Scene::shadow_hit`]).
#[derive(Clone, Copy, Debug)]
pub enum ShadowHit {
    /// A surface that lets no light straight through.
    Opaque,
    /// A plain `null` surface.
    Null {
        /// Ray parameter of the hit.
        t: f32,
        /// Hit point.
        p: glam::Vec3,
        /// Geometric normal, as the interaction would give it.
        n: glam::Vec3,
        /// The shape.
        shape: u32,
    },
    /// Another surface that may let light through.
    Surface(SurfaceInteraction),
}

/// A scene ready to render.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Triangle data.
    pub meshes: Vec<TriangleMesh>,
    /// All shapes, including those only reachable through instances.
    pub shapes: Vec<Shape>,
    /// Material and emission of each shape.
    pub shape_info: Vec<ShapeInfo>,
    /// BSDFs, textures and texture images.
    pub materials: Materials,
    /// Emitters.
    pub emitters: Vec<Emitter>,
    /// Per emitter: visibility and sampling weight.
    pub emitter_options: Vec<EmitterOptions>,
    /// Chooses emitters for next-event estimation.
    pub light_sampler: LightSampler,
    /// Indices of emitters at infinity (hit by escaping rays).
    pub environment_emitters: Vec<u32>,
    /// Sampling distributions that emitters refer to by index (one per
    /// `envmap`), made by [`SceneBuilder::build`].
    pub light_distributions: Vec<Distribution2D>,
    /// The camera.
    pub camera: Camera,
    /// The film.
    pub film: Film,
    /// The sampler.
    pub sampler: Sampler,
    /// Participating media, referred to by [`ShapeInfo`] and
    /// [`Scene::camera_medium`].
    pub media: Vec<crate::medium::Medium>,
    /// The medium the camera sits in.
    pub camera_medium: Option<u32>,
    groups: Vec<Group>,
    instances: Vec<Instance>,
    /// (shape in a group, its world copy in one instance), for each
    /// emitting shape of each instance (`Instance::placed_emitters`).
    placed_emitters: Vec<(u32, u32)>,
    /// [`BsdfModel::flags`] of each BSDF of [`Materials::bsdfs`], asked
    /// at every bounce: taken once (nested BSDFs ask theirs recursively).
    bsdf_flags: Vec<crate::bsdf::BsdfFlags>,
    /// Per BSDF, its reflectances when it is a constant `diffuse` (alone
    /// or in `twosided`), which the path tracer shades eight at a time.
    diffuse_sides: Vec<Option<DiffuseSides>>,
    /// Per emitter, the rectangle light it is, if it is one of constant
    /// radiance, which the path tracer samples eight at a time.
    rectangle_lights: Vec<Option<RectangleLight>>,
    /// Some shape's BSDF lets light through (`null`, `mask`): shadow rays
    /// may have to look past their first hit.
    has_pass_through: bool,
    /// Some shape lets light straight through with `thindielectric` slabs
    /// counted ([`Bsdf::lets_light_through`]).
    has_null_transmission: bool,
    /// Nothing reads a hit's uv: the scene has no textures and its
    /// integrator writes no uv ([`SceneBuilder::uv_unread_by_integrator`]);
    /// spheres then skip their angles' arctangents.
    uv_unread: bool,
    /// Per shape, whether its hits may take any shading frame about the
    /// normal: nothing reads uv (`uv_unread`) and its BSDF turns freely
    /// ([`Bsdf::turns_freely`]); spheres and disks then build theirs from
    /// the normal alone ([`crate::shape::Sphere::interaction_free_frame`]).
    free_frame: Vec<bool>,
}

impl Scene {
    /// World-space bounds of all geometry.
    pub fn bounds(&self) -> Bounds3 {
        self.groups
            .first()
            .map_or(Bounds3::EMPTY, |g| g.bvh.bounds())
    }

    /// What emitters need to see of the scene.
    #[inline]
    pub fn emitter_context(&self) -> EmitterContext<'_> {
        EmitterContext {
            shapes: &self.shapes,
            meshes: &self.meshes,
            images: &self.materials.images,
            materials: &self.materials,
            distributions: &self.light_distributions,
        }
    }

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

    /// The first surface along a shadow ray, with no more computed than the
    /// ray needs: nothing for a surface that lets no light straight
    /// through, the point and normal for a plain `null` one, the whole
    /// interaction otherwise.
    pub fn shadow_hit(&self, ray: &Ray) -> Option<ShadowHit> {
        let h = self.closest(ray)?;
        let bsdf = self.bsdf_of(h.shape);
        if !bsdf.lets_light_through(&self.materials) {
            return Some(ShadowHit::Opaque);
        }
        if !matches!(bsdf, Bsdf::Null(_)) {
            return Some(ShadowHit::Surface(self.interaction(ray, &h)));
        }
        let shape = &self.shapes[h.shape as usize];
        let (p, n) = match h.instance {
            None => shape.point_and_normal(&self.meshes, h.prim, ray, *h.hit),
            Some(inst) => {
                let t = &self.instances[inst as usize].to_world;
                let local_ray = to_local_ray(ray, t);
                let (p, n) = shape.point_and_normal(&self.meshes, h.prim, &local_ray, *h.hit);
                (t.point(p), t.normal(n).normalize())
            }
        };
        Some(ShadowHit::Null {
            t: h.hit.t,
            p,
            n,
            shape: h.shape,
        })
    }

    /// Whether light may pass straight through shape `shape`
    /// ([`Bsdf::lets_light_through`]).
    #[inline]
    pub fn lets_light_through(&self, shape: u32) -> bool {
        self.bsdf_of(shape).lets_light_through(&self.materials)
    }

    /// Shape of the top-level BVH (for benchmarks and tuning).
    pub fn bvh_stats(&self) -> crate::accel::BvhStats {
        self.groups[0].bvh.stats()
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
    fn closest_in_group(&self, g: &Group, ray: &Ray, instance: Option<u32>) -> Option<HitRecord> {
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
    /// CPU cannot forward (a fifth of this function's time in the fog
    /// scene).
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
    fn occluded_in_group(&self, g: &Group, ray: &Ray) -> bool {
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
    fn instance_occludes(&self, inst: u32, r: &Ray) -> bool {
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
    fn interaction(&self, ray: &Ray, h: &HitRecord) -> SurfaceInteraction {
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

    /// The shape a hit on `shape` through instance `inst` is: its world
    /// copy when it emits (which carries that instance's light), else
    /// itself.
    #[inline]
    fn placed_shape(&self, inst: u32, shape: u32) -> u32 {
        let (start, count) = self.instances[inst as usize].placed_emitters;
        self.placed_emitters[start as usize..(start + count) as usize]
            .iter()
            .find(|(local, _)| *local == shape)
            .map_or(shape, |&(_, world)| world)
    }

    /// True when anything blocks `ray` within its interval.
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_in_group(&self.groups[0], ray)
    }

    /// Whether the scene has surfaces that let light through (`null`,
    /// `mask`): then shadow rays may have to cross them.
    #[inline]
    pub fn has_pass_through(&self) -> bool {
        self.has_pass_through
    }

    /// The fraction of light that gets along `ray` (a generalized shadow
    /// ray): 0 when an opaque surface blocks it, else the product of what
    /// the pass-through surfaces it crosses (`null`, `mask`) let through,
    /// 0 as well when it would cross more than `max_crossings` of them.
    /// Scenes without pass-through surfaces pay one any-hit query.
    pub fn transmittance(&self, ray: &Ray, max_crossings: u32) -> f32 {
        if !self.has_pass_through() || max_crossings == 0 {
            return if self.occluded(ray) { 0.0 } else { 1.0 };
        }
        let mut tr = 1.0;
        let mut r = *ray;
        for _ in 0..=max_crossings.min(MAX_CROSSINGS) {
            let si = match self.intersect_if(&r, |shape| self.lets_light_through(shape)) {
                None => return tr,
                Some(Err(_)) => return 0.0,
                Some(Ok(si)) => si,
            };
            tr *= self.bsdf_of(si.shape).pass_through(&self.materials, &si);
            if tr <= 0.0 {
                return 0.0;
            }
            // Continue past the surface; `d` is unnormalized in general, so
            // the remaining interval is kept in units of `d`.
            let next = si.spawn_ray(r.d);
            r = Ray {
                t_max: r.t_max - si.t,
                ..next
            };
            if r.t_max <= r.t_min {
                return tr;
            }
        }
        0.0
    }

    /// The medium a ray leaving the hit `si` in direction `d` travels in,
    /// coming from `current`: the shape's interior or exterior when the
    /// shape bounds media (by the side of its normal `d` is on), else
    /// unchanged.
    #[inline]
    pub fn medium_after(
        &self,
        si: &SurfaceInteraction,
        d: glam::Vec3,
        current: Option<u32>,
    ) -> Option<u32> {
        self.medium_across(si.shape, si.n, d, current)
    }

    /// [`Scene::medium_after`] for a hit on `shape` whose geometric normal
    /// is `n`.
    #[inline]
    pub fn medium_across(
        &self,
        shape: u32,
        n: glam::Vec3,
        d: glam::Vec3,
        current: Option<u32>,
    ) -> Option<u32> {
        let info = &self.shape_info[shape as usize];
        if !info.is_medium_transition() {
            return current;
        }
        if d.dot(n) > 0.0 {
            info.exterior
        } else {
            info.interior
        }
    }

    /// Whether shadow rays may have to look past surfaces: some surface
    /// lets light straight through (`null`, `mask`, `thindielectric`
    /// slabs) or media fill shapes.
    #[inline]
    pub fn shadow_rays_cross_surfaces(&self) -> bool {
        self.has_null_transmission || self.has_media()
    }

    /// Whether any medium is in the scene.
    #[inline]
    pub fn has_media(&self) -> bool {
        !self.media.is_empty()
    }

    /// The BSDF of a shape.
    #[inline]
    pub fn bsdf_of(&self, shape: u32) -> &Bsdf {
        &self.materials.bsdfs[self.shape_info[shape as usize].bsdf as usize]
    }

    /// The flags of a shape's BSDF ([`BsdfModel::flags`]), as
    /// [`SceneBuilder::build`] took them: a scene whose BSDFs change is
    /// built again.
    #[inline]
    pub fn bsdf_flags_of(&self, shape: u32) -> crate::bsdf::BsdfFlags {
        self.bsdf_flags[self.shape_info[shape as usize].bsdf as usize]
    }

    /// The reflectances of a shape's BSDF, when it is a `diffuse` of
    /// constant reflectance (alone or in `twosided`).
    #[inline]
    pub(crate) fn diffuse_sides_of(&self, shape: u32) -> Option<DiffuseSides> {
        self.diffuse_sides[self.shape_info[shape as usize].bsdf as usize]
    }

    /// Emitter `emitter`, when it is an area light of constant radiance on
    /// a rectangle.
    #[inline]
    pub(crate) fn rectangle_light(&self, emitter: u32) -> Option<&RectangleLight> {
        self.rectangle_lights[emitter as usize].as_ref()
    }

    /// The emitter of a shape, if it is an area light.
    #[inline]
    pub fn emitter_of(&self, shape: u32) -> Option<&Emitter> {
        self.shape_info[shape as usize]
            .emitter
            .map(|e| &self.emitters[e as usize])
    }

    /// Chooses a light for next-event estimation at `p` (surface normal
    /// `n`, or zero); returns it and its probability.
    #[inline]
    pub fn pick_light(&self, u: f32, p: glam::Vec3, n: glam::Vec3) -> Option<(LightChoice, f32)> {
        self.light_sampler.sample(u, p, n)
    }

    /// Probability that [`Scene::pick_light`] at (`p`, `n`) chooses `light`.
    #[inline]
    pub fn light_pmf(&self, light: LightChoice, p: glam::Vec3, n: glam::Vec3) -> f32 {
        self.light_sampler.pmf(light, p, n)
    }

    /// The light a hit on an emitting surface is, as the light sampler
    /// counts lights (the triangle, when it chooses them one by one).
    #[inline]
    pub fn light_of_hit(&self, si: &SurfaceInteraction) -> Option<LightChoice> {
        let emitter = self.shape_info[si.shape as usize].emitter?;
        let prim = if self.light_sampler.splits(emitter) {
            si.prim
        } else {
            LightChoice::WHOLE
        };
        Some(LightChoice { emitter, prim })
    }
}

/// The most pass-through surfaces one shadow ray looks past.
const MAX_CROSSINGS: u32 = 256;

/// The ray in an instance's object space; the direction is not
/// normalized, so distances along it equal world distances.
#[inline]
fn to_local_ray(r: &Ray, t: &Transform) -> Ray {
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
fn triangle_of_id(runs: &[TriangleRun], id: u32) -> (u32, u32) {
    let run = &runs[runs.partition_point(|r| r.first <= id) - 1];
    (run.shape, id - run.first)
}

/// The runs of consecutive triangles of one mesh shape in a group's items
/// (`add_shape_to` adds a mesh's triangles together, in order), numbered
/// one after another.
fn triangle_runs(items: &[Item]) -> Vec<TriangleRun> {
    let mut runs: Vec<TriangleRun> = Vec::new();
    for item in items {
        if let Item::Triangle { shape, .. } = *item {
            match runs.last_mut() {
                Some(r) if r.shape == shape => r.count += 1,
                _ => runs.push(TriangleRun {
                    first: runs.last().map_or(0, |r| r.first + r.count),
                    count: 1,
                    shape,
                }),
            }
        }
    }
    runs
}

/// Errors from [`SceneBuilder::build`] and its methods.
#[derive(Debug, PartialEq)]
pub enum BuildError {
    /// An index that doesn't refer to anything.
    BadIndex {
        /// Kind of object.
        what: &'static str,
        /// The index given.
        index: u32,
    },
    /// An emitting sphere in a shape group placed by an instance that
    /// scales it unevenly (into an ellipsoid, which cannot be sampled).
    StretchedEmittingSphere {
        /// The shape.
        shape: u32,
    },
    /// A shape group (or the scene's top level) with more primitives than
    /// one BVH can address.
    TooManyPrimitives {
        /// Primitives in the group.
        count: usize,
    },
}

impl std::fmt::Display for BuildError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BuildError::BadIndex { what, index } => write!(f, "{what} {index} does not exist"),
            BuildError::StretchedEmittingSphere { shape } => write!(
                f,
                "shape {shape} is an emitting sphere in a shapegroup, and an instance scales \
                 it unevenly (into an ellipsoid, which cannot be sampled as a light); \
                 use a uniform scale or a mesh"
            ),
            BuildError::TooManyPrimitives { count } => write!(
                f,
                "{count} primitives in one group are more than one BVH can hold \
                 (at most {} leaf positions); split the geometry into shape groups",
                crate::accel::MAX_POSITIONS
            ),
        }
    }
}

impl std::error::Error for BuildError {}

/// Builds a [`Scene`] piece by piece.
#[derive(Debug)]
pub struct SceneBuilder {
    meshes: Vec<TriangleMesh>,
    shapes: Vec<Shape>,
    shape_info: Vec<ShapeInfo>,
    materials: Materials,
    emitters: Vec<Emitter>,
    emitter_options: Vec<EmitterOptions>,
    light_selection: LightSelection,
    mis_compensation: bool,
    uv_unread_by_integrator: bool,
    groups: Vec<Vec<Item>>,
    instances: Vec<Instance>,
    group_emitters: Vec<GroupEmitter>,
    camera: Option<Camera>,
    film: Film,
    sampler: Sampler,
    media: Vec<crate::medium::Medium>,
    camera_medium: Option<u32>,
}

impl Default for SceneBuilder {
    fn default() -> Self {
        Self::new()
    }
}

impl SceneBuilder {
    /// An empty scene: Mitsuba's defaults (768×576 film with a Gaussian
    /// filter, 4 independent samples per pixel).
    pub fn new() -> Self {
        Self {
            meshes: Vec::new(),
            shapes: Vec::new(),
            shape_info: Vec::new(),
            materials: Materials::default(),
            emitters: Vec::new(),
            emitter_options: Vec::new(),
            light_selection: LightSelection::default(),
            mis_compensation: false,
            uv_unread_by_integrator: false,
            groups: vec![Vec::new()],
            instances: Vec::new(),
            group_emitters: Vec::new(),
            camera: None,
            film: Film::default(),
            sampler: Sampler::default(),
            media: Vec::new(),
            camera_medium: None,
        }
    }

    /// Adds a BSDF; returns its index (for shapes and composite BSDFs).
    pub fn add_bsdf(&mut self, b: Bsdf) -> u32 {
        self.materials.add_bsdf(b)
    }

    /// Adds a texture; returns its index (for [`crate::texture::Tex::Texture`]).
    pub fn add_texture(&mut self, t: Texture) -> u32 {
        self.materials.textures.push(t);
        self.materials.textures.len() as u32 - 1
    }

    /// Adds an image for textures; returns its index.
    pub fn add_image(&mut self, image: TexImage) -> u32 {
        self.materials.images.push(image);
        self.materials.images.len() as u32 - 1
    }

    /// The image at `index`, to check or fix before the scene is built.
    pub fn image_mut(&mut self, index: u32) -> Option<&mut TexImage> {
        self.materials.images.get_mut(index as usize)
    }

    /// The BSDF at `index`, if there is one (what a front end built).
    pub fn bsdf(&self, index: u32) -> Option<&Bsdf> {
        self.materials.bsdfs.get(index as usize)
    }

    /// True when BSDF `index` reads a normal map in MikkTSpace
    /// ([`Bsdf::needs_mikktspace`]).
    pub fn needs_mikktspace(&self, index: u32) -> bool {
        self.bsdf(index)
            .is_some_and(|b| b.needs_mikktspace(&self.materials))
    }

    /// The index of attribute name `name` in the scene's attribute table
    /// (added if new); what a `mesh_attribute` texture holds.
    pub fn attribute_name(&mut self, name: &str) -> u32 {
        self.materials.attributes.intern(name)
    }

    /// The name at index `name` of the attribute table.
    pub fn attribute_label(&self, name: u32) -> &str {
        self.materials
            .attributes
            .names
            .get(name as usize)
            .map_or("?", String::as_str)
    }

    /// Attribute `name` (an index from [`SceneBuilder::attribute_name`])
    /// of mesh `mesh`, if it has one.
    pub fn mesh_attribute(&self, mesh: u32, name: u32) -> Option<&AttributeSlot> {
        let set = self.meshes.get(mesh as usize)?.attribute_set;
        self.materials.attributes.find(set, name)
    }

    /// Adds triangle data; returns its index (for [`crate::shape::MeshShape`]).
    /// Its named attributes move into the scene's attribute table.
    pub fn add_mesh(&mut self, mut m: TriangleMesh) -> u32 {
        if !m.attributes.is_empty() {
            let attributes = std::mem::take(&mut m.attributes);
            m.attribute_set = self.materials.attributes.add_set(attributes);
        }
        self.meshes.push(m);
        self.meshes.len() as u32 - 1
    }

    /// Creates an empty shape group; returns its index.
    pub fn add_group(&mut self) -> u32 {
        self.groups.push(Vec::new());
        self.groups.len() as u32 - 1
    }

    /// Adds a shape to the world with a BSDF (or the default diffuse when
    /// `None`) and, for area lights, its emitted radiance.
    pub fn add_shape(
        &mut self,
        shape: Shape,
        bsdf: Option<u32>,
        radiance: Option<Tex>,
    ) -> Result<u32, BuildError> {
        self.add_shape_to(0, shape, bsdf, radiance)
    }

    /// Adds a shape to group `group` (0 is the world).
    pub fn add_shape_to(
        &mut self,
        group: u32,
        shape: Shape,
        bsdf: Option<u32>,
        radiance: Option<Tex>,
    ) -> Result<u32, BuildError> {
        self.add_shape_with_emitter(group, shape, bsdf, radiance.map(ShapeEmitter::Area))
    }

    /// Adds a shape to group `group` (0 is the world) with the emitter it
    /// carries, if any.
    pub fn add_shape_with_emitter(
        &mut self,
        group: u32,
        shape: Shape,
        bsdf: Option<u32>,
        emitter: Option<ShapeEmitter>,
    ) -> Result<u32, BuildError> {
        let radiance = emitter.map(|e| match e {
            ShapeEmitter::Area(t) | ShapeEmitter::DirectionalArea(t) => t,
        });
        if group as usize >= self.groups.len() {
            return Err(BuildError::BadIndex {
                what: "shape group",
                index: group,
            });
        }
        if let Shape::Mesh(m) = shape {
            if m.mesh as usize >= self.meshes.len() {
                return Err(BuildError::BadIndex {
                    what: "mesh",
                    index: m.mesh,
                });
            }
        }
        let bsdf = match bsdf {
            Some(b) if b as usize >= self.materials.bsdfs.len() => {
                return Err(BuildError::BadIndex {
                    what: "bsdf",
                    index: b,
                })
            }
            Some(b) => b,
            // Mitsuba's default: grey diffuse, black on emitters (a light
            // without a BSDF reflects nothing).
            None if radiance.is_some() => {
                self.add_bsdf(Bsdf::Diffuse(Diffuse::new(crate::Rgb::ZERO)))
            }
            None => self.add_bsdf(Bsdf::Diffuse(Diffuse::default())),
        };
        let id = self.shapes.len() as u32;
        let (emitter, grouped) = if group == 0 {
            (emitter, None)
        } else {
            (None, emitter)
        };
        if let Some(emitter) = grouped {
            self.group_emitters.push(GroupEmitter {
                group,
                shape: id,
                emitter,
                options: EmitterOptions::default(),
            });
        }
        let emitter = emitter.map(|e| {
            if let Shape::Mesh(m) = shape {
                self.meshes[m.mesh as usize].prepare_area_sampling();
            }
            self.add_emitter(e.on_shape(id))
        });
        let prims = shape.prim_count(&self.meshes);
        self.shapes.push(shape);
        self.shape_info.push(ShapeInfo {
            bsdf,
            emitter,
            interior: None,
            exterior: None,
        });
        let is_mesh = matches!(shape, Shape::Mesh(_));
        self.groups[group as usize].extend((0..prims).map(|prim| {
            if is_mesh {
                Item::Triangle { shape: id, prim }
            } else {
                Item::Prim { shape: id, prim }
            }
        }));
        Ok(id)
    }

    /// Places group `group` in the world with `to_world`.
    pub fn add_instance(&mut self, group: u32, to_world: Transform) -> Result<(), BuildError> {
        if group == 0 || group as usize >= self.groups.len() {
            return Err(BuildError::BadIndex {
                what: "shape group",
                index: group,
            });
        }
        // Refused here, where a front end still knows the instance's line.
        for g in self.group_emitters.iter().filter(|g| g.group == group) {
            if let Shape::Sphere(sphere) = self.shapes[g.shape as usize] {
                if sphere.placed(&to_world).is_none() {
                    return Err(BuildError::StretchedEmittingSphere { shape: g.shape });
                }
            }
        }
        self.instances.push(Instance {
            group,
            to_world,
            placed_emitters: (0, 0),
        });
        self.groups[0].push(Item::Instance(self.instances.len() as u32 - 1));
        Ok(())
    }

    /// Adds a non-surface emitter (point, directional, environment). An
    /// `envmap`'s image must be in the image table ([`SceneBuilder::add_image`])
    /// by the time the scene is built, which makes its sampling distribution.
    pub fn add_emitter(&mut self, e: Emitter) -> u32 {
        self.emitters.push(e);
        self.emitter_options.push(EmitterOptions::default());
        self.emitters.len() as u32 - 1
    }

    /// Sets the visibility and sampling weight of emitter `emitter`.
    pub fn set_emitter_options(&mut self, emitter: u32, options: EmitterOptions) {
        if let Some(o) = self.emitter_options.get_mut(emitter as usize) {
            *o = options;
        }
    }

    /// The emitter of shape `shape`, if it is an area light in the world.
    pub fn emitter_of_shape(&self, shape: u32) -> Option<u32> {
        self.shape_info.get(shape as usize)?.emitter
    }

    /// Sets the visibility and sampling weight of the emitter on shape
    /// `shape`, in the world or in a shape group (where each instance's
    /// light gets them).
    pub fn set_shape_emitter_options(&mut self, shape: u32, options: EmitterOptions) {
        if let Some(e) = self.emitter_of_shape(shape) {
            self.set_emitter_options(e, options);
        }
        for g in self.group_emitters.iter_mut().filter(|g| g.shape == shape) {
            g.options = options;
        }
    }

    /// Gives each instance a world copy of each emitting shape of its
    /// group, with its own light: light sampling and the light BVH see
    /// every placed light where it is, and a hit through the instance is
    /// reported on the copy (`Scene::placed_shape`). Returns the list the
    /// instances' `placed_emitters` index.
    fn place_group_emitters(&mut self) -> Result<Vec<(u32, u32)>, BuildError> {
        let mut placed = Vec::new();
        // Built once: the scene keeps no list of group emitters.
        let group_emitters = std::mem::take(&mut self.group_emitters);
        for i in 0..self.instances.len() {
            let inst = self.instances[i];
            let start = placed.len() as u32;
            for g in group_emitters.iter().filter(|g| g.group == inst.group) {
                let copy = self.shapes[g.shape as usize]
                    .placed(&inst.to_world, &mut self.meshes)
                    .ok_or(BuildError::StretchedEmittingSphere { shape: g.shape })?;
                let id = self.shapes.len() as u32;
                let emitter = self.add_emitter(g.emitter.on_shape(id));
                self.set_emitter_options(emitter, g.options);
                self.shapes.push(copy);
                self.shape_info.push(ShapeInfo {
                    emitter: Some(emitter),
                    ..self.shape_info[g.shape as usize]
                });
                placed.push((g.shape, id));
            }
            self.instances[i].placed_emitters = (start, placed.len() as u32 - start);
        }
        Ok(placed)
    }

    /// Adds a participating medium; returns its index.
    pub fn add_medium(&mut self, m: crate::medium::Medium) -> u32 {
        self.media.push(m);
        self.media.len() as u32 - 1
    }

    /// Sets the media inside and outside shape `shape`.
    pub fn set_shape_media(
        &mut self,
        shape: u32,
        interior: Option<u32>,
        exterior: Option<u32>,
    ) -> Result<(), BuildError> {
        self.check_medium(interior)?;
        self.check_medium(exterior)?;
        let info = self
            .shape_info
            .get_mut(shape as usize)
            .ok_or(BuildError::BadIndex {
                what: "shape",
                index: shape,
            })?;
        info.interior = interior;
        info.exterior = exterior;
        Ok(())
    }

    /// Sets the medium the camera sits in.
    pub fn camera_medium(&mut self, medium: Option<u32>) -> Result<&mut Self, BuildError> {
        self.check_medium(medium)?;
        self.camera_medium = medium;
        Ok(self)
    }

    fn check_medium(&self, medium: Option<u32>) -> Result<(), BuildError> {
        match medium {
            Some(m) if m as usize >= self.media.len() => Err(BuildError::BadIndex {
                what: "medium",
                index: m,
            }),
            _ => Ok(()),
        }
    }

    /// How next-event estimation will choose emitters.
    pub fn light_selection(&mut self, selection: LightSelection) -> &mut Self {
        self.light_selection = selection;
        self
    }

    /// Whether light sampling may leave to BSDF sampling the light it finds
    /// well ([`crate::integrator::Integrator::mis_compensation`]; off
    /// unless the integrator says so).
    pub fn mis_compensation(&mut self, on: bool) -> &mut Self {
        self.mis_compensation = on;
        self
    }

    /// Whether the integrator leaves hits' uv unread
    /// ([`crate::integrator::Integrator::reads_uv`]); with no textures in
    /// the scene either, shapes may then skip computing it. Off (uv always
    /// computed) unless the integrator says so.
    pub fn uv_unread_by_integrator(&mut self, unread: bool) -> &mut Self {
        self.uv_unread_by_integrator = unread;
        self
    }

    /// Sets the camera.
    pub fn camera(&mut self, c: Camera) -> &mut Self {
        self.camera = Some(c);
        self
    }

    /// True unless the camera set is one that paths from the lights cannot
    /// reach ([`Camera::can_connect`]).
    pub fn camera_can_connect(&self) -> bool {
        self.camera.is_none_or(|c| c.can_connect())
    }

    /// Sets the film.
    pub fn film(&mut self, f: Film) -> &mut Self {
        self.film = f;
        self
    }

    /// Sets the sampler.
    pub fn sampler(&mut self, s: Sampler) -> &mut Self {
        self.sampler = s;
        self
    }

    /// Builds the acceleration structures and returns the scene. Without
    /// a camera, a 45° perspective camera at the origin looking down +z
    /// is used.
    pub fn build(mut self) -> Result<Scene, BuildError> {
        for b in &self.materials.bsdfs {
            if let Bsdf::TwoSided(t) = b {
                for index in [t.front, t.back] {
                    if index as usize >= self.materials.bsdfs.len() {
                        return Err(BuildError::BadIndex {
                            what: "bsdf",
                            index,
                        });
                    }
                }
            }
        }
        let camera = self.camera.unwrap_or_else(|| {
            Camera::Perspective(Perspective::new(
                glam::Affine3A::IDENTITY,
                45.0,
                FovAxis::X,
                self.film.width,
                self.film.height,
                0.01,
                1e4,
            ))
        });
        let placed_emitters = self.place_group_emitters()?;
        // Build the groups' BVHs first: instance bounds need them.
        let mut groups: Vec<Group> = self
            .groups
            .into_iter()
            .map(|items| Group {
                tri_runs: triangle_runs(&items),
                items,
                tris: TrianglePackets::default(),
                only_triangles: false,
                leaf_has_items: Vec::new(),
                bvh: Bvh::default(),
            })
            .collect();
        for gi in (1..groups.len()).chain(std::iter::once(0)) {
            let count = groups[gi].items.len();
            if count > crate::accel::MAX_POSITIONS {
                return Err(BuildError::TooManyPrimitives { count });
            }
            let bounds: Vec<Bounds3> = groups[gi]
                .items
                .par_iter()
                .map(|item| match *item {
                    Item::Triangle { shape, prim } | Item::Prim { shape, prim } => {
                        self.shapes[shape as usize].prim_bounds(&self.meshes, prim)
                    }
                    Item::Empty => Bounds3::EMPTY,
                    Item::Instance(i) => {
                        let inst = &self.instances[i as usize];
                        let local = groups[inst.group as usize].bvh.bounds();
                        if local.is_empty() {
                            return Bounds3::EMPTY;
                        }
                        Bounds3::from_points(local.corners().map(|c| inst.to_world.point(c)))
                    }
                })
                .collect();
            // SAH costs relative to a node visit: a triangle rides in a
            // packet; analytic shapes and instances cost more.
            let items = &groups[gi].items;
            let mut bvh = Bvh::build_with_costs(&bounds, |i| match items[i] {
                Item::Triangle { .. } | Item::Empty => PrimCost::Packed,
                Item::Prim { .. } => PrimCost::Alone(1.0),
                Item::Instance(_) => PrimCost::Alone(4.0),
            });
            let g = &mut groups[gi];
            let order = bvh
                .take_leaf_order_packed()
                .ok_or(BuildError::TooManyPrimitives { count })?;
            // Whether a group holds only triangles does not depend on the
            // order; such a group keeps no item list, so none is permuted.
            g.only_triangles = g
                .items
                .iter()
                .all(|item| matches!(item, Item::Triangle { .. } | Item::Empty));
            let old_items = std::mem::take(&mut g.items);
            let item_at = |i: usize| order[i].map_or(Item::Empty, |p| old_items[p as usize]);
            let (shapes, meshes, runs) = (&self.shapes, &self.meshes, &g.tri_runs);
            let only_triangles = g.only_triangles;
            // Gathering the vertices is random access into the meshes, so
            // it runs in parallel, packet by packet.
            g.tris = TrianglePackets::new(order.len(), |i| {
                let (shape, prim, id) = if only_triangles {
                    // The items are then the runs end to end (a mesh's
                    // triangles are added together, in order): item `p`
                    // is triangle id `p`, and reading the item list, a
                    // random access per triangle, is saved.
                    let id = order[i]?;
                    let (shape, prim) = triangle_of_id(runs, id);
                    (shape, prim, id)
                } else {
                    let Item::Triangle { shape, prim } = item_at(i) else {
                        return None;
                    };
                    // Runs are in the order shapes were added, so sorted
                    // by shape.
                    let run = runs.binary_search_by_key(&shape, |r| r.shape).ok()?;
                    (shape, prim, runs[run].first + prim)
                };
                let Shape::Mesh(m) = shapes[shape as usize] else {
                    return None;
                };
                Some((meshes[m.mesh as usize].triangle(prim as usize), id))
            });
            if !g.only_triangles {
                g.items = (0..order.len()).into_par_iter().map(item_at).collect();
                g.leaf_has_items = (g.items.chunks(crate::shape::PACKET))
                    .map(|leaf| {
                        leaf.iter()
                            .any(|item| matches!(item, Item::Prim { .. } | Item::Instance(_)))
                    })
                    .collect();
            }
            g.bvh = bvh;
        }
        // Emitters hidden from indirect rays cannot be found by BSDF
        // sampling: light sampling must cover them whole.
        let compensated: Vec<bool> = (self.emitter_options.iter())
            .map(|o| self.mis_compensation && o.visible_indirect)
            .collect();
        let light_distributions =
            crate::light::build_distributions(&mut self.emitters, &self.materials, &compensated)
                .map_err(|index| BuildError::BadIndex {
                    what: "image",
                    index,
                })?;
        let environment_emitters = self
            .emitters
            .iter()
            .enumerate()
            .filter(|(_, e)| e.is_environment())
            .map(|(i, _)| i as u32)
            .collect();
        let bsdf_flags: Vec<_> = (self.materials.bsdfs.iter())
            .map(|b| b.flags(&self.materials))
            .collect();
        let diffuse_sides = (self.materials.bsdfs.iter())
            .map(|b| DiffuseSides::of(&self.materials, b))
            .collect();
        let rectangle_lights = (self.emitters.iter().zip(&self.emitter_options))
            .map(|(e, o)| RectangleLight::of(e, o, &self.shapes))
            .collect();
        let has_pass_through = self
            .shape_info
            .iter()
            .any(|info| bsdf_flags[info.bsdf as usize].intersects(crate::bsdf::BsdfFlags::NULL));
        let has_null_transmission = self.shape_info.iter().any(|info| {
            self.materials.bsdfs[info.bsdf as usize].lets_light_through(&self.materials)
        });
        let bounds = groups.first().map_or(Bounds3::EMPTY, |g| g.bvh.bounds());
        let radius = if bounds.is_empty() {
            1.0
        } else {
            0.5 * bounds.extent().length()
        };
        let light_sampler = LightSampler::new(
            self.light_selection,
            &self.emitters,
            &self.emitter_options,
            &compensated,
            &EmitterContext {
                shapes: &self.shapes,
                meshes: &self.meshes,
                images: &self.materials.images,
                materials: &self.materials,
                distributions: &light_distributions,
            },
            radius,
        );
        let uv_unread = self.uv_unread_by_integrator && self.materials.textures.is_empty();
        let free_frame = (self.shape_info.iter())
            .map(|info| {
                let bsdf = &self.materials.bsdfs[info.bsdf as usize];
                uv_unread && bsdf.turns_freely(&self.materials)
            })
            .collect();
        Ok(Scene {
            uv_unread,
            free_frame,
            meshes: self.meshes,
            shapes: self.shapes,
            shape_info: self.shape_info,
            has_pass_through,
            has_null_transmission,
            materials: self.materials,
            emitters: self.emitters,
            emitter_options: self.emitter_options,
            light_sampler,
            environment_emitters,
            light_distributions,
            camera,
            film: self.film,
            sampler: self.sampler,
            media: self.media,
            camera_medium: self.camera_medium,
            groups,
            instances: self.instances,
            placed_emitters,
            bsdf_flags,
            diffuse_sides,
            rectangle_lights,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;
    use crate::sampling::square_to_uniform_sphere;
    use crate::shape::{cube::cube_mesh, Cylinder, Disk, MeshShape, Rectangle, Sphere};
    use glam::{Affine3A, Vec3};

    fn t(m: Affine3A) -> Transform {
        Transform::new(m).unwrap()
    }

    /// Shapes without a BSDF get Mitsuba's default: grey diffuse, black on
    /// emitters.
    #[test]
    fn default_bsdf_is_black_on_emitters() {
        let mut b = SceneBuilder::new();
        let sphere = || Shape::Sphere(Sphere::new(Vec3::ZERO, 1.0, false));
        b.add_shape(sphere(), None, None).unwrap();
        b.add_shape(sphere(), None, Some(crate::Rgb::ONE.into()))
            .unwrap();
        b.camera(crate::camera::Camera::Perspective(
            crate::camera::Perspective::new(
                Affine3A::IDENTITY,
                45.0,
                crate::camera::FovAxis::X,
                4,
                4,
                0.01,
                100.0,
            ),
        ));
        let scene = b.build().unwrap();
        let reflectance =
            |shape: usize| match scene.materials.bsdfs[scene.shape_info[shape].bsdf as usize] {
                Bsdf::Diffuse(d) => d.reflectance,
                other => panic!("{other:?}"),
            };
        assert_eq!(
            reflectance(0),
            crate::texture::Tex::Const(crate::Rgb::splat(0.5))
        );
        assert_eq!(reflectance(1), crate::texture::Tex::Const(crate::Rgb::ZERO));
    }

    /// Every shape kind, in the world and in two instances of a group.
    pub(super) fn mixed_scene() -> Scene {
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
    pub(super) fn random_ray(rng: &mut Pcg32) -> Ray {
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
