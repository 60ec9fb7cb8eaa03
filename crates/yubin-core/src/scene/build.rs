//! [`SceneBuilder`], which builds a [`Scene`] piece by piece and checks
//! every index it is given, and [`BuildError`]. [`SceneBuilder::build`]
//! checks the BSDF references, places the emitters of shape groups in
//! every instance, builds each group's BVH and lays its items and
//! triangle packets out in leaf order, fits the emitters to the scene's
//! data, and makes the per-BSDF and per-shape tables read at every hit.

use super::parameters::{EditTarget, Editable, Edits, GroupEntry};
use super::traversal::{triangle_of_id, Group, Instance, Item, TriangleRun};
use super::{Scene, ShapeEmitter, ShapeInfo};
use crate::accel::{Bvh, PrimCost};
use crate::bsdf::{Diffuse, Material};
use crate::camera::{Camera, FovAxis, Perspective, Shutter};
use crate::film::Film;
use crate::light::{Emitter, EmitterOptions};
use crate::material::Materials;
use crate::math::{Bounds3, Transform};
use crate::sampler::Sampler;
use crate::shape::{Shape, ShapeModel, TriangleMesh, TrianglePackets};
use crate::texture::{AttributeSlot, Tex, TexImage, Texture};
use rayon::prelude::*;

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
    /// Portals in a scene with surfaces that let shadow rays through
    /// (`null`, `mask`, `thindielectric` slabs) or with media, which the
    /// world-aware shadow rays do not cross yet.
    PortalsWithPassThrough,
    /// A composite BSDF nesting more BSDFs than the BSDF at a vertex holds
    /// ([`crate::bsdf::MAX_NODES`] nodes, [`crate::bsdf::MAX_LOBES`]
    /// single models).
    CompositeTooLarge {
        /// The BSDF.
        bsdf: u32,
        /// Nodes and single models it resolves to.
        size: (usize, usize),
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
            BuildError::PortalsWithPassThrough => write!(
                f,
                "portals do not yet combine with null, mask or thindielectric surfaces or \
                 with media (shadow rays through them stay in one world)"
            ),
            BuildError::CompositeTooLarge { bsdf, size } => write!(
                f,
                "composite BSDF {bsdf} nests {} BSDFs, {} of them single models; the BSDF \
                 at a vertex holds at most {} nested BSDFs and {} single models",
                size.0,
                size.1,
                crate::bsdf::MAX_NODES,
                crate::bsdf::MAX_LOBES
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
    uv_unread_by_integrator: bool,
    instances: Vec<Instance>,
    group_emitters: Vec<GroupEmitter>,
    camera: Option<Camera>,
    shutter: Shutter,
    film: Film,
    sampler: Sampler,
    media: Vec<crate::medium::Medium>,
    camera_medium: Option<u32>,
    /// What [`crate::Scene::update`] needs: editable objects, groups'
    /// contents in order.
    edits: Edits,
    /// Per world, its root group (world 0: group 0).
    world_groups: Vec<u32>,
    /// Per emitter, its world (missing ones: world 0).
    emitter_world: Vec<u32>,
    /// The portal sides: (shape, its world, where it leads).
    portal_sides: Vec<(u32, u32, crate::scene::PortalSide)>,
}

impl Default for SceneBuilder {
    fn default() -> Self {
        Self::new()
    }
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
            uv_unread_by_integrator: false,
            instances: Vec::new(),
            group_emitters: Vec::new(),
            camera: None,
            shutter: Shutter::INSTANT,
            film: Film::default(),
            sampler: Sampler::default(),
            media: Vec::new(),
            camera_medium: None,
            edits: Edits::new(),
            world_groups: vec![0],
            emitter_world: Vec::new(),
            portal_sides: Vec::new(),
        }
    }

    /// Shapes added so far (the next shape's index).
    pub fn shape_count(&self) -> u32 {
        self.shapes.len() as u32
    }

    /// Whether any portal has been added.
    pub fn has_portals(&self) -> bool {
        !self.portal_sides.is_empty()
    }

    /// Creates an empty world (its own root group and environment);
    /// returns its index.
    pub fn add_world(&mut self) -> u32 {
        let group = self.add_group();
        self.world_groups.push(group);
        self.world_groups.len() as u32 - 1
    }

    /// The root group of world `world`.
    pub fn world_group(&self, world: u32) -> Option<u32> {
        self.world_groups.get(world as usize).copied()
    }

    /// The world whose root is `group`, if it is one.
    pub fn world_of_group(&self, group: u32) -> Option<u32> {
        self.world_groups
            .iter()
            .position(|g| *g == group)
            .map(|w| w as u32)
    }

    /// Puts emitter `emitter` in world `world`.
    pub fn set_emitter_world(&mut self, emitter: u32, world: u32) {
        if self.emitter_world.len() <= emitter as usize {
            self.emitter_world.resize(emitter as usize + 1, 0);
        }
        self.emitter_world[emitter as usize] = world;
    }

    /// Joins shapes `a` (in world `world_a`) and `b` (in `world_b`) as the
    /// two sides of a portal; `a_to_b` maps `a`'s space onto `b`'s.
    pub fn add_portal(&mut self, a: u32, world_a: u32, b: u32, world_b: u32, a_to_b: Transform) {
        let b_to_a = a_to_b.inverse();
        self.portal_sides
            .push((a, world_a, crate::scene::PortalSide::new(world_b, a_to_b)));
        self.portal_sides
            .push((b, world_b, crate::scene::PortalSide::new(world_a, b_to_a)));
    }

    /// Makes an object editable under its key ([`Scene::parameters`],
    /// [`Scene::update`]): what its plugin read and where it is.
    pub fn record(&mut self, editable: Editable) {
        self.edits.editables.push(editable);
    }

    /// Adds a BSDF; returns its index (for shapes and composite BSDFs).
    pub fn add_bsdf(&mut self, b: Material) -> u32 {
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
    pub fn bsdf(&self, index: u32) -> Option<&Material> {
        self.materials.bsdfs.get(index as usize)
    }

    /// True when BSDF `index` reads a normal map in MikkTSpace
    /// ([`Material::needs_mikktspace`]).
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
        self.edits.counts.meshes_added += 1;
        self.meshes.len() as u32 - 1
    }

    /// Creates an empty shape group; returns its index.
    pub fn add_group(&mut self) -> u32 {
        self.edits.add_group()
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
        if group >= self.edits.group_count() {
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
                self.add_bsdf(Material::Diffuse(Diffuse::new(crate::Rgb::ZERO)))
            }
            None => self.add_bsdf(Material::Diffuse(Diffuse::default())),
        };
        let id = self.shapes.len() as u32;
        let world = self.world_of_group(group);
        let (emitter, grouped) = if world.is_some() {
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
            let e = self.add_emitter(e.on_shape(id));
            self.set_emitter_world(e, world.unwrap_or(0));
            e
        });
        let prims = shape.prim_count(&self.meshes);
        self.shapes.push(shape);
        self.shape_info.push(ShapeInfo {
            bsdf,
            emitter,
            interior: None,
            exterior: None,
        });
        let entry = GroupEntry::Shape { shape: id, prims };
        self.edits.add_to_group(group, entry);
        Ok(id)
    }

    /// Places group `group` in the world with `to_world`.
    pub fn add_instance(&mut self, group: u32, to_world: Transform) -> Result<u32, BuildError> {
        if group == 0 || group >= self.edits.group_count() {
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
        let index = self.instances.len() as u32 - 1;
        self.edits.add_to_group(0, GroupEntry::Instance(index));
        Ok(index)
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

    /// Whether the integrator leaves hits' uv unread
    /// (its `Integrator::reads_uv`); with no textures in
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

    /// The camera set so far.
    pub fn current_camera(&self) -> Option<Camera> {
        self.camera
    }

    /// True unless the camera set is one that paths from the lights cannot
    /// reach ([`Camera::can_connect`]).
    pub fn camera_can_connect(&self) -> bool {
        self.camera.is_none_or(|c| c.can_connect())
    }

    /// Sets when the camera's samples are taken.
    pub fn shutter(&mut self, s: Shutter) -> &mut Self {
        self.shutter = s;
        self
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
        self.check_bsdf_references()?;
        self.check_editables()?;
        let camera = self.camera_or_default();
        let placed_emitters = self.place_group_emitters()?;
        let groups = self.build_groups()?;
        self.prepare_emitters()?;
        let mut emitter_world = std::mem::take(&mut self.emitter_world);
        emitter_world.resize(self.emitters.len(), 0);
        let environments =
            world_environments(&self.emitters, &emitter_world, self.world_groups.len());
        let environment_emitters = environments[0].clone();
        let mut worlds: Vec<_> = (self.world_groups.iter().zip(environments))
            .map(|(&group, environment)| crate::scene::World {
                group,
                environment,
                lit_sides: Vec::new(),
            })
            .collect();
        let mut portals = Vec::new();
        if !self.portal_sides.is_empty() {
            portals.resize(self.shapes.len(), None);
            for &(shape, world, side) in &self.portal_sides {
                portals[shape as usize] = Some(side);
                if side.lit_through {
                    worlds[world as usize].lit_sides.push(shape);
                }
            }
        }
        let bsdf_flags: Vec<_> = (self.materials.bsdfs.iter())
            .map(|b| b.flags(&self.materials))
            .collect();
        let (has_pass_through, has_null_transmission) = self.pass_through(&bsdf_flags);
        if !self.portal_sides.is_empty() && (has_pass_through || !self.media.is_empty()) {
            return Err(BuildError::PortalsWithPassThrough);
        }
        let uv_unread = self.uv_unread_by_integrator && self.materials.textures.is_empty();
        let free_frame = self.free_frames(uv_unread);
        let mut scene = Scene {
            edits: self.edits,
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
            environment_emitters,
            worlds,
            portals,
            emitter_world,
            camera,
            shutter: self.shutter,
            film: self.film,
            sampler: self.sampler,
            media: self.media,
            camera_medium: self.camera_medium,
            groups,
            instances: self.instances,
            placed_emitters,
            bsdf_flags,
        };
        scene.settle_camera();
        Ok(scene)
    }

    /// Checks that the BSDFs a `twosided` refers to exist (the other
    /// indices were checked as they were added), and that every composite
    /// fits the BSDF at a vertex.
    fn check_bsdf_references(&self) -> Result<(), BuildError> {
        for b in &self.materials.bsdfs {
            if let Material::TwoSided(t) = b {
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
        (0..self.materials.bsdfs.len() as u32).try_for_each(|i| self.check_composite_size(i))
    }

    /// Checks that BSDF `bsdf` (an index already checked) fits the BSDF at
    /// a vertex ([`crate::bsdf::MAX_NODES`], [`crate::bsdf::MAX_LOBES`]).
    pub fn check_composite_size(&self, bsdf: u32) -> Result<(), BuildError> {
        let size = self.materials.bsdfs[bsdf as usize].tree_size(&self.materials);
        if size.0 > crate::bsdf::MAX_NODES || size.1 > crate::bsdf::MAX_LOBES {
            return Err(BuildError::CompositeTooLarge { bsdf, size });
        }
        Ok(())
    }

    /// Checks that every recorded object's place exists
    /// ([`SceneBuilder::record`]).
    fn check_editables(&self) -> Result<(), BuildError> {
        for e in &self.edits.editables {
            let (what, index, len) = match e.target {
                EditTarget::Bsdf(i) => ("bsdf", i, self.materials.bsdfs.len()),
                EditTarget::Texture(i) => ("texture", i, self.materials.textures.len()),
                EditTarget::Emitter(i) | EditTarget::AreaEmitter(i) => {
                    ("emitter", i, self.emitters.len())
                }
                EditTarget::Shape(i) => ("shape", i, self.shapes.len()),
                EditTarget::Instance(i) => ("instance", i, self.instances.len()),
                EditTarget::Medium(i) => ("medium", i, self.media.len()),
                EditTarget::Sensor => continue,
            };
            if index as usize >= len {
                return Err(BuildError::BadIndex { what, index });
            }
        }
        Ok(())
    }

    /// The camera set, or a 45° perspective camera at the origin looking
    /// down +z that fills the film.
    fn camera_or_default(&self) -> Camera {
        self.camera.unwrap_or_else(|| {
            Camera::Perspective(Perspective::new(
                glam::Affine3A::IDENTITY,
                45.0,
                FovAxis::X,
                self.film.width,
                self.film.height,
                0.01,
                1e4,
            ))
        })
    }

    /// The groups with their BVHs, their items in leaf order and their
    /// triangles in packets. The shape groups are built first and the
    /// world last: instance bounds need the BVHs of their groups.
    fn build_groups(&mut self) -> Result<Vec<Group>, BuildError> {
        let mut groups: Vec<Group> = (0..self.edits.group_count() as usize)
            .map(|gi| unbuilt_group(self.edits.group_items(gi, &self.shapes)))
            .collect();
        let geometry = Geometry {
            shapes: &self.shapes,
            meshes: &self.meshes,
            instances: &self.instances,
        };
        for gi in (1..groups.len()).chain(std::iter::once(0)) {
            build_group(&mut groups, gi, &geometry)?;
            self.edits.counts.bvh_builds += 1;
        }
        Ok(groups)
    }

    /// Fits the emitters to the scene's data and checks the images they
    /// name ([`crate::light::prepare_emitters`]).
    fn prepare_emitters(&mut self) -> Result<(), BuildError> {
        crate::light::prepare_emitters(&mut self.emitters, &self.materials).map_err(|index| {
            BuildError::BadIndex {
                what: "image",
                index,
            }
        })
    }

    /// Whether some shape's BSDF lets light through (`null`, `mask`; by
    /// `bsdf_flags`, per BSDF), and whether some shape lets light
    /// straight through with `thindielectric` slabs counted.
    fn pass_through(&self, bsdf_flags: &[crate::bsdf::BsdfFlags]) -> (bool, bool) {
        pass_through(&self.shape_info, &self.materials, bsdf_flags)
    }

    /// Per shape, whether its hits may take any shading frame about the
    /// normal: nothing reads uv (`uv_unread`) and its BSDF turns freely.
    fn free_frames(&self, uv_unread: bool) -> Vec<bool> {
        free_frames(&self.shape_info, &self.materials, uv_unread)
    }
}

/// Indices of the emitters at infinity.
/// Per world (`worlds` of them), its emitters at infinity.
pub(super) fn world_environments(
    emitters: &[Emitter],
    emitter_world: &[u32],
    worlds: usize,
) -> Vec<Vec<u32>> {
    let mut lists = vec![Vec::new(); worlds.max(1)];
    for e in environment_emitters(emitters) {
        let w = emitter_world.get(e as usize).map_or(0, |w| *w as usize);
        if let Some(list) = lists.get_mut(w) {
            list.push(e);
        }
    }
    lists
}

pub(super) fn environment_emitters(emitters: &[Emitter]) -> Vec<u32> {
    (emitters.iter().enumerate())
        .filter(|(_, e)| e.is_environment())
        .map(|(i, _)| i as u32)
        .collect()
}

/// Whether some shape's BSDF lets light through (`null`, `mask`; by
/// `bsdf_flags`, per BSDF), and whether some shape lets light straight
/// through with `thindielectric` slabs counted.
pub(super) fn pass_through(
    shape_info: &[ShapeInfo],
    materials: &Materials,
    bsdf_flags: &[crate::bsdf::BsdfFlags],
) -> (bool, bool) {
    let has_pass_through = (shape_info.iter())
        .any(|info| bsdf_flags[info.bsdf as usize].intersects(crate::bsdf::BsdfFlags::NULL));
    let has_null_transmission = (shape_info.iter())
        .any(|info| materials.bsdfs[info.bsdf as usize].lets_light_through(materials));
    (has_pass_through, has_null_transmission)
}

/// Per shape, whether its hits may take any shading frame about the
/// normal: nothing reads uv (`uv_unread`) and its BSDF turns freely.
pub(super) fn free_frames(
    shape_info: &[ShapeInfo],
    materials: &Materials,
    uv_unread: bool,
) -> Vec<bool> {
    (shape_info.iter())
        .map(|info| {
            let bsdf = &materials.bsdfs[info.bsdf as usize];
            uv_unread && bsdf.turns_freely(materials)
        })
        .collect()
}

/// What a group's BVH is built over.
pub(super) struct Geometry<'a> {
    pub(super) shapes: &'a [Shape],
    pub(super) meshes: &'a [TriangleMesh],
    pub(super) instances: &'a [Instance],
}

/// Builds the BVH of group `gi` of `groups` (whose items are in the order
/// they were added) and lays the group out in its leaf order; the groups
/// its instances place must be built already.
pub(super) fn build_group(
    groups: &mut [Group],
    gi: usize,
    geometry: &Geometry,
) -> Result<(), BuildError> {
    let count = groups[gi].items.len();
    if count > crate::accel::MAX_POSITIONS {
        return Err(BuildError::TooManyPrimitives { count });
    }
    let bounds = item_bounds(&groups[gi].items, groups, geometry);
    let items = &groups[gi].items;
    let mut bvh = Bvh::build_with_costs(&bounds, |i| item_cost(items[i], geometry.shapes));
    let g = &mut groups[gi];
    let order = bvh
        .take_leaf_order_packed()
        .ok_or(BuildError::TooManyPrimitives { count })?;
    lay_out_in_leaf_order(g, &order, geometry.shapes, geometry.meshes);
    g.bvh = bvh;
    Ok(())
}

/// The world bounds of each of `items`; an instance's are its group's
/// (in `groups`, built already), transformed.
fn item_bounds(items: &[Item], groups: &[Group], geometry: &Geometry) -> Vec<Bounds3> {
    items
        .par_iter()
        .map(|item| match *item {
            Item::Triangle { shape, prim } | Item::Prim { shape, prim } => {
                geometry.shapes[shape as usize].prim_bounds(geometry.meshes, prim)
            }
            Item::Empty => Bounds3::EMPTY,
            Item::Instance(i) => {
                let inst = &geometry.instances[i as usize];
                let local = groups[inst.group as usize].bvh.bounds();
                if local.is_empty() {
                    return Bounds3::EMPTY;
                }
                Bounds3::from_points(local.corners().map(|c| inst.to_world.point(c)))
            }
        })
        .collect()
}

/// A group of `items` in the order they were added, its BVH not built.
pub(super) fn unbuilt_group(items: Vec<Item>) -> Group {
    Group {
        tri_runs: triangle_runs(&items),
        items,
        tris: TrianglePackets::default(),
        only_triangles: false,
        leaf_has_items: Vec::new(),
        bvh: Bvh::default(),
    }
}

/// What testing `item` costs for the SAH, relative to a node visit: a
/// triangle rides in a packet; analytic shapes and instances cost more.
fn item_cost(item: Item, shapes: &[Shape]) -> PrimCost {
    match item {
        Item::Triangle { .. } | Item::Empty => PrimCost::Packed,
        Item::Prim { shape, .. } => PrimCost::Alone(shapes[shape as usize].intersect_cost()),
        Item::Instance(_) => PrimCost::Alone(4.0),
    }
}

/// Lays group `g` out in its BVH's packed leaf order `order`
/// ([`Bvh::take_leaf_order_packed`]): its triangles' vertices gathered
/// into packets, its items (unless it holds only triangles) permuted,
/// and per leaf whether it holds other items.
fn lay_out_in_leaf_order(
    g: &mut Group,
    order: &[Option<u32>],
    shapes: &[Shape],
    meshes: &[TriangleMesh],
) {
    // Whether a group holds only triangles does not depend on the
    // order; such a group keeps no item list, so none is permuted.
    g.only_triangles = g
        .items
        .iter()
        .all(|item| matches!(item, Item::Triangle { .. } | Item::Empty));
    let old_items = std::mem::take(&mut g.items);
    let item_at = |i: usize| order[i].map_or(Item::Empty, |p| old_items[p as usize]);
    let runs = &g.tri_runs;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::Sphere;
    use glam::{Affine3A, Vec3};

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
                Material::Diffuse(d) => d.reflectance,
                other => panic!("{other:?}"),
            };
        assert_eq!(
            reflectance(0),
            crate::texture::Tex::Const(crate::Rgb::splat(0.5))
        );
        assert_eq!(reflectance(1), crate::texture::Tex::Const(crate::Rgb::ZERO));
    }
}
