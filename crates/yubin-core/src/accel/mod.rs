//! Ray acceleration. The rest of the renderer sees only [`Bvh`]'s three
//! operations — build over primitive bounds, closest hit, any hit — with
//! the primitive test supplied by the caller as a closure, so the
//! structure can be replaced without touching shapes or integrators.

mod bvh;
mod huge_array;

#[cfg(target_arch = "x86_64")]
pub(crate) use bvh::{hit_child_avx2, hit_children_avx2};
pub use bvh::{Bvh, BvhStats, PrimCost, MAX_LEAF, MAX_POSITIONS, PACKET_NODES, PACKET_RAYS};
pub(crate) use bvh::{Node, PacketLanes, RayLanes};
pub use huge_array::{huge_array_bytes, HugeArray};
