//! `yubin-bench`: benchmarks and peer comparisons.
//!
//! ```text
//! cargo run --profile dist -p yubin-bench -- cornell [--spp 256] [--scene PATH] [--skip-mitsuba]
//! cargo run --release -p yubin-bench -- manylights [--spp 16] [--ref-spp 1024]
//! cargo build --release -p yubin-bench --features embree
//! ./target/release/yubin-bench rays [--mesh cubesphere-92|cubesphere-289|dragon|all] [--no-embree]
//! ```
//!
//! - [`cornell`]: whole renders against Mitsuba 3 (wall time and error).
//! - [`manylights`]: uniform, power and light-BVH light selection on
//!   10,000 emissive triangles (equal-time error).
//! - [`samplers`]: each sampler's cost per sample, and a render with each.
//! - [`media`]: a homogeneous and a heterogeneous medium against Mitsuba 3
//!   (time to equal error), and the majorant grid's effect.
//! - [`adaptive`]: adaptive against uniform sampling at equal samples.
//! - [`suite`]: time to equal error against Mitsuba 3 on a suite of
//!   scenes, with load time and peak memory.
//! - [`smoke`]: writes the procedural smoke plume grid of `scenes/smoke.xml`.
//! - [`sdf`]: ray-marching cost (evaluations per ray, marches per second)
//!   of a scene's `sdf` and `mandelbox` shapes, with and without their
//!   step factors.
//! - [`farm`]: the CPU time of a render split into parts against one
//!   render, and the time to merge 8 parts of a 4K image.
//! - [`envmap`]: time to build a 4096 × 2048 environment map's sampling
//!   distribution.
//! - [`rays`]: ray-traversal throughput, build time and memory of yubin's
//!   BVH against Intel Embree in the same process, on the meshes and rays
//!   of `../shared/tools/raybench` (issue 3). Run `setup.sh` first.

mod adaptive;
mod alloc;
mod cornell;
mod envmap;
mod farm;
mod manylights;
mod media;
mod rays;
mod samplers;
mod sdf;
mod smoke;
mod suite;

use anyhow::{bail, Result};

/// Counts heap bytes while switched on, for the `rays` memory figures;
/// otherwise it is the system allocator plus one relaxed load.
#[global_allocator]
static ALLOC: alloc::CountingAlloc = alloc::CountingAlloc;

const USAGE: &str = "usage:
  yubin-bench cornell [--spp N] [--scene PATH] [--skip-mitsuba]
  yubin-bench manylights [--spp N] [--ref-spp N] [--res N]
  yubin-bench envmap [--reps N]
  yubin-bench sdf [--scene PATH] [-D name=value]...
  yubin-bench samplers [--reps N]
  yubin-bench smoke-vol PATH [--res X,Y,Z]
  yubin-bench media [--spp N] [--ref-spp N] [--reps N]
  yubin-bench adaptive [--ref-spp N] [--max-spp N]
  yubin-bench suite [--spp N] [--ref-spp N] [--reps N] [--scenes a,b] [--variants v,w] [-D name=value]...
  yubin-bench farm [--scene PATH] [--spp N] [--parts 2,4,8] [--merge-res WxH] [--merge-only]
  yubin-bench rays [--mesh cubesphere-92|cubesphere-289|dragon|all] [--no-embree]
                   [--wait-quiet X] [--width N] [--incoherent N] [--build-reps N]
                   [--min-passes N] [--max-passes N] [--out FILE.md]
  environment: YUBIN_EMBREE_VERBOSE=2 prints Embree's BVH statistics,
               YUBIN_EMBREE_ISA=avx2 limits Embree's instruction set";

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.iter().any(|a| a == "-h" || a == "--help") {
        println!("{USAGE}");
        return Ok(());
    }
    match args.first().map(String::as_str) {
        Some("cornell") => cornell::run(&args[1..]),
        Some("rays") => rays::run(&args[1..]),
        Some("manylights") => manylights::run(&args[1..]),
        Some("envmap") => envmap::run(&args[1..]),
        Some("sdf") => sdf::run(&args[1..]),
        Some("samplers") => samplers::run(&args[1..]),
        Some("smoke-vol") => smoke::run(&args[1..]),
        Some("media") => media::run(&args[1..]),
        Some("adaptive") => adaptive::run(&args[1..]),
        Some("suite") => suite::run(&args[1..]),
        Some("farm") => farm::run(&args[1..]),
        Some("help") => {
            println!("{USAGE}");
            Ok(())
        }
        _ => bail!("{USAGE}"),
    }
}
