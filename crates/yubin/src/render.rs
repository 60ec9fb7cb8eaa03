//! `yubin render`.

use crate::checkpoint;
use crate::denoise;
use crate::interrupt::Interrupt;
use crate::output::{write_output, Display, DisplayArgs};
use crate::part::{self, PartHeader};
use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};
use yubin_core::filter::Filter;
use yubin_core::integrator::{DenoiserGuides, Guide, PathIntegrator};
use yubin_core::limits::{self, Limit};
use yubin_core::render::{
    render_until, Adaptive, NonFiniteSample, Part, PassSize, Progressive, RenderOutput,
    RenderSettings,
};
use yubin_scene::tonemap::View;
use yubin_scene::{load_scene, load_scene_str, LoadedScene};

mod animate;

/// The built-in demo scene.
const CORNELL_BOX: &str = include_str!("../../../scenes/cornell-box.xml");

/// Arguments of `yubin render`.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// Scene file: Mitsuba 3 XML, glTF 2.0 (.gltf, .glb) or a Lua script
    /// (.lua). Without one, the built-in Cornell box.
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
    /// glTF scenes: an environment map (lat-long EXR/HDR/PNG) lighting the
    /// model (default: the file's lights, else a white environment).
    #[arg(long, value_name = "HDRI")]
    env: Option<PathBuf>,
    /// Lua scenes: let the script read files outside its own directory.
    #[arg(long)]
    allow_read: bool,
    /// Lua scenes: render the frames A-B (or one frame N) of the script's
    /// animation; `#` in the output (`out/frame_####.png`) is the frame
    /// number, zero-padded to their count.
    #[arg(long, value_name = "A-B", value_parser = parse_frames)]
    frames: Option<(i64, i64)>,
    /// Frames per second of the animation: the script's `time` is
    /// `frame / fps`.
    #[arg(long, default_value_t = 24.0)]
    fps: f64,
    /// With --frames: stitch the frames into this video with the system's
    /// ffmpeg (H.264 MP4).
    #[arg(long, value_name = "VIDEO")]
    video: Option<PathBuf>,
    /// glTF scenes: image width in pixels (default 1024).
    #[arg(long)]
    width: Option<u32>,
    /// glTF scenes: image height (default: from the width and the camera's
    /// aspect ratio, else 4:3).
    #[arg(long)]
    height: Option<u32>,
    /// Seed of the sample sequence (default: the scene's sampler seed).
    #[arg(long)]
    seed: Option<u32>,
    /// Scene parameter, overriding a <default>: -D spp=64.
    #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = parse_define)]
    define: Vec<(String, String)>,
    /// Treat a NaN or infinite sample as an error: list where each came
    /// from (pixel and sample index, the first 100), write the image
    /// without them and exit with 1.
    #[arg(long)]
    strict: bool,
    /// Raise (or lower) a limit on what a scene may ask for: film-pixels
    /// (default 268435456, a 16384² film), texture-pixels (2^30 texels),
    /// grid-cells (2^32 volume grid values), include-depth (64).
    /// Repeatable.
    #[arg(long, value_name = "NAME=N", value_parser = parse_limit)]
    limit: Vec<(Limit, u64)>,
    /// No progress bar and no summary.
    #[arg(short, long)]
    quiet: bool,
    /// Stop after the last pass that ends within this time (90, 90s, 5m,
    /// 1h30m) and write the average of the passes done. Without --spp,
    /// passes go on until the limit.
    #[arg(long, value_name = "DURATION", value_parser = parse_duration)]
    time_limit: Option<Duration>,
    /// Write the image so far every SECONDS (rendering in passes).
    #[arg(long, value_name = "SECONDS", value_parser = parse_duration)]
    progressive: Option<Duration>,
    /// Samples per pixel in each pass of a render in passes (default: 1
    /// for a time-limited render, else passes of 1, 2, 4, … up to a
    /// sixteenth of --spp, as a plain render takes them).
    #[arg(long, value_name = "N")]
    pass_spp: Option<u32>,
    /// Render only part K of N (K from 0 to N − 1) of the image: every
    /// N-th tile of 16 × 16 pixels from the K-th. The output is a part
    /// file, which `yubin merge` puts together with the others into the
    /// image a plain render makes, bit for bit. `auto/N` takes K from the
    /// scheduler: SLURM_ARRAY_TASK_ID, JOB_COMPLETION_INDEX (Kubernetes)
    /// or AWS_BATCH_JOB_ARRAY_INDEX. A part stopped by SIGINT or SIGTERM
    /// saves its state to OUTPUT.state, and the same command continues it.
    #[arg(long, value_name = "K/N", value_parser = parse_part)]
    part: Option<PartArg>,
    /// Render only the crop window X,Y,W,H of the film (pixels; Mitsuba's
    /// crop_offset_x/y, crop_width/height).
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_crop)]
    crop: Option<[u32; 4]>,
    /// Adaptive sampling: a pixel stops once the estimated relative error
    /// of its mean falls below THRESHOLD (e.g. 0.01), with at most --spp
    /// samples; adds an `spp` layer to EXR output.
    #[arg(long, value_name = "THRESHOLD")]
    adaptive: Option<f32>,
    /// Samples every pixel takes before adaptive sampling may stop it.
    #[arg(long, value_name = "N", default_value_t = 16)]
    adaptive_min: u32,
    /// Denoiser guide layers for the EXR, any of albedo,normal,depth:
    /// albedo and normal of the first surface that is not purely specular
    /// (as Intel Open Image Denoise asks), depth of the first hit.
    #[arg(long, value_name = "LIST", value_parser = parse_guides)]
    aov: Option<GuideList>,
    /// Write the render's state to OUTPUT.state every SECONDS (rendering in
    /// passes), for --resume. SIGINT and SIGTERM write it too, with the
    /// image so far, and exit with 130 and 143.
    #[arg(long, value_name = "SECONDS", value_parser = parse_duration)]
    checkpoint: Option<Duration>,
    /// Continue the render saved in STATE (the same scene and options; a
    /// difference is refused, named); the result equals an uninterrupted
    /// render bit for bit.
    #[arg(long, value_name = "STATE")]
    resume: Option<PathBuf>,
    /// Denoise the finished image with Intel Open Image Denoise, guided by
    /// albedo and normal layers (which the EXR then holds); needs a build
    /// with `--features denoise` (scripts/oidn-setup).
    #[arg(long)]
    denoise: bool,
    /// How PNG/JPEG output shows the image.
    #[command(flatten)]
    display: DisplayArgs,
}

/// `--part K/N`, K given or (`auto/N`) from the environment.
#[derive(Clone, Copy, Debug)]
struct PartArg {
    index: Option<u32>,
    count: u32,
}

fn parse_part(s: &str) -> Result<PartArg, String> {
    let bad = || format!("expected K/N (part K of N, K from 0) or auto/N, not \"{s}\"");
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    let count: u32 = n.trim().parse().map_err(|_| bad())?;
    let index = match k.trim() {
        "auto" => None,
        k => Some(k.parse().map_err(|_| bad())?),
    };
    if count == 0 {
        return Err(format!("--part {s}: N must be at least 1"));
    }
    if index.is_some_and(|k| k >= count) {
        return Err(format!("--part {s}: parts are numbered 0 to {}", count - 1));
    }
    Ok(PartArg { index, count })
}

/// The environment variables a scheduler gives an array task its index in.
pub(crate) const INDEX_VARIABLES: [&str; 3] = [
    "SLURM_ARRAY_TASK_ID",
    "JOB_COMPLETION_INDEX",
    "AWS_BATCH_JOB_ARRAY_INDEX",
];

impl PartArg {
    /// The part, its index read from the environment for `auto`.
    fn resolve(self) -> Result<Part> {
        let index = match self.index {
            Some(k) => k,
            None => {
                let (name, value) = INDEX_VARIABLES
                    .iter()
                    .find_map(|&v| Some((v, std::env::var(v).ok()?)))
                    .ok_or_else(|| {
                        anyhow::anyhow!(
                            "--part auto/{}: none of {} is set (give the part as K/{})",
                            self.count,
                            INDEX_VARIABLES.join(", "),
                            self.count
                        )
                    })?;
                value.trim().parse().map_err(|_| {
                    anyhow::anyhow!("--part auto: {name}={value} is not a part number")
                })?
            }
        };
        if index >= self.count {
            bail!(
                "part {index} of {}: parts are numbered 0 to {}",
                self.count,
                self.count - 1
            );
        }
        Ok(Part {
            index,
            count: self.count,
        })
    }
}

/// The denoiser guides `--aov` asks for (a newtype: clap reads a `Vec`
/// as repeated values).
#[derive(Clone, Debug)]
struct GuideList(Vec<Guide>);

fn parse_guides(s: &str) -> Result<GuideList, String> {
    s.split(',')
        .map(|name| {
            let name = name.trim();
            Guide::ALL
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, g)| *g)
                .ok_or_else(|| {
                    format!("unknown guide layer \"{name}\" (known: albedo, normal, depth)")
                })
        })
        .collect::<Result<_, _>>()
        .map(GuideList)
}

/// A duration: seconds, or a sequence of numbers with units h, m, s
/// (`90`, `2.5s`, `5m`, `1h30m`).
fn parse_duration(s: &str) -> Result<Duration, String> {
    let bad = || format!("expected a duration such as 90, 90s, 5m or 1h30m, got \"{s}\"");
    if let Ok(secs) = s.parse::<f64>() {
        return Duration::try_from_secs_f64(secs).map_err(|_| bad());
    }
    let mut total = 0.0;
    let mut number = String::new();
    for c in s.chars() {
        match c {
            '0'..='9' | '.' => number.push(c),
            'h' | 'm' | 's' => {
                let v: f64 = number.parse().map_err(|_| bad())?;
                total += v * match c {
                    'h' => 3600.0,
                    'm' => 60.0,
                    _ => 1.0,
                };
                number.clear();
            }
            _ => return Err(bad()),
        }
    }
    if !number.is_empty() || s.is_empty() {
        return Err(bad());
    }
    Duration::try_from_secs_f64(total).map_err(|_| bad())
}

/// `X,Y,W,H` (non-negative integers).
fn parse_crop(s: &str) -> Result<[u32; 4], String> {
    let v: Vec<u32> = s
        .split(',')
        .map(|t| t.trim().parse())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("expected X,Y,W,H (four whole numbers), got \"{s}\""))?;
    v.try_into()
        .map_err(|_| format!("expected X,Y,W,H (four whole numbers), got \"{s}\""))
}

pub(crate) fn parse_frames(s: &str) -> Result<(i64, i64), String> {
    let bad = || format!("frames are A-B or N (1-120, 7), not \"{s}\"");
    let (a, b) = match s.split_once('-') {
        Some((a, b)) => (
            a.trim().parse().map_err(|_| bad())?,
            b.trim().parse().map_err(|_| bad())?,
        ),
        None => {
            let n = s.trim().parse().map_err(|_| bad())?;
            (n, n)
        }
    };
    if a > b || a < 0 {
        return Err(bad());
    }
    Ok((a, b))
}

fn parse_define(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((k, v)) if !k.trim().is_empty() => Ok((k.trim().to_string(), v.to_string())),
        _ => Err(format!("expected NAME=VALUE, got \"{s}\"")),
    }
}

fn parse_limit(s: &str) -> Result<(Limit, u64), String> {
    let names = || {
        let all: Vec<&str> = limits::ALL.iter().map(|l| l.name()).collect();
        all.join(", ")
    };
    let (name, value) = s
        .split_once('=')
        .ok_or_else(|| format!("expected NAME=N, got \"{s}\" (limits: {})", names()))?;
    let limit = Limit::named(name.trim())
        .ok_or_else(|| format!("unknown limit \"{name}\" (limits: {})", names()))?;
    let value = value
        .trim()
        .parse()
        .map_err(|_| format!("--limit {name}: \"{value}\" is not a whole number"))?;
    Ok((limit, value))
}

/// Loads, renders and writes.
pub fn run(args: RenderArgs) -> Result<()> {
    for &(limit, value) in &args.limit {
        limit.set(value);
    }
    if args.frames.is_some() || args.video.is_some() {
        return animate::run(&args);
    }
    let t0 = Instant::now();
    let (loaded, output) = load(&args)?;
    check_output_format(&output)?;
    for w in &loaded.warnings {
        eprintln!("warning: {w}");
    }
    let load_time = t0.elapsed();
    let mut loaded = loaded;
    if let Some(crop) = args.crop {
        set_crop(&mut loaded, crop)?;
    }
    if args.denoise {
        denoise::check_available()?;
        // A wider pixel filter spreads each sample over several pixels,
        // and OIDN keeps noise that neighbours share as detail.
        if loaded.scene.film.filter != Filter::Box {
            if !args.quiet {
                eprintln!("note: --denoise renders with a box pixel filter (Open Image Denoise needs each pixel's noise to be its own)");
            }
            loaded.scene.film.filter = Filter::Box;
        }
    }
    let mut guides = args.aov.as_ref().map(|g| g.0.clone()).unwrap_or_default();
    if args.denoise {
        for guide in [Guide::Albedo, Guide::Normal] {
            if !guides.contains(&guide) {
                guides.push(guide);
            }
        }
    }
    if !guides.is_empty() {
        if loaded.integrator.particle_tracer().is_some() {
            bail!("--aov and --denoise trace camera rays, which ptracer does not");
        }
        let inner = std::mem::replace(&mut loaded.integrator, Box::new(PathIntegrator::default()));
        loaded.integrator = Box::new(DenoiserGuides::new(inner, guides));
    }
    render_scene(&args, &loaded, &output, load_time, None)
}

/// What a render with `--part` is split into, and what it refuses.
fn part_of(args: &RenderArgs, loaded: &LoadedScene) -> Result<Option<Part>> {
    let Some(part) = args.part else {
        return Ok(None);
    };
    let refused = [
        (
            args.time_limit.is_some(),
            "--time-limit (parts must take the same samples)",
        ),
        (
            args.adaptive.is_some(),
            "--adaptive (a pixel stops by its neighbours, which another part renders)",
        ),
        (
            args.progressive.is_some(),
            "--progressive (a part is not an image)",
        ),
        (
            args.pass_spp.is_some(),
            "--pass-spp (a part takes its passes as a plain render does)",
        ),
        (
            args.resume.is_some(),
            "--resume (a part continues its own OUTPUT.state when run again)",
        ),
        (
            loaded.integrator.particle_tracer().is_some(),
            "ptracer (its light paths land anywhere in the image)",
        ),
    ];
    if let Some((_, what)) = refused.iter().find(|(on, _)| *on) {
        bail!("--part cannot be used with {what}");
    }
    // A part file is data for `yubin merge`, not an image: it never takes
    // the scene's image name.
    if !args.output.as_deref().is_some_and(output_is_exr) {
        bail!("--part needs -o PART.exr: a part file (an EXR of the part's sums) for yubin merge");
    }
    part.resolve().map(Some)
}

/// Renders `loaded` and writes it to `output`, with a summary line; for a
/// frame of an animation, `frame` is (its number, its place, the count).
fn render_scene(
    args: &RenderArgs,
    loaded: &LoadedScene,
    output: &Path,
    load_time: Duration,
    frame: Option<(i64, usize, usize)>,
) -> Result<()> {
    let part = part_of(args, loaded)?;
    let passes = args.time_limit.is_some()
        || args.progressive.is_some()
        || args.adaptive.is_some()
        || args.checkpoint.is_some()
        || args.resume.is_some()
        || part.is_some();
    if passes && loaded.integrator.particle_tracer().is_some() {
        bail!("--time-limit, --progressive, --adaptive, --checkpoint and --resume render in passes, which ptracer does not (it renders all its light paths at once)");
    }
    if let Some(t) = args.adaptive {
        if !(t > 0.0 && t.is_finite()) {
            bail!("--adaptive needs a positive threshold (a relative error such as 0.01), not {t}");
        }
    }
    // A time limit without --spp renders until the limit.
    let spp = match (args.spp, args.time_limit) {
        (Some(n), _) => n,
        (None, Some(_)) => u32::MAX,
        (None, None) => loaded.scene.sampler.sample_count(),
    };
    if spp == 0 {
        bail!("--spp must be at least 1");
    }
    if args.pass_spp == Some(0) {
        bail!("--pass-spp must be at least 1");
    }
    let film = &loaded.scene.film;
    let [w, h] = film.crop_size.map(u64::from);
    Limit::FilmPixels
        .check(w * h, || {
            format!("the film of {w} × {h} = {} pixels", w * h)
        })
        .map_err(|e| match &args.scene {
            Some(scene) => anyhow::anyhow!("{}: {e}", scene.display()),
            None => anyhow::anyhow!(e),
        })?;
    let display = args.display.resolve()?;
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
    let pixels = u64::from(film.crop_size[0]) * u64::from(film.crop_size[1]);
    let t1 = Instant::now();
    let interrupt = Interrupt::watch()?;
    let job = PassJob {
        settings,
        part,
        frame: frame.map(|(number, _, _)| number),
        output,
        display: &display,
        denoise: args.denoise,
        crop_offset: loaded.scene.film.crop_offset,
    };
    let (out, total_samples, passes_done) = if passes {
        render_in_passes(&pool, loaded, args, &job)?
    } else {
        let bar = progress_bar(pixels * u64::from(spp), args.quiet);
        if let Some((number, place, count)) = frame {
            bar.set_message(format!("frame {number} ({}/{count})  ", place + 1));
        }
        let done = AtomicU64::new(0);
        let out = pool.install(|| {
            let progress = |n| {
                let d = done.fetch_add(n, Ordering::Relaxed) + n;
                bar.set_position(d);
            };
            render_until(
                &loaded.scene,
                loaded.integrator.as_ref(),
                &settings,
                &progress,
                interrupt.stop(),
            )
        });
        bar.finish_and_clear();
        let samples = out.samples;
        (out, samples, 1)
    };
    let render_time = t1.elapsed();
    // Stopped by a signal before the end: the samples done are kept.
    let stopped = interrupt
        .exit_code()
        .filter(|_| total_samples < pixels * u64::from(spp) && !passes);
    if let (Some(code), 0) = (stopped, total_samples) {
        eprintln!(
            "interrupted before the first pass finished: nothing written ({} untouched)",
            output.display()
        );
        std::process::exit(code);
    }
    report_nonfinite(&out, args.strict);
    let mut out = out;
    if args.denoise && part.is_none() {
        denoise::denoise(&mut out)?;
    }
    if part.is_none() {
        write_output(output, &out, &display)?;
    }
    if !args.quiet {
        if let (View::Ocio(p), false) = (&display.view, output_is_exr(output)) {
            eprintln!("{}: shown through OCIO {}", output.display(), p.description);
        }
        let passes = match (part, passes) {
            (Some(p), _) => format!(" in {passes_done} passes, part {}/{}", p.index, p.count),
            (None, true) => format!(" in {passes_done} passes"),
            (None, false) => String::new(),
        };
        let spp = if args.adaptive.is_some() {
            format!("{:.1} spp on average", total_samples as f64 / pixels as f64)
        } else if part.is_some() {
            format!("{spp} spp")
        } else {
            format!("{} spp", total_samples / pixels.max(1))
        };
        let noise = out
            .estimated_error
            .map(|e| {
                let when = if args.denoise {
                    " before denoising"
                } else {
                    ""
                };
                format!(", noise{when} ~{:.2} %", 100.0 * e)
            })
            .unwrap_or_default();
        eprintln!(
            "{}: {}x{}, {spp}{passes} in {:.2} s (load {:.2} s, {:.2} M samples/s{noise})",
            output.display(),
            film.crop_size[0],
            film.crop_size[1],
            render_time.as_secs_f64(),
            load_time.as_secs_f64(),
            total_samples as f64 / render_time.as_secs_f64() / 1e6
        );
    }
    if args.strict && out.dropped_samples > 0 {
        bail!(
            "--strict: {} samples were NaN or infinite ({} written without them)",
            out.dropped_samples,
            output.display()
        );
    }
    if let Some(code) = stopped {
        eprintln!(
            "interrupted after {} of {spp} samples per pixel: wrote {}",
            total_samples / pixels.max(1),
            output.display()
        );
        std::process::exit(code);
    }
    Ok(())
}

/// Says how many samples came out NaN or infinite (dropped from the
/// image) and where the first did, so that `--crop` can render it again;
/// `strict` lists every one kept.
pub(crate) fn report_nonfinite(out: &RenderOutput, strict: bool) {
    let dropped = out.dropped_samples;
    if dropped == 0 {
        return;
    }
    let pixels = match out.nonfinite.pixels {
        0 => String::new(),
        1 => " in 1 pixel".to_string(),
        n => format!(" in {n} pixels"),
    };
    let again = |s: &NonFiniteSample| {
        format!(
            "pixel ({}, {}) sample {} (render it again with --crop {},{},1,1 --spp {})",
            s.x,
            s.y,
            s.index,
            s.x,
            s.y,
            s.index + 1
        )
    };
    match out.nonfinite.first.first() {
        Some(first) => eprintln!(
            "warning: {dropped} samples{pixels} were NaN or infinite and were dropped; the first: {}",
            again(first)
        ),
        None => eprintln!("warning: {dropped} light paths were NaN or infinite and were dropped"),
    }
    if strict {
        for s in &out.nonfinite.first {
            eprintln!("  {}", again(s));
        }
        let listed = out.nonfinite.first.len() as u64;
        if dropped > listed && listed > 0 {
            eprintln!("  and {} more", dropped - listed);
        }
    }
}

/// What a render in passes is asked for beyond its arguments.
struct PassJob<'a> {
    settings: RenderSettings,
    /// The part it renders, if only one.
    part: Option<Part>,
    /// The frame of an animation it renders.
    frame: Option<i64>,
    output: &'a Path,
    display: &'a Display,
    /// The image is to be denoised (for a part: once merged).
    denoise: bool,
    /// The crop window's place in the film.
    crop_offset: [u32; 2],
}

/// The passes a render takes: `--pass-spp`, else one sample at a time
/// until a time limit, else as a plain render takes them.
fn pass_size(args: &RenderArgs, spp: u32) -> PassSize {
    match (args.pass_spp, args.time_limit) {
        (Some(n), _) => PassSize::Fixed(n),
        (None, Some(_)) => PassSize::Fixed(1),
        (None, None) => PassSize::growing(spp),
    }
}

/// Renders pass after pass until the samples are taken or the next pass
/// would end past the time limit, writing the image so far at the
/// `--progressive` interval (a part: its part file once finished);
/// returns the image, the samples taken over the image and the passes.
fn render_in_passes(
    pool: &rayon::ThreadPool,
    loaded: &LoadedScene,
    args: &RenderArgs,
    job: &PassJob,
) -> Result<(RenderOutput, u64, u32)> {
    let (settings, output, display) = (&job.settings, job.output, job.display);
    let start = Instant::now();
    let mut render = Progressive::new(&loaded.scene, loaded.integrator.as_ref(), *settings, 1)
        .with_passes(pass_size(args, settings.spp));
    if let Some(threshold) = args.adaptive {
        render = render.with_adaptive(Adaptive {
            threshold,
            min_spp: args.adaptive_min,
        });
    }
    if let Some(part) = job.part {
        render = render
            .with_part(part)
            .map_err(|e| anyhow::anyhow!("--part: {e}"))?;
    }
    let fingerprint = fingerprint(args, loaded, settings, job.frame)?;
    let state_path = PathBuf::from(format!("{}.state", output.display()));
    // A part continues the state a signal left (the same command again).
    let resume = match (&args.resume, job.part) {
        (Some(r), _) => Some(r.clone()),
        (None, Some(_)) if state_path.exists() => Some(state_path.clone()),
        _ => None,
    };
    if let Some(resume) = &resume {
        let (saved, state) = checkpoint::read(resume)?;
        checkpoint::check_same(resume, &saved, &fingerprint)?;
        render
            .restore(state)
            .map_err(|e| anyhow::anyhow!("{}: {e}", resume.display()))?;
        // Said even when quiet: a farm task's log tells what it resumed.
        if job.part.is_some() {
            eprintln!(
                "{}: continuing from {} ({} of {} samples per pixel done)",
                output.display(),
                resume.display(),
                render.samples_done(),
                settings.spp
            );
        }
    }
    // SIGINT and SIGTERM end the render, its pass in flight dropped, saved.
    let interrupt = Interrupt::watch()?;
    let mut last_checkpoint = Instant::now();
    // The bar follows the time limit, else the samples.
    let bar = match args.time_limit {
        Some(limit) => progress_bar(limit.as_millis() as u64, args.quiet),
        None => progress_bar(u64::from(settings.spp), args.quiet),
    };
    let mut last_write = Instant::now();
    let mut longest_pass = Duration::ZERO;
    while !render.finished() {
        let t = Instant::now();
        pool.install(|| render.pass_unless(&|_| {}, interrupt.stop()));
        longest_pass = longest_pass.max(t.elapsed());
        let elapsed = start.elapsed();
        match args.time_limit {
            Some(limit) => {
                bar.set_position((elapsed.as_millis() as u64).min(limit.as_millis() as u64))
            }
            None => bar.set_position(u64::from(render.samples_done())),
        }
        if let Some(every) = args.progressive {
            if last_write.elapsed() >= every && !render.finished() {
                write_output(output, &render.output(), display)?;
                last_write = Instant::now();
            }
        }
        if let Some(every) = args.checkpoint {
            if last_checkpoint.elapsed() >= every && !render.finished() {
                checkpoint::write(&state_path, &fingerprint, &render.state())?;
                last_checkpoint = Instant::now();
            }
        }
        if let Some(code) = interrupt.exit_code() {
            bar.finish_and_clear();
            checkpoint::write(&state_path, &fingerprint, &render.state())?;
            if let Some(p) = job.part {
                eprintln!(
                    "interrupted after {} of {} samples per pixel: part {}/{} saved to {} (the same command continues it)",
                    render.samples_done(),
                    settings.spp,
                    p.index,
                    p.count,
                    state_path.display()
                );
                std::process::exit(code);
            }
            write_output(output, &render.output(), display)?;
            eprintln!(
                "interrupted after {} passes: wrote {} and {} (continue with --resume {})",
                render.passes_done(),
                output.display(),
                state_path.display(),
                state_path.display()
            );
            std::process::exit(code);
        }
        if args
            .time_limit
            .is_some_and(|limit| elapsed + longest_pass > limit)
        {
            break;
        }
    }
    bar.finish_and_clear();
    let out = render.output();
    if let Some(part) = job.part {
        write_part(output, &render, &out, part, fingerprint.clone(), job)?;
    }
    if render.finished() {
        // A finished render needs no state.
        if args.checkpoint.is_some() || resume.is_some() {
            std::fs::remove_file(&state_path).ok();
        }
    } else if args.checkpoint.is_some() {
        checkpoint::write(&state_path, &fingerprint, &render.state())?;
    }
    Ok((out, render.total_samples(), render.passes_done()))
}

/// Writes the part file of the finished `render` of `part`, whose output
/// (its image of the part's tiles) is `out`.
fn write_part(
    output: &Path,
    render: &Progressive,
    out: &RenderOutput,
    part: Part,
    fingerprint: checkpoint::Fingerprint,
    job: &PassJob,
) -> Result<()> {
    let sums: Vec<&[f32]> = render.part_sums().map(|(_, s)| s).collect();
    let header = PartHeader {
        index: part.index,
        count: part.count,
        version: env!("CARGO_PKG_VERSION").to_string(),
        fingerprint,
        crop: [out.image.width, out.image.height],
        crop_offset: job.crop_offset,
        margin: render.margin(),
        channels: out.image.channels,
        layers: out.layers.clone(),
        spp: job.settings.spp,
        done: render.samples_done(),
        samples: render.total_samples(),
        dropped: out.dropped_samples,
        nonfinite_pixels: out.nonfinite.pixels,
        nonfinite: out.nonfinite.first.clone(),
        error: render.error_sum(),
        denoise: job.denoise,
    };
    part::write(output, &header, &sums)
}

/// What a checkpoint must match to be resumed (and the parts of a render
/// to be merged): the yubin version, the scene file's contents, the
/// defines, the frame and every setting that changes the samples.
fn fingerprint(
    args: &RenderArgs,
    loaded: &LoadedScene,
    settings: &RenderSettings,
    frame: Option<i64>,
) -> Result<checkpoint::Fingerprint> {
    let (scene, text) = match &args.scene {
        // The file's name, not its path: parts rendered from other
        // directories belong together (its contents are compared too).
        Some(p) => (
            p.file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned(),
            std::fs::read(p).with_context(|| format!("cannot read {}", p.display()))?,
        ),
        None => (
            "(built-in Cornell box)".to_string(),
            CORNELL_BOX.as_bytes().to_vec(),
        ),
    };
    let film = &loaded.scene.film;
    let defines: Vec<String> = args
        .define
        .iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect();
    let guides = args
        .aov
        .as_ref()
        .map(|g| format!("{:?}", g.0))
        .unwrap_or_default();
    Ok([
        ("yubin", env!("CARGO_PKG_VERSION").to_string()),
        ("scene", scene),
        (
            "scene contents",
            format!("{:016x}", checkpoint::fnv1a(&text)),
        ),
        ("defines", defines.join(" ")),
        ("spp", settings.spp.to_string()),
        ("seed", settings.seed.to_string()),
        ("frame", frame.map(|f| f.to_string()).unwrap_or_default()),
        ("passes", format!("{:?}", pass_size(args, settings.spp))),
        ("pixel filter", format!("{:?}", film.filter)),
        ("film", format!("{}x{}", film.width, film.height)),
        (
            "crop",
            format!("{:?} {:?}", film.crop_offset, film.crop_size),
        ),
        (
            "adaptive",
            format!("{:?} min {}", args.adaptive, args.adaptive_min),
        ),
        ("aov", guides),
        ("denoise", args.denoise.to_string()),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect())
}

/// How PNG output shows the image.
/// Restricts the film to the crop window `[x, y, w, h]`.
fn set_crop(loaded: &mut LoadedScene, [x, y, w, h]: [u32; 4]) -> Result<()> {
    let film = &mut loaded.scene.film;
    let fits = w > 0
        && h > 0
        && x.checked_add(w).is_some_and(|r| r <= film.width)
        && y.checked_add(h).is_some_and(|b| b <= film.height);
    if !fits {
        bail!(
            "--crop {x},{y},{w},{h}: the window must be non-empty and inside the {}x{} film",
            film.width,
            film.height
        );
    }
    film.crop_offset = [x, y];
    film.crop_size = [w, h];
    Ok(())
}

/// Fails before rendering, not after, when the output can't be written
/// in the format its extension names.
pub(crate) fn output_is_exr(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

pub(crate) fn check_output_format(path: &Path) -> Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("exr" | "png" | "jpg" | "jpeg") => {}
        _ => bail!(
            "{}: unsupported output format (supported extensions: .exr, .png, .jpg)",
            path.display()
        ),
    }
    check_writable_dir(path)
}

/// Fails before rendering when the output's directory cannot take a new
/// file (missing, not a directory, read-only): a probe file is created
/// there and removed.
fn check_writable_dir(path: &Path) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let probe = dir.join(format!(".yubin-write-test-{}", std::process::id()));
    std::fs::File::create(&probe).with_context(|| {
        format!(
            "{}: cannot write into {} (it must be an existing, writable directory)",
            path.display(),
            dir.display()
        )
    })?;
    std::fs::remove_file(&probe).ok();
    Ok(())
}

fn load(args: &RenderArgs) -> Result<(LoadedScene, PathBuf)> {
    match &args.scene {
        Some(path) if yubin_scene::gltf::is_gltf(path) => {
            let options = yubin_scene::gltf::GltfOptions {
                width: args.width,
                height: args.height,
                spp: args.spp,
                env: args.env.clone(),
            };
            let loaded = yubin_scene::gltf::load_gltf(path, &options)?;
            let default_out = Path::new(path.file_stem().unwrap_or_default()).with_extension("exr");
            Ok((loaded, args.output.clone().unwrap_or(default_out)))
        }
        Some(path) if yubin_scene::lua::is_lua(path) => {
            let options = yubin_scene::lua::LuaOptions {
                allow_read_anywhere: args.allow_read,
            };
            let (loaded, named) = yubin_scene::lua::load_lua(path, &options)?;
            // Outside an animation, an output pattern's `#`s are frame 0.
            let named = named.map(|n| PathBuf::from(n.to_string_lossy().replace('#', "0")));
            let default_out = named.unwrap_or_else(|| {
                Path::new(path.file_stem().unwrap_or_default()).with_extension("exr")
            });
            Ok((loaded, args.output.clone().unwrap_or(default_out)))
        }
        Some(path) => {
            if args.env.is_some() || args.width.is_some() || args.height.is_some() {
                anyhow::bail!(
                    "--env, --width and --height are for glTF scenes; an XML scene sets its \
                     film and emitters (use -D with its <default>s)"
                );
            }
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

/// Loads the built-in scene with `args`' `-D` defines, for the fuzz
/// target of the command line ([`crate::fuzz_arguments`]); errors are
/// the point, and dropped.
pub(crate) fn load_builtin_with_defines(args: &RenderArgs) {
    let _ = load_scene_str(
        CORNELL_BOX,
        Path::new("<built-in>/cornell-box.xml"),
        &args.define,
    );
}

fn progress_bar(total: u64, quiet: bool) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::hidden());
    }
    let bar = ProgressBar::new(total);
    let style = ProgressStyle::with_template(
        "{msg}{bar:40} {percent:>3}%  {per_sec:>14}  elapsed {elapsed_precise}  ETA {eta_precise}",
    )
    .unwrap_or_else(|_| ProgressStyle::default_bar());
    bar.set_style(style.progress_chars("=> "));
    bar
}
