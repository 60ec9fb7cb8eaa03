//! `yubin-bench media`: participating media against Mitsuba 3, and the
//! majorant grid's effect.
//!
//! ```text
//! cargo run --release -p yubin-bench -- media [--spp 64] [--ref-spp 1024] [--reps 3]
//! ```
//!
//! For `scenes/fog.xml` (a chromatic homogeneous medium around the
//! camera, a spot light above it) and `scenes/smoke.xml` (a heterogeneous
//! `.vol` plume, written first if absent), renders each with yubin (in
//! this process) and Mitsuba 3.9.1 `llvm_ad_rgb` (through
//! `scripts/mitsuba-ref`), alternating, `--reps` times, and prints the
//! median time (scene load + render; Mitsuba's Python start excluded), the
//! relMSE against a yubin render at `--ref-spp` (cached in `out/bench/media`;
//! both renderers converge to it, see the Z-tests), and the efficiency
//! ratio (relMSE × time of yubin) / (relMSE × time of Mitsuba): the ratio
//! of times to equal error. Then the plume with its majorant grid and
//! with one majorant for the whole grid, at equal samples.

use crate::cornell::{rel_mse_rgb, repo_root, rgb_image};
use anyhow::{bail, Context, Result};
use std::path::Path;
use std::process::Command;
use std::time::Instant;
use yubin_core::medium::{Majorants, Medium};
use yubin_core::render::{render, RenderSettings};
use yubin_scene::image_io::{read_image, write_image, ColorHandling, Image};

const VARIANT: &str = "llvm_ad_rgb";

pub fn run(args: &[String]) -> Result<()> {
    let (mut spp, mut ref_spp, mut reps) = (64u32, 1024u32, 3usize);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().context("option needs a value");
        match a.as_str() {
            "--spp" => spp = value()?.parse()?,
            "--ref-spp" => ref_spp = value()?.parse()?,
            "--reps" => reps = value()?.parse()?,
            other => bail!("unknown option {other}"),
        }
    }
    let scenes = repo_root().join("scenes");
    let vol = scenes.join("smoke.vol");
    if !vol.exists() {
        crate::smoke::write_smoke(&vol, crate::smoke::RES)?;
    }
    let out = repo_root().join("out/bench/media");
    std::fs::create_dir_all(&out)?;
    println!(
        "{} threads, {spp} spp, reference {ref_spp} spp, median of {reps}\n",
        rayon::current_num_threads()
    );
    println!("| scene | yubin (s) | relMSE | Mitsuba {VARIANT} (s) | relMSE | time ratio | efficiency ratio |");
    println!("|---|---:|---:|---:|---:|---:|---:|");
    for name in ["fog", "smoke"] {
        let scene = scenes.join(format!("{name}.xml"));
        let reference = reference(
            &scene,
            &out.join(format!("{name}-ref-{ref_spp}.exr")),
            ref_spp,
        )?;
        let (mut ty, mut tm) = (Vec::new(), Vec::new());
        let (mut ey, mut em) = (0.0, 0.0);
        for _ in 0..reps {
            let (t, img) = yubin(&scene, spp, false)?;
            ty.push(t);
            ey = rel_mse(&img, &reference);
            let (t, img) = mitsuba(&scene, spp, &out.join(format!("{name}-mitsuba.exr")))?;
            tm.push(t);
            em = rel_mse(&img, &reference);
        }
        let (ty, tm) = (median(ty), median(tm));
        println!(
            "| {name} | {ty:.2} | {ey:.5} | {tm:.2} | {em:.5} | {:.2} | {:.3} |",
            ty / tm,
            (ey * ty) / (em * tm)
        );
    }
    let scene = scenes.join("smoke.xml");
    let reference = read_image(
        &out.join(format!("smoke-ref-{ref_spp}.exr")),
        ColorHandling::Raw,
    )?;
    println!("\nsmoke.xml, yubin at {spp} spp\n");
    println!("| majorants | time (s) | relMSE |");
    println!("|---|---:|---:|");
    for (label, single) in [
        ("majorant grid (4³ voxels per cell)", false),
        ("one for the grid", true),
    ] {
        let mut times = Vec::new();
        let mut err = 0.0;
        for _ in 0..reps {
            let (t, img) = yubin(&scene, spp, single)?;
            times.push(t);
            err = rel_mse(&img, &reference);
        }
        println!("| {label} | {:.2} | {err:.5} |", median(times));
    }
    Ok(())
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn rel_mse(a: &Image, b: &Image) -> f64 {
    rel_mse_rgb(&a.data, a.channels, &b.data, b.channels)
}

/// The cached reference, rendered by yubin at `spp` when absent.
fn reference(scene: &Path, path: &Path, spp: u32) -> Result<Image> {
    if !path.exists() {
        eprintln!("rendering the reference {} ...", path.display());
        let (_, img) = yubin(scene, spp, false)?;
        write_image(path, &img, &[])?;
    }
    Ok(read_image(path, ColorHandling::Raw)?)
}

/// Load + render time and the image; with `single_majorant`, every
/// heterogeneous medium tracks against one majorant for its whole volume.
fn yubin(scene: &Path, spp: u32, single_majorant: bool) -> Result<(f64, Image)> {
    let t = Instant::now();
    let mut loaded = yubin_scene::load_scene(scene, &[])?;
    if single_majorant {
        for m in &mut loaded.scene.media {
            if let Medium::Heterogeneous(h) = m {
                h.majorants = Majorants::Uniform {
                    value: h.sigma_t.max() * h.common.scale,
                    extent: h.sigma_t.extent(),
                };
            }
        }
    }
    let out = render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &RenderSettings { spp, seed: 0 },
        &|_| {},
    );
    Ok((t.elapsed().as_secs_f64(), rgb_image(&out.image)))
}

/// Mitsuba's load + render time (as its script reports them) and image.
fn mitsuba(scene: &Path, spp: u32, path: &Path) -> Result<(f64, Image)> {
    let output = Command::new(repo_root().join("scripts/mitsuba-ref"))
        .args(["render", &scene.to_string_lossy(), "--variant", VARIANT])
        .args(["--spp", &spp.to_string(), "-o", &path.to_string_lossy()])
        .output()
        .context("cannot run scripts/mitsuba-ref")?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    if !output.status.success() {
        bail!(
            "Mitsuba failed on {}: {stdout}{}",
            scene.display(),
            String::from_utf8_lossy(&output.stderr)
        );
    }
    let seconds = |key: &str| -> Result<f64> {
        let line = stdout
            .lines()
            .find(|l| l.starts_with(key))
            .with_context(|| format!("no \"{key}\" in Mitsuba's output"))?;
        Ok(line[key.len()..]
            .trim()
            .trim_end_matches('s')
            .trim()
            .parse()?)
    };
    let t = seconds("load time:")? + seconds("render time:")?;
    Ok((t, read_image(path, ColorHandling::Raw)?))
}
