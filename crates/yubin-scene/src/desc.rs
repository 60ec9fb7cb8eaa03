//! The format-neutral scene description.
//!
//! A front end (today only [`crate::xml`]) turns a scene file into a tree of
//! [`Object`]s: each has a [`Category`] (shape, bsdf, ...), a plugin type
//! string (`"roughconductor"`), typed [`Property`] values and nested
//! [`Child`] objects, and every one of them remembers the [`Location`] it
//! came from. Nothing here knows about the renderer; the builder reads the
//! description and makes `yubin_core` objects.
//!
//! Reading is tracked: the typed accessors ([`Object::float`],
//! [`Object::children_of`], ...) mark what they return as used, and
//! [`Object::check_unused`] turns the first parameter nobody read into an
//! error that points at its line, the way pbrt-v4 does:
//!
//! ```text
//! scene.xml:42: unknown parameter "roughnes" for bsdf "roughconductor"
//! ```
//!
//! Objects are shared through `Rc`: a `<ref id="x"/>` yields the very same
//! `Rc<Object>` as the declaration of `x`, so the builder can build each
//! object once and dedupe with [`Rc::as_ptr`].
//!
//! ```
//! # use yubin_scene::xml::parse_str;
//! # use std::path::Path;
//! let desc = parse_str(
//!     r#"<scene version="3.0.0">
//!            <bsdf type="roughconductor"><float name="alpha" value="0.1"/></bsdf>
//!        </scene>"#,
//!     Path::new("scene.xml"),
//!     &[],
//! )?;
//! let bsdf = &desc.root.children[0].object;
//! assert_eq!(bsdf.float_or("alpha", 0.5)?, 0.1);
//! bsdf.check_unused()?;
//! # Ok::<(), yubin_scene::SceneError>(())
//! ```

use std::cell::Cell;
use std::collections::HashSet;
use std::fmt;
use std::path::{Path, PathBuf};
use std::rc::Rc;

use glam::{DMat4, Vec3};

use crate::error::{Location, SceneError};

/// The family an object belongs to; the names are Mitsuba's XML tags.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Category {
    /// `<scene>`, the root.
    Scene,
    /// `<shape>`: meshes, analytic shapes, instances.
    Shape,
    /// `<bsdf>`: surface scattering.
    Bsdf,
    /// `<emitter>`: lights.
    Emitter,
    /// `<sensor>`: cameras.
    Sensor,
    /// `<film>`: the image a sensor records.
    Film,
    /// `<sampler>`: sample generators.
    Sampler,
    /// `<integrator>`: the light transport algorithm.
    Integrator,
    /// `<rfilter>`: the pixel reconstruction filter.
    Rfilter,
    /// `<texture>`: spatially varying parameters.
    Texture,
    /// `<medium>`: participating media.
    Medium,
    /// `<phase>`: phase functions.
    Phase,
    /// `<volume>`: 3D grids and constant volumes.
    Volume,
    /// `<spectrum type="...">`: a spectrum plugin (blackbody, ...).
    Spectrum,
    /// `<sdf>`: a node of an `sdf` shape's distance function.
    Sdf,
    /// `<world id="...">`: shapes and emitters apart from the camera's,
    /// reached through portals.
    World,
}

impl Category {
    /// Every category, in declaration order.
    pub const ALL: [Category; 16] = [
        Category::Scene,
        Category::Shape,
        Category::Bsdf,
        Category::Emitter,
        Category::Sensor,
        Category::Film,
        Category::Sampler,
        Category::Integrator,
        Category::Rfilter,
        Category::Texture,
        Category::Medium,
        Category::Phase,
        Category::Volume,
        Category::Spectrum,
        Category::Sdf,
        Category::World,
    ];

    /// The XML tag name (`"bsdf"`, `"rfilter"`, ...).
    pub fn as_str(self) -> &'static str {
        match self {
            Category::Scene => "scene",
            Category::Shape => "shape",
            Category::Bsdf => "bsdf",
            Category::Emitter => "emitter",
            Category::Sensor => "sensor",
            Category::Film => "film",
            Category::Sampler => "sampler",
            Category::Integrator => "integrator",
            Category::Rfilter => "rfilter",
            Category::Texture => "texture",
            Category::Medium => "medium",
            Category::Phase => "phase",
            Category::Volume => "volume",
            Category::Spectrum => "spectrum",
            Category::Sdf => "sdf",
            Category::World => "world",
        }
    }

    /// The category whose tag name is `tag`, if any.
    pub fn from_tag(tag: &str) -> Option<Category> {
        Category::ALL.into_iter().find(|c| c.as_str() == tag)
    }
}

impl fmt::Display for Category {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A spectrum written inline in the scene.
#[derive(Clone, Debug, PartialEq)]
pub enum Spectrum {
    /// The same value at every wavelength (`value="0.5"`).
    Constant(f32),
    /// `(wavelength in nm, value)` pairs in the order written
    /// (`value="400:0.1, 500:0.2"`).
    Sampled(Vec<(f32, f32)>),
}

/// The value of a parameter.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// `<integer>`.
    Integer(i64),
    /// `<float>`.
    Float(f64),
    /// `<boolean>`.
    Boolean(bool),
    /// `<string>`.
    String(String),
    /// `<rgb>` (and the legacy `<srgb>`, already linearized), linear RGB.
    Rgb([f32; 3]),
    /// `<spectrum>` without a `type`.
    Spectrum(Spectrum),
    /// `<point>`.
    Point(Vec3),
    /// `<vector>`.
    Vector(Vec3),
    /// `<transform>`: the composed matrix, in f64 so long chains keep precision.
    Transform(DMat4),
}

impl Value {
    /// [`Value::type_name`] with its indefinite article (`"an integer"`).
    pub fn type_name_with_article(&self) -> &'static str {
        match self {
            Value::Integer(_) => "an integer",
            Value::Rgb(_) => "an rgb",
            Value::Float(_) => "a float",
            Value::Boolean(_) => "a boolean",
            Value::String(_) => "a string",
            Value::Spectrum(_) => "a spectrum",
            Value::Point(_) => "a point",
            Value::Vector(_) => "a vector",
            Value::Transform(_) => "a transform",
        }
    }

    /// The scene-file name of the value's type (`"float"`, `"rgb"`, ...).
    pub fn type_name(&self) -> &'static str {
        match self {
            Value::Integer(_) => "integer",
            Value::Float(_) => "float",
            Value::Boolean(_) => "boolean",
            Value::String(_) => "string",
            Value::Rgb(_) => "rgb",
            Value::Spectrum(_) => "spectrum",
            Value::Point(_) => "point",
            Value::Vector(_) => "vector",
            Value::Transform(_) => "transform",
        }
    }
}

/// One named parameter of an object.
#[derive(Clone, Debug)]
pub struct Property {
    /// The parameter name (`name="..."`), snake_case.
    pub name: String,
    /// The parsed value.
    pub value: Value,
    /// Where it was written.
    pub loc: Location,
    /// Whether someone read it (or deliberately ignored it).
    pub used: Cell<bool>,
    /// For a transform with a `<lookat>`: its target, carried through the
    /// operations after it (where a camera focuses by default).
    pub look_at_target: Option<Vec3>,
}

/// A nested object, either declared in place or pulled in by `<ref>`.
#[derive(Clone, Debug)]
pub struct Child {
    /// The name under which the parent sees it: the `name` attribute of the
    /// nested element, or of the `<ref>` that refers to it.
    pub name: Option<String>,
    /// The object; shared with every other reference to the same id.
    pub object: Rc<Object>,
    /// Where the nested element or the `<ref>` was written.
    pub loc: Location,
    /// Whether someone read it.
    pub used: Cell<bool>,
}

/// A scene entity: a plugin type with its parameters and nested objects.
#[derive(Clone, Debug)]
pub struct Object {
    /// The family (the XML tag).
    pub category: Category,
    /// The plugin type string (`type="diffuse"`); `"scene"` for the root.
    pub plugin_type: String,
    /// The `id` attribute, if any.
    pub id: Option<String>,
    /// The `name` attribute of the declaration, if it was nested as a named
    /// child (`<texture name="reflectance">`).
    pub name: Option<String>,
    /// Parameters in the order written.
    pub props: Vec<Property>,
    /// Nested objects and references in the order written.
    pub children: Vec<Child>,
    /// Where the object was declared.
    pub loc: Location,
}

impl Object {
    /// An empty object of `category` and `plugin_type` declared at `loc`.
    pub fn new(category: Category, plugin_type: impl Into<String>, loc: Location) -> Self {
        Self {
            category,
            plugin_type: plugin_type.into(),
            id: None,
            name: None,
            props: Vec::new(),
            children: Vec::new(),
            loc,
        }
    }

    /// `bsdf "diffuse"`: how messages name this object.
    pub fn describe(&self) -> String {
        format!("{} \"{}\"", self.category, self.plugin_type)
    }

    /// An error at the object's declaration.
    pub fn error(&self, msg: impl fmt::Display) -> SceneError {
        SceneError::at(&self.loc, format!("{}: {msg}", self.describe()))
    }

    /// Whether a parameter or named child called `name` exists (does not
    /// mark it used).
    pub fn has(&self, name: &str) -> bool {
        self.find_prop(name).is_some() || self.find_child(name).is_some()
    }

    /// The parameter `name`, marked used.
    pub fn prop(&self, name: &str) -> Option<&Property> {
        let prop = self.find_prop(name)?;
        prop.used.set(true);
        Some(prop)
    }

    /// Where parameter or named child `name` was written, else where the
    /// object was declared; for the builder's own error messages.
    pub fn loc_of(&self, name: &str) -> &Location {
        if let Some(prop) = self.find_prop(name) {
            &prop.loc
        } else if let Some(child) = self.find_child(name) {
            &child.loc
        } else {
            &self.loc
        }
    }

    /// An error at parameter `name` (or at the object when it is absent).
    pub fn param_error(&self, name: &str, msg: impl fmt::Display) -> SceneError {
        SceneError::at(
            self.loc_of(name),
            format!("parameter \"{name}\" of {}: {msg}", self.describe()),
        )
    }

    /// Marks parameter or named child `name` as used without reading it
    /// (legacy parameters such as `light_samples` or `file_format`).
    pub fn mark_ignored(&self, name: &str) {
        if let Some(prop) = self.find_prop(name) {
            prop.used.set(true);
        }
        if let Some(child) = self.find_child(name) {
            child.used.set(true);
        }
    }

    /// Float parameter `name`; an integer is accepted too.
    pub fn float(&self, name: &str) -> Result<Option<f32>, SceneError> {
        Ok(self.double(name)?.map(|v| v as f32))
    }

    /// Float parameter `name` or `default` when absent.
    pub fn float_or(&self, name: &str, default: f32) -> Result<f32, SceneError> {
        Ok(self.float(name)?.unwrap_or(default))
    }

    /// Float parameter `name` at full precision; an integer is accepted too.
    pub fn double(&self, name: &str) -> Result<Option<f64>, SceneError> {
        self.typed(name, "a float", |v| match v {
            Value::Float(x) => Some(*x),
            Value::Integer(i) => Some(*i as f64),
            _ => None,
        })
    }

    /// Integer parameter `name`.
    pub fn integer(&self, name: &str) -> Result<Option<i64>, SceneError> {
        self.typed(name, "an integer", |v| match v {
            Value::Integer(i) => Some(*i),
            _ => None,
        })
    }

    /// Integer parameter `name` or `default` when absent.
    pub fn integer_or(&self, name: &str, default: i64) -> Result<i64, SceneError> {
        Ok(self.integer(name)?.unwrap_or(default))
    }

    /// Boolean parameter `name`.
    pub fn boolean(&self, name: &str) -> Result<Option<bool>, SceneError> {
        self.typed(name, "a boolean", |v| match v {
            Value::Boolean(b) => Some(*b),
            _ => None,
        })
    }

    /// Boolean parameter `name` or `default` when absent.
    pub fn boolean_or(&self, name: &str, default: bool) -> Result<bool, SceneError> {
        Ok(self.boolean(name)?.unwrap_or(default))
    }

    /// String parameter `name`.
    pub fn string(&self, name: &str) -> Result<Option<&str>, SceneError> {
        self.typed(name, "a string", |v| match v {
            Value::String(s) => Some(s.as_str()),
            _ => None,
        })
    }

    /// String parameter `name` or `default` when absent.
    pub fn string_or<'a>(&'a self, name: &str, default: &'a str) -> Result<&'a str, SceneError> {
        Ok(self.string(name)?.unwrap_or(default))
    }

    /// Point parameter `name` (a `<vector>` is accepted too, as in Mitsuba).
    pub fn point(&self, name: &str) -> Result<Option<Vec3>, SceneError> {
        self.typed(name, "a point", Self::as_vec3)
    }

    /// Point parameter `name` or `default` when absent.
    pub fn point_or(&self, name: &str, default: Vec3) -> Result<Vec3, SceneError> {
        Ok(self.point(name)?.unwrap_or(default))
    }

    /// Vector parameter `name` (a `<point>` is accepted too, as in Mitsuba).
    pub fn vector(&self, name: &str) -> Result<Option<Vec3>, SceneError> {
        self.typed(name, "a vector", Self::as_vec3)
    }

    /// Vector parameter `name` or `default` when absent.
    pub fn vector_or(&self, name: &str, default: Vec3) -> Result<Vec3, SceneError> {
        Ok(self.vector(name)?.unwrap_or(default))
    }

    /// Transform parameter `name`, if present.
    pub fn transform_opt(&self, name: &str) -> Result<Option<DMat4>, SceneError> {
        self.typed(name, "a transform", |v| match v {
            Value::Transform(m) => Some(*m),
            _ => None,
        })
    }

    /// The `<lookat>` target of transform parameter `name`, carried
    /// through the operations written after it, if it has one.
    pub fn look_at_target(&self, name: &str) -> Option<Vec3> {
        self.find_prop(name)?.look_at_target
    }

    /// Transform parameter `name`, or the identity when absent.
    pub fn transform(&self, name: &str) -> Result<DMat4, SceneError> {
        Ok(self.transform_opt(name)?.unwrap_or(DMat4::IDENTITY))
    }

    /// A colour-like parameter as written: [`Value::Rgb`],
    /// [`Value::Spectrum`], [`Value::Float`] or [`Value::Integer`]; the
    /// builder converts. A texture given as a named child is not a
    /// property: look for it with [`Object::child`].
    pub fn rgb_or_spectrum(&self, name: &str) -> Result<Option<&Value>, SceneError> {
        self.typed(name, "an rgb, spectrum or float", |v| match v {
            Value::Rgb(_) | Value::Spectrum(_) | Value::Float(_) | Value::Integer(_) => Some(v),
            _ => None,
        })
    }

    /// Nested objects of `category` in the order written; each one is
    /// marked used as the iterator yields it.
    pub fn children_of(&self, category: Category) -> impl Iterator<Item = &Child> + '_ {
        self.children
            .iter()
            .filter(move |c| c.object.category == category)
            .inspect(|c| c.used.set(true))
    }

    /// The nested object called `name` (by its own `name` attribute or its
    /// `<ref name=...>`), marked used.
    pub fn child(&self, name: &str) -> Option<&Child> {
        let child = self.find_child(name)?;
        child.used.set(true);
        Some(child)
    }

    /// The nested object called `name`, without marking it used (to look
    /// at its category before deciding how to read it).
    pub fn find_named_child(&self, name: &str) -> Option<Rc<Object>> {
        self.find_child(name).map(|c| c.object.clone())
    }

    /// The only nested object of `category`, marked used; an error at the
    /// second one's line when there are several.
    pub fn single_child(&self, category: Category) -> Result<Option<&Child>, SceneError> {
        let mut found = self.children_of(category);
        let first = found.next();
        match found.next() {
            Some(second) => Err(SceneError::at(
                &second.loc,
                format!(
                    "{} has more than one nested {category} (the first is at line {})",
                    self.describe(),
                    first.map_or(0, |c| c.loc.line)
                ),
            )),
            None => Ok(first),
        }
    }

    /// The first parameter or nested object that nobody read, as an error
    /// at its line: `unknown parameter "roughnes" for bsdf "roughconductor"`.
    /// Looks at this object only; see [`Object::check_unused_tree`].
    pub fn check_unused(&self) -> Result<(), SceneError> {
        let unused_prop = self
            .props
            .iter()
            .filter(|p| !p.used.get())
            .map(|p| (&p.loc, self.unknown_parameter(&p.name)));
        let unused_child = self.children.iter().filter(|c| !c.used.get()).map(|c| {
            let msg = match &c.name {
                Some(name) => self.unknown_parameter(name),
                None => format!(
                    "unexpected nested {} in {}",
                    c.object.describe(),
                    self.describe()
                ),
            };
            (&c.loc, msg)
        });
        let first = unused_prop
            .chain(unused_child)
            .min_by_key(|(loc, _)| loc.line);
        match first {
            Some((loc, msg)) => Err(SceneError::at(loc, msg)),
            None => Ok(()),
        }
    }

    /// [`Object::check_unused`] on this object and, recursively, on every
    /// nested object that was used (each shared object once). Objects that
    /// nobody used are reported by their parent instead of being searched.
    pub fn check_unused_tree(&self) -> Result<(), SceneError> {
        let mut seen = HashSet::new();
        self.check_unused_walk(&mut seen)
    }

    fn check_unused_walk(&self, seen: &mut HashSet<*const Object>) -> Result<(), SceneError> {
        self.check_unused()?;
        for child in self.children.iter().filter(|c| c.used.get()) {
            if seen.insert(Rc::as_ptr(&child.object)) {
                child.object.check_unused_walk(seen)?;
            }
        }
        Ok(())
    }

    fn unknown_parameter(&self, name: &str) -> String {
        format!("unknown parameter \"{name}\" for {}", self.describe())
    }

    fn find_prop(&self, name: &str) -> Option<&Property> {
        self.props.iter().find(|p| p.name == name)
    }

    fn find_child(&self, name: &str) -> Option<&Child> {
        self.children
            .iter()
            .find(|c| c.name.as_deref() == Some(name))
    }

    fn as_vec3(value: &Value) -> Option<Vec3> {
        match value {
            Value::Point(v) | Value::Vector(v) => Some(*v),
            _ => None,
        }
    }

    /// Looks up `name`, marks it used and converts it with `get`; a value of
    /// another type is an error at the parameter's line.
    fn typed<'a, T>(
        &'a self,
        name: &str,
        expected: &str,
        get: impl FnOnce(&'a Value) -> Option<T>,
    ) -> Result<Option<T>, SceneError> {
        let Some(prop) = self.prop(name) else {
            if let Some(child) = self.find_child(name) {
                return Err(SceneError::at(
                    &child.loc,
                    format!(
                        "parameter \"{name}\" of {} must be {expected}, not a nested {}",
                        self.describe(),
                        child.object.category
                    ),
                ));
            }
            return Ok(None);
        };
        match get(&prop.value) {
            Some(v) => Ok(Some(v)),
            None => Err(SceneError::at(
                &prop.loc,
                format!(
                    "parameter \"{name}\" of {} must be {expected}, not {}",
                    self.describe(),
                    prop.value.type_name_with_article()
                ),
            )),
        }
    }
}

/// A parsed scene: the root object and what is needed to find its files.
#[derive(Clone, Debug)]
pub struct SceneDesc {
    /// The `<scene>` object; its children are the top-level declarations.
    pub root: Rc<Object>,
    /// The `version` attribute of the root file (`(3, 0, 0)` when absent).
    pub version: (u32, u32, u32),
    /// The scene file as given.
    pub file: PathBuf,
    /// Where relative file names are looked up, in order: the scene file's
    /// directory, then every `<path>` entry in declaration order.
    pub search_paths: Vec<PathBuf>,
}

impl SceneDesc {
    /// Finds the file `name` (written at `loc`) in the search paths; an
    /// absolute name is used as is. The error lists every path tried.
    pub fn resolve_file(&self, name: &str, loc: &Location) -> Result<PathBuf, SceneError> {
        resolve_in(&self.search_paths, name, Some(loc))
    }
}

/// Finds `name` in `search_paths` (in order); an absolute `name` is checked
/// on its own. [`SceneError::NotFound`] lists every candidate.
pub fn resolve_in(
    search_paths: &[PathBuf],
    name: &str,
    from: Option<&Location>,
) -> Result<PathBuf, SceneError> {
    let path = Path::new(name);
    let candidates: Vec<PathBuf> = if path.is_absolute() {
        vec![path.to_path_buf()]
    } else {
        search_paths.iter().map(|dir| dir.join(path)).collect()
    };
    let found = candidates
        .iter()
        .find(|c| c.is_file() && !crate::fuzzing::outside_sandbox(c));
    match found {
        Some(found) => Ok(found.clone()),
        None => Err(SceneError::NotFound {
            name: name.to_string(),
            searched: candidates,
            from: from.cloned(),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    fn loc(line: u32) -> Location {
        Location::new(Arc::new(PathBuf::from("scene.xml")), line)
    }

    fn prop(name: &str, value: Value, line: u32) -> Property {
        Property {
            name: name.to_string(),
            value,
            loc: loc(line),
            used: Cell::new(false),
            look_at_target: None,
        }
    }

    fn conductor() -> Object {
        let mut obj = Object::new(Category::Bsdf, "roughconductor", loc(40));
        obj.props.push(prop("alpha", Value::Float(0.1), 41));
        obj.props.push(prop("roughnes", Value::Float(0.2), 42));
        obj.props.push(prop("sample_count", Value::Integer(4), 43));
        obj.props
            .push(prop("distribution", Value::String("ggx".into()), 44));
        obj
    }

    #[test]
    fn category_names_round_trip() {
        for c in Category::ALL {
            assert_eq!(Category::from_tag(c.as_str()), Some(c));
        }
        assert_eq!(Category::from_tag("bogus"), None);
        assert_eq!(Category::Rfilter.to_string(), "rfilter");
    }

    #[test]
    fn unused_parameter_message_names_file_line_and_plugin() {
        let obj = conductor();
        assert_eq!(obj.float("alpha").unwrap(), Some(0.1));
        obj.mark_ignored("sample_count");
        assert_eq!(obj.string_or("distribution", "beckmann").unwrap(), "ggx");
        let err = obj.check_unused().unwrap_err().to_string();
        assert_eq!(
            err,
            "scene.xml:42: unknown parameter \"roughnes\" for bsdf \"roughconductor\""
        );
        obj.mark_ignored("roughnes");
        assert!(obj.check_unused().is_ok());
    }

    #[test]
    fn typed_accessors_check_types_and_accept_integer_as_float() {
        let obj = conductor();
        assert_eq!(obj.float("sample_count").unwrap(), Some(4.0));
        assert_eq!(obj.float_or("missing", 2.5).unwrap(), 2.5);
        let err = obj.integer("alpha").unwrap_err().to_string();
        assert!(err.starts_with("scene.xml:41: "), "{err}");
        assert!(err.contains("must be an integer, not a float"), "{err}");
        let err = obj.boolean("distribution").unwrap_err().to_string();
        assert!(err.starts_with("scene.xml:44: "), "{err}");
        assert_eq!(obj.transform("to_world").unwrap(), DMat4::IDENTITY);
        assert!(obj.rgb_or_spectrum("alpha").unwrap().is_some());
        assert!(obj.rgb_or_spectrum("distribution").is_err());
    }

    #[test]
    fn children_are_marked_used_and_unused_ones_reported() {
        let mut shape = Object::new(Category::Shape, "sphere", loc(10));
        let bsdf = Rc::new(Object::new(Category::Bsdf, "diffuse", loc(11)));
        let medium = Rc::new(Object::new(Category::Medium, "homogeneous", loc(12)));
        shape.children.push(Child {
            name: None,
            object: bsdf.clone(),
            loc: loc(13),
            used: Cell::new(false),
        });
        shape.children.push(Child {
            name: Some("interior".into()),
            object: medium,
            loc: loc(14),
            used: Cell::new(false),
        });
        let err = shape.check_unused().unwrap_err().to_string();
        assert_eq!(
            err,
            "scene.xml:13: unexpected nested bsdf \"diffuse\" in shape \"sphere\""
        );
        let found = shape.single_child(Category::Bsdf).unwrap().unwrap();
        assert!(Rc::ptr_eq(&found.object, &bsdf));
        let err = shape.check_unused().unwrap_err().to_string();
        assert_eq!(
            err,
            "scene.xml:14: unknown parameter \"interior\" for shape \"sphere\""
        );
        assert!(shape.child("interior").is_some());
        assert!(shape.check_unused_tree().is_ok());
    }

    #[test]
    fn resolve_lists_every_candidate() {
        let dirs = vec![
            PathBuf::from("/nonexistent-a"),
            PathBuf::from("/nonexistent-b"),
        ];
        let err = resolve_in(&dirs, "mesh.obj", Some(&loc(7))).unwrap_err();
        let text = err.to_string();
        assert!(text.starts_with("scene.xml:7: "), "{text}");
        assert!(text.contains("/nonexistent-a/mesh.obj"), "{text}");
        assert!(text.contains("/nonexistent-b/mesh.obj"), "{text}");
    }
}
