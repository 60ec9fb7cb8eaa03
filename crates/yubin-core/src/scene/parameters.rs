//! Scene parameters: every editable value of a loaded scene under a
//! stable key, read with [`Scene::parameters`] and changed in place with
//! [`Scene::update`], in the manner of Mitsuba 3's `traverse()` and
//! `SceneParameters.update()`.
//!
//! **Keys.** An object's key is its `id` in the scene file; an object
//! without one is named by its parent's key and its role (`light.emitter`,
//! `wall.bsdf`, `red.reflectance` for a nested texture, `sensor.film`), a
//! top-level object without one by its plugin type (`sphere`, `envmap`),
//! the sensor without one `sensor`; a name already taken gets `_1`, `_2`,
//! … A parameter's key is the object's key and the parameter's name;
//! colours and constant textures end in `.value`, as Mitsuba names a
//! constant texture's value: `red.reflectance.value`,
//! `light.emitter.radiance.value`, `sensor.to_world`, `sensor.x_fov`,
//! `fog.sigma_t.value`.
//!
//! **Updates** are made by building the object again from what its
//! plugin read at load ([`crate::params::Record`]) with the one value
//! changed, through the plugin's own `from_params`: a value is validated
//! exactly as the loader validates it, and the object equals what a fresh
//! load of the edited file builds. Then only what depends on the object
//! is refreshed:
//!
//! | edited | refreshed |
//! |---|---|
//! | a BSDF | its flags and the per-shape shading tables (no geometry) |
//! | a texture | every BSDF's tables, and the lights (a textured emitter's power) |
//! | an emitter | the light distributions and the light sampler |
//! | the sensor | the camera, film and sampler |
//! | a medium | the medium |
//! | an analytic shape (`to_world`, radius, …) | the BVH of its group, the top level, the lights |
//! | an instance's `to_world` | the top-level BVH and the lights |
//!
//! Editing a `to_world` forgets the `<lookat>` target it came from, as a
//! fresh load of a file that gives a `<matrix>` would: a `thinlens` or
//! `physical` camera that focused there then needs its
//! `focus_distance`.
//!
//! [`Scene::rebuild_counts`] counts BVH builds and meshes added, so a
//! test can show that an edit rebuilt nothing it did not need to.
//! Not editable: mesh shapes (their file is not read again; place a mesh
//! in a `shapegroup` and move its `instance`), file names (images,
//! grids), which object a reference points to, an edit that changes
//! which meshes need MikkTSpace tangents (a normal map's
//! `tangent_space`), the sampler's `seed`
//! (the render's, not the scene's), and emitting shapes in shape groups
//! and the instances that place them (each instance holds a copy).

use super::build::{
    build_group, free_frames, pass_through, unbuilt_group, world_environments, BuildError, Geometry,
};
use super::traversal::Item;
use super::Scene;
use crate::camera::Sensor;
use crate::light::{AreaLight, DirectionalAreaLight, Emitter, EmitterOptions};
use crate::params::{
    plugin_of, ColorKind, ParamError, ParamValue, Parameter, Params, Record, Replay,
};
use crate::shape::{BuiltShape, Shape};
use crate::Rgb;

/// What an editable object is in the scene's tables.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EditTarget {
    /// A BSDF, by index into [`crate::material::Materials::bsdfs`].
    Bsdf(u32),
    /// A texture, by index into [`crate::material::Materials::textures`].
    Texture(u32),
    /// An emitter that is not on a shape, by index into `Scene::emitters`.
    Emitter(u32),
    /// The `area` or `directionalarea` emitter of a shape, by emitter
    /// index.
    AreaEmitter(u32),
    /// An analytic shape, by index into `Scene::shapes`.
    Shape(u32),
    /// A shape-group instance, by index.
    Instance(u32),
    /// The sensor: camera, film and sampler.
    Sensor,
    /// A participating medium, by index into `Scene::media`.
    Medium(u32),
}

/// One editable object: its key, where it is, and what its plugin read.
#[derive(Clone, Debug)]
pub struct Editable {
    /// The object's key (`red`, `light.emitter`).
    pub key: String,
    /// Where it lives in the scene.
    pub target: EditTarget,
    /// What its plugin read at load.
    pub record: Record,
}

/// How many times a scene has built expensive things, from its load on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RebuildCounts {
    /// BVHs built (one per shape group, the world's included).
    pub bvh_builds: u64,
    /// Triangle meshes added.
    pub meshes_added: u64,
}

/// One entry of a group in the order it was added: a shape's primitives
/// or an instance. A group's BVH is built again from these, in the same
/// order, so an update gives the tree a fresh load builds.
#[derive(Clone, Copy, Debug)]
pub(super) enum GroupEntry {
    /// The primitives `0..prims` of shape `shape`.
    Shape { shape: u32, prims: u32 },
    /// An instance, by index.
    Instance(u32),
}

impl GroupEntry {
    /// Appends the entry's BVH items to `out`.
    fn push_items(self, shapes: &[Shape], out: &mut Vec<Item>) {
        match self {
            GroupEntry::Shape { shape, prims } => {
                let is_mesh = matches!(shapes[shape as usize], Shape::Mesh(_));
                out.extend((0..prims).map(|prim| {
                    if is_mesh {
                        Item::Triangle { shape, prim }
                    } else {
                        Item::Prim { shape, prim }
                    }
                }));
            }
            GroupEntry::Instance(i) => out.push(Item::Instance(i)),
        }
    }
}

/// What a scene keeps so that it can be updated, and the builder's
/// record of what each group holds.
#[derive(Clone, Debug)]
pub(super) struct Edits {
    pub(super) editables: Vec<Editable>,
    /// Per group, its entries in the order they were added.
    group_entries: Vec<Vec<GroupEntry>>,
    pub(super) counts: RebuildCounts,
}

impl Edits {
    pub(super) fn new() -> Self {
        Self {
            editables: Vec::new(),
            group_entries: vec![Vec::new()],
            counts: RebuildCounts::default(),
        }
    }

    /// Adds an empty shape group; returns its index.
    pub(super) fn add_group(&mut self) -> u32 {
        self.group_entries.push(Vec::new());
        self.group_entries.len() as u32 - 1
    }

    /// How many groups there are, the world's included.
    pub(super) fn group_count(&self) -> u32 {
        self.group_entries.len() as u32
    }

    /// Adds `entry` to group `group` (which exists).
    pub(super) fn add_to_group(&mut self, group: u32, entry: GroupEntry) {
        self.group_entries[group as usize].push(entry);
    }

    /// The BVH items of group `gi`, in the order they were added.
    pub(super) fn group_items(&self, gi: usize, shapes: &[Shape]) -> Vec<Item> {
        let mut items = Vec::new();
        for entry in &self.group_entries[gi] {
            entry.push_items(shapes, &mut items);
        }
        items
    }

    /// The group holding shape `shape`.
    fn group_of_shape(&self, shape: u32) -> Option<usize> {
        (self.group_entries.iter()).position(|entries| {
            (entries.iter()).any(|e| matches!(e, GroupEntry::Shape { shape: s, .. } if *s == shape))
        })
    }
}

impl Scene {
    /// Every editable parameter of the scene with its key, kind and
    /// value (see the module docs for the keys).
    pub fn parameters(&self) -> Vec<Parameter> {
        let mut out = Vec::new();
        for e in &self.edits.editables {
            e.record.parameters(&e.key, &mut out);
        }
        out
    }

    /// How many BVHs the scene has built and meshes it has been given,
    /// from its load on.
    pub fn rebuild_counts(&self) -> RebuildCounts {
        self.edits.counts
    }

    /// Sets parameter `key` ([`Scene::parameters`]) to `value`, validated
    /// as the scene loader validates it, and rebuilds what depends on it.
    /// An unknown key, a value of the wrong type or one out of range is
    /// an error naming the key, and the scene is then unchanged.
    pub fn update(&mut self, key: &str, value: ParamValue) -> Result<(), ParamError> {
        let (index, path) = self.editable_of(key).ok_or_else(|| {
            ParamError(format!(
                "unknown scene parameter \"{key}\" (Scene::parameters lists them)"
            ))
        })?;
        if self.edits.editables[index].target == EditTarget::Sensor && path == "sampler.seed" {
            return Err(ParamError(format!(
                "scene parameter \"{key}\" is the render's, not the scene's: \
                 set RenderSettings::seed (yubin render --seed)"
            )));
        }
        let mut record = self.edits.editables[index].record.clone();
        (record.set(path, value))
            .map_err(|msg| ParamError(format!("scene parameter \"{key}\" {msg}")))?;
        let target = self.edits.editables[index].target;
        (self.rebuild(target, &record))
            .map_err(|e| ParamError(format!("scene parameter \"{key}\": {e}")))?;
        self.edits.editables[index].record = record;
        // A moved shape or a new sensor: a distant sensor's reach.
        self.settle_camera();
        Ok(())
    }

    /// The editable object `key` belongs to (the longest key that
    /// prefixes it) and the rest of the key.
    fn editable_of<'k>(&self, key: &'k str) -> Option<(usize, &'k str)> {
        (self.edits.editables.iter().enumerate())
            .filter_map(|(i, e)| {
                let rest = key.strip_prefix(e.key.as_str())?.strip_prefix('.')?;
                Some((i, rest, e.key.len()))
            })
            .max_by_key(|&(_, _, len)| len)
            .map(|(i, rest, _)| (i, rest))
    }

    /// Builds `target` again from `record` and refreshes what depends on
    /// it; on an error nothing has changed.
    fn rebuild(&mut self, target: EditTarget, record: &Record) -> Result<(), ParamError> {
        let mut replay = Replay::new(record, &self.materials);
        match target {
            EditTarget::Bsdf(i) => {
                let build = plugin_of(&replay, "bsdf", crate::bsdf::PLUGINS, None)?;
                let bsdf = build(&mut replay)?;
                // Whether a shape has MikkTSpace tangents (or a cube is a
                // mesh) was decided at load from its BSDF.
                let tangents = self.mikktspace_needs();
                let old = self.materials.bsdfs[i as usize];
                self.materials.replace_bsdf(i, bsdf);
                if self.mikktspace_needs() != tangents {
                    self.materials.replace_bsdf(i, old);
                    return Err(ParamError(
                        "this edit changes which meshes need MikkTSpace tangents, which \
                         are made at load: load the scene again"
                            .to_string(),
                    ));
                }
                self.refresh_materials();
            }
            EditTarget::Texture(i) => {
                let build = plugin_of(&replay, "texture", crate::texture::PLUGINS, None)?;
                self.materials.textures[i as usize] = build(&mut replay)?;
                // BSDFs keep tables made from their textures' means.
                self.materials.prepare_bsdfs();
                self.refresh_materials();
            }
            EditTarget::Emitter(i) => {
                let options = EmitterOptions::from_params(&mut replay)?;
                let build = plugin_of(&replay, "emitter", crate::light::PLUGINS, None)?;
                let emitter = self.prepared(build(&mut replay)?)?;
                self.emitters[i as usize] = emitter;
                self.emitter_options[i as usize] = options;
                let lists =
                    world_environments(&self.emitters, &self.emitter_world, self.worlds.len());
                self.environment_emitters = lists[0].clone();
                for (world, list) in self.worlds.iter_mut().zip(lists) {
                    world.environment = list;
                }
            }
            EditTarget::AreaEmitter(i) => {
                let radiance = replay.texture_or("radiance", ColorKind::Illuminant, Rgb::ONE)?;
                let options = EmitterOptions::from_params(&mut replay)?;
                let emitter = match self.emitters[i as usize] {
                    Emitter::Area(a) => Emitter::Area(AreaLight { radiance, ..a }),
                    Emitter::DirectionalArea(d) => {
                        Emitter::DirectionalArea(DirectionalAreaLight { radiance, ..d })
                    }
                    _ => return Err(replay.error("is not an emitter on a shape")),
                };
                self.emitters[i as usize] = emitter;
                self.emitter_options[i as usize] = options;
            }
            EditTarget::Sensor => {
                let sensor = Sensor::from_params(&mut replay)?;
                self.camera = sensor.camera;
                self.shutter = sensor.shutter;
                self.film = sensor.film;
                self.sampler = sensor.sampler;
            }
            EditTarget::Medium(i) => {
                self.media[i as usize] = crate::medium::from_params(&mut replay)?;
            }
            EditTarget::Shape(i) => {
                let BuiltShape::Analytic(shape) = crate::shape::from_params(&mut replay)? else {
                    return Err(replay.error("a mesh shape cannot be edited in place"));
                };
                let group =
                    (self.edits.group_of_shape(i)).ok_or_else(|| replay.error("is in no group"))?;
                if self.placed_emitters.iter().any(|&(shape, _)| shape == i) {
                    return Err(replay.error(
                        "an emitting shape in a shape group (copied per instance) cannot be \
                         edited in place",
                    ));
                }
                let old = std::mem::replace(&mut self.shapes[i as usize], shape);
                if let Err(e) = self.rebuild_groups_from(group) {
                    // The group may have been built with the new shape
                    // before the world failed: build it again as it was.
                    self.shapes[i as usize] = old;
                    let _ = self.rebuild_groups_from(group);
                    return Err(ParamError(e.to_string()));
                }
            }
            EditTarget::Instance(i) => {
                let to_world = replay.transform_or_identity("to_world")?;
                let inst = &mut self.instances[i as usize];
                if inst.placed_emitters.1 > 0 {
                    return Err(
                        replay.error("an instance of emitting shapes cannot be moved by an update")
                    );
                }
                let old = std::mem::replace(&mut inst.to_world, to_world);
                if let Err(e) = self.rebuild_groups_from(0) {
                    self.instances[i as usize].to_world = old;
                    return Err(ParamError(e.to_string()));
                }
            }
        }
        Ok(())
    }

    /// Builds the BVH of group `group` again, and the world's after it
    /// when the group is a shape group (its instances' bounds changed).
    fn rebuild_groups_from(&mut self, group: usize) -> Result<(), BuildError> {
        let mut groups = std::mem::take(&mut self.groups);
        let mut result = Ok(());
        for gi in std::iter::once(group).chain((group != 0).then_some(0)) {
            let items = self.edits.group_items(gi, &self.shapes);
            let old = std::mem::replace(&mut groups[gi], unbuilt_group(items));
            let geometry = Geometry {
                shapes: &self.shapes,
                meshes: &self.meshes,
                instances: &self.instances,
            };
            self.edits.counts.bvh_builds += 1;
            if let Err(e) = build_group(&mut groups, gi, &geometry) {
                groups[gi] = old;
                result = Err(e);
                break;
            }
        }
        self.groups = groups;
        result
    }

    /// Per BSDF, whether it reads MikkTSpace tangents.
    fn mikktspace_needs(&self) -> Vec<bool> {
        let m = &self.materials;
        m.bsdfs.iter().map(|b| b.needs_mikktspace(m)).collect()
    }

    /// The tables taken from the BSDFs at build: flags, the wide
    /// shading's reflectances, pass-through surfaces, free frames.
    fn refresh_materials(&mut self) {
        let m = &self.materials;
        self.bsdf_flags = m.bsdfs.iter().map(|b| b.flags(m)).collect();
        (self.has_pass_through, self.has_null_transmission) =
            pass_through(&self.shape_info, m, &self.bsdf_flags);
        self.free_frame = free_frames(&self.shape_info, m, self.uv_unread);
    }

    /// `emitter` fitted to the scene as the build fits it
    /// (`light::prepare_emitters`). The light sampler and the emitters'
    /// sampling tables belong to each render (`render::RenderState`).
    fn prepared(&self, emitter: Emitter) -> Result<Emitter, ParamError> {
        let mut one = [emitter];
        crate::light::prepare_emitters(&mut one, &self.materials)
            .map_err(|index| ParamError(format!("no image {index} in the scene")))?;
        Ok(one[0])
    }
}
