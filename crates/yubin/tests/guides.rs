//! `--aov albedo,normal,depth`: denoiser guide layers in the EXR, read
//! back by name with the `exr` crate. Behind a glass ball the albedo is the
//! red wall seen through it (OIDN follows specular chains); normals are
//! unit world-space vectors (the wall's faces the camera); depth is the
//! distance to the first hit (the ball's front, not the wall).

use std::collections::HashMap;
use std::process::Command;

const SCENE: &str = r#"<scene version="3.0.0">
<sensor type="perspective"><float name="fov" value="30"/>
  <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
  <film type="hdrfilm"><integer name="width" value="33"/><integer name="height" value="33"/><rfilter type="box"/></film>
</sensor>
<emitter type="constant"/>
<shape type="sphere"><float name="radius" value="0.8"/><bsdf type="dielectric"/></shape>
<shape type="rectangle"><transform name="to_world"><scale value="5"/><translate z="-2"/></transform>
  <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.1, 0.1"/></bsdf></shape>
</scene>"#;

#[test]
fn guides_follow_specular_chains_and_read_back_by_name() {
    let d = std::env::temp_dir().join(format!("yubin-guides-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(d.join("s.xml"), SCENE).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_yubin"))
        .current_dir(&d)
        .args([
            "render",
            "s.xml",
            "--spp",
            "64",
            "--aov",
            "albedo,normal,depth",
        ])
        .args(["-o", "g.exr", "--quiet"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let image = exr::prelude::read_all_flat_layers_from_file(d.join("g.exr")).unwrap();
    let layer = &image.layer_data[0];
    let width = layer.size.0;
    let channels: HashMap<String, Vec<f32>> = layer
        .channel_data
        .list
        .iter()
        .map(|c| {
            let values = (0..c.sample_data.len())
                .map(|i| c.sample_data.value_by_flat_index(i).to_f32())
                .collect();
            (c.name.to_string(), values)
        })
        .collect();
    for name in [
        "R", "G", "B", "albedo.R", "albedo.G", "albedo.B", "normal.X", "normal.Y", "normal.Z",
        "depth.Z",
    ] {
        assert!(
            channels.contains_key(name),
            "no channel {name}: {:?}",
            channels.keys()
        );
    }
    let at = |name: &str, x: usize, y: usize| channels[name][y * width + x];
    // The ball's centre: albedo of the red wall behind the glass, depth
    // of the ball's front (5 − 0.8), normal of the wall (towards the
    // camera, +z).
    let (cx, cy) = (16, 16);
    let (r, g) = (at("albedo.R", cx, cy), at("albedo.G", cx, cy));
    assert!(r > 0.5 && r > 5.0 * g, "albedo behind the glass: {r}, {g}");
    assert!(
        (at("depth.Z", cx, cy) - 4.2).abs() < 0.01,
        "depth {}",
        at("depth.Z", cx, cy)
    );
    let n = glam::Vec3::new(
        at("normal.X", cx, cy),
        at("normal.Y", cx, cy),
        at("normal.Z", cx, cy),
    );
    assert!((n.length() - 1.0).abs() < 1e-3 && n.z > 0.99, "normal {n}");
    // A corner sees the wall directly: its albedo and normal, depth 7.
    let n = glam::Vec3::new(
        at("normal.X", 1, 1),
        at("normal.Y", 1, 1),
        at("normal.Z", 1, 1),
    );
    assert!((n - glam::Vec3::Z).length() < 1e-3, "wall normal {n}");
    assert!((at("albedo.R", 1, 1) - 0.8).abs() < 1e-4);
    assert!(at("depth.Z", 1, 1) > 7.0);
    std::fs::remove_dir_all(&d).ok();
}
