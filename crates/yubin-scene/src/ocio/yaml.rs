//! The YAML of an OCIO config as a small tree that keeps each node's line
//! and tag (`!<FileTransform>`), read with `saphyr`.

use crate::error::{Location, SceneError};
use saphyr::{LoadableYamlNode, MarkedYaml, Scalar, YamlData};
use std::path::PathBuf;
use std::sync::Arc;

/// A YAML node: its 1-based line, its tag (without `!<` `>`), its value.
#[derive(Clone, Debug)]
pub struct Node {
    pub line: u32,
    pub tag: Option<String>,
    pub value: Value,
}

/// A node's value; scalars keep their text.
#[derive(Clone, Debug)]
pub enum Value {
    Null,
    Scalar(String),
    Seq(Vec<Node>),
    Map(Vec<(String, Node)>),
}

/// A config's text as a tree, every node knowing its line in `file`.
pub fn parse(text: &str, file: &Arc<PathBuf>) -> Result<Node, SceneError> {
    let docs = MarkedYaml::load_from_str(text).map_err(|e| {
        let line = e.marker().line() as u32;
        SceneError::at(
            &Location::new(file.clone(), line),
            format!("YAML: {}", e.info()),
        )
    })?;
    let Some(doc) = docs.first() else {
        return Err(SceneError::file(file.as_ref(), "empty OCIO config"));
    };
    Ok(convert(doc, None))
}

fn scalar_text(s: &Scalar) -> Option<String> {
    match s {
        Scalar::Null => None,
        Scalar::Boolean(b) => Some(b.to_string()),
        Scalar::Integer(i) => Some(i.to_string()),
        Scalar::FloatingPoint(f) => Some(f.into_inner().to_string()),
        Scalar::String(s) => Some(s.to_string()),
    }
}

fn convert(node: &MarkedYaml, tag: Option<String>) -> Node {
    let line = node.span.start.line() as u32;
    let value = match &node.data {
        YamlData::Tagged(t, inner) => return convert(inner, Some(t.suffix.clone())),
        YamlData::Value(s) => scalar_text(s).map_or(Value::Null, Value::Scalar),
        YamlData::Representation(text, _, _) => Value::Scalar(text.to_string()),
        YamlData::Sequence(items) => Value::Seq(items.iter().map(|n| convert(n, None)).collect()),
        YamlData::Mapping(map) => Value::Map(
            map.iter()
                .map(|(k, v)| (key_text(k), convert(v, None)))
                .collect(),
        ),
        _ => Value::Null,
    };
    Node { line, tag, value }
}

fn key_text(key: &MarkedYaml) -> String {
    match &key.data {
        YamlData::Value(s) => scalar_text(s).unwrap_or_default(),
        YamlData::Representation(text, _, _) => text.to_string(),
        _ => String::new(),
    }
}

impl Node {
    /// The value under `key` of a mapping (the last one if repeated).
    pub fn get(&self, key: &str) -> Option<&Node> {
        match &self.value {
            Value::Map(entries) => entries.iter().rev().find(|(k, _)| k == key).map(|(_, v)| v),
            _ => None,
        }
    }

    /// The text of a scalar.
    pub fn text(&self) -> Option<&str> {
        match &self.value {
            Value::Scalar(s) => Some(s),
            _ => None,
        }
    }

    /// The items of a sequence (none for null).
    pub fn items(&self) -> &[Node] {
        match &self.value {
            Value::Seq(items) => items,
            _ => &[],
        }
    }

    /// The entries of a mapping, in order.
    pub fn entries(&self) -> &[(String, Node)] {
        match &self.value {
            Value::Map(entries) => entries,
            _ => &[],
        }
    }
}
