//! Cameras with a lens: `ptracer` (paths from the lights, connected
//! through the lens) converges to the image `path` renders with
//! `thinlens` and with `physical` (pentagonal, biased aperture with cat's
//! eye); `physical` focuses on its `lookat` target by default; bad camera
//! settings and `ptracer` with an `orthographic` sensor are load errors
//! with the line.

mod common;

use std::path::Path;
use yubin_core::render::{render, RenderSettings};
use yubin_scene::load_scene_str;

fn scene(integrator: &str, sensor: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
<integrator type="{integrator}"><integer name="max_depth" value="4"/></integrator>
{sensor}
<shape type="rectangle">
  <transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
  <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.6, 0.5"/></bsdf>
</shape>
<shape type="sphere">
  <point name="center" value="0.4, 0.4, -0.6"/><float name="radius" value="0.4"/>
  <bsdf type="roughplastic"><rgb name="diffuse_reflectance" value="0.2, 0.5, 0.8"/></bsdf>
</shape>
<shape type="sphere">
  <point name="center" value="-0.6, 0.2, 0.8"/><float name="radius" value="0.2"/>
  <emitter type="area"><rgb name="radiance" value="8, 6, 4"/></emitter>
</shape>
<shape type="rectangle">
  <transform name="to_world"><scale value="0.5"/><rotate x="1" angle="90"/><translate y="2.5"/></transform>
  <emitter type="area"><rgb name="radiance" value="6"/></emitter>
</shape>
</scene>"#
    )
}

fn sensor(kind: &str, params: &str) -> String {
    format!(
        r#"<sensor type="{kind}">
  {params}
  <transform name="to_world"><lookat origin="0, 1.5, 4" target="0, 0.3, 0" up="0, 1, 0"/></transform>
  <film type="hdrfilm"><integer name="width" value="12"/><integer name="height" value="10"/>
    <rfilter type="box"/></film>
</sensor>"#
    )
}

#[test]
fn ptracer_matches_path_through_a_thin_lens() {
    let s = sensor(
        "thinlens",
        r#"<float name="fov" value="45"/><float name="aperture_radius" value="0.3"/>"#,
    );
    common::assert_same_image(
        &scene("ptracer", &s),
        &scene("path", &s),
        48,
        16,
        "thinlens",
    );
}

#[test]
fn ptracer_matches_path_through_a_physical_lens() {
    let s = sensor(
        "physical",
        r#"<float name="focal_length" value="35"/><float name="f_stop" value="0.2"/>
           <integer name="blades" value="5"/><float name="aperture_bias" value="0.4"/>
           <float name="cats_eye" value="150"/><float name="focus_distance" value="3"/>"#,
    );
    common::assert_same_image(
        &scene("ptracer", &s),
        &scene("path", &s),
        48,
        16,
        "physical",
    );
}

/// Without `focus_distance`, `physical` focuses on the lookat target:
/// the same image, bit for bit, as the distance written out.
#[test]
fn physical_focuses_on_the_lookat_target() {
    let render_with = |focus: &str| {
        let xml = scene(
            "path",
            &sensor(
                "physical",
                &format!(r#"<float name="f_stop" value="0.5"/>{focus}"#),
            ),
        );
        let loaded = load_scene_str(&xml, Path::new("focus.xml"), &[]).unwrap();
        render(
            &loaded.scene,
            loaded.integrator.as_ref(),
            &RenderSettings { spp: 4, seed: 1 },
            &|_| {},
        )
        .image
        .data
    };
    let distance = (1.2f32 * 1.2 + 4.0 * 4.0).sqrt();
    let explicit = format!(r#"<float name="focus_distance" value="{distance}"/>"#);
    let (a, b) = (render_with(""), render_with(&explicit));
    let worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-3, "largest difference {worst}");
    let blurred = render_with(r#"<float name="focus_distance" value="1"/>"#);
    assert_ne!(a, blurred);
}

#[test]
fn bad_camera_settings_are_load_errors_with_the_line() {
    for (kind, params, says) in [
        ("physical", r#"<float name="f_stop" value="0"/>"#, "f_stop"),
        ("physical", r#"<float name="f_stop" value="-2"/>"#, "f_stop"),
        (
            "physical",
            r#"<integer name="blades" value="1"/>"#,
            "blades",
        ),
        (
            "physical",
            r#"<integer name="blades" value="2"/>"#,
            "blades",
        ),
        (
            "physical",
            r#"<float name="focus_distance" value="0"/>"#,
            "focus_distance",
        ),
        (
            "physical",
            r#"<float name="aperture_bias" value="-1"/>"#,
            "aperture_bias",
        ),
        (
            "thinlens",
            r#"<float name="fov" value="40"/><float name="aperture_radius" value="0.1"/><float name="focus_distance" value="-1"/>"#,
            "focus_distance",
        ),
        (
            "thinlens",
            r#"<float name="fov" value="40"/>"#,
            "aperture_radius",
        ),
        (
            "perspective",
            r#"<string name="fov_axis" value="z"/>"#,
            "fov_axis",
        ),
        (
            "perspective",
            r#"<float name="focus_distance" value="0"/>"#,
            "focus_distance",
        ),
    ] {
        let xml = scene("path", &sensor(kind, params));
        let Err(e) = load_scene_str(&xml, Path::new("bad.xml"), &[]) else {
            panic!("{kind} with {params} loaded");
        };
        let e = e.to_string();
        assert!(
            e.contains("bad.xml:") && e.contains(says),
            "{kind} {params}: {e}"
        );
    }
}

#[test]
fn ptracer_refuses_an_orthographic_sensor() {
    let xml = scene("ptracer", &sensor("orthographic", ""));
    let Err(e) = load_scene_str(&xml, Path::new("ortho.xml"), &[]) else {
        panic!("ptracer with an orthographic sensor loaded");
    };
    let e = e.to_string();
    assert!(
        e.contains("ortho.xml:3") && e.contains("orthographic"),
        "{e}"
    );
}

/// `scenes/bokeh.xml` (the README's depth-of-field sheet) loads and renders
/// with every aperture the sheet shows.
#[test]
fn bokeh_scene_renders_with_every_aperture() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/bokeh.xml");
    for extra in [
        None,
        Some(("blades", "5")),
        Some(("bias", "0.6")),
        Some(("cats_eye", "170")),
    ] {
        let mut defines = vec![
            ("resx".to_string(), "24".to_string()),
            ("resy".to_string(), "16".to_string()),
            ("spp".to_string(), "4".to_string()),
        ];
        if let Some((k, v)) = extra {
            defines.push((k.to_string(), v.to_string()));
        }
        let loaded = yubin_scene::load_scene(&path, &defines).unwrap();
        assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
        let image = render(
            &loaded.scene,
            loaded.integrator.as_ref(),
            &RenderSettings { spp: 4, seed: 0 },
            &|_| {},
        )
        .image
        .data;
        assert!(image.iter().all(|v| v.is_finite()) && image.iter().sum::<f32>() > 0.0);
    }
}

/// A `batch` of radiancemeters (each held to its own 1 × 1 film, as in
/// Mitsuba) under the `depth` integrator reads each meter's distance, left
/// to right in the order written (Mitsuba 3.9.1: 4.99991, 6.99991,
/// 8.99991); a film whose width the sensors do not divide, an empty batch
/// and a batch in a batch are refused at their line.
#[test]
fn batch_places_its_sensors_left_to_right() {
    let meter = |z: f32| {
        format!(
            r#"<sensor type="radiancemeter"><point name="origin" value="0, 0, {z}"/><vector name="direction" value="0, 0, -1"/>
  <film type="hdrfilm"><integer name="width" value="1"/><integer name="height" value="1"/></film></sensor>"#
        )
    };
    let xml = |inner: &str, width: u32| {
        format!(
            r#"<scene version="3.0.0">
<integrator type="depth"/>
<sensor type="batch">
{inner}
  <film type="hdrfilm"><integer name="width" value="{width}"/><integer name="height" value="1"/><rfilter type="box"/></film>
</sensor>
<shape type="rectangle"/>
</scene>"#
        )
    };
    let three = format!("{}{}{}", meter(5.0), meter(7.0), meter(9.0));
    let loaded = load_scene_str(&xml(&three, 3), Path::new("batch.xml"), &[]).unwrap();
    let out = render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &RenderSettings { spp: 4, seed: 0 },
        &|_| {},
    );
    let depths: Vec<f32> = out.image.data.chunks_exact(3).map(|c| c[0]).collect();
    for (got, want) in depths.iter().zip([5.0f32, 7.0, 9.0]) {
        assert!((got - (want - 8.94e-5)).abs() < 1e-4, "{depths:?}");
    }
    let error = |text: &str| match load_scene_str(text, Path::new("batch.xml"), &[]) {
        Ok(_) => panic!("{text} loaded"),
        Err(e) => e.to_string(),
    };
    let e = error(&xml(&three, 4));
    assert!(
        e.contains("batch.xml:3") && e.contains("multiple of its number of sensors (3)"),
        "{e}"
    );
    let e = error(&xml("", 3));
    assert!(e.contains("needs at least one nested sensor"), "{e}");
    let e = error(&xml(r#"<sensor type="batch"/>"#, 3));
    assert!(e.contains("cannot hold another batch"), "{e}");
}

/// An `irradiancemeter` written in a square measures the mean irradiance
/// over it: under a parallel square emitter of radiance 1 one unit above,
/// π times the form factor, computed here by quadrature (Mitsuba 3.9.1
/// reads 1.30092 for 1.30456). On a 2 × 2 film each pixel measures its
/// quarter of the square (column ↔ x, row ↔ y, as Mitsuba samples it):
/// with the emitter moved over the (+x, +y) corner, that pixel reads
/// most. Outside a shape, it is refused.
#[test]
fn irradiancemeter_measures_the_mean_irradiance_over_its_shape() {
    let xml = |film: u32, shift: f32| {
        format!(
            r#"<scene version="3.0.0">
<integrator type="path"/>
<shape type="rectangle">
  <sensor type="irradiancemeter">
    <film type="hdrfilm"><integer name="width" value="{film}"/><integer name="height" value="{film}"/><rfilter type="box"/></film>
  </sensor>
</shape>
<shape type="rectangle">
  <transform name="to_world"><rotate x="1" angle="180"/><translate x="{shift}" y="{shift}" z="1"/></transform>
  <emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>
</shape>
</scene>"#
        )
    };
    // E at (x, y, 0) from the emitter [−1, 1]² + shift at z = 1, averaged
    // over the receiver region [x0, x1] × [y0, y1] (midpoint rule).
    let expected = |shift: f64, (x0, x1): (f64, f64), (y0, y1): (f64, f64)| {
        let n = 24;
        let mut sum = 0.0;
        for a in 0..n * n {
            let x = x0 + (x1 - x0) * ((a % n) as f64 + 0.5) / n as f64;
            let y = y0 + (y1 - y0) * ((a / n) as f64 + 0.5) / n as f64;
            for b in 0..n * n {
                let ex = -1.0 + shift + 2.0 * ((b % n) as f64 + 0.5) / n as f64;
                let ey = -1.0 + shift + 2.0 * ((b / n) as f64 + 0.5) / n as f64;
                let r2 = (ex - x).powi(2) + (ey - y).powi(2) + 1.0;
                sum += 1.0 / (r2 * r2) * (4.0 / (n * n) as f64);
            }
        }
        sum / (n * n) as f64
    };
    let readings = |film: u32, shift: f32| -> Vec<Vec<f64>> {
        let loaded = load_scene_str(&xml(film, shift), Path::new("irr.xml"), &[]).unwrap();
        (0..8)
            .map(|seed| {
                let out = render(
                    &loaded.scene,
                    loaded.integrator.as_ref(),
                    &RenderSettings { spp: 4096, seed },
                    &|_| {},
                );
                out.image
                    .data
                    .chunks_exact(3)
                    .map(|c| f64::from(c[0]))
                    .collect()
            })
            .collect()
    };
    let z = |runs: &[Vec<f64>], pixel: usize, want: f64| {
        let v: Vec<f64> = runs.iter().map(|r| r[pixel]).collect();
        let (mean, se) = common::mean_and_error(&v);
        (mean - want) / se
    };
    let whole = expected(0.0, (-1.0, 1.0), (-1.0, 1.0));
    assert!((whole - 1.30456).abs() < 2e-3, "quadrature {whole}");
    let one = readings(1, 0.0);
    assert!(z(&one, 0, whole).abs() < 4.0, "z = {}", z(&one, 0, whole));
    assert!(z(&one, 0, whole * 1.03).abs() > 4.0, "a 3 % error passes");
    let quarters = readings(2, 0.6);
    for (pixel, (xs, ys)) in [
        ((-1.0, 0.0), (-1.0, 0.0)),
        ((0.0, 1.0), (-1.0, 0.0)),
        ((-1.0, 0.0), (0.0, 1.0)),
        ((0.0, 1.0), (0.0, 1.0)),
    ]
    .into_iter()
    .enumerate()
    {
        let want = expected(0.6, xs, ys);
        let zs = z(&quarters, pixel, want);
        assert!(zs.abs() < 4.0, "pixel {pixel}: z = {zs} (expected {want})");
    }
    let outside =
        r#"<scene version="3.0.0"><sensor type="irradiancemeter"/><shape type="disk"/></scene>"#;
    let e = match load_scene_str(outside, Path::new("irr.xml"), &[]) {
        Ok(_) => panic!("an irradiancemeter outside a shape loaded"),
        Err(e) => e.to_string(),
    };
    assert!(
        e.contains("irr.xml:1") && e.contains("put it inside a <shape>"),
        "{e}"
    );
}

/// A `distant` sensor reads the radiance a diffuse square (ρ = 0.5, lit
/// straight down by irradiance 1) sends along −d, averaged over its
/// target, as Mitsuba 3.9.1 does: ρ/π over the square itself (obliquely
/// too) or at a point of it, a quarter of that over a target twice as
/// wide, the square's share of the bounding sphere's disk without a
/// target, nothing from behind, and its share of a mesh target's area.
#[test]
fn distant_averages_over_its_target() {
    let reading = |direction: &str, target: &str| -> (f64, f64) {
        let xml = format!(
            r#"<scene version="3.0.0">
<integrator type="path"/>
<sensor type="distant">
  <vector name="direction" value="{direction}"/>
  {target}
  <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="1"/><rfilter type="box"/></film>
</sensor>
<emitter type="directional"><vector name="direction" value="0, 0, -1"/><rgb name="irradiance" value="1, 1, 1"/></emitter>
<shape type="rectangle"><bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf></shape>
</scene>"#
        );
        let loaded =
            load_scene_str(&xml, Path::new("distant.xml"), &[]).unwrap_or_else(|e| panic!("{e}"));
        let out = render(
            &loaded.scene,
            loaded.integrator.as_ref(),
            &RenderSettings { spp: 2048, seed: 4 },
            &|_| {},
        );
        let (mean, se) = common::pixel_mean_and_error(&out.image.data, 0);
        (mean, se.max(1e-6))
    };
    let lambert = 0.5 / std::f64::consts::PI;
    let rect = r#"<shape type="rectangle" name="target"/>"#;
    let dir = common::scratch_dir("distant");
    let ply = dir.join("strip.ply");
    std::fs::write(
        &ply,
        "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\n\
         element face 4\nproperty list uchar int vertex_indices\nend_header\n\
         0 -1 0\n1 -1 0\n1 1 0\n0 1 0\n3 -1 0\n3 1 0\n3 0 1 2\n3 0 2 3\n3 1 4 5\n3 1 5 2\n",
    )
    .unwrap();
    let mesh_target = format!(
        r#"<shape type="ply" name="target"><string name="filename" value="{}"/></shape>"#,
        ply.display()
    );
    let wide = r#"<shape type="rectangle" name="target"><transform name="to_world"><scale value="2"/></transform></shape>"#;
    for (direction, target, want) in [
        ("0, 0.6, -0.8", rect, lambert),
        (
            "0, 0, -1",
            r#"<point name="target" value="0.2, 0.3, 0"/>"#,
            lambert,
        ),
        ("0, 0, -1", wide, lambert / 4.0),
        // The square's 4 of the disk's π·2 (the sphere of its box, R = √2).
        ("0, 0, -1", "", lambert * 4.0 / (2.0 * std::f64::consts::PI)),
        ("0, 0, 1", rect, 0.0),
        // A mesh of unequal triangles over [0, 3] × [−1, 1]: the square
        // holds 2 of its 6 units of area (1/2 if triangles were chosen
        // uniformly).
        ("0, 0, -1", &mesh_target, lambert / 3.0),
    ] {
        let (mean, se) = reading(direction, target);
        let z = (mean - want) / se;
        assert!(
            z.abs() < 4.0,
            "{direction} {target}: {mean} ± {se}, expected {want}"
        );
    }
    let both = r#"<scene version="3.0.0"><sensor type="distant"><vector name="direction" value="0,0,1"/>
<transform name="to_world"><translate x="1"/></transform>
<film type="hdrfilm"><integer name="width" value="1"/><integer name="height" value="1"/></film></sensor><shape type="disk"/></scene>"#;
    let e = match load_scene_str(both, Path::new("distant.xml"), &[]) {
        Ok(_) => panic!("direction and to_world both loaded"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("distant.xml:1") && e.contains("not both"), "{e}");
}
