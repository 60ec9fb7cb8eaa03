//! `scenes/preetham-day.xml` end to end: the `preetham` emitter loads from
//! XML with `$time`, lights the scene by day (finite, not black), leaves it
//! dark at night, and an unknown parameter of the emitter is a load error.

use std::path::Path;
use yubin_core::render::{render, RenderSettings};
use yubin_scene::{load_scene, load_scene_str};

/// Mean R, G, B of the scene rendered at local time `time` (tiny, 4 spp).
fn mean_rgb(time: &str) -> [f32; 3] {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/preetham-day.xml");
    let defines = [
        ("time".to_string(), time.to_string()),
        ("resx".to_string(), "24".to_string()),
        ("resy".to_string(), "16".to_string()),
    ];
    let loaded = load_scene(&path, &defines).unwrap_or_else(|e| panic!("{e}"));
    let out = render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &RenderSettings { spp: 4, seed: 1 },
        &|_| {},
    );
    let data = &out.image.data;
    assert!(data.iter().all(|v| v.is_finite()), "time {time}");
    let channels = out.image.channels;
    assert!(channels >= 3);
    let pixels = (data.len() / channels) as f32;
    let mut mean = [0.0; 3];
    for px in data.chunks_exact(channels) {
        for c in 0..3 {
            mean[c] += px[c] / pixels;
        }
    }
    mean
}

#[test]
fn preetham_day_scene_renders_day_and_night() {
    let noon = mean_rgb("13");
    let morning = mean_rgb("6.5");
    let night = mean_rgb("1");
    assert!(noon[1] > 0.1, "noon {noon:?}");
    assert!(noon[1] > morning[1], "noon {noon:?}, morning {morning:?}");
    // A low sun is redder than a high one.
    assert!(
        morning[0] / morning[2] > noon[0] / noon[2],
        "noon {noon:?}, morning {morning:?}"
    );
    assert_eq!(night, [0.0; 3]);
}

#[test]
fn preetham_unknown_parameter_is_a_load_error() {
    let xml = r#"<scene version="3.0.0">
    <emitter type="preetham">
        <float name="turbidty" value="3"/>
    </emitter>
</scene>"#;
    let dir = std::env::temp_dir().join(format!("yubin-preetham-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let Err(err) = load_scene_str(xml, &dir.join("scene.xml"), &[]) else {
        panic!("an unknown parameter must fail");
    };
    let err = err.to_string();
    assert!(err.contains("turbidty"), "{err}");
}
