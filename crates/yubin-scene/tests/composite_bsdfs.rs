//! Composite BSDFs nest as far as the BSDF at a vertex holds, and a scene
//! that nests them further is refused at load, with the file and line of
//! the composite that does.

use std::path::Path;
use yubin_scene::load_scene_str;

/// A sphere whose BSDF blends a diffuse into `depth` nested `blendbsdf`s.
fn nested_blends(depth: usize) -> String {
    let mut bsdf = r#"<bsdf type="diffuse"/>"#.to_string();
    for _ in 0..depth {
        bsdf = format!(
            "<bsdf type=\"blendbsdf\">\n<float name=\"weight\" value=\"0.5\"/>\n\
             <bsdf type=\"diffuse\"/>\n{bsdf}\n</bsdf>"
        );
    }
    format!("<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n{bsdf}\n</shape>\n</scene>")
}

#[test]
fn blends_nest_as_far_as_the_bsdf_holds() {
    let max = yubin_core::bsdf::MAX_LOBES - 1;
    let text = nested_blends(max);
    let loaded = load_scene_str(&text, Path::new("scene.xml"), &[]);
    assert!(loaded.is_ok(), "{}", loaded.err().unwrap());
}

#[test]
fn blends_nested_further_are_refused_with_their_line() {
    let depth = yubin_core::bsdf::MAX_LOBES;
    let text = nested_blends(depth);
    let Err(err) = load_scene_str(&text, Path::new("scene.xml"), &[]) else {
        panic!("too deep a composite must not load");
    };
    let err = err.to_string();
    // The outermost blend (line 3) is the first too large.
    assert!(
        err.contains("scene.xml:3") && err.contains("single models"),
        "{err}"
    );
}
