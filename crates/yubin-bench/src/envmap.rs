//! `yubin-bench envmap`: time to build an `envmap`'s sampling
//! distribution (luminance, patch weights, the 2D table) for a
//! 4096 × 2048 float map, median of `--reps` builds.
//!
//! ```text
//! cargo run --release -p yubin-bench -- envmap [--reps 7]
//! ```

use anyhow::{bail, Context, Result};
use glam::Mat3;
use std::time::Instant;
use yubin_core::light::EnvMapLight;
use yubin_core::texture::image::ImageData;
use yubin_core::texture::TexImage;

pub fn run(args: &[String]) -> Result<()> {
    let mut reps = 7usize;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--reps" => reps = it.next().context("--reps needs a value")?.parse()?,
            other => bail!("unknown option {other}"),
        }
    }
    let (w, h) = (4096u32, 2048u32);
    // A sky-like map with a bright sun and texture everywhere, so that no
    // row or column is trivially uniform.
    let data: Vec<f32> = (0..(w * h) as usize)
        .flat_map(|i| {
            let (x, y) = ((i % w as usize) as f32, (i / w as usize) as f32);
            let v = 0.5 + 0.4 * (x * 0.013).sin() * (y * 0.021).cos();
            let sun = if (x - 1200.0).hypot(y - 500.0) < 8.0 {
                5e4
            } else {
                0.0
            };
            [v + sun, v * 0.8 + sun, v * 0.6 + sun]
        })
        .collect();
    let img = TexImage::new(w, h, 3, ImageData::F32(data), false).context("image")?;
    let light = EnvMapLight::new(0, 1.0, Mat3::IDENTITY, Some(false));
    let mut times = Vec::new();
    for _ in 0..reps.max(1) {
        let start = Instant::now();
        let dist = light.sampling_distribution(&img);
        times.push(start.elapsed().as_secs_f64() * 1e3);
        std::hint::black_box(dist);
    }
    times.sort_by(f64::total_cmp);
    println!(
        "envmap distribution build, {w}×{h}: median {:.1} ms (min {:.1}, max {:.1}) over {} builds, {} threads",
        times[times.len() / 2],
        times[0],
        times[times.len() - 1],
        times.len(),
        rayon::current_num_threads()
    );
    Ok(())
}
