//! The Bitterli Cornell box (`../shared/assets/cornell-box-bitterli`)
//! against its independent Tungsten reference, on a 256×256 crop of the
//! 1024×1024 image (the floor and both boxes) to keep the test short.
//!
//! The bar is Mitsuba 3's own render at the same spp on the same crop:
//! Mitsuba 3.9.1 `scalar_rgb`, 64 spp, gives relMSE 0.001483 on this crop
//! (`scripts/mitsuba-ref render scene_v3.xml --strip-legacy --spp 64`;
//! crop (256, 512) + 256²). yubin must be within 10 % of that, with a
//! mean-luminance bias under 0.5 %.

mod common;

use common::shared_or_skip;
use yubin_core::render::{render, RenderSettings};
use yubin_scene::image_io::{read_image, ColorHandling};
use yubin_scene::load_scene;

const MITSUBA_REL_MSE: f64 = 0.001_483;
const CROP: [u32; 4] = [256, 512, 256, 256];

#[test]
fn cornell_box_matches_tungsten_as_well_as_mitsuba_shared() {
    let Some(shared) = shared_or_skip("cornell_box_matches_tungsten_as_well_as_mitsuba_shared")
    else {
        return;
    };
    let dir = shared.join("assets/cornell-box-bitterli");
    let mut loaded = load_scene(&dir.join("scene_v3.xml"), &[]).unwrap();
    loaded.scene.film.crop_offset = [CROP[0], CROP[1]];
    loaded.scene.film.crop_size = [CROP[2], CROP[3]];
    let out = render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &RenderSettings { spp: 64, seed: 0 },
        &|_| {},
    );
    let reference = read_image(&dir.join("TungstenRender.exr"), ColorHandling::Raw).unwrap();
    let (mut rel, mut lum_a, mut lum_b) = (0.0f64, 0.0f64, 0.0f64);
    for y in 0..CROP[3] {
        for x in 0..CROP[2] {
            let b = reference.rgb((x + CROP[0]) as usize, (y + CROP[1]) as usize);
            let a: [f32; 3] = std::array::from_fn(|c| out.image.get(x, y, c));
            for c in 0..3 {
                let (p, q) = (a[c] as f64, b[c] as f64);
                rel += (p - q) * (p - q) / (q * q + 0.01);
            }
            lum_a += 0.2126 * a[0] as f64 + 0.7152 * a[1] as f64 + 0.0722 * a[2] as f64;
            lum_b += 0.2126 * b[0] as f64 + 0.7152 * b[1] as f64 + 0.0722 * b[2] as f64;
        }
    }
    let rel_mse = rel / (3 * CROP[2] * CROP[3]) as f64;
    let bias = (lum_a - lum_b) / lum_b;
    println!(
        "relMSE {rel_mse:.6} (Mitsuba {MITSUBA_REL_MSE}), bias {:+.3}%",
        bias * 100.0
    );
    assert!(
        rel_mse <= 1.1 * MITSUBA_REL_MSE,
        "relMSE {rel_mse} is more than 10 % above Mitsuba's {MITSUBA_REL_MSE}"
    );
    assert!(
        bias.abs() < 0.005,
        "mean luminance off by {:.3}%",
        bias * 100.0
    );
}
