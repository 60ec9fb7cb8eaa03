//! Bad environment maps: an image that is not latitude–longitude is a load
//! error at the `filename` line; negative and NaN texels read as 0, with a
//! warning that counts them.

use yubin_scene::image_io::{write_image, Image};
use yubin_scene::load_scene_str;

fn scene_with_map(
    dir: &std::path::Path,
    w: usize,
    h: usize,
    texel: impl Fn(usize) -> f32,
) -> String {
    let data: Vec<f32> = (0..w * h * 3).map(texel).collect();
    let img = Image {
        width: w,
        height: h,
        channels: 3,
        data,
    };
    write_image(&dir.join("map.exr"), &img, &[]).unwrap();
    r#"<scene version="3.0.0">
    <emitter type="envmap">
        <string name="filename" value="map.exr"/>
    </emitter>
</scene>"#
        .to_string()
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("yubin-envmap-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn an_envmap_that_is_not_lat_long_is_an_error_at_its_filename() {
    let dir = temp_dir("aspect");
    let xml = scene_with_map(&dir, 16, 16, |_| 1.0);
    let err = load_scene_str(&xml, &dir.join("scene.xml"), &[])
        .unwrap_err()
        .to_string();
    assert!(err.contains("scene.xml:3:"), "{err}");
    assert!(
        err.contains("16×16") && err.contains("twice as wide"),
        "{err}"
    );
    // The same map at 2:1 loads.
    let xml = scene_with_map(&dir, 16, 8, |_| 1.0);
    assert!(load_scene_str(&xml, &dir.join("scene.xml"), &[]).is_ok());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn negative_and_nan_texels_read_as_zero_with_a_warning() {
    let dir = temp_dir("nan");
    let xml = scene_with_map(&dir, 8, 4, |i| match i {
        5 => f32::NAN,
        17 => -3.0,
        40 => f32::INFINITY,
        _ => 1.0,
    });
    let loaded = load_scene_str(&xml, &dir.join("scene.xml"), &[]).unwrap();
    assert!(
        loaded
            .warnings
            .iter()
            .any(|w| w.contains("scene.xml:3:") && w.contains("3 texel values")),
        "{:?}",
        loaded.warnings
    );
    let img = &loaded.scene.materials.images[0];
    for y in 0..img.height {
        for x in 0..img.width {
            let t = img.texel(x, y, false);
            assert!(t.is_finite() && t.min_element() >= 0.0, "({x}, {y}): {t}");
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}
