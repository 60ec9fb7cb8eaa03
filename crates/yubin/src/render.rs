//! `yubin render`.

use crate::output::write_output;
use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;
use yubin_core::render::{render, RenderSettings};
use yubin_scene::{load_scene, load_scene_str, LoadedScene};

/// The built-in demo scene.
const CORNELL_BOX: &str = include_str!("../../../scenes/cornell-box.xml");

/// Arguments of `yubin render`.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// Scene file (Mitsuba 3 XML). Without one, the built-in Cornell box.
    scene: Option<PathBuf>,
    /// Output image: .exr (linear float32, with any extra layers) or .png
    /// (8-bit sRGB). Default: the scene's name with .exr, or
    /// cornell-box.png for the built-in scene.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Samples per pixel (default: the scene's sampler).
    #[arg(long)]
    spp: Option<u32>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Seed of the sample sequence (default: the scene's sampler seed).
    #[arg(long)]
    seed: Option<u32>,
    /// Scene parameter, overriding a <default>: -D spp=64.
    #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = parse_define)]
    define: Vec<(String, String)>,
    /// No progress bar and no summary.
    #[arg(short, long)]
    quiet: bool,
}

fn parse_define(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((k, v)) if !k.trim().is_empty() => Ok((k.trim().to_string(), v.to_string())),
        _ => Err(format!("expected NAME=VALUE, got \"{s}\"")),
    }
}

/// Loads, renders and writes.
pub fn run(args: RenderArgs) -> Result<()> {
    let t0 = Instant::now();
    let (loaded, output) = load(&args)?;
    check_output_format(&output)?;
    for w in &loaded.warnings {
        eprintln!("warning: {w}");
    }
    let load_time = t0.elapsed();
    let spp = args
        .spp
        .unwrap_or_else(|| loaded.scene.sampler.sample_count());
    if spp == 0 {
        bail!("--spp must be at least 1");
    }
    let settings = RenderSettings {
        spp,
        seed: args.seed.unwrap_or(loaded.seed),
    };
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = args.threads {
        if n == 0 {
            bail!("--threads must be at least 1");
        }
        pool = pool.num_threads(n);
    }
    let pool = pool.build().context("cannot start the worker threads")?;
    let film = &loaded.scene.film;
    let total = u64::from(film.crop_size[0]) * u64::from(film.crop_size[1]) * u64::from(spp);
    let bar = progress_bar(total, args.quiet);
    let done = AtomicU64::new(0);
    let t1 = Instant::now();
    let out = pool.install(|| {
        render(&loaded.scene, loaded.integrator.as_ref(), &settings, &|n| {
            let d = done.fetch_add(n, Ordering::Relaxed) + n;
            bar.set_position(d);
        })
    });
    bar.finish_and_clear();
    let render_time = t1.elapsed();
    if out.dropped_samples > 0 {
        eprintln!(
            "warning: {} samples were NaN or infinite and were dropped",
            out.dropped_samples
        );
    }
    write_output(&output, &out).with_context(|| format!("cannot write {}", output.display()))?;
    if !args.quiet {
        eprintln!(
            "{}: {}x{}, {spp} spp in {:.2} s (load {:.2} s, {:.2} M samples/s)",
            output.display(),
            film.crop_size[0],
            film.crop_size[1],
            render_time.as_secs_f64(),
            load_time.as_secs_f64(),
            total as f64 / render_time.as_secs_f64() / 1e6
        );
    }
    Ok(())
}

/// Fails before rendering, not after, when the output can't be written
/// in the format its extension names.
fn check_output_format(path: &Path) -> Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("exr" | "png") => Ok(()),
        _ => bail!(
            "{}: unsupported output format (supported extensions: .exr, .png)",
            path.display()
        ),
    }
}

fn load(args: &RenderArgs) -> Result<(LoadedScene, PathBuf)> {
    match &args.scene {
        Some(path) => {
            let loaded = load_scene(path, &args.define)?;
            let default_out = Path::new(path.file_stem().unwrap_or_default()).with_extension("exr");
            Ok((loaded, args.output.clone().unwrap_or(default_out)))
        }
        None => {
            let loaded = load_scene_str(
                CORNELL_BOX,
                Path::new("<built-in>/cornell-box.xml"),
                &args.define,
            )?;
            Ok((
                loaded,
                args.output
                    .clone()
                    .unwrap_or_else(|| PathBuf::from("cornell-box.png")),
            ))
        }
    }
}

fn progress_bar(total: u64, quiet: bool) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::hidden());
    }
    let bar = ProgressBar::new(total);
    let style = ProgressStyle::with_template(
        "{bar:40} {percent:>3}%  {per_sec:>14}  elapsed {elapsed_precise}  ETA {eta_precise}",
    )
    .unwrap_or_else(|_| ProgressStyle::default_bar());
    bar.set_style(style.progress_chars("=> "));
    bar
}
