//! Ray-marched `sdf` shapes render what the same solids made of analytic
//! shapes render (per-pixel Z-tests, Mitsuba's method, the reference's
//! variance from yubin's `moment` integrator), and bad trees are refused
//! with their line.

use std::path::Path;
use yubin_core::render::{render, RenderSettings};
use yubin_core::testing::ztest::z_test;
use yubin_scene::load_scene_str;

/// A small lit scene around `shapes`, under `integrator`.
fn scene(integrator: &str, shapes: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
{integrator}
<sensor type="perspective"><float name="fov" value="40"/>
  <transform name="to_world"><lookat origin="3, -4, 3" target="0, 0, 0.3" up="0, 0, 1"/></transform>
  <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="24"/><rfilter type="box"/></film>
</sensor>
<emitter type="constant"><rgb name="radiance" value="0.3"/></emitter>
<emitter type="point"><point name="position" value="2, -1, 4"/><rgb name="intensity" value="20"/></emitter>
<bsdf type="diffuse" id="red"><rgb name="reflectance" value="0.8, 0.3, 0.2"/></bsdf>
<shape type="rectangle"><transform name="to_world"><scale value="5"/><translate z="-1.01"/></transform></shape>
{shapes}
</scene>"#
    )
}

const PATH: &str = r#"<integrator type="path"><integer name="max_depth" value="3"/></integrator>"#;

/// Renders `xml` at `spp`: the RGB values, interleaved.
fn render_rgb(xml: &str, spp: u32, seed: u32) -> (Vec<f32>, Vec<f32>) {
    let loaded = load_scene_str(xml, Path::new("test.xml"), &[]).unwrap_or_else(|e| panic!("{e}"));
    let out = render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &RenderSettings { spp, seed },
        &|_| {},
    );
    let c = out.image.channels;
    let mut rgb = Vec::new();
    let mut second = Vec::new();
    for px in out.image.data.chunks_exact(c) {
        rgb.extend_from_slice(&px[0..3]);
        if c >= 6 {
            second.extend((0..3).map(|i| (px[3 + i] - px[i] * px[i]).max(0.0)));
        }
    }
    (rgb, second)
}

/// Z-test of `test_shapes` at 256 spp against `reference_shapes` at 4096
/// (mean and per-sample variance from `moment`); a 5 % brighter image
/// must fail, so the test can tell.
fn assert_same_image(name: &str, test_shapes: &str, reference_shapes: &str) {
    let moment = format!(r#"<integrator type="moment">{PATH}</integrator>"#);
    let (mean, var) = render_rgb(&scene(&moment, reference_shapes), 4096, 1);
    let spp = 256;
    let (test, _) = render_rgb(&scene(PATH, test_shapes), spp, 2);
    let report = z_test(&test, spp, &mean, &var, 0.01);
    println!("{name}: {report:?}");
    assert!(report.passed, "{name}: {report:?}");
    let brighter: Vec<f32> = test.iter().map(|v| v * 1.05).collect();
    assert!(
        !z_test(&brighter, spp, &mean, &var, 0.01).passed,
        "{name}: the test cannot tell a 5 % bias"
    );
}

#[test]
fn sdf_sphere_renders_as_the_analytic_sphere() {
    assert_same_image(
        "sphere",
        r#"<shape type="sdf"><sdf type="sphere"><point name="center" value="0, 0, 0.2"/></sdf><ref id="red"/></shape>"#,
        r#"<shape type="sphere"><point name="center" value="0, 0, 0.2"/><ref id="red"/></shape>"#,
    );
}

#[test]
fn sdf_box_renders_as_the_cube() {
    let place = r#"<transform name="to_world"><scale x="0.8" y="0.6" z="0.5"/><rotate z="1" angle="30"/><translate z="-0.2"/></transform>"#;
    assert_same_image(
        "box",
        &format!(r#"<shape type="sdf"><sdf type="box"/>{place}<ref id="red"/></shape>"#),
        &format!(r#"<shape type="cube">{place}<ref id="red"/></shape>"#),
    );
}

#[test]
fn sdf_cylinder_renders_as_a_cylinder_with_two_disks() {
    let (p0, p1, r) = ("-0.3, 0.2, -0.5", "0.4, -0.3, 0.9", "0.6");
    // The caps: disks at p0 (facing away from p1) and p1, turned from +z
    // to the axis (0.7, -0.5, 1.4) by rotation about z × axis.
    let axis = glam::Vec3::new(0.7, -0.5, 1.4).normalize();
    let about = glam::Vec3::Z.cross(axis).normalize();
    let angle = axis.z.acos().to_degrees();
    let cap = |at: &str, flip: bool| {
        format!(
            r#"<shape type="disk"><boolean name="flip_normals" value="{flip}"/>
            <transform name="to_world"><scale value="{r}"/><rotate x="{}" y="{}" z="{}" angle="{angle}"/><translate value="{at}"/></transform>
            <ref id="red"/></shape>"#,
            about.x, about.y, about.z
        )
    };
    assert_same_image(
        "cylinder",
        &format!(
            r#"<shape type="sdf"><sdf type="cylinder"><point name="p0" value="{p0}"/><point name="p1" value="{p1}"/><float name="radius" value="{r}"/></sdf><ref id="red"/></shape>"#
        ),
        &format!(
            r#"<shape type="cylinder"><point name="p0" value="{p0}"/><point name="p1" value="{p1}"/><float name="radius" value="{r}"/><ref id="red"/></shape>{}{}"#,
            cap(p0, true),
            cap(p1, false)
        ),
    );
}

#[test]
fn sdf_repeat_renders_as_instances() {
    let mut instances = String::new();
    for x in [-1.0, 0.0, 1.0] {
        for y in [-1.0, 0.0, 1.0] {
            instances += &format!(
                r#"<shape type="instance"><ref id="ball"/><transform name="to_world"><translate x="{x}" y="{y}"/></transform></shape>"#
            );
        }
    }
    assert_same_image(
        "repeat",
        r#"<shape type="sdf"><sdf type="repeat"><vector name="cell" value="1, 1, 0"/><vector name="limit" value="1, 1, 0"/>
              <sdf type="sphere"><float name="radius" value="0.35"/></sdf></sdf><ref id="red"/></shape>"#,
        &format!(
            r#"<shape type="shapegroup" id="ball"><shape type="sphere"><float name="radius" value="0.35"/><ref id="red"/></shape></shape>{instances}"#
        ),
    );
}

/// Loading `shapes` fails with a message holding `expected` and the line.
fn assert_refused(shapes: &str, expected: &str, line: usize) {
    let xml = scene(PATH, shapes);
    let err = match load_scene_str(&xml, Path::new("test.xml"), &[]) {
        Ok(_) => panic!("loaded: {shapes}"),
        Err(e) => e.to_string(),
    };
    assert!(err.contains(expected), "{err}");
    assert!(err.contains(&format!("test.xml:{line}")), "{err}");
}

#[test]
fn bad_sdf_trees_are_refused_with_their_line() {
    // The scene's shapes start on line 11.
    assert_refused(
        "<shape type=\"sdf\">\n<sdf type=\"sphere\"/>\n<sdf type=\"blob\"/></shape>",
        "unknown sdf type \"blob\"",
        13,
    );
    assert_refused(
        "<shape type=\"sdf\">\n<float name=\"step_factor\" value=\"1.5\"/><sdf type=\"sphere\"/></shape>",
        "step_factor",
        12,
    );
    assert_refused(
        "<shape type=\"sdf\">\n<float name=\"step_factor\" value=\"0\"/><sdf type=\"sphere\"/></shape>",
        "must be in (0, 1]",
        12,
    );
    assert_refused(
        "<shape type=\"sdf\"><sdf type=\"repeat\"><vector name=\"cell\" value=\"1, 1, 1\"/><sdf type=\"sphere\"/></sdf></shape>",
        "unbounded",
        11,
    );
    assert_refused("<shape type=\"sdf\"/>", "at least one nested <sdf>", 11);
    assert_refused(
        "<shape type=\"sdf\"><sdf type=\"difference\">\n<sdf type=\"sphere\"/></sdf></shape>",
        "at least two",
        11,
    );
    assert_refused(
        "<shape type=\"sdf\"><sdf type=\"sphere\"><float name=\"radius\" value=\"-1\"/></sdf>\n<emitter type=\"area\"/></shape>",
        "radius",
        11,
    );
    assert_refused(
        "<shape type=\"sdf\"><sdf type=\"sphere\"/>\n<emitter type=\"area\"/></shape>",
        "cannot carry an area emitter",
        11,
    );
    assert_refused(
        "<shape type=\"sdf\"><sdf type=\"sphere\"><float name=\"radiuss\" value=\"1\"/></sdf></shape>",
        "radiuss",
        11,
    );
}

/// A nested node's parameter is editable like any other: the edited scene
/// renders, bit for bit, what loading the edited file renders.
#[test]
fn sdf_parameters_are_editable() {
    use yubin_core::params::ParamValue;
    let file = |r: &str| {
        scene(
            PATH,
            &format!(
                r#"<shape type="sdf" id="blob"><sdf type="smooth_union"><float name="k" value="0.2"/>
                     <sdf type="sphere"><float name="radius" value="{r}"/></sdf>
                     <sdf type="box"><vector name="half_size" value="0.3, 0.3, 1"/></sdf></sdf><ref id="red"/></shape>"#
            ),
        )
    };
    let mut loaded = load_scene_str(&file("0.6"), Path::new("test.xml"), &[]).unwrap();
    let key = loaded
        .scene
        .parameters()
        .into_iter()
        .map(|p| p.key)
        .find(|k| k.starts_with("blob.") && k.ends_with(".radius"))
        .expect("the sphere's radius is listed");
    loaded.scene.update(&key, ParamValue::Float(0.8)).unwrap();
    let edited = render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &RenderSettings { spp: 4, seed: 1 },
        &|_| {},
    );
    let (fresh, _) = render_rgb(&file("0.8"), 4, 1);
    let edited: Vec<f32> = edited
        .image
        .data
        .chunks_exact(edited.image.channels)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    assert_eq!(edited, fresh, "{key}");
    assert!(loaded.scene.update(&key, ParamValue::Float(-1.0)).is_err());
}

/// The showcase scene loads and renders (small): finite, not black.
#[test]
fn showcase_scene_renders() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/implicit/sculpture.xml");
    let defines: Vec<(String, String)> = [("resx", "24"), ("resy", "16"), ("spp", "2")]
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    let loaded = yubin_scene::load_scene(&path, &defines).unwrap_or_else(|e| panic!("{e}"));
    let out = render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &RenderSettings { spp: 2, seed: 1 },
        &|_| {},
    );
    let data = &out.image.data;
    assert!(data.iter().all(|v| v.is_finite()));
    assert!(data.iter().sum::<f32>() / data.len() as f32 > 0.05);
}
