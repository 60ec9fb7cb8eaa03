//! The yubin renderer core: shapes, acceleration, BSDFs, emitters, cameras,
//! samplers, filters, film and integrators. No file formats and no I/O live
//! here; `yubin-scene` turns scene files into a [`Scene`].
//!
//! Everything called per ray or per sample is a closed enum dispatched by
//! `match` (see `ARCHITECTURE.md`); scene-owned arrays hold the heavy data
//! and variants refer to them by index.
#![warn(missing_docs)]

pub mod accel;
pub mod bsdf;
pub mod camera;
pub mod film;
pub mod filter;
pub mod integrator;
pub mod interaction;
pub mod light;
pub mod limits;
pub mod material;
pub mod math;
pub mod medium;
pub mod params;
pub mod phase;
pub mod render;
pub mod sampler;
pub mod sampling;
pub mod scene;
pub mod shape;
pub mod spectrum;
pub mod testing;
pub mod texture;
pub mod volume;

pub use glam::{Affine3A, Mat3, Mat4, Vec2, Vec3, Vec3A};
pub use scene::{Scene, SceneBuilder, ShapeEmitter};
pub use spectrum::Rgb;

/// The README's code blocks, compiled and run by `cargo test --doc` so
/// that its library example (a copy of `examples/01_build_a_scene.rs`)
/// cannot go stale. Blocks that are not Rust name their language.
#[cfg(doctest)]
#[doc = include_str!("../../../README.md")]
pub struct ReadmeDoctests;
