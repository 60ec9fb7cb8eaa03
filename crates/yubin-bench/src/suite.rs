//! `yubin-bench suite`: time to equal error against Mitsuba 3 on a suite
//! of scenes, in one run.
//!
//! ```text
//! cargo build --release -p yubin -p yubin-bench
//! ./target/release/yubin-bench suite [--spp 64] [--ref-spp 1024] [--reps 3]
//!     [--scenes cornell,glass-metal,...] [--variants llvm_ad_rgb,scalar_rgb]
//!     [-D name=value]...
//! ```
//!
//! Each scene (files in `scenes/` and `scenes/suite/`, written for both
//! renderers; `mesh.ply` and `sky.exr` are generated here when absent) is
//! rendered with the `yubin` binary and with Mitsuba 3.9.1 in each
//! `--variants` variant (`scripts/mitsuba-ref render`), alternating, each
//! `--reps` times, all at `--spp`, repetition k with seed k (both
//! renderers). For each the table gives the median wall time (scene
//! load plus render, as each renderer reports them: process start,
//! Python's import of Mitsuba and the image write are left out), the
//! mean over the repetitions of the relMSE against a converged yubin
//! render at `--ref-spp` with seed 0, which no measured run shares
//! samples with
//! (cached in `out/bench/suite`; both renderers converge to the same
//! image, as the Z-tests show), the **efficiency ratio** (relMSE × time of
//! yubin) / (relMSE × time of Mitsuba), the ratio of their times to equal
//! error, the load times, and the peak resident memory of each process
//! (GNU time's maximum RSS; Mitsuba's includes its Python interpreter).
//! The last row is the geometric mean of the efficiency ratios.
//!
//! `-D name=value` sets a scene parameter in both renderers (and in the
//! reference, cached per setting): `-D max_depth=2` measures paths of one
//! bounce, which with the full depth splits the cost between the first
//! hit and the later bounces. Only the scenes that declare the parameter
//! take it (the Cornell box declares `max_depth`, the others fix their
//! depth): both renderers refuse a parameter a scene does not have.

use crate::cornell::{rel_mse_rgb, repo_root};
use anyhow::{bail, Context, Result};
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::process::Command;
use yubin_scene::image_io::{read_image, write_image, ColorHandling, Image};

/// The suite: name and scene file (relative to `scenes/`).
const SCENES: &[(&str, &str)] = &[
    ("cornell", "cornell-box.xml"),
    ("glass-metal", "suite/glass-metal.xml"),
    ("rough", "suite/rough.xml"),
    ("textures", "suite/textures.xml"),
    ("mesh", "suite/mesh.xml"),
    ("envmap", "suite/envmap.xml"),
    ("dof", "suite/dof.xml"),
    ("fog", "fog.xml"),
];

/// One render's measurements.
#[derive(Clone, Copy, Debug, Default)]
struct Run {
    load: f64,
    total: f64,
    peak_mb: f64,
    rel_mse: f64,
}

pub fn run(args: &[String]) -> Result<()> {
    let (mut spp, mut ref_spp, mut reps) = (64u32, 1024u32, 3usize);
    let mut names: Vec<String> = SCENES.iter().map(|(n, _)| n.to_string()).collect();
    let mut variants = vec!["llvm_ad_rgb".to_string()];
    let mut defines = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().context("option needs a value");
        match a.as_str() {
            "--spp" => spp = value()?.parse()?,
            "--ref-spp" => ref_spp = value()?.parse()?,
            "--reps" => reps = value()?.parse()?,
            "--scenes" => names = value()?.split(',').map(str::to_string).collect(),
            "--variants" => variants = value()?.split(',').map(str::to_string).collect(),
            "-D" | "--define" => {
                let define = value()?;
                if !define.contains('=') {
                    bail!("-D takes name=value, not {define}");
                }
                defines.push(define.clone());
            }
            other => bail!("unknown option {other}"),
        }
    }
    let root = repo_root();
    let yubin = root.join("target/release/yubin");
    if !yubin.exists() {
        bail!("build the renderer first: cargo build --release -p yubin");
    }
    write_assets(&root.join("scenes/suite"))?;
    let out = root.join("out/bench/suite");
    std::fs::create_dir_all(&out)?;
    println!(
        "{} at {spp} spp{}, reference {ref_spp} spp (yubin), median of {reps}; CPU: {}\n",
        names.join(", "),
        defines.iter().map(|d| format!(", {d}")).collect::<String>(),
        cpu_model()
    );
    // The reference of each setting is its own file, named by the sorted
    // settings with anything but letters, digits, '=', '.' and '_' made
    // '_' (a value may be a path).
    let mut sorted = defines.clone();
    sorted.sort();
    let setting: String = sorted
        .iter()
        .map(|d| {
            let safe = |c: char| c.is_ascii_alphanumeric() || "=._".contains(c);
            let d: String = d.chars().map(|c| if safe(c) { c } else { '_' }).collect();
            format!("-{d}")
        })
        .collect();
    let mut header = "| scene | yubin s (load) | relMSE | peak MB |".to_string();
    let mut rule = "|---|---:|---:|---:|".to_string();
    for v in &variants {
        header += &format!(" {v} s (load) | relMSE | peak MB | efficiency |");
        rule += "---:|---:|---:|---:|";
    }
    println!("{header}\n{rule}");
    let mut log_sums = vec![0.0f64; variants.len()];
    for name in &names {
        let Some((_, file)) = SCENES.iter().find(|(n, _)| n == name) else {
            bail!("no scene {name} in the suite");
        };
        let scene = root.join("scenes").join(file);
        let reference = reference(
            &yubin,
            &scene,
            &out.join(format!("{name}-ref-{ref_spp}{setting}.exr")),
            ref_spp,
            &defines,
        )?;
        let mut ours = Vec::new();
        let mut theirs = vec![Vec::new(); variants.len()];
        // Each repetition renders with its own seed (the reference has
        // seed 0): the relMSE is then an average over independent noise,
        // and no run shares samples with the reference.
        for rep in 0..reps {
            let seed = rep as u32 + 1;
            let path = out.join(format!("{name}-yubin.exr"));
            let run = RunSpec {
                scene: &scene,
                spp,
                seed,
                defines: &defines,
                out: &path,
            };
            ours.push(measure_yubin(&yubin, &run, &reference)?);
            for (v, variant) in variants.iter().enumerate() {
                let path = out.join(format!("{name}-{variant}.exr"));
                let run = RunSpec { out: &path, ..run };
                theirs[v].push(measure_mitsuba(variant, &run, &reference)?);
            }
        }
        let y = median_run(&ours);
        let mut row = format!(
            "| {name} | {:.2} ({:.2}) | {:.6} | {:.0} |",
            y.total, y.load, y.rel_mse, y.peak_mb
        );
        for (v, runs) in theirs.iter().enumerate() {
            let m = median_run(runs);
            let efficiency = (y.rel_mse * y.total) / (m.rel_mse * m.total);
            log_sums[v] += efficiency.ln();
            row += &format!(
                " {:.2} ({:.2}) | {:.6} | {:.0} | {efficiency:.3} |",
                m.total, m.load, m.rel_mse, m.peak_mb
            );
        }
        println!("{row}");
    }
    let mut row = "| geometric mean | | | |".to_string();
    for s in &log_sums {
        row += &format!(" | | | {:.3} |", (s / names.len() as f64).exp());
    }
    println!("{row}");
    Ok(())
}

/// The median of each measurement on its own, but the mean relMSE: the
/// runs' seeds differ, and the expected error is what efficiency compares.
fn median_run(runs: &[Run]) -> Run {
    let median = |f: fn(&Run) -> f64| {
        let mut v: Vec<f64> = runs.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    Run {
        load: median(|r| r.load),
        total: median(|r| r.total),
        peak_mb: median(|r| r.peak_mb),
        rel_mse: runs.iter().map(|r| r.rel_mse).sum::<f64>() / runs.len() as f64,
    }
}

/// The CPU's model name, family and model (`/proc/cpuinfo`): virtual
/// machines often report only "AMD EPYC", which the family and model
/// narrow to a generation.
pub(crate) fn cpu_model() -> String {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let field = |key: &str| {
        info.lines()
            .find(|l| l.split(':').next().is_some_and(|k| k.trim() == key))
            .and_then(|l| l.split(':').nth(1))
            .map(|v| v.trim().to_string())
            .unwrap_or_else(|| "?".into())
    };
    format!(
        "{} (family {}, model {}), {} threads",
        field("model name"),
        field("cpu family"),
        field("model"),
        rayon::current_num_threads()
    )
}

/// Runs `program args` under GNU time; returns stdout, stderr and the
/// peak resident set in MB.
fn timed(program: &Path, args: &[String]) -> Result<(String, String, f64)> {
    let out = Command::new("/usr/bin/time")
        .arg("-f")
        .arg("PEAK_RSS_KB %M")
        .arg(program)
        .args(args)
        .output()
        .context("cannot run /usr/bin/time (GNU time)")?;
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    if !out.status.success() {
        bail!("{} failed: {stdout}{stderr}", program.display());
    }
    let kb: f64 = stderr
        .lines()
        .rev()
        .find_map(|l| l.strip_prefix("PEAK_RSS_KB "))
        .context("no peak memory from GNU time")?
        .trim()
        .parse()?;
    Ok((stdout, stderr, kb / 1024.0))
}

fn rel_mse(a: &Image, b: &Image) -> f64 {
    rel_mse_rgb(&a.data, a.channels, &b.data, b.channels)
}

/// The number after `key` in `text` (up to the next space or "s").
fn number_after(text: &str, key: &str) -> Result<f64> {
    let start = text
        .find(key)
        .with_context(|| format!("no \"{key}\" in:\n{text}"))?
        + key.len();
    let rest = text[start..].trim_start();
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(rest.len());
    Ok(rest[..end].parse()?)
}

/// One render: scene, samples, seed, scene parameters and output file.
#[derive(Clone, Copy)]
struct RunSpec<'a> {
    scene: &'a Path,
    spp: u32,
    seed: u32,
    defines: &'a [String],
    out: &'a Path,
}

/// The command line both `yubin` and `scripts/mitsuba-ref` take.
fn render_args(run: &RunSpec) -> Vec<String> {
    let mut args = vec![
        "render".into(),
        run.scene.to_string_lossy().into_owned(),
        "--spp".into(),
        run.spp.to_string(),
        "--seed".into(),
        run.seed.to_string(),
        "-o".into(),
        run.out.to_string_lossy().into_owned(),
    ];
    for d in run.defines {
        args.extend(["-D".into(), d.clone()]);
    }
    args
}

fn measure_yubin(bin: &Path, run: &RunSpec, reference: &Image) -> Result<Run> {
    let (_, stderr, peak_mb) = timed(bin, &render_args(run))?;
    // "OUT: WxH, N spp in R s (load L s, ..."
    let render = number_after(&stderr, " spp in ")?;
    let load = number_after(&stderr, "(load ")?;
    finish_run(load, render, peak_mb, run.out, reference)
}

/// The run's measurements, its image compared with the reference.
fn finish_run(load: f64, render: f64, peak_mb: f64, out: &Path, reference: &Image) -> Result<Run> {
    let img = read_image(out, ColorHandling::Raw)?;
    Ok(Run {
        load,
        total: load + render,
        peak_mb,
        rel_mse: rel_mse(&img, reference),
    })
}

fn measure_mitsuba(variant: &str, run: &RunSpec, reference: &Image) -> Result<Run> {
    let mut args = render_args(run);
    args.extend(["--variant".into(), variant.into()]);
    let (stdout, _, peak_mb) = timed(&repo_root().join("scripts/mitsuba-ref"), &args)?;
    let load = number_after(&stdout, "load time:")?;
    let render = number_after(&stdout, "render time:")?;
    finish_run(load, render, peak_mb, run.out, reference)
}

/// The cached reference, rendered by yubin at `spp` when absent.
fn reference(bin: &Path, scene: &Path, path: &Path, spp: u32, defines: &[String]) -> Result<Image> {
    if !path.exists() {
        eprintln!("rendering the reference {} ...", path.display());
        let run = RunSpec {
            scene,
            spp,
            seed: 0,
            defines,
            out: path,
        };
        timed(bin, &render_args(&run))?;
    }
    Ok(read_image(path, ColorHandling::Raw)?)
}

/// Writes the suite's generated inputs when absent: `mesh.ply` and `sky.exr`.
fn write_assets(dir: &Path) -> Result<()> {
    let mesh = dir.join("mesh.ply");
    if !mesh.exists() {
        write_mesh(&mesh, 512, 256)?;
    }
    let sky = dir.join("sky.exr");
    if !sky.exists() {
        write_sky(&sky, 1024, 512)?;
    }
    Ok(())
}

/// The displaced sphere: radius 0.8 modulated by a few sines, on a
/// `nu` × `nv` latitude-longitude grid (2·nu·(nv − 1) triangles), with
/// vertex normals from the grid's finite differences, as binary PLY.
fn write_mesh(path: &PathBuf, nu: usize, nv: usize) -> Result<()> {
    let point = |u: f32, v: f32| {
        let (phi, theta) = (u * std::f32::consts::TAU, v * std::f32::consts::PI);
        let dir = Vec3::new(
            theta.sin() * phi.cos(),
            theta.cos(),
            theta.sin() * phi.sin(),
        );
        let r = 0.8
            + 0.05 * (7.0 * phi).sin() * (5.0 * theta).sin()
            + 0.015 * (23.0 * phi + 3.0 * theta).sin();
        dir * r
    };
    let mut vertices = Vec::with_capacity(nu * (nv + 1));
    for j in 0..=nv {
        for i in 0..nu {
            let (u, v) = (i as f32 / nu as f32, j as f32 / nv as f32);
            let (du, dv) = (0.5 / nu as f32, 0.5 / nv as f32);
            let p = point(u, v);
            let tu = point(u + du, v) - point(u - du, v);
            let tv = point(u, (v + dv).min(1.0)) - point(u, (v - dv).max(0.0));
            // At the poles the φ tangent vanishes: the radial direction.
            let mut n = tu.cross(tv).normalize_or_zero();
            if n == Vec3::ZERO {
                n = p.normalize_or_zero();
            } else if n.dot(p) < 0.0 {
                n = -n;
            }
            vertices.push((p, n));
        }
    }
    let mut faces = Vec::new();
    for j in 0..nv {
        for i in 0..nu {
            let a = (j * nu + i) as u32;
            let b = (j * nu + (i + 1) % nu) as u32;
            let (c, d) = (a + nu as u32, b + nu as u32);
            if j > 0 {
                faces.push([a, b, c]);
            }
            if j + 1 < nv {
                faces.push([b, d, c]);
            }
        }
    }
    let mut bytes = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        vertices.len(),
        faces.len()
    )
    .into_bytes();
    for (p, n) in &vertices {
        for v in [p.x, p.y, p.z, n.x, n.y, n.z] {
            bytes.extend(v.to_le_bytes());
        }
    }
    for f in &faces {
        bytes.push(3);
        for i in f {
            bytes.extend(i.to_le_bytes());
        }
    }
    std::fs::write(path, bytes)?;
    eprintln!("wrote {} ({} triangles)", path.display(), faces.len());
    Ok(())
}

/// A latitude-longitude sky: blue at the zenith fading to a pale horizon,
/// a dark ground below it, and a sun 2° across at 35° elevation whose
/// radiance dwarfs the rest (as real skies do), as EXR.
fn write_sky(path: &Path, width: usize, height: usize) -> Result<()> {
    let sun = {
        let (elevation, azimuth) = (35f32.to_radians(), 120f32.to_radians());
        Vec3::new(
            elevation.cos() * azimuth.cos(),
            elevation.sin(),
            elevation.cos() * azimuth.sin(),
        )
    };
    let sun_cos = 1f32.to_radians().cos();
    let mut data = Vec::with_capacity(width * height * 3);
    for y in 0..height {
        let theta = (y as f32 + 0.5) / height as f32 * std::f32::consts::PI;
        for x in 0..width {
            let phi = (x as f32 + 0.5) / width as f32 * std::f32::consts::TAU;
            let d = Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            let rgb = if d.dot(sun) > sun_cos {
                Vec3::new(4000.0, 3600.0, 3000.0)
            } else if d.y > 0.0 {
                let t = d.y.powf(0.4);
                Vec3::new(0.9, 0.9, 0.95).lerp(Vec3::new(0.25, 0.4, 0.85), t)
            } else {
                Vec3::new(0.15, 0.12, 0.1)
            };
            data.extend([rgb.x, rgb.y, rgb.z]);
        }
    }
    let img = Image {
        width,
        height,
        channels: 3,
        data,
    };
    write_image(path, &img, &[])?;
    eprintln!("wrote {}", path.display());
    Ok(())
}
