//! yubin's side: one mesh shape in a [`yubin_core::Scene`], traced with
//! [`Scene::intersect_distance`] (closest hit) and [`Scene::occluded`]
//! (any hit).
//!
//! Build time is the wall time of [`SceneBuilder::build`], which builds
//! the BVH over the primitives' bounds. Memory is measured with the
//! counting allocator: what `add_shape` (the scene's per-primitive item
//! list) and `build` (the BVH, heap and huge-page mappings) keep, beyond
//! the input mesh.

use super::mesh::Mesh;
use super::raygen::BenchRay;
use super::{BuildStats, Hit, Tracer};
use crate::alloc::Counter;
use anyhow::Result;
use std::time::Instant;
use yubin_core::math::Ray;
use yubin_core::shape::{MeshShape, Shape, TriangleMesh};
use yubin_core::{Scene, SceneBuilder, Vec3};

/// A built yubin scene.
#[derive(Debug)]
pub struct YubinTracer {
    scene: Scene,
}

/// A builder holding the mesh, ready for the timed `build` call, and the
/// bytes its shape's item list took.
fn prepare(mesh: &Mesh) -> Result<(SceneBuilder, isize)> {
    let positions = mesh
        .positions
        .iter()
        .map(|&p| Vec3::from_array(p))
        .collect();
    // face_normals = true: flat shading, so no vertex normals are computed.
    let tri = TriangleMesh::new(positions, vec![], vec![], mesh.indices.clone(), true, false)?;
    let mut builder = SceneBuilder::new();
    let id = builder.add_mesh(tri);
    let counter = Counter::start();
    builder.add_shape(Shape::Mesh(MeshShape { mesh: id }), None, None)?;
    let items = counter.retained();
    Ok((builder, items))
}

/// Builds `reps` times on each pool, after one untimed warm-up build on
/// each (see [`BuildStats::warm_up`]), then once more on `pool2`,
/// untimed, with the counting allocator on for the memory figures; keeps
/// that scene.
///
/// The timed builds run with counting off: while on, every allocation
/// updates shared atomics, and two threads allocating the binary tree's
/// nodes at once made the 2-thread builds contend for their cache line,
/// which would time the counter rather than the build. Embree's
/// allocations never pass through it (its bytes come from the device's
/// memory monitor, a call per allocated block).
pub fn build(
    mesh: &Mesh,
    reps: usize,
    pool1: &rayon::ThreadPool,
    pool2: &rayon::ThreadPool,
) -> Result<(YubinTracer, BuildStats)> {
    let mut stats = BuildStats::default();
    let timed_build = |pool: &rayon::ThreadPool| -> Result<std::time::Duration> {
        let (builder, _) = prepare(mesh)?;
        let t0 = Instant::now();
        let scene = pool.install(|| builder.build())?;
        let dt = t0.elapsed();
        drop(scene);
        Ok(dt)
    };
    stats.warm_up = Some(timed_build(pool1)?);
    for _ in 0..reps {
        stats.build_1t.push(timed_build(pool1)?);
    }
    timed_build(pool2)?;
    for _ in 0..reps {
        stats.build_2t.push(timed_build(pool2)?);
    }
    let (builder, items) = prepare(mesh)?;
    let counter = Counter::start();
    let scene = pool2.install(|| builder.build())?;
    let (retained, peak) = (counter.retained(), counter.peak());
    drop(counter);
    stats.accel_bytes = Some((retained + items).max(0) as usize);
    stats.peak_build_bytes = Some(peak.max(0) as usize);
    let shape = scene.bvh_stats();
    stats.note = format!(
        "BVH {:.1} MiB (retained by `build`) + item list {:.1} MiB (retained by `add_shape`); \
         {} nodes ({:.2} children each, histogram {:?}), {} leaves ({:.2} triangles each); \
         SAH: nodes {:.3}, leaves {:.3} (expected visits per ray through the root box); \
         depth {} (area-weighted mean over leaves {:.2})",
        super::mib(retained.max(0) as usize),
        super::mib(items.max(0) as usize),
        shape.nodes,
        shape.child_slots as f64 / shape.nodes.max(1) as f64,
        shape.children_histogram,
        shape.leaves,
        shape.leaf_prims as f64 / shape.leaves.max(1) as f64,
        shape.node_sah,
        shape.leaf_sah,
        shape.depth,
        shape.leaf_depth,
    );
    Ok((YubinTracer { scene }, stats))
}

#[inline]
fn to_ray(r: &BenchRay) -> Ray {
    Ray {
        o: Vec3::from_array(r.o),
        d: Vec3::from_array(r.d),
        t_min: 0.0,
        t_max: f32::INFINITY,
    }
}

impl Tracer for YubinTracer {
    fn closest(&self, rays: &[BenchRay], out: &mut [Hit], _coherent: bool) {
        for (r, o) in rays.iter().zip(out) {
            *o = match self.scene.intersect_distance(&to_ray(r)) {
                Some((t, _shape, prim)) => Hit { t, prim },
                None => Hit::MISS,
            };
        }
    }

    fn occluded(&self, rays: &[BenchRay], out: &mut [bool], _coherent: bool) {
        for (r, o) in rays.iter().zip(out) {
            *o = self.scene.occluded(&to_ray(r));
        }
    }
}
