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
#[doc(hidden)]
pub mod fuzzing;
pub mod gltf;
pub mod image_io;
pub mod lua;
pub mod mesh;
pub mod ocio;
mod params;
pub mod tonemap;
pub mod volume_io;
pub mod xml;

pub use build::{load_scene, load_scene_str, LoadedScene};
pub use error::{Location, SceneError};

/// Where tests find `../shared` (Mitsuba test data, assets): `$YUBIN_SHARED`
/// or the `shared` directory beside the repository. `rel` is joined to it.
#[cfg(test)]
pub(crate) fn shared_path(rel: &str) -> std::path::PathBuf {
    let root = std::env::var_os("YUBIN_SHARED")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| {
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared")
        });
    root.join(rel)
}
