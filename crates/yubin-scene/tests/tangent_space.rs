//! `normalmap`'s `tangent_space` end to end: MikkTSpace tangents computed
//! for a mesh at load agree with ∂p/∂u where the uv mapping is uniform,
//! follow the bitangent sign where it is mirrored, and a mesh without uvs
//! is a load error.

use std::path::PathBuf;
use yubin_core::render::{render, RenderSettings};
use yubin_scene::load_scene_str;

/// A unit quad facing +z, with texture coordinates when `uvs`.
fn quad_obj(uvs: bool) -> String {
    let mut obj = String::from("v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n");
    if uvs {
        obj += "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
    } else {
        obj += "f 1 2 3\nf 1 3 4\n";
    }
    obj
}

/// Writes `quad.obj` into a fresh temp directory; returns the scene path.
fn setup(name: &str, uvs: bool) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("yubin-tangent-space-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("quad.obj"), quad_obj(uvs)).unwrap();
    dir.join("scene.xml")
}

/// An 8×8 render of the quad under a tilted normal map, lit from the side.
fn render_quad(name: &str, space: &str, flip_tex_coords: bool) -> Result<Vec<f32>, String> {
    let path = setup(name, true);
    let xml = format!(
        r#"<scene version="3.0.0">
    <integrator type="direct"/>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
    </sensor>
    <emitter type="directional">
        <vector name="direction" value="-0.3, 1, -1"/>
    </emitter>
    <shape type="obj">
        <string name="filename" value="quad.obj"/>
        <boolean name="flip_tex_coords" value="{flip_tex_coords}"/>
        <bsdf type="normalmap">
            <string name="tangent_space" value="{space}"/>
            <rgb name="normalmap" value="0.5, 0.15, 0.85"/>
            <bsdf type="diffuse"/>
        </bsdf>
    </shape>
</scene>"#
    );
    let loaded = load_scene_str(&xml, &path, &[]).map_err(|e| e.to_string())?;
    let out = render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &RenderSettings { spp: 4, seed: 1 },
        &|_| {},
    );
    Ok(out.image.data)
}

fn max_difference(a: &[f32], b: &[f32]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

#[test]
fn uniform_uvs_give_the_dpdu_frame() {
    let dpdu = render_quad("uniform-dpdu", "dpdu", false).unwrap();
    let mikk = render_quad("uniform-mikk", "mikktspace", false).unwrap();
    assert!(dpdu.iter().any(|&v| v > 0.05), "the quad is lit");
    assert!(max_difference(&dpdu, &mikk) < 1e-4);
}

#[test]
fn mirrored_uvs_flip_the_bitangent() {
    // OBJ's v flip makes ∂p/∂v point down: MikkTSpace's bitangent follows
    // it (sign −1), the ∂p/∂u frame's does not, and the map tilts the
    // normal along y: towards the light (from −y) in the ∂p/∂u frame, away
    // from it in MikkTSpace.
    let dpdu = render_quad("mirrored-dpdu", "dpdu", true).unwrap();
    let mikk = render_quad("mirrored-mikk", "mikktspace", true).unwrap();
    let sum = |v: &[f32]| v.iter().sum::<f32>();
    assert!(
        sum(&dpdu) > 2.0 * sum(&mikk),
        "{} vs {}",
        sum(&dpdu),
        sum(&mikk)
    );
}

#[test]
fn mikktspace_on_a_mesh_without_uvs_is_an_error() {
    let path = setup("no-uvs", false);
    let xml = r#"<scene version="3.0.0">
    <shape type="obj">
        <string name="filename" value="quad.obj"/>
        <bsdf type="normalmap">
            <string name="tangent_space" value="mikktspace"/>
            <rgb name="normalmap" value="0.5, 0.5, 1"/>
            <bsdf type="diffuse"/>
        </bsdf>
    </shape>
</scene>"#;
    let err = load_scene_str(xml, &path, &[]).unwrap_err().to_string();
    assert!(err.contains("scene.xml:2"), "{err}");
    assert!(
        err.contains("no texture coordinates") && err.contains("MikkTSpace"),
        "{err}"
    );
}
