//! `yubin-bench smoke-vol PATH [--res X,Y,Z]`: writes a procedural smoke
//! plume as a Mitsuba `.vol` grid (version 3, one float32 channel, box
//! [0, 1]³) for `scenes/smoke.xml` and the media benchmark: a column that
//! rises from the floor of the box, sways, widens and thins with height,
//! broken into wisps by fBm noise. Most of the box is empty, which is what
//! a majorant grid is for.

use anyhow::{bail, Context, Result};
use glam::Vec3;
use std::path::Path;
use yubin_core::texture::noise::perlin;

/// The default resolution (x, y up, z).
pub const RES: [u32; 3] = [64, 96, 64];

pub fn run(args: &[String]) -> Result<()> {
    let mut path = None;
    let mut res = RES;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--res" => {
                let v: Vec<u32> = it
                    .next()
                    .context("--res needs X,Y,Z")?
                    .split(',')
                    .map(str::parse)
                    .collect::<Result<_, _>>()?;
                res = v.try_into().ok().context("--res needs three numbers")?;
            }
            p if path.is_none() => path = Some(p.to_string()),
            other => bail!("unexpected argument {other}"),
        }
    }
    let path = path.context("usage: yubin-bench smoke-vol PATH [--res X,Y,Z]")?;
    write_smoke(Path::new(&path), res)?;
    eprintln!("wrote {path} ({}x{}x{})", res[0], res[1], res[2]);
    Ok(())
}

/// Writes the plume at resolution `res` to `path`.
pub fn write_smoke(path: &Path, res: [u32; 3]) -> Result<()> {
    let mut bytes = b"VOL".to_vec();
    bytes.push(3);
    bytes.extend(1i32.to_le_bytes());
    for r in res {
        bytes.extend((r as i32).to_le_bytes());
    }
    bytes.extend(1i32.to_le_bytes());
    for v in [0.0f32, 0.0, 0.0, 1.0, 1.0, 1.0] {
        bytes.extend(v.to_le_bytes());
    }
    for z in 0..res[2] {
        for y in 0..res[1] {
            for x in 0..res[0] {
                let p = (Vec3::new(x as f32, y as f32, z as f32) + 0.5)
                    / Vec3::new(res[0] as f32, res[1] as f32, res[2] as f32);
                bytes.extend(plume(p).to_le_bytes());
            }
        }
    }
    std::fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))
}

fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

fn fbm(p: Vec3, octaves: u32) -> f32 {
    let (mut sum, mut amp, mut freq) = (0.0, 0.5, 1.0);
    for _ in 0..octaves {
        sum += amp * perlin(p * freq).0;
        amp *= 0.5;
        freq *= 2.03;
    }
    sum
}

/// The plume's density at `p` in the unit box (y up).
fn plume(p: Vec3) -> f32 {
    let h = p.y;
    // Turbulence pushes the column sideways, more as it rises.
    let push = Vec3::new(
        fbm(p * 3.0 + Vec3::new(1.7, -2.0 * h, 4.2), 3),
        0.0,
        fbm(p * 3.0 + Vec3::new(-3.1, -2.0 * h, 0.4), 3),
    ) * (0.3 * h);
    let centre = Vec3::new(
        0.5 + 0.1 * h * (5.0 * h + 0.7).sin(),
        h,
        0.5 + 0.08 * h * (3.7 * h).cos(),
    );
    let width = 0.05 + 0.3 * h;
    let off = p + push - centre;
    let r = (off.x * off.x + off.z * off.z).sqrt() / width;
    let core = (-2.0 * r * r).exp();
    let wisps = (0.35 + 2.0 * fbm(p * 6.0 + Vec3::new(0.0, -3.0 * h, 0.0), 5)).clamp(0.0, 1.0);
    let fade = smoothstep(0.0, 0.05, h) * (1.0 - smoothstep(0.7, 1.0, h));
    core * wisps * fade * (0.08 / width)
}
