//! `yubin-bench farm`: what splitting a render into parts costs.
//!
//! ```text
//! cargo build --release -p yubin -p yubin-bench
//! ./target/release/yubin-bench farm [--scene PATH] [--spp 1024] [--parts 2,4,8] [--merge-res 3840x2160] [--merge-only]
//! ```
//!
//! Renders the scene (default the built-in Cornell box, 512 × 512) once
//! with `target/release/yubin render`, then as N parts, one after another,
//! for each N, and prints the CPU time (user + system, GNU time) of the N
//! parts summed against the single render's, with the wall times; each
//! merged image is checked to be the single render's file byte for byte.
//! Then renders the Cornell box at `--merge-res` (4K by default) at 1 spp
//! as 8 parts and times `yubin merge` of them (wall clock, best of 3).

use crate::cornell::repo_root;
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

pub fn run(args: &[String]) -> Result<()> {
    let mut scene: Option<PathBuf> = None;
    let mut spp = 1024u32;
    let mut counts = vec![2u32, 4, 8];
    let mut merge_res = (3840u32, 2160u32);
    let mut merge_only = false;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().context("option needs a value");
        match a.as_str() {
            "--scene" => scene = Some(PathBuf::from(value()?)),
            "--spp" => spp = value()?.parse()?,
            "--parts" => {
                counts = value()?
                    .split(',')
                    .map(str::parse)
                    .collect::<Result<_, _>>()?
            }
            "--merge-res" => {
                let v = value()?;
                let (w, h) = v.split_once('x').context("--merge-res WxH")?;
                merge_res = (w.parse()?, h.parse()?);
            }
            "--merge-only" => merge_only = true,
            other => bail!("unknown option {other}"),
        }
    }
    let root = repo_root();
    let yubin = root.join("target/release/yubin");
    if !yubin.exists() {
        bail!("build yubin first: cargo build --release -p yubin");
    }
    let out = root.join("out/bench/farm");
    std::fs::create_dir_all(&out)?;
    let scene_args: Vec<String> = scene
        .iter()
        .map(|s| s.display().to_string())
        .chain(["--spp".into(), spp.to_string(), "-q".into()])
        .collect();
    let scene_name = scene
        .as_ref()
        .map(|s| s.display().to_string())
        .unwrap_or_else(|| "the built-in Cornell box (512 × 512)".into());
    println!("{scene_name}, {spp} spp, {}\n", crate::suite::cpu_model());
    if !merge_only {
        parts_against_one(&yubin, &out, &scene_args, &counts)?;
    }
    merge_big(&yubin, &out, merge_res)
}

/// The table of CPU times: one render, then N parts for each N.
fn parts_against_one(
    yubin: &Path,
    out: &Path,
    scene_args: &[String],
    counts: &[u32],
) -> Result<()> {
    let single = out.join("single.exr");
    let whole = cpu_time(yubin, &with_output(scene_args, &single))?;
    println!("| render | CPU time (s) | / single | wall time (s) | merge (s) | merged = single |");
    println!("|---|---:|---:|---:|---:|---|");
    println!(
        "| single | {:.2} | 1.000 | {:.2} | | |",
        whole.cpu, whole.wall
    );
    for &n in counts {
        let (mut cpu, mut wall) = (0.0, 0.0);
        let mut files = Vec::new();
        for k in 0..n {
            let file = out.join(format!("part_{k}_of_{n}.exr"));
            let mut a = with_output(scene_args, &file);
            a.extend(["--part".into(), format!("{k}/{n}")]);
            let t = cpu_time(yubin, &a)?;
            cpu += t.cpu;
            wall += t.wall;
            files.push(file);
        }
        let merged = out.join(format!("merged_{n}.exr"));
        let merge = merge_time(yubin, &files, &merged)?;
        let same = std::fs::read(&merged)? == std::fs::read(&single)?;
        println!(
            "| {n} parts | {cpu:.2} | {:.3} | {wall:.2} | {merge:.2} | {} |",
            cpu / whole.cpu,
            if same { "yes" } else { "NO" }
        );
    }
    Ok(())
}

/// Renders a `w` × `h` Cornell box at 1 spp as 8 parts and times their
/// merge (best of 3).
fn merge_big(yubin: &Path, out: &Path, (w, h): (u32, u32)) -> Result<()> {
    let mut files = Vec::new();
    for k in 0..8 {
        let file = out.join(format!("big_{k}.exr"));
        let args: Vec<String> = [
            "render".to_string(),
            "-D".into(),
            format!("resx={w}"),
            "-D".into(),
            format!("resy={h}"),
            "--spp".into(),
            "1".into(),
            "-q".into(),
            "--part".into(),
            format!("{k}/8"),
            "-o".into(),
            file.display().to_string(),
        ]
        .to_vec();
        cpu_time(yubin, &args)?;
        files.push(file);
    }
    let bytes: u64 = files
        .iter()
        .map(|f| std::fs::metadata(f).map(|m| m.len()).unwrap_or(0))
        .sum();
    let merged = out.join("big.exr");
    let best = (0..3)
        .map(|_| merge_time(yubin, &files, &merged))
        .collect::<Result<Vec<f64>>>()?
        .into_iter()
        .fold(f64::INFINITY, f64::min);
    println!(
        "\nmerge of 8 parts of a {w} × {h} image ({:.0} MB of part files): {best:.2} s (best of 3)",
        bytes as f64 / 1e6
    );
    Ok(())
}

fn with_output(args: &[String], output: &Path) -> Vec<String> {
    let mut a = vec!["render".to_string()];
    a.extend(args.iter().cloned());
    a.extend(["-o".into(), output.display().to_string()]);
    a
}

struct Times {
    cpu: f64,
    wall: f64,
}

/// Runs `yubin args` under GNU time: its CPU time (user + system) and
/// wall time.
fn cpu_time(yubin: &Path, args: &[String]) -> Result<Times> {
    let out = Command::new("/usr/bin/time")
        .args(["-f", "CPU_TIMES %U %S %e"])
        .arg(yubin)
        .args(args)
        .output()
        .context("cannot run /usr/bin/time (GNU time)")?;
    let stderr = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        bail!("yubin {} failed: {stderr}", args.join(" "));
    }
    let line = stderr
        .lines()
        .rev()
        .find_map(|l| l.strip_prefix("CPU_TIMES "))
        .context("no times from GNU time")?;
    let v: Vec<f64> = line
        .split_whitespace()
        .map(str::parse)
        .collect::<Result<_, _>>()?;
    Ok(Times {
        cpu: v[0] + v[1],
        wall: v[2],
    })
}

/// Wall time of `yubin merge files -o output`.
fn merge_time(yubin: &Path, files: &[PathBuf], output: &Path) -> Result<f64> {
    let t = Instant::now();
    let status = Command::new(yubin)
        .arg("merge")
        .args(files)
        .arg("-q")
        .arg("-o")
        .arg(output)
        .status()?;
    if !status.success() {
        bail!("yubin merge failed");
    }
    Ok(t.elapsed().as_secs_f64())
}
