//! The procedural textures end to end: every example scene in
//! `scenes/textures/` loads and renders (tiny, finite, not black), nested
//! textures evaluate at ray hits through the scene's texture table, and bad
//! parameters are load errors naming the line.

use glam::Vec3;
use std::path::Path;
use yubin_core::math::Ray;
use yubin_core::render::{render, RenderSettings};
use yubin_core::texture::TextureModel;
use yubin_scene::{load_scene, load_scene_str, LoadedScene};

#[test]
fn example_scenes_load_and_render() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/textures");
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .collect();
    names.sort();
    assert!(names.len() >= 7, "{names:?}");
    let defines = [("res".to_string(), "12".to_string())];
    for path in names {
        let loaded = load_scene(&path, &defines).unwrap_or_else(|e| panic!("{e}"));
        let out = render(
            &loaded.scene,
            loaded.integrator.as_ref(),
            &RenderSettings { spp: 2, seed: 1 },
            &|_| {},
        );
        let data = &out.image.data;
        assert!(data.iter().all(|v| v.is_finite()), "{path:?}");
        let mean = data.iter().sum::<f32>() / data.len() as f32;
        assert!(mean > 0.05, "{path:?}: mean {mean}");
    }
}

fn load(name: &str, texture: &str) -> Result<LoadedScene, String> {
    let xml = format!(
        r#"<scene version="3.0.0">
    <!-- Read as a float with its colour's pattern (yubin's reading, not
         Mitsuba's swap), so that a texture's colour and value agree. -->
    <texture type="checkerboard" id="checks">
        <rgb name="color0" value="0.8"/>
        <rgb name="color1" value="0.2"/>
        <boolean name="consistent_float" value="true"/>
    </texture>
    <shape type="rectangle">
        <bsdf type="diffuse">
            {texture}
        </bsdf>
    </shape>
</scene>"#
    );
    let dir = std::env::temp_dir().join(format!("yubin-procedural-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    load_scene_str(&xml, &dir.join("scene.xml"), &[]).map_err(|e| e.to_string())
}

/// The reflectance texture (the last one built) at the rectangle's point
/// (x, y): one point in each checkerboard square for (±½, ±½).
fn at(loaded: &LoadedScene, x: f32, y: f32) -> (Vec3, f32) {
    let scene = &loaded.scene;
    let si = scene
        .intersect(&Ray::new(Vec3::new(x, y, 1.0), -Vec3::Z))
        .expect("the ray hits the rectangle");
    let t = scene.materials.textures.last().unwrap();
    (
        t.eval(&scene.materials, &si),
        t.eval_1(&scene.materials, &si),
    )
}

#[test]
fn nested_and_referenced_textures_evaluate() {
    // scale(mix(checks, 1, weight 0.25), 2): 2·(0.75·checks + 0.25).
    let loaded = load(
        "nested",
        r#"<texture type="scale" name="reflectance">
                <float name="scale" value="2"/>
                <texture type="mix" name="texture">
                    <ref id="checks" name="color0"/>
                    <rgb name="color1" value="1"/>
                    <float name="weight" value="0.25"/>
                </texture>
            </texture>"#,
    )
    .unwrap();
    let mut seen = Vec::new();
    for (x, y) in [(-0.5, 0.5), (0.5, 0.5), (-0.5, -0.5), (0.5, -0.5)] {
        let (c, v) = at(&loaded, x, y);
        assert!((c - Vec3::splat(v)).abs().max_element() < 1e-5, "{c}");
        seen.push((v * 1000.0).round() as i32);
    }
    seen.sort();
    // 2·(0.75·0.2 + 0.25) = 0.8 and 2·(0.75·0.8 + 0.25) = 1.7.
    assert_eq!(seen, vec![800, 800, 1700, 1700]);
}

#[test]
fn bad_parameters_name_the_line() {
    let cases = [
        (
            r#"<texture type="grid" name="reflectance">
                <float name="line_width" value="-0.1"/>
            </texture>"#,
            "\"line_width\"",
        ),
        (
            r#"<texture type="fbm" name="reflectance">
                <integer name="octaves" value="0"/>
            </texture>"#,
            "\"octaves\"",
        ),
        (
            r#"<texture type="fbm" name="reflectance">
                <float name="lacunarity" value="-2"/>
            </texture>"#,
            "\"lacunarity\"",
        ),
        (
            r#"<texture type="perlin" name="reflectance">
                <string name="space" value="object"/>
            </texture>"#,
            "\"space\"",
        ),
        (
            r#"<texture type="scale" name="reflectance">
                <float name="scale" value="2"/>
            </texture>"#,
            "\"texture\"",
        ),
        (
            r#"<texture type="normal_deviation" name="reflectance">
                <vector name="direction" x="0" y="0" z="0"/>
            </texture>"#,
            "\"direction\"",
        ),
    ];
    for (i, (texture, what)) in cases.into_iter().enumerate() {
        let err = load(&format!("bad{i}"), texture).unwrap_err();
        assert!(err.contains("scene.xml:") && err.contains(what), "{err}");
    }
}
