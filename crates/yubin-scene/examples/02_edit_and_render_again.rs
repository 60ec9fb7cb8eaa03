//! Load a scene once, render it, edit it in place and render it again:
//! a wall's colour, the light's radiance and the camera, with no reload
//! and no BVH rebuilt (`Scene::parameters`, `Scene::update`).
//!
//! ```sh
//! cargo run --release -p yubin-scene --example 02_edit_and_render_again
//! ```

use std::path::Path;
use yubin_core::params::ParamValue;
use yubin_core::render::{render, RenderSettings};
use yubin_core::{Rgb, Scene};
use yubin_scene::load_scene;

/// Mean RGB of the left and right thirds of a small render.
fn render_thirds(scene: &Scene, integrator: &dyn yubin_core::integrator::Integrator) -> [Rgb; 2] {
    let out = render(
        scene,
        integrator,
        &RenderSettings { spp: 16, seed: 0 },
        &|_| {},
    );
    let rgb = out.image.select_channels(0..3);
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

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cornell-box.xml");
    let defines = [("resx", "64"), ("resy", "64")].map(|(k, v)| (k.to_string(), v.to_string()));
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

    let [left, right] = render_thirds(scene, loaded.integrator.as_ref());
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
    let [left, right] = render_thirds(scene, loaded.integrator.as_ref());
    println!("after:  left third {left}, right third {right}");

    // A bad value is refused with the key and what is allowed; the scene
    // stays as it was.
    let bad = scene.update(
        "LeftWallBSDF.bsdf.reflectance.value",
        ParamValue::Color(Rgb::new(-1.0, 0.0, 0.0)),
    );
    println!("refused: {}", bad.expect_err("a negative reflectance"));
    Ok(())
}
