//! Area lights inside a `shapegroup`: every instance of the group is a
//! light of its own, and the scene renders as if each instance's shapes
//! were written out in the world with the composed transforms — with
//! `path` (light sampling, MIS against hits through the instance) and
//! with `ptracer` (emission from the placed lights) — for a rectangle, a
//! sphere and a cube mesh placed by translations, a rotation with uniform
//! scale, a mirror and an uneven scale.

mod common;

use std::path::Path;
use yubin_scene::load_scene_str;

const SIZE: u32 = 12;

fn scene(integrator: &str, body: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
<integrator type="{integrator}"><integer name="max_depth" value="4"/></integrator>
<sensor type="perspective">
  <float name="fov" value="60"/>
  <transform name="to_world"><lookat origin="0, 2.5, 4" target="0, 0.6, 0" up="0, 1, 0"/></transform>
  <film type="hdrfilm"><integer name="width" value="{SIZE}"/><integer name="height" value="{SIZE}"/>
    <rfilter type="box"/></film>
</sensor>
<shape type="rectangle">
  <transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
  <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.6, 0.5"/></bsdf>
</shape>
{body}
</scene>"#
    )
}

/// The group's shapes, each with its own transform `(shape transform)`
/// followed by `placement` (Mitsuba composes a transform's elements in
/// the order written). With `sphere`, an emitting sphere too.
fn lights(placement: &str, sphere: bool) -> String {
    let sphere = if sphere {
        format!(
            r#"<shape type="sphere">
  <transform name="to_world"><scale value="0.2"/><translate x="0.5" y="0.3"/>{placement}</transform>
  <emitter type="area"><rgb name="radiance" value="4, 2, 1"/></emitter>
</shape>"#
        )
    } else {
        String::new()
    };
    format!(
        r#"<shape type="rectangle">
  <transform name="to_world"><scale x="0.3" y="0.2"/><rotate x="1" angle="60"/>{placement}</transform>
  <emitter type="area"><rgb name="radiance" value="6"/></emitter>
</shape>
<shape type="cube">
  <transform name="to_world"><scale value="0.15"/><translate x="-0.5" y="0.2"/>{placement}</transform>
  <emitter type="area"><rgb name="radiance" value="1, 2, 4"/></emitter>
</shape>
<shape type="cube">
  <transform name="to_world"><scale value="0.1"/><translate z="0.4" y="-0.2"/>{placement}</transform>
  <bsdf type="diffuse"/>
</shape>
{sphere}"#
    )
}

/// Placements: (transform elements, whether the sphere can go along).
const PLACEMENTS: [(&str, bool); 4] = [
    (r#"<translate x="-1" y="0.8"/>"#, true),
    (
        r#"<scale value="0.7"/><rotate y="1" angle="60"/><translate x="1" y="0.6" z="-0.5"/>"#,
        true,
    ),
    (r#"<scale x="-1"/><translate y="1.2" z="1"/>"#, true),
    (
        r#"<scale x="1.5" y="0.5"/><translate x="0.3" y="1.6" z="-1"/>"#,
        false,
    ),
];

/// The lights in shape groups, placed by instances.
fn instanced() -> String {
    let mut body = String::new();
    for (k, (placement, sphere)) in PLACEMENTS.iter().enumerate() {
        body += &format!(
            r#"<shape type="shapegroup" id="g{k}">{}</shape>
<shape type="instance"><ref id="g{k}"/><transform name="to_world">{placement}</transform></shape>
"#,
            lights("", *sphere)
        );
    }
    body
}

/// The same lights written out in the world.
fn flattened() -> String {
    PLACEMENTS
        .iter()
        .map(|(placement, sphere)| lights(placement, *sphere))
        .collect()
}

#[test]
fn every_instance_is_a_light() {
    let xml = scene("path", &instanced());
    let loaded = load_scene_str(&xml, Path::new("instanced.xml"), &[]).unwrap();
    // Rectangle and cube in every instance, the sphere in three.
    assert_eq!(loaded.scene.emitters.len(), 4 * 2 + 3);
}

#[test]
fn instanced_lights_render_as_written_out_with_path() {
    common::assert_same_image(
        &scene("path", &instanced()),
        &scene("path", &flattened()),
        32,
        16,
        "path",
    );
}

#[test]
fn instanced_lights_render_as_written_out_with_ptracer() {
    common::assert_same_image(
        &scene("ptracer", &instanced()),
        &scene("path", &flattened()),
        32,
        16,
        "ptracer",
    );
}

#[test]
fn an_unevenly_scaled_emitting_sphere_is_refused_at_its_instance() {
    let body = format!(
        r#"<shape type="shapegroup" id="g">{}</shape>
<shape type="instance"><ref id="g"/><transform name="to_world"><scale x="2"/></transform></shape>"#,
        lights("", true)
    );
    let Err(err) = load_scene_str(&scene("path", &body), Path::new("stretched.xml"), &[]) else {
        panic!("an ellipsoidal light must not load");
    };
    let err = err.to_string();
    assert!(
        err.contains("stretched.xml:") && err.contains("ellipsoid"),
        "{err}"
    );
}
