//! `yubin-bench manylights`: light selection on a scene with 10,000
//! emissive triangles.
//!
//! ```text
//! cargo run --release -p yubin-bench -- manylights [--spp 16] [--ref-spp 1024] [--res 128]
//! ```
//!
//! The scene (written to a temporary folder): a 20 × 20 floor under a
//! grid of 100 × 50 small emissive quads (one OBJ mesh, 10,000 triangles)
//! hanging 0.3 above it, some of them raised or tilted so that the lighting
//! varies, seen at a grazing angle. Every point of the floor is lit mostly
//! by the few quads just above it, which is what a light BVH finds and
//! uniform or power choice cannot. The bench renders it with
//! `light_sampler` = `uniform`, `power` and `bvh` at the same spp, times
//! each, and compares it with a `bvh` reference at `--ref-spp`; the
//! table's last column, relMSE × time relative to uniform's, is the ratio
//! of the times each needs for equal error (relMSE ∝ 1/time).

use anyhow::{bail, Context, Result};
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;
use yubin_core::film::Framebuffer as Image;
use yubin_core::render::{render, RenderSettings};

/// The OBJ text of the light grid: `nx` × `nz` quads of side `size`.
fn light_grid(nx: usize, nz: usize) -> String {
    let mut obj = String::new();
    let size = 0.015f32;
    let mut v = 1;
    for i in 0..nx {
        for k in 0..nz {
            let x = -9.5 + 19.0 * i as f32 / (nx - 1) as f32;
            let z = -9.5 + 19.0 * k as f32 / (nz - 1) as f32;
            // Every seventh quad hangs higher; rows tilt a little, in turn.
            let y = if (i * 31 + k * 17) % 7 == 0 { 1.2 } else { 0.3 };
            let tilt = 0.3 * ((k % 3) as f32 - 1.0) * size;
            for (dx, dz, dy) in [
                (-size, -size, -tilt),
                (size, -size, tilt),
                (size, size, tilt),
                (-size, size, -tilt),
            ] {
                let _ = writeln!(obj, "v {} {} {}", x + dx, y + dy, z + dz);
            }
            // Wound to face down (-y), towards the floor.
            let _ = writeln!(obj, "f {} {} {}", v, v + 1, v + 2);
            let _ = writeln!(obj, "f {} {} {}", v, v + 2, v + 3);
            v += 4;
        }
    }
    obj
}

fn scene_xml(res: u32) -> String {
    format!(
        r#"<scene version="3.0.0">
    <default name="light_sampler" value="bvh"/>
    <integrator type="path">
        <integer name="max_depth" value="3"/>
        <string name="light_sampler" value="$light_sampler"/>
    </integrator>
    <sensor type="perspective">
        <float name="fov" value="50"/>
        <transform name="to_world"><lookat origin="0, 4, 14" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="{res}"/><integer name="height" value="{res}"/>
            <rfilter type="box"/></film>
    </sensor>
    <shape type="rectangle">
        <transform name="to_world"><rotate x="1" angle="-90"/><scale value="10"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.6"/></bsdf>
    </shape>
    <shape type="obj">
        <string name="filename" value="lights.obj"/>
        <emitter type="area"><rgb name="radiance" value="640, 480, 320"/></emitter>
    </shape>
</scene>"#
    )
}

fn rel_mse(a: &Image, b: &Image) -> f64 {
    crate::cornell::rel_mse_rgb(&a.data, a.channels, &b.data, b.channels)
}

/// Loads and renders the scene with `sampler` at `spp`: image and seconds
/// (load + render).
fn render_with(path: &Path, sampler: &str, spp: u32, seed: u32) -> Result<(Image, f64)> {
    let start = Instant::now();
    let defines = [("light_sampler".to_string(), sampler.to_string())];
    let loaded = yubin_scene::load_scene(path, &defines)?;
    let out = render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &RenderSettings { spp, seed },
        &|_| {},
    );
    let secs = start.elapsed().as_secs_f64();
    Ok((out.image.select_channels(0..3), secs))
}

pub fn run(args: &[String]) -> Result<()> {
    let (mut spp, mut ref_spp, mut res) = (16u32, 1024u32, 128u32);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| -> Result<u32> {
            Ok(it
                .next()
                .with_context(|| format!("{name} needs a value"))?
                .parse()?)
        };
        match a.as_str() {
            "--spp" => spp = value("--spp")?,
            "--ref-spp" => ref_spp = value("--ref-spp")?,
            "--res" => res = value("--res")?,
            other => bail!("unknown option {other}"),
        }
    }
    let dir = std::env::temp_dir().join(format!("yubin-manylights-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    std::fs::write(dir.join("lights.obj"), light_grid(100, 50))?;
    let path = dir.join("manylights.xml");
    std::fs::write(&path, scene_xml(res))?;
    eprintln!("reference: bvh at {ref_spp} spp");
    let (reference, _) = render_with(&path, "bvh", ref_spp, 12345)?;
    let mut rows = Vec::new();
    for sampler in ["uniform", "power", "bvh"] {
        eprintln!("{sampler} at {spp} spp");
        let (img, secs) = render_with(&path, sampler, spp, 1)?;
        rows.push((sampler, secs, rel_mse(&img, &reference)));
    }
    if std::env::var_os("YUBIN_KEEP_SCENE").is_none() {
        std::fs::remove_dir_all(&dir).ok();
    } else {
        eprintln!("scene kept in {}", dir.display());
    }
    println!(
        "10,000 emissive triangles, {res}×{res}, {spp} spp (reference: bvh, {ref_spp} spp), {} threads\n",
        rayon::current_num_threads()
    );
    println!("| light_sampler | wall time (s) | relMSE | relMSE × time / uniform's |");
    println!("|---|---:|---:|---:|");
    let base = rows[0].1 * rows[0].2;
    for (name, secs, err) in &rows {
        println!(
            "| {name} | {secs:.2} | {err:.5} | {:.3} |",
            secs * err / base
        );
    }
    Ok(())
}
