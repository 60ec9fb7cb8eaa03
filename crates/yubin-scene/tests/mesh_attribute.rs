//! `mesh_attribute` end to end: a PLY file with vertex and face colours,
//! loaded through a scene, evaluated at ray hits (expected values as
//! Mitsuba 3.9.1 gives them for the same file), and the load errors.

use glam::Vec3;
use std::path::PathBuf;
use yubin_core::math::Ray;
use yubin_core::texture::TextureModel;
use yubin_scene::{load_scene_str, LoadedScene};

/// A unit square in z = 0 as two triangles (0,1,2) and (0,2,3), with float
/// vertex colours (`r g b`) and face colours (`color_0..2`) and a face
/// weight (`weight_0`).
const SQUARE: &str = "ply
format ascii 1.0
element vertex 4
property float x
property float y
property float z
property float r
property float g
property float b
element face 2
property list uchar int vertex_indices
property float color_0
property float color_1
property float color_2
property float weight_0
end_header
0 0 0 1 0 0
1 0 0 0 1 0
1 1 0 0 0 1
0 1 0 1 1 1
3 0 1 2 0.1 0.2 0.3 0.25
3 0 2 3 1 2 3 0.75
";

/// Writes the PLY into a fresh temp directory; returns the scene path.
fn setup(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "yubin-mesh-attribute-{}-{name}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("square.ply"), SQUARE).unwrap();
    dir.join("scene.xml")
}

fn load(name: &str, shape: &str, texture_name: &str) -> Result<LoadedScene, String> {
    let xml = format!(
        r#"<scene version="3.0.0">
    <bsdf type="diffuse" id="m">
        <texture type="mesh_attribute" name="reflectance">
            <string name="name" value="{texture_name}"/>
            <float name="scale" value="2"/>
        </texture>
    </bsdf>
    {shape}
</scene>"#
    );
    load_scene_str(&xml, &setup(name), &[]).map_err(|e| e.to_string())
}

const PLY_SHAPE: &str = r#"<shape type="ply">
        <string name="filename" value="square.ply"/>
        <ref id="m"/>
    </shape>"#;

/// The texture at the point (x, y) of the square.
fn at(loaded: &LoadedScene, x: f32, y: f32) -> (Vec3, f32) {
    let scene = &loaded.scene;
    let si = scene
        .intersect(&Ray::new(Vec3::new(x, y, 1.0), -Vec3::Z))
        .expect("the ray hits the square");
    let t = &scene.materials.textures[0];
    (
        t.eval(&scene.materials, &si),
        t.eval_1(&scene.materials, &si),
    )
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() < 1e-5
}

#[test]
fn vertex_colours_interpolate_at_hits() {
    let loaded = load("vertex", PLY_SHAPE, "vertex_color").unwrap();
    // (0.7, 0.2) on triangle 0: barycentrics (0.3, 0.5, 0.2).
    let (c, _) = at(&loaded, 0.7, 0.2);
    assert!(close(c, 2.0 * Vec3::new(0.3, 0.5, 0.2)), "{c}");
    // (0.2, 0.7) on triangle 1 (0, 2, 3): barycentrics (0.3, 0.2, 0.5).
    let (c, _) = at(&loaded, 0.2, 0.7);
    assert!(close(c, 2.0 * Vec3::new(0.8, 0.5, 0.7)), "{c}");
}

#[test]
fn face_attributes_are_per_triangle() {
    let loaded = load("face", PLY_SHAPE, "face_color").unwrap();
    assert!(close(at(&loaded, 0.7, 0.2).0, Vec3::new(0.2, 0.4, 0.6)));
    assert!(close(at(&loaded, 0.2, 0.7).0, Vec3::new(2.0, 4.0, 6.0)));
    let loaded = load("weight", PLY_SHAPE, "face_weight").unwrap();
    let (c, v) = at(&loaded, 0.2, 0.7);
    assert!(
        close(c, Vec3::splat(1.5)) && (v - 1.5).abs() < 1e-6,
        "{c} {v}"
    );
}

#[test]
fn missing_attribute_is_a_load_error_at_the_shape() {
    let err = load("missing", PLY_SHAPE, "vertex_weight").unwrap_err();
    assert!(
        err.contains("scene.xml:8:")
            && err.contains("\"vertex_weight\"")
            && err.contains("is not in the mesh"),
        "{err}"
    );
    let sphere = r#"<shape type="sphere">
        <bsdf type="twosided"><ref id="m"/></bsdf>
    </shape>"#;
    let err = load("sphere", sphere, "vertex_color").unwrap_err();
    assert!(
        err.contains("scene.xml:8:") && err.contains("needs a mesh"),
        "{err}"
    );
    let err = load("prefix", PLY_SHAPE, "color").unwrap_err();
    assert!(
        err.contains("must start with \"vertex_\" or \"face_\""),
        "{err}"
    );
}

#[test]
fn unused_texture_needs_no_attribute() {
    let cube = r#"<shape type="cube"/>"#;
    assert!(load("unused", cube, "vertex_nothing").is_ok());
}
