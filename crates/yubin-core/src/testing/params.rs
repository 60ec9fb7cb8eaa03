//! An in-memory [`Params`] for tests of plugins' `from_params`: a list of
//! named values, with the same "read marks" a scene front end keeps, so a
//! test can assert that a plugin read everything it was given.

use crate::bsdf::Material;
use crate::params::{ColorKind, ParamError, Params};
use crate::texture::Tex;
use crate::Rgb;
use glam::{DMat4, Vec3};

/// One parameter value.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// A float.
    Float(f32),
    /// An integer.
    Integer(i64),
    /// A boolean.
    Bool(bool),
    /// A string.
    String(String),
    /// A colour (also what a float is as a colour).
    Rgb(Rgb),
    /// A texture, by index.
    Texture(u32),
    /// An image file already in the scene's image table, by index.
    Image(u32),
    /// A transform matrix.
    Transform(glam::DMat4),
    /// A point or vector.
    Vector(Vec3),
}

/// Named values and which of them were read.
#[derive(Clone, Debug, Default)]
pub struct MapParams {
    entries: Vec<(String, Value, bool)>,
}

impl MapParams {
    /// No parameters.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds parameter `name` (builder style).
    pub fn with(mut self, name: &str, v: Value) -> Self {
        self.entries.push((name.to_string(), v, false));
        self
    }

    /// Adds a float parameter.
    pub fn float(self, name: &str, v: f32) -> Self {
        self.with(name, Value::Float(v))
    }

    /// Adds a string parameter.
    pub fn string(self, name: &str, v: &str) -> Self {
        self.with(name, Value::String(v.to_string()))
    }

    /// Adds a boolean parameter.
    pub fn boolean(self, name: &str, v: bool) -> Self {
        self.with(name, Value::Bool(v))
    }

    /// Adds a colour parameter.
    pub fn color(self, name: &str, v: Rgb) -> Self {
        self.with(name, Value::Rgb(v))
    }

    /// Adds a texture parameter (a texture index).
    pub fn texture(self, name: &str, index: u32) -> Self {
        self.with(name, Value::Texture(index))
    }

    /// Names of parameters nobody read.
    pub fn unread(&self) -> Vec<String> {
        self.entries
            .iter()
            .filter(|e| !e.2)
            .map(|e| e.0.clone())
            .collect()
    }

    fn take(&mut self, name: &str) -> Option<Value> {
        let e = self.entries.iter_mut().find(|e| e.0 == name)?;
        e.2 = true;
        Some(e.1.clone())
    }

    fn wrong(&self, name: &str, want: &str) -> ParamError {
        self.param_error(name, &format!("expected {want}"))
    }
}

impl Params for MapParams {
    fn plugin_type(&self) -> String {
        "test".into()
    }
    fn child(
        &mut self,
        _: crate::params::Family,
    ) -> Result<Option<Box<dyn Params + '_>>, ParamError> {
        Ok(None)
    }
    fn describe(&self) -> String {
        "test object".into()
    }
    fn error_at(&self, _: Option<&str>, msg: &str) -> ParamError {
        ParamError(msg.to_string())
    }
    fn has(&self, name: &str) -> bool {
        self.entries.iter().any(|e| e.0 == name)
    }
    fn float(&mut self, name: &str) -> Result<Option<f32>, ParamError> {
        match self.take(name) {
            None => Ok(None),
            Some(Value::Float(v)) => Ok(Some(v)),
            Some(Value::Integer(v)) => Ok(Some(v as f32)),
            Some(_) => Err(self.wrong(name, "a float")),
        }
    }
    fn integer(&mut self, name: &str) -> Result<Option<i64>, ParamError> {
        match self.take(name) {
            None => Ok(None),
            Some(Value::Integer(v)) => Ok(Some(v)),
            Some(_) => Err(self.wrong(name, "an integer")),
        }
    }
    fn boolean(&mut self, name: &str) -> Result<Option<bool>, ParamError> {
        match self.take(name) {
            None => Ok(None),
            Some(Value::Bool(v)) => Ok(Some(v)),
            Some(_) => Err(self.wrong(name, "a boolean")),
        }
    }
    fn string(&mut self, name: &str) -> Result<Option<String>, ParamError> {
        match self.take(name) {
            None => Ok(None),
            Some(Value::String(v)) => Ok(Some(v)),
            Some(_) => Err(self.wrong(name, "a string")),
        }
    }
    fn point(&mut self, name: &str) -> Result<Option<Vec3>, ParamError> {
        match self.take(name) {
            None => Ok(None),
            Some(Value::Vector(v)) => Ok(Some(v)),
            Some(_) => Err(self.wrong(name, "a point or vector")),
        }
    }
    fn vector(&mut self, name: &str) -> Result<Option<Vec3>, ParamError> {
        self.point(name)
    }
    fn transform(&mut self, name: &str) -> Result<Option<DMat4>, ParamError> {
        match self.take(name) {
            None => Ok(None),
            Some(Value::Transform(m)) => Ok(Some(m)),
            Some(_) => Err(self.wrong(name, "a transform")),
        }
    }
    fn color(&mut self, name: &str, _: ColorKind) -> Result<Option<Rgb>, ParamError> {
        match self.take(name) {
            None => Ok(None),
            Some(Value::Rgb(c)) => Ok(Some(c)),
            Some(Value::Float(v)) => Ok(Some(Rgb::splat(v))),
            Some(_) => Err(self.wrong(name, "a colour")),
        }
    }
    fn texture(&mut self, name: &str, kind: ColorKind) -> Result<Option<Tex>, ParamError> {
        if let Some(e) = self.entries.iter_mut().find(|e| e.0 == name) {
            if let Value::Texture(t) = e.1 {
                e.2 = true;
                return Ok(Some(Tex::Texture(t)));
            }
        }
        Ok(Params::color(self, name, kind)?.map(Tex::Const))
    }
    fn bsdfs(&mut self) -> Result<Vec<(u32, Material)>, ParamError> {
        Ok(Vec::new())
    }
    fn image(&mut self, name: &str) -> Result<Option<u32>, ParamError> {
        match self.take(name) {
            None => Ok(None),
            Some(Value::Image(i)) => Ok(Some(i)),
            Some(_) => Err(self.wrong(name, "an image")),
        }
    }
    fn mark_ignored(&mut self, name: &str) {
        self.take(name);
    }
    fn warn(&mut self, _: Option<&str>, _: &str) {}
}
