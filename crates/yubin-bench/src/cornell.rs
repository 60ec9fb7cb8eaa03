//! `yubin-bench cornell`: yubin against Mitsuba 3 on a scene file.
//!
//! ```text
//! cargo run --profile dist -p yubin-bench -- cornell [--spp 256] [--scene PATH]
//!     [--ref PATH] [--variants scalar_rgb,llvm_ad_rgb] [--skip-mitsuba]
//! ```
//!
//! Renders a scene (default: the Bitterli Cornell box from
//! `../shared/assets`) with yubin in this process and with Mitsuba 3.9.1
//! (`scalar_rgb` and `llvm_ad_rgb`, through `scripts/mitsuba-ref`) one after
//! the other on the same machine, and prints a markdown table of wall
//! times (scene load + render) and their ratios to yubin, plus each
//! image's relMSE against a reference: `--ref`, else the one beside the
//! scene (`TungstenRender.exr`) when there is one. `--variants` picks the
//! Mitsuba variants.

use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;
use yubin_core::render::{render, RenderSettings};
use yubin_scene::image_io::{read_image, write_image, ColorHandling, Image};

struct Row {
    name: String,
    wall: f64,
    rel_mse: Option<f64>,
}

pub(crate) fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

pub fn run(args: &[String]) -> Result<()> {
    let mut spp = 256u32;
    let mut scene = repo_root().join("../shared/assets/cornell-box-bitterli/scene_v3.xml");
    let mut skip_mitsuba = false;
    let mut reference_path = None;
    let mut variants = vec!["scalar_rgb".to_string(), "llvm_ad_rgb".to_string()];
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--spp" => spp = it.next().context("--spp needs a value")?.parse()?,
            "--scene" => scene = PathBuf::from(it.next().context("--scene needs a value")?),
            "--skip-mitsuba" => skip_mitsuba = true,
            "--ref" => {
                reference_path = Some(PathBuf::from(it.next().context("--ref needs a value")?))
            }
            "--variants" => {
                let list = it.next().context("--variants needs a value")?;
                variants = list.split(',').map(str::to_string).collect();
            }
            other => bail!("unknown option {other}"),
        }
    }
    let reference = reference_path.unwrap_or_else(|| scene.with_file_name("TungstenRender.exr"));
    let reference = reference
        .exists()
        .then(|| read_image(&reference, ColorHandling::Raw))
        .transpose()?;
    let out_dir = repo_root().join("out/bench");
    std::fs::create_dir_all(&out_dir)?;
    let mut rows = Vec::new();

    let t = Instant::now();
    let loaded = yubin_scene::load_scene(&scene, &[])?;
    let out = render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &RenderSettings { spp, seed: 0 },
        &|_| {},
    );
    let wall = t.elapsed().as_secs_f64();
    let img = rgb_image(&out.image);
    write_image(&out_dir.join("yubin.exr"), &img, &[])?;
    rows.push(Row {
        name: "yubin".into(),
        wall,
        rel_mse: reference.as_ref().map(|r| rel_mse(&img, r)),
    });
    eprintln!("yubin: {wall:.1} s");

    if !skip_mitsuba {
        for variant in variants.iter().map(String::as_str) {
            let path = out_dir.join(format!("mitsuba_{variant}.exr"));
            let t = Instant::now();
            let status = Command::new(repo_root().join("scripts/mitsuba-ref"))
                .args([
                    "render",
                    &scene.to_string_lossy(),
                    "--strip-legacy",
                    "--variant",
                    variant,
                    "--spp",
                    &spp.to_string(),
                    "-o",
                    &path.to_string_lossy(),
                ])
                .status()
                .context("cannot run scripts/mitsuba-ref")?;
            let wall = t.elapsed().as_secs_f64();
            if !status.success() {
                bail!("Mitsuba {variant} failed");
            }
            let img = read_image(&path, ColorHandling::Raw)?;
            rows.push(Row {
                name: format!("Mitsuba 3.9.1 {variant}"),
                wall,
                rel_mse: reference.as_ref().map(|r| rel_mse(&img, r)),
            });
            eprintln!("{variant}: {wall:.1} s");
        }
    }
    print_table(&rows, spp, &scene);
    Ok(())
}

/// The RGB channels of a rendered framebuffer as an image.
pub(crate) fn rgb_image(fb: &yubin_core::film::Framebuffer) -> Image {
    let rgb = fb.select_channels(0..3);
    Image {
        width: rgb.width as usize,
        height: rgb.height as usize,
        channels: 3,
        data: rgb.data,
    }
}

fn rel_mse(a: &Image, b: &Image) -> f64 {
    rel_mse_rgb(&a.data, a.channels, &b.data, b.channels)
}

/// relMSE of the RGB of image `a` against `b` (pixels interleaved,
/// `a_channels` / `b_channels` values each): the mean over pixels and
/// channels of (a − b)² / (b² + 0.01).
pub(crate) fn rel_mse_rgb(a: &[f32], a_channels: usize, b: &[f32], b_channels: usize) -> f64 {
    let n = b.len() / b_channels;
    let mut sum = 0.0;
    for i in 0..n {
        for c in 0..3 {
            let (x, y) = (a[i * a_channels + c] as f64, b[i * b_channels + c] as f64);
            sum += (x - y) * (x - y) / (y * y + 0.01);
        }
    }
    sum / (3 * n) as f64
}

fn print_table(rows: &[Row], spp: u32, scene: &Path) {
    println!(
        "{} at {spp} spp, {} threads\n",
        scene.display(),
        rayon::current_num_threads()
    );
    println!("| renderer | wall time (s) | time / yubin's | relMSE vs reference |");
    println!("|---|---:|---:|---:|");
    let base = rows[0].wall;
    for r in rows {
        let rel = r.rel_mse.map_or("–".to_string(), |v| format!("{v:.6}"));
        println!(
            "| {} | {:.1} | {:.2}× | {rel} |",
            r.name,
            r.wall,
            r.wall / base
        );
    }
}
