//! `yubin-bench adaptive`: adaptive sampling against uniform sampling at
//! equal total samples.
//!
//! ```text
//! cargo run --release -p yubin-bench -- adaptive [--ref-spp 4096] [--max-spp 1024]
//! ```
//!
//! On `scenes/caustic.xml` (a caustic beside evenly lit surfaces), for
//! each threshold, renders with adaptive sampling (at most `--max-spp`
//! per pixel, at least 16), then uniformly with the same total number of
//! samples, and prints both relMSEs against a uniform render at
//! `--ref-spp` (cached in `out/bench/adaptive`) and their ratio.

use crate::cornell::{rel_mse_rgb, repo_root, rgb_image};
use anyhow::{bail, Context, Result};
use std::time::Instant;
use yubin_core::render::{Adaptive, Progressive, RenderSettings};
use yubin_scene::image_io::{read_image, write_image, ColorHandling, Image};

pub fn run(args: &[String]) -> Result<()> {
    let (mut ref_spp, mut max_spp) = (4096u32, 1024u32);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().context("option needs a value");
        match a.as_str() {
            "--ref-spp" => ref_spp = value()?.parse()?,
            "--max-spp" => max_spp = value()?.parse()?,
            other => bail!("unknown option {other}"),
        }
    }
    let scene_path = repo_root().join("scenes/caustic.xml");
    let loaded = yubin_scene::load_scene(&scene_path, &[])?;
    let out = repo_root().join("out/bench/adaptive");
    std::fs::create_dir_all(&out)?;
    let ref_path = out.join(format!("caustic-ref-{ref_spp}.exr"));
    if !ref_path.exists() {
        eprintln!("rendering the reference at {ref_spp} spp ...");
        write_image(&ref_path, &render(&loaded, ref_spp, None).0, &[])?;
    }
    let reference = read_image(&ref_path, ColorHandling::Raw)?;
    let pixels = (reference.width * reference.height) as f64;
    println!(
        "scenes/caustic.xml, {} threads, at most {max_spp} spp, reference {ref_spp} spp\n",
        rayon::current_num_threads()
    );
    println!("| threshold | mean spp | adaptive relMSE | uniform relMSE (same samples) | uniform / adaptive | adaptive time (s) | uniform time (s) |");
    println!("|---:|---:|---:|---:|---:|---:|---:|");
    for threshold in [0.1f32, 0.05, 0.03] {
        let adaptive = Adaptive {
            threshold,
            min_spp: 16,
        };
        let t = Instant::now();
        let (img, samples) = render(&loaded, max_spp, Some(adaptive));
        let ta = t.elapsed().as_secs_f64();
        let mean_spp = samples as f64 / pixels;
        let t = Instant::now();
        let (uniform, _) = render(&loaded, mean_spp.round().max(1.0) as u32, None);
        let tu = t.elapsed().as_secs_f64();
        let ea = rel_mse_rgb(&img.data, img.channels, &reference.data, reference.channels);
        let eu = rel_mse_rgb(
            &uniform.data,
            uniform.channels,
            &reference.data,
            reference.channels,
        );
        println!(
            "| {threshold} | {mean_spp:.1} | {ea:.5} | {eu:.5} | {:.2}× | {ta:.2} | {tu:.2} |",
            eu / ea
        );
    }
    Ok(())
}

/// A render, adaptive (in passes of one sample) or uniform (one pass);
/// its RGB and the samples taken.
fn render(loaded: &yubin_scene::LoadedScene, spp: u32, adaptive: Option<Adaptive>) -> (Image, u64) {
    let settings = RenderSettings { spp, seed: 0 };
    let (scene, integrator) = (&loaded.scene, loaded.integrator.as_ref());
    let mut passes = match adaptive {
        Some(a) => Progressive::new(scene, integrator, settings, 1).with_adaptive(a),
        None => Progressive::new(scene, integrator, settings, spp),
    };
    while !passes.finished() {
        passes.pass(&|_| {});
    }
    (rgb_image(&passes.output().image), passes.total_samples())
}
