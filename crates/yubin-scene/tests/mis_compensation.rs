//! MIS compensation (`path`'s `mis_compensation`, on by default): light
//! sampling leaves `constant` emitters to BSDF sampling and samples an
//! `envmap`'s excess over its mean. The image must stay the same in the
//! mean, with less noise.

mod common;

use common::{assert_same_image, render_statistics};
use yubin_scene::image_io::{write_image, Image};

/// A sky with a small bright sun and a gradient, as a lat-long map.
fn write_sky(path: &std::path::Path) {
    let (w, h) = (32usize, 16usize);
    let mut data = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        for x in 0..w {
            let sun = (9..11).contains(&x) && (4..6).contains(&y);
            let sky = 0.2 + 0.6 * (1.0 - y as f32 / h as f32);
            let v = if sun { 60.0 } else { sky };
            data.extend([v, 0.9 * v, 0.8 * v]);
        }
    }
    let img = Image {
        width: w,
        height: h,
        channels: 3,
        data,
    };
    write_image(path, &img, &[]).unwrap();
}

/// A fresh temporary folder named after `tag` with the sky map in it:
/// the folder and the map's path.
fn sky_in_temp_dir(tag: &str) -> (std::path::PathBuf, std::path::PathBuf) {
    let dir = std::env::temp_dir().join(format!(
        "yubin-mis-compensation-{tag}-{}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let map = dir.join("sky.exr");
    write_sky(&map);
    (dir, map)
}

/// Spheres of rough metal and rough plastic on a diffuse floor, lit by a
/// map, a constant sky and a small rectangle, rendered by `integrator`
/// with `mis_compensation` as `compensated`; `extra` adds shapes.
fn scene(map: &std::path::Path, integrator: &str, compensated: bool, extra: &str) -> String {
    let depth = match integrator {
        "direct" => "",
        _ => r#"<integer name="max_depth" value="4"/>"#,
    };
    format!(
        r#"<scene version="3.0.0">
    <integrator type="{integrator}">
        {depth}
        <boolean name="mis_compensation" value="{compensated}"/>
    </integrator>
    <sensor type="perspective">
        <float name="fov" value="45"/>
        <transform name="to_world"><lookat origin="0, 2, -5" target="0, 0.4, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm">
            <integer name="width" value="24"/>
            <integer name="height" value="18"/>
            <rfilter type="box"/>
        </film>
    </sensor>
    <emitter type="envmap"><string name="filename" value="{map}"/></emitter>
    <emitter type="constant"><rgb name="radiance" value="0.3"/></emitter>
    <shape type="rectangle">
        <transform name="to_world"><scale value="0.3"/><rotate x="1" angle="90"/><translate y="3"/></transform>
        <emitter type="area"><rgb name="radiance" value="20"/></emitter>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.6"/></bsdf>
    </shape>
    <shape type="sphere">
        <point name="center" x="-0.7" y="0.6" z="0"/><float name="radius" value="0.6"/>
        <bsdf type="roughconductor"><float name="alpha" value="0.2"/></bsdf>
    </shape>
    <shape type="sphere">
        <point name="center" x="0.7" y="0.6" z="0"/><float name="radius" value="0.6"/>
        <bsdf type="roughplastic"><float name="alpha" value="0.3"/></bsdf>
    </shape>
    {extra}
</scene>"#,
        map = map.display()
    )
}

/// A sphere of fog that scatters (light-sampled at its scattering
/// points) in front of the others, bounded by a `null` surface.
const FOG: &str = r#"<shape type="sphere">
        <point name="center" x="0" y="0.9" z="-1.2"/><float name="radius" value="0.7"/>
        <bsdf type="null"/>
        <medium type="homogeneous" name="interior">
            <rgb name="albedo" value="0.8"/><float name="sigma_t" value="1.5"/>
        </medium>
    </shape>"#;

/// `integrator` with and without compensation: the same image (Welch's t
/// per pixel, see `assert_same_image`) and less noise with it.
fn check_same_image_less_noise(integrator: &str, extra: &str) {
    let (dir, map) = sky_in_temp_dir(integrator);
    let on = scene(&map, integrator, true, extra);
    let off = scene(&map, integrator, false, extra);
    assert_same_mean_less_noise(integrator, &on, &off, 0.8);
    std::fs::remove_dir_all(&dir).ok();
}

/// `on` and `off` converge to the same image, and `on`'s summed variance
/// is below `most` times `off`'s.
fn assert_same_mean_less_noise(label: &str, on: &str, off: &str, most: f64) {
    assert_same_image(on, off, 16, 16, &format!("{label}: compensation on vs off"));
    let noise = |xml: &str| render_statistics(xml, 16, 16).1.iter().sum::<f64>();
    let (noise_on, noise_off) = (noise(on), noise(off));
    println!("{label}: summed variance {noise_on} with compensation, {noise_off} without");
    assert!(
        noise_on < most * noise_off,
        "{label}: summed variance {noise_on} with compensation, {noise_off} without"
    );
}

/// A `preetham` sky (with a widened, dimmed sun) in place of the map, the
/// constant sky and the area light: its table holds the sky's excess over
/// its mean.
#[test]
fn compensated_daylight_gives_the_same_image_with_less_noise() {
    let daylight = |compensated| {
        let xml = scene(std::path::Path::new("unused.exr"), "path", compensated, "");
        let (start, end) = (
            xml.find("<emitter type=\"envmap\">").unwrap(),
            // The floor: the first rectangle is the area light.
            xml.match_indices("<shape type=\"rectangle\">")
                .nth(1)
                .unwrap()
                .0,
        );
        format!(
            r#"{}<emitter type="preetham">
        <vector name="sun_direction" x="0.4" y="0.5" z="-0.6"/>
        <float name="sun_radius" value="3"/>
        <float name="sun_scale" value="0.0005"/>
        <float name="sky_scale" value="0.03"/>
    </emitter>
    {}"#,
            &xml[..start],
            &xml[end..]
        )
    };
    assert_same_mean_less_noise("preetham", &daylight(true), &daylight(false), 0.9);
}

#[test]
fn compensated_skies_give_the_same_image_with_less_noise() {
    check_same_image_less_noise("path", "");
}

#[test]
fn compensated_skies_in_direct_light_give_the_same_image_with_less_noise() {
    check_same_image_less_noise("direct", "");
}

/// Without BSDF samples, light sampling is `direct`'s only strategy and
/// keeps every emitter whole (else the sky would be lost), even a map that
/// asks for compensation itself.
#[test]
fn direct_light_sampling_alone_is_not_compensated() {
    let (dir, map) = sky_in_temp_dir("alone");
    let light_only = |compensated| {
        scene(&map, "direct", compensated, "").replace(
            "<boolean name=\"mis_compensation\"",
            "<integer name=\"bsdf_samples\" value=\"0\"/><boolean name=\"mis_compensation\"",
        )
    };
    // The compensated side's map asks for compensation itself too.
    let asked = light_only(true).replace(
        "<emitter type=\"envmap\">",
        "<emitter type=\"envmap\"><boolean name=\"mis_compensation\" value=\"true\"/>",
    );
    assert_same_image(
        &asked,
        &light_only(false),
        16,
        16,
        "direct, light samples only",
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn compensated_skies_through_fog_give_the_same_image_with_less_noise() {
    check_same_image_less_noise("volpath", FOG);
    check_same_image_less_noise("volpathmis", FOG);
}
