//! Recording what a plugin read, and building it again from the record
//! with one value changed: the machinery behind
//! [`crate::Scene::parameters`] and [`crate::Scene::update`].
//!
//! A front end wraps the [`Params`] it hands a plugin's `from_params` in a
//! [`Recorder`]: every getter's answer (a value, an absent parameter, a
//! texture index, a nested object's own record) is written to a
//! [`Record`]. Later, [`Record::set`] changes one value of a copy of the
//! record and [`Replay`] hands that copy to the same `from_params`, so an
//! edited object is validated by exactly the code that validated the
//! file, and equals what a fresh load of the edited file builds. Nothing
//! is read from disk again: images, voxel grids and nested objects are
//! replayed as the indices (or shared data) the load gave them, and a
//! mesh file cannot be re-read at all (mesh shapes are not recorded).

use super::{check_color, ColorKind, Family, NamedChild, ParamError, Params};
use crate::bsdf::Material;
use crate::material::Materials;
use crate::medium::Grid;
use crate::texture::Tex;
use crate::Rgb;
use glam::{DMat4, Vec3};
use std::sync::Arc;

/// The value of an editable parameter.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamValue {
    /// A float.
    Float(f32),
    /// An integer.
    Integer(i64),
    /// A boolean.
    Boolean(bool),
    /// A string (a choice such as a distribution's name).
    String(String),
    /// A point or a vector.
    Vector(Vec3),
    /// A 4×4 transform (`to_world`), composed in f64 as the loader does.
    Transform(DMat4),
    /// An RGB colour (a constant texture's `value`; a float is taken as
    /// grey).
    Color(Rgb),
}

impl ParamValue {
    fn type_name(&self) -> &'static str {
        match self {
            ParamValue::Float(_) => "a float",
            ParamValue::Integer(_) => "an integer",
            ParamValue::Boolean(_) => "a boolean",
            ParamValue::String(_) => "a string",
            ParamValue::Vector(_) => "a vector",
            ParamValue::Transform(_) => "a transform",
            ParamValue::Color(_) => "a colour",
        }
    }
}

impl std::fmt::Display for ParamValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParamValue::Float(v) => write!(f, "{v}"),
            ParamValue::Integer(v) => write!(f, "{v}"),
            ParamValue::Boolean(v) => write!(f, "{v}"),
            ParamValue::String(v) => write!(f, "\"{v}\""),
            ParamValue::Vector(v) => write!(f, "{}, {}, {}", v.x, v.y, v.z),
            ParamValue::Transform(m) => {
                let rows: Vec<String> = (0..4)
                    .map(|r| {
                        let row = m.row(r);
                        format!("{} {} {} {}", row.x, row.y, row.z, row.w)
                    })
                    .collect();
                write!(f, "[{}]", rows.join("; "))
            }
            ParamValue::Color(c) => write!(f, "{c}"),
        }
    }
}

/// What a parameter holds, as the plugin asked for it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamKind {
    /// [`Params::float`].
    Float,
    /// [`Params::integer`].
    Integer,
    /// [`Params::boolean`].
    Boolean,
    /// [`Params::string`].
    String,
    /// [`Params::point`].
    Point,
    /// [`Params::vector`].
    Vector,
    /// [`Params::transform`].
    Transform,
    /// [`Params::color`] in its role.
    Color(ColorKind),
    /// [`Params::texture`] holding a constant, in its role; its key ends
    /// in `.value`, as Mitsuba names a constant texture's value.
    Texture(ColorKind),
}

impl ParamKind {
    fn type_name(self) -> &'static str {
        match self {
            ParamKind::Float => "a float",
            ParamKind::Integer => "an integer",
            ParamKind::Boolean => "a boolean",
            ParamKind::String => "a string",
            ParamKind::Point => "a point",
            ParamKind::Vector => "a vector",
            ParamKind::Transform => "a transform",
            ParamKind::Color(_) | ParamKind::Texture(_) => "a colour (or a number, for grey)",
        }
    }

    /// `value` as this kind wants it (an integer is a float, a float a
    /// grey colour), or `None` when the types differ.
    fn coerce(self, value: ParamValue) -> Option<ParamValue> {
        use ParamValue as V;
        Some(match (self, value) {
            (ParamKind::Float, V::Float(v)) => V::Float(v),
            (ParamKind::Float, V::Integer(v)) => V::Float(v as f32),
            (ParamKind::Integer, V::Integer(v)) => V::Integer(v),
            (ParamKind::Boolean, V::Boolean(v)) => V::Boolean(v),
            (ParamKind::String, V::String(v)) => V::String(v),
            (ParamKind::Point | ParamKind::Vector, V::Vector(v)) => V::Vector(v),
            (ParamKind::Transform, V::Transform(m)) => V::Transform(m),
            (ParamKind::Color(_) | ParamKind::Texture(_), V::Color(c)) => V::Color(c),
            (ParamKind::Color(_) | ParamKind::Texture(_), V::Float(v)) => V::Color(Rgb::splat(v)),
            (ParamKind::Color(_) | ParamKind::Texture(_), V::Integer(v)) => {
                V::Color(Rgb::splat(v as f32))
            }
            _ => return None,
        })
    }
}

/// One editable parameter of a scene, as [`crate::Scene::parameters`]
/// lists it.
#[derive(Clone, Debug, PartialEq)]
pub struct Parameter {
    /// Its stable key, in Mitsuba's `traverse` style
    /// (`red.reflectance.value`, `sensor.to_world`).
    pub key: String,
    /// What it holds.
    pub kind: ParamKind,
    /// Its value; `None` when the file left it at the plugin's default
    /// (setting it overrides the default).
    pub value: Option<ParamValue>,
}

/// A parameter the plugin read by value.
#[derive(Clone, Debug, PartialEq)]
struct Entry {
    name: String,
    kind: ParamKind,
    value: Option<Stored>,
}

/// A [`ParamValue`] as a record keeps it: a transform boxed, so that the
/// records of a scene of many shapes (each with its `to_world`, most of
/// their other values scalars) take a third of the memory.
#[derive(Clone, Debug, PartialEq)]
enum Stored {
    Float(f32),
    Integer(i64),
    Boolean(bool),
    String(Box<str>),
    Vector(Vec3),
    Transform(Box<DMat4>),
    Color(Rgb),
}

impl From<ParamValue> for Stored {
    fn from(v: ParamValue) -> Self {
        match v {
            ParamValue::Float(v) => Stored::Float(v),
            ParamValue::Integer(v) => Stored::Integer(v),
            ParamValue::Boolean(v) => Stored::Boolean(v),
            ParamValue::String(v) => Stored::String(v.into()),
            ParamValue::Vector(v) => Stored::Vector(v),
            ParamValue::Transform(m) => Stored::Transform(Box::new(m)),
            ParamValue::Color(c) => Stored::Color(c),
        }
    }
}

impl Stored {
    fn value(&self) -> ParamValue {
        match self {
            Stored::Float(v) => ParamValue::Float(*v),
            Stored::Integer(v) => ParamValue::Integer(*v),
            Stored::Boolean(v) => ParamValue::Boolean(*v),
            Stored::String(v) => ParamValue::String(v.to_string()),
            Stored::Vector(v) => ParamValue::Vector(*v),
            Stored::Transform(m) => ParamValue::Transform(**m),
            Stored::Color(c) => ParamValue::Color(*c),
        }
    }
}

/// A nested object the plugin asked for, and how.
#[derive(Clone, Debug)]
enum ChildQuery {
    /// [`Params::child`].
    Single(Family),
    /// [`Params::nth_child`].
    Nth(Family, usize),
    /// [`Params::named_child`].
    Named(Family, String),
}

#[derive(Clone, Debug)]
struct Child {
    query: ChildQuery,
    /// The name its parent gives it (for [`Params::nth_child`]).
    name: String,
    /// What it read; `None` when there was no such object.
    record: Option<Record>,
}

/// An answer a record keeps that is not a value.
#[derive(Clone, Debug)]
enum Other {
    /// A texturable parameter that held a texture object (not editable by
    /// value; the texture has its own record).
    Texture(String, Tex),
    LookAt(String, Option<Vec3>),
    NestedTextures(Vec<Tex>),
    Bsdfs(Vec<u32>),
    Image(String, Option<u32>),
    Grid(String, Option<Arc<Grid>>),
    Attribute(String, u32),
}

/// Everything a plugin read of its parameters, in a form it can read
/// again ([`Replay`]).
#[derive(Clone, Debug, Default)]
pub struct Record {
    describe: String,
    plugin_type: String,
    entries: Vec<Entry>,
    children: Vec<Child>,
    /// The other answers, which few plugins ask for (one list rather than
    /// one per kind keeps a record small).
    other: Vec<Other>,
}

impl Record {
    /// The plugin type the record was made for (`roughconductor`).
    pub fn plugin_type(&self) -> &str {
        &self.plugin_type
    }

    /// Every editable parameter under `prefix` (`red` gives
    /// `red.reflectance.value`), nested objects' too, in the order read.
    pub fn parameters(&self, prefix: &str, out: &mut Vec<Parameter>) {
        for e in &self.entries {
            out.push(Parameter {
                key: entry_key(prefix, e),
                kind: e.kind,
                value: e.value.as_ref().map(Stored::value),
            });
        }
        for (label, child) in self.labelled_children() {
            if let Some(r) = &child.record {
                r.parameters(&format!("{prefix}.{label}"), out);
            }
        }
    }

    /// The nested objects with the labels their keys use: the family
    /// (`film`), the name the parent gives it (`albedo`), or the family
    /// and position (`bsdf_1`) when several are unnamed.
    fn labelled_children(&self) -> impl Iterator<Item = (String, &Child)> {
        self.children.iter().map(|c| {
            let label = match &c.query {
                ChildQuery::Single(f) => family_label(*f).to_string(),
                ChildQuery::Named(_, name) => name.clone(),
                ChildQuery::Nth(f, i) if c.name.is_empty() => match i {
                    0 => family_label(*f).to_string(),
                    i => format!("{}_{i}", family_label(*f)),
                },
                ChildQuery::Nth(..) => c.name.clone(),
            };
            (label, c)
        })
    }

    /// Sets the parameter that `path` (a key with the object's own
    /// prefix removed: `reflectance.value`, `film.width`) names, checking
    /// its type. A transform's `<lookat>` target is forgotten with it.
    pub fn set(&mut self, path: &str, value: ParamValue) -> Result<(), String> {
        if let Some(i) = (self.entries.iter()).position(|e| entry_key("", e) == format!(".{path}"))
        {
            let e = &mut self.entries[i];
            let value = e
                .kind
                .coerce(value.clone())
                .ok_or_else(|| format!("is {}, not {}", e.kind.type_name(), value.type_name()))?;
            e.value = Some(value.into());
            if e.kind == ParamKind::Transform {
                let name = e.name.clone();
                (self.other).retain(|o| !matches!(o, Other::LookAt(n, _) if *n == name));
            }
            return Ok(());
        }
        let children: Vec<(String, usize)> = (self.labelled_children())
            .enumerate()
            .map(|(i, (label, _))| (label, i))
            .collect();
        for (label, i) in children {
            if let Some(rest) = path.strip_prefix(&label).and_then(|r| r.strip_prefix('.')) {
                if let Some(r) = &mut self.children[i].record {
                    return r.set(rest, value);
                }
            }
        }
        let texture = |o: &Other| match o {
            Other::Texture(n, _) if path.starts_with(n.as_str()) => Some(n.clone()),
            _ => None,
        };
        if let Some(name) = self.other.iter().find_map(texture) {
            return Err(format!(
                "\"{name}\" is a texture: edit the texture's own parameters"
            ));
        }
        if let Some(name) = self.image(path).map(|_| path) {
            return Err(format!(
                "\"{name}\" names a file, which an update does not read: load the scene again"
            ));
        }
        Err("is not a parameter of this scene".to_string())
    }

    fn texture(&self, name: &str) -> Option<Tex> {
        self.other.iter().find_map(|o| match o {
            Other::Texture(n, t) if n == name => Some(*t),
            _ => None,
        })
    }

    fn look_at(&self, name: &str) -> Option<Option<Vec3>> {
        self.other.iter().find_map(|o| match o {
            Other::LookAt(n, t) if n == name => Some(*t),
            _ => None,
        })
    }

    fn image(&self, name: &str) -> Option<Option<u32>> {
        self.other.iter().find_map(|o| match o {
            Other::Image(n, i) if n == name => Some(*i),
            _ => None,
        })
    }

    fn grid(&self, name: &str) -> Option<Option<Arc<Grid>>> {
        self.other.iter().find_map(|o| match o {
            Other::Grid(n, g) if n == name => Some(g.clone()),
            _ => None,
        })
    }

    fn attribute(&self, name: &str) -> Option<u32> {
        self.other.iter().find_map(|o| match o {
            Other::Attribute(n, i) if n == name => Some(*i),
            _ => None,
        })
    }

    fn nested_textures(&self) -> Option<&[Tex]> {
        self.other.iter().find_map(|o| match o {
            Other::NestedTextures(t) => Some(t.as_slice()),
            _ => None,
        })
    }

    fn bsdfs(&self) -> Option<&[u32]> {
        self.other.iter().find_map(|o| match o {
            Other::Bsdfs(b) => Some(b.as_slice()),
            _ => None,
        })
    }

    /// Records `entry`; a parameter read again through the same getter
    /// keeps its last answer.
    fn add(&mut self, entry: Entry) {
        (self.entries).retain(|e| !(e.name == entry.name && same_getter(e.kind, entry.kind)));
        self.entries.push(entry);
    }

    fn entry(&self, name: &str, kind: ParamKind) -> Option<&Entry> {
        (self.entries.iter()).find(|e| e.name == name && same_getter(e.kind, kind))
    }
}

/// Whether two kinds come from the same getter (colour roles aside).
fn same_getter(a: ParamKind, b: ParamKind) -> bool {
    std::mem::discriminant(&a) == std::mem::discriminant(&b)
}

fn entry_key(prefix: &str, e: &Entry) -> String {
    match e.kind {
        ParamKind::Texture(_) | ParamKind::Color(_) => format!("{prefix}.{}.value", e.name),
        _ => format!("{prefix}.{}", e.name),
    }
}

fn family_label(f: Family) -> &'static str {
    match f {
        Family::Film => "film",
        Family::Sampler => "sampler",
        Family::Rfilter => "rfilter",
        Family::Integrator => "integrator",
        Family::Phase => "phase_function",
        Family::Volume => "volume",
        Family::Sdf => "sdf",
        Family::Sensor => "sensor",
        Family::Shape => "shape",
    }
}

/// The [`Params`] a recorder forwards to: the front end's own, or a
/// nested object's that it handed out.
enum Inner<'a> {
    Borrowed(&'a mut dyn Params),
    Owned(Box<dyn Params + 'a>),
}

impl Inner<'_> {
    #[inline]
    fn get(&mut self) -> &mut dyn Params {
        match self {
            Inner::Borrowed(p) => &mut **p,
            Inner::Owned(p) => p.as_mut(),
        }
    }
    #[inline]
    fn get_ref(&self) -> &dyn Params {
        match self {
            Inner::Borrowed(p) => &**p,
            Inner::Owned(p) => p.as_ref(),
        }
    }
}

/// Forwards to a front end's [`Params`] and records every answer.
pub struct Recorder<'a> {
    inner: Inner<'a>,
    record: &'a mut Record,
}

impl std::fmt::Debug for Recorder<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recorder")
            .field("record", &self.record)
            .finish()
    }
}

impl<'a> Recorder<'a> {
    /// Records what is read of `inner` into `record` (which it resets).
    pub fn new(inner: &'a mut dyn Params, record: &'a mut Record) -> Self {
        *record = Record {
            describe: inner.describe(),
            plugin_type: inner.plugin_type(),
            ..Record::default()
        };
        Self {
            inner: Inner::Borrowed(inner),
            record,
        }
    }

    fn value<T>(
        &mut self,
        name: &str,
        kind: ParamKind,
        get: impl FnOnce(&mut dyn Params) -> Result<Option<T>, ParamError>,
        wrap: impl FnOnce(&T) -> ParamValue,
    ) -> Result<Option<T>, ParamError> {
        let v = get(self.inner.get())?;
        self.record.add(Entry {
            name: name.to_string(),
            kind,
            value: v.as_ref().map(|v| wrap(v).into()),
        });
        Ok(v)
    }

    /// A recorder for a nested object `inner` handed out by the front
    /// end; its record is appended to this one's children.
    fn child_recorder<'b>(
        record: &'b mut Record,
        query: ChildQuery,
        name: String,
        inner: Option<Box<dyn Params + 'b>>,
    ) -> Option<Box<dyn Params + 'b>> {
        let Some(inner) = inner else {
            record.children.push(Child {
                query,
                name,
                record: None,
            });
            return None;
        };
        record.children.push(Child {
            query,
            name,
            record: Some(Record {
                describe: inner.describe(),
                plugin_type: inner.plugin_type(),
                ..Record::default()
            }),
        });
        let slot = (record.children.last_mut())
            .and_then(|c| c.record.as_mut())
            .expect("pushed above");
        Some(Box::new(Recorder {
            inner: Inner::Owned(inner),
            record: slot,
        }))
    }
}

impl Params for Recorder<'_> {
    fn describe(&self) -> String {
        self.inner.get_ref().describe()
    }
    fn plugin_type(&self) -> String {
        self.inner.get_ref().plugin_type()
    }
    fn child(&mut self, family: Family) -> Result<Option<Box<dyn Params + '_>>, ParamError> {
        let Recorder { inner, record } = self;
        let c = inner.get().child(family)?;
        Ok(Self::child_recorder(
            record,
            ChildQuery::Single(family),
            String::new(),
            c,
        ))
    }
    fn nth_child(
        &mut self,
        family: Family,
        index: usize,
    ) -> Result<Option<NamedChild<'_>>, ParamError> {
        let Recorder { inner, record } = self;
        let (name, c) = match inner.get().nth_child(family, index)? {
            Some((name, c)) => (name, Some(c)),
            None => (String::new(), None),
        };
        let query = ChildQuery::Nth(family, index);
        Ok(Self::child_recorder(record, query, name.clone(), c).map(|c| (name, c)))
    }
    fn named_child(
        &mut self,
        family: Family,
        name: &str,
    ) -> Result<Option<Box<dyn Params + '_>>, ParamError> {
        let Recorder { inner, record } = self;
        let c = inner.get().named_child(family, name)?;
        let query = ChildQuery::Named(family, name.to_string());
        Ok(Self::child_recorder(record, query, name.to_string(), c))
    }
    fn grid_file(&mut self, name: &str) -> Result<Option<Arc<Grid>>, ParamError> {
        let g = self.inner.get().grid_file(name)?;
        self.record
            .other
            .push(Other::Grid(name.to_string(), g.clone()));
        Ok(g)
    }
    fn error_at(&self, name: Option<&str>, msg: &str) -> ParamError {
        self.inner.get_ref().error_at(name, msg)
    }
    fn has(&self, name: &str) -> bool {
        self.inner.get_ref().has(name)
    }
    fn float(&mut self, name: &str) -> Result<Option<f32>, ParamError> {
        self.value(
            name,
            ParamKind::Float,
            |p| p.float(name),
            |v| ParamValue::Float(*v),
        )
    }
    fn integer(&mut self, name: &str) -> Result<Option<i64>, ParamError> {
        self.value(
            name,
            ParamKind::Integer,
            |p| p.integer(name),
            |v| ParamValue::Integer(*v),
        )
    }
    fn boolean(&mut self, name: &str) -> Result<Option<bool>, ParamError> {
        self.value(
            name,
            ParamKind::Boolean,
            |p| p.boolean(name),
            |v| ParamValue::Boolean(*v),
        )
    }
    fn string(&mut self, name: &str) -> Result<Option<String>, ParamError> {
        self.value(
            name,
            ParamKind::String,
            |p| p.string(name),
            |v| ParamValue::String(v.clone()),
        )
    }
    fn point(&mut self, name: &str) -> Result<Option<Vec3>, ParamError> {
        self.value(
            name,
            ParamKind::Point,
            |p| p.point(name),
            |v| ParamValue::Vector(*v),
        )
    }
    fn vector(&mut self, name: &str) -> Result<Option<Vec3>, ParamError> {
        self.value(
            name,
            ParamKind::Vector,
            |p| p.vector(name),
            |v| ParamValue::Vector(*v),
        )
    }
    fn transform(&mut self, name: &str) -> Result<Option<DMat4>, ParamError> {
        self.value(
            name,
            ParamKind::Transform,
            |p| p.transform(name),
            |m| ParamValue::Transform(*m),
        )
    }
    fn look_at_target(&mut self, name: &str) -> Option<Vec3> {
        let t = self.inner.get().look_at_target(name);
        self.record.other.push(Other::LookAt(name.to_string(), t));
        t
    }
    fn color(&mut self, name: &str, kind: ColorKind) -> Result<Option<Rgb>, ParamError> {
        self.value(
            name,
            ParamKind::Color(kind),
            |p| p.color(name, kind),
            |c| ParamValue::Color(*c),
        )
    }
    fn texture(&mut self, name: &str, kind: ColorKind) -> Result<Option<Tex>, ParamError> {
        let t = self.inner.get().texture(name, kind)?;
        match t {
            Some(tex @ Tex::Texture(_)) => {
                (self.record.other).push(Other::Texture(name.to_string(), tex));
            }
            _ => self.record.add(Entry {
                name: name.to_string(),
                kind: ParamKind::Texture(kind),
                value: t.map(|t| match t {
                    Tex::Const(c) => Stored::Color(c),
                    Tex::Texture(_) => unreachable!("matched above"),
                }),
            }),
        }
        Ok(t)
    }
    fn nested_textures(&mut self) -> Result<Vec<Tex>, ParamError> {
        let t = self.inner.get().nested_textures()?;
        self.record.other.push(Other::NestedTextures(t.clone()));
        Ok(t)
    }
    fn bsdfs(&mut self) -> Result<Vec<(u32, Material)>, ParamError> {
        let b = self.inner.get().bsdfs()?;
        (self.record.other).push(Other::Bsdfs(b.iter().map(|(i, _)| *i).collect()));
        Ok(b)
    }
    fn image(&mut self, name: &str) -> Result<Option<u32>, ParamError> {
        let i = self.inner.get().image(name)?;
        self.record.other.push(Other::Image(name.to_string(), i));
        Ok(i)
    }
    fn mesh_file(&mut self) -> Result<crate::shape::MeshData, ParamError> {
        // Not recorded: a replay reads no file (mesh shapes are not
        // editable).
        self.inner.get().mesh_file()
    }
    fn ply_table(&mut self, name: &str) -> Result<Option<crate::shape::PropertyTable>, ParamError> {
        // Not recorded, as a mesh file.
        self.inner.get().ply_table(name)
    }
    fn file_bytes(&mut self, name: &str) -> Result<Option<Vec<u8>>, ParamError> {
        // Not recorded, as a mesh file.
        self.inner.get().file_bytes(name)
    }
    fn attribute_index(&mut self, attribute: &str) -> Result<u32, ParamError> {
        let i = self.inner.get().attribute_index(attribute)?;
        (self.record.other).push(Other::Attribute(attribute.to_string(), i));
        Ok(i)
    }
    fn mark_ignored(&mut self, name: &str) {
        self.inner.get().mark_ignored(name);
    }
    fn warn(&mut self, name: Option<&str>, msg: &str) {
        self.inner.get().warn(name, msg);
    }
}

/// Answers a plugin's getters from a [`Record`], so that its
/// `from_params` builds the object again.
#[derive(Debug)]
pub struct Replay<'a> {
    record: &'a Record,
    materials: &'a Materials,
}

impl<'a> Replay<'a> {
    /// Replays `record`; nested BSDFs are read from `materials`.
    pub fn new(record: &'a Record, materials: &'a Materials) -> Self {
        Self { record, materials }
    }

    fn value(&self, name: &str, kind: ParamKind) -> Result<Option<ParamValue>, ParamError> {
        match self.record.entry(name, kind) {
            Some(e) => Ok(e.value.as_ref().map(Stored::value)),
            None => Err(self.not_recorded(name)),
        }
    }

    fn not_recorded(&self, name: &str) -> ParamError {
        ParamError(format!(
            "{} read \"{name}\" in a way its load did not; load the scene again",
            self.record.describe
        ))
    }

    fn child_of(&self, matches: impl Fn(&ChildQuery) -> bool) -> Option<&'a Child> {
        self.record.children.iter().find(|c| matches(&c.query))
    }
}

macro_rules! replay_getter {
    ($fn:ident, $ty:ty, $kind:expr, $pat:pat => $out:expr) => {
        fn $fn(&mut self, name: &str) -> Result<Option<$ty>, ParamError> {
            Ok(match self.value(name, $kind)? {
                None => None,
                Some($pat) => Some($out),
                Some(other) => {
                    return Err(self.param_error(name, &format!("holds {}", other.type_name())))
                }
            })
        }
    };
}

impl Params for Replay<'_> {
    fn describe(&self) -> String {
        self.record.describe.clone()
    }
    fn plugin_type(&self) -> String {
        self.record.plugin_type.clone()
    }
    fn child(&mut self, family: Family) -> Result<Option<Box<dyn Params + '_>>, ParamError> {
        let c = self.child_of(|q| matches!(q, ChildQuery::Single(f) if *f == family));
        Ok(c.and_then(|c| c.record.as_ref())
            .map(|r| Box::new(Replay::new(r, self.materials)) as Box<dyn Params>))
    }
    fn nth_child(
        &mut self,
        family: Family,
        index: usize,
    ) -> Result<Option<NamedChild<'_>>, ParamError> {
        let c =
            self.child_of(|q| matches!(q, ChildQuery::Nth(f, i) if *f == family && *i == index));
        Ok(c.and_then(|c| {
            let r = c.record.as_ref()?;
            Some((
                c.name.clone(),
                Box::new(Replay::new(r, self.materials)) as Box<dyn Params>,
            ))
        }))
    }
    fn named_child(
        &mut self,
        family: Family,
        name: &str,
    ) -> Result<Option<Box<dyn Params + '_>>, ParamError> {
        let c =
            self.child_of(|q| matches!(q, ChildQuery::Named(f, n) if *f == family && n == name));
        Ok(c.and_then(|c| c.record.as_ref())
            .map(|r| Box::new(Replay::new(r, self.materials)) as Box<dyn Params>))
    }
    fn grid_file(&mut self, name: &str) -> Result<Option<Arc<Grid>>, ParamError> {
        (self.record.grid(name)).ok_or_else(|| self.not_recorded(name))
    }
    fn error_at(&self, _name: Option<&str>, msg: &str) -> ParamError {
        ParamError(msg.to_string())
    }
    fn has(&self, name: &str) -> bool {
        if let Some(e) = self.record.entries.iter().find(|e| e.name == name) {
            return e.value.is_some();
        }
        // A front end answers for parameters the plugin only asks about;
        // a replay knows those it read.
        self.record.texture(name).is_some()
            || self.record.image(name).is_some_and(|i| i.is_some())
            || self.record.grid(name).is_some_and(|g| g.is_some())
            || (self.record.children.iter()).any(|c| {
                matches!(&c.query, ChildQuery::Named(_, n) if n == name) && c.record.is_some()
            })
    }
    replay_getter!(float, f32, ParamKind::Float, ParamValue::Float(v) => v);
    replay_getter!(integer, i64, ParamKind::Integer, ParamValue::Integer(v) => v);
    replay_getter!(boolean, bool, ParamKind::Boolean, ParamValue::Boolean(v) => v);
    replay_getter!(string, String, ParamKind::String, ParamValue::String(v) => v);
    replay_getter!(point, Vec3, ParamKind::Point, ParamValue::Vector(v) => v);
    replay_getter!(vector, Vec3, ParamKind::Vector, ParamValue::Vector(v) => v);
    replay_getter!(transform, DMat4, ParamKind::Transform, ParamValue::Transform(m) => m);
    fn look_at_target(&mut self, name: &str) -> Option<Vec3> {
        self.record.look_at(name).flatten()
    }
    fn color(&mut self, name: &str, kind: ColorKind) -> Result<Option<Rgb>, ParamError> {
        match self.value(name, ParamKind::Color(kind))? {
            None => Ok(None),
            Some(ParamValue::Color(c)) => check_color(self, name, c, kind).map(Some),
            Some(other) => Err(self.param_error(name, &format!("holds {}", other.type_name()))),
        }
    }
    fn texture(&mut self, name: &str, kind: ColorKind) -> Result<Option<Tex>, ParamError> {
        if let Some(t) = self.record.texture(name) {
            return Ok(Some(t));
        }
        match self.value(name, ParamKind::Texture(kind))? {
            None => Ok(None),
            Some(ParamValue::Color(c)) => {
                check_color(self, name, c, kind).map(|c| Some(Tex::Const(c)))
            }
            Some(other) => Err(self.param_error(name, &format!("holds {}", other.type_name()))),
        }
    }
    fn nested_textures(&mut self) -> Result<Vec<Tex>, ParamError> {
        Ok(self.record.nested_textures().unwrap_or_default().to_vec())
    }
    fn bsdfs(&mut self) -> Result<Vec<(u32, Material)>, ParamError> {
        let indices = self.record.bsdfs().unwrap_or_default();
        indices
            .iter()
            .map(|&i| {
                self.materials
                    .bsdfs
                    .get(i as usize)
                    .map(|b| (i, *b))
                    .ok_or_else(|| self.not_recorded("bsdf"))
            })
            .collect()
    }
    fn image(&mut self, name: &str) -> Result<Option<u32>, ParamError> {
        (self.record.image(name)).ok_or_else(|| self.not_recorded(name))
    }
    fn mesh_file(&mut self) -> Result<crate::shape::MeshData, ParamError> {
        Err(self.error("a mesh file is not read again by an update: load the scene again"))
    }
    fn ply_table(
        &mut self,
        _name: &str,
    ) -> Result<Option<crate::shape::PropertyTable>, ParamError> {
        Err(self.error("a PLY file is not read again by an update: load the scene again"))
    }
    fn attribute_index(&mut self, attribute: &str) -> Result<u32, ParamError> {
        (self.record.attribute(attribute)).ok_or_else(|| self.not_recorded(attribute))
    }
    fn mark_ignored(&mut self, _name: &str) {}
    fn warn(&mut self, _name: Option<&str>, _msg: &str) {}
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::params::MapParams;

    fn plugin(name: &str) -> crate::bsdf::BsdfFromParams {
        let found = crate::bsdf::PLUGINS.iter().find(|(n, _)| *n == name);
        found.expect("a BSDF plugin").1
    }

    fn recorded(name: &str, p: &mut MapParams) -> (Material, Record) {
        let mut record = Record::default();
        let b = plugin(name)(&mut Recorder::new(p, &mut record)).unwrap();
        (b, record)
    }

    fn replayed(name: &str, record: &Record) -> Result<Material, ParamError> {
        let m = Materials::default();
        plugin(name)(&mut Replay::new(record, &m))
    }

    #[test]
    fn a_replay_builds_what_the_load_built() {
        let mut p = MapParams::new()
            .float("alpha", 0.3)
            .string("distribution", "beckmann");
        let (built, record) = recorded("roughconductor", &mut p);
        let again = replayed("roughconductor", &record).unwrap();
        assert_eq!(format!("{again:?}"), format!("{built:?}"));
    }

    #[test]
    fn set_changes_one_value_and_checks_its_type() {
        let mut p = MapParams::new().color("reflectance", Rgb::new(0.2, 0.3, 0.4));
        let (_, mut record) = recorded("diffuse", &mut p);
        let mut keys = Vec::new();
        record.parameters("wall", &mut keys);
        assert_eq!(keys.len(), 1);
        assert_eq!(keys[0].key, "wall.reflectance.value");
        assert!(record
            .set("reflectance.value", ParamValue::Boolean(true))
            .is_err());
        assert!(record.set("roughness", ParamValue::Float(0.1)).is_err());
        record
            .set(
                "reflectance.value",
                ParamValue::Color(Rgb::new(0.9, 0.1, 0.1)),
            )
            .unwrap();
        let mut q = MapParams::new().color("reflectance", Rgb::new(0.9, 0.1, 0.1));
        let (fresh, _) = recorded("diffuse", &mut q);
        let again = replayed("diffuse", &record).unwrap();
        assert_eq!(format!("{again:?}"), format!("{fresh:?}"));
    }

    #[test]
    fn a_replayed_value_is_validated_as_the_loader_validates_it() {
        let mut p = MapParams::new().color("reflectance", Rgb::splat(0.5));
        let (_, mut record) = recorded("diffuse", &mut p);
        record
            .set(
                "reflectance.value",
                ParamValue::Color(Rgb::new(-1.0, 0.0, 0.0)),
            )
            .unwrap();
        let e = replayed("diffuse", &record).unwrap_err();
        assert!(e.0.contains("invalid value"), "{e}");
    }
}
