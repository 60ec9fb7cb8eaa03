//! `ptracer` (paths from the lights) converges to the same image as `path`
//! (paths from the camera) on scenes it can render — diffuse and rough
//! surfaces, a rough glass sphere (refraction in importance mode), area,
//! spot, projector, directional and environment lights — and its image is
//! bit-identical on any thread count.
//!
//! Comparison: K independent renders of each integrator (seeds 0..K); per
//! pixel and channel, Welch's t = (mean_pt − mean_path) / √(s²_pt/K +
//! s²_path/K) must stay within a bound that a correct pair exceeds with
//! probability below 10⁻⁴ per image, and the two images' means must agree
//! within 4 standard errors. A missing factor (π, a cosine, η²) moves the
//! mean by far more.

mod common;

use std::path::Path;
use yubin_core::render::{render, RenderSettings};
use yubin_scene::build::load_scene_str;

const SIZE: u32 = 12;

fn scene(integrator: &str, lights: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
<integrator type="{integrator}"><integer name="max_depth" value="6"/></integrator>
<sensor type="perspective">
  <float name="fov" value="50"/>
  <transform name="to_world"><lookat origin="0, 1.2, 4" target="0, 0.3, 0" up="0, 1, 0"/></transform>
  <film type="hdrfilm"><integer name="width" value="{SIZE}"/><integer name="height" value="{SIZE}"/>
    <rfilter type="gaussian"/></film>
</sensor>
<bsdf type="diffuse" id="white"><rgb name="reflectance" value="0.7, 0.6, 0.5"/></bsdf>
<shape type="rectangle">
  <transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
  <ref id="white"/>
</shape>
<shape type="rectangle">
  <transform name="to_world"><scale value="3"/><translate z="-1.5"/></transform>
  <bsdf type="roughconductor"><float name="alpha" value="0.3"/></bsdf>
</shape>
<shape type="sphere">
  <point name="center" value="-0.6, 0.5, 0"/><float name="radius" value="0.5"/>
  <bsdf type="roughdielectric"><float name="alpha" value="0.3"/></bsdf>
</shape>
<shape type="sphere">
  <point name="center" value="0.7, 0.4, 0.3"/><float name="radius" value="0.4"/>
  <bsdf type="roughplastic"><rgb name="diffuse_reflectance" value="0.2, 0.5, 0.8"/></bsdf>
</shape>
{lights}
</scene>"#
    )
}

const AREA: &str = r#"<shape type="rectangle">
  <transform name="to_world"><scale value="0.5"/><rotate x="1" angle="90"/><translate y="2.5"/></transform>
  <emitter type="area"><rgb name="radiance" value="8"/></emitter>
</shape>"#;

const DELTA_AND_INFINITE: &str = r#"<emitter type="spot">
  <rgb name="intensity" value="20"/><float name="cutoff_angle" value="35"/>
  <transform name="to_world"><lookat origin="1, 3, 1" target="0, 0, 0" up="0, 1, 0"/></transform>
</emitter>
<emitter type="projector">
  <float name="fov" value="40"/><rgb name="irradiance" value="0.3, 0.6, 0.9"/>
  <transform name="to_world"><lookat origin="-2, 2, 2" target="0, 0.3, 0" up="0, 1, 0"/></transform>
</emitter>
<emitter type="directional"><vector name="direction" value="0.3, -1, -0.4"/><rgb name="irradiance" value="0.8"/></emitter>
<emitter type="constant"><rgb name="radiance" value="0.3"/></emitter>"#;

fn assert_same_image(lights: &str, label: &str) {
    common::assert_same_image(
        &scene("ptracer", lights),
        &scene("path", lights),
        48,
        16,
        label,
    );
}

#[test]
fn ptracer_matches_path_with_an_area_light() {
    assert_same_image(AREA, "area light");
}

#[test]
fn ptracer_matches_path_with_delta_and_infinite_lights() {
    assert_same_image(DELTA_AND_INFINITE, "spot, projector, directional, constant");
}

#[test]
fn ptracer_image_is_the_same_on_any_thread_count() {
    let xml = scene("ptracer", &format!("{AREA}\n{DELTA_AND_INFINITE}"));
    let loaded = load_scene_str(&xml, Path::new("ptracer.xml"), &[]).unwrap();
    let render_on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            render(
                &loaded.scene,
                loaded.integrator.as_ref(),
                // More paths than one chunk, so that chunks are merged.
                &RenderSettings { spp: 200, seed: 5 },
                &|_| {},
            )
        })
        .image
        .data
    };
    let one = render_on(1);
    for threads in [2, 3] {
        let many = render_on(threads);
        assert!(
            one.iter()
                .zip(&many)
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "1 and {threads} threads differ"
        );
    }
}

#[test]
fn ptracer_cannot_be_nested() {
    let xml = scene("aov", AREA).replace(
        r#"<integrator type="aov"><integer name="max_depth" value="6"/></integrator>"#,
        r#"<integrator type="aov"><string name="aovs" value="d:depth"/>
<integrator type="ptracer" name="img"/></integrator>"#,
    );
    let Err(err) = load_scene_str(&xml, Path::new("nested.xml"), &[]) else {
        panic!("a nested ptracer must be refused");
    };
    let err = err.to_string();
    assert!(
        err.contains("nested.xml:3") && err.contains("cannot be nested"),
        "{err}"
    );
}

/// A `directionalarea` square tilted at 45° lights a floor patch with
/// irradiance E cos 45°: seen from straight above, the patch has radiance
/// ρ E cos 45° / π and the floor beside it is black. `path` cannot see
/// that light at all.
#[test]
fn directional_area_light_lights_its_footprint() {
    let xml = |integrator: &str| {
        format!(
            r#"<scene version="3.0.0">
<integrator type="{integrator}"/>
<sensor type="perspective">
  <float name="fov" value="40"/>
  <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
  <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/>
    <rfilter type="box"/></film>
</sensor>
<shape type="rectangle">
  <transform name="to_world"><scale value="4"/></transform>
  <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>
</shape>
<shape type="rectangle">
  <transform name="to_world"><scale value="0.5"/><rotate y="1" angle="135"/><translate x="-2.2" z="2.2"/></transform>
  <emitter type="directionalarea"><rgb name="radiance" value="3"/></emitter>
</shape>
</scene>"#
        )
    };
    let render_with = |integrator: &str| {
        let loaded = load_scene_str(&xml(integrator), Path::new("da.xml"), &[]).unwrap();
        render(
            &loaded.scene,
            loaded.integrator.as_ref(),
            &RenderSettings { spp: 256, seed: 1 },
            &|_| {},
        )
        .image
        .data
    };
    let img = render_with("ptracer");
    // The camera sees |x|, |y| < 5 tan 20° = 1.82; the footprint is
    // |x| < 0.71, |y| < 0.5 (a pixel is 0.23 wide).
    let at = |px: usize, py: usize| img[(py * 16 + px) * 3];
    let expected = 0.5 * 3.0 * std::f32::consts::FRAC_1_SQRT_2 / std::f32::consts::PI;
    let centre: f32 = [(7, 7), (8, 7), (7, 8), (8, 8), (6, 7), (9, 8)]
        .iter()
        .map(|&(x, y)| at(x, y))
        .sum::<f32>()
        / 6.0;
    assert!(
        (centre / expected - 1.0).abs() < 0.03,
        "{centre} vs {expected}"
    );
    for (x, y) in [(7, 1), (8, 14), (0, 8), (15, 7)] {
        assert_eq!(at(x, y), 0.0, "pixel ({x}, {y}) is outside the footprint");
    }
    assert!(render_with("path").iter().all(|&v| v == 0.0));
}
