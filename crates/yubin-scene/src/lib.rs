//! Scene front ends for yubin.
//!
//! A front end parses a file into a format-neutral description ([`desc`])
//! that remembers where every object and parameter came from; the builder
//! ([`build`]) turns a description into a [`yubin_core::Scene`] and reports
//! unknown plugins and unread parameters with `file:line`.
#![warn(missing_docs)]

pub mod build;
pub mod desc;
pub mod error;
pub mod image_io;
pub mod mesh;
pub mod xml;

pub use build::{load_scene, load_scene_str, LoadedScene};
pub use error::{Location, SceneError};
