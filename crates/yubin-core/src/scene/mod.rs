//! The scene: geometry in a two-level hierarchy, materials, emitters,
//! camera, film and sampler; and [`SceneBuilder`], the API for building
//! one in code (the scene-file front ends use it too).
//!
//! Geometry is a list of groups, each with its own BVH over *items*; an
//! item is a primitive of a shape or an instance of another group. Group
//! 0 is the world; `shapegroup`s are further groups, referenced by
//! instances (a transform and a group), so instanced geometry is stored
//! once. Instances nest one level, as in Mitsuba.
//!
//! The module is split by concern:
//!
//! - this file: [`Scene`] and the records it hands out ([`ShapeInfo`],
//!   [`HitRecord`], [`ShadowHit`], [`ShapeEmitter`]), with the per-shape
//!   accessors;
//! - `traversal.rs`: groups, items and instances, and the single-ray
//!   closest-hit and any-hit kernels over them;
//! - `packet.rs`: closest and any hits of eight rays at once in small
//!   trees;
//! - `build.rs`: [`SceneBuilder`] and [`BuildError`]: checking what was
//!   added and building the BVHs and the per-BSDF and per-shape tables;
//! - `media.rs`: what shadow rays and media see of surfaces
//!   (pass-through surfaces, transmittance, the medium on either side);
//! - `emitters.rs`: emitter queries.

mod build;
mod emitters;
mod media;
mod packet;
mod parameters;
mod traversal;
mod worlds;

pub use build::{BuildError, SceneBuilder};
pub use parameters::{EditTarget, Editable, RebuildCounts};
pub use worlds::{LightView, PortalSide, Traced, World, MAX_CROSSINGS};

use crate::bsdf::Material;
use crate::camera::Camera;
use crate::film::Film;
use crate::interaction::SurfaceInteraction;
use crate::light::{AreaLight, Emitter, EmitterOptions};
use crate::material::Materials;
use crate::math::Bounds3;
use crate::sampler::Sampler;
use crate::shape::{PrimHit, Shape, TriangleMesh};
use crate::texture::Tex;
use traversal::{Group, Instance};

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
/// straddling the stores that wrote it, which the CPU cannot forward,
/// and the interaction would wait for them. Only here: padded in the
/// traversal's inner loop, where a hit is stored at every closer
/// candidate, the wider stores slowed single-ray closest hits.
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

/// A scene ready to render: what the scene describes. What a render
/// builds from it for its integrator (the light sampler, the emitters'
/// sampling distributions, the integrators' own tables) the render holds
/// (`render::RenderState`).
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
    /// Emitters, as the scene describes them: a render samples its own
    /// copies, which refer to its sampling distributions.
    pub emitters: Vec<Emitter>,
    /// Per emitter: visibility and sampling weight.
    pub emitter_options: Vec<EmitterOptions>,
    /// Indices of emitters at infinity (hit by escaping rays) of world 0.
    pub environment_emitters: Vec<u32>,
    /// The worlds (`worlds[0]` is the camera's; see `scene/worlds.rs`).
    pub worlds: Vec<World>,
    /// Per shape, the portal side it is (empty when there are no portals).
    pub(crate) portals: Vec<Option<PortalSide>>,
    /// Per emitter, its world.
    pub(crate) emitter_world: Vec<u32>,
    /// The camera.
    pub camera: Camera,
    /// When the camera's samples are taken.
    pub shutter: crate::camera::Shutter,
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
    /// [`Material::flags`](crate::bsdf::Material::flags) of each BSDF
    /// of [`Materials::bsdfs`], asked at every bounce: taken once (nested
    /// BSDFs ask theirs recursively).
    bsdf_flags: Vec<crate::bsdf::BsdfFlags>,
    /// Some shape's BSDF lets light through (`null`, `mask`): shadow rays
    /// may have to look past their first hit.
    has_pass_through: bool,
    /// Some shape lets light straight through with `thindielectric` slabs
    /// counted ([`Material::lets_light_through`]).
    has_null_transmission: bool,
    /// Nothing reads a hit's uv: the scene has no textures and its
    /// integrator writes no uv ([`SceneBuilder::uv_unread_by_integrator`]);
    /// spheres then skip their angles' arctangents.
    uv_unread: bool,
    /// Per shape, whether its hits may take any shading frame about the
    /// normal: nothing reads uv (`uv_unread`) and its BSDF turns freely
    /// ([`Material::turns_freely`]); spheres and disks then build theirs from
    /// the normal alone ([`crate::shape::Sphere::interaction_free_frame`]).
    free_frame: Vec<bool>,
    /// Editable objects and what updates rebuild ([`Scene::update`]).
    edits: parameters::Edits,
}

impl Scene {
    /// Gives the camera what it needs of the built scene: a `distant`
    /// sensor its bounding sphere.
    pub(crate) fn settle_camera(&mut self) {
        if let crate::camera::Camera::Distant(d) = self.camera {
            self.camera = crate::camera::Camera::Distant(d.with_scene_bounds(self.bounds()));
        }
    }

    /// World-space bounds of all geometry.
    pub fn bounds(&self) -> Bounds3 {
        self.groups
            .first()
            .map_or(Bounds3::EMPTY, |g| g.bvh.bounds())
    }

    /// Shape of the top-level BVH (for benchmarks and tuning).
    pub fn bvh_stats(&self) -> crate::accel::BvhStats {
        self.groups[0].bvh.stats()
    }

    /// The BSDF of a shape.
    #[inline]
    pub fn bsdf_of(&self, shape: u32) -> &Material {
        &self.materials.bsdfs[self.shape_info[shape as usize].bsdf as usize]
    }

    /// The flags of a shape's BSDF
    /// ([`Material::flags`](crate::bsdf::Material::flags)), as
    /// [`SceneBuilder::build`] took them: a scene whose BSDFs change is
    /// built again.
    #[inline]
    pub fn bsdf_flags_of(&self, shape: u32) -> crate::bsdf::BsdfFlags {
        self.bsdf_flags[self.shape_info[shape as usize].bsdf as usize]
    }
}
