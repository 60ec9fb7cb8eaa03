//! `yubin-bench samplers`: each sampler's cost per sample: the time to
//! draw a pixel sample's first 30 dimensions (as renders draw them: a 2D
//! pair then a 1D value, ten times) for every sample of a 256 × 256 image
//! at 16 spp, on one thread, median of `--reps` runs; and the Cornell box
//! (`scenes/cornell-box.xml`, 256 × 256, 16 spp) rendered with each, so
//! the sampler's share of a render shows.
//!
//! ```text
//! cargo run --release -p yubin-bench -- samplers [--reps 5]
//! ```

use anyhow::{bail, Context, Result};
use std::path::Path;
use std::time::Instant;
use yubin_core::render::{render, RenderSettings};
use yubin_scene::{load_scene, load_scene_str};

pub fn run(args: &[String]) -> Result<()> {
    let mut reps = 5usize;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--reps" => reps = it.next().context("--reps needs a value")?.parse()?,
            other => bail!("unknown option {other}"),
        }
    }
    let cornell = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cornell-box.xml");
    let defines = [("resx", "256"), ("resy", "256"), ("spp", "16")]
        .map(|(k, v)| (k.to_string(), v.to_string()));
    println!(
        "| sampler | ns per sample (30 dimensions) | ns per dimension | Cornell box render (s) |"
    );
    println!("|---|---:|---:|---:|");
    for (kind, _) in yubin_core::sampler::PLUGINS {
        let xml = format!(
            r#"<scene version="3.0.0"><sensor type="perspective"><sampler type="{kind}">
                 <integer name="sample_count" value="16"/></sampler></sensor></scene>"#
        );
        let sampler = load_scene_str(&xml, Path::new("sampler.xml"), &[])?
            .scene
            .sampler;
        let mut draw = Vec::new();
        for _ in 0..reps.max(1) {
            let start = Instant::now();
            let mut acc = 0.0f32;
            for y in 0..256 {
                for x in 0..256 {
                    for i in 0..16 {
                        let mut st = sampler.stream(x, y, i, 1);
                        for _ in 0..10 {
                            let v = st.next_2d();
                            acc += v.x + v.y + st.next_1d();
                        }
                    }
                }
            }
            std::hint::black_box(acc);
            draw.push(start.elapsed().as_secs_f64() * 1e9 / (256.0 * 256.0 * 16.0));
        }
        draw.sort_by(f64::total_cmp);
        let ns = draw[draw.len() / 2];
        let mut loaded = load_scene(&cornell, &defines)?;
        loaded.scene.sampler = sampler;
        let mut renders = Vec::new();
        for _ in 0..reps.max(1) {
            let start = Instant::now();
            let out = render(
                &loaded.scene,
                loaded.integrator.as_ref(),
                &RenderSettings { spp: 16, seed: 0 },
                &|_| {},
            );
            renders.push(start.elapsed().as_secs_f64());
            std::hint::black_box(out);
        }
        renders.sort_by(f64::total_cmp);
        println!(
            "| `{kind}` | {ns:.0} | {:.1} | {:.2} |",
            ns / 30.0,
            renders[renders.len() / 2]
        );
    }
    Ok(())
}
