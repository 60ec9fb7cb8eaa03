//! Ray acceleration. The rest of the renderer sees only [`Bvh`]'s three
//! operations — build over primitive bounds, closest hit, any hit — with
//! the primitive test supplied by the caller as a closure, so the
//! structure can be replaced without touching shapes or integrators.
//!
//! `bvh.rs` holds the node layout and the [`Bvh`] struct, `build.rs` the
//! SAH build and the leaf order, `traverse.rs` the SIMD box tests and the
//! traversal loops; `huge_array.rs` the node storage.

mod build;
mod bvh;
mod huge_array;
mod traverse;

pub use build::PrimCost;
pub(crate) use bvh::Node;
pub use bvh::{Bvh, BvhStats, MAX_LEAF, MAX_POSITIONS};
pub use huge_array::{huge_array_bytes, HugeArray};
#[cfg(target_arch = "x86_64")]
pub(crate) use traverse::{hit_child_avx2, hit_children_avx2};
pub(crate) use traverse::{PacketLanes, RayLanes};
pub use traverse::{PACKET_NODES, PACKET_RAYS};
