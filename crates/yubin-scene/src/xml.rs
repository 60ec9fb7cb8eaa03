//! The Mitsuba 3 XML front end.
//!
//! [`parse_file`] and [`parse_str`] read a Mitsuba scene into a
//! [`SceneDesc`]: a tree of [`Object`]s whose parameters and nested objects
//! remember their `file:line`. Nothing is built here and plugin type names
//! are not checked; the builder knows the plugins and reports unknown types
//! and unread parameters.
//!
//! ```xml
//! <scene version="3.0.0">
//!     <default name="spp" value="64"/>              <!-- unless -D spp=... -->
//!     <path value="../common"/>                     <!-- extra search directory -->
//!     <include filename="fragments/camera.xml"/>    <!-- splices its children -->
//!     <bsdf type="diffuse" id="white">
//!         <rgb name="reflectance" value="0.8"/>      <!-- one number: gray -->
//!     </bsdf>
//!     <shape type="obj">
//!         <string name="filename" value="meshes/bunny.obj"/>
//!         <transform name="to_world">
//!             <scale value="2"/>
//!             <rotate y="1" angle="90"/>              <!-- applied after scale -->
//!             <translate x="1" z="-2"/>
//!         </transform>
//!         <ref id="white"/>                          <!-- the same Rc<Object> -->
//!     </shape>
//!     <sampler type="independent">
//!         <integer name="sample_count" value="$spp"/>
//!     </sampler>
//! </scene>
//! ```
//!
//! # What is accepted
//!
//! - Objects: every [`Category`] tag with a `type` and optional `id` and
//!   `name`, nested to any depth; `<spectrum>` with a `type` is an object,
//!   without one a property. `<ref id= [name=]>` points at an object declared
//!   *earlier*, `<alias id= as=>` gives it a second id.
//! - Properties: `integer`, `float`, `boolean` (`true`/`false`, any case),
//!   `string`, `rgb` (one number for gray, or three; `#rrggbb` is read as
//!   sRGB and linearized), `spectrum` (`"0.5"` or `"400:0.1, 500:0.2"`),
//!   `point`/`vector` (`x= y= z=`, missing ones 0, or `value=` with one or
//!   three numbers), and `transform`.
//! - Transforms compose in the order written, each op applied after the
//!   previous ones (`M = op · M`): `translate`, `rotate` (axis and `angle`
//!   in degrees), `scale` (missing axes 1), `matrix` (16 or 9 numbers,
//!   row-major) and `lookat` (Mitsuba's convention; an `up` parallel to the
//!   view direction is replaced by some perpendicular one instead of
//!   producing NaN).
//! - Numbers are separated by commas and/or whitespace; `1e-3` and `.5`
//!   are fine.
//! - `$name` is replaced in every attribute value, also inside longer
//!   strings. Parameters come from the caller's defines first, then from
//!   `<default>` in document order (a default never overrides). A define
//!   that the scene neither declares with a `<default>` nor reads as
//!   `$name` is an error, as in Mitsuba 3 ("unused parameters"): a
//!   misspelt `-D` would otherwise change nothing without a word.
//! - `<path value=>` adds a search directory, relative to the file that
//!   declares it. File names (includes, and later meshes and images via
//!   [`SceneDesc::resolve_file`]) are looked up in the main scene file's
//!   directory, then the `<path>` directories in declaration order. An
//!   `<include>` is additionally looked up next to the file that contains
//!   it. An included `<scene>` has its children spliced in place (with its
//!   own file name in locations); any other root element is inserted as one
//!   element. Include cycles are an error.
//!
//! # Legacy scenes
//!
//! Files whose `version` is below 2.0.0 (Mitsuba 0.5/0.6) are upgraded the
//! way Mitsuba 3 does it, per file: every `name` attribute except
//! `<default>`'s goes from camelCase to snake_case (`toWorld` → `to_world`,
//! `intIOR` → `int_ior`), `<lookAt>` is `<lookat>`, and `diffuse_reflectance`
//! of a `diffuse` BSDF is `reflectance`. `<srgb>` is accepted there as an
//! `rgb` whose values are sRGB-encoded and get linearized, as in Mitsuba
//! 0.6. Newer files must use the current spelling; the error then says so.
//! A missing `version` means the current one.
//!
//! # Errors
//!
//! Malformed XML, unknown tags and attributes, bad numbers, undefined
//! `$names`, unknown or duplicate ids and repeated parameter names are all
//! [`SceneError::At`] with the file and line (of the attribute where that
//! is more precise). A missing include is [`SceneError::NotFound`] listing
//! every path tried.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::Arc;

use glam::{DMat3, DMat4, DVec3};
use roxmltree::{Document, Node};

use crate::desc::{resolve_in, Category, Child, Object, Property, SceneDesc, Spectrum, Value};
use crate::error::{Location, SceneError};

/// The version assumed when a file has no `version` attribute.
const CURRENT_VERSION: (u32, u32, u32) = (3, 0, 0);

/// Reads and parses the scene file at `path`. `defines` are `-D name=value`
/// pairs; they take precedence over the scene's `<default>`s.
pub fn parse_file(path: &Path, defines: &[(String, String)]) -> Result<SceneDesc, SceneError> {
    let text = read_text(path)?;
    parse_str(&text, path, defines)
}

/// Parses scene text; `path` names the file in messages and its directory is
/// the first search path.
pub fn parse_str(
    text: &str,
    path: &Path,
    defines: &[(String, String)],
) -> Result<SceneDesc, SceneError> {
    let mut parser = Parser::new(path, defines);
    let file = Arc::new(path.to_path_buf());
    let doc = parse_document(text, &file)?;
    let root = doc.root_element();
    let version = read_version(&doc, root, &file)?.unwrap_or(CURRENT_VERSION);
    let src = Source::new(&doc, file, version);
    if root.tag_name().name() != "scene" {
        return Err(src.error(
            root,
            format!(
                "the root element must be <scene>, not <{}>",
                root.tag_name().name()
            ),
        ));
    }
    src.check_attributes(root, &["version"])?;
    let mut scene = Object::new(Category::Scene, "scene", src.loc(root));
    parser.parse_body(&src, root, &mut scene)?;
    let unused: Vec<&str> = defines
        .iter()
        .map(|(name, _)| name.as_str())
        .filter(|name| !parser.used.borrow().contains(*name))
        .collect();
    if !unused.is_empty() {
        return Err(SceneError::file(
            path,
            format!(
                "the scene has no parameter {} (no <default name=...> declares it and no $name reads it)",
                unused.join(", ")
            ),
        ));
    }
    let root = parser.resolve_forward(Rc::new(scene))?;
    Ok(SceneDesc {
        root,
        version,
        file: path.to_path_buf(),
        search_paths: parser.search_paths,
    })
}

/// The parse state shared by the main file and everything it includes.
struct Parser {
    /// `$name` values: the caller's defines, then `<default>`s.
    params: HashMap<String, String>,
    /// Parameter names a `<default>` declares or a `$name` reads.
    used: std::cell::RefCell<std::collections::HashSet<String>>,
    /// Objects declared with an `id`, for `<ref>`.
    ids: HashMap<String, Rc<Object>>,
    /// Stand-ins for `<ref>`s to ids not declared yet (Mitsuba resolves
    /// references after parsing), by address: the id and where it was used.
    /// The `Rc`s keep the addresses unique until they are resolved.
    forward: Vec<(Rc<Object>, String, Location)>,
    /// The main file's directory, then `<path>` entries.
    search_paths: Vec<PathBuf>,
    /// Files being included, outermost first, to catch cycles.
    include_stack: Vec<PathBuf>,
}

/// Rebuilds a parsed tree with forward references resolved.
struct Resolver<'a> {
    ids: &'a HashMap<String, Rc<Object>>,
    stand_ins: HashMap<*const Object, (&'a str, &'a Location)>,
    /// Each object already resolved, by its address before resolution.
    done: HashMap<*const Object, Rc<Object>>,
    /// Objects being resolved (to catch cycles).
    active: HashSet<*const Object>,
}

impl Resolver<'_> {
    fn resolve(&mut self, obj: &Rc<Object>) -> Result<Rc<Object>, SceneError> {
        let key = Rc::as_ptr(obj);
        if let Some(done) = self.done.get(&key) {
            return Ok(done.clone());
        }
        if let Some(&(id, loc)) = self.stand_ins.get(&key) {
            let target = self
                .ids
                .get(id)
                .ok_or_else(|| SceneError::at(loc, format!("unknown id \"{id}\"")))?
                .clone();
            let resolved = self.resolve(&target)?;
            self.done.insert(key, resolved.clone());
            return Ok(resolved);
        }
        if !self.active.insert(key) {
            return Err(obj.error("refers to itself through <ref> (a reference cycle)"));
        }
        let mut children = Vec::with_capacity(obj.children.len());
        let mut changed = false;
        for child in &obj.children {
            let object = self.resolve(&child.object)?;
            changed |= !Rc::ptr_eq(&object, &child.object);
            children.push(Child {
                object,
                ..child.clone()
            });
        }
        self.active.remove(&key);
        let resolved = if changed {
            Rc::new(Object {
                children,
                ..(**obj).clone()
            })
        } else {
            obj.clone()
        };
        self.done.insert(key, resolved.clone());
        Ok(resolved)
    }
}

/// One XML document being read: the tree, its file name and its version.
struct Source {
    file: Arc<PathBuf>,
    /// The directory of `file`.
    dir: PathBuf,
    /// Whether the file predates Mitsuba 2 and needs the legacy upgrades.
    legacy: bool,
    /// Byte offset of each line's start: a location is a binary search
    /// (roxmltree's `text_pos_at` scans the text from its start, which
    /// made loading a scene of many objects quadratic in its size).
    line_starts: Vec<usize>,
}

/// Byte offsets where the lines of `text` start.
fn line_starts(text: &str) -> Vec<usize> {
    std::iter::once(0)
        .chain(text.match_indices('\n').map(|(i, _)| i + 1))
        .collect()
}

/// The 1-based line of byte offset `pos`, given the lines' starts.
fn line_at(line_starts: &[usize], pos: usize) -> u32 {
    line_starts.partition_point(|&start| start <= pos) as u32
}

/// An attribute value after `$` substitution, with its line.
struct Attr {
    value: String,
    loc: Location,
}

impl Parser {
    fn new(path: &Path, defines: &[(String, String)]) -> Self {
        Self {
            params: defines.iter().cloned().collect(),
            used: Default::default(),
            ids: HashMap::new(),
            forward: Vec::new(),
            search_paths: vec![directory_of(path)],
            include_stack: vec![path.to_path_buf()],
        }
    }

    /// Parses every child element of `node` into `target`.
    fn parse_body(
        &mut self,
        src: &Source,
        node: Node,
        target: &mut Object,
    ) -> Result<(), SceneError> {
        for element in node.children().filter(Node::is_element) {
            self.parse_element(src, element, target)?;
        }
        Ok(())
    }

    /// One element inside an object (or the scene): a directive, a
    /// property, a reference or a nested object.
    fn parse_element(
        &mut self,
        src: &Source,
        el: Node,
        target: &mut Object,
    ) -> Result<(), SceneError> {
        let tag = el.tag_name().name();
        match tag {
            "default" => self.define_default(src, el),
            "path" => self.add_search_path(src, el),
            "include" => self.include(src, el, target),
            "alias" => self.alias(src, el),
            "ref" => {
                let child = self.reference(src, el, target)?;
                add_child(target, child)
            }
            "spectrum" if el.attribute("type").is_none() => {
                let prop = self.property(src, el, target)?;
                add_property(target, prop)
            }
            "integer" | "float" | "boolean" | "string" | "rgb" | "point" | "vector"
            | "transform" => {
                let prop = self.property(src, el, target)?;
                add_property(target, prop)
            }
            "srgb" if src.legacy => {
                let prop = self.property(src, el, target)?;
                add_property(target, prop)
            }
            "scene" => Err(src.error(el, "<scene> cannot be nested")),
            _ => match Category::from_tag(tag) {
                Some(category) => {
                    let child = self.object(src, el, category, target)?;
                    add_child(target, child)
                }
                None => Err(src.error(el, unknown_tag_message(tag, "scene element"))),
            },
        }
    }

    /// `<default name= value=>`: defines `$name` unless already defined.
    fn define_default(&mut self, src: &Source, el: Node) -> Result<(), SceneError> {
        src.check_attributes(el, &["name", "value"])?;
        let name = src.raw_attribute(el, "name")?;
        let value = self.required(src, el, "value")?.value;
        self.used.borrow_mut().insert(name.clone());
        self.params.entry(name).or_insert(value);
        Ok(())
    }

    /// `<path value=>`: a search directory relative to the current file.
    fn add_search_path(&mut self, src: &Source, el: Node) -> Result<(), SceneError> {
        src.check_attributes(el, &["value"])?;
        let value = self.required(src, el, "value")?.value;
        let dir = self.search_dir(src, &value);
        if !self.search_paths.contains(&dir) {
            self.search_paths.push(dir);
        }
        Ok(())
    }

    /// The folder a `<path value=>` names. As in Mitsuba, a relative value
    /// is looked up like a file (the main scene's folder, then the folders
    /// added so far), so an included file's `<path>` may be relative to the
    /// main scene; failing that, it is relative to the declaring file.
    fn search_dir(&self, src: &Source, value: &str) -> PathBuf {
        let own = src.dir.join(value);
        if Path::new(value).is_absolute() {
            return own;
        }
        self.search_paths
            .iter()
            .map(|d| d.join(value))
            .find(|d| d.is_dir())
            .unwrap_or(own)
    }

    /// `<alias id= as=>`: a second id for an object declared earlier.
    fn alias(&mut self, src: &Source, el: Node) -> Result<(), SceneError> {
        src.check_attributes(el, &["id", "as"])?;
        let id = self.required(src, el, "id")?;
        let alias = self.required(src, el, "as")?;
        let object = self.lookup_id(&id)?;
        self.register_id(&alias, object)
    }

    /// `<include filename=>`: parses the file and splices its content into
    /// `target`.
    fn include(&mut self, src: &Source, el: Node, target: &mut Object) -> Result<(), SceneError> {
        src.check_attributes(el, &["filename"])?;
        let name = self.required(src, el, "filename")?;
        let mut dirs = self.search_paths.clone();
        if !dirs.contains(&src.dir) {
            dirs.push(src.dir.clone());
        }
        let path = resolve_in(&dirs, &name.value, Some(&name.loc))?;
        self.enter_include(&path, &name.loc)?;
        let text = read_text(&path)?;
        let file = Arc::new(path);
        let doc = parse_document(&text, &file)?;
        let root = doc.root_element();
        let result = if root.tag_name().name() == "scene" {
            let version = read_version(&doc, root, &file)?.unwrap_or(CURRENT_VERSION);
            let nested = Source::new(&doc, file, version);
            nested.check_attributes(root, &["version"])?;
            self.parse_body(&nested, root, target)
        } else {
            let nested = Source {
                dir: directory_of(&file),
                file,
                legacy: src.legacy,
                line_starts: line_starts(doc.input_text()),
            };
            self.parse_element(&nested, root, target)
        };
        self.include_stack.pop();
        result
    }

    /// Pushes `path` on the include stack, refusing cycles.
    fn enter_include(&mut self, path: &Path, loc: &Location) -> Result<(), SceneError> {
        let key = canonical(path);
        if self.include_stack.iter().any(|p| canonical(p) == key) {
            return Err(SceneError::at(
                loc,
                format!("include cycle: \"{}\" includes itself", path.display()),
            ));
        }
        yubin_core::limits::Limit::IncludeDepth
            .check(self.include_stack.len() as u64, || {
                format!(
                    "\"{}\", included {} files deep,",
                    path.display(),
                    self.include_stack.len()
                )
            })
            .map_err(|e| SceneError::at(loc, e))?;
        self.include_stack.push(path.to_path_buf());
        Ok(())
    }

    /// `<ref id= [name=]>`: the object declared with that id, before or
    /// (through a stand-in resolved after parsing) after the reference.
    fn reference(&mut self, src: &Source, el: Node, parent: &Object) -> Result<Child, SceneError> {
        src.check_attributes(el, &["id", "name"])?;
        let id = self.required(src, el, "id")?;
        let object = match self.ids.get(&id.value) {
            Some(object) => object.clone(),
            None => {
                let stand_in = Rc::new(Object::new(Category::Scene, "ref", id.loc.clone()));
                self.forward
                    .push((stand_in.clone(), id.value.clone(), id.loc.clone()));
                stand_in
            }
        };
        Ok(Child {
            name: self.child_name(src, el, parent)?,
            object,
            loc: src.loc(el),
            used: Default::default(),
        })
    }

    /// A nested object: `<bsdf type= [id=] [name=]>` and its body.
    fn object(
        &mut self,
        src: &Source,
        el: Node,
        category: Category,
        parent: &Object,
    ) -> Result<Child, SceneError> {
        src.check_attributes(el, &["type", "id", "name"])?;
        let loc = src.loc(el);
        // A <world> has no plugin type: it is a group of objects.
        let kind = if category == Category::World {
            "world".to_string()
        } else {
            self.required(src, el, "type")?.value
        };
        let mut object = Object::new(category, kind, loc.clone());
        let id = self.optional(src, el, "id")?;
        object.id = id.as_ref().map(|a| a.value.clone());
        object.name = self.child_name(src, el, parent)?;
        self.parse_body(src, el, &mut object)?;
        let name = object.name.clone();
        let object = Rc::new(object);
        if let Some(id) = id {
            self.register_id(&id, object.clone())?;
        }
        Ok(Child {
            name,
            object,
            loc,
            used: Default::default(),
        })
    }

    /// Records `object` under `id`; a second declaration is an error.
    fn register_id(&mut self, id: &Attr, object: Rc<Object>) -> Result<(), SceneError> {
        if let Some(previous) = self.ids.get(&id.value) {
            return Err(SceneError::at(
                &id.loc,
                format!(
                    "duplicate id \"{}\" (already declared at {})",
                    id.value, previous.loc
                ),
            ));
        }
        self.ids.insert(id.value.clone(), object);
        Ok(())
    }

    fn lookup_id(&self, id: &Attr) -> Result<Rc<Object>, SceneError> {
        self.ids
            .get(&id.value)
            .cloned()
            .ok_or_else(|| SceneError::at(&id.loc, format!("unknown id \"{}\"", id.value)))
    }

    /// Replaces the stand-ins of forward references with the objects they
    /// name, rebuilding only the objects on a path to a stand-in (shared
    /// objects stay shared). A reference cycle is an error.
    fn resolve_forward(&self, root: Rc<Object>) -> Result<Rc<Object>, SceneError> {
        if self.forward.is_empty() {
            return Ok(root);
        }
        let stand_ins: HashMap<*const Object, (&str, &Location)> = self
            .forward
            .iter()
            .map(|(o, id, loc)| (Rc::as_ptr(o), (id.as_str(), loc)))
            .collect();
        let mut resolver = Resolver {
            ids: &self.ids,
            stand_ins,
            done: HashMap::new(),
            active: HashSet::new(),
        };
        resolver.resolve(&root)
    }

    /// A property element: its name and parsed value.
    fn property(&self, src: &Source, el: Node, parent: &Object) -> Result<Property, SceneError> {
        let tag = el.tag_name().name();
        let allowed: &[&str] = match tag {
            "point" | "vector" => &["name", "value", "x", "y", "z"],
            "transform" => &["name"],
            "spectrum" => &["name", "value", "filename"],
            _ => &["name", "value"],
        };
        src.check_attributes(el, allowed)?;
        let name = self
            .property_name(src, el, parent)?
            .ok_or_else(|| src.error(el, format!("<{tag}> needs a \"name\" attribute")))?;
        let mut look_at_target = None;
        let value = match tag {
            "integer" => Value::Integer(self.integer_value(src, el)?),
            "float" => Value::Float(self.float_value(src, el)?),
            "boolean" => Value::Boolean(self.boolean_value(src, el)?),
            "string" => Value::String(self.required(src, el, "value")?.value),
            "rgb" => Value::Rgb(self.rgb_value(src, el, false)?),
            "srgb" => Value::Rgb(self.rgb_value(src, el, true)?),
            "spectrum" => Value::Spectrum(self.spectrum_value(src, el)?),
            "point" => Value::Point(self.vec3(src, el, 0.0)?.as_vec3()),
            "vector" => Value::Vector(self.vec3(src, el, 0.0)?.as_vec3()),
            "transform" => {
                let (m, target) = self.transform_value(src, el)?;
                look_at_target = target.map(|t| t.as_vec3());
                Value::Transform(m)
            }
            _ => return Err(src.error(el, unknown_tag_message(tag, "property"))),
        };
        Ok(Property {
            name,
            value,
            loc: src.loc(el),
            used: Default::default(),
            look_at_target,
        })
    }

    fn integer_value(&self, src: &Source, el: Node) -> Result<i64, SceneError> {
        let attr = self.required(src, el, "value")?;
        attr.value.trim().parse().map_err(|_| {
            SceneError::at(
                &attr.loc,
                format!("invalid integer \"{}\" in <integer>", attr.value),
            )
        })
    }

    fn float_value(&self, src: &Source, el: Node) -> Result<f64, SceneError> {
        let attr = self.required(src, el, "value")?;
        parse_number(&attr.value, &attr.loc)
    }

    fn boolean_value(&self, src: &Source, el: Node) -> Result<bool, SceneError> {
        let attr = self.required(src, el, "value")?;
        match attr.value.trim().to_ascii_lowercase().as_str() {
            "true" => Ok(true),
            "false" => Ok(false),
            _ => Err(SceneError::at(
                &attr.loc,
                format!(
                    "invalid boolean \"{}\" (expected true or false)",
                    attr.value
                ),
            )),
        }
    }

    /// `<rgb value=>`: one number (gray), three numbers or `#rrggbb`.
    /// `encoded` (the legacy `<srgb>`) linearizes the values.
    fn rgb_value(&self, src: &Source, el: Node, encoded: bool) -> Result<[f32; 3], SceneError> {
        let attr = self.required(src, el, "value")?;
        let text = attr.value.trim();
        if let Some(hex) = text.strip_prefix('#') {
            let rgb = parse_hex_color(hex, &attr.loc)?;
            return Ok(rgb.map(srgb_to_linear));
        }
        let numbers = parse_numbers(text, &attr.loc)?;
        let rgb = match numbers[..] {
            [v] => [v as f32; 3],
            [r, g, b] => [r as f32, g as f32, b as f32],
            _ => {
                return Err(SceneError::at(
                    &attr.loc,
                    format!(
                        "an rgb value needs 1 or 3 numbers, got {} in \"{}\"",
                        numbers.len(),
                        attr.value
                    ),
                ))
            }
        };
        Ok(if encoded {
            rgb.map(srgb_to_linear)
        } else {
            rgb
        })
    }

    fn spectrum_value(&self, src: &Source, el: Node) -> Result<Spectrum, SceneError> {
        if el.attribute("filename").is_some() {
            return Err(src.error(
                el,
                "spectra read from files (filename=) are not supported; \
                 write them inline as value=\"400:0.1, 500:0.2, ...\"",
            ));
        }
        let attr = self.required(src, el, "value")?;
        parse_spectrum(&attr.value, &attr.loc)
    }

    /// A 3-vector from `value` (one number for all three, or three) or from
    /// `x`/`y`/`z`, each missing one being `default`.
    fn vec3(&self, src: &Source, el: Node, default: f64) -> Result<DVec3, SceneError> {
        let xyz = ["x", "y", "z"];
        if let Some(attr) = self.optional(src, el, "value")? {
            if let Some(axis) = xyz.into_iter().find(|a| el.attribute(*a).is_some()) {
                return Err(src.error(
                    el,
                    format!("\"value\" and \"{axis}\" cannot be given together"),
                ));
            }
            return parse_vec3(&attr.value, &attr.loc);
        }
        let mut v = [default; 3];
        for (slot, axis) in v.iter_mut().zip(xyz) {
            if let Some(attr) = self.optional(src, el, axis)? {
                *slot = parse_number(&attr.value, &attr.loc)?;
            }
        }
        Ok(DVec3::from_array(v))
    }

    /// `<transform>`: its ops composed in order, each applied after the
    /// previous ones; with the last `<lookat>`'s target, moved by the ops
    /// after it.
    fn transform_value(
        &self,
        src: &Source,
        el: Node,
    ) -> Result<(DMat4, Option<DVec3>), SceneError> {
        let mut matrix = DMat4::IDENTITY;
        let mut target: Option<DVec3> = None;
        for op in el.children().filter(Node::is_element) {
            let m = self.transform_op(src, op)?;
            matrix = m * matrix;
            target = match op.tag_name().name() {
                "lookat" | "lookAt" => self.point_attribute(src, op, "target").ok(),
                _ => target.map(|t| m.transform_point3(t)),
            };
        }
        Ok((matrix, target))
    }

    fn transform_op(&self, src: &Source, op: Node) -> Result<DMat4, SceneError> {
        match op.tag_name().name() {
            "translate" => {
                src.check_attributes(op, &["value", "x", "y", "z"])?;
                Ok(DMat4::from_translation(self.vec3(src, op, 0.0)?))
            }
            "scale" => {
                src.check_attributes(op, &["value", "x", "y", "z"])?;
                Ok(DMat4::from_scale(self.vec3(src, op, 1.0)?))
            }
            "rotate" => self.rotation(src, op),
            "matrix" => self.matrix(src, op),
            "lookat" => self.look_at(src, op),
            "lookAt" if src.legacy => self.look_at(src, op),
            tag => Err(src.error(op, unknown_tag_message(tag, "transform operation"))),
        }
    }

    /// `<rotate x= y= z= angle=>` or `<rotate value="x,y,z" angle=>`.
    fn rotation(&self, src: &Source, op: Node) -> Result<DMat4, SceneError> {
        src.check_attributes(op, &["value", "x", "y", "z", "angle"])?;
        let axis = self.vec3(src, op, 0.0)?;
        let angle = self.required(src, op, "angle")?;
        let degrees = parse_number(&angle.value, &angle.loc)?;
        rotation_matrix(axis, degrees).ok_or_else(|| src.error(op, "the rotation axis is zero"))
    }

    /// `<matrix value=>`: 16 numbers (4×4) or 9 (3×3), row-major.
    fn matrix(&self, src: &Source, op: Node) -> Result<DMat4, SceneError> {
        src.check_attributes(op, &["value"])?;
        let attr = self.required(src, op, "value")?;
        let numbers = parse_numbers(&attr.value, &attr.loc)?;
        match numbers.len() {
            16 => Ok(DMat4::from_cols_slice(&numbers).transpose()),
            9 => Ok(DMat4::from_mat3(
                DMat3::from_cols_slice(&numbers).transpose(),
            )),
            n => Err(SceneError::at(
                &attr.loc,
                format!("a matrix needs 16 or 9 numbers, got {n}"),
            )),
        }
    }

    /// A point written as attribute `name` of `op`.
    fn point_attribute(&self, src: &Source, op: Node, name: &str) -> Result<DVec3, SceneError> {
        let attr = self.required(src, op, name)?;
        parse_vec3(&attr.value, &attr.loc)
    }

    /// `<lookat origin= target= [up=]>`.
    fn look_at(&self, src: &Source, op: Node) -> Result<DMat4, SceneError> {
        src.check_attributes(op, &["origin", "target", "up"])?;
        let origin = self.point_attribute(src, op, "origin")?;
        let target = self.point_attribute(src, op, "target")?;
        let up = match self.optional(src, op, "up")? {
            Some(attr) => parse_vec3(&attr.value, &attr.loc)?,
            None => DVec3::ZERO,
        };
        look_at_matrix(origin, target, up)
            .ok_or_else(|| src.error(op, "lookat: origin and target are the same point"))
    }

    /// The `name` of a property, upgraded for legacy files.
    fn property_name(
        &self,
        src: &Source,
        el: Node,
        parent: &Object,
    ) -> Result<Option<String>, SceneError> {
        let Some(attr) = self.optional(src, el, "name")? else {
            return Ok(None);
        };
        if !src.legacy {
            return Ok(Some(attr.value));
        }
        let name = to_snake_case(&attr.value);
        let diffuse = parent.category == Category::Bsdf && parent.plugin_type == "diffuse";
        Ok(Some(if diffuse && name == "diffuse_reflectance" {
            "reflectance".to_string()
        } else {
            name
        }))
    }

    /// The `name` of a nested object or reference (same upgrade rules).
    fn child_name(
        &self,
        src: &Source,
        el: Node,
        parent: &Object,
    ) -> Result<Option<String>, SceneError> {
        self.property_name(src, el, parent)
    }

    /// Attribute `name` after `$` substitution, if present.
    fn optional(&self, src: &Source, el: Node, name: &str) -> Result<Option<Attr>, SceneError> {
        let Some(attr) = el.attributes().find(|a| a.name() == name) else {
            return Ok(None);
        };
        let loc = src.loc_at(attr.range().start);
        let value = self.substitute(attr.value(), &loc)?;
        Ok(Some(Attr { value, loc }))
    }

    /// Attribute `name` after `$` substitution; an error when missing.
    fn required(&self, src: &Source, el: Node, name: &str) -> Result<Attr, SceneError> {
        self.optional(src, el, name)?.ok_or_else(|| {
            src.error(
                el,
                format!("<{}> needs a \"{name}\" attribute", el.tag_name().name()),
            )
        })
    }

    /// Replaces every `$name` in `text` by its parameter value. A `$` not
    /// followed by a name character is kept as is.
    fn substitute(&self, text: &str, loc: &Location) -> Result<String, SceneError> {
        if !text.contains('$') {
            return Ok(text.to_string());
        }
        let mut out = String::with_capacity(text.len());
        let mut rest = text;
        while let Some(dollar) = rest.find('$') {
            out.push_str(&rest[..dollar]);
            let after = &rest[dollar + 1..];
            let len = after
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            let name = &after[..len];
            if name.is_empty() {
                out.push('$');
            } else {
                let value = self.params.get(name).ok_or_else(|| {
                    SceneError::at(
                        loc,
                        format!(
                            "undefined parameter \"${name}\" (declare it with <default name=\"{name}\" value=\"...\"/> or -D {name}=...)"
                        ),
                    )
                })?;
                self.used.borrow_mut().insert(name.to_string());
                out.push_str(value);
            }
            rest = &after[len..];
        }
        out.push_str(rest);
        Ok(out)
    }
}

impl Source {
    fn new(doc: &Document, file: Arc<PathBuf>, version: (u32, u32, u32)) -> Self {
        Self {
            dir: directory_of(&file),
            file,
            legacy: version < (2, 0, 0),
            line_starts: line_starts(doc.input_text()),
        }
    }

    /// The location of `node`'s start tag.
    fn loc(&self, node: Node) -> Location {
        self.loc_at(node.range().start)
    }

    /// The location of byte offset `pos`.
    fn loc_at(&self, pos: usize) -> Location {
        Location::new(self.file.clone(), line_at(&self.line_starts, pos))
    }

    fn error(&self, node: Node, msg: impl Into<String>) -> SceneError {
        SceneError::at(&self.loc(node), msg)
    }

    /// An attribute's value without substitution (for `<default name=>`).
    fn raw_attribute(&self, el: Node, name: &str) -> Result<String, SceneError> {
        el.attribute(name).map(str::to_string).ok_or_else(|| {
            self.error(
                el,
                format!("<{}> needs a \"{name}\" attribute", el.tag_name().name()),
            )
        })
    }

    /// Errors on the first attribute of `el` not in `allowed`.
    fn check_attributes(&self, el: Node, allowed: &[&str]) -> Result<(), SceneError> {
        match el.attributes().find(|a| !allowed.contains(&a.name())) {
            Some(attr) => Err(SceneError::at(
                &self.loc_at(attr.range().start),
                format!(
                    "unexpected attribute \"{}\" on <{}> (allowed: {})",
                    attr.name(),
                    el.tag_name().name(),
                    allowed.join(", ")
                ),
            )),
            None => Ok(()),
        }
    }
}

/// Appends `prop` to `target`, refusing a second parameter of the same name.
fn add_property(target: &mut Object, prop: Property) -> Result<(), SceneError> {
    check_name_is_new(target, &prop.name, &prop.loc)?;
    target.props.push(prop);
    Ok(())
}

/// Appends `child` to `target`, refusing a second child of the same name.
fn add_child(target: &mut Object, child: Child) -> Result<(), SceneError> {
    if let Some(name) = &child.name {
        check_name_is_new(target, name, &child.loc)?;
    }
    target.children.push(child);
    Ok(())
}

fn check_name_is_new(target: &Object, name: &str, loc: &Location) -> Result<(), SceneError> {
    let previous = target
        .props
        .iter()
        .find(|p| p.name == name)
        .map(|p| &p.loc)
        .or_else(|| {
            target
                .children
                .iter()
                .find(|c| c.name.as_deref() == Some(name))
                .map(|c| &c.loc)
        });
    match previous {
        Some(first) => Err(SceneError::at(
            loc,
            format!(
                "parameter \"{name}\" of {} is given twice (first at {first})",
                target.describe()
            ),
        )),
        None => Ok(()),
    }
}

fn unknown_tag_message(tag: &str, expected: &str) -> String {
    let hint = match tag {
        "lookAt" => " (write <lookat>; <lookAt> is only accepted in files with version < 2.0.0)",
        "srgb" => " (write <rgb> with linear values; <srgb> is only accepted in files with version < 2.0.0)",
        _ => "",
    };
    format!("unknown tag <{tag}> where a {expected} was expected{hint}")
}

fn read_text(path: &Path) -> Result<String, SceneError> {
    std::fs::read_to_string(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        error: source,
    })
}

/// Elements may nest this deep (Mitsuba's scenes nest a dozen levels;
/// at 1000, reading the objects overflowed a 2 MiB stack):
/// the XML parser, and the reading of objects after it, recurse once per
/// level, and a file of a million nested tags would overflow the stack.
const MAX_NESTING: usize = 256;

/// Parses XML text; a syntax error becomes an error at its line.
fn parse_document<'input>(
    text: &'input str,
    file: &Arc<PathBuf>,
) -> Result<Document<'input>, SceneError> {
    if let Some(offset) = too_deep(text.as_bytes(), MAX_NESTING) {
        let row = text[..offset].bytes().filter(|&b| b == b'\n').count() as u32 + 1;
        return Err(SceneError::at(
            &Location::new(file.clone(), row),
            format!("elements nested more than {MAX_NESTING} deep"),
        ));
    }
    let options = roxmltree::ParsingOptions {
        allow_dtd: true,
        ..Default::default()
    };
    Document::parse_with_options(text, options).map_err(|e| {
        SceneError::at(
            &Location::new(file.clone(), e.pos().row),
            format!("malformed XML: {e}"),
        )
    })
}

/// The offset of the first tag nested deeper than `limit` in XML text,
/// if any: opening tags counted against closing ones, comments, CDATA,
/// processing instructions and declarations skipped, quoted attribute
/// values (which may hold `/>`) read through. Malformed text is left to
/// the parser.
fn too_deep(text: &[u8], limit: usize) -> Option<usize> {
    let find = |from: usize, what: &[u8]| {
        (text.get(from..)?.windows(what.len()))
            .position(|w| w == what)
            .map(|p| from + p + what.len())
    };
    let (mut depth, mut i) = (0usize, 0usize);
    while let Some(p) = text.get(i..)?.iter().position(|&b| b == b'<') {
        let at = i + p;
        let rest = &text[at..];
        i = if rest.starts_with(b"<!--") {
            find(at, b"-->")?
        } else if rest.starts_with(b"<![CDATA[") {
            find(at, b"]]>")?
        } else if rest.starts_with(b"<?") {
            find(at, b"?>")?
        } else if rest.starts_with(b"<!") || rest.starts_with(b"</") {
            depth = depth.saturating_sub(usize::from(rest[1] == b'/'));
            find(at, b">")?
        } else {
            let (end, self_closing) = tag_end(text, at)?;
            if !self_closing {
                depth += 1;
                if depth > limit {
                    return Some(at);
                }
            }
            end
        };
    }
    None
}

/// Where the opening tag at `start` ends (past its `>`), and whether it
/// closes itself (`/>`); quoted attribute values are skipped whole.
fn tag_end(text: &[u8], start: usize) -> Option<(usize, bool)> {
    let mut quote = None;
    for (i, &b) in text.iter().enumerate().skip(start + 1) {
        match (quote, b) {
            (Some(q), _) if b == q => quote = None,
            (Some(_), _) => {}
            (None, b'"' | b'\'') => quote = Some(b),
            (None, b'>') => return Some((i + 1, text[i - 1] == b'/')),
            _ => {}
        }
    }
    None
}

/// The `version` attribute of a root element, if it has one.
fn read_version(
    doc: &Document,
    root: Node,
    file: &Arc<PathBuf>,
) -> Result<Option<(u32, u32, u32)>, SceneError> {
    let Some(attr) = root.attributes().find(|a| a.name() == "version") else {
        return Ok(None);
    };
    let loc = Location::new(file.clone(), doc.text_pos_at(attr.range().start).row);
    parse_version(attr.value())
        .map(Some)
        .ok_or_else(|| SceneError::at(&loc, format!("invalid version \"{}\"", attr.value())))
}

/// `"3.0.0"`, `"0.6"` or `"2"` as (major, minor, patch).
fn parse_version(text: &str) -> Option<(u32, u32, u32)> {
    let mut parts = [0u32; 3];
    for (i, piece) in text.trim().split('.').enumerate() {
        *parts.get_mut(i)? = piece.parse().ok()?;
    }
    Some((parts[0], parts[1], parts[2]))
}

fn directory_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

fn canonical(path: &Path) -> PathBuf {
    std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf())
}

/// The pieces of a number list: separated by commas and/or whitespace.
fn number_tokens(text: &str) -> impl Iterator<Item = &str> {
    text.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
}

/// One number (surrounding whitespace allowed).
fn parse_number(text: &str, loc: &Location) -> Result<f64, SceneError> {
    text.trim()
        .parse()
        .map_err(|_| SceneError::at(loc, format!("invalid number \"{text}\"")))
}

/// A list of numbers separated by commas and/or whitespace.
fn parse_numbers(text: &str, loc: &Location) -> Result<Vec<f64>, SceneError> {
    number_tokens(text)
        .map(|t| {
            t.parse()
                .map_err(|_| SceneError::at(loc, format!("invalid number \"{t}\" in \"{text}\"")))
        })
        .collect()
}

/// One number (used for all three components) or three.
fn parse_vec3(text: &str, loc: &Location) -> Result<DVec3, SceneError> {
    match parse_numbers(text, loc)?[..] {
        [v] => Ok(DVec3::splat(v)),
        [x, y, z] => Ok(DVec3::new(x, y, z)),
        ref other => Err(SceneError::at(
            loc,
            format!("expected 1 or 3 numbers, got {} in \"{text}\"", other.len()),
        )),
    }
}

/// `"0.5"` (constant) or `"400:0.1, 500:0.2"` (sampled, wavelengths in nm
/// and increasing).
fn parse_spectrum(text: &str, loc: &Location) -> Result<Spectrum, SceneError> {
    let compact = remove_space_around_colons(text);
    if !compact.contains(':') {
        return match parse_numbers(text, loc)?[..] {
            [v] => Ok(Spectrum::Constant(v as f32)),
            _ => Err(SceneError::at(
                loc,
                format!("a spectrum is one number or wavelength:value pairs, not \"{text}\""),
            )),
        };
    }
    let mut samples: Vec<(f32, f32)> = Vec::new();
    for token in number_tokens(&compact) {
        let bad = || {
            SceneError::at(
                loc,
                format!("invalid spectrum sample \"{token}\" (expected wavelength:value)"),
            )
        };
        let (wavelength, value) = token.split_once(':').ok_or_else(bad)?;
        let wavelength: f32 = wavelength.parse().map_err(|_| bad())?;
        let value: f32 = value.parse().map_err(|_| bad())?;
        if samples.last().is_some_and(|&(prev, _)| wavelength <= prev) {
            return Err(SceneError::at(
                loc,
                format!("spectrum wavelengths must increase (at \"{token}\")"),
            ));
        }
        samples.push((wavelength, value));
    }
    Ok(Spectrum::Sampled(samples))
}

/// `"400 : 0.1"` → `"400:0.1"`, so that pairs survive whitespace splitting.
fn remove_space_around_colons(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut after_colon = false;
    for c in text.chars() {
        if c == ':' {
            out.truncate(out.trim_end().len());
            after_colon = true;
        } else if after_colon && c.is_whitespace() {
            continue;
        } else {
            after_colon = false;
        }
        out.push(c);
    }
    out
}

/// `rrggbb` as three values in [0, 1] (still sRGB-encoded).
fn parse_hex_color(hex: &str, loc: &Location) -> Result<[f32; 3], SceneError> {
    let bad = || SceneError::at(loc, format!("invalid colour \"#{hex}\" (expected #rrggbb)"));
    if hex.len() != 6 || !hex.is_ascii() {
        return Err(bad());
    }
    let mut rgb = [0.0; 3];
    for (i, slot) in rgb.iter_mut().enumerate() {
        let byte = u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).map_err(|_| bad())?;
        *slot = f32::from(byte) / 255.0;
    }
    Ok(rgb)
}

/// The sRGB transfer function, inverted (IEC 61966-2-1).
fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Rotation by `degrees` about `axis` (right-handed, Rodrigues' formula);
/// `None` for a zero axis.
fn rotation_matrix(axis: DVec3, degrees: f64) -> Option<DMat4> {
    let axis = axis.try_normalize()?;
    Some(DMat4::from_axis_angle(axis, degrees.to_radians()))
}

/// Mitsuba's `Transform4f::look_at`: columns left, up, dir, origin with
/// `dir = normalize(target − origin)`, `left = normalize(up × dir)`,
/// `up' = dir × left`. An `up` parallel to `dir` (or zero) is replaced by
/// some perpendicular direction. `None` when origin equals target.
fn look_at_matrix(origin: DVec3, target: DVec3, up: DVec3) -> Option<DMat4> {
    let dir = (target - origin).try_normalize()?;
    let cross = up.cross(dir);
    let left = if cross.length() > 1e-9 * up.length() {
        cross.normalize()
    } else {
        dir.any_orthonormal_vector()
    };
    let new_up = dir.cross(left);
    Some(DMat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    ))
}

/// `toWorld` → `to_world`, `intIOR` → `int_ior`, `HDRFilm` → `hdr_film`.
fn to_snake_case(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    let mut out = String::with_capacity(name.len() + 4);
    for (i, &c) in chars.iter().enumerate() {
        if !c.is_ascii_uppercase() {
            out.push(c);
            continue;
        }
        let prev = i.checked_sub(1).and_then(|j| chars.get(j));
        let next = chars.get(i + 1);
        let after_lower = prev.is_some_and(|p| p.is_ascii_lowercase() || p.is_ascii_digit());
        let ends_acronym = prev.is_some_and(char::is_ascii_uppercase)
            && next.is_some_and(char::is_ascii_lowercase);
        if after_lower || ends_acronym {
            out.push('_');
        }
        out.push(c.to_ascii_lowercase());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_lookup_agrees_with_roxmltree_at_every_byte() {
        let text =
            "<scene version=\"3.0.0\">\r\n\n  <shape type=\"sphere\"/>\n<!-- é -->\n</scene>\n";
        let doc = Document::parse(text).unwrap();
        let starts = line_starts(text);
        for pos in (0..=text.len()).filter(|&p| text.is_char_boundary(p)) {
            assert_eq!(
                line_at(&starts, pos),
                doc.text_pos_at(pos).row,
                "byte {pos}"
            );
        }
    }
    use glam::{DVec4, Vec3};

    fn parse(text: &str) -> Result<SceneDesc, SceneError> {
        parse_str(text, Path::new("scene.xml"), &[])
    }

    fn parse_ok(text: &str) -> SceneDesc {
        match parse(text) {
            Ok(desc) => desc,
            Err(e) => panic!("parse failed: {e}"),
        }
    }

    fn error_text(text: &str) -> String {
        match parse(text) {
            Ok(_) => panic!("expected an error for:\n{text}"),
            Err(e) => e.to_string(),
        }
    }

    fn scene(body: &str) -> String {
        format!("<scene version=\"3.0.0\">\n{body}\n</scene>")
    }

    /// The first top-level object.
    fn first(desc: &SceneDesc) -> &Object {
        &desc.root.children[0].object
    }

    /// The transform `to_world` of the first top-level object.
    fn to_world(body: &str) -> DMat4 {
        let desc = parse_ok(&scene(body));
        first(&desc).transform("to_world").unwrap()
    }

    fn assert_mat_eq(a: DMat4, b: DMat4) {
        assert!(a.abs_diff_eq(b, 1e-9), "\n{a}\n!=\n{b}");
    }

    fn apply(m: DMat4, p: DVec3) -> DVec3 {
        m.transform_point3(p)
    }

    /// A fresh directory under the system temp dir for file tests.
    fn temp_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("yubin-xml-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A define the scene neither declares nor reads is refused, named;
    /// one it reads as `$name` without a default, or declares without
    /// reading, is taken.
    #[test]
    fn unused_defines_are_an_error() {
        let text = scene(
            r#"<default name="unread" value="1"/>
               <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>"#,
        );
        let define = |pairs: &[(&str, &str)]| -> Vec<(String, String)> {
            pairs
                .iter()
                .map(|(n, v)| (n.to_string(), v.to_string()))
                .collect()
        };
        let path = Path::new("scene.xml");
        assert!(parse_str(&text, path, &define(&[("spp", "4"), ("unread", "2")])).is_ok());
        let err = parse_str(
            &text,
            path,
            &define(&[("spp", "4"), ("sp", "8"), ("max_depth", "2")]),
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.contains("scene.xml") && err.contains("no parameter sp, max_depth"),
            "{err}"
        );
    }

    #[test]
    fn defaults_apply_and_defines_override_them() {
        let text = scene(
            r#"<default name="spp" value="16"/>
               <default name="spp" value="99"/>
               <default name="res" value="32"/>
               <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
               <film type="hdrfilm"><integer name="width" value="$res"/></film>"#,
        );
        let desc = parse_ok(&text);
        assert_eq!(first(&desc).integer("sample_count").unwrap(), Some(16));
        let defines = [("spp".to_string(), "4".to_string())];
        let desc = parse_str(&text, Path::new("scene.xml"), &defines).unwrap();
        assert_eq!(first(&desc).integer("sample_count").unwrap(), Some(4));
        let film = &desc.root.children[1].object;
        assert_eq!(film.integer("width").unwrap(), Some(32));
    }

    #[test]
    fn dollar_names_are_substituted_inside_strings_and_types() {
        let desc = parse_ok(&scene(
            r#"<default name="kind" value="path"/>
               <default name="name" value="bunny"/>
               <default name="name_lo" value="lowres"/>
               <integrator type="$kind">
                   <string name="file" value="meshes/$name_lo/$name.obj, cost $"/>
               </integrator>"#,
        ));
        let integrator = first(&desc);
        assert_eq!(integrator.plugin_type, "path");
        assert_eq!(
            integrator.string("file").unwrap(),
            Some("meshes/lowres/bunny.obj, cost $")
        );
    }

    #[test]
    fn undefined_parameter_is_an_error_at_its_line() {
        let err = error_text(&scene(
            "<sampler type=\"independent\">\n<integer name=\"sample_count\" value=\"$spp\"/>\n</sampler>",
        ));
        assert!(err.starts_with("scene.xml:3: "), "{err}");
        assert!(err.contains("undefined parameter \"$spp\""), "{err}");
    }

    #[test]
    fn refs_resolve_to_the_same_object_and_keep_their_name() {
        let desc = parse_ok(&scene(
            r#"<bsdf type="diffuse" id="white"/>
               <medium type="homogeneous" id="fog"/>
               <shape type="sphere"><ref id="white"/><ref id="fog" name="interior"/></shape>
               <shape type="cube"><ref id="white"/></shape>"#,
        ));
        let children = &desc.root.children;
        let white = &children[0].object;
        let sphere = &children[2].object;
        let cube = &children[3].object;
        let bsdf = sphere.single_child(Category::Bsdf).unwrap().unwrap();
        assert!(Rc::ptr_eq(white, &bsdf.object));
        assert_eq!(
            Rc::as_ptr(&cube.children[0].object),
            Rc::as_ptr(&bsdf.object)
        );
        let interior = sphere.child("interior").unwrap();
        assert!(Rc::ptr_eq(&interior.object, &children[1].object));
        assert_eq!(interior.object.category, Category::Medium);
        assert!(sphere.check_unused().is_ok());
    }

    #[test]
    fn alias_gives_an_object_a_second_id() {
        let desc = parse_ok(&scene(
            r#"<bsdf type="diffuse" id="white"/>
               <alias id="white" as="paper"/>
               <shape type="sphere"><ref id="paper"/></shape>"#,
        ));
        let kids = &desc.root.children;
        assert!(Rc::ptr_eq(
            &kids[0].object,
            &kids[1].object.children[0].object
        ));
    }

    #[test]
    fn truncated_and_mangled_scenes_are_errors_not_panics() {
        let text = scene(
            r##"<default name="s" value="4"/>
               <sensor type="perspective"><transform name="to_world">
                 <lookat origin="0,0,0" target="0,0,1" up="0,1,0"/><rotate x="1" angle="3"/>
                 <matrix value="1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1"/></transform>
                 <sampler type="independent"><integer name="sample_count" value="$s"/></sampler>
               </sensor>
               <bsdf type="conductor" id="m"><spectrum name="k" value="400:1, 500:2"/>
                 <rgb name="c" value="#a0b0c0"/></bsdf>
               <shape type="sphere"><ref id="m" name="x"/><point name="p" x="1"/></shape>"##,
        );
        assert!(parse(&text).is_ok());
        for (cut, _) in text.char_indices() {
            let _ = parse(&text[..cut]);
            let mangled: String = text
                .char_indices()
                .map(|(i, c)| if i == cut { '$' } else { c })
                .collect();
            let _ = parse(&mangled);
        }
    }

    #[test]
    fn unknown_and_duplicate_ids_are_errors_at_their_lines() {
        let err = error_text(&scene(
            "<shape type=\"sphere\">\n<ref id=\"nope\"/></shape>",
        ));
        assert!(err.starts_with("scene.xml:3: "), "{err}");
        assert!(err.contains("unknown id \"nope\""), "{err}");
        let err = error_text(&scene(
            "<bsdf type=\"diffuse\" id=\"a\"/>\n<bsdf type=\"conductor\" id=\"a\"/>",
        ));
        assert!(err.starts_with("scene.xml:3: "), "{err}");
        assert!(err.contains("duplicate id \"a\""), "{err}");
        assert!(err.contains("scene.xml:2"), "{err}");
    }

    #[test]
    fn malformed_xml_is_an_error_with_file_and_line() {
        let err = error_text("<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n</scene>");
        assert!(err.starts_with("scene.xml:3: malformed XML"), "{err}");
    }

    #[test]
    fn unknown_tags_and_attributes_are_errors_naming_them() {
        let err = error_text(&scene(
            "<shape type=\"sphere\">\n<floot name=\"x\" value=\"1\"/></shape>",
        ));
        assert!(err.starts_with("scene.xml:3: "), "{err}");
        assert!(err.contains("<floot>"), "{err}");
        let err = error_text(&scene("<float name=\"x\" valeu=\"1\"/>"));
        assert!(err.starts_with("scene.xml:2: "), "{err}");
        assert!(err.contains("unexpected attribute \"valeu\""), "{err}");
        let err = error_text(&scene(
            "<sensor type=\"perspective\"><transform name=\"to_world\">\n<lookAt origin=\"0,0,0\" target=\"0,0,1\"/></transform></sensor>",
        ));
        assert!(err.starts_with("scene.xml:3: "), "{err}");
        assert!(err.contains("write <lookat>"), "{err}");
    }

    #[test]
    fn bad_numbers_name_the_line_and_the_text() {
        let err = error_text(&scene("<float name=\"x\"\n value=\"1.2.3\"/>"));
        assert!(err.starts_with("scene.xml:3: "), "{err}");
        assert!(err.contains("\"1.2.3\""), "{err}");
        let err = error_text(&scene("<point name=\"p\" value=\"1, two, 3\"/>"));
        assert!(err.contains("\"two\""), "{err}");
        let err = error_text(&scene("<integer name=\"n\" value=\"1.5\"/>"));
        assert!(err.contains("invalid integer \"1.5\""), "{err}");
        let err = error_text(&scene("<boolean name=\"b\" value=\"yes\"/>"));
        assert!(err.contains("invalid boolean"), "{err}");
    }

    #[test]
    fn numbers_accept_mitsuba_spellings() {
        let desc = parse_ok(&scene(
            r#"<shape type="sphere">
                 <float name="a" value="1e-3"/>
                 <float name="b" value=".5"/>
                 <point name="c" value="  0, -5, 1  "/>
                 <vector name="d" value="1 2,3"/>
                 <point name="e" y="2"/>
                 <boolean name="f" value="True"/>
               </shape>"#,
        ));
        let shape = first(&desc);
        assert_eq!(shape.float("a").unwrap(), Some(1e-3));
        assert_eq!(shape.float("b").unwrap(), Some(0.5));
        assert_eq!(shape.point("c").unwrap(), Some(Vec3::new(0.0, -5.0, 1.0)));
        assert_eq!(shape.vector("d").unwrap(), Some(Vec3::new(1.0, 2.0, 3.0)));
        assert_eq!(shape.point("e").unwrap(), Some(Vec3::new(0.0, 2.0, 0.0)));
        assert_eq!(shape.boolean("f").unwrap(), Some(true));
    }

    #[test]
    fn an_unread_parameter_is_reported_in_the_house_format() {
        let desc = parse_ok(&scene(
            "<bsdf type=\"roughconductor\">\n<float name=\"alpha\" value=\"0.1\"/>\n<float name=\"roughnes\" value=\"0.2\"/>\n</bsdf>",
        ));
        let bsdf = first(&desc);
        assert_eq!(bsdf.float("alpha").unwrap(), Some(0.1));
        assert_eq!(
            bsdf.check_unused().unwrap_err().to_string(),
            "scene.xml:4: unknown parameter \"roughnes\" for bsdf \"roughconductor\""
        );
    }

    #[test]
    fn repeated_parameter_names_are_errors() {
        let err = error_text(&scene(
            "<bsdf type=\"diffuse\">\n<rgb name=\"reflectance\" value=\"1\"/>\n<texture type=\"bitmap\" name=\"reflectance\"/></bsdf>",
        ));
        assert!(err.starts_with("scene.xml:4: "), "{err}");
        assert!(err.contains("given twice"), "{err}");
    }

    #[test]
    fn transform_ops_compose_in_order_written() {
        let m = to_world(
            r#"<shape type="sphere"><transform name="to_world">
                   <translate x="1"/>
                   <rotate z="1" angle="90"/>
                   <scale value="2"/>
               </transform></shape>"#,
        );
        // (0,0,0) → translate (1,0,0) → rotate 90° about z (0,1,0) → scale (0,2,0).
        assert!(apply(m, DVec3::ZERO).abs_diff_eq(DVec3::new(0.0, 2.0, 0.0), 1e-12));
        // (1,0,0) → (2,0,0) → (0,2,0) → (0,4,0).
        assert!(apply(m, DVec3::X).abs_diff_eq(DVec3::new(0.0, 4.0, 0.0), 1e-12));
        let expected = DMat4::from_scale(DVec3::splat(2.0))
            * DMat4::from_rotation_z(90f64.to_radians())
            * DMat4::from_translation(DVec3::X);
        assert_mat_eq(m, expected);
    }

    #[test]
    fn rotate_accepts_a_value_axis_and_scale_defaults_to_one() {
        let m = to_world(
            r#"<shape type="sphere"><transform name="to_world">
                   <rotate value="0, 0, 5" angle="-90"/>
                   <scale x="3"/>
               </transform></shape>"#,
        );
        // (0,1,0) → rotate −90° about z (1,0,0) → scale x by 3 (3,0,0).
        assert!(apply(m, DVec3::Y).abs_diff_eq(DVec3::new(3.0, 0.0, 0.0), 1e-12));
        assert!(apply(m, DVec3::Z).abs_diff_eq(DVec3::Z, 1e-12));
        let err = error_text(&scene(
            "<shape type=\"sphere\"><transform name=\"to_world\">\n<rotate angle=\"3\"/></transform></shape>",
        ));
        assert!(err.starts_with("scene.xml:3: "), "{err}");
    }

    #[test]
    fn matrix_values_are_rows() {
        let m = to_world(
            r#"<shape type="sphere"><transform name="to_world">
                   <matrix value="1 2 3 4  5 6 7 8  9 10 11 12  13 14 15 16"/>
               </transform></shape>"#,
        );
        assert_eq!(m.row(0), DVec4::new(1.0, 2.0, 3.0, 4.0));
        assert_eq!(m.row(3), DVec4::new(13.0, 14.0, 15.0, 16.0));
        assert_eq!(m.w_axis, DVec4::new(4.0, 8.0, 12.0, 16.0));
        let m3 = to_world(
            r#"<shape type="sphere"><transform name="to_world">
                   <matrix value="1,2,3, 4,5,6, 7,8,9"/>
               </transform></shape>"#,
        );
        assert_eq!(m3.row(1), DVec4::new(4.0, 5.0, 6.0, 0.0));
        assert_eq!(m3.row(3), DVec4::new(0.0, 0.0, 0.0, 1.0));
        let err = error_text(&scene(
            "<shape type=\"sphere\"><transform name=\"to_world\"><matrix value=\"1 2 3\"/></transform></shape>",
        ));
        assert!(err.contains("16 or 9 numbers"), "{err}");
    }

    #[test]
    fn lookat_follows_mitsubas_convention() {
        let m = to_world(
            r#"<sensor type="perspective"><transform name="to_world">
                   <lookat origin="0,-5,1" target="0,0,1" up="0,0,1"/>
               </transform></sensor>"#,
        );
        // dir = +y, left = up × dir = z × y = −x, new up = dir × left = +z.
        assert_eq!(m.z_axis, DVec4::new(0.0, 1.0, 0.0, 0.0));
        assert!(m.x_axis.abs_diff_eq(DVec4::new(-1.0, 0.0, 0.0, 0.0), 1e-12));
        assert!(m.y_axis.abs_diff_eq(DVec4::new(0.0, 0.0, 1.0, 0.0), 1e-12));
        assert_eq!(m.w_axis, DVec4::new(0.0, -5.0, 1.0, 1.0));
        // The camera's +z looks at the target.
        let seen = apply(m, DVec3::new(0.0, 0.0, 5.0));
        assert!(seen.abs_diff_eq(DVec3::new(0.0, 0.0, 1.0), 1e-12));
    }

    #[test]
    fn lookat_with_parallel_up_stays_finite_and_orthonormal() {
        let m = to_world(
            r#"<sensor type="perspective"><transform name="to_world">
                   <lookat origin="0,0,0" target="0,0,-3" up="0,0,1"/>
               </transform></sensor>"#,
        );
        assert!(m.is_finite());
        let (x, y, z) = (
            m.x_axis.truncate(),
            m.y_axis.truncate(),
            m.z_axis.truncate(),
        );
        assert!(z.abs_diff_eq(DVec3::NEG_Z, 1e-12));
        for (a, b) in [(x, y), (y, z), (x, z)] {
            assert!(a.dot(b).abs() < 1e-12);
        }
        assert!((x.length() - 1.0).abs() < 1e-12 && (y.length() - 1.0).abs() < 1e-12);
        let err = error_text(&scene(
            "<sensor type=\"perspective\"><transform name=\"to_world\">\n<lookat origin=\"1,1,1\" target=\"1,1,1\"/></transform></sensor>",
        ));
        assert!(err.starts_with("scene.xml:3: "), "{err}");
    }

    #[test]
    fn rgb_takes_one_or_three_numbers() {
        let desc = parse_ok(&scene(
            r#"<bsdf type="diffuse">
                   <rgb name="a" value="0.5"/>
                   <rgb name="b" value="0.1, 0.2, 0.3"/>
                   <rgb name="c" value="0.1 0.2 0.3"/>
               </bsdf>"#,
        ));
        let bsdf = first(&desc);
        assert_eq!(
            bsdf.rgb_or_spectrum("a").unwrap(),
            Some(&Value::Rgb([0.5; 3]))
        );
        assert_eq!(
            bsdf.rgb_or_spectrum("b").unwrap(),
            Some(&Value::Rgb([0.1, 0.2, 0.3]))
        );
        assert_eq!(
            bsdf.rgb_or_spectrum("c").unwrap(),
            Some(&Value::Rgb([0.1, 0.2, 0.3]))
        );
        let err = error_text(&scene(
            "<bsdf type=\"diffuse\"><rgb name=\"a\" value=\"1 2\"/></bsdf>",
        ));
        assert!(err.contains("1 or 3 numbers"), "{err}");
    }

    #[test]
    fn spectra_are_constant_or_sampled() {
        let desc = parse_ok(&scene(
            r#"<bsdf type="conductor">
                   <spectrum name="eta" value="0.5"/>
                   <spectrum name="k" value="400:0.1, 500:0.2,600:0.3 700 : 0.4"/>
                   <spectrum name="tint" type="blackbody"><float name="temperature" value="5000"/></spectrum>
               </bsdf>"#,
        ));
        let bsdf = first(&desc);
        assert_eq!(
            bsdf.rgb_or_spectrum("eta").unwrap(),
            Some(&Value::Spectrum(Spectrum::Constant(0.5)))
        );
        let expected = vec![(400.0, 0.1), (500.0, 0.2), (600.0, 0.3), (700.0, 0.4)];
        assert_eq!(
            bsdf.rgb_or_spectrum("k").unwrap(),
            Some(&Value::Spectrum(Spectrum::Sampled(expected)))
        );
        let tint = bsdf.child("tint").unwrap();
        assert_eq!(tint.object.category, Category::Spectrum);
        assert_eq!(tint.object.plugin_type, "blackbody");
        for bad in ["400:0.1, 300:0.2", "400:0.1, 500", "0.1 0.2", "400:x"] {
            let text = scene(&format!(
                "<bsdf type=\"conductor\">\n<spectrum name=\"k\" value=\"{bad}\"/></bsdf>"
            ));
            let err = error_text(&text);
            assert!(err.starts_with("scene.xml:3: "), "{bad}: {err}");
        }
    }

    #[test]
    fn include_and_path_resolve_files_and_keep_their_own_locations() {
        let dir = temp_dir("include");
        std::fs::create_dir_all(dir.join("fragments")).unwrap();
        std::fs::create_dir_all(dir.join("common/meshes")).unwrap();
        std::fs::write(dir.join("common/meshes/bunny.obj"), "").unwrap();
        std::fs::write(
            dir.join("fragments/camera.xml"),
            "<scene version=\"3.0.0\">\n<default name=\"res\" value=\"8\"/>\n\
             <sensor type=\"perspective\">\n<float name=\"fov\" value=\"$fov\"/>\n</sensor>\n\
             <bsdf type=\"diffuse\" id=\"white\"/>\n</scene>",
        )
        .unwrap();
        let main = dir.join("main.xml");
        std::fs::write(
            &main,
            "<scene version=\"3.0.0\">\n<path value=\"common\"/>\n<default name=\"fov\" value=\"40\"/>\n\
             <include filename=\"fragments/camera.xml\"/>\n\
             <film type=\"hdrfilm\"><integer name=\"width\" value=\"$res\"/></film>\n\
             <shape type=\"obj\"><ref id=\"white\"/></shape>\n</scene>",
        )
        .unwrap();
        let desc = parse_file(&main, &[]).unwrap();
        assert_eq!(desc.search_paths, vec![dir.clone(), dir.join("common")]);
        let kids = &desc.root.children;
        assert_eq!(kids.len(), 4);
        let sensor = &kids[0].object;
        assert_eq!(sensor.float("fov").unwrap(), Some(40.0));
        assert_eq!(*sensor.loc.file, dir.join("fragments/camera.xml"));
        assert_eq!(sensor.loc.line, 3);
        assert_eq!(kids[2].object.integer("width").unwrap(), Some(8));
        assert!(Rc::ptr_eq(
            &kids[1].object,
            &kids[3].object.children[0].object
        ));

        let loc = Location::new(Arc::new(main.clone()), 9);
        let found = desc.resolve_file("meshes/bunny.obj", &loc).unwrap();
        assert_eq!(found, dir.join("common/meshes/bunny.obj"));
        let err = desc.resolve_file("meshes/dragon.obj", &loc).unwrap_err();
        let text = err.to_string();
        assert!(text.contains(":9: "), "{text}");
        assert!(
            text.contains(&dir.join("meshes/dragon.obj").display().to_string()),
            "{text}"
        );
        assert!(
            text.contains(&dir.join("common/meshes/dragon.obj").display().to_string()),
            "{text}"
        );

        std::fs::write(
            dir.join("broken.xml"),
            "<scene version=\"3.0.0\">\n<include filename=\"missing.xml\"/>\n</scene>",
        )
        .unwrap();
        let err = parse_file(&dir.join("broken.xml"), &[]).unwrap_err();
        assert!(matches!(err, SceneError::NotFound { .. }), "{err}");
        assert!(err.to_string().contains("broken.xml:2: "), "{err}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn deep_nesting_is_an_error_not_a_stack_overflow() {
        let n = 200_000;
        let text = format!(
            "<scene version=\"3.0.0\">\n<shape type=\"sphere\">{}<bsdf type=\"diffuse\"/>{}</shape></scene>",
            "<bsdf type=\"twosided\">".repeat(n),
            "</bsdf>".repeat(n)
        );
        let err = parse_str(&text, Path::new("deep.xml"), &[])
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("deep.xml:2") && err.contains("nested more than 256"),
            "{err}"
        );
        // Quoted "/>" and comments do not hide the depth; siblings add none.
        let tricky = format!(
            "<a>{}{}",
            "<b x=\"/>\"><!-- <c/> -->".repeat(300),
            "</b>".repeat(300)
        );
        assert!(too_deep(tricky.as_bytes(), 256).is_some());
        let wide = format!("<a>{}</a>", "<b x='/>'/><!-- <c> -->".repeat(5000));
        assert_eq!(too_deep(wide.as_bytes(), 256), None);
    }

    #[test]
    fn include_cycles_are_errors() {
        let dir = temp_dir("cycle");
        std::fs::write(
            dir.join("a.xml"),
            "<scene version=\"3.0.0\">\n<include filename=\"b.xml\"/>\n</scene>",
        )
        .unwrap();
        std::fs::write(
            dir.join("b.xml"),
            "<scene version=\"3.0.0\">\n\n<include filename=\"a.xml\"/>\n</scene>",
        )
        .unwrap();
        let err = parse_file(&dir.join("a.xml"), &[]).unwrap_err().to_string();
        assert!(err.contains("b.xml:3: include cycle"), "{err}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn legacy_scenes_get_snake_case_names_lookat_and_srgb() {
        let desc = parse_ok(
            r##"<scene version="0.6.0">
                  <default name="sampleCount" value="4"/>
                  <sensor type="perspective">
                    <transform name="toWorld"><lookAt origin="0,0,0" target="0,0,1" up="0,1,0"/></transform>
                    <sampler type="independent"><integer name="sampleCount" value="$sampleCount"/></sampler>
                  </sensor>
                  <bsdf type="dielectric"><float name="intIOR" value="1.5"/></bsdf>
                  <bsdf type="diffuse">
                    <srgb name="diffuseReflectance" value="#ffffff"/>
                    <srgb name="other" value="0.5"/>
                  </bsdf>
                </scene>"##,
        );
        assert_eq!(desc.version, (0, 6, 0));
        let kids = &desc.root.children;
        let sensor = &kids[0].object;
        assert_mat_eq(sensor.transform("to_world").unwrap(), DMat4::IDENTITY);
        let sampler = sensor.single_child(Category::Sampler).unwrap().unwrap();
        assert_eq!(sampler.object.integer("sample_count").unwrap(), Some(4));
        assert_eq!(kids[1].object.float("int_ior").unwrap(), Some(1.5));
        let diffuse = &kids[2].object;
        assert_eq!(
            diffuse.rgb_or_spectrum("reflectance").unwrap(),
            Some(&Value::Rgb([1.0; 3]))
        );
        let Some(Value::Rgb([g, _, _])) = diffuse.rgb_or_spectrum("other").unwrap() else {
            panic!("srgb is not an rgb");
        };
        assert!((g - 0.214_041).abs() < 1e-5, "{g}");
    }

    #[test]
    fn snake_case_conversion() {
        for (camel, snake) in [
            ("toWorld", "to_world"),
            ("sampleCount", "sample_count"),
            ("intIOR", "int_ior"),
            ("HDRFilm", "hdr_film"),
            ("max_depth", "max_depth"),
            ("uvscale", "uvscale"),
        ] {
            assert_eq!(to_snake_case(camel), snake);
        }
    }

    #[test]
    fn root_must_be_a_scene() {
        let err = error_text("<shape type=\"sphere\"/>");
        assert!(err.starts_with("scene.xml:1: "), "{err}");
        let err = error_text("<scene version=\"three\"/>");
        assert!(err.contains("invalid version"), "{err}");
    }

    fn xml_files_under(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                xml_files_under(&path, out);
            } else if path.extension().is_some_and(|e| e == "xml") {
                out.push(path);
            }
        }
    }

    #[test]
    fn parses_every_shared_mitsuba_test_scene() {
        let shared_scenes = crate::shared_path("mitsuba-data/tests/scenes");
        let dir = shared_scenes.as_path();
        if !dir.is_dir() {
            println!("skipped: {} is not present", dir.display());
            return;
        }
        let mut files = Vec::new();
        xml_files_under(dir, &mut files);
        // Fragments are only meaningful inside the scene that includes them
        // (they use its `$names` and its directory), as in Mitsuba.
        let texts: Vec<String> = files
            .iter()
            .map(|f| std::fs::read_to_string(f).unwrap())
            .collect();
        let is_fragment = |file: &Path| {
            let name = file.file_name().unwrap().to_string_lossy();
            let pattern = format!("{name}\"/>");
            texts.iter().any(|t| {
                t.lines()
                    .any(|l| l.contains("<include") && l.contains(&pattern))
            })
        };
        let scenes: Vec<&PathBuf> = files.iter().filter(|f| !is_fragment(f)).collect();
        assert!(scenes.len() >= 10, "only {} scenes found", scenes.len());
        for file in &scenes {
            if let Err(e) = parse_file(file, &[]) {
                panic!("{}: {e}", file.display());
            }
        }
        println!(
            "parsed {} scenes ({} fragments parsed through them)",
            scenes.len(),
            files.len() - scenes.len()
        );
    }

    #[test]
    fn parses_the_shared_bitterli_cornell_box() {
        let shared_cornell = crate::shared_path("assets/cornell-box-bitterli/scene_v3.xml");
        let path = shared_cornell.as_path();
        if !path.is_file() {
            println!("skipped: {} is not present", path.display());
            return;
        }
        let desc = parse_file(path, &[]).unwrap();
        let sensor = desc
            .root
            .children_of(Category::Sensor)
            .next()
            .expect("a sensor");
        let m = sensor.object.transform("to_world").unwrap();
        assert_eq!(m.row(1), DVec4::new(0.0, 1.0, 0.0, 1.0));
        assert_eq!(m.row(2), DVec4::new(0.0, 0.0, -1.0, 6.8));
        let sampler = sensor
            .object
            .single_child(Category::Sampler)
            .unwrap()
            .unwrap();
        assert_eq!(sampler.object.integer("sample_count").unwrap(), Some(32));
    }

    #[test]
    fn references_may_come_before_the_declaration() {
        let desc = parse_ok(&scene(
            r#"<shape type="sphere"><ref id="late"/><ref id="light"/></shape>
               <shape type="sphere"><ref id="late"/></shape>
               <bsdf type="diffuse" id="late"/>
               <emitter type="area" id="light"><rgb name="radiance" value="1"/></emitter>"#,
        ));
        let shapes: Vec<_> = desc
            .root
            .children
            .iter()
            .take(2)
            .map(|c| c.object.clone())
            .collect();
        let declared = &desc.root.children[2].object;
        assert!(Rc::ptr_eq(&shapes[0].children[0].object, declared));
        assert!(Rc::ptr_eq(&shapes[1].children[0].object, declared));
        assert_eq!(shapes[0].children[1].object.plugin_type, "area");
        let err = error_text(&scene(
            r#"<shape type="sphere"><ref id="nowhere"/></shape>"#,
        ));
        assert!(err.contains("unknown id \"nowhere\""), "{err}");
        let err = error_text(&scene(
            r#"<bsdf type="twosided" id="a"><ref id="b"/></bsdf>
               <bsdf type="twosided" id="b"><ref id="a"/></bsdf>"#,
        ));
        assert!(err.contains("reference cycle"), "{err}");
    }

    #[test]
    fn top_level_textures_are_built_where_referenced() {
        let text = scene(
            r#"<texture type="checkerboard" id="checks"/>
               <shape type="sphere"><bsdf type="diffuse"><ref name="reflectance" id="checks"/></bsdf></shape>"#,
        );
        let loaded = crate::build::load_scene_str(&text, Path::new("scene.xml"), &[]).unwrap();
        assert_eq!(loaded.scene.materials.textures.len(), 1);
    }
}
