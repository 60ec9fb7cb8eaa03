//! Load a scene once, render it, edit it in place and render it again: a
//! wall's colour and the light's radiance, with no reload and no BVH
//! rebuilt (`Scene::parameters`, `Scene::update`).
//!
//! ```sh
//! cargo run --release -p yubin-scene --example 02_edit_and_render_again [PICTURE.png]
//! ```
//!
//! With a file name, the two renders are also written side by side
//! (256² each, 64 spp) as a PNG: `docs/edit.png` was made so.

use std::path::Path;
use yubin_core::film::Framebuffer;
use yubin_core::integrator::Integrator;
use yubin_core::params::ParamValue;
use yubin_core::render::{render, RenderSettings};
use yubin_core::{Rgb, Scene};
use yubin_scene::image_io::{write_png, Image};
use yubin_scene::load_scene;

/// The RGB of a render of `scene`.
fn render_rgb(scene: &Scene, integrator: &dyn Integrator, spp: u32) -> Framebuffer {
    let out = render(scene, integrator, &RenderSettings { spp, seed: 0 }, &|_| {});
    out.image.select_channels(0..3)
}

/// Mean RGB of the left and right thirds of an image.
fn thirds(rgb: &Framebuffer) -> [Rgb; 2] {
    let mean_of = |xs: std::ops::Range<u32>| {
        let mut sum = Rgb::ZERO;
        let mut n = 0.0;
        for y in 0..rgb.height {
            for x in xs.clone() {
                sum += Rgb::new(rgb.get(x, y, 0), rgb.get(x, y, 1), rgb.get(x, y, 2));
                n += 1.0;
            }
        }
        sum / n
    };
    let third = rgb.width / 3;
    [mean_of(0..third), mean_of(2 * third..rgb.width)]
}

/// `a` and `b` next to each other.
fn side_by_side(a: &Framebuffer, b: &Framebuffer) -> Image {
    let (w, h) = (a.width as usize, a.height as usize);
    let mut out = Image::new(2 * w, h, 3);
    for y in 0..h {
        for (i, img) in [a, b].into_iter().enumerate() {
            for x in 0..w {
                for c in 0..3 {
                    out.data[(y * 2 * w + i * w + x) * 3 + c] = img.get(x as u32, y as u32, c);
                }
            }
        }
    }
    out
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let picture = std::env::args().nth(1);
    let (size, spp) = if picture.is_some() {
        ("256", 64)
    } else {
        ("64", 16)
    };
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cornell-box.xml");
    let defines = [("resx", size), ("resy", size)].map(|(k, v)| (k.to_string(), v.to_string()));
    let mut loaded = load_scene(&file, &defines)?;
    let scene = &mut loaded.scene;

    println!(
        "{} editable parameters, among them:",
        scene.parameters().len()
    );
    for p in scene
        .parameters()
        .iter()
        .filter(|p| p.key.starts_with("LeftWall"))
    {
        let value = p
            .value
            .as_ref()
            .map_or("default".to_string(), |v| v.to_string());
        println!("  {} = {value}", p.key);
    }

    let before = render_rgb(scene, loaded.integrator.as_ref(), spp);
    let [left, right] = thirds(&before);
    println!("before: left third {left}, right third {right}");

    // A blue left wall and a warmer, brighter light: materials and
    // emitters change in place; the geometry is not touched.
    let builds = scene.rebuild_counts().bvh_builds;
    scene.update(
        "LeftWallBSDF.bsdf.reflectance.value",
        ParamValue::Color(Rgb::new(0.05, 0.1, 0.6)),
    )?;
    scene.update(
        "Light.emitter.radiance.value",
        ParamValue::Color(Rgb::new(24.0, 18.0, 10.0)),
    )?;
    assert_eq!(scene.rebuild_counts().bvh_builds, builds);
    let after = render_rgb(scene, loaded.integrator.as_ref(), spp);
    let [left, right] = thirds(&after);
    println!("after:  left third {left}, right third {right}");
    if let Some(picture) = picture {
        write_png(Path::new(&picture), &side_by_side(&before, &after))?;
        println!("wrote {picture}");
    }

    // A bad value is refused with the key and what is allowed; the scene
    // stays as it was.
    let bad = scene.update(
        "LeftWallBSDF.bsdf.reflectance.value",
        ParamValue::Color(Rgb::new(-1.0, 0.0, 0.0)),
    );
    println!("refused: {}", bad.expect_err("a negative reflectance"));
    Ok(())
}
