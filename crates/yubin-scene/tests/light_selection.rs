//! Choosing lights: every `light_sampler` converges to the same image on a
//! scene with lights of every kind, `visible` / `visible_indirect` hide an
//! emitter from camera and indirect rays while it still lights the scene,
//! and bad settings are load errors with the line.

use std::path::Path;
use yubin_core::render::{render, RenderSettings};
use yubin_scene::load_scene_str;

/// A floor and a diffuse box lit by an area rectangle, an emissive sphere,
/// an emissive cube mesh, a point light, a spot light and a dim sky.
/// `integrator` is XML; `light` the sphere's emitter's extra parameters.
fn scene(integrator: &str, light: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
    {integrator}
    <sensor type="perspective">
        <float name="fov" value="60"/>
        <transform name="to_world"><lookat origin="0, 3, 4" target="0, 0.5, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/>
            <rfilter type="box"/></film>
    </sensor>
    <shape type="rectangle">
        <transform name="to_world"><rotate x="1" angle="-90"/><scale value="4"/></transform>
        <bsdf type="diffuse"/>
    </shape>
    <shape type="cube">
        <transform name="to_world"><scale value="0.4"/><translate x="-1" y="0.4"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.6, 0.3"/></bsdf>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="0.4"/><rotate x="1" angle="90"/><translate y="1.5" x="0.5"/></transform>
        <emitter type="area"><rgb name="radiance" value="10"/></emitter>
    </shape>
    <shape type="sphere">
        <point name="center" value="1.2, 0.4, 0.8"/><float name="radius" value="0.4"/>
        <emitter type="area"><rgb name="radiance" value="16, 8, 4"/>{light}</emitter>
    </shape>
    <shape type="cube">
        <transform name="to_world"><scale value="0.15"/><translate x="-1.5" y="1" z="1"/></transform>
        <emitter type="area"><rgb name="radiance" value="0.5, 1, 3"/></emitter>
    </shape>
    <emitter type="point"><point name="position" value="-0.5, 2, -1"/><rgb name="intensity" value="3"/></emitter>
    <emitter type="spot">
        <rgb name="intensity" value="20"/><float name="cutoff_angle" value="25"/>
        <transform name="to_world"><lookat origin="2, 3, 0" target="0.5, 0, 0" up="0, 1, 0"/></transform>
    </emitter>
    <emitter type="constant"><rgb name="radiance" value="0.05"/></emitter>
</scene>"#
    )
}

fn render_xml(xml: &str, spp: u32) -> Vec<f32> {
    let loaded = load_scene_str(xml, Path::new("scene.xml"), &[]).unwrap();
    render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &RenderSettings { spp, seed: 11 },
        &|_| {},
    )
    .image
    .data
}

/// Mean of each colour channel over the pixels `keep` accepts.
fn channel_means(img: &[f32], keep: impl Fn(usize) -> bool) -> [f64; 3] {
    let (mut m, mut n) = ([0.0; 3], 0);
    for (i, px) in img.chunks_exact(3).enumerate() {
        if keep(i) {
            for c in 0..3 {
                m[c] += f64::from(px[c]);
            }
            n += 1;
        }
    }
    m.map(|v| v / n as f64)
}

fn path(light_sampler: &str) -> String {
    format!(
        r#"<integrator type="path"><integer name="max_depth" value="3"/><string name="light_sampler" value="{light_sampler}"/></integrator>"#
    )
}

/// Image-mean of each channel over `K` renders (seeds 0..K) of `xml`: the
/// mean and its standard error.
fn image_means(xml: &str, spp: u32) -> ([f64; 3], [f64; 3]) {
    const K: u32 = 8;
    let loaded = load_scene_str(xml, Path::new("scene.xml"), &[]).unwrap();
    let runs: Vec<[f64; 3]> = (0..K)
        .map(|seed| {
            let img = render(
                &loaded.scene,
                loaded.integrator.as_ref(),
                &RenderSettings { spp, seed },
                &|_| {},
            )
            .image
            .data;
            channel_means(&img, |_| true)
        })
        .collect();
    let k = K as f64;
    let mean = [0, 1, 2].map(|c| runs.iter().map(|r| r[c]).sum::<f64>() / k);
    let se = [0, 1, 2].map(|c| {
        let var = runs.iter().map(|r| (r[c] - mean[c]).powi(2)).sum::<f64>() / (k - 1.0);
        (var / k).sqrt()
    });
    (mean, se)
}

/// Two estimates of the same image mean agree: |a − b| within 5 combined
/// standard errors (with 7 + 7 degrees of freedom, a correct pair fails
/// about 1 in 5000), and within 1 % (so that a noisy pair cannot pass
/// everything).
fn assert_same_means(label: &str, a: ([f64; 3], [f64; 3]), b: ([f64; 3], [f64; 3])) {
    for c in 0..3 {
        let se = (a.1[c].powi(2) + b.1[c].powi(2)).sqrt();
        assert!(se < 0.003 * b.0[c], "{label}: too noisy to tell ({se})");
        assert!(
            (a.0[c] - b.0[c]).abs() < 5.0 * se,
            "{label}: channel {c}: {} vs {} (standard error {se})",
            a.0[c],
            b.0[c]
        );
    }
}

#[test]
fn every_light_sampler_converges_to_the_same_image() {
    let reference = image_means(&scene(&path("bvh"), ""), 2048);
    for sampler in ["uniform", "power"] {
        let m = image_means(&scene(&path(sampler), ""), 2048);
        assert_same_means(sampler, m, reference);
    }
    // Uneven sampling weights change the noise, not the image.
    let weighted = r#"<float name="sampling_weight" value="5"/>"#;
    let m = image_means(&scene(&path("uniform"), weighted), 2048);
    assert_same_means("sampling_weight 5", m, reference);
}

#[test]
fn invisible_lights_still_light_the_scene() {
    let shown = render_xml(&scene(&path("bvh"), ""), 256);
    let hidden = render_xml(
        &scene(&path("bvh"), r#"<boolean name="visible" value="false"/>"#),
        256,
    );
    // The camera sees the sphere light (red radiance 16) in some pixels...
    let light_pixels: Vec<usize> = (0..shown.len() / 3)
        .filter(|&i| shown[3 * i] > 12.0)
        .collect();
    assert!(!light_pixels.is_empty());
    // ... which go dark when it is invisible,
    for &i in &light_pixels {
        assert!(hidden[3 * i] < 4.0, "pixel {i}: {}", hidden[3 * i]);
    }
    // while everything else is lit as before.
    let elsewhere = |i: usize| shown[3 * i] < 4.0;
    let (a, b) = (
        channel_means(&shown, elsewhere),
        channel_means(&hidden, elsewhere),
    );
    for c in 0..3 {
        assert!((a[c] - b[c]).abs() < 0.03 * a[c], "{a:?} vs {b:?}");
    }
    // Hidden from indirect rays too, it lights the scene by light sampling
    // alone, unbiased (its light samples take the whole MIS weight).
    let both = render_xml(
        &scene(
            &path("bvh"),
            r#"<boolean name="visible" value="false"/><boolean name="visible_indirect" value="false"/>"#,
        ),
        256,
    );
    let m = channel_means(&both, elsewhere);
    for c in 0..3 {
        assert!((m[c] - a[c]).abs() < 0.03 * a[c], "{m:?} vs {a:?}");
    }
}

#[test]
fn bad_light_settings_are_errors_with_the_line() {
    for (integrator, light, needle) in [
        (path("nearest"), "", "light_sampler"),
        (
            path("bvh"),
            r#"<float name="sampling_weight" value="-1"/>"#,
            "sampling_weight",
        ),
    ] {
        let xml = scene(&integrator, light);
        let line = xml.lines().position(|l| l.contains(needle)).unwrap() + 1;
        let err = load_scene_str(&xml, Path::new("scene.xml"), &[])
            .unwrap_err()
            .to_string();
        assert!(err.contains(&format!("scene.xml:{line}:")), "{err}");
        assert!(err.contains(needle), "{err}");
    }
}
