//! Triangle mesh loaders (OBJ, PLY, Mitsuba serialized) producing plain [`MeshData`].

pub mod obj;
pub mod ply;
pub mod serialized;

pub use yubin_core::shape::MeshData;
