//! `yubin render scene.lua --frames A-B [--fps F] [--video out.mp4]`: the
//! frames of a Lua scene's animation, each rendered as it would be alone
//! (the same seed, the scene of that frame), written to numbered images
//! and, with `--video`, stitched by the system's ffmpeg.

use super::{check_output_format, check_writable_dir, render_scene, RenderArgs};
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;
use yubin_scene::lua::{is_lua, LuaAnimation, LuaOptions};

/// Renders the frames (and the video).
pub(super) fn run(args: &RenderArgs) -> Result<()> {
    let Some(script) = args.scene.as_ref().filter(|p| is_lua(p)) else {
        bail!("--frames and --video animate a Lua scene (.lua); this is not one");
    };
    let Some((first, last)) = args.frames else {
        bail!("--video stitches the frames of --frames A-B");
    };
    if !(args.fps > 0.0 && args.fps.is_finite()) {
        bail!("--fps must be a positive number, not {}", args.fps);
    }
    let unsupported = [
        (args.aov.is_some(), "--aov"),
        (args.denoise, "--denoise"),
        (args.crop.is_some(), "--crop"),
        (args.time_limit.is_some(), "--time-limit"),
        (args.progressive.is_some(), "--progressive"),
        (args.checkpoint.is_some(), "--checkpoint"),
        (args.resume.is_some(), "--resume"),
        (args.adaptive.is_some(), "--adaptive"),
    ];
    if let Some((_, name)) = unsupported.iter().find(|(on, _)| *on) {
        bail!("{name} is not available with --frames yet");
    }
    if let Some(video) = &args.video {
        check_ffmpeg()?;
        check_writable_dir(video)?;
    }
    let digits = last.to_string().len().max(4);
    let options = LuaOptions {
        allow_read_anywhere: args.allow_read,
    };
    let mut animation = LuaAnimation::new(script, options, args.fps);
    let count = (last - first + 1) as usize;
    let mut pattern = None;
    for (place, frame) in (first..=last).enumerate() {
        let t0 = Instant::now();
        let (loaded, named) = animation.frame(frame)?;
        let template = args
            .output
            .clone()
            .or(named)
            .unwrap_or_else(|| PathBuf::from(format!("{}_####.png", stem(script))));
        let output = numbered(&template, frame, digits)?;
        if place == 0 {
            check_output_format(&output)?;
            check_writable_dir(&output)?;
            for w in &loaded.warnings {
                eprintln!("warning: {w}");
            }
        }
        pattern.get_or_insert(template);
        render_scene(
            args,
            loaded,
            &output,
            t0.elapsed(),
            Some((frame, place, count)),
        )?;
    }
    if !args.quiet {
        eprintln!(
            "{count} frames: {} built, the others updated in place ({} parameter updates)",
            animation.rebuilds, animation.updates
        );
    }
    if let (Some(video), Some(template)) = (&args.video, &pattern) {
        stitch(template, first, digits, args.fps, video)?;
        if !args.quiet {
            eprintln!("{}: {count} frames at {} fps", video.display(), args.fps);
        }
    }
    Ok(())
}

fn stem(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// `template` with its run of `#` replaced by `frame`, zero-padded to
/// `digits` (or to the run's length if longer); without `#`, `_NNNN` is
/// added before the extension.
fn numbered(template: &Path, frame: i64, digits: usize) -> Result<PathBuf> {
    let (before, width, after) = split_at_hashes(template, digits)?;
    Ok(PathBuf::from(format!("{before}{frame:0width$}{after}")))
}

/// `template` around its run of `#` (or, without one, around `_` added
/// before the extension), and the frame number's width: the run's length
/// or `digits`, whichever is more.
fn split_at_hashes(template: &Path, digits: usize) -> Result<(String, usize, String)> {
    let text = template.to_string_lossy();
    let Some(start) = text.find('#') else {
        let ext = template.extension().map(|e| e.len() + 1).unwrap_or(0);
        let (b, a) = text.split_at(text.len() - ext);
        return Ok((format!("{b}_"), digits, a.to_string()));
    };
    let end = start + text[start..].chars().take_while(|&c| c == '#').count();
    if text[end..].contains('#') {
        bail!("the output {text} has more than one run of '#'");
    }
    Ok((
        text[..start].to_string(),
        (end - start).max(digits),
        text[end..].to_string(),
    ))
}

fn check_ffmpeg() -> Result<()> {
    match Command::new("ffmpeg").arg("-version").output() {
        Ok(o) if o.status.success() => Ok(()),
        _ => bail!(
            "--video needs ffmpeg on the PATH (Debian: apt-get install ffmpeg); the frames \
             alone render without it"
        ),
    }
}

/// The frames `template` names, from `first`, as an H.264 MP4.
fn stitch(template: &Path, first: i64, digits: usize, fps: f64, video: &Path) -> Result<()> {
    let (before, width, after) = split_at_hashes(template, digits)?;
    let input = format!("{before}%0{width}d{after}");
    let status = Command::new("ffmpeg")
        .args(["-y", "-loglevel", "error", "-framerate"])
        .arg(fps.to_string())
        .args(["-start_number", &first.to_string(), "-i", &input])
        .args([
            "-c:v",
            "libx264",
            "-pix_fmt",
            "yuv420p",
            "-vf",
            "pad=ceil(iw/2)*2:ceil(ih/2)*2",
        ])
        .arg(video)
        .status()
        .context("cannot run ffmpeg")?;
    if !status.success() {
        bail!(
            "ffmpeg could not make {} from {input} ({status})",
            video.display()
        );
    }
    Ok(())
}
