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

/// Builds `reps` times on each pool, after one untimed warm-up build (see
/// [`BuildStats::warm_up`]); keeps the last scene built on `pool2`.
pub fn build(
    mesh: &Mesh,
    reps: usize,
    pool1: &rayon::ThreadPool,
    pool2: &rayon::ThreadPool,
) -> Result<(YubinTracer, BuildStats)> {
    let mut stats = BuildStats::default();
    let (builder, _) = prepare(mesh)?;
    let t0 = Instant::now();
    drop(pool1.install(|| builder.build())?);
    stats.warm_up = Some(t0.elapsed());
    let mut kept = None;
    for (pool, times) in [(pool1, 1), (pool2, 2)] {
        for _ in 0..reps {
            let (builder, items) = prepare(mesh)?;
            let counter = Counter::start();
            let t0 = Instant::now();
            let scene = pool.install(|| builder.build())?;
            let dt = t0.elapsed();
            let (retained, peak) = (counter.retained(), counter.peak());
            drop(counter);
            if times == 1 {
                stats.build_1t.push(dt);
            } else {
                stats.build_2t.push(dt);
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
                kept = Some(scene);
            }
        }
    }
    let scene = kept.expect("reps > 0");
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
