//! `yubin-bench sdf`: the cost of ray marching on a scene's `sdf` and
//! `mandelbox` shapes. One camera ray per pixel (through its centre) is
//! marched through each ray-marched shape whose box it enters (shapes in
//! another world, behind a portal, are listed with no marches), with the
//! file's `step_factor` and again with every step factor set to 1:
//! distance evaluations per ray, marches per second on one thread, and
//! how many marches ended at the step limit, and (at step factor 1) how
//! many rays hit elsewhere than with the file's step factor (a miss, a
//! new hit, or a hit more than 0.1 % of its distance away): what the
//! smaller step buys.
//!
//! ```text
//! cargo run --release -p yubin-bench -- sdf [--scene scenes/implicit/sculpture.xml] [-D name=value]...
//! ```

use anyhow::{bail, Context, Result};
use glam::Vec2;
use std::path::PathBuf;
use std::time::Instant;
use yubin_core::shape::{sdf::March, SdfShape, Shape};

pub fn run(args: &[String]) -> Result<()> {
    let mut scene = PathBuf::from("scenes/implicit/sculpture.xml");
    let mut defines = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--scene" => scene = it.next().context("--scene needs a path")?.into(),
            "-D" => {
                let d = it.next().context("-D needs name=value")?;
                let (k, v) = d.split_once('=').context("-D needs name=value")?;
                defines.push((k.to_string(), v.to_string()));
            }
            other => bail!("unknown option {other}"),
        }
    }
    let loaded = yubin_scene::load_scene(&scene, &defines).map_err(|e| anyhow::anyhow!("{e}"))?;
    let s = &loaded.scene;
    let shapes: Vec<SdfShape> = s
        .shapes
        .iter()
        .filter_map(|sh| match sh {
            Shape::Sdf(m) => Some(*m),
            _ => None,
        })
        .collect();
    if shapes.is_empty() {
        bail!("{}: no sdf or mandelbox shape", scene.display());
    }
    let (w, h) = (s.film.width, s.film.height);
    let rays: Vec<_> = (0..h)
        .flat_map(|y| (0..w).map(move |x| Vec2::new(x as f32 + 0.5, y as f32 + 0.5)))
        .filter_map(|p| s.camera.generate_ray(p, Vec2::splat(0.5)))
        .collect();
    println!(
        "{}: {w}×{h} camera rays, {} ray-marched shapes, one thread",
        scene.display(),
        shapes.len()
    );
    println!("| shape | step factor | marches | evaluations per march | max steps reached | hits moved | marches/s |");
    println!("|---|---|---|---|---|---|---|");
    for (i, shape) in shapes.iter().enumerate() {
        let mut first: Vec<Option<f32>> = Vec::new();
        for step in [shape.step_factor, 1.0] {
            let sh = SdfShape {
                step_factor: step,
                ..*shape
            };
            let start = Instant::now();
            let (mut marches, mut steps, mut capped) = (0u64, 0u64, 0u64);
            let mut hits = Vec::with_capacity(rays.len());
            for r in &rays {
                let March { t, steps: n } = sh.march(r);
                if n > 0 {
                    marches += 1;
                    steps += u64::from(n);
                    capped += u64::from(t.is_none() && n == sh.max_steps);
                }
                hits.push(t);
            }
            let secs = start.elapsed().as_secs_f64();
            if marches == 0 {
                // In another world (behind a portal) or out of view.
                println!("| {i} | — | 0 | — | — | — | — |");
                break;
            }
            let moved = if first.is_empty() {
                "—".to_string()
            } else {
                let moved = first.iter().zip(&hits).filter(|(a, b)| match (a, b) {
                    (Some(a), Some(b)) => (a - b).abs() > 1e-3 * a,
                    (None, None) => false,
                    _ => true,
                });
                moved.count().to_string()
            };
            println!(
                "| {i} | {step} | {marches} | {:.1} | {capped} | {moved} | {:.2} M |",
                steps as f64 / marches.max(1) as f64,
                marches as f64 / secs / 1e6
            );
            if step == 1.0 {
                break;
            }
            first = hits;
        }
    }
    Ok(())
}
