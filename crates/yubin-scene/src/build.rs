//! The builder: turns a [`SceneDesc`] into a [`yubin_core::Scene`] plus the
//! integrator and render seed.
//!
//! It knows every plugin type and its parameters; an unknown type, a
//! parameter nobody read or a nested object nobody used is an error naming
//! `file:line`. Shared objects (`id` + `<ref>`) are built once.
//!
//! **Scenes written for older Mitsuba versions.** Parameters that older
//! versions accepted and Mitsuba 3 dropped are read and ignored with a
//! warning that names the line, rather than failing the load: the
//! sampler's `light_samples` (Mitsuba 0.6), and the film's `file_format`,
//! `banner`, `high_quality_edges` and `attach_log` (output options that
//! `yubin render -o` decides instead). The XML front end already converts
//! 0.6-style camelCase names.

use crate::desc::{Category, Object, SceneDesc};
use crate::error::{Location, SceneError};
use crate::image_io::read_texture;
use crate::mesh::{obj::load_obj, ply::load_ply, serialized::load_serialized, MeshData};
use crate::params::{to_param, ObjParams};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use yubin_core::bsdf::Material;
use yubin_core::camera::Sensor;
use yubin_core::integrator::{Integrator, PathIntegrator};
use yubin_core::light::EmitterOptions;
use yubin_core::params::{ColorKind, ParamError, Params, Record, Recorder};
use yubin_core::scene::{EditTarget, Editable};
use yubin_core::shape::{BuiltShape, MeshShape, Shape, TriangleMesh};
use yubin_core::spectrum::Rgb;
use yubin_core::texture::Tex;
use yubin_core::{Scene, SceneBuilder, ShapeEmitter};

/// A scene ready to render, with what the file said about how.
#[derive(Debug)]
pub struct LoadedScene {
    /// The scene.
    pub scene: Scene,
    /// The integrator the file asked for (`path` when it asked for none).
    pub integrator: Box<dyn Integrator>,
    /// The sampler's `seed` parameter (0 by default).
    pub seed: u32,
    /// Things that loaded but deserve a mention (ignored legacy parameters).
    pub warnings: Vec<String>,
    /// The key (`Scene::parameters`) each described object was given, by
    /// the object's address in the description it was built from: what
    /// ties a description's values to the scene's parameters.
    pub object_keys: HashMap<usize, String>,
}

/// Parses and builds a Mitsuba XML scene file; `defines` are `-D name=value`.
pub fn load_scene(path: &Path, defines: &[(String, String)]) -> Result<LoadedScene, SceneError> {
    let desc = crate::xml::parse_file(path, defines)?;
    build_scene(&desc)
}

/// Like [`load_scene`] for a scene held in memory; `path` names it in
/// messages and anchors relative file names.
pub fn load_scene_str(
    text: &str,
    path: &Path,
    defines: &[(String, String)],
) -> Result<LoadedScene, SceneError> {
    let desc = crate::xml::parse_str(text, path, defines)?;
    build_scene(&desc)
}

/// Builds a parsed scene.
pub fn build_scene(desc: &SceneDesc) -> Result<LoadedScene, SceneError> {
    let mut b = Builder {
        desc,
        sb: SceneBuilder::new(),
        bsdfs: HashMap::new(),
        textures: HashMap::new(),
        images: HashMap::new(),
        groups: HashMap::new(),
        grids: HashMap::new(),
        media: HashMap::new(),
        warnings: Vec::new(),
        reading: Vec::new(),
        texture_reads: HashMap::new(),
        bsdf_reads: HashMap::new(),
        keys: std::collections::HashSet::new(),
        suffixes: HashMap::new(),
        ids: all_ids(&desc.root),
        parents: Vec::new(),
        object_keys: HashMap::new(),
        worlds: HashMap::new(),
        shape_sensor: None,
    };
    let root = &desc.root;
    let integrator = match root.single_child(Category::Integrator)? {
        Some(c) => b.integrator(&c.object)?,
        None => Box::new(PathIntegrator::default()),
    };
    let mut seed = 0;
    let top_sensor = root.single_child(Category::Sensor)?;
    if let Some(sensor) = top_sensor {
        seed = b.sensor(&sensor.object)?;
        if integrator.particle_tracer().is_some() && !b.sb.camera_can_connect() {
            return Err(sensor.object.error(format!(
                "ptracer connects paths from the lights to the camera, which a{} {} sensor \
                 cannot be (use perspective, thinlens or physical)",
                if sensor
                    .object
                    .plugin_type
                    .starts_with(['a', 'e', 'i', 'o', 'u'])
                {
                    "n"
                } else {
                    ""
                },
                sensor.object.plugin_type
            )));
        }
    }
    // Worlds first, so that a portal may name one declared after it.
    for child in root
        .children
        .iter()
        .filter(|c| c.object.category == Category::World)
    {
        let obj = &child.object;
        let Some(id) = obj.id.clone() else {
            return Err(obj.error("a <world> needs an id (portals name it)"));
        };
        let w = b.sb.add_world();
        b.worlds.insert(id, w);
    }
    for child in &root.children {
        let obj = &child.object;
        match obj.category {
            Category::Integrator | Category::Sensor => {}
            Category::World => {
                child.used.set(true);
                b.world(obj)?;
            }
            Category::Bsdf => {
                child.used.set(true);
                b.bsdf(obj)?;
            }
            Category::Shape => {
                child.used.set(true);
                b.shape(obj, 0)?;
            }
            Category::Emitter => {
                child.used.set(true);
                b.emitter(obj, 0)?;
            }
            // Built (and checked) even when nothing refers to it.
            Category::Medium if obj.id.is_some() => {
                child.used.set(true);
                b.medium(obj, "medium")?;
            }
            // Built (and checked) even when nothing refers to it, as
            // Mitsuba loads every declared object.
            Category::Texture if obj.id.is_some() => {
                child.used.set(true);
                b.texture(obj, "texture")?;
            }
            Category::Phase if obj.id.is_some() => {
                child.used.set(true);
                yubin_core::phase::PhaseFunction::from_params(&mut ObjParams { obj, b: &mut b })?;
            }
            Category::Volume if obj.id.is_some() => {
                child.used.set(true);
                yubin_core::volume::from_params(&mut ObjParams { obj, b: &mut b })?;
            }
            Category::Spectrum if obj.id.is_some() => {
                child.used.set(true);
                b.spectrum_object(obj, ColorKind::Unbounded)?;
            }
            // Declared to be referenced (Mitsuba's docs scenes declare a
            // sampler for the sensor so): built where a `<ref>` uses it,
            // and here too, so that one nobody refers to is checked and
            // its parameters count as read, as Mitsuba loads it.
            Category::Sampler | Category::Film | Category::Rfilter if obj.id.is_some() => {
                child.used.set(true);
                let p = &mut ObjParams { obj, b: &mut b };
                match obj.category {
                    Category::Sampler => yubin_core::sampler::Sampler::from_params(p).map(drop),
                    Category::Film => yubin_core::film::Film::from_params(p).map(drop),
                    _ => yubin_core::filter::Filter::from_params(p).map(drop),
                }?;
            }
            _ => {}
        }
    }
    root.check_unused_tree()?;
    if b.sb.has_portals() {
        let kind = root
            .single_child(Category::Integrator)?
            .map_or("path".to_string(), |c| c.object.plugin_type.clone());
        if kind != "path" {
            return Err(root.error(format!(
                "portals are rendered by the path integrator (this scene's is \"{kind}\")"
            )));
        }
    }
    if let Some((shape_seed, loc)) = &b.shape_sensor {
        if let Some(top) = top_sensor {
            return Err(SceneError::at(
                loc,
                format!(
                    "a scene has one sensor, and this one is the second (the first is at line {})",
                    top.loc.line
                ),
            ));
        }
        seed = *shape_seed;
    } else if let (Some(top), Some(yubin_core::camera::Camera::Irradiancemeter(m))) =
        (top_sensor, b.sb.current_camera())
    {
        if !m.has_shape() {
            return Err(top.object.error(
                "an irradiancemeter measures the shape it is written in: put it inside a <shape>",
            ));
        }
    }
    if let (Some((_, loc)), Some(_)) = (&b.shape_sensor, integrator.particle_tracer()) {
        return Err(SceneError::at(
            loc,
            "ptracer connects paths from the lights to the camera, which an irradiancemeter cannot be",
        ));
    }
    b.sb.uv_unread_by_integrator(!integrator.reads_uv());
    let scene =
        b.sb.build()
            .map_err(|e| SceneError::at(&root.loc, e.to_string()))?;
    Ok(LoadedScene {
        scene,
        integrator,
        seed,
        warnings: b.warnings,
        object_keys: b.object_keys,
    })
}

/// An object's key and what its plugin read, before it has a place in
/// the scene.
struct Recorded {
    key: String,
    record: Record,
}

impl Recorded {
    fn of(self, target: EditTarget) -> Editable {
        Editable {
            key: self.key,
            target,
            record: self.record,
        }
    }
}

/// The builder's state: the scene under construction and what has been
/// built of the description (shared objects are built once).
pub(crate) struct Builder<'a> {
    pub(crate) desc: &'a SceneDesc,
    pub(crate) sb: SceneBuilder,
    bsdfs: HashMap<*const Object, u32>,
    textures: HashMap<*const Object, u32>,
    images: HashMap<PathBuf, u32>,
    groups: HashMap<*const Object, u32>,
    /// Voxel grids by file (each read once).
    grids: HashMap<PathBuf, std::sync::Arc<yubin_core::medium::Grid>>,
    /// Built media by object (a shared medium is built once).
    media: HashMap<*const Object, u32>,
    pub(crate) warnings: Vec<String>,
    /// Mesh attributes (name indices) read by the BSDF or texture being
    /// built, innermost last: a shape's BSDF is checked against its mesh.
    reading: Vec<Vec<u32>>,
    /// Mesh attributes each built texture reads, itself or through others.
    texture_reads: HashMap<u32, Vec<u32>>,
    /// Mesh attributes each built BSDF reads through its textures.
    bsdf_reads: HashMap<u32, Vec<u32>>,
    /// Keys given to editable objects (`Scene::parameters`).
    keys: std::collections::HashSet<String>,
    /// Per name, the last suffix a key made from it took, so that a scene
    /// of many unnamed spheres takes one look per sphere, not one per
    /// sphere named before it.
    suffixes: HashMap<String, u32>,
    /// Every id in the file: a generated key never takes one, so that an
    /// object keeps its id as its key whatever comes before it.
    ids: std::collections::HashSet<String>,
    /// Keys of the objects being built, innermost last: a nested object
    /// without an id is named after its parent.
    parents: Vec<String>,
    /// Every object's key, by address ([`LoadedScene::object_keys`]).
    object_keys: HashMap<usize, String>,
    /// The worlds by id (`<world id="...">`), created before any shape.
    worlds: HashMap<String, u32>,
    /// A sensor written in a shape (an `irradiancemeter`): its sampler's
    /// seed and where it was written.
    shape_sensor: Option<(u32, Location)>,
}

/// The ids of `obj` and every object nested in it.
fn all_ids(obj: &Object) -> std::collections::HashSet<String> {
    let mut ids = std::collections::HashSet::new();
    let mut stack = vec![obj];
    while let Some(o) = stack.pop() {
        ids.extend(o.id.clone());
        stack.extend(o.children.iter().map(|c| &*c.object));
    }
    ids
}

/// The constructor of `obj`'s plugin type in a family's plugin table; an
/// unknown type is an error listing the known ones.
fn plugin<T: Copy>(obj: &Object, table: &[(&str, T)]) -> Result<T, SceneError> {
    table
        .iter()
        .find(|(name, _)| *name == obj.plugin_type)
        .map(|(_, build)| *build)
        .ok_or_else(|| {
            let known: Vec<&str> = table.iter().map(|(name, _)| *name).collect();
            unknown_type(obj, &known.join(", "))
        })
}

fn unknown_type(obj: &Object, known: &str) -> SceneError {
    obj.error(yubin_core::params::unknown_type_message(
        &obj.category.to_string(),
        &obj.plugin_type,
        known,
    ))
}

impl Builder<'_> {
    fn integrator(&mut self, obj: &Object) -> Result<Box<dyn Integrator>, SceneError> {
        Ok(yubin_core::integrator::from_params(&mut ObjParams {
            obj,
            b: self,
        })?)
    }

    /// Builds camera, film and sampler; returns the sampler's seed.
    fn sensor(&mut self, obj: &Object) -> Result<u32, SceneError> {
        let (sensor, editable) = self.recorded(obj, "sensor", Sensor::from_params)?;
        let key = editable.key.clone();
        self.sb.record(editable.of(EditTarget::Sensor));
        self.parents.push(key);
        let medium = self.medium_child(obj, None);
        self.parents.pop();
        let medium = medium?;
        self.sb
            .camera_medium(medium)
            .map_err(|e| obj.error(e.to_string()))?;
        self.sb
            .camera(sensor.camera)
            .shutter(sensor.shutter)
            .film(sensor.film)
            .sampler(sensor.sampler);
        Ok(sensor.seed)
    }

    /// Builds a BSDF (once per shared object); returns its index.
    pub(crate) fn bsdf(&mut self, obj: &Rc<Object>) -> Result<u32, SceneError> {
        let key = Rc::as_ptr(obj);
        if let Some(&id) = self.bsdfs.get(&key) {
            self.note_reads(self.bsdf_reads.get(&id).cloned());
            return Ok(id);
        }
        let build = plugin(obj, yubin_core::bsdf::PLUGINS)?;
        self.reading.push(Vec::new());
        let (bsdf, editable) = self.recorded(obj, "bsdf", build)?;
        let reads = self.reading.pop().unwrap_or_default();
        let id = self.sb.add_bsdf(bsdf);
        self.sb
            .check_composite_size(id)
            .map_err(|e| SceneError::at(&obj.loc, e.to_string()))?;
        self.sb.record(editable.of(EditTarget::Bsdf(id)));
        self.bsdfs.insert(key, id);
        if !reads.is_empty() {
            self.note_reads(Some(reads.clone()));
            self.bsdf_reads.insert(id, reads);
        }
        Ok(id)
    }

    /// The index of mesh attribute `name` in the scene's table, noted as
    /// read by the object being built.
    pub(crate) fn attribute_index(&mut self, name: &str) -> u32 {
        let index = self.sb.attribute_name(name);
        self.note_reads(Some(vec![index]));
        index
    }

    /// Notes mesh attributes as read by the object being built.
    fn note_reads(&mut self, reads: Option<Vec<u32>>) {
        if let (Some(frame), Some(reads)) = (self.reading.last_mut(), reads) {
            for r in reads {
                if !frame.contains(&r) {
                    frame.push(r);
                }
            }
        }
    }

    /// Checks that a shape's mesh has every attribute its BSDF reads (with
    /// one or three channels). Mitsuba fails at render time instead
    /// (`Invalid attribute requested`); here it is a load error.
    fn check_attributes(&self, obj: &Object, shape: &Shape, bsdf: u32) -> Result<(), SceneError> {
        let Some(reads) = self.bsdf_reads.get(&bsdf) else {
            return Ok(());
        };
        for &name in reads {
            let label = self.sb.attribute_label(name);
            let slot = match shape {
                Shape::Mesh(m) => self.sb.mesh_attribute(m.mesh, name),
                _ => None,
            };
            let problem = match slot {
                Some(s) if matches!(s.channels, 1 | 3) => continue,
                Some(s) => format!("has {} channels (mesh_attribute reads 1 or 3)", s.channels),
                None if matches!(shape, Shape::Mesh(_)) => "is not in the mesh".to_string(),
                None => "needs a mesh (ply) shape".to_string(),
            };
            return Err(obj.error(format!(
                "attribute \"{label}\", read by its BSDF's mesh_attribute texture, {problem}"
            )));
        }
        Ok(())
    }

    /// The BSDF built at index `id`.
    pub(crate) fn built_bsdf(&self, id: u32) -> Material {
        *self.sb.bsdf(id).expect("an index the builder returned")
    }

    /// Builds a texture (once per shared object), the parameter `role` of
    /// the object being built; returns its index.
    pub(crate) fn texture(&mut self, obj: &Rc<Object>, role: &str) -> Result<u32, ParamError> {
        let key = Rc::as_ptr(obj);
        if let Some(&id) = self.textures.get(&key) {
            self.note_reads(self.texture_reads.get(&id).cloned());
            return Ok(id);
        }
        let build = plugin(obj, yubin_core::texture::PLUGINS).map_err(to_param)?;
        self.reading.push(Vec::new());
        let (texture, editable) = self.recorded(obj, role, build)?;
        let reads = self.reading.pop().unwrap_or_default();
        let id = self.sb.add_texture(texture);
        self.sb.record(editable.of(EditTarget::Texture(id)));
        self.textures.insert(key, id);
        if !reads.is_empty() {
            self.note_reads(Some(reads.clone()));
            self.texture_reads.insert(id, reads);
        }
        Ok(id)
    }

    /// Loads an image file for a texture or emitter (once per file).
    pub(crate) fn image(&mut self, name: &str, loc: &Location) -> Result<u32, SceneError> {
        let path = self.desc.resolve_file(name, loc)?;
        let key = path.canonicalize().unwrap_or_else(|_| path.clone());
        if let Some(&id) = self.images.get(&key) {
            return Ok(id);
        }
        let image = read_texture(&path)?;
        let id = self.sb.add_image(image);
        self.images.insert(key, id);
        Ok(id)
    }

    /// Reads a `.vol` voxel grid (once per file).
    pub(crate) fn grid(
        &mut self,
        name: &str,
        loc: &Location,
    ) -> Result<std::sync::Arc<yubin_core::medium::Grid>, SceneError> {
        let path = self.desc.resolve_file(name, loc)?;
        let key = path.canonicalize().unwrap_or_else(|_| path.clone());
        if let Some(g) = self.grids.get(&key) {
            return Ok(g.clone());
        }
        let grid = crate::volume_io::read_vol(&path).map_err(|e| SceneError::at(loc, e))?;
        let grid = std::sync::Arc::new(grid);
        self.grids.insert(key, grid.clone());
        Ok(grid)
    }

    /// Builds a medium (once per shared object), the `role` of the object
    /// being built; returns its index.
    fn medium(&mut self, obj: &Rc<Object>, role: &str) -> Result<u32, SceneError> {
        let key = Rc::as_ptr(obj);
        if let Some(&id) = self.media.get(&key) {
            return Ok(id);
        }
        let (medium, editable) = self.recorded(obj, role, yubin_core::medium::from_params)?;
        let id = self.sb.add_medium(medium);
        self.sb.record(editable.of(EditTarget::Medium(id)));
        self.media.insert(key, id);
        Ok(id)
    }

    /// The medium nested in `obj` under `name` (`interior`, `exterior`), or
    /// its one unnamed medium when `name` is `None` (a sensor's).
    fn medium_child(
        &mut self,
        obj: &Object,
        name: Option<&str>,
    ) -> Result<Option<u32>, SceneError> {
        let child = match name {
            Some(n) => match obj.find_named_child(n) {
                Some(c) if c.category == Category::Medium => obj.child(n).map(|c| c.object.clone()),
                Some(c) => {
                    return Err(SceneError::at(
                        &obj.child(n).expect("found above").loc,
                        format!("\"{n}\" must be a medium, not a {}", c.category),
                    ))
                }
                None => None,
            },
            None => obj
                .single_child(Category::Medium)?
                .map(|c| c.object.clone()),
        };
        child
            .map(|c| self.medium(&c, name.unwrap_or("medium")))
            .transpose()
    }

    /// A `<spectrum type="...">` object as RGB for its role.
    pub(crate) fn spectrum_object(
        &mut self,
        obj: &Object,
        kind: ColorKind,
    ) -> Result<Rgb, ParamError> {
        let p = &mut ObjParams { obj, b: self };
        yubin_core::spectrum::plugin::spectrum_plugin_to_rgb(&obj.plugin_type, p, kind)
    }

    fn shape_bsdf(&mut self, obj: &Object) -> Result<Option<u32>, SceneError> {
        match obj.single_child(Category::Bsdf)? {
            Some(c) => Ok(Some(self.bsdf(&c.object.clone())?)),
            None => Ok(None),
        }
    }

    fn area_radiance(
        &mut self,
        obj: &Object,
    ) -> Result<Option<(ShapeEmitter, EmitterOptions, Recorded)>, SceneError> {
        let Some(c) = obj.single_child(Category::Emitter)? else {
            return Ok(None);
        };
        let e = &c.object;
        let directional = match e.plugin_type.as_str() {
            "area" => false,
            "directionalarea" => true,
            other => {
                return Err(e.error(format!(
                    "a shape can only carry an \"area\" or \"directionalarea\" emitter, not \"{other}\""
                )))
            }
        };
        let e = e.clone();
        let read = |p: &mut dyn Params| -> Result<_, ParamError> {
            let radiance = p.texture_or("radiance", ColorKind::Illuminant, Rgb::ONE)?;
            Ok((radiance, EmitterOptions::from_params(p)?))
        };
        let ((radiance, options), editable) = self.recorded(&e, "emitter", read)?;
        let reads_attributes = match radiance {
            Tex::Texture(t) => self.texture_reads.get(&t).is_some_and(|r| !r.is_empty()),
            Tex::Const(_) => false,
        };
        if reads_attributes {
            return Err(SceneError::at(
                e.loc_of("radiance"),
                "an area emitter's radiance cannot be a mesh_attribute texture \
                 (light samples carry no triangle attributes)",
            ));
        }
        let emitter = if directional {
            ShapeEmitter::DirectionalArea(radiance)
        } else {
            ShapeEmitter::Area(radiance)
        };
        Ok(Some((emitter, options, editable)))
    }

    /// Builds a shape into group `group` (0: the world).
    fn shape(&mut self, obj: &Rc<Object>, group: u32) -> Result<(), SceneError> {
        let kind = obj.plugin_type.as_str();
        match kind {
            "shapegroup" => {
                if group != 0 {
                    return Err(obj.error("shape groups cannot be nested"));
                }
                self.shape_group(obj)?;
                return Ok(());
            }
            "gltf" => return self.gltf_shape(obj, group),
            "merge" => return self.merge(obj, group),
            "portal" => return self.portal(obj, group),
            "instance" => {
                if group != 0 {
                    return Err(obj.error("instances cannot be placed inside shape groups"));
                }
                let target = obj.single_child(Category::Shape)?.ok_or_else(|| {
                    obj.error("an instance needs a shapegroup (use <ref id=\"...\"/>)")
                })?;
                if target.object.plugin_type != "shapegroup" {
                    return Err(SceneError::at(
                        &target.loc,
                        "an instance must refer to a shapegroup",
                    ));
                }
                let g = self.shape_group(&target.object.clone())?;
                let key = self.object_key(obj, "instance");
                let mut record = Record::default();
                let t = Recorder::new(&mut ObjParams { obj, b: self }, &mut record)
                    .transform_or_identity("to_world")?;
                let index = self
                    .sb
                    .add_instance(g, t)
                    .map_err(|e| obj.error(e.to_string()))?;
                self.sb.record(Editable {
                    key,
                    target: EditTarget::Instance(index),
                    record,
                });
                return Ok(());
            }
            _ => {}
        }
        let key = self.object_key(obj, "shape");
        self.parents.push(key.clone());
        let built = self.shape_parts(obj);
        self.parents.pop();
        let (bsdf, built, record, emission) = built?;
        let shape = match Self::cube_as_mesh(
            built,
            emission.is_some(),
            bsdf.is_some_and(|b| self.sb.needs_mikktspace(b)),
        ) {
            BuiltShape::Analytic(shape) => shape,
            BuiltShape::Mesh(mut mesh) => {
                self.prepare_tangents(obj, bsdf, &mut mesh)?;
                Shape::Mesh(MeshShape {
                    mesh: self.sb.add_mesh(mesh),
                })
            }
        };
        if let Some(b) = bsdf {
            self.check_attributes(obj, &shape, b)?;
        }
        if emission.is_some()
            && matches!(
                shape,
                Shape::Sdf(_)
                    | Shape::SdfGrid(_)
                    | Shape::Ellipsoids(_)
                    | Shape::EllipsoidsMesh(_)
                    | Shape::LinearCurve(_)
                    | Shape::BSplineCurve(_)
            )
        {
            return Err(obj.error(format!(
                "a \"{}\" shape cannot carry an area emitter: its surface cannot be sampled",
                obj.plugin_type
            )));
        }
        let analytic = !matches!(shape, Shape::Mesh(_));
        self.shape_sensor(obj, group, shape)?;
        let id = self
            .sb
            .add_shape_with_emitter(group, shape, bsdf, emission.as_ref().map(|(e, ..)| *e))
            .map_err(|e| obj.error(e.to_string()))?;
        if analytic {
            self.sb.record(Editable {
                key: key.clone(),
                target: EditTarget::Shape(id),
                record,
            });
        }
        if let Some((_, options, editable)) = emission {
            self.sb.set_shape_emitter_options(id, options);
            // An emitter on a shape in a group is copied per instance.
            if let Some(e) = self.sb.emitter_of_shape(id).filter(|_| group == 0) {
                self.sb.record(editable.of(EditTarget::AreaEmitter(e)));
            }
        }
        self.parents.push(key);
        let media = (|| {
            let interior = self.medium_child(obj, Some("interior"))?;
            let exterior = self.medium_child(obj, Some("exterior"))?;
            Ok::<_, SceneError>((interior, exterior))
        })();
        self.parents.pop();
        let (interior, exterior) = media?;
        if interior.is_some() || exterior.is_some() {
            self.sb
                .set_shape_media(id, interior, exterior)
                .map_err(|e| obj.error(e.to_string()))?;
        }
        Ok(())
    }

    /// The sensor written in `obj` (an `irradiancemeter` of `shape`), if
    /// any: it becomes the scene's sensor.
    fn shape_sensor(&mut self, obj: &Object, group: u32, shape: Shape) -> Result<(), SceneError> {
        let Some(sensor) = obj.single_child(Category::Sensor)? else {
            return Ok(());
        };
        sensor.used.set(true);
        let o = &sensor.object;
        if o.plugin_type != "irradiancemeter" {
            return Err(o.error(format!(
                "only an irradiancemeter can be written in a shape, not a \"{}\" sensor",
                o.plugin_type
            )));
        }
        if group != 0 {
            return Err(o.error("an irradiancemeter cannot measure a shape of a shapegroup"));
        }
        if let Some((_, first)) = &self.shape_sensor {
            return Err(o.error(format!(
                "a scene has one sensor, and this one is the second (the first is at line {})",
                first.line
            )));
        }
        let seed = self.sensor(o)?;
        if let Some(yubin_core::camera::Camera::Irradiancemeter(m)) = self.sb.current_camera() {
            self.sb.camera(yubin_core::camera::Camera::Irradiancemeter(
                m.with_shape(shape),
            ));
        }
        self.shape_sensor = Some((seed, sensor.loc.clone()));
        Ok(())
    }

    /// What a shape is made of: its BSDF, the shape its plugin builds
    /// with the record of what it read, and its area emitter.
    #[allow(clippy::type_complexity)]
    fn shape_parts(
        &mut self,
        obj: &Object,
    ) -> Result<
        (
            Option<u32>,
            BuiltShape,
            Record,
            Option<(ShapeEmitter, EmitterOptions, Recorded)>,
        ),
        SceneError,
    > {
        let bsdf = self.shape_bsdf(obj)?;
        let mut record = Record::default();
        let built = yubin_core::shape::from_params(&mut Recorder::new(
            &mut ObjParams { obj, b: self },
            &mut record,
        ))?;
        let emission = self.area_radiance(obj)?;
        Ok((bsdf, built, record, emission))
    }

    /// Builds `obj` with `build` through a recorder, as the `role` of the
    /// object being built (its key's last part when it has no id); nested
    /// objects it builds are named after it.
    fn recorded<T, E>(
        &mut self,
        obj: &Object,
        role: &str,
        build: impl FnOnce(&mut dyn Params) -> Result<T, E>,
    ) -> Result<(T, Recorded), E> {
        let key = self.object_key(obj, role);
        self.parents.push(key.clone());
        let mut record = Record::default();
        let built = build(&mut Recorder::new(
            &mut ObjParams { obj, b: self },
            &mut record,
        ));
        self.parents.pop();
        Ok((built?, Recorded { key, record }))
    }

    /// The key of `obj` (`Scene::parameters`): its id, or its parent's key
    /// and its `role` (`wall.bsdf`), or at the top level its plugin type;
    /// `_1`, `_2`, … added while the name is taken.
    fn object_key(&mut self, obj: &Object, role: &str) -> String {
        let base = match (&obj.id, self.parents.last()) {
            (Some(id), _) => id.clone(),
            (None, Some(parent)) => format!("{parent}.{role}"),
            (None, None) if role == "sensor" => role.to_string(),
            (None, None) => obj.plugin_type.clone(),
        };
        let own_id = |key: &str| obj.id.as_deref() == Some(key);
        let free =
            |b: &Self, key: &str| !b.keys.contains(key) && (own_id(key) || !b.ids.contains(key));
        let mut key = base.clone();
        let mut n = self.suffixes.get(&base).copied().unwrap_or(0);
        while !free(self, &key) {
            n += 1;
            key = format!("{base}_{n}");
        }
        self.suffixes.insert(base, n);
        self.keys.insert(key.clone());
        self.object_keys
            .insert(obj as *const Object as usize, key.clone());
        key
    }

    /// A `cube` that emits, or whose BSDF reads MikkTSpace tangents, as
    /// its 12-triangle mesh: the light hierarchy bounds a mesh's triangles
    /// one by one, and tangents are computed for meshes.
    fn cube_as_mesh(built: BuiltShape, emits: bool, needs_tangents: bool) -> BuiltShape {
        match built {
            BuiltShape::Analytic(Shape::Cube(c)) if emits || needs_tangents => {
                BuiltShape::Mesh(c.mesh())
            }
            other => other,
        }
    }

    /// The mesh in the file `obj` (an `obj`, `ply` or `serialized` shape)
    /// names, with the format's own parameters.
    pub(crate) fn mesh_file(&self, obj: &Object) -> Result<MeshData, SceneError> {
        let name = obj
            .string("filename")?
            .ok_or_else(|| obj.error("needs a \"filename\""))?;
        let path = self.desc.resolve_file(name, obj.loc_of("filename"))?;
        match obj.plugin_type.as_str() {
            "obj" => load_obj(&path, obj.boolean_or("flip_tex_coords", true)?),
            "ply" => load_ply(&path),
            _ => {
                let index = obj.integer_or("shape_index", 0)?;
                let index = usize::try_from(index).map_err(|_| {
                    obj.param_error("shape_index", format!("must be 0 or more, not {index}"))
                })?;
                load_serialized(&path, index)
            }
        }
    }

    /// Computes the mesh's MikkTSpace tangents when its BSDF reads a
    /// normal map in that frame; a mesh without uvs cannot have them.
    fn prepare_tangents(
        &self,
        obj: &Object,
        bsdf: Option<u32>,
        mesh: &mut TriangleMesh,
    ) -> Result<(), SceneError> {
        let Some(b) = bsdf else { return Ok(()) };
        if !self.sb.needs_mikktspace(b) || mesh.compute_tangents() {
            return Ok(());
        }
        Err(obj.error(format!(
            "{} has no texture coordinates, so no MikkTSpace tangents for its normalmap \
             (tangent_space=\"mikktspace\"); use tangent_space=\"dpdu\" or a mesh with uvs",
            obj.describe()
        )))
    }

    fn shape_group(&mut self, obj: &Rc<Object>) -> Result<u32, SceneError> {
        let key = Rc::as_ptr(obj);
        if let Some(&g) = self.groups.get(&key) {
            return Ok(g);
        }
        let g = self.sb.add_group();
        self.groups.insert(key, g);
        let shapes: Vec<Rc<Object>> = obj
            .children_of(Category::Shape)
            .map(|c| c.object.clone())
            .collect();
        let name = self.object_key(obj, "shapegroup");
        self.parents.push(name);
        let built = shapes.iter().try_for_each(|s| self.shape(s, g));
        self.parents.pop();
        built.map(|()| g)
    }

    /// An `envmap`'s image must be lat-long; bad texels become 0 (warned).
    fn check_envmap_image(&mut self, obj: &Object, image: u32) -> Result<(), SceneError> {
        let Some(img) = self.sb.image_mut(image) else {
            return Ok(());
        };
        let loc = obj.loc_of("filename");
        match yubin_core::light::EnvMapLight::prepare_image(img) {
            Err(msg) => Err(SceneError::at(loc, format!("envmap: {msg}"))),
            Ok(0) => Ok(()),
            Ok(n) => {
                self.warnings.push(format!(
                    "{loc}: envmap: {n} texel values were negative, NaN or infinite and read as 0"
                ));
                Ok(())
            }
        }
    }

    fn emitter(&mut self, obj: &Object, world: u32) -> Result<(), SceneError> {
        if obj.plugin_type == "area" || obj.plugin_type == "directionalarea" {
            if obj.id.is_some() {
                // Declared at the top level to be attached to shapes by
                // `<ref>`; each shape that refers to it builds it.
                return Ok(());
            }
            return Err(obj.error(
                "an area or directionalarea emitter must be nested inside a shape (or declared with an id and referenced from shapes)",
            ));
        }
        let build = plugin(obj, yubin_core::light::PLUGINS).map_err(|_| {
            let known: Vec<&str> = yubin_core::light::PLUGINS.iter().map(|(n, _)| *n).collect();
            unknown_type(obj, &format!("area, directionalarea, {}", known.join(", ")))
        })?;
        let read = |p: &mut dyn Params| -> Result<_, ParamError> {
            let options = EmitterOptions::from_params(p)?;
            Ok((options, build(p)?))
        };
        let ((options, e), editable) = self.recorded(obj, "emitter", read)?;
        if let yubin_core::light::Emitter::EnvMap(env) = e {
            self.check_envmap_image(obj, env.image)?;
        }
        let index = self.sb.add_emitter(e);
        self.sb.set_emitter_options(index, options);
        self.sb.set_emitter_world(index, world);
        self.sb.record(editable.of(EditTarget::Emitter(index)));
        Ok(())
    }

    /// Mitsuba 3's `merge`: its shapes, each as if written on its own.
    /// Mitsuba joins the meshes that share a BSDF, media and attributes
    /// into one mesh, to have fewer shapes in its BVH; the image is the
    /// same, and yubin's BVH does not need it. A `<bsdf>` written in it
    /// applies to none of them (in Mitsuba neither): a warning says so.
    fn merge(&mut self, obj: &Rc<Object>, group: u32) -> Result<(), SceneError> {
        for child in &obj.children {
            let o = &child.object;
            match o.category {
                Category::Shape => {
                    child.used.set(true);
                    self.shape(o, group)?;
                }
                Category::Bsdf => {
                    child.used.set(true);
                    self.warnings.push(format!(
                        "{}: a <bsdf> in a merge shape is ignored (give each shape its own, as in Mitsuba)",
                        child.loc
                    ));
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// A `<world>`'s shapes and emitters, in its own root group.
    fn world(&mut self, obj: &Rc<Object>) -> Result<(), SceneError> {
        let id = obj.id.clone().unwrap_or_default();
        let w = self.worlds[&id];
        let group = self.sb.world_group(w).expect("created above");
        for child in &obj.children {
            let o = &child.object;
            child.used.set(true);
            match (o.category, o.plugin_type.as_str()) {
                (Category::Shape, "shapegroup" | "instance") => {
                    return Err(o.error(
                        "a <world> holds shapes and emitters, not shape groups or instances",
                    ))
                }
                (Category::Shape, _) => self.shape(o, group)?,
                (Category::Emitter, _) => self.emitter(o, w)?,
                (Category::World, _) => return Err(o.error("worlds cannot be nested")),
                _ => {
                    return Err(o.error(format!(
                        "a <world> holds shapes and emitters, not a <{}>",
                        o.category
                    )))
                }
            }
        }
        Ok(())
    }

    /// A `portal`: its `here` shape in this group's world, its `there`
    /// shape in the world named `to`, joined.
    fn portal(&mut self, obj: &Rc<Object>, group: u32) -> Result<(), SceneError> {
        let to = obj
            .string("to")?
            .ok_or_else(|| obj.error("a portal needs \"to\", the id of the <world> it opens onto"))?
            .to_string();
        let Some(&to_world) = self.worlds.get(&to) else {
            let mut known: Vec<&String> = self.worlds.keys().collect();
            known.sort();
            return Err(SceneError::at(
                obj.loc_of("to"),
                format!("no <world id=\"{to}\"> (worlds: {known:?})"),
            ));
        };
        let here_world = self
            .sb
            .world_of_group(group)
            .ok_or_else(|| obj.error("a portal must be in a <world> or at the top level"))?;
        let side = |name: &str| {
            obj.child(name)
                .map(|c| c.object.clone())
                .ok_or_else(|| obj.error(format!("a portal needs a shape called \"{name}\"")))
        };
        let (here, there) = (side("here")?, side("there")?);
        if here.plugin_type != there.plugin_type || !same_but_placement(&here, &there) {
            return Err(there.error(format!(
                "the two sides of a portal must be the same shape but for to_world \
                 (here: {} at {}, there: {})",
                here.plugin_type, here.loc, there.plugin_type
            )));
        }
        let place =
            |b: &mut Self, o: &Rc<Object>| -> Result<yubin_core::math::Transform, SceneError> {
                Ok(ObjParams { obj: o, b }.transform_or_identity("to_world")?)
            };
        let (t_here, t_there) = (place(self, &here)?, place(self, &there)?);
        let a = self.sb.shape_count();
        self.shape(&here, group)?;
        let b = self.sb.shape_count();
        let there_group = self.sb.world_group(to_world).expect("a world");
        self.shape(&there, there_group)?;
        if b != a + 1 || self.sb.shape_count() != b + 1 {
            return Err(obj.error("each side of a portal must be one shape"));
        }
        let a_to_b = t_there.after(&t_here.inverse());
        self.sb.add_portal(a, here_world, b, to_world, a_to_b);
        Ok(())
    }
}

/// Whether `a` and `b` have the same parameters (values and nested
/// objects' types) but for `to_world` (and their BSDFs).
fn same_but_placement(a: &Object, b: &Object) -> bool {
    let props = |o: &Object| -> Vec<(String, String)> {
        let mut v: Vec<_> = o
            .props
            .iter()
            .filter(|p| p.name != "to_world")
            .map(|p| (p.name.clone(), format!("{:?}", p.value)))
            .collect();
        v.sort();
        v
    };
    props(a) == props(b)
}
