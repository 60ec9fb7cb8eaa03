//! An `area` emitter with a textured `radiance`: light sampling and BSDF
//! sampling see the same texture (the direct integrator with only one of
//! them gives the same image), a texture of one colour renders exactly as
//! that constant, and `mesh_attribute` as a radiance is a load error.

use std::path::Path;
use yubin_core::render::{render, RenderSettings};
use yubin_scene::load_scene_str;

/// A diffuse floor lit by a checkered rectangle light facing down, seen
/// from above at an angle; `integrator` and `radiance` are XML.
fn scene(integrator: &str, radiance: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
    {integrator}
    <sensor type="perspective">
        <float name="fov" value="50"/>
        <transform name="to_world"><lookat origin="0, 2.5, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
    </sensor>
    <shape type="rectangle">
        <transform name="to_world"><rotate x="1" angle="-90"/><scale value="2"/></transform>
        <bsdf type="diffuse"/>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><rotate x="1" angle="90"/><translate y="1"/></transform>
        <emitter type="area">
            {radiance}
        </emitter>
    </shape>
</scene>"#
    )
}

const CHECKER: &str = r#"<texture type="checkerboard" name="radiance">
                <rgb name="color0" value="0.2, 0.5, 1"/>
                <rgb name="color1" value="6, 3, 0.5"/>
                <transform name="to_uv"><scale x="2" y="3"/></transform>
            </texture>"#;

fn render_xml(xml: &str, spp: u32) -> Vec<f32> {
    let loaded = load_scene_str(xml, Path::new("scene.xml"), &[]).unwrap();
    render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &RenderSettings { spp, seed: 7 },
        &|_| {},
    )
    .image
    .data
}

/// Mean of each colour channel.
fn channel_means(img: &[f32]) -> [f64; 3] {
    let mut m = [0.0; 3];
    for px in img.chunks_exact(3) {
        for c in 0..3 {
            m[c] += f64::from(px[c]);
        }
    }
    m.map(|v| v / (img.len() / 3) as f64)
}

#[test]
fn light_and_bsdf_sampling_agree_on_a_textured_light() {
    let direct = |e: u32, b: u32| {
        format!(
            r#"<integrator type="direct"><integer name="emitter_samples" value="{e}"/><integer name="bsdf_samples" value="{b}"/></integrator>"#
        )
    };
    let nee = channel_means(&render_xml(&scene(&direct(1, 0), CHECKER), 256));
    let bsdf = channel_means(&render_xml(&scene(&direct(0, 1), CHECKER), 1024));
    for c in 0..3 {
        assert!(
            (nee[c] - bsdf[c]).abs() < 0.03 * bsdf[c],
            "channel {c}: light sampling {nee:?}, BSDF sampling {bsdf:?}"
        );
    }
    // The two colours reach the floor in the texture's proportions: the
    // blue of color0 and the red of color1 both show.
    assert!(nee[0] > 0.05 && nee[2] > 0.01, "{nee:?}");
}

#[test]
fn a_texture_of_one_colour_is_that_constant() {
    let flat = r#"<texture type="checkerboard" name="radiance">
                <rgb name="color0" value="2, 3, 4"/>
                <rgb name="color1" value="2, 3, 4"/>
            </texture>"#;
    let constant = r#"<rgb name="radiance" value="2, 3, 4"/>"#;
    let path = r#"<integrator type="path"/>"#;
    assert_eq!(
        render_xml(&scene(path, flat), 4),
        render_xml(&scene(path, constant), 4)
    );
}

#[test]
fn mesh_attribute_radiance_is_an_error() {
    let radiance = r#"<texture type="mesh_attribute" name="radiance">
                <string name="name" value="vertex_color"/>
            </texture>"#;
    let xml = scene("", radiance);
    let line = xml
        .lines()
        .position(|l| l.contains("mesh_attribute"))
        .unwrap()
        + 1;
    let err = load_scene_str(&xml, Path::new("scene.xml"), &[])
        .unwrap_err()
        .to_string();
    assert!(err.contains(&format!("scene.xml:{line}:")), "{err}");
    assert!(err.contains("mesh_attribute"), "{err}");
}
